"""Data meshes: points, edges, triangles, or any mix of them over one vertex array.

A :class:`DataMesh` holds ``V (n, 3) float64`` and three index arrays: ``points (p,)``,
``edges (e, 2)`` and ``triangles (t, 3)`` (int64). It validates and repairs its input, computes
the valences and the per-primitive weight polynomials of Madan & Levin 2022 (Sec. 3.3, App. C),
and loads OBJ (``f`` and ``l`` records), OFF, STL and PLY files.

:func:`as_data_mesh` is the one door for every mesh: a DataMesh, ``(V, F)`` arrays, or trimesh /
pyvista objects (converted to arrays by :mod:`smoothdist.convert`, which imports nothing from
here).
"""

import logging
import os
import re
import warnings
from typing import NamedTuple

import numpy as np

from smoothdist._cast import COORD_LIMIT, as_indices, as_points, non_finite_rows
from smoothdist._kernels import weights as _weights
from smoothdist.connectivity import (first_of_each, has_equal_rows, row_counts,
                                     triangle_half_edges, unique_edges, unique_sorted_rows)
from smoothdist.convert import foreign_arrays, is_foreign_geometry, trimesh_arrays

KIND_POINT, KIND_EDGE, KIND_TRIANGLE = 0, 1, 2
_KIND_NAMES = {"points": KIND_POINT, "edges": KIND_EDGE, "triangles": KIND_TRIANGLE}


class MeshRepairWarning(UserWarning):
    """Emitted when input geometry is repaired (duplicates merged, degenerate primitives
    dropped)."""


class DataMesh:
    """A co-dimensional data mesh: any combination of points, edges and triangles.

    Parameters
    ----------
    V : (n, 3) array_like of float
        Vertex positions. Must be finite.
    F : (m, k) array_like of int, optional
        ``None`` makes every vertex a point; ``k = 1`` points, ``k = 2`` edges, ``k = 3``
        triangles. Ignored when any of ``points``, ``edges``, ``triangles`` is given.
    points, edges, triangles : array_like of int, optional
        Index arrays for a *mixed* mesh: ``(p,)``, ``(e, 2)``, ``(t, 3)``.
    repair : bool
        Merge exactly duplicated vertices, drop zero-length edges, zero-area and duplicate
        triangles, with a :class:`MeshRepairWarning`. With ``False`` such input raises.
    name : str, optional
        A label used in messages (file name when loaded).

    Examples
    --------
    >>> import numpy as np
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]])
    >>> DataMesh(V, [[0, 1, 2]]).num_primitives
    1
    """

    def __init__(self, V, F=None, *, points=None, edges=None, triangles=None, repair=True,
                 name=None, _quiet_duplicates=False):
        self.name = name or "mesh"
        try:
            V = as_points(V, "V")
        except ValueError as exc:
            raise ValueError(f"{self.name}: {exc}") from None
        if V.shape[0] == 0:
            raise ValueError(f"{self.name}: the mesh has no vertices")
        n = V.shape[0]
        if points is None and edges is None and triangles is None:
            if F is None:
                points = np.arange(n)
            else:
                Fa = np.asarray(F)
                if Fa.ndim == 1 and Fa.size == 0:
                    Fa = Fa.reshape(0, 3)
                if Fa.ndim != 2 or Fa.shape[1] not in (1, 2, 3):
                    raise ValueError(f"{self.name}: F must have shape (m, 1), (m, 2) or (m, 3), "
                                     f"got {Fa.shape}")
                k = Fa.shape[1]
                if Fa.shape[0] == 0:
                    raise ValueError(f"{self.name}: F has no rows (an empty mesh)")
                points, edges, triangles = [(Fa, None, None), (None, Fa, None),
                                            (None, None, Fa)][k - 1]
        try:
            P = as_indices(points if points is not None else [], n, 1, "points").ravel()
            E = as_indices(edges if edges is not None else [], n, 2, "edges")
            T = as_indices(triangles if triangles is not None else [], n, 3, "triangles")
        except ValueError as exc:
            raise ValueError(f"{self.name}: {exc}") from None
        if P.size + E.shape[0] + T.shape[0] == 0:
            raise ValueError(f"{self.name}: the mesh has no primitives")
        V, P, E, T = _repair(V, P, E, T, repair, self.name, _quiet_duplicates)
        self.V, self.points, self.edges, self.triangles = V, P, E, T
        self._weights = None

    # ------------------------------------------------------------------ construction helpers
    @classmethod
    def load(cls, path, kind=None, repair=True):
        """Load a mesh file (OBJ, OFF, STL, PLY) and optionally reduce it to one primitive kind.

        Parameters
        ----------
        path : str or os.PathLike
            The file. OBJ ``l`` records and 2-vertex ``f`` records become edges, other ``f``
            records triangles (polygons are fanned); a file without faces or lines is a point
            cloud.
        kind : {None, "points", "edges", "triangles"}
            ``None`` keeps everything the file holds (possibly mixed). ``"points"`` keeps the
            vertices, ``"edges"`` the unique edges of triangles plus the file's own edges,
            ``"triangles"`` requires triangles.
        """
        V, E, T, is_stl = read_mesh_file(path)
        name = os.path.basename(os.fspath(path))
        mesh = cls(V, points=np.arange(V.shape[0]) if (E.size == 0 and T.size == 0) else None,
                   edges=E if E.size else None, triangles=T if T.size else None,
                   repair=repair, name=name, _quiet_duplicates=is_stl)
        return mesh.as_kind(kind) if kind is not None else mesh

    def as_kind(self, kind):
        """Return this mesh as ``"points"``, ``"edges"``, ``"triangles"`` (the paper's V/E/F)."""
        if kind not in _KIND_NAMES and kind != "mixed":
            raise ValueError(f"kind must be one of points, edges, triangles; got {kind!r}")
        if kind == "mixed":
            return self
        if kind == "points":
            return DataMesh(self.V, points=self.used_indices(), name=self.name)
        if kind == "edges":
            E = self.distinct_edges()
            if E.shape[0] == 0:
                raise ValueError(f"{self.name}: has no edges or triangles to take edges from")
            return DataMesh(self.V, edges=E, name=self.name)
        if self.triangles.shape[0] == 0:
            raise ValueError(f"{self.name}: has no triangles (it holds "
                             f"{self.edges.shape[0]} edges and {self.points.size} points)")
        return DataMesh(self.V, triangles=self.triangles, name=self.name)

    # ------------------------------------------------------------------ properties
    @property
    def num_primitives(self):
        """Number of primitives (points + edges + triangles)."""
        return int(self.points.size + self.edges.shape[0] + self.triangles.shape[0])

    @property
    def kind(self):
        """``"points"``, ``"edges"``, ``"triangles"`` or ``"mixed"``."""
        present = [k for k, a in (("points", self.points), ("edges", self.edges),
                                  ("triangles", self.triangles)) if len(a)]
        return present[0] if len(present) == 1 else "mixed"

    def distinct_edges(self):
        """``(e, 2)`` int64: every undirected edge of the mesh's edges and triangles once,
        each row sorted, in lexicographic order."""
        n = self.V.shape[0]
        E = unique_edges(self.triangles, n)
        if self.edges.shape[0]:
            E = unique_sorted_rows(np.sort(np.concatenate([self.edges, E]), axis=1), n)
        return E

    def used_indices(self):
        """``(u,)`` int64 indices, ascending, of the vertices referenced by some primitive."""
        n = self.V.shape[0]
        hit = np.zeros(n, dtype=bool)
        for a in (self.points, self.edges, self.triangles):
            hit[a.ravel()] = True
        return np.flatnonzero(hit)

    def used_vertices(self):
        """``(u, 3)`` positions of the vertices referenced by some primitive."""
        return self.V[self.used_indices()]

    @property
    def bounds(self):
        """``(lo, hi)``: the bounding box of the referenced vertices, two (3,) float64 arrays."""
        U = self.used_vertices()
        return U.min(axis=0), U.max(axis=0)

    @property
    def diagonal(self):
        """Length of the bounding-box diagonal (scene units)."""
        lo, hi = self.bounds
        return float(np.linalg.norm(hi - lo))

    def min_edge_length(self):
        """Shortest edge of the edges and triangles, or ``None`` for a pure point cloud."""
        E = np.concatenate([self.edges, unique_edges(self.triangles, self.V.shape[0])])
        if E.shape[0] == 0:
            return None
        return float(np.linalg.norm(self.V[E[:, 1]] - self.V[E[:, 0]], axis=1).min())

    def __repr__(self):
        return (f"DataMesh({self.name!r}, {self.V.shape[0]} vertices, {self.points.size} points, "
                f"{self.edges.shape[0]} edges, {self.triangles.shape[0]} triangles)")

    # ------------------------------------------------------------------ weights
    def weight_data(self):
        """Per-primitive weight data (Madan & Levin 2022, Sec. 3.3 and App. C).

        Returns
        -------
        A : float
            The valence bound: the largest vertex valence (edges counted per edge mesh,
            triangles per triangle mesh), at least 1. ``A * w~ >= 1`` everywhere.
        edge_coeffs : (e, 5) float64
            Quartic coefficients of each edge's unscaled weight ``w~(t)``.
        edge_whi : (e,) float64
            Upper clamp of each edge's raw weight ``A w~``: its maximum over the edge (>= 1).
        tri_coeffs : (t, 13) float64
            Symmetric degree-7 coefficients of each triangle's ``w~(s, t)``.
        tri_whi : (t,) float64
            Upper clamp of each triangle's raw weight ``A w~`` (sampled maximum, >= 1).

        The arrays are expanded from :meth:`weight_classes` on each call (a few distinct
        polynomials serve every primitive; the mesh keeps only those).
        """
        w = self.weight_classes()
        return (w.A, w.edge_coeffs[w.edge_class], w.edge_whi[w.edge_class],
                w.tri_coeffs[w.tri_class], w.tri_whi[w.tri_class])

    def weight_classes(self):
        """The weight data of :meth:`weight_data`, compact: a ``WeightClasses`` whose
        few distinct polynomials (one per pair of valences) each primitive indexes. Computed
        once and kept."""
        if self._weights is None:
            self._weights = _weight_classes(self.V.shape[0], self.edges, self.triangles)
        return self._weights


class WeightClasses(NamedTuple):
    """Weight polynomials of a mesh's edges and triangles, one per class of valences.

    ``A`` the valence bound (float); ``edge_coeffs (ke, 5)`` and ``edge_whi (ke,)`` float64
    per edge class, ``edge_class (e,)`` int64 each edge's class; ``tri_coeffs (kt, 13)``,
    ``tri_whi (kt,)`` and ``tri_class (t,)`` the same for triangles (see
    :meth:`DataMesh.weight_data`).
    """

    A: float
    edge_coeffs: np.ndarray
    edge_whi: np.ndarray
    edge_class: np.ndarray
    tri_coeffs: np.ndarray
    tri_whi: np.ndarray
    tri_class: np.ndarray


# ---------------------------------------------------------------------- the one door
def as_data_mesh(mesh, F=None, *, name=None, **mesh_kwargs):
    """Return ``mesh`` (and ``F``) as a :class:`DataMesh`: the one door every mesh comes in
    through (:class:`~smoothdist.SmoothDistanceField`, the module-level functions, the
    tracer; also ``smoothdist.as_data_mesh``).

    ============================== ======================================================
    input                          becomes
    ============================== ======================================================
    ``DataMesh``                   itself
    ``V`` and ``F`` arrays         ``DataMesh(V, F)`` (``F`` None, ``(m, 2)`` or
                                   ``(m, 3)``), also as one ``(V, F)`` tuple; array
                                   subclasses and lists are arrays
    a trimesh or pyvista object    its geometry, converted by
                                   :func:`smoothdist.convert.foreign_arrays` (see
                                   :mod:`smoothdist.convert` for what each becomes)
    ============================== ======================================================

    Parameters
    ----------
    mesh : DataMesh, (n, 3) array_like, or a trimesh / pyvista object
        See the table above.
    F : None, (m, 2) or (m, 3) array_like of int
        Primitives when ``mesh`` is a vertex array; must be None otherwise.
    name : str, optional
        Label used in messages (default: the object's class name).
    **mesh_kwargs
        Passed to :class:`DataMesh` (e.g. ``repair=False``).

    Raises
    ------
    ValueError
        For an object that holds no usable geometry, ``F`` given with an object, or input
        :class:`DataMesh` rejects (NaN vertices, bad indices, ...).
    """
    if isinstance(mesh, DataMesh):
        if F is not None:
            raise ValueError("pass F only together with a vertex array, not with a DataMesh")
        return mesh
    if (F is None and isinstance(mesh, tuple) and len(mesh) == 2
            and np.ndim(mesh[0]) == 2 and (mesh[1] is None or np.ndim(mesh[1]) == 2)):
        mesh, F = mesh  # a (V, F) pair
    if not is_foreign_geometry(mesh):
        return DataMesh(mesh, F, name=name, **mesh_kwargs)
    if F is not None:
        raise ValueError(f"pass F only together with a vertex array, not with a "
                         f"{type(mesh).__name__}")
    name = name or type(mesh).__name__
    V, P, E, T = foreign_arrays(mesh, name)
    return DataMesh(V, points=P, edges=E, triangles=T, name=name, **mesh_kwargs)


# ---------------------------------------------------------------------- helpers
def _weight_classes(n, E, T):
    """:class:`WeightClasses` of a mesh of ``n`` vertices with edges ``E`` and triangles
    ``T``: each primitive's class is its pair of valences (edges: the valences of its two
    ends; triangles: the largest vertex and edge valence), and the polynomial of each class is
    computed once."""
    A = 1
    ev = np.bincount(E.ravel(), minlength=n) if E.shape[0] else None
    if ev is not None:
        A = max(A, int(ev.max()))
    if T.shape[0]:
        tv = np.bincount(T.ravel(), minlength=n)
        A = max(A, int(tv.max()))
        ecount = row_counts(triangle_half_edges(T), n).reshape(3, -1).T  # (t, 3) edge valences
        vmax = tv[T].max(axis=1)
        emax = ecount.max(axis=1)
    A = float(A)
    edge_coeffs, edge_whi = np.zeros((0, 5)), np.ones(0)
    edge_class = np.zeros(E.shape[0], dtype=np.int64)
    if E.shape[0]:
        pairs, edge_class = _classes(ev[E[:, 0]], ev[E[:, 1]])
        edge_coeffs = np.array([_weights.edge_weight_coefficients(int(a), int(b))
                                for a, b in pairs]).reshape(-1, 5)
        edge_whi = np.array([max(1.0, A * _weights.edge_weight_max(c)) for c in edge_coeffs])
    tri_coeffs, tri_whi = np.zeros((0, 13)), np.ones(0)
    tri_class = np.zeros(T.shape[0], dtype=np.int64)
    if T.shape[0]:
        pairs, tri_class = _classes(vmax, emax)
        tri_coeffs = np.array([_weights.triangle_weight_coefficients(int(v), int(e))
                               for v, e in pairs]).reshape(-1, 13)
        tri_whi = np.array([max(1.0, A * _weights.triangle_weight_range(c)[1])
                            for c in tri_coeffs])
    return WeightClasses(A, edge_coeffs, edge_whi, edge_class, tri_coeffs, tri_whi, tri_class)


def _classes(a, b):
    """``(pairs (k, 2), inverse (r,))``: the distinct pairs ``(a[i], b[i])`` of two int64
    arrays of valences, sorted, and each row's index among them."""
    a = np.asarray(a, dtype=np.int64)
    b = np.asarray(b, dtype=np.int64)
    base = int(b.max()) + 1
    key = a * base + b
    top = int(key.max()) + 1
    if top > 4 * key.size + (1 << 16):    # valences far apart: sort them
        keys, inverse = np.unique(key, return_inverse=True)
        return np.stack([keys // base, keys % base], axis=1), inverse.ravel().astype(np.int64)
    # valences are small numbers: a table over every key, no sort
    present = np.zeros(top, dtype=bool)
    present[key] = True
    keys = np.flatnonzero(present)
    index = np.cumsum(present, dtype=np.int64) - 1
    return np.stack([keys // base, keys % base], axis=1), index[key]


def triangle_normals(V, T):
    """``(b - a) x (c - a)`` of every triangle ``abc`` of ``T (t, 3)`` over ``V (n, 3)``:
    ``(t, 3)`` float64, twice the area times the unit normal. The bits of ``np.cross`` of the
    gathered edges, at 0.4 of its time (its axis handling; 1M triangles: 0.17 s, not 0.44)."""
    a = V[T[:, 0]]
    u = V[T[:, 1]] - a
    v = V[T[:, 2]] - a
    c = np.empty_like(u)
    c[:, 0] = u[:, 1] * v[:, 2] - u[:, 2] * v[:, 1]
    c[:, 1] = u[:, 2] * v[:, 0] - u[:, 0] * v[:, 2]
    c[:, 2] = u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]
    return c


def _repair(V, P, E, T, repair, name, quiet_duplicates):
    """Merge duplicate vertices, drop degenerate and duplicate primitives (see DataMesh)."""
    notes = []
    # merge exactly duplicated vertices (a hash of the rows finds out cheaply whether there
    # are any)
    has_dups = has_equal_rows(V)
    if has_dups:
        Vu, inv = np.unique(V, axis=0, return_inverse=True)
        inv = inv.ravel()
    if has_dups and Vu.shape[0] < V.shape[0]:
        if not repair:
            raise ValueError(f"{name}: has {V.shape[0] - Vu.shape[0]} duplicated vertices")
        if not quiet_duplicates:
            notes.append(f"merged {V.shape[0] - Vu.shape[0]} duplicated vertices")
        V, P, E, T = Vu, inv[P], inv[E], inv[T]
    scale = float(np.linalg.norm(V.max(axis=0) - V.min(axis=0))) if V.shape[0] > 1 else 1.0
    scale = scale if scale > 0 else 1.0
    # points: duplicates would be counted twice (an increasing list, as every point cloud's
    # arange, has none and is its own np.unique)
    Pu = P if P.size < 2 or bool(np.all(P[1:] > P[:-1])) else np.unique(P)
    if Pu.size < P.size:
        notes.append(f"dropped {P.size - Pu.size} duplicated points")
        P = Pu
    # edges: zero-length and duplicates
    if E.shape[0]:
        length = np.linalg.norm(V[E[:, 1]] - V[E[:, 0]], axis=1)
        bad = length <= 1e-12 * scale
        if bad.any():
            if not repair:
                raise ValueError(f"{name}: has {int(bad.sum())} zero-length edges")
            notes.append(f"dropped {int(bad.sum())} zero-length edges")
            E = E[~bad]
        keep = first_of_each(np.sort(E, axis=1), V.shape[0])
        if keep.size < E.shape[0]:
            notes.append(f"dropped {E.shape[0] - keep.size} duplicated edges")
            E = E[keep]
    # triangles: zero-area and duplicates
    if T.shape[0]:
        area2 = np.linalg.norm(triangle_normals(V, T), axis=1)
        bad = area2 <= 1e-14 * scale * scale
        if bad.any():
            if not repair:
                raise ValueError(f"{name}: has {int(bad.sum())} zero-area triangles")
            notes.append(f"dropped {int(bad.sum())} zero-area triangles")
            T = T[~bad]
        keep = first_of_each(np.sort(T, axis=1), V.shape[0])
        if keep.size < T.shape[0]:
            notes.append(f"dropped {T.shape[0] - keep.size} duplicated triangles")
            T = T[keep]
    if P.size + E.shape[0] + T.shape[0] == 0:
        raise ValueError(f"{name}: no valid primitives left after removing degenerate ones")
    if notes:
        warnings.warn(f"{name}: " + "; ".join(notes), MeshRepairWarning, stacklevel=4)
    return (np.ascontiguousarray(V), np.ascontiguousarray(P, dtype=np.int64),
            np.ascontiguousarray(E, dtype=np.int64).reshape(-1, 2),
            np.ascontiguousarray(T, dtype=np.int64).reshape(-1, 3))


# ---------------------------------------------------------------------- file reading
#: File extensions :func:`read_mesh_file` reads: OBJ with our own reader (it keeps ``l``
#: records as edges), ASCII OFF with our own reader (no trimesh import: faster start-up), the
#: others (and binary OFF) with trimesh (a glTF scene's parts are concatenated); XYZ point
#: clouds with our own reader (columns separated by white space or commas).
MESH_EXTENSIONS = (".obj", ".off", ".stl", ".ply", ".glb", ".gltf", ".xyz")


def read_mesh_file(path):
    """Read ``(V, E, T, is_stl)`` from an OBJ, OFF, STL, PLY, glTF or XYZ file.

    Raises ``ValueError`` with a one-line message for a missing, unreadable, empty or
    malformed file.
    """
    path = os.fspath(path)
    if not os.path.exists(path):
        raise ValueError(f"mesh file not found: {path}")
    if os.path.isdir(path):
        raise ValueError(f"mesh path is a folder, not a file: {path}")
    if not os.path.isfile(path):
        raise ValueError(f"mesh path is not a regular file: {path}")
    ext = os.path.splitext(path)[1].lower()
    if ext not in MESH_EXTENSIONS:
        raise ValueError(f"unsupported mesh format {ext or '(none)'!r} for {path}: "
                         f"use {', '.join(MESH_EXTENSIONS[:-1])} or {MESH_EXTENSIONS[-1]}")
    try:
        if os.path.getsize(path) == 0:
            raise _MeshFileError(f"mesh file is empty: {path}")
        if ext == ".obj":
            V, E, T = _read_obj(path)
        elif ext == ".off" and _is_ascii_off(path):
            V, E, T = _read_off(path)
        elif ext == ".xyz":
            V, E, T = _read_xyz(path)
        else:
            V, E, T = _read_with_trimesh(path, ext)
    except _MeshFileError as exc:
        raise ValueError(str(exc)) from None
    except ImportError:
        raise
    except PermissionError:
        raise ValueError(f"mesh file is not readable (permission denied): {path}") from None
    except (MemoryError, RecursionError):
        raise ValueError(f"could not read mesh file {path}: it is too large or malformed") from None
    except Exception as exc:  # trimesh raises many kinds of errors (ValueError too) on garbage
        msg = str(exc).strip().splitlines()[0] if str(exc).strip() else "malformed file"
        raise ValueError(f"could not read mesh file {path}: {type(exc).__name__}: {msg}") from None
    if V.shape[0] == 0:
        raise ValueError(f"mesh file has no vertices: {path}")
    if not np.all(np.isfinite(V)):
        raise ValueError(f"mesh file has NaN or infinite vertex coordinates: {path}: "
                         f"{non_finite_rows(V, 'vertex', 'vertices')}, 0-based")
    if np.abs(V).max() > COORD_LIMIT:
        raise ValueError(f"mesh file has coordinates beyond +-{COORD_LIMIT:.0e}: {path} "
                         "(rescale or recentre the data)")
    return V, E, T, ext == ".stl"


def needs_trimesh(path):
    """Whether :func:`read_mesh_file` reads ``path`` with trimesh (STL, PLY, glTF, binary OFF),
    without reading more than an OFF file's first bytes. False for the formats our own readers
    handle and for a file it rejects before (missing, a folder, empty, unknown format)."""
    path = os.fspath(path)
    ext = os.path.splitext(path)[1].lower()
    if ext not in MESH_EXTENSIONS or ext in (".obj", ".xyz"):
        return False
    try:
        if not os.path.isfile(path) or os.path.getsize(path) == 0:
            return False
        return ext != ".off" or not _is_ascii_off(path)
    except OSError:  # unreadable: read_mesh_file says so
        return False


class _MeshFileError(Exception):
    """A malformed mesh file detected by our own readers (message ready for the user)."""


#: bytes sniffed at the start of an OBJ file to tell text from binary data
_SNIFF = 4096


def _read_obj(path):
    with open(path, "rb") as fh:
        head = fh.read(_SNIFF)
    if b"\0" in head:
        raise _MeshFileError(f"{path}: not a text OBJ file (it holds binary data)")
    verts, edges, tris = [], [], []
    with open(path, "r", encoding="utf-8", errors="replace") as fh:
        for lineno, line in enumerate(fh, 1):
            parts = line.split()
            if not parts:
                continue
            tag = parts[0]
            try:
                if tag == "v":
                    verts.append((float(parts[1]), float(parts[2]), float(parts[3])))
                elif tag in ("f", "l"):
                    idx = [int(p.split("/")[0]) for p in parts[1:]]
                    if 0 in idx:
                        raise ValueError("OBJ vertex indices start at 1, not 0")
                    nv = len(verts)
                    idx = [i - 1 if i > 0 else nv + i for i in idx]
                    if len(idx) < 2:
                        raise ValueError(f"{'a line' if tag == 'l' else 'a face'} needs at "
                                         "least 2 vertices")
                    if tag == "l" or len(idx) == 2:   # a 2-vertex face is an edge (libigl's
                        edges.extend(zip(idx[:-1], idx[1:]))   # and the authors' convention)
                    else:
                        tris.extend((idx[0], idx[j], idx[j + 1]) for j in range(1, len(idx) - 1))
            except (ValueError, IndexError) as exc:
                raise _MeshFileError(f"{path}:{lineno}: malformed OBJ record "
                                     f"{line.strip()[:60]!r} ({exc})") from None
    V = np.array(verts, dtype=np.float64).reshape(-1, 3)
    return (V, np.array(edges, dtype=np.int64).reshape(-1, 2),
            np.array(tris, dtype=np.int64).reshape(-1, 3))


def _is_ascii_off(path):
    with open(path, "rb") as fh:
        head = fh.read(_SNIFF)
    return b"\0" not in head and head.lstrip().upper().startswith(b"OFF") \
        and not head.lstrip()[3:4].isalpha()  # not COFF/NOFF/"OFF BINARY" variants


def _read_off(path):
    """ASCII OFF: ``OFF`` (counts may follow on the same line), ``nv nf ne``, one vertex per
    line, then one face per line ``k i0 ... ik-1 [colour]`` (fanned into triangles; ``k = 2``
    is an edge; trailing colour values are ignored). ``#`` comments are ignored."""
    with open(path, "r", encoding="utf-8", errors="replace") as fh:
        rows = [ln.split("#", 1)[0].split() for ln in fh]
    rows = [r for r in rows if r]
    if not rows or rows[0][0].upper() != "OFF":
        raise _MeshFileError(f"{path}: not an OFF file (no OFF header)")
    try:
        head = rows[0][1:] or rows[1]
        first = 1 if rows[0][1:] else 2
        nv, nf = int(head[0]), int(head[1])
        if nv < 0 or nf < 0:
            raise ValueError("negative counts")
        vrows = rows[first:first + nv]
        if len(vrows) != nv or any(len(r) < 3 for r in vrows):
            raise ValueError(f"{nv} vertices announced, {len(vrows)} complete ones found")
        V = np.array([r[:3] for r in vrows], dtype=np.float64).reshape(-1, 3)
        frows = rows[first + nv:first + nv + nf]
        if len(frows) != nf:
            raise ValueError(f"{nf} faces announced, {len(frows)} found")
        edges, tris = [], []
        for face, r in enumerate(frows):
            k = int(r[0])
            if k < 2 or len(r) < 1 + k:
                raise ValueError(f"face {face}: a face needs 2 or more vertex indices")
            idx = [int(x) for x in r[1:1 + k]]
            if k == 2:
                edges.append(idx)
            else:
                tris.extend((idx[0], idx[j], idx[j + 1]) for j in range(1, k - 1))
    except (ValueError, IndexError) as exc:
        raise _MeshFileError(f"{path}: malformed OFF file ({exc})") from None
    return (V, np.array(edges, dtype=np.int64).reshape(-1, 2),
            np.array(tris, dtype=np.int64).reshape(-1, 3))


#: separators of an XYZ row: white space and/or one comma (or semicolon)
_XYZ_SEP = re.compile(r"\s*[,;]\s*|\s+")


def _read_xyz(path):
    """XYZ point cloud: one point per line, ``x y z`` or ``x,y,z`` (white space, commas or
    semicolons between the columns; further columns, such as normals or colours, are
    ignored). ``#`` comments, blank lines and a non-numeric first line (a header such as
    ``x,y,z``) are skipped."""
    with open(path, "rb") as fh:
        head = fh.read(_SNIFF)
    if b"\0" in head:
        raise _MeshFileError(f"{path}: not a text XYZ file (it holds binary data)")
    verts = []
    header_allowed = True
    with open(path, "r", encoding="utf-8", errors="replace") as fh:
        for lineno, line in enumerate(fh, 1):
            text = line.split("#", 1)[0].strip()
            if not text:
                continue
            cols = [c for c in _XYZ_SEP.split(text) if c]
            try:
                if len(cols) < 3:
                    raise ValueError(f"{len(cols)} column(s), need x, y and z")
                verts.append((float(cols[0]), float(cols[1]), float(cols[2])))
            except ValueError as exc:
                if header_allowed and not any(_is_number(c) for c in cols):
                    header_allowed = False
                    continue
                raise _MeshFileError(f"{path}:{lineno}: malformed XYZ row "
                                     f"{text[:60]!r} ({exc})") from None
            header_allowed = False
    V = np.array(verts, dtype=np.float64).reshape(-1, 3)
    return V, np.zeros((0, 2), dtype=np.int64), np.zeros((0, 3), dtype=np.int64)


def _is_number(text):
    try:
        float(text)
    except ValueError:
        return False
    return True


def _read_with_trimesh(path, ext):
    try:
        import trimesh  # trimesh (tracer extra): loaded on use
    except ImportError:
        raise ImportError(f"reading {ext} files needs trimesh (pip install trimesh, or "
                          f"'smoothdist[tracer]'); OBJ and ASCII OFF files are read without "
                          f"it") from None

    # trimesh logs its own complaints about malformed files; we report them as one error
    log = logging.getLogger("trimesh")
    level = log.level
    log.setLevel(logging.CRITICAL)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            loaded = trimesh.load(path, process=False, force=None)
    finally:
        log.setLevel(level)
    if isinstance(loaded, trimesh.Scene) and not loaded.geometry:
        raise _MeshFileError(f"mesh file holds no geometry: {path}")
    V, _, E, T = trimesh_arrays(loaded, os.path.basename(path))
    V = np.asarray(V, dtype=np.float64).reshape(-1, 3)
    E = np.zeros((0, 2), dtype=np.int64) if E is None else np.asarray(E, dtype=np.int64)
    T = np.zeros((0, 3), dtype=np.int64) if T is None else np.asarray(T, dtype=np.int64)
    return V, E, T
