"""Exact unsigned distance on a tree of its own: binned-SAH build, wide leaves, child boxes
stored with their parent, and a batch kernel that traces groups of neighbouring queries
together, each group seeded by the previous one's closest primitive.

The smooth-distance kernels need the leaf-size-1 tree of :mod:`smoothdist._kernels.bvh` (its node
diameters and weight bounds drive Barnes-Hut); exact branch and bound only needs
tight boxes and few nodes. :class:`ExactTree` is that second tree. It is built from a
:class:`~smoothdist._kernels.bvh.TreeData`'s primitive table by :func:`build_exact_tree`, and
:class:`~smoothdist.field.SmoothDistanceField` builds it lazily, once its exact-distance calls
have asked for about one query per primitive (:data:`smoothdist.field.EXACT_TREE_AFTER`).

Layout
------
Only inner nodes are stored; inner node ``k`` holds the boxes of *both* its children,
``box[k] = (lo0 xyz, hi0 xyz, lo1 xyz, hi1 xyz)``, so that one visit reads both boxes from one
row and decides the order and the pruning of both children. ``child[k, j]`` is the index of
child ``j`` if it is an inner node (``>= 0``), or a leaf code ``-1 - (start * 16 + count)``:
the leaf's primitives are ``start : start + count`` of the reordered primitive table
(``count <= 15``). Nodes are numbered in depth-first order (left child right after its
parent), so a traversal walks mostly forward through memory. ``root`` is ``0`` or a leaf code
(a table of at most ``leaf_size`` primitives is one leaf).

Memory: 112 bytes per inner node (boxes in float64) plus, per primitive, the reordered
coordinates (``24 k`` bytes, ``k`` the largest vertex count present), a kind byte, the original
index (8 bytes) and, with edges or triangles, a precomputed Gram matrix (24 bytes). The build
leaves 0.23 inner nodes per triangle, 0.25 per edge and 0.17 per point on the paper's bunny:
about 131 bytes per triangle, 108 per edge, 52 per point (a 1e7-point cloud: 0.5 GB).

The hot loop computes squared distances only (:func:`primitive_d2`); the closest point, the
distance and the gradient are computed once per query, for the winner, by the routines of
:mod:`smoothdist._kernels.closest_point` that the plain kernel uses, so whenever both pick the same
primitive they return the same bits.
"""

import math
from typing import NamedTuple

import numba
import numpy as np
from numba import prange

from smoothdist._config import NJIT, NJIT_INLINE, NJIT_IR_INLINE, NJIT_PARALLEL
from smoothdist._kernels.closest_point import closest_point_segment, closest_point_triangle
from smoothdist._kernels.traversal import beyond_best, nearest_first, no_far_field, within_best
from smoothdist.mesh import KIND_TRIANGLE

#: queries handled by one parallel task (one stack and one seed chain each)
CHUNK = 64
#: consecutive queries traced together by :func:`exact_tree_batch` (one traversal, each node's
#: boxes read once for all of them; the fastest measured: performance guide, "Tuning constants")
GROUP = 4
#: largest leaf (the leaf code keeps the count in 4 bits)
MAX_LEAF = 15
#: from this depth on the build splits at the object median instead (balanced: the depth stays
#: below ``SAH_DEPTH + log2(m)``, whatever the data, e.g. points at x = 2^-k)
SAH_DEPTH = 48


class ExactTree(NamedTuple):
    """Inner-node table plus reordered primitive table (see the module docstring).

    box : (n, 12) float64
        Both children's boxes of every inner node.
    child : (n, 2) int64
        Inner child index or leaf code.
    root : int
        ``0`` or the leaf code of a single-leaf tree.
    root_box : (6,) float64
        Box of the whole table ``(lo, hi)``.
    kind : (m,) int8
        0 point, 1 edge, 2 triangle, in tree order.
    pts : (m, 3 k) float64
        Vertex coordinates in tree order (``k`` = largest vertex count present).
    gram : (m, 3) float64
        ``(|b - a|^2, (b - a).(c - a), |c - a|^2)`` of every edge ``ab`` and triangle ``abc``
        (unused entries 0; ``(0, 3)`` for a point cloud): the squared-distance routines'
        precomputed Gram matrix.
    orig : (m,) int64
        Index of each primitive in the mesh numbering.
    depth : int
        Number of inner nodes on the longest root-to-leaf path.
    tri_only : bool
        The table holds triangles only (the batch kernel skips the per-primitive kind
        dispatch; kept here so that a call of a few queries does not scan ``kind``: 0.1 ms a
        call at 1.3M triangles).
    """

    box: np.ndarray
    child: np.ndarray
    root: int
    root_box: np.ndarray
    kind: np.ndarray
    pts: np.ndarray
    gram: np.ndarray
    orig: np.ndarray
    depth: int
    tri_only: bool


def build_exact_tree(tree, leaf_size=8, bins=16, node_cost=3.0):
    """Build an :class:`ExactTree` over the primitives of ``tree`` (a ``TreeData``).

    Binned surface-area-heuristic split (``bins`` centroid bins per axis, a node visit costing
    ``node_cost`` primitive tests); a node becomes a leaf when it holds one primitive, or at
    most ``leaf_size`` and the heuristic prefers it or they are all points. Build time is
    about 1.5 us per primitive. The defaults (leaves of up to 8, a node visit worth 3 tests)
    were measured on the 1e6-point grid around the paper's bunny once the primitive tests
    were inlined into the traversal: 11-16 % less CPU than leaves of 4 at cost 1 (V / E / F
    0.36 -> 0.30-0.32, 1.03-1.06 -> 0.87-0.89, 1.07 -> 0.95 s; 2 or 4 were worse, 15 alike).
    """
    leaf_size = int(leaf_size)
    if not 1 <= leaf_size <= MAX_LEAF:
        raise ValueError(f"leaf_size must be in [1, {MAX_LEAF}], got {leaf_size}")
    kind = tree.kind
    m = kind.size
    nv = kind + 1
    width = 3 * int(nv.max()) if m else 3
    pts = tree.pts[:, :width]
    plo = pts[:, 0:3].copy()
    phi = pts[:, 0:3].copy()
    cent = pts[:, 0:3].copy()
    for j in (1, 2):
        use = nv > j
        if use.any():
            Xj = pts[use, 3 * j:3 * j + 3]
            plo[use] = np.minimum(plo[use], Xj)
            phi[use] = np.maximum(phi[use], Xj)
            cent[use] += Xj
    cent /= nv[:, None]
    order, box, child, root, root_box, depth = _build_sah(cent, plo, phi, kind, leaf_size,
                                                          int(bins), float(node_cost), SAH_DEPTH)
    pts = np.ascontiguousarray(pts[order])
    gram = np.zeros((m if width >= 6 else 0, 3))
    if width >= 6:
        ab = pts[:, 3:6] - pts[:, 0:3]
        gram[:, 0] = (ab * ab).sum(axis=1)
        if width == 9:
            ac = pts[:, 6:9] - pts[:, 0:3]
            tri = kind[order] == KIND_TRIANGLE
            gram[tri, 1] = (ab[tri] * ac[tri]).sum(axis=1)
            gram[tri, 2] = (ac[tri] * ac[tri]).sum(axis=1)
    return ExactTree(box=box, child=child, root=int(root), root_box=root_box,
                     kind=kind[order].astype(np.int8), pts=pts, gram=gram,
                     orig=np.ascontiguousarray(tree.orig[order]), depth=int(depth),
                     tri_only=bool(m) and bool(kind.min() == KIND_TRIANGLE))


@numba.njit(**NJIT)
def _area(x0, x1, y0, y1, z0, z1):
    dx = x1 - x0
    dy = y1 - y0
    dz = z1 - z0
    return dx * dy + dy * dz + dz * dx


@numba.njit(**NJIT)
def _range_box(order, plo, phi, s, e, out):
    for a in range(3):
        out[a] = np.inf
        out[3 + a] = -np.inf
    for k in range(s, e):
        i = order[k]
        for a in range(3):
            out[a] = min(out[a], plo[i, a])
            out[3 + a] = max(out[3 + a], phi[i, a])


@numba.njit(**NJIT)
def _leaf_code(s, e):
    return -1 - (s * 16 + (e - s))


@numba.njit(**NJIT_INLINE)
def _bin_axis(order, cent, plo, phi, s, e, a, lo, scale, nbins, bcnt, bbox):
    """Count the primitives ``order[s:e]`` into ``nbins`` centroid bins along axis ``a`` and
    grow each bin's box (``bcnt[a]``, ``bbox[a]``)."""
    for b in range(nbins):
        bcnt[a, b] = 0
        for c in range(3):
            bbox[a, b, c] = np.inf
            bbox[a, b, 3 + c] = -np.inf
    for k in range(s, e):
        i = order[k]
        b = min(nbins - 1, int((cent[i, a] - lo) * scale))
        bcnt[a, b] += 1
        for c in range(3):
            bbox[a, b, c] = min(bbox[a, b, c], plo[i, c])
            bbox[a, b, 3 + c] = max(bbox[a, b, 3 + c], phi[i, c])


@numba.njit(**NJIT_INLINE)
def _sweep_axis(a, nbins, bcnt, bbox, rarea, rcnt, best_cost, best_axis, best_split):
    """The cheapest split between the bins of axis ``a`` by the surface area heuristic (area x
    count on each side), against the best so far: ``(cost, axis, first bin of the right)``."""
    # sweep from the right: area and count of bins b .. nbins-1
    x0 = np.inf
    y0 = np.inf
    z0 = np.inf
    x1 = -np.inf
    y1 = -np.inf
    z1 = -np.inf
    rc = 0
    for b in range(nbins - 1, 0, -1):
        if bcnt[a, b] > 0:
            x0 = min(x0, bbox[a, b, 0])
            y0 = min(y0, bbox[a, b, 1])
            z0 = min(z0, bbox[a, b, 2])
            x1 = max(x1, bbox[a, b, 3])
            y1 = max(y1, bbox[a, b, 4])
            z1 = max(z1, bbox[a, b, 5])
        rc += bcnt[a, b]
        rcnt[b] = rc
        rarea[b] = _area(x0, x1, y0, y1, z0, z1) if rc > 0 else 0.0
    x0 = np.inf
    y0 = np.inf
    z0 = np.inf
    x1 = -np.inf
    y1 = -np.inf
    z1 = -np.inf
    lc = 0
    for b in range(nbins - 1):
        if bcnt[a, b] > 0:
            x0 = min(x0, bbox[a, b, 0])
            y0 = min(y0, bbox[a, b, 1])
            z0 = min(z0, bbox[a, b, 2])
            x1 = max(x1, bbox[a, b, 3])
            y1 = max(y1, bbox[a, b, 4])
            z1 = max(z1, bbox[a, b, 5])
        lc += bcnt[a, b]
        if lc == 0 or rcnt[b + 1] == 0:
            continue
        cost = _area(x0, x1, y0, y1, z0, z1) * lc + rarea[b + 1] * rcnt[b + 1]
        if cost < best_cost:
            best_cost = cost
            best_axis = a
            best_split = b + 1
    return best_cost, best_axis, best_split


@numba.njit(**NJIT_INLINE)
def _best_split(order, cent, plo, phi, s, e, cbox, nbins, bcnt, bbox, rarea, rcnt):
    """``(cost, axis, split bin)`` of the cheapest binned SAH split of ``order[s:e]`` (axis -1:
    no axis has a centroid spread)."""
    best_cost = np.inf
    best_axis = -1
    best_split = 0
    for a in range(3):
        ext = cbox[3 + a] - cbox[a]
        if not ext > 0.0:
            continue
        _bin_axis(order, cent, plo, phi, s, e, a, cbox[a], nbins / ext, nbins, bcnt, bbox)
        best_cost, best_axis, best_split = _sweep_axis(a, nbins, bcnt, bbox, rarea, rcnt,
                                                       best_cost, best_axis, best_split)
    return best_cost, best_axis, best_split


@numba.njit(**NJIT_INLINE)
def _is_leaf(order, kind, s, e, leaf_size, node_cost, best_cost, best_axis, parea):
    """Whether ``order[s:e]`` becomes a leaf: one primitive, or small and the heuristic
    prefers it (cost of a split: one node test plus the children's primitive tests weighted by
    their area share), or small and points only."""
    cnt = e - s
    if cnt == 1:
        return True
    if cnt > leaf_size:
        return False
    split_cost = node_cost + (best_cost / parea if parea > 0.0 else cnt)
    if best_axis < 0 or cnt <= split_cost:
        return True
    # points cost no more than a box test: keep up to leaf_size of them together (half the
    # nodes of a point cloud, as fast)
    for k in range(s, e):
        if kind[order[k]] != 0:
            return False
    return True


@numba.njit(**NJIT_INLINE)
def _partition(order, cent, s, e, d, cbox, best_axis, best_split, nbins, sah_depth):
    """Reorder ``order[s:e]`` into the two children's ranges; returns where the right one
    starts."""
    if best_axis < 0:
        # no centroid spread (coincident centroids): split the range in half
        return (s + e) // 2
    if d >= sah_depth:
        # deep already (very uneven data): object median on the widest centroid axis
        a = 0
        for c in range(1, 3):
            if cbox[3 + c] - cbox[c] > cbox[3 + a] - cbox[a]:
                a = c
        cnt = e - s
        sub = order[s:e].copy()
        keys = np.empty(cnt)
        for k in range(cnt):
            keys[k] = cent[sub[k], a]
        idx = np.argsort(keys, kind="mergesort")
        for k in range(cnt):
            order[s + k] = sub[idx[k]]
        return (s + e) // 2
    a = best_axis
    scale = nbins / (cbox[3 + a] - cbox[a])
    i0 = s
    i1 = e - 1
    while i0 <= i1:
        b = min(nbins - 1, int((cent[order[i0], a] - cbox[a]) * scale))
        if b < best_split:
            i0 += 1
        else:
            tmp = order[i0]
            order[i0] = order[i1]
            order[i1] = tmp
            i1 -= 1
    return i0


@numba.njit(**NJIT)
def _build_sah(cent, plo, phi, kind, leaf_size, nbins, node_cost, sah_depth):
    m = cent.shape[0]
    order = np.arange(m)
    cap = max(1, m)
    box = np.empty((cap, 12))
    child = np.empty((cap, 2), dtype=np.int64)
    root_box = np.empty(6)
    _range_box(order, plo, phi, 0, m, root_box)
    # task stack: range, parent node and slot (-1: the root), depth
    st_s = np.empty(256, dtype=np.int64)
    st_e = np.empty(256, dtype=np.int64)
    st_p = np.empty(256, dtype=np.int64)
    st_j = np.empty(256, dtype=np.int64)
    st_d = np.empty(256, dtype=np.int64)
    st_s[0] = 0
    st_e[0] = m
    st_p[0] = -1
    st_j[0] = 0
    st_d[0] = 0
    sp = 1
    n = 0
    root = 0
    depth = 0
    bcnt = np.zeros((3, nbins), dtype=np.int64)
    bbox = np.empty((3, nbins, 6))
    rarea = np.empty(nbins)
    rcnt = np.empty(nbins, dtype=np.int64)
    nb = np.empty(6)
    cbox = np.empty(6)
    while sp > 0:
        sp -= 1
        s = st_s[sp]
        e = st_e[sp]
        par = st_p[sp]
        slot = st_j[sp]
        d = st_d[sp]
        _range_box(order, plo, phi, s, e, nb)
        parea = _area(nb[0], nb[3], nb[1], nb[4], nb[2], nb[5])
        _range_box(order, cent, cent, s, e, cbox)    # the centroids' box
        best_cost = np.inf
        best_axis = -1
        best_split = 0
        if e - s > 1:
            best_cost, best_axis, best_split = _best_split(order, cent, plo, phi, s, e, cbox,
                                                           nbins, bcnt, bbox, rarea, rcnt)
        if _is_leaf(order, kind, s, e, leaf_size, node_cost, best_cost, best_axis, parea):
            code = _leaf_code(s, e)
            if par < 0:
                root = code
            else:
                child[par, slot] = code
            continue
        node = n
        n += 1
        if par < 0:
            root = node
        else:
            child[par, slot] = node
        if d + 1 > depth:
            depth = d + 1
        mid = _partition(order, cent, s, e, d, cbox, best_axis, best_split, nbins, sah_depth)
        _range_box(order, plo, phi, s, mid, cbox)
        for c in range(6):
            box[node, c] = cbox[c]
        _range_box(order, plo, phi, mid, e, cbox)
        for c in range(6):
            box[node, 6 + c] = cbox[c]
        # right pushed first: the left subtree is built (and numbered) first
        st_s[sp] = mid
        st_e[sp] = e
        st_p[sp] = node
        st_j[sp] = 1
        st_d[sp] = d + 1
        sp += 1
        st_s[sp] = s
        st_e[sp] = mid
        st_p[sp] = node
        st_j[sp] = 0
        st_d[sp] = d + 1
        sp += 1
    return order, box[:n].copy(), child[:n].copy(), root, root_box, depth


@numba.njit(**NJIT_INLINE)
def _box_d2(px, py, pz, box, k, o):
    """Squared distance from ``p`` to the box ``box[k, o:o + 6]``."""
    dx = max(box[k, o] - px, 0.0, px - box[k, o + 3])
    dy = max(box[k, o + 1] - py, 0.0, py - box[k, o + 4])
    dz = max(box[k, o + 2] - pz, 0.0, pz - box[k, o + 5])
    return dx * dx + dy * dy + dz * dz


@numba.njit(**NJIT_INLINE)
def _triangle_d2(px, py, pz, P, G, i):
    """Squared distance from ``p`` to triangle ``i`` (rows of ``P`` and ``G`` as in
    :class:`ExactTree`): the Voronoi-region method of
    :func:`smoothdist._kernels.closest_point.closest_point_triangle`, with the six dot products it
    needs reduced to two per query (``d1 = ab.ap``, ``d2 = ac.ap``; ``ab.bp = d1 - |ab|^2``
    and so on from the Gram matrix)."""
    ax = P[i, 0]
    ay = P[i, 1]
    az = P[i, 2]
    abx = P[i, 3] - ax
    aby = P[i, 4] - ay
    abz = P[i, 5] - az
    acx = P[i, 6] - ax
    acy = P[i, 7] - ay
    acz = P[i, 8] - az
    apx = px - ax
    apy = py - ay
    apz = pz - az
    d1 = abx * apx + aby * apy + abz * apz
    d2 = acx * apx + acy * apy + acz * apz
    if d1 <= 0.0 and d2 <= 0.0:                      # vertex a
        return apx * apx + apy * apy + apz * apz
    g_ab = G[i, 1]
    d3 = d1 - G[i, 0]
    d4 = d2 - g_ab
    if d3 >= 0.0 and d4 <= d3:                       # vertex b
        x = apx - abx
        y = apy - aby
        z = apz - abz
        return x * x + y * y + z * z
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:        # edge ab
        v = d1 / (d1 - d3)
        x = apx - v * abx
        y = apy - v * aby
        z = apz - v * abz
        return x * x + y * y + z * z
    d5 = d1 - g_ab
    d6 = d2 - G[i, 2]
    if d6 >= 0.0 and d5 <= d6:                       # vertex c
        x = apx - acx
        y = apy - acy
        z = apz - acz
        return x * x + y * y + z * z
    vb = d5 * d2 - d1 * d6
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:        # edge ac
        w = d2 / (d2 - d6)
        x = apx - w * acx
        y = apy - w * acy
        z = apz - w * acz
        return x * x + y * y + z * z
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and (d4 - d3) >= 0.0 and (d5 - d6) >= 0.0:   # edge bc
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        x = apx - abx - w * (acx - abx)
        y = apy - aby - w * (acy - aby)
        z = apz - abz - w * (acz - abz)
        return x * x + y * y + z * z
    denom = 1.0 / (va + vb + vc)                     # interior
    v = vb * denom
    w = vc * denom
    x = apx - v * abx - w * acx
    y = apy - v * aby - w * acy
    z = apz - v * abz - w * acz
    return x * x + y * y + z * z


@numba.njit(**NJIT_INLINE)
def _segment_d2(px, py, pz, P, G, i):
    """Squared distance from ``p`` to segment ``i`` (``G[i, 0] = |ab|^2``)."""
    abx = P[i, 3] - P[i, 0]
    aby = P[i, 4] - P[i, 1]
    abz = P[i, 5] - P[i, 2]
    apx = px - P[i, 0]
    apy = py - P[i, 1]
    apz = pz - P[i, 2]
    num = abx * apx + aby * apy + abz * apz
    if num <= 0.0:
        return apx * apx + apy * apy + apz * apz
    den = G[i, 0]
    t = 1.0 if num >= den else num / den
    x = apx - t * abx
    y = apy - t * aby
    z = apz - t * abz
    return x * x + y * y + z * z


@numba.njit(**NJIT_INLINE)
def primitive_d2(kind, pts, gram, i, px, py, pz):
    """Squared distance from ``p`` to primitive ``i`` of an :class:`ExactTree`'s table.

    Agrees with the closest point of :func:`primitive_closest` to rounding (it is only used
    to choose the closest primitive; the result is recomputed from that closest point)."""
    k = kind[i]
    if k == 2:
        return _triangle_d2(px, py, pz, pts, gram, i)
    if k == 1:
        return _segment_d2(px, py, pz, pts, gram, i)
    x = px - pts[i, 0]
    y = py - pts[i, 1]
    z = pz - pts[i, 2]
    return x * x + y * y + z * z


@numba.njit(**NJIT_INLINE)
def primitive_closest(kind, pts, i, px, py, pz):
    """Closest point ``(cx, cy, cz)`` on primitive ``i`` to ``p``."""
    P = pts[i]
    k = kind[i]
    if k == 2:
        cx, cy, cz, s, t, f = closest_point_triangle(px, py, pz, P[0], P[1], P[2], P[3], P[4],
                                                     P[5], P[6], P[7], P[8])
    elif k == 1:
        cx, cy, cz, t, f = closest_point_segment(px, py, pz, P[0], P[1], P[2], P[3], P[4], P[5])
    else:
        cx = P[0]
        cy = P[1]
        cz = P[2]
    return cx, cy, cz


@numba.njit(**NJIT_INLINE)
def winner_result(kind, pts, bi, px, py, pz):
    """``(d, gx, gy, gz)``: distance from ``p`` to primitive ``bi`` (tree order) and the unit
    gradient ``(p - c) / d`` (zero on the geometry), from its closest point ``c``."""
    cx, cy, cz = primitive_closest(kind, pts, bi, px, py, pz)
    d = math.sqrt((px - cx) ** 2 + (py - cy) ** 2 + (pz - cz) ** 2)
    if d > 0.0:
        return d, (px - cx) / d, (py - cy) / d, (pz - cz) / d
    return 0.0, 0.0, 0.0, 0.0


@numba.njit(**NJIT_IR_INLINE)
def _coded_children(et, q, code):
    """``children`` of an ExactTree inner node: its two child codes, keyed by the squared
    distance to the child boxes stored in the node's row."""
    px, py, pz = q
    return (et.child[code, 0], _box_d2(px, py, pz, et.box, code, 0),
            et.child[code, 1], _box_d2(px, py, pz, et.box, code, 6))


@numba.njit(**NJIT_IR_INLINE)
def _code_leaf(et, q, code, st):
    """A leaf code's primitives (``-1 - (start << 4 | count)``); ``st = (best d2, prim,
    leaves)``."""
    if code >= 0:
        return False, st
    px, py, pz = q
    best, bi, leaves = st
    c = -1 - code
    first = c >> 4
    for i in range(first, first + (c & 15)):
        d2 = primitive_d2(et.kind, et.pts, et.gram, i, px, py, pz)
        leaves += 1
        if d2 < best:
            best = d2
            bi = i
    return True, (best, bi, leaves)


@numba.njit(**NJIT)
def exact_tree_point(et, px, py, pz, stack, dstack, seed=-1):
    """Exact unsigned distance at ``p`` by nearest-first branch and bound over an ExactTree.

    ``seed`` (a primitive index in tree order, or -1) is evaluated first, so that its
    distance is the initial upper bound. Returns ``(d, gx, gy, gz, prim, nodes, leaves,
    winner)``: as :func:`smoothdist._kernels.query.exact_distance_point`, plus the winner's index in
    tree order (the next query's seed). ``nodes`` counts the nodes whose box test did not
    prune them (inner nodes and leaves), ``leaves`` the primitive evaluations.
    """
    kind = et.kind
    pts = et.pts
    best = np.inf
    bi = -1
    leaves = 0
    if seed >= 0:
        d2 = primitive_d2(kind, pts, et.gram, seed, px, py, pz)
        leaves += 1
        if d2 < best:
            best = d2
            bi = seed
    rb = et.root_box
    dx = max(rb[0] - px, 0.0, px - rb[3])
    dy = max(rb[1] - py, 0.0, py - rb[4])
    dz = max(rb[2] - pz, 0.0, pz - rb[5])
    (best, bi, leaves), nodes = nearest_first(
        et, (px, py, pz), (best, bi, leaves), stack, dstack, et.root, dx * dx + dy * dy + dz * dz,
        beyond_best, no_far_field, _code_leaf, _coded_children, within_best)
    d, gx, gy, gz = winner_result(kind, pts, bi, px, py, pz)
    return d, gx, gy, gz, et.orig[bi], nodes, leaves, bi


def exact_stack_size(et):
    """Traversal stack length for ``et`` (one pending sibling per level plus both children)."""
    return et.depth + 4


@numba.njit(**NJIT)
def exact_tree_group(et, P, k, stack, dstack, best, idx, need, nodes, leaves, count=True,
                     tri_only=False):
    """Exact branch and bound for the ``GROUP`` queries ``P (GROUP, 3)`` in one traversal.

    The rows ``k <= q < GROUP`` repeat row ``k - 1`` (a short last group) and are not
    counted. On entry ``best[q]`` is query ``q``'s squared distance bound (``inf``, or a seed
    primitive's, which is then ``idx[q]``); on return ``best[q]`` is its smallest squared
    distance and ``idx[q]`` the primitive (tree order) that gave it. ``nodes[q]`` and
    ``leaves[q]`` are incremented as :func:`exact_tree_point` counts them, per query. A node is
    opened when it is nearer than the bound of *any* of the queries, and each primitive test
    and each pruning decision is still made per query, so every query gets what
    :func:`exact_tree_point` would find: neighbouring queries (the rows of a grid, the pixels
    of a tile) visit mostly the same nodes, and the group reads each node's boxes once for all
    of them. Children are pushed nearer-first by the sum of the group's squared distances.
    ``dstack`` is ``(len(stack), GROUP)``: each entry's box distance for every query.
    ``count``: count nodes and leaves; ``tri_only``: the table holds triangles only.
    """
    kind = et.kind
    pts = et.pts
    gram = et.gram
    box = et.box
    child = et.child
    rb = et.root_box
    for q in range(GROUP):
        px = P[q, 0]
        py = P[q, 1]
        pz = P[q, 2]
        dx = max(rb[0] - px, 0.0, px - rb[3])
        dy = max(rb[1] - py, 0.0, py - rb[4])
        dz = max(rb[2] - pz, 0.0, pz - rb[5])
        dstack[0, q] = dx * dx + dy * dy + dz * dz
    stack[0] = et.root
    sp = 1
    while sp > 0:
        sp -= 1
        any_need = False
        for q in range(GROUP):
            # the repeated rows of a short group are never tested (their bound stays where
            # it started): they must not open nodes, or a group of 1-3 queries without a seed
            # searched the whole tree
            nq = q < k and dstack[sp, q] < best[q]
            need[q] = nq
            any_need = any_need or nq
        if not any_need:
            continue
        code = stack[sp]
        if code < 0:
            c = -1 - code
            st = c >> 4
            cnt = c & 15
            if count:
                for q in range(k):
                    if need[q]:
                        nodes[q] += 1
                        leaves[q] += cnt
            if tri_only:                # no per-primitive kind dispatch (3 % on the bunny)
                for i in range(st, st + cnt):
                    for q in range(k):
                        if need[q]:
                            d2 = _triangle_d2(P[q, 0], P[q, 1], P[q, 2], pts, gram, i)
                            if d2 < best[q]:
                                best[q] = d2
                                idx[q] = i
            else:
                for i in range(st, st + cnt):
                    for q in range(k):
                        if need[q]:
                            d2 = primitive_d2(kind, pts, gram, i, P[q, 0], P[q, 1], P[q, 2])
                            if d2 < best[q]:
                                best[q] = d2
                                idx[q] = i
            continue
        if count:
            for q in range(k):
                if need[q]:
                    nodes[q] += 1
        # both children's distances for every query: child 0's into row sp, child 1's into
        # row sp + 1; then the rows are ordered so that the nearer child is popped first
        s0 = 0.0
        s1 = 0.0
        p0 = False
        p1 = False
        for q in range(GROUP):
            px = P[q, 0]
            py = P[q, 1]
            pz = P[q, 2]
            d0 = _box_d2(px, py, pz, box, code, 0)
            d1 = _box_d2(px, py, pz, box, code, 6)
            dstack[sp, q] = d0
            dstack[sp + 1, q] = d1
            s0 += d0
            s1 += d1
            p0 = p0 or d0 < best[q]
            p1 = p1 or d1 < best[q]
        c0 = child[code, 0]
        c1 = child[code, 1]
        if p0 and p1:
            if s0 <= s1:            # child 0 nearer: it goes on top (row sp + 1)
                stack[sp] = c1
                stack[sp + 1] = c0
                for q in range(GROUP):
                    t = dstack[sp, q]
                    dstack[sp, q] = dstack[sp + 1, q]
                    dstack[sp + 1, q] = t
            else:
                stack[sp] = c0
                stack[sp + 1] = c1
            sp += 2
        elif p0:
            stack[sp] = c0
            sp += 1
        elif p1:
            stack[sp] = c1
            for q in range(GROUP):
                dstack[sp, q] = dstack[sp + 1, q]
            sp += 1


@numba.njit(**NJIT_PARALLEL)
def exact_tree_batch(et, Q, seeded, out_d, out_g, out_prim, out_nodes, out_leaves,
                     ntasks=1, count=True, order=None, group=GROUP):
    """Exact distance for every row of ``Q (q, 3)`` into the output arrays.

    ``group`` (1 to :data:`GROUP`): queries traced together; 1 for scattered queries, which
    share no nodes (a group of unrelated queries visits the union of their searches).

    ``order`` (optional ``(q,) int64`` permutation; empty or None: ``Q``'s own order): take
    the queries in the order
    ``Q[order[0]], Q[order[1]], ...`` (a coherent order, :mod:`smoothdist.query_order`) and
    write each result to the row of its query, so the outputs stay in ``Q``'s order without a
    copy of ``Q`` or of the results.

    Queries are taken in chunks of :data:`CHUNK` rows and, within a chunk, in groups of
    :data:`GROUP` consecutive rows traced together (:func:`exact_tree_group`). With
    ``seeded``, each group starts from the previous group's last closest primitive (the chain
    restarts at every chunk, so the results do not depend on the thread count). ``ntasks``
    strided tasks share the chunks out (:mod:`smoothdist.schedule`). The closest point,
    distance and gradient of each query's winner come from :func:`winner_result`, as in
    :func:`exact_tree_point`.
    """
    n = Q.shape[0]
    nchunks = (n + CHUNK - 1) // CHUNK
    cap = et.depth + 4
    ntasks = max(1, min(nchunks, ntasks))
    kind = et.kind
    pts = et.pts
    gram = et.gram
    tri_only = et.tri_only
    for task in prange(ntasks):
        stack = np.empty(cap, dtype=np.int64)
        dstack = np.empty((cap, GROUP))
        P = np.empty((GROUP, 3))
        best = np.empty(GROUP)
        idx = np.empty(GROUP, dtype=np.int64)
        need = np.empty(GROUP, dtype=np.bool_)
        nodes = np.empty(GROUP, dtype=np.int64)
        leaves = np.empty(GROUP, dtype=np.int64)
        for c in range(task, nchunks, ntasks):    # every ntasks-th chunk
            prev = -1
            end = min(n, (c + 1) * CHUNK)
            for i in range(c * CHUNK, end, group):
                k = min(group, end - i)
                for q in range(GROUP):
                    j = i + min(q, k - 1)
                    if order is not None:
                        if order.size:
                            j = order[j]
                    P[q, 0] = Q[j, 0]
                    P[q, 1] = Q[j, 1]
                    P[q, 2] = Q[j, 2]
                    nodes[q] = 0
                    leaves[q] = 0
                    best[q] = np.inf
                    idx[q] = -1
                    if prev >= 0:
                        best[q] = primitive_d2(kind, pts, gram, prev, P[q, 0], P[q, 1], P[q, 2])
                        idx[q] = prev
                        leaves[q] = 1
                exact_tree_group(et, P, k, stack, dstack, best, idx, need, nodes, leaves, count,
                                 tri_only)
                for q in range(k):
                    bi = idx[q]
                    d, gx, gy, gz = winner_result(kind, pts, bi, P[q, 0], P[q, 1], P[q, 2])
                    r = i + q
                    if order is not None:
                        if order.size:
                            r = order[r]
                    out_d[r] = d
                    out_g[r, 0] = gx
                    out_g[r, 1] = gy
                    out_g[r, 2] = gz
                    out_prim[r] = et.orig[bi]
                    out_nodes[r] = nodes[q]
                    out_leaves[r] = leaves[q]
                if seeded:
                    prev = idx[k - 1]
