"""Kernels: smooth and exact distance from one query primitive (point, edge, triangle) to a tree.

The paper's generalized query primitives (Madan & Levin 2022, Sec. 3.4): the smooth distance from a
query primitive ``g`` to the data mesh is

    d_hat(g) = -(1/alpha) log sum_i W_i exp(-alpha d(f_i, g)),

with ``d(f_i, g)`` the exact primitive-primitive distance
(:mod:`smoothdist._kernels.closest_pair`) and ``W_i`` the data primitive's weight at the data-side
barycentrics of the closest pair. Its gradient is with respect to a rigid translation ``tau`` of
``g``:

    grad d(f_i, g) = unit(r),  r = (closest point on g) - (closest point on f_i),

and the weight's gradient goes through the closest pair's data barycentrics ``phi``: on the pair of
active features (the faces of both simplices the closest points lie in), the stationarity
conditions ``D^T r = 0`` and ``Q^T r = 0`` (``D``, ``Q`` the features' edge directions) give
``d[phi, lambda] / d tau = (M^T M)^-1 M^T`` with ``M = [D, -Q]``. For a point query this is the
point kernel's projection Jacobian (:func:`smoothdist._kernels.query.primitive_term`).

Traversal as for points: :func:`smoothdist._kernels.traversal.nearest_first`, nearest child first
by the cheap box-box distance, with this module's skip, far-field, leaf and children functions.
Barnes-Hut replaces a node by ``count * whi**S * exp(-alpha delta)`` with ``delta`` a lower bound
of the query-box distance: the box-box distance when that already satisfies ``diag < beta delta``,
else
:func:`smoothdist._kernels.box_distance.box_lower_bound` (the paper's halfspace test, done
conservatively). So the far field overestimates the subtree's sum and ``d_hat_beta <= d_hat_0``.
Point queries use the point kernels themselves.

One traversal (:func:`smooth_traverse`) serves the translation gradient and
:mod:`smoothdist._kernels.mesh_moment`'s rotational and per-vertex ones; its kind (the moment
flag and the far-field functions) is an argument fixed by each caller, so the distance kernel
neither runs nor compiles any of the moment's work. For speed (the same nodes,
terms and values as a plain version; issue 17): the traversal reads the tree's arrays without
reference counts (``smoothdist._kernels.traversal.borrowed``), the data primitive's
coordinates go to the closest-pair kernels as scalars, small helpers are inlined
(``NJIT_INLINE``), the stack holds squared box distances, and the finer Barnes-Hut bound is
only tried where a cheap upper bound says it could qualify the node.
"""

import math
from typing import NamedTuple

import numba
import numpy as np
from numba import prange

from smoothdist._config import NJIT, NJIT_GENERIC, NJIT_INLINE, NJIT_IR_INLINE, NJIT_PARALLEL
from smoothdist._kernels.box_distance import (box_box_distance, box_box_offset, box_distance_exact,
                                              signed_gap,
                                              box_lower_bound)
from smoothdist._kernels.closest_pair import (closest_pair, point_segment, point_triangle,
                                              segment_point, segment_segment,
                                              segment_triangle, triangle_point, triangle_segment,
                                              triangle_triangle)
from smoothdist._kernels.closest_point import (SEG_INTERIOR, TRI_AB, TRI_AC, TRI_BC, TRI_INTERIOR)
from smoothdist._kernels.query import (_attenuate, exact_distance_point, logsumexp_accumulate,
                                       negligible_reach)
from smoothdist._kernels.traversal import (NONE, ZERO, always, nearest_first, no_far_field,
                                           python_function)
from smoothdist._kernels.weights import eval_triangle_weight

#: :func:`smoothdist._kernels.query._attenuate`, inlined (it calls no other kernel)
_attenuate_inline = numba.njit(**NJIT_INLINE)(python_function(_attenuate))
#: ``moment`` values of :func:`smooth_traverse` (and its pair terms) beyond True (the moment):
#: the derivative for a motion of query vertex 1 or 2 alone
VERTEX_1, VERTEX_2 = 2, 3
#: :func:`smoothdist._kernels.closest_pair.segment_segment`, inlined (the edge-edge leaves)
_segment_segment_inline = numba.njit(**NJIT_INLINE)(python_function(segment_segment))


@numba.njit(**NJIT)
def feature_directions(kind, feat, X):
    """Edge directions spanning the feature a closest point lies in.

    Returns ``(n, d1x, d1y, d1z, d2x, d2y, d2z)`` with ``n`` in 0..2 free directions. For a
    triangle edge ``bc`` the direction is ``c - b`` (parameter ``u`` with ``s = 1 - u, t = u``).
    """
    if kind == 1:
        if feat == SEG_INTERIOR:
            return 1, X[3] - X[0], X[4] - X[1], X[5] - X[2], 0.0, 0.0, 0.0
        return 0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    if kind == 2:
        if feat == TRI_INTERIOR:
            return (2, X[3] - X[0], X[4] - X[1], X[5] - X[2], X[6] - X[0], X[7] - X[1],
                    X[8] - X[2])
        if feat == TRI_AB:
            return 1, X[3] - X[0], X[4] - X[1], X[5] - X[2], 0.0, 0.0, 0.0
        if feat == TRI_AC:
            return 1, X[6] - X[0], X[7] - X[1], X[8] - X[2], 0.0, 0.0, 0.0
        if feat == TRI_BC:
            return 1, X[6] - X[3], X[7] - X[4], X[8] - X[5], 0.0, 0.0, 0.0
    return 0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0


@numba.njit(**NJIT_INLINE)
def _dot(ax, ay, az, bx, by, bz):
    return ax * bx + ay * by + az * bz


@numba.njit(**NJIT)
def weight_gradient(nd, d1x, d1y, d1z, d2x, d2y, d2z, w1, w2, nq, q1x, q1y, q1z):
    """Gradient of the weight with respect to a translation of the query.

    ``nd`` data directions ``d1, d2`` with weight partials ``w1, w2`` along their parameters, and
    ``nq`` (0 or 1 used) query directions. Solves ``(M^T M) y = (w1, w2, 0)`` for ``M = [D, -Q]``
    and returns ``M y``. Falls back to the data directions alone when the system is singular
    (parallel features) or has three unknowns (only at intersections, where ``r = 0``).
    """
    if nq == 1 and nd == 1:
        a = _dot(d1x, d1y, d1z, d1x, d1y, d1z)
        b = -_dot(d1x, d1y, d1z, q1x, q1y, q1z)
        c = _dot(q1x, q1y, q1z, q1x, q1y, q1z)
        det = a * c - b * b
        if det > 1e-12 * a * c:
            y1 = c * w1 / det
            y2 = -b * w1 / det
            return y1 * d1x - y2 * q1x, y1 * d1y - y2 * q1y, y1 * d1z - y2 * q1z
    if nd == 1:
        f = w1 / _dot(d1x, d1y, d1z, d1x, d1y, d1z)
        return f * d1x, f * d1y, f * d1z
    a = _dot(d1x, d1y, d1z, d1x, d1y, d1z)
    b = _dot(d1x, d1y, d1z, d2x, d2y, d2z)
    c = _dot(d2x, d2y, d2z, d2x, d2y, d2z)
    det = a * c - b * b
    y1 = (c * w1 - b * w2) / det
    y2 = (a * w2 - b * w1) / det
    return y1 * d1x + y2 * d2x, y1 * d1y + y2 * d2y, y1 * d1z + y2 * d2z


@numba.njit(**NJIT_INLINE)
def _edge_weight(wc, i, t):
    """:func:`smoothdist._kernels.weights.eval_edge_weight` of row ``i`` of ``wc`` (no row view)."""
    c0 = wc[i, 0]
    c1 = wc[i, 1]
    c2 = wc[i, 2]
    c3 = wc[i, 3]
    c4 = wc[i, 4]
    w = c0 + t * (c1 + t * (c2 + t * (c3 + t * c4)))
    dw = c1 + t * (2.0 * c2 + t * (3.0 * c3 + t * (4.0 * c4)))
    return w, dw


@numba.njit(**NJIT_IR_INLINE)
def _closest(kind, P, i, kq, Q, k):
    """:func:`smoothdist._kernels.closest_pair.closest_pair` of query ``(kq, Q)`` and data
    primitive ``i`` of ``kind``, ``P`` (the tree's arrays), called with the data's coordinates as
    scalars for edge and triangle queries (no row view, no dispatch through every kind pair)."""
    if kq == 0:
        # a point query (the brute-force references only: the traversal takes edges and
        # triangles), as closest_pair does it, without compiling closest_pair's other kinds
        if k == 0:
            rx = Q[0] - P[i, 0]
            ry = Q[1] - P[i, 1]
            rz = Q[2] - P[i, 2]
            return rx * rx + ry * ry + rz * rz, rx, ry, rz, 0.0, 0.0, 0, 0.0, 0.0, 0
        if k == 1:
            return point_segment(Q[0], Q[1], Q[2], P[i, 0], P[i, 1], P[i, 2], P[i, 3], P[i, 4],
                                 P[i, 5])
        return point_triangle(Q[0], Q[1], Q[2], P[i, 0], P[i, 1], P[i, 2], P[i, 3], P[i, 4],
                              P[i, 5], P[i, 6], P[i, 7], P[i, 8])
    if k == 0:
        if kq == 1:
            return segment_point(Q[0], Q[1], Q[2], Q[3], Q[4], Q[5], P[i, 0], P[i, 1], P[i, 2])
        return triangle_point(Q[0], Q[1], Q[2], Q[3], Q[4], Q[5], Q[6], Q[7], Q[8], P[i, 0],
                              P[i, 1], P[i, 2])
    if k == 1:
        if kq == 1:
            return _segment_segment_inline(Q[0], Q[1], Q[2], Q[3], Q[4], Q[5], P[i, 0], P[i, 1],
                                           P[i, 2], P[i, 3], P[i, 4], P[i, 5])
        return triangle_segment(Q[0], Q[1], Q[2], Q[3], Q[4], Q[5], Q[6], Q[7], Q[8], P[i, 0],
                                P[i, 1], P[i, 2], P[i, 3], P[i, 4], P[i, 5])
    if kq == 1:
        return segment_triangle(Q[0], Q[1], Q[2], Q[3], Q[4], Q[5], P[i, 0], P[i, 1], P[i, 2],
                                P[i, 3], P[i, 4], P[i, 5], P[i, 6], P[i, 7], P[i, 8])
    return triangle_triangle(Q[0], Q[1], Q[2], Q[3], Q[4], Q[5], Q[6], Q[7], Q[8], P[i, 0],
                             P[i, 1], P[i, 2], P[i, 3], P[i, 4], P[i, 5], P[i, 6], P[i, 7],
                             P[i, 8])


@numba.njit(**NJIT)
def query_coefficient(nd, d1x, d1y, d1z, w1, nq, q1x, q1y, q1z):
    """The query-edge component ``y`` of :func:`weight_gradient`'s solve (one data and one query
    direction, same singularity test; 0 otherwise): the rotational part of the weight's motion
    (:mod:`smoothdist._kernels.mesh_moment`)."""
    if nq == 1 and nd == 1:
        a = _dot(d1x, d1y, d1z, d1x, d1y, d1z)
        b = -_dot(d1x, d1y, d1z, q1x, q1y, q1z)
        c = _dot(q1x, q1y, q1z, q1x, q1y, q1z)
        det = a * c - b * b
        if det > 1e-12 * a * c:
            return -b * w1 / det
    return 0.0


@numba.njit(**NJIT_INLINE)
def _pair(kind, pts, wc, wcls, pwhi, i, kq, Q, S, wgrad_scale, moment, cx, cy, cz, k):
    """Term of data primitive ``i`` (tree order) for query primitive ``(kq, Q)``.

    Returns ``(d, W, vx, vy, vz, mx, my, mz)``: distance, attenuated weight, the gradient
    numerator ``v = W unit(r) - wgrad_scale grad W`` (for a translation of the query) and, with
    ``moment`` True (or 1), the term's moment about ``c``
    (:mod:`smoothdist._kernels.mesh_moment`), with ``moment`` ``VERTEX_1`` or ``VERTEX_2`` the
    numerator for a motion of that query vertex alone
    (:func:`smoothdist._kernels.mesh_moment.smooth_vertex_primitive`); else 0.
    """
    return _pair_term(_closest(kind, pts, i, kq, Q, k), kind, pts, wc, wcls, pwhi, i, kq, Q, S,
                      wgrad_scale, moment, cx, cy, cz, k)


@numba.njit(**NJIT_GENERIC)
def closest_triangles(kind, P, i, kq, Q, k):
    """``_closest`` where the query and the data primitive are both triangles (the
    traversal of a triangle mesh against a triangle mesh compiles this pair kernel only)."""
    return triangle_triangle(Q[0], Q[1], Q[2], Q[3], Q[4], Q[5], Q[6], Q[7], Q[8], P[i, 0],
                             P[i, 1], P[i, 2], P[i, 3], P[i, 4], P[i, 5], P[i, 6], P[i, 7],
                             P[i, 8])


@numba.njit(**NJIT_GENERIC)
def closest_segments(kind, P, i, kq, Q, k):
    """``_closest`` where the query and the data primitive are both edges."""
    return _segment_segment_inline(Q[0], Q[1], Q[2], Q[3], Q[4], Q[5], P[i, 0], P[i, 1],
                                   P[i, 2], P[i, 3], P[i, 4], P[i, 5])


@numba.njit(**NJIT_GENERIC)
def closest_triangles_segments(kind, P, i, kq, Q, k):
    """``_closest`` where the query is a triangle and the data primitive an edge."""
    return triangle_segment(Q[0], Q[1], Q[2], Q[3], Q[4], Q[5], Q[6], Q[7], Q[8], P[i, 0],
                            P[i, 1], P[i, 2], P[i, 3], P[i, 4], P[i, 5])


@numba.njit(**NJIT_GENERIC)
def closest_segments_triangles(kind, P, i, kq, Q, k):
    """``_closest`` where the query is an edge and the data primitive a triangle."""
    return segment_triangle(Q[0], Q[1], Q[2], Q[3], Q[4], Q[5], P[i, 0], P[i, 1], P[i, 2],
                            P[i, 3], P[i, 4], P[i, 5], P[i, 6], P[i, 7], P[i, 8])


@numba.njit(**NJIT_INLINE)
def _pair_term(c, kind, pts, wc, wcls, pwhi, i, kq, Q, S, wgrad_scale, moment, cx, cy, cz, k):
    """:func:`_pair` from the pair's closest points ``c`` (:func:`_closest`'s tuple)."""
    d = math.sqrt(c[0])
    rx = c[1]
    ry = c[2]
    rz = c[3]
    W = 1.0
    gwx = 0.0
    gwy = 0.0
    gwz = 0.0
    y = 0.0
    q1x = q1y = q1z = 0.0
    if k != 0:
        df = c[9]
        if k == 1:
            w, dw = _edge_weight(wc, wcls[i], c[7])
            W, fac = _attenuate_inline(w, dw, pwhi[i], S)
            if fac != 0.0 and df == SEG_INTERIOR:
                # feature_directions and weight_gradient with the data edge's one direction
                d1x = pts[i, 3] - pts[i, 0]
                d1y = pts[i, 4] - pts[i, 1]
                d1z = pts[i, 5] - pts[i, 2]
                if kq == 1:
                    nq = 1 if c[6] == SEG_INTERIOR else 0
                    q1x = Q[3] - Q[0]
                    q1y = Q[4] - Q[1]
                    q1z = Q[5] - Q[2]
                else:
                    nq, q1x, q1y, q1z, _, _, _ = feature_directions(kq, c[6], Q)
                gwx, gwy, gwz = weight_gradient(1, d1x, d1y, d1z, 0.0, 0.0, 0.0, fac, 0.0, nq,
                                                q1x, q1y, q1z)
                if moment:
                    y = query_coefficient(1, d1x, d1y, d1z, fac, nq, q1x, q1y, q1z)
        else:
            w, dws, dwt = eval_triangle_weight(wc[wcls[i]], c[7], c[8])
            W, fac = _attenuate_inline(w, 1.0, pwhi[i], S)
            if df == TRI_INTERIOR:
                w1 = fac * dws
                w2 = fac * dwt
            elif df == TRI_AB:
                w1 = fac * dws
                w2 = 0.0
            elif df == TRI_AC:
                w1 = fac * dwt
                w2 = 0.0
            else:
                w1 = fac * (dwt - dws)
                w2 = 0.0
            if fac != 0.0:
                nd, d1x, d1y, d1z, d2x, d2y, d2z = feature_directions(k, df, pts[i])
                if nd > 0:
                    nq, q1x, q1y, q1z, _, _, _ = feature_directions(kq, c[6], Q)
                    gwx, gwy, gwz = weight_gradient(nd, d1x, d1y, d1z, d2x, d2y, d2z, w1, w2, nq,
                                                    q1x, q1y, q1z)
                    if moment:
                        y = query_coefficient(nd, d1x, d1y, d1z, w1, nq, q1x, q1y, q1z)
    if d > 0.0:
        inv = W / d
        vx = rx * inv - wgrad_scale * gwx
        vy = ry * inv - wgrad_scale * gwy
        vz = rz * inv - wgrad_scale * gwz
    else:
        vx = -wgrad_scale * gwx
        vy = -wgrad_scale * gwy
        vz = -wgrad_scale * gwz
    mx = my = mz = 0.0
    if moment >= VERTEX_1:
        # vertex mode: the term's derivative for a motion of query vertex 1 or 2 alone, b v +
        # wgrad_scale y (d b / d lambda) r (module notes; b the vertex's barycentric at the pair)
        b = c[4] if moment == VERTEX_1 else c[5]
        db = 0.0
        if y != 0.0:
            qf = c[6]
            if kq == 1:
                db = 1.0 if moment == VERTEX_1 else 0.0
            elif qf == TRI_AB:
                db = 1.0 if moment == VERTEX_1 else 0.0
            elif qf == TRI_AC:
                db = 0.0 if moment == VERTEX_1 else 1.0
            elif qf == TRI_BC:
                db = -1.0 if moment == VERTEX_1 else 1.0
        f = wgrad_scale * y * db
        mx = b * vx + f * rx
        my = b * vy + f * ry
        mz = b * vz + f * rz
    elif moment:
        # the closest point on the query, relative to c
        s = c[4]
        t = c[5]
        px = Q[0] - cx
        py = Q[1] - cy
        pz = Q[2] - cz
        if kq >= 1:
            px += s * (Q[3] - Q[0])
            py += s * (Q[4] - Q[1])
            pz += s * (Q[5] - Q[2])
        if kq == 2:
            px += t * (Q[6] - Q[0])
            py += t * (Q[7] - Q[1])
            pz += t * (Q[8] - Q[2])
        mx = py * vz - pz * vy
        my = pz * vx - px * vz
        mz = px * vy - py * vx
        if y != 0.0:
            f = wgrad_scale * y
            mx += f * (q1y * rz - q1z * ry)
            my += f * (q1z * rx - q1x * rz)
            mz += f * (q1x * ry - q1y * rx)
    return d, W, vx, vy, vz, mx, my, mz


#: ``_pair`` as an ordinary kernel (for the brute-force references: one compiled copy)
pair_terms = numba.njit(**NJIT)(python_function(_pair))


@numba.njit(**NJIT)
def pair_term(tree, i, kq, Q, S, wgrad_scale):
    """Term of data primitive ``i`` (tree order) for query primitive ``(kq, Q)``.

    Returns ``(d, W, vx, vy, vz)`` as :func:`smoothdist._kernels.query.primitive_term`: distance,
    attenuated weight and the gradient numerator ``W unit(r) - wgrad_scale grad W`` (gradients with
    respect to a translation of the query).
    """
    # ``kq < 0`` is a run-time False: the moment reference (``moment=kq >= 0``) shares the
    # compiled pair_terms
    d, W, vx, vy, vz, _, _, _ = pair_terms(tree.kind, tree.pts, tree.wc, tree.wcls, tree.pwhi, i,
                                           kq, Q, S, wgrad_scale, kq < 0, 0.0, 0.0, 0.0,
                                           tree.kind[i])
    return d, W, vx, vy, vz


@numba.njit(**NJIT)
def query_box(kq, Q, qlo, qhi):
    """Fill ``qlo``, ``qhi`` (3,) with the bounding box of the query's ``kq + 1`` vertices."""
    for a in range(3):
        lo = Q[a]
        hi = Q[a]
        for j in range(1, kq + 1):
            v = Q[3 * j + a]
            lo = min(lo, v)
            hi = max(hi, v)
        qlo[a] = lo
        qhi[a] = hi


@numba.njit(**NJIT)
def centroid(kq, Q):
    """Centroid ``(cx, cy, cz)`` of the query's ``kq + 1`` vertices."""
    cx = Q[0]
    cy = Q[1]
    cz = Q[2]
    for j in range(1, kq + 1):
        cx += Q[3 * j]
        cy += Q[3 * j + 1]
        cz += Q[3 * j + 2]
    n = kq + 1.0
    return cx / n, cy / n, cz / n


@numba.njit(**NJIT_INLINE)
def _box_gap2(l0, l1, l2, h0, h1, h2, lo, hi, node):
    """Squared :func:`smoothdist._kernels.box_distance.box_box_distance` of the query box ``l..h``
    (scalars) and a node's box (the same sum of the same squared gaps)."""
    g0 = signed_gap(l0, h0, lo[node, 0], hi[node, 0])
    g1 = signed_gap(l1, h1, lo[node, 1], hi[node, 1])
    g2 = signed_gap(l2, h2, lo[node, 2], hi[node, 2])
    return g0 * g0 + g1 * g1 + g2 * g2


@numba.njit(**NJIT_INLINE)
def _accumulate(m, s, gx, gy, gz, mx, my, mz, d, W, vx, vy, vz, ux, uy, uz, alpha, moment):
    """:func:`smoothdist._kernels.query.logsumexp_accumulate` (the same operations on
    ``m, s, g``), with the moment ``u`` summed like ``v`` when ``moment``."""
    if d < m:
        f = math.exp(-alpha * (m - d))
        s *= f
        gx *= f
        gy *= f
        gz *= f
        if moment:
            mx *= f
            my *= f
            mz *= f
        m = d
    e = math.exp(-alpha * (d - m))
    if moment:
        mx += e * ux
        my += e * uy
        mz += e * uz
    return m, s + W * e, gx + e * vx, gy + e * vy, gz + e * vz, mx, my, mz


@numba.njit(**NJIT_INLINE)
def _far_weight(whi, node, cnt, S):
    """``count * whi**S``: the far-field weight of a node (bounds every replaced term)."""
    wh = whi[node]
    return cnt * (wh if (S == 1.0 or wh == 1.0) else math.exp(S * math.log(wh)))


class _PrimitiveQuery(NamedTuple):
    """What :func:`smooth_traverse`'s traversal functions read about the query primitive."""
    kq: int               # 1 edge, 2 triangle
    Q: np.ndarray         # (9,) its vertices
    qlo: np.ndarray       # (3,) its box
    qhi: np.ndarray
    E: np.ndarray         # (9,) scratch of the box bounds
    L: np.ndarray         # (18,) lever arms (moment 1), else E
    l0: float             # the box as scalars
    l1: float
    l2: float
    h0: float
    h1: float
    h2: float
    qd: float             # the box's diagonal
    beta: float
    b2: float             # beta**2
    ib: float             # (1 - 1e-9) / beta (0 without beta)
    split: float          # 1 / (number of vertices)
    cx: float             # centroid (moment 1)
    cy: float
    cz: float
    alpha: float
    S: float
    wgrad_scale: float
    tol: float
    moment: int
    reach: float          # negligible-term pruning (query.negligible_reach)


@numba.njit(**NJIT_GENERIC)
def no_levers(kq, Q, scratch):
    """``setup`` of the distance: no lever arms (``L`` is the box bounds' scratch) and the
    centroid unused, ``(L, cx, cy, cz)``."""
    return scratch[6:15], 0.0, 0.0, 0.0


@numba.njit(**NJIT_GENERIC)
def no_lever(q, ux, uy, uz):
    """``lever`` of the distance: a far field's moment is 0."""
    return 0.0, 0.0, 0.0


@numba.njit(**NJIT_GENERIC)
def box_gap_far(q, lo, hi, node, lever):
    """``coarse`` (and the ``tol`` rule's far field): the box-box distance and its direction,
    with the kind's ``lever``; ``(delta, ux, uy, uz, ax, ay, az)``."""
    delta, ux, uy, uz = box_box_offset(q.qlo, q.qhi, lo, hi, node)
    ax, ay, az = lever(q, ux, uy, uz)
    return delta, ux, uy, uz, ax, ay, az


@numba.njit(**NJIT_GENERIC)
def halfspace_far(q, lo, hi, node, lever):
    """``fine``: the paper's halfspace test
    (:func:`~smoothdist._kernels.box_distance.box_lower_bound`), with the kind's
    ``lever``."""
    delta, ux, uy, uz = box_lower_bound(q.kq, q.Q, q.qlo, q.qhi, lo, hi, node, q.E)
    ax, ay, az = lever(q, ux, uy, uz)
    return delta, ux, uy, uz, ax, ay, az


@numba.njit(**NJIT_GENERIC)
def exact_box_far(q, lo, hi, node, lever):
    """``coarse`` and ``fine`` with the box test off: the exact primitive-box distance
    (:func:`~smoothdist._kernels.box_distance.box_distance_exact`), no moment."""
    delta, ux, uy, uz = box_distance_exact(q.kq, q.Q, lo, hi, node, q.E)
    return delta, ux, uy, uz, 0.0, 0.0, 0.0


@numba.njit(**NJIT_IR_INLINE)
def _gap_children(tree, q, node):
    """``children``: both children, keyed by squared box-box distance."""
    l = tree.left[node]
    r = tree.right[node]
    return (l, _box_gap2(q.l0, q.l1, q.l2, q.h0, q.h1, q.h2, tree.lo, tree.hi, l),
            r, _box_gap2(q.l0, q.l1, q.l2, q.h0, q.h1, q.h2, tree.lo, tree.hi, r))


@numba.njit(**NJIT_IR_INLINE)
def _prim_skip(tree, q, node, bd2, st):
    """Negligible-term pruning, as in the point kernel."""
    return bd2 >= st[8]


@numba.njit(**NJIT_GENERIC)
def _barnes_hut(tree, q, node, bd2, coarse, fine, lever):
    """Barnes-Hut for a query primitive: ``(far, delta, ux, uy, uz, ax, ay, az)``, the node's
    lower-bound distance ``delta``, its direction ``u`` and the moment lever ``a``.

    The kind's coarse bound (the box-box distance, a lower bound) qualifies the node first; its
    fine bound (the paper's halfspace test,
    :func:`smoothdist._kernels.box_distance.box_lower_bound`) is tried only if the smallest
    query-vertex distance could qualify it, and that only if the box-box distance plus the query
    box's diagonal (an upper bound of it) could. With the box test off both are the exact
    primitive-box distance.
    """
    lo = tree.lo
    hi = tree.hi
    dg = tree.diag[node]
    delta = ux = uy = uz = 0.0
    ax = ay = az = 0.0
    far = False
    if dg * dg < q.b2 * bd2:
        delta, ux, uy, uz, ax, ay, az = coarse(q, lo, hi, node, lever)
        far = True
    else:
        x = dg * q.ib - q.qd
        if (x <= 0.0 or x * x < bd2) and dg < q.beta * _point_box(q.kq, q.Q, lo, hi, node):
            delta, ux, uy, uz, ax, ay, az = fine(q, lo, hi, node, lever)
            far = dg < q.beta * delta
    return far, delta, ux, uy, uz, ax, ay, az


@numba.njit(**NJIT_GENERIC)
def far_field(tree, q, node, bd2, st, coarse, fine, lever):
    """Far fields: Barnes-Hut, then the ``tol`` rule; ``st = (m, s, gx, gy, gz, mx, my, mz,
    cut2, leaves)``. ``coarse``, ``fine``, ``lever``: the traversal kind's far-field functions
    (``_barnes_hut``); each kind's ``approximate`` of the traversal passes its own
    (:func:`distance_far`)."""
    m, s, gx, gy, gz, mx, my, mz, cut2, leaves = st
    cnt = tree.count[node]
    far = False
    delta = ux = uy = uz = 0.0
    ax = ay = az = 0.0
    if cnt > 1 and q.beta > 0.0:
        far, delta, ux, uy, uz, ax, ay, az = _barnes_hut(tree, q, node, bd2, coarse, fine, lever)
    if not far and q.tol > 0.0 and s > 0.0:
        W = _far_weight(tree.whi, node, cnt, q.S)
        if W * math.exp(-q.alpha * (math.sqrt(bd2) - m)) <= q.tol * s:
            delta, ux, uy, uz, ax, ay, az = box_gap_far(q, tree.lo, tree.hi, node, lever)
            far = True
    if not far:
        return False, st
    W = _far_weight(tree.whi, node, cnt, q.S)
    m, s, gx, gy, gz, mx, my, mz = _accumulate(
        m, s, gx, gy, gz, mx, my, mz, delta, W, W * ux, W * uy, W * uz, W * ax, W * ay, W * az,
        q.alpha, q.moment)
    cut = max(m + q.reach, 0.0)
    return True, (m, s, gx, gy, gz, mx, my, mz, cut * cut, leaves + 1)


@numba.njit(**NJIT_GENERIC)
def distance_far(tree, q, node, bd2, st):
    """``approximate`` of the distance: the box-box distance, then the halfspace test."""
    return far_field(tree, q, node, bd2, st, box_gap_far, halfspace_far, no_lever)


@numba.njit(**NJIT_GENERIC)
def exact_box_far_field(tree, q, node, bd2, st):
    """``approximate`` of the distance with the box test off: the exact primitive-box
    distance."""
    return far_field(tree, q, node, bd2, st, exact_box_far, exact_box_far, no_lever)


@numba.njit(**NJIT_GENERIC)
def any_leaf(tree, q, node, st):
    """``leaf`` of the traversal for any kinds of data and query primitives."""
    return _prim_leaf(tree, q, node, st, _closest)


@numba.njit(**NJIT_GENERIC)
def triangles_leaf(tree, q, node, st):
    """``leaf`` of the traversal where the data and the query are triangles only."""
    return _prim_leaf(tree, q, node, st, closest_triangles)


@numba.njit(**NJIT_GENERIC)
def segments_leaf(tree, q, node, st):
    """``leaf`` of the traversal where the data and the query are edges only."""
    return _prim_leaf(tree, q, node, st, closest_segments)


@numba.njit(**NJIT_GENERIC)
def triangles_on_segments_leaf(tree, q, node, st):
    """``leaf`` of the traversal where the query is triangles only and the data edges only."""
    return _prim_leaf(tree, q, node, st, closest_triangles_segments)


@numba.njit(**NJIT_GENERIC)
def segments_on_triangles_leaf(tree, q, node, st):
    """``leaf`` of the traversal where the query is edges only and the data triangles only."""
    return _prim_leaf(tree, q, node, st, closest_segments_triangles)


@numba.njit(**NJIT_GENERIC)
def _prim_leaf(tree, q, node, st, closest):
    """A leaf's data primitives against the query primitive, exactly; ``closest``: the pair
    kernel of the kinds the traversal meets (:func:`_closest` for any)."""
    if tree.left[node] >= 0:
        return False, st
    m, s, gx, gy, gz, mx, my, mz, cut2, leaves = st
    kq = q.kq
    kind = tree.kind
    st_ = tree.start[node]
    cnt = tree.count[node]
    for i in range(st_, st_ + cnt):
        # one copy of the term (a second for edges against edges, in which the compiler knew
        # both kinds, was no faster and cost the first call 0.6 s of compiling)
        k = kind[i]
        d, W, vx, vy, vz, tx, ty, tz = _pair_term(
            closest(kind, tree.pts, i, kq, q.Q, k), kind, tree.pts, tree.wc, tree.wcls,
            tree.pwhi, i, kq, q.Q, q.S, q.wgrad_scale, q.moment, q.cx, q.cy, q.cz, k)
        m, s, gx, gy, gz, mx, my, mz = _accumulate(
            m, s, gx, gy, gz, mx, my, mz, d, W, vx, vy, vz, tx, ty, tz, q.alpha, q.moment)
    cut = max(m + q.reach, 0.0)
    return True, (m, s, gx, gy, gz, mx, my, mz, cut * cut, leaves + cnt)


@numba.njit(**NJIT_GENERIC)
def smooth_traverse(tree, kq, Q, alpha, beta, S, wgrad_scale, stack, dstack, scratch, tol, moment,
                    setup, far, leaf):
    """The traversal of the distance kernels (:func:`smooth_distance_primitive_tasks`) and of
    :mod:`smoothdist._kernels.mesh_moment`'s (one code for all, so that their ``d_hat`` and
    gradients agree bit for bit).

    ``moment, setup, far`` are the kind, fixed by each caller: ``moment`` False (the
    distance), True (the moment about the query's centroid) or ``VERTEX_1`` / ``VERTEX_2`` (the
    motion of one query vertex), the function that gives the lever arms
    (``setup(kq, Q, scratch)``), the traversal's far-field function (:func:`far_field` with
    the kind's bounds, e.g. :func:`distance_far`) and its leaf function (:func:`any_leaf`, or
    :func:`triangles_leaf`, :func:`segments_leaf`, :func:`triangles_on_segments_leaf` or
    :func:`segments_on_triangles_leaf` where the data and the query are each of one kind: one
    pair kernel compiled instead of all). They are arguments, not run-time flags, so
    that a kernel compiles only its own kind's far fields (the distance neither the moment's
    nor the box-test-off's; performance guide, "Cold start"). Each caller names the functions
    in its call, so that numba merges them into it (``NJIT_GENERIC``); kept in a tuple they
    would be compiled on their own, and stored in one that a kernel builds, numba would keep
    their Python objects' addresses, and the kernel could not be cached.

    ``scratch`` holds 15 float64 (33 for the moment). Returns
    ``(d_hat, gx, gy, gz, mx, my, mz, nodes_visited, leaves_visited)``; the moment is 0 for
    the distance.

    The keys are squared box-box distances; Barnes-Hut tests ``diag**2 < beta**2 d**2``, as the
    point kernel does, and tries finer bounds only where they could help (``_barnes_hut``).
    With the box test off (:func:`exact_box_far_field`) every Barnes-Hut candidate's distance is the
    exact primitive-box distance
    (:func:`smoothdist._kernels.box_distance.box_distance_exact`, the quadratic program the paper's
    halfspace test avoids) instead of the box-box distance or the halfspace bound; the same
    traversal otherwise.
    """
    qlo = scratch[0:3]
    qhi = scratch[3:6]
    E = scratch[6:15]
    query_box(kq, Q, qlo, qhi)
    l0, l1, l2 = qlo[0], qlo[1], qlo[2]
    h0, h1, h2 = qhi[0], qhi[1], qhi[2]
    L, cx, cy, cz = setup(kq, Q, scratch)
    q = _PrimitiveQuery(
        kq, Q, qlo, qhi, E, L, l0, l1, l2, h0, h1, h2,
        # any query vertex is within the query box's diagonal of the box-box closest point
        math.sqrt((h0 - l0) ** 2 + (h1 - l1) ** 2 + (h2 - l2) ** 2),
        beta, beta * beta, (1.0 - 1e-9) / beta if beta > 0.0 else 0.0,
        # vertex modes: a far field's gradient is split equally among the query's vertices
        1.0 / (kq + 1), cx, cy, cz, alpha, S, wgrad_scale, tol, moment,
        # negligible-term pruning, as in the point kernel: a node at box-box distance
        # >= m + reach adds less than 2**-53 x n_B / N of the sum
        negligible_reach(tree, ZERO, S, alpha))
    (m, s, gx, gy, gz, mx, my, mz, _, leaves), nodes = nearest_first(
        tree, q, (np.inf, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, np.inf, ZERO), stack, dstack, ZERO,
        _box_gap2(l0, l1, l2, h0, h1, h2, tree.lo, tree.hi, ZERO), _prim_skip, far, leaf,
        _gap_children, always)
    inv = 1.0 / s
    return (m - math.log(s) / alpha, gx * inv, gy * inv, gz * inv, mx * inv, my * inv, mz * inv,
            nodes, leaves)


@numba.njit(**NJIT)
def _point_box(kq, Q, lo, hi, node):
    """Smallest distance from a query vertex to a node box (an upper bound of the query's)."""
    best = np.inf
    for j in range(kq + 1):
        d2 = 0.0
        for a in range(3):
            v = Q[3 * j + a]
            if v < lo[node, a]:
                d2 += (lo[node, a] - v) ** 2
            elif v > hi[node, a]:
                d2 += (v - hi[node, a]) ** 2
        best = min(best, d2)
    return math.sqrt(best)


@numba.njit(**NJIT)
def smooth_distance_brute_primitive(tree, kq, Q, alpha, S, wgrad_scale):
    """``d_hat(g)`` and gradient summing every data primitive (reference; no tree)."""
    m = np.inf
    s = 0.0
    gx = 0.0
    gy = 0.0
    gz = 0.0
    for i in range(tree.kind.size):
        d, W, vx, vy, vz = pair_term(tree, i, kq, Q, S, wgrad_scale)
        m, s, gx, gy, gz = logsumexp_accumulate(m, s, gx, gy, gz, d, W, vx, vy, vz, alpha)
    return m - math.log(s) / alpha, gx / s, gy / s, gz / s


class _PairQuery(NamedTuple):
    """An edge or triangle query of the exact kernel: its kind, vertices (9,) and box (3,)."""
    kq: int
    Q: np.ndarray
    qlo: np.ndarray
    qhi: np.ndarray


@numba.njit(**NJIT_IR_INLINE)
def _box_box_children(tree, q, node):
    """``children`` of the exact primitive query: keyed by box-box distance."""
    l = tree.left[node]
    r = tree.right[node]
    return (l, box_box_distance(q.qlo, q.qhi, tree.lo, tree.hi, l),
            r, box_box_distance(q.qlo, q.qhi, tree.lo, tree.hi, r))


@numba.njit(**NJIT_IR_INLINE)
def _gap_beyond_best(tree, q, node, key, st):
    """Branch and bound on the box-box distance against the best squared distance."""
    return key * key >= st[0]


@numba.njit(**NJIT_IR_INLINE)
def _gap_within_best(key, st):
    """Push a child only if its box-box distance is below the best so far."""
    return key * key < st[0]


@numba.njit(**NJIT_IR_INLINE)
def _pair_leaf(tree, q, node, st):
    """A leaf's closest pairs; ``st = (best d2, prim, r, leaves)``."""
    return _exact_leaf(tree, q, node, st, any_pair)


@numba.njit(**NJIT_IR_INLINE)
def _triangle_pair_leaf(tree, q, node, st):
    """:func:`_pair_leaf` where the data and the query are triangles only."""
    return _exact_leaf(tree, q, node, st, closest_triangles)


@numba.njit(**NJIT_IR_INLINE)
def _segment_pair_leaf(tree, q, node, st):
    """:func:`_pair_leaf` where the data and the query are edges only."""
    return _exact_leaf(tree, q, node, st, closest_segments)


@numba.njit(**NJIT_GENERIC)
def any_pair(kind, P, i, kq, Q, k):
    """:func:`smoothdist._kernels.closest_pair.closest_pair` of query ``(kq, Q)`` and data
    primitive ``i`` of kind ``k`` (any kinds), in the pair functions' arguments."""
    return closest_pair(kq, Q, k, P[i])


@numba.njit(**NJIT_GENERIC)
def _exact_leaf(tree, q, node, st, closest):
    """A leaf's closest pairs with the pair function ``closest`` (:func:`any_pair`, or one
    kind's: :func:`closest_triangles`, :func:`closest_segments`)."""
    if tree.left[node] >= 0:
        return False, st
    best, bi, brx, bry, brz, leaves = st
    st_ = tree.start[node]
    cnt = tree.count[node]
    kind = tree.kind
    for i in range(st_, st_ + cnt):
        c = closest(kind, tree.pts, i, q.kq, q.Q, kind[i])
        if c[0] < best:
            best = c[0]
            bi = i
            brx = c[1]
            bry = c[2]
            brz = c[3]
    return True, (best, bi, brx, bry, brz, leaves + cnt)


@numba.njit(**NJIT)
def exact_distance_primitive(tree, kq, Q, stack, dstack, scratch, bound2=np.inf):
    """Exact distance from an edge or triangle query to the data by branch and bound.

    Prunes with the distance between the query's and the node's boxes (a lower bound for the whole
    query, unlike the authors' first-vertex distance). Returns
    ``(d, ux, uy, uz, prim, nodes_visited, leaves_visited)``: the distance, the unit translation
    gradient ``r / d`` (0 on contact) and the closest primitive (mesh numbering). Only pairs at
    squared distance ``< bound2`` are considered; with none, ``d = inf`` and ``prim = -1``.
    """
    return _exact_primitive(tree, kq, Q, stack, dstack, scratch, bound2, _pair_leaf)


@numba.njit(**NJIT_GENERIC)
def _exact_primitive(tree, kq, Q, stack, dstack, scratch, bound2, leaf):
    """:func:`exact_distance_primitive` with the leaf function ``leaf`` (:func:`_pair_leaf`, or
    one kind's)."""
    qlo = scratch[0:3]
    qhi = scratch[3:6]
    query_box(kq, Q, qlo, qhi)
    (best, bi, brx, bry, brz, leaves), nodes = nearest_first(
        tree, _PairQuery(kq, Q, qlo, qhi), (bound2, NONE, 0.0, 0.0, 0.0, ZERO), stack, dstack, ZERO,
        box_box_distance(qlo, qhi, tree.lo, tree.hi, ZERO), _gap_beyond_best, no_far_field,
        leaf, _box_box_children, _gap_within_best)
    if bi < 0:
        return np.inf, 0.0, 0.0, 0.0, -1, nodes, leaves
    d = math.sqrt(best)
    if d > 0.0:
        return d, brx / d, bry / d, brz / d, tree.orig[bi], nodes, leaves
    return 0.0, 0.0, 0.0, 0.0, tree.orig[bi], nodes, leaves


@numba.njit(**NJIT_IR_INLINE)
def task_scratch(tree, n):
    """Work space of one task of the primitive kernels: the traversal's two stacks
    (``tree.depth + 4``: int64 nodes, float64 keys) and ``n`` float64 of scratch."""
    k = tree.depth + 4
    return np.empty(k, dtype=np.int64), np.empty(k), np.empty(n)


@numba.njit(**NJIT_GENERIC)
def _distance_tasks(tree, qkind, qpts, alpha, beta, S, wgrad_scale, out_d, out_g, out_nodes,
                    out_leaves, tol, far, leaf, ntasks, task0, task1):
    """The body of :func:`smooth_distance_primitive_tasks` with the far-field and leaf functions
    ``far``, ``leaf`` (:func:`smooth_traverse`)."""
    stack, dstack, scratch = task_scratch(tree, 15)
    for task in range(task0, task1):
        for j in range(task, qkind.size, ntasks):
            d, gx, gy, gz, _, _, _, nodes, leaves = smooth_traverse(
                tree, qkind[j], qpts[j], alpha, beta, S, wgrad_scale, stack, dstack, scratch,
                tol, False, no_levers, far, leaf)
            out_d[j] = d
            out_g[j, 0] = gx
            out_g[j, 1] = gy
            out_g[j, 2] = gz
            out_nodes[j] = nodes
            out_leaves[j] = leaves


@numba.njit(**NJIT)
def smooth_distance_primitive_tasks(tree, qkind, qpts, alpha, beta, S, wgrad_scale, out_d, out_g,
                                    out_nodes, out_leaves, tol, ntasks, task0, task1):
    """``d_hat`` and translation gradient of every edge and triangle query, as a serial task
    kernel (point queries: the point kernel's
    :func:`smoothdist._kernels.query.smooth_distance_tasks`).

    ``qkind (m,)`` int64 (1 or 2), ``qpts (m, 9)`` float64; fills ``out_d (m,)``,
    ``out_g (m, 3)``, ``out_nodes``, ``out_leaves (m,)``.

    ``tol > 0`` adds a second far-field rule (docs/design-notes.md §3, not in the paper): a
    node whose far-field term ``count * whi**S * exp(-alpha delta)`` (``delta`` its box-box
    distance) is at most ``tol`` times the sum so far is replaced by that term. It is the same
    overestimate of the subtree's sum as Barnes-Hut's, so ``d_hat`` only decreases, by at most
    ``-log(1 - k tol) / alpha`` for ``k`` such nodes (``k tol < 1``).

    Runs tasks ``task0 <= t < task1`` of ``ntasks`` strided tasks (task ``t`` takes primitives
    ``t, t + ntasks, ...``), GIL-free, from Python threads
    (:func:`smoothdist.schedule.run_tasks`): no ``prange`` loop, which would compile the whole
    traversal again (:mod:`smoothdist.schedule`). Values do not depend on the split.
    """
    _distance_tasks(tree, qkind, qpts, alpha, beta, S, wgrad_scale, out_d, out_g, out_nodes,
                    out_leaves, tol, distance_far, any_leaf, ntasks, task0, task1)


@numba.njit(**NJIT)
def triangle_distance_tasks(tree, qkind, qpts, alpha, beta, S, wgrad_scale, out_d, out_g,
                            out_nodes, out_leaves, tol, ntasks, task0, task1):
    """:func:`smooth_distance_primitive_tasks` where the data and the query are triangles only:
    a kernel of its own, so that a first call between triangle meshes compiles the
    triangle-triangle pair kernel only (performance guide, "Cold start")."""
    _distance_tasks(tree, qkind, qpts, alpha, beta, S, wgrad_scale, out_d, out_g, out_nodes,
                    out_leaves, tol, distance_far, triangles_leaf, ntasks, task0, task1)


@numba.njit(**NJIT)
def segment_distance_tasks(tree, qkind, qpts, alpha, beta, S, wgrad_scale, out_d, out_g,
                           out_nodes, out_leaves, tol, ntasks, task0, task1):
    """:func:`smooth_distance_primitive_tasks` where the data and the query are edges only (the
    segment-segment pair kernel only)."""
    _distance_tasks(tree, qkind, qpts, alpha, beta, S, wgrad_scale, out_d, out_g, out_nodes,
                    out_leaves, tol, distance_far, segments_leaf, ntasks, task0, task1)


@numba.njit(**NJIT)
def triangles_on_segments_tasks(tree, qkind, qpts, alpha, beta, S, wgrad_scale, out_d, out_g,
                                out_nodes, out_leaves, tol, ntasks, task0, task1):
    """:func:`smooth_distance_primitive_tasks` where the query is triangles only and the data
    edges only (the triangle-segment pair kernel only)."""
    _distance_tasks(tree, qkind, qpts, alpha, beta, S, wgrad_scale, out_d, out_g, out_nodes,
                    out_leaves, tol, distance_far, triangles_on_segments_leaf, ntasks, task0,
                    task1)


@numba.njit(**NJIT)
def segments_on_triangles_tasks(tree, qkind, qpts, alpha, beta, S, wgrad_scale, out_d, out_g,
                                out_nodes, out_leaves, tol, ntasks, task0, task1):
    """:func:`smooth_distance_primitive_tasks` where the query is edges only and the data
    triangles only (the segment-triangle pair kernel only)."""
    _distance_tasks(tree, qkind, qpts, alpha, beta, S, wgrad_scale, out_d, out_g, out_nodes,
                    out_leaves, tol, distance_far, segments_on_triangles_leaf, ntasks, task0,
                    task1)


@numba.njit(**NJIT)
def exact_box_primitive_tasks(tree, qkind, qpts, alpha, beta, S, wgrad_scale, out_d, out_g,
                              out_nodes, out_leaves, tol, ntasks, task0, task1):
    """:func:`smooth_distance_primitive_tasks` with the box test off: every Barnes-Hut
    candidate at its exact primitive-box distance (``MeshDistance(box_test=False)``; a kernel
    of its own, so that the default compiles none of it)."""
    _distance_tasks(tree, qkind, qpts, alpha, beta, S, wgrad_scale, out_d, out_g, out_nodes,
                    out_leaves, tol, exact_box_far_field, any_leaf, ntasks, task0, task1)


@numba.njit(**NJIT)
def smooth_distance_primitives_brute(tree, qkind, qpts, alpha, S, wgrad_scale, out_d, out_g):
    """:func:`smooth_distance_primitive_tasks` summing every data primitive for every query
    primitive (the reference of ``method="brute"``; serial, no tree, no Barnes-Hut)."""
    for j in range(qkind.size):
        d, gx, gy, gz = smooth_distance_brute_primitive(tree, qkind[j], qpts[j], alpha, S,
                                                        wgrad_scale)
        out_d[j] = d
        out_g[j, 0] = gx
        out_g[j, 1] = gy
        out_g[j, 2] = gz


@numba.njit(**NJIT)
def exact_distance_primitive_tasks(tree, qkind, qpts, bound2, out_d, out_g, out_prim, ntasks,
                                   task0, task1):
    """Exact distance, unit translation gradient and closest data primitive per query primitive,
    as a serial task kernel (tasks ``task0 <= t < task1`` of ``ntasks``, as
    :func:`smooth_distance_primitive_tasks`).

    Edge and triangle queries only look for pairs closer than ``sqrt(bound2)`` (an upper bound of
    the minimum over all query primitives, e.g. from the query vertices); the others get
    ``inf`` and ``-1``. Point queries are always exact.
    """
    stack, dstack, scratch = task_scratch(tree, 15)
    root = ZERO
    for task in range(task0, task1):
        for j in range(task, qkind.size, ntasks):
            kq = qkind[j]
            Q = qpts[j]
            if kq == 0:
                d, gx, gy, gz, p, nodes, leaves = exact_distance_point(
                    tree, Q[0], Q[1], Q[2], stack, dstack, root, -1.0)
            else:
                d, gx, gy, gz, p, nodes, leaves = exact_distance_primitive(
                    tree, kq, Q, stack, dstack, scratch, bound2)
            out_d[j] = d
            out_g[j, 0] = gx
            out_g[j, 1] = gy
            out_g[j, 2] = gz
            out_prim[j] = p


@numba.njit(**NJIT_PARALLEL)
def exact_distance_primitives(tree, qkind, qpts, bound2, out_d, out_g, out_prim, ntasks):
    """:func:`exact_distance_primitive_tasks` over ``ntasks`` tasks in a ``prange`` loop, for
    large query meshes: numba's own threads start a short call sooner than Python threads do
    (the bunny against itself, 6,966 triangles, 2 threads: 0.39 ms against 0.67 ms for the
    primitives' pass; the smooth distance's passes, ten times longer, gain nothing from it).
    Compiled only when a query mesh of ``SERIAL_BELOW["exact"]`` primitives or more is
    measured exactly."""
    for task in prange(ntasks):
        exact_distance_primitive_tasks(tree, qkind, qpts, bound2, out_d, out_g, out_prim, ntasks,
                                       np.int64(task), np.int64(task) + 1)


@numba.njit(**NJIT_GENERIC)
def _exact_kind_tasks(tree, qpts, bound2, out_d, out_g, out_prim, ntasks, task0, task1, kq, leaf):
    """:func:`exact_distance_primitive_tasks` where every query primitive is of kind ``kq`` and
    ``leaf`` is that kind pair's leaf (no point branch, one pair kernel)."""
    stack, dstack, scratch = task_scratch(tree, 15)
    for task in range(task0, task1):
        for j in range(task, qpts.shape[0], ntasks):
            d, gx, gy, gz, p, nodes, leaves = _exact_primitive(
                tree, kq, qpts[j], stack, dstack, scratch, bound2, leaf)
            out_d[j] = d
            out_g[j, 0] = gx
            out_g[j, 1] = gy
            out_g[j, 2] = gz
            out_prim[j] = p


@numba.njit(**NJIT)
def exact_triangle_tasks(tree, qkind, qpts, bound2, out_d, out_g, out_prim, ntasks, task0,
                         task1):
    """:func:`exact_distance_primitive_tasks` where the data and the query are triangles only
    (the triangle-triangle pair kernel only: performance guide, "Cold start")."""
    _exact_kind_tasks(tree, qpts, bound2, out_d, out_g, out_prim, ntasks, task0, task1,
                      np.int64(2), _triangle_pair_leaf)


@numba.njit(**NJIT)
def exact_segment_tasks(tree, qkind, qpts, bound2, out_d, out_g, out_prim, ntasks, task0,
                        task1):
    """:func:`exact_distance_primitive_tasks` where the data and the query are edges only."""
    _exact_kind_tasks(tree, qpts, bound2, out_d, out_g, out_prim, ntasks, task0, task1,
                      np.int64(1), _segment_pair_leaf)


@numba.njit(**NJIT_PARALLEL)
def exact_triangles(tree, qkind, qpts, bound2, out_d, out_g, out_prim, ntasks):
    """:func:`exact_distance_primitives` where the data and the query are triangles only."""
    for task in prange(ntasks):
        exact_triangle_tasks(tree, qkind, qpts, bound2, out_d, out_g, out_prim, ntasks,
                           np.int64(task), np.int64(task) + 1)


@numba.njit(**NJIT_PARALLEL)
def exact_segments(tree, qkind, qpts, bound2, out_d, out_g, out_prim, ntasks):
    """:func:`exact_distance_primitives` where the data and the query are edges only."""
    for task in prange(ntasks):
        exact_segment_tasks(tree, qkind, qpts, bound2, out_d, out_g, out_prim, ntasks,
                           np.int64(task), np.int64(task) + 1)


@numba.njit(**NJIT)
def nearest_vertex_distance(tree, X):
    """Smallest exact distance from the rows of ``X (n, 3)`` to the data (serial)."""
    k = tree.depth + 4
    stack = np.empty(k, dtype=np.int64)
    dstack = np.empty(k)
    best = np.inf
    for i in range(X.shape[0]):
        d = exact_distance_point(tree, X[i, 0], X[i, 1], X[i, 2], stack, dstack, ZERO, -1.0)[0]
        best = min(best, d)
    return best
