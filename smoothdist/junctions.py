"""Inclusion-exclusion junction weights: the alternative to the paper's weight polynomials.

Why: the LogSumExp counts a junction once per primitive that meets there. Above an edge shared
by two coplanar triangles both are at the same distance, so the sum doubles and the surface
bulges by ``log 2 / alpha``; the paper's weight polynomials (Sec. 3.3, App. C) halve each
triangle's weight near the edge, but they vary over the triangle's size, while the doubling
fades within ``sqrt(2 d / alpha)`` of the edge. Between the two lengths the surface sinks by
up to ``log 2 / alpha``: a groove along every internal edge of a flat face (about a pixel
wide in the renderer's thin shell, where it shows as a dotted seam).

These weights subtract each junction as often as it was counted too often, by
inclusion-exclusion over the mesh's cells. For a triangle mesh the sum is

    sum_T exp(-alpha d_T) - sum_E (n_E - 1) exp(-alpha d_E) + sum_v c_v exp(-alpha d_v),

``n_E`` the triangles on edge ``E``, ``c_v = 1 - k_v + sum_{E at v} (n_E - 1)`` (``k_v`` the
triangles at ``v``: 1 at an interior vertex of a closed fan, 0 on a boundary). Whenever the
closest points of all the triangles at a junction lie on it (any query above a flat face, or
outside a convex edge or corner) the terms cancel to exactly one ``exp(-alpha d)``: the sum is
the exact distance's, with no groove, no bulge and no weight gradient. Inside a concave
crease both faces are nearer than their edge and the sum blends them (at most twice the
largest term), as the LogSumExp does. Each edge's and vertex's terms are shared out among the
triangles that meet there, so a triangle's term is its own distance's with the weight

    W_T = 1 - sum_{E of T} a_E exp(-alpha (d_E - d_T)) + sum_{v of T} b_v exp(-alpha (d_v - d_T)),

``a_E = (n_E - 1) / n_E``, ``b_v = c_v / k_v``; an edge mesh (a polyline) likewise has
``W_E = 1 - sum_{v of E} a_v exp(-alpha (d_v - d_E))``, ``a_v = (n_v - 1) / n_v``. Points share
no junctions; what a cloud counts twice is its clumps: a random sample's clump of ``n`` points
raises the surface by ``log(n) / alpha``. So a point's weight is the share of the sampled curve
or surface it stands for, from its nearest neighbours
(:func:`smoothdist._kernels.spacing.area_weights`, in ``pwhi``; a volume sample keeps 1).
The weight and its gradient are exact (``smoothdist._kernels.query.primitive_term``).

Limits: a term's weight can be negative (a sliver's corner), and seen from far away the sum
over a closed surface tends to its Euler characteristic times one term (0 for a torus) instead
of ``N`` terms. Where ``alpha`` times the edge length is small and the whole object is in
reach, the sum can therefore fall below one term; the kernels clamp it there to the nearest
primitive's (``d_hat <= d``, the conservative property, always holds). The renderer uses
these weights for its automatic thin shell and tubes (``alpha`` large against the edges);
the paper's weights stay the default of the library and of scene files.

Attenuation ``S`` (``alpha_u``) scales the junction terms: ``W = 1 + S (W_ie - 1)``, and a point's
area weight ``w`` to ``w ** S`` (a point cloud's automatic ``alpha_u`` is ``alpha``); the bound
``pwhi = exp(B)`` (``B`` the sum of a primitive's positive ``b_v``) keeps ``pwhi ** S >= W``
for every ``S`` in ``(0, 1]``, so the far fields stay upper bounds.
"""

from typing import NamedTuple

import numpy as np

from smoothdist.connectivity import key_counts, row_counts, triangle_half_edges

__all__ = ["WEIGHTS", "JUNCTION_COLUMNS", "JunctionWeights", "junction_weights",
           "junction_table", "check_weights"]

#: the weight schemes: the paper's polynomials, and inclusion-exclusion over the junctions
WEIGHTS = ("paper", "inclusion-exclusion")
#: columns of a junction row of ``TreeData.wc``: ``a_01 a_12 a_20 b_0 b_1 b_2`` (triangles) or
#: ``a_0 a_1`` (edges), zeros, and a last column of 1 that marks the row as a junction row (the
#: paper's rows have 13 columns)
JUNCTION_COLUMNS = 14


def check_weights(weights):
    """``weights`` as given, after checking it is one of :data:`WEIGHTS` (``ValueError``)."""
    if not isinstance(weights, str) or weights not in WEIGHTS:
        raise ValueError(f"weights must be one of {', '.join(map(repr, WEIGHTS))}, "
                         f"got {weights!r}")
    return weights


class JunctionWeights(NamedTuple):
    """Per-primitive junction coefficients of a mesh (module notes).

    ``edge (e, 2)`` float64: ``a_v`` of each edge's two ends (subtracted); ``tri (t, 6)``
    float64: ``a_01, a_12, a_20`` of each triangle's edges (subtracted) and ``b_0, b_1, b_2`` of
    its corners (added), in the order of the triangle's vertices.
    """

    edge: np.ndarray
    tri: np.ndarray


def junction_weights(mesh):
    """:class:`JunctionWeights` of a :class:`~smoothdist.DataMesh` (edges and triangles are
    separate meshes: an edge's ends count edges, a triangle's junctions count triangles)."""
    n = mesh.V.shape[0]
    E, T = mesh.edges, mesh.triangles
    edge = np.zeros((E.shape[0], 2))
    if E.shape[0]:
        nv = np.bincount(E.ravel(), minlength=n).astype(np.float64)
        edge = (nv[E] - 1.0) / nv[E]
    tri = np.zeros((T.shape[0], 6))
    if T.shape[0]:
        lo, hi, ne = _triangle_edges(T, n)                     # (01), (12), (20) of each
        share = (ne - 1.0) / ne                                # (3 t,) a_E of each
        tri[:, :3] = share.reshape(3, -1).T
        k = np.bincount(T.ravel(), minlength=n).astype(np.float64)
        # c_v = 1 - k_v + sum over the distinct edges at v of (n_E - 1): each triangle's edge
        # adds (n_E - 1) / n_E (its share of the edge) to both of its ends
        c = (1.0 - k + np.bincount(lo, weights=share, minlength=n)
             + np.bincount(hi, weights=share, minlength=n))
        with np.errstate(invalid="ignore", divide="ignore"):
            b = np.where(k > 0, c / k, 0.0)
        tri[:, 3:] = b[T]
    return JunctionWeights(edge, tri)


def _triangle_edges(T, n):
    """``(lo, hi, count)``, each ``(3 t,)``: the ends of every triangle's edges (01 of every
    triangle, then 12, then 20; ``lo < hi``) and how many triangles share each, from one int64
    key per edge (rows of :func:`~smoothdist.connectivity.triangle_half_edges` when ``n**2``
    does not fit)."""
    if n * n - 1 > np.iinfo(np.int64).max:
        half = triangle_half_edges(T)
        return half[:, 0], half[:, 1], row_counts(half, n).astype(np.float64)
    t = T.shape[0]
    lo = np.empty(3 * t, dtype=np.int64)
    hi = np.empty(3 * t, dtype=np.int64)
    for j, (a, b) in enumerate(((0, 1), (1, 2), (2, 0))):
        np.minimum(T[:, a], T[:, b], out=lo[j * t:(j + 1) * t])
        np.maximum(T[:, a], T[:, b], out=hi[j * t:(j + 1) * t])
    return lo, hi, key_counts(lo * n + hi).astype(np.float64)


def junction_table(mesh, kind, order):
    """``(wc, wcls, pwhi)`` of a tree with junction weights (``TreeData`` fields), for the
    primitives in tree order ``order (m,)`` (mesh numbering: points, edges, triangles) of kind
    ``kind (m,)`` (0, 1, 2).

    ``wc (k, JUNCTION_COLUMNS)``: the distinct coefficient rows (the points' row of zeros, then
    the edges', then the triangles'; each with the marker); ``wcls (m,)`` each primitive's row;
    ``pwhi (m,)`` the bound ``exp(sum of the positive b_v)`` (1 for points and edges).
    Memory: the coefficients in the mesh's order (16 bytes an edge, 48 a triangle) and a few
    ``(m,)`` arrays; the rows are made once per distinct class.
    """
    jw = junction_weights(mesh)
    p, e = mesh.points.size, mesh.edges.shape[0]
    ec, ecls = _distinct_rows(jw.edge)
    tc, tcls = _distinct_rows(jw.tri)
    wc = np.zeros((1 + ec.shape[0] + tc.shape[0], JUNCTION_COLUMNS))
    wc[1:1 + ec.shape[0], :2] = ec
    wc[1 + ec.shape[0]:, :6] = tc
    wc[:, -1] = 1.0
    # each kind's class, in the mesh's numbering: points 0, then the edges' rows, the triangles'
    cls = np.concatenate([np.zeros(p, dtype=np.int64), 1 + ecls, 1 + ec.shape[0] + tcls])
    wcls = cls[order]
    bound = np.exp(np.maximum(tc[:, 3:6], 0.0).sum(axis=1)) if tc.size else np.ones(0)
    pwhi = np.concatenate([np.ones(1 + ec.shape[0]), bound])[wcls]
    return wc, wcls, pwhi


def _distinct_rows(rows):
    """``(distinct (k, c), index (m,) int64)`` of the float rows ``rows (m, c)``: a 64-bit hash
    of each row's bits, made unique (``np.unique(rows, axis=0)`` sorts the rows themselves, 15x
    slower: 3 s per million triangles); a hash collision, which the check finds, falls back
    to it. The coefficients are never ``-0.0`` (quotients of counts), so equal rows have equal
    bits."""
    if rows.shape[0] == 0:
        return rows.reshape(0, rows.shape[1]), np.zeros(0, dtype=np.int64)
    bits = np.ascontiguousarray(rows).view(np.uint64)
    h = np.zeros(rows.shape[0], dtype=np.uint64)
    with np.errstate(over="ignore"):
        for j in range(bits.shape[1]):
            h *= np.uint64(0x9E3779B97F4A7C15)
            h ^= bits[:, j]
    _, first, index = np.unique(h, return_index=True, return_inverse=True)
    index = index.ravel()
    distinct = rows[first]
    if not all(np.array_equal(distinct[index, j], rows[:, j]) for j in range(rows.shape[1])):
        distinct, index = np.unique(rows, axis=0, return_inverse=True)
    return np.ascontiguousarray(distinct), index.ravel().astype(np.int64)
