"""Kernels: smooth and exact distance from one query primitive (point, edge, triangle) to a tree.

The paper's generalized query primitives (Madan & Levin 2022, Sec. 3.4): the smooth distance from a
query primitive ``g`` to the data mesh is

    d_hat(g) = -(1/alpha) log sum_i W_i exp(-alpha d(f_i, g)),

with ``d(f_i, g)`` the exact primitive-primitive distance (:mod:`smoothdist.closest_pair`) and
``W_i`` the data primitive's weight at the data-side barycentrics of the closest pair. Its gradient
is with respect to a rigid translation ``tau`` of ``g``:

    grad d(f_i, g) = unit(r),  r = (closest point on g) - (closest point on f_i),

and the weight's gradient goes through the closest pair's data barycentrics ``phi``: on the pair of
active features (the faces of both simplices the closest points lie in), the stationarity
conditions ``D^T r = 0`` and ``Q^T r = 0`` (``D``, ``Q`` the features' edge directions) give
``d[phi, lambda] / d tau = (M^T M)^-1 M^T`` with ``M = [D, -Q]``. For a point query this is the
point kernel's projection Jacobian (:func:`smoothdist.query.primitive_term`).

Traversal as for points (:func:`smoothdist.query.smooth_distance_point`): an explicit stack,
nearest child first by the cheap box-box distance. Barnes-Hut replaces a node by
``count * whi**S * exp(-alpha delta)`` with ``delta`` a lower bound of the query-box distance: the
box-box distance when that already satisfies ``diag < beta delta``, else
:func:`smoothdist.box_distance.box_lower_bound` (the paper's halfspace test, done
conservatively). So the far field overestimates the subtree's sum and ``d_hat_beta <= d_hat_0``.
Point queries use the point kernels themselves.
"""

import math

import numba
import numpy as np
from numba import prange

from smoothdist._config import NJIT, NJIT_PARALLEL
from smoothdist.box_distance import box_box_distance, box_box_offset, box_lower_bound
from smoothdist.closest_pair import closest_pair
from smoothdist.closest_point import (SEG_INTERIOR, TRI_AB, TRI_AC, TRI_BC, TRI_INTERIOR)
from smoothdist.query import (DEFAULT_TOL, _attenuate, exact_distance_point, logsumexp_accumulate,
                              push_nearest_first, smooth_distance_point)
from smoothdist.weights import eval_edge_weight, eval_triangle_weight

#: number of parallel tasks; task ``c`` takes query primitives ``c, c + TASKS, ...`` so that the
#: expensive ones (near the data, usually contiguous in a mesh) are spread over all threads
TASKS = 64


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


@numba.njit(**NJIT)
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


@numba.njit(**NJIT)
def pair_term(tree, i, kq, Q, S, wgs):
    """Term of data primitive ``i`` (tree order) for query primitive ``(kq, Q)``.

    Returns ``(d, W, vx, vy, vz)`` as :func:`smoothdist.query.primitive_term`: distance,
    attenuated weight and the gradient numerator ``W unit(r) - wgs grad W`` (gradients with
    respect to a translation of the query).
    """
    k = tree.kind[i]
    P = tree.pts[i]
    c = closest_pair(kq, Q, k, P)
    d = math.sqrt(c[0])
    rx = c[1]
    ry = c[2]
    rz = c[3]
    W = 1.0
    gwx = 0.0
    gwy = 0.0
    gwz = 0.0
    if k != 0:
        df = c[9]
        if k == 1:
            w, dw = eval_edge_weight(tree.wc[i], c[7])
            W, fac = _attenuate(w, dw, tree.pwhi[i], S)
            w1 = fac
            w2 = 0.0
        else:
            w, dws, dwt = eval_triangle_weight(tree.wc[i], c[7], c[8])
            W, fac = _attenuate(w, 1.0, tree.pwhi[i], S)
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
            nd, d1x, d1y, d1z, d2x, d2y, d2z = feature_directions(k, df, P)
            if nd > 0:
                nq, q1x, q1y, q1z, q2x, q2y, q2z = feature_directions(kq, c[6], Q)
                gwx, gwy, gwz = weight_gradient(nd, d1x, d1y, d1z, d2x, d2y, d2z, w1, w2, nq,
                                                q1x, q1y, q1z)
    if d > 0.0:
        inv = W / d
        return d, W, rx * inv - wgs * gwx, ry * inv - wgs * gwy, rz * inv - wgs * gwz
    return d, W, -wgs * gwx, -wgs * gwy, -wgs * gwz


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
def smooth_distance_primitive(tree, kq, Q, alpha, beta, S, wgs, stack, dstack, scratch,
                              tol=DEFAULT_TOL):
    """Smooth distance ``d_hat(g)`` and its translation gradient for an edge or triangle query.

    ``Q (9,)`` the query's vertices, ``kq`` 1 or 2; ``scratch (15,)`` float64 work space; other
    arguments as :func:`smoothdist.query.smooth_distance_point`. Returns
    ``(d_hat, gx, gy, gz, nodes_visited, leaves_visited)``.

    ``tol > 0`` adds a second far-field rule (docs/design-notes.md §3, not in the paper): a
    node whose far-field term ``count * whi**S * exp(-alpha delta)`` (``delta`` its box-box
    distance) is at most ``tol`` times the sum so far is replaced by that term. It is the same
    overestimate of the subtree's sum as Barnes-Hut's, so ``d_hat`` only decreases, by at most
    ``-log(1 - k tol) / alpha`` for ``k`` such nodes (``k tol < 1``).
    """
    qlo = scratch[0:3]
    qhi = scratch[3:6]
    E = scratch[6:15]
    query_box(kq, Q, qlo, qhi)
    m = np.inf
    s = 0.0
    gx = 0.0
    gy = 0.0
    gz = 0.0
    nodes = 0
    leaves = 0
    lo = tree.lo
    hi = tree.hi
    stack[0] = 0
    dstack[0] = box_box_distance(qlo, qhi, lo, hi, 0)
    sp = 1
    while sp > 0:
        sp -= 1
        node = stack[sp]
        bd = dstack[sp]
        nodes += 1
        cnt = tree.count[node]
        far = False
        delta = ux = uy = uz = 0.0
        if cnt > 1 and beta > 0.0:
            dg = tree.diag[node]
            if dg < beta * bd:
                # the box-box distance (a lower bound) already qualifies the node
                delta, ux, uy, uz = box_box_offset(qlo, qhi, lo, hi, node)
                far = True
            elif dg < beta * _point_box(kq, Q, lo, hi, node):
                # the box distance is at most any vertex's: only then can the finer bound help
                delta, ux, uy, uz = box_lower_bound(kq, Q, qlo, qhi, lo, hi, node, E)
                far = dg < beta * delta
        if not far and tol > 0.0 and s > 0.0:
            wh = tree.whi[node]
            W = cnt * (wh if (S == 1.0 or wh == 1.0) else math.exp(S * math.log(wh)))
            if W * math.exp(-alpha * (bd - m)) <= tol * s:
                delta, ux, uy, uz = box_box_offset(qlo, qhi, lo, hi, node)
                far = True
        if far:
            wh = tree.whi[node]
            W = cnt * (wh if (S == 1.0 or wh == 1.0) else math.exp(S * math.log(wh)))
            m, s, gx, gy, gz = logsumexp_accumulate(m, s, gx, gy, gz, delta, W, W * ux, W * uy,
                                                    W * uz, alpha)
            leaves += 1
            continue
        l = tree.left[node]
        if l < 0:
            st = tree.start[node]
            for i in range(st, st + cnt):
                d, W, vx, vy, vz = pair_term(tree, i, kq, Q, S, wgs)
                m, s, gx, gy, gz = logsumexp_accumulate(m, s, gx, gy, gz, d, W, vx, vy, vz,
                                                        alpha)
            leaves += cnt
            continue
        r = tree.right[node]
        dl = box_box_distance(qlo, qhi, lo, hi, l)
        dr = box_box_distance(qlo, qhi, lo, hi, r)
        sp = push_nearest_first(stack, dstack, sp, l, dl, r, dr)
    inv = 1.0 / s
    return m - math.log(s) / alpha, gx * inv, gy * inv, gz * inv, nodes, leaves


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
def smooth_distance_brute_primitive(tree, kq, Q, alpha, S, wgs):
    """``d_hat(g)`` and gradient summing every data primitive (reference; no tree)."""
    m = np.inf
    s = 0.0
    gx = 0.0
    gy = 0.0
    gz = 0.0
    for i in range(tree.kind.size):
        d, W, vx, vy, vz = pair_term(tree, i, kq, Q, S, wgs)
        m, s, gx, gy, gz = logsumexp_accumulate(m, s, gx, gy, gz, d, W, vx, vy, vz, alpha)
    return m - math.log(s) / alpha, gx / s, gy / s, gz / s


@numba.njit(**NJIT)
def exact_distance_primitive(tree, kq, Q, stack, dstack, scratch, bound2=np.inf):
    """Exact distance from an edge or triangle query to the data by branch and bound.

    Prunes with the distance between the query's and the node's boxes (a lower bound for the whole
    query, unlike the authors' first-vertex distance). Returns
    ``(d, ux, uy, uz, prim, nodes_visited, leaves_visited)``: the distance, the unit translation
    gradient ``r / d`` (0 on contact) and the closest primitive (mesh numbering). Only pairs at
    squared distance ``< bound2`` are considered; with none, ``d = inf`` and ``prim = -1``.
    """
    qlo = scratch[0:3]
    qhi = scratch[3:6]
    query_box(kq, Q, qlo, qhi)
    best = bound2
    bi = -1
    brx = 0.0
    bry = 0.0
    brz = 0.0
    nodes = 0
    leaves = 0
    lo = tree.lo
    hi = tree.hi
    stack[0] = 0
    dstack[0] = box_box_distance(qlo, qhi, lo, hi, 0)
    sp = 1
    while sp > 0:
        sp -= 1
        node = stack[sp]
        if dstack[sp] * dstack[sp] >= best:
            continue
        nodes += 1
        l = tree.left[node]
        if l < 0:
            st = tree.start[node]
            for i in range(st, st + tree.count[node]):
                c = closest_pair(kq, Q, tree.kind[i], tree.pts[i])
                leaves += 1
                if c[0] < best:
                    best = c[0]
                    bi = i
                    brx = c[1]
                    bry = c[2]
                    brz = c[3]
            continue
        r = tree.right[node]
        dl = box_box_distance(qlo, qhi, lo, hi, l)
        dr = box_box_distance(qlo, qhi, lo, hi, r)
        if dl <= dr:
            if dr * dr < best:
                stack[sp] = r
                dstack[sp] = dr
                sp += 1
            if dl * dl < best:
                stack[sp] = l
                dstack[sp] = dl
                sp += 1
        else:
            if dl * dl < best:
                stack[sp] = l
                dstack[sp] = dl
                sp += 1
            if dr * dr < best:
                stack[sp] = r
                dstack[sp] = dr
                sp += 1
    if bi < 0:
        return np.inf, 0.0, 0.0, 0.0, -1, nodes, leaves
    d = math.sqrt(best)
    if d > 0.0:
        return d, brx / d, bry / d, brz / d, tree.orig[bi], nodes, leaves
    return 0.0, 0.0, 0.0, 0.0, tree.orig[bi], nodes, leaves


@numba.njit(**NJIT)
def _smooth_task(tree, qkind, qpts, alpha, beta, S, wgs, brute, out_d, out_g, out_nodes,
                 out_leaves, tol, task, ntasks):
    """Query primitives ``task, task + ntasks, ...`` of :func:`smooth_distance_primitives`."""
    k = tree.depth + 4
    stack = np.empty(k, dtype=np.int64)
    dstack = np.empty(k)
    scratch = np.empty(15)
    for j in range(task, qkind.size, ntasks):
        kq = qkind[j]
        Q = qpts[j]
        nodes = 0
        leaves = tree.kind.size
        if brute:
            d, gx, gy, gz = smooth_distance_brute_primitive(tree, kq, Q, alpha, S, wgs)
        elif kq == 0:
            d, gx, gy, gz, nodes, leaves = smooth_distance_point(
                tree, Q[0], Q[1], Q[2], alpha, beta, S, wgs, stack, dstack)
        else:
            d, gx, gy, gz, nodes, leaves = smooth_distance_primitive(
                tree, kq, Q, alpha, beta, S, wgs, stack, dstack, scratch, tol)
        out_d[j] = d
        out_g[j, 0] = gx
        out_g[j, 1] = gy
        out_g[j, 2] = gz
        out_nodes[j] = nodes
        out_leaves[j] = leaves


@numba.njit(**NJIT_PARALLEL)
def smooth_distance_primitives(tree, qkind, qpts, alpha, beta, S, wgs, brute, out_d, out_g,
                               out_nodes, out_leaves, tol=DEFAULT_TOL):
    """``d_hat`` and translation gradient of every query primitive, in parallel.

    ``qkind (m,)`` int64, ``qpts (m, 9)`` float64; fills ``out_d (m,)``, ``out_g (m, 3)``,
    ``out_nodes``, ``out_leaves (m,)``. ``brute`` sums every data primitive (reference).
    ``tol``: see :func:`smooth_distance_primitive` (edge and triangle queries only).
    """
    ntasks = min(qkind.size, TASKS)
    for task in prange(ntasks):
        _smooth_task(tree, qkind, qpts, alpha, beta, S, wgs, brute, out_d, out_g, out_nodes,
                     out_leaves, tol, task, ntasks)


@numba.njit(**NJIT)
def smooth_distance_primitives_serial(tree, qkind, qpts, alpha, beta, S, wgs, brute, out_d,
                                      out_g, out_nodes, out_leaves, tol=DEFAULT_TOL):
    """:func:`smooth_distance_primitives` on the calling thread (small query meshes)."""
    _smooth_task(tree, qkind, qpts, alpha, beta, S, wgs, brute, out_d, out_g, out_nodes,
                 out_leaves, tol, 0, 1)


@numba.njit(**NJIT)
def _exact_task(tree, qkind, qpts, bound2, out_d, out_g, out_prim, task, ntasks):
    """Query primitives ``task, task + ntasks, ...`` of :func:`exact_distance_primitives`."""
    k = tree.depth + 4
    stack = np.empty(k, dtype=np.int64)
    dstack = np.empty(k)
    scratch = np.empty(15)
    for j in range(task, qkind.size, ntasks):
        kq = qkind[j]
        Q = qpts[j]
        if kq == 0:
            d, gx, gy, gz, p, nodes, leaves = exact_distance_point(tree, Q[0], Q[1], Q[2],
                                                                   stack, dstack)
        else:
            d, gx, gy, gz, p, nodes, leaves = exact_distance_primitive(tree, kq, Q, stack,
                                                                       dstack, scratch, bound2)
        out_d[j] = d
        out_g[j, 0] = gx
        out_g[j, 1] = gy
        out_g[j, 2] = gz
        out_prim[j] = p


@numba.njit(**NJIT_PARALLEL)
def exact_distance_primitives(tree, qkind, qpts, bound2, out_d, out_g, out_prim):
    """Exact distance, unit translation gradient and closest data primitive per query primitive.

    Edge and triangle queries only look for pairs closer than ``sqrt(bound2)`` (an upper bound of
    the minimum over all query primitives, e.g. from the query vertices); the others get
    ``inf`` and ``-1``. Point queries are always exact.
    """
    ntasks = min(qkind.size, TASKS)
    for task in prange(ntasks):
        _exact_task(tree, qkind, qpts, bound2, out_d, out_g, out_prim, task, ntasks)


@numba.njit(**NJIT)
def exact_distance_primitives_serial(tree, qkind, qpts, bound2, out_d, out_g, out_prim):
    """:func:`exact_distance_primitives` on the calling thread (small query meshes)."""
    _exact_task(tree, qkind, qpts, bound2, out_d, out_g, out_prim, 0, 1)


@numba.njit(**NJIT)
def nearest_vertex_distance(tree, X):
    """Smallest exact distance from the rows of ``X (n, 3)`` to the data (serial)."""
    k = tree.depth + 4
    stack = np.empty(k, dtype=np.int64)
    dstack = np.empty(k)
    best = np.inf
    for i in range(X.shape[0]):
        d = exact_distance_point(tree, X[i, 0], X[i, 1], X[i, 2], stack, dstack)[0]
        best = min(best, d)
    return best
