"""Geometry from other libraries: trimesh and pyvista objects as vertex and index arrays.

This module only converts; :func:`smoothdist.mesh.as_data_mesh` (also
``smoothdist.as_data_mesh``), the one door every mesh comes in through, builds the
:class:`~smoothdist.mesh.DataMesh` from what it returns. Nothing here imports
:mod:`smoothdist.mesh`. What each object becomes (:func:`foreign_arrays`):

============================== ==========================================================
object                         arrays
============================== ==========================================================
``trimesh.Trimesh``            its triangles
``trimesh.PointCloud``         its vertices as points
``trimesh.path.Path3D``        its polylines as edges (curved entities are discretised)
``trimesh.Scene``              its geometries, concatenated (one mixed mesh)
``pyvista.PolyData``           its faces (polygons fanned into triangles), lines (polylines
                               split into edges) and vertex cells (points); all of them, so
                               a PolyData with several kinds gives a mixed mesh. A PolyData
                               without cells is a point cloud of its points.
``pyvista.UnstructuredGrid``   its surface (``extract_surface``)
============================== ==========================================================

trimesh and pyvista are never imported here: objects are recognised by the module their
class comes from, so that plain numpy users do not pay for importing them.
"""

import numpy as np

__all__ = ["is_foreign_geometry", "foreign_arrays", "trimesh_arrays", "pyvista_arrays"]


def _module_of(obj):
    return type(obj).__module__.split(".")[0]


def is_foreign_geometry(obj):
    """True for a trimesh or pyvista object that :func:`foreign_arrays` converts.

    Arrays are never foreign geometry: numpy subclasses that these libraries hand out
    (``trimesh.caching.TrackedArray``, ``pyvista.pyvista_ndarray``) and array-likes such as
    lists are vertex or index arrays."""
    if isinstance(obj, (np.ndarray, list, tuple)):
        return False
    return _module_of(obj) in ("trimesh", "pyvista", "vtkmodules")


def foreign_arrays(obj, name):
    """``(V, points, edges, triangles)`` of a trimesh or pyvista object (None for absent
    kinds; ``obj`` must satisfy :func:`is_foreign_geometry`)."""
    if _module_of(obj) == "trimesh":
        return trimesh_arrays(obj, name)
    return pyvista_arrays(obj, name)


# ---------------------------------------------------------------------- trimesh
def trimesh_arrays(obj, name):
    """``(V, points, edges, triangles)`` of a trimesh object (None for absent kinds)."""
    cls = type(obj).__name__
    if cls == "Scene":
        geoms = list(obj.geometry.values())
        if not geoms:
            raise ValueError(f"{name}: the trimesh.Scene holds no geometry")
        parts = [trimesh_arrays(g, name) for g in obj.dump()] if hasattr(obj, "dump") else \
            [trimesh_arrays(g, name) for g in geoms]
        return _concatenate(parts)
    V = np.asarray(getattr(obj, "vertices", np.zeros((0, 3))), dtype=np.float64)
    if cls == "PointCloud":
        return V, np.arange(V.shape[0]), None, None
    if hasattr(obj, "faces") and cls != "Path3D":
        T = np.asarray(obj.faces, dtype=np.int64).reshape(-1, 3)
        if T.shape[0] == 0:
            return V, np.arange(V.shape[0]), None, None
        return V, None, None, T
    if hasattr(obj, "entities"):
        return _from_path(obj, V, name)
    raise ValueError(f"{name}: cannot use a trimesh {cls}; give a Trimesh, PointCloud, "
                     "Path3D or Scene")


def _from_path(path, V, name):
    """Edges of a trimesh ``Path3D``: lines by index, other entities discretised."""
    if V.ndim != 2 or V.shape[1] != 3:
        raise ValueError(f"{name}: a trimesh path must be 3D (Path3D), got vertices of shape "
                         f"{V.shape}")
    verts = [V]
    edges = []
    count = V.shape[0]
    for ent in path.entities:
        if type(ent).__name__ == "Line":
            idx = np.asarray(ent.points, dtype=np.int64)
        else:
            pts = np.asarray(ent.discrete(V), dtype=np.float64).reshape(-1, 3)
            idx = np.arange(count, count + pts.shape[0])
            verts.append(pts)
            count += pts.shape[0]
        if idx.size >= 2:
            edges.append(np.stack([idx[:-1], idx[1:]], axis=1))
    if not edges:
        raise ValueError(f"{name}: the path has no line segments")
    return np.concatenate(verts), None, np.concatenate(edges), None


# ---------------------------------------------------------------------- pyvista
def _cells(conn, name, what):
    """Split a VTK cell connectivity array ``[n, i0, ..., n, ...]`` into index lists."""
    conn = np.asarray(conn, dtype=np.int64).ravel()
    out = []
    i = 0
    while i < conn.size:
        n = int(conn[i])
        if n < 0 or i + 1 + n > conn.size:
            raise ValueError(f"{name}: malformed pyvista {what} array at offset {i}")
        out.append(conn[i + 1:i + 1 + n])
        i += 1 + n
    return out


def pyvista_arrays(obj, name):
    """``(V, points, edges, triangles)`` of a pyvista object (None for absent kinds)."""
    cls = type(obj).__name__
    if cls != "PolyData" and hasattr(obj, "extract_surface"):
        obj = obj.extract_surface()
        cls = type(obj).__name__
    if cls != "PolyData":
        raise ValueError(f"{name}: cannot use a pyvista {cls}; give a PolyData")
    V = np.asarray(obj.points, dtype=np.float64).reshape(-1, 3)
    P, E, T = [], [], []
    for cell in _cells(obj.verts, name, "verts"):
        P.extend(cell.tolist())
    for cell in _cells(obj.lines, name, "lines"):
        if cell.size >= 2:
            E.append(np.stack([cell[:-1], cell[1:]], axis=1))
    for cell in _cells(obj.faces, name, "faces"):
        if cell.size >= 3:
            T.append(np.stack([np.full(cell.size - 2, cell[0]), cell[1:-1], cell[2:]], axis=1))
    strips = getattr(obj, "strips", None)
    for cell in _cells(strips if strips is not None else [], name, "strips"):
        for j in range(cell.size - 2):
            a, b, c = cell[j:j + 3]
            T.append(np.array([[a, b, c] if j % 2 == 0 else [b, a, c]]))
    if not (P or E or T):
        return V, np.arange(V.shape[0]), None, None
    return (V, np.asarray(P, dtype=np.int64) if P else None,
            np.concatenate(E) if E else None, np.concatenate(T) if T else None)


def _concatenate(parts):
    V, P, E, T = [], [], [], []
    off = 0
    for v, p, e, t in parts:
        V.append(v)
        if p is not None:
            P.append(np.asarray(p) + off)
        if e is not None:
            E.append(np.asarray(e) + off)
        if t is not None:
            T.append(np.asarray(t) + off)
        off += v.shape[0]
    return (np.concatenate(V), np.concatenate(P) if P else None,
            np.concatenate(E) if E else None, np.concatenate(T) if T else None)
