"""Kernels: a query primitive's smooth distance with its exact *rotational* gradient (moment).

:mod:`smoothdist.mesh_query` gives each query primitive ``g``'s smooth distance ``d_hat(g)`` and
its gradient for a translation of ``g``. For a rigid rotation ``omega`` of ``g`` about a point
``c`` the derivative is ``omega . M`` with the moment

    M = sum_i softmax_i [ (p_i - c) x v_i + wgs y_i (q_i x r_i) ]

over the data primitives (and far-field nodes) ``i`` that ``d_hat(g)`` sums, with ``v_i`` the
term's translation-gradient numerator (``W unit(r) - wgs grad W``), ``p_i`` the closest point of
the pair *on g* and ``r_i`` the pair's offset (query minus data point). Why: each pair distance
is a minimum over point pairs, so by the envelope theorem a rigid motion changes it through the
motion of its own closest point ``p_i`` (not the centroid of ``g``). The weight ``W`` follows
the data-side closest point, which moves with the query's feature when that is an edge
(direction ``q_i``): the stationarity conditions of the active features add the term
``y_i (q_i x r_i)``, with ``y_i`` the query-edge component of ``(M^T M)^-1 (w1, w2, 0)`` in
:func:`smoothdist.mesh_query.weight_gradient`'s notation (0 in its fallbacks). Far-field nodes
use the moments of :mod:`smoothdist.box_moment`.

The paper's equal split (Eq. 7-8) applies every primitive's translation gradient at its centroid
``c``; ``M`` about the centroid is what it leaves out. Point queries have ``M = 0`` (their
closest point is the point). Here ``c`` is the primitive's centroid, and ``d_hat`` and the
translation gradient are computed by the same operations as in :mod:`smoothdist.mesh_query`, so
they agree with it bit for bit.
"""

import math

import numba
import numpy as np
from numba import prange

from smoothdist._config import NJIT, NJIT_PARALLEL
from smoothdist.box_distance import box_box_distance, box_box_offset
from smoothdist.box_moment import box_lower_bound_moment, extreme_levers, gap_moment
from smoothdist.closest_pair import closest_pair
from smoothdist.closest_point import TRI_AB, TRI_AC, TRI_INTERIOR
from smoothdist.mesh_query import (TASKS, _dot, _point_box, feature_directions, query_box,
                                   weight_gradient)
from smoothdist.query import (DEFAULT_TOL, _attenuate, push_nearest_first,
                              smooth_distance_point)
from smoothdist.weights import eval_edge_weight, eval_triangle_weight


@numba.njit(**NJIT)
def accumulate_moment(m, s, gx, gy, gz, mx, my, mz, d, W, vx, vy, vz, ux, uy, uz, alpha):
    """:func:`smoothdist.query.logsumexp_accumulate` with a moment ``u`` summed like ``v``.

    Returns ``(m, s, gx, gy, gz, mx, my, mz)``; the same operations on ``m, s, g``.
    """
    if d < m:
        f = math.exp(-alpha * (m - d))
        s *= f
        gx *= f
        gy *= f
        gz *= f
        mx *= f
        my *= f
        mz *= f
        m = d
    e = math.exp(-alpha * (d - m))
    return (m, s + W * e, gx + e * vx, gy + e * vy, gz + e * vz, mx + e * ux, my + e * uy,
            mz + e * uz)


@numba.njit(**NJIT)
def _query_coefficient(nd, d1x, d1y, d1z, w1, nq, q1x, q1y, q1z):
    """The query-edge component ``y`` of :func:`~smoothdist.mesh_query.weight_gradient`'s
    solve (one data and one query direction, same singularity test; 0 otherwise)."""
    if nq == 1 and nd == 1:
        a = _dot(d1x, d1y, d1z, d1x, d1y, d1z)
        b = -_dot(d1x, d1y, d1z, q1x, q1y, q1z)
        c = _dot(q1x, q1y, q1z, q1x, q1y, q1z)
        det = a * c - b * b
        if det > 1e-12 * a * c:
            return -b * w1 / det
    return 0.0


@numba.njit(**NJIT)
def pair_term_moment(tree, i, kq, Q, S, wgs, cx, cy, cz):
    """:func:`smoothdist.mesh_query.pair_term` and the term's moment about ``c``.

    Returns ``(d, W, vx, vy, vz, mx, my, mz)``: ``v`` as there, and
    ``M = (p - c) x v + wgs y (q x r)`` (module notes).
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
    y = 0.0
    q1x = q1y = q1z = 0.0
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
                y = _query_coefficient(nd, d1x, d1y, d1z, w1, nq, q1x, q1y, q1z)
    if d > 0.0:
        inv = W / d
        vx = rx * inv - wgs * gwx
        vy = ry * inv - wgs * gwy
        vz = rz * inv - wgs * gwz
    else:
        vx = -wgs * gwx
        vy = -wgs * gwy
        vz = -wgs * gwz
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
        f = wgs * y
        mx += f * (q1y * rz - q1z * ry)
        my += f * (q1z * rx - q1x * rz)
        mz += f * (q1x * ry - q1y * rx)
    return d, W, vx, vy, vz, mx, my, mz


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


@numba.njit(**NJIT)
def smooth_moment_primitive(tree, kq, Q, alpha, beta, S, wgs, stack, dstack, scratch,
                            tol=DEFAULT_TOL):
    """:func:`smoothdist.mesh_query.smooth_distance_primitive` with the moment about the
    query's centroid.

    Same traversal and arguments (``kq`` 1 or 2), but ``scratch (33,)``. Returns
    ``(d_hat, gx, gy, gz, mx, my, mz, nodes_visited, leaves_visited)``.
    """
    qlo = scratch[0:3]
    qhi = scratch[3:6]
    E = scratch[6:15]
    L = scratch[15:33]
    query_box(kq, Q, qlo, qhi)
    cx, cy, cz = centroid(kq, Q)
    extreme_levers(kq, Q, cx, cy, cz, L)
    m = np.inf
    s = 0.0
    gx = 0.0
    gy = 0.0
    gz = 0.0
    mx = 0.0
    my = 0.0
    mz = 0.0
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
        ax = ay = az = 0.0
        if cnt > 1 and beta > 0.0:
            dg = tree.diag[node]
            if dg < beta * bd:
                delta, ux, uy, uz = box_box_offset(qlo, qhi, lo, hi, node)
                ax, ay, az = gap_moment(L, ux, uy, uz)
                far = True
            elif dg < beta * _point_box(kq, Q, lo, hi, node):
                delta, ux, uy, uz, ax, ay, az = box_lower_bound_moment(kq, Q, qlo, qhi, lo, hi,
                                                                       node, E, cx, cy, cz, L)
                far = dg < beta * delta
        if not far and tol > 0.0 and s > 0.0:
            wh = tree.whi[node]
            W = cnt * (wh if (S == 1.0 or wh == 1.0) else math.exp(S * math.log(wh)))
            if W * math.exp(-alpha * (bd - m)) <= tol * s:
                delta, ux, uy, uz = box_box_offset(qlo, qhi, lo, hi, node)
                ax, ay, az = gap_moment(L, ux, uy, uz)
                far = True
        if far:
            wh = tree.whi[node]
            W = cnt * (wh if (S == 1.0 or wh == 1.0) else math.exp(S * math.log(wh)))
            m, s, gx, gy, gz, mx, my, mz = accumulate_moment(
                m, s, gx, gy, gz, mx, my, mz, delta, W, W * ux, W * uy, W * uz, W * ax, W * ay,
                W * az, alpha)
            leaves += 1
            continue
        l = tree.left[node]
        if l < 0:
            st = tree.start[node]
            for i in range(st, st + cnt):
                d, W, vx, vy, vz, tx, ty, tz = pair_term_moment(tree, i, kq, Q, S, wgs, cx, cy,
                                                                cz)
                m, s, gx, gy, gz, mx, my, mz = accumulate_moment(
                    m, s, gx, gy, gz, mx, my, mz, d, W, vx, vy, vz, tx, ty, tz, alpha)
            leaves += cnt
            continue
        r = tree.right[node]
        dl = box_box_distance(qlo, qhi, lo, hi, l)
        dr = box_box_distance(qlo, qhi, lo, hi, r)
        sp = push_nearest_first(stack, dstack, sp, l, dl, r, dr)
    inv = 1.0 / s
    return (m - math.log(s) / alpha, gx * inv, gy * inv, gz * inv, mx * inv, my * inv, mz * inv,
            nodes, leaves)


@numba.njit(**NJIT)
def smooth_moment_brute_primitive(tree, kq, Q, alpha, S, wgs):
    """``(d_hat, gx, gy, gz, mx, my, mz)`` summing every data primitive (reference; no tree)."""
    cx, cy, cz = centroid(kq, Q)
    m = np.inf
    s = 0.0
    gx = gy = gz = 0.0
    mx = my = mz = 0.0
    for i in range(tree.kind.size):
        d, W, vx, vy, vz, tx, ty, tz = pair_term_moment(tree, i, kq, Q, S, wgs, cx, cy, cz)
        m, s, gx, gy, gz, mx, my, mz = accumulate_moment(m, s, gx, gy, gz, mx, my, mz, d, W, vx,
                                                         vy, vz, tx, ty, tz, alpha)
    return m - math.log(s) / alpha, gx / s, gy / s, gz / s, mx / s, my / s, mz / s


@numba.njit(**NJIT)
def _moment_task(tree, qkind, qpts, alpha, beta, S, wgs, brute, out_d, out_g, out_m, out_nodes,
                 out_leaves, tol, task, ntasks):
    """Query primitives ``task, task + ntasks, ...`` of :func:`smooth_moment_primitives`."""
    k = tree.depth + 4
    stack = np.empty(k, dtype=np.int64)
    dstack = np.empty(k)
    scratch = np.empty(33)
    for j in range(task, qkind.size, ntasks):
        kq = qkind[j]
        Q = qpts[j]
        nodes = 0
        leaves = tree.kind.size
        mx = my = mz = 0.0
        if brute:
            d, gx, gy, gz, mx, my, mz = smooth_moment_brute_primitive(tree, kq, Q, alpha, S, wgs)
        elif kq == 0:
            # a point: its closest point is itself, no moment about it
            d, gx, gy, gz, nodes, leaves = smooth_distance_point(
                tree, Q[0], Q[1], Q[2], alpha, beta, S, wgs, stack, dstack)
        else:
            d, gx, gy, gz, mx, my, mz, nodes, leaves = smooth_moment_primitive(
                tree, kq, Q, alpha, beta, S, wgs, stack, dstack, scratch, tol)
        out_d[j] = d
        out_g[j, 0] = gx
        out_g[j, 1] = gy
        out_g[j, 2] = gz
        out_m[j, 0] = mx
        out_m[j, 1] = my
        out_m[j, 2] = mz
        out_nodes[j] = nodes
        out_leaves[j] = leaves


@numba.njit(**NJIT_PARALLEL)
def smooth_moment_primitives(tree, qkind, qpts, alpha, beta, S, wgs, brute, out_d, out_g, out_m,
                             out_nodes, out_leaves, tol=DEFAULT_TOL):
    """``d_hat``, translation gradient and moment (about the centroid) of every query primitive.

    As :func:`smoothdist.mesh_query.smooth_distance_primitives`, plus ``out_m (m, 3)`` float64.
    """
    ntasks = min(qkind.size, TASKS)
    for task in prange(ntasks):
        _moment_task(tree, qkind, qpts, alpha, beta, S, wgs, brute, out_d, out_g, out_m,
                     out_nodes, out_leaves, tol, task, ntasks)


@numba.njit(**NJIT)
def smooth_moment_primitives_serial(tree, qkind, qpts, alpha, beta, S, wgs, brute, out_d, out_g,
                                    out_m, out_nodes, out_leaves, tol=DEFAULT_TOL):
    """:func:`smooth_moment_primitives` on the calling thread (small query meshes)."""
    _moment_task(tree, qkind, qpts, alpha, beta, S, wgs, brute, out_d, out_g, out_m, out_nodes,
                 out_leaves, tol, 0, 1)
