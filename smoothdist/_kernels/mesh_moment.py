"""Kernels: a query primitive's smooth distance with its exact *rotational* gradient (moment).

:mod:`smoothdist._kernels.mesh_query` gives each query primitive ``g``'s smooth distance
``d_hat(g)`` and its gradient for a translation of ``g``. For a rigid rotation ``omega`` of ``g``
about a point ``c`` the derivative is ``omega . M`` with the moment

    M = sum_i softmax_i [ (p_i - c) x v_i + wgrad_scale y_i (q_i x r_i) ]

over the data primitives (and far-field nodes) ``i`` that ``d_hat(g)`` sums, with ``v_i`` the
term's translation-gradient numerator (``W unit(r) - wgrad_scale grad W``), ``p_i`` the
closest point of the pair *on g* and ``r_i`` the pair's offset (query minus data point). Why:
each pair distance is a minimum over point pairs, so by the envelope theorem a rigid motion
changes it through the motion of its own closest point ``p_i`` (not the centroid of ``g``).
The weight ``W`` follows the data-side closest point, which moves with the query's feature
when that is an edge (direction ``q_i``): the stationarity conditions of the active features
add the term ``y_i (q_i x r_i)``, with ``y_i`` the query-edge component of
``(M^T M)^-1 (w1, w2, 0)`` in :func:`smoothdist._kernels.mesh_query.weight_gradient`'s
notation (0 in its fallbacks).
Far-field nodes use the moments of :mod:`smoothdist._kernels.box_moment`.

The same traversal gives the derivative for a motion of one query vertex ``x_k`` alone (a
deformation, :func:`smooth_vertex_primitive`): by the same envelope argument a pair distance
changes through its closest point ``p_i = sum_k b_k x_k`` (``b_k`` the query barycentrics of
the pair), and the weight through the stationarity conditions, whose query-edge row now also
sees the edge direction ``q = sum_k (d b_k / d lambda) x_k`` change:

    grad_k d_hat(g) = sum_i softmax_i [ b_k v_i + wgrad_scale y_i (d b_k / d lambda) r_i ].

Summed over ``k`` this is the translation gradient, and ``sum_k (x_k - c) x grad_k`` the moment.
A far-field node (Barnes-Hut, tol) has no closest point on ``g``: its term is split equally
among the vertices, so the result is the exact derivative at ``beta = 0`` and ``tol = 0``.

The paper's equal split (Eq. 7-8) applies every primitive's translation gradient at its centroid
``c``; ``M`` about the centroid is what it leaves out. Point queries have ``M = 0`` (their
closest point is the point). Here ``c`` is the primitive's centroid, and ``d_hat`` and the
translation gradient are computed by the same operations as in
:mod:`smoothdist._kernels.mesh_query`, so they agree with it bit for bit.
"""

import math

import numba
import numpy as np

from smoothdist._config import NJIT, NJIT_GENERIC, NJIT_IR_INLINE
from smoothdist._kernels.box_moment import box_lower_bound_moment, extreme_levers, gap_moment
from smoothdist._kernels.mesh_query import (VERTEX_1, _accumulate, any_leaf, box_gap_far,
                                            centroid, far_field, halfspace_far, no_levers,
                                            pair_terms, query_coefficient, smooth_traverse,
                                            task_scratch)
from smoothdist._kernels.query import DEFAULT_TOL, smooth_distance_point
from smoothdist._kernels.traversal import ZERO


#: the query-edge coefficient of the weight's motion (``mesh_query.query_coefficient``)
_query_coefficient = query_coefficient


@numba.njit(**NJIT)
def pair_term_moment(tree, i, kq, Q, S, wgrad_scale, cx, cy, cz):
    """:func:`smoothdist._kernels.mesh_query.pair_term` and the term's moment about ``c``.

    Returns ``(d, W, vx, vy, vz, mx, my, mz)``: ``v`` as there, and
    ``M = (p - c) x v + wgrad_scale y (q x r)`` (module notes).
    """
    return pair_terms(tree.kind, tree.pts, tree.wc, tree.wcls, tree.pwhi, i, kq, Q, S,
                      wgrad_scale, kq >= 0, cx, cy, cz, tree.kind[i])


@numba.njit(**NJIT_GENERIC)
def centroid_levers(kq, Q, scratch):
    """``setup`` of the moment (:func:`smoothdist._kernels.mesh_query.smooth_traverse`): the
    query's :func:`~smoothdist._kernels.box_moment.extreme_levers` about its centroid in
    ``scratch[15:33]``; ``(L, cx, cy, cz)``."""
    L = scratch[15:33]
    cx, cy, cz = centroid(kq, Q)
    extreme_levers(kq, Q, cx, cy, cz, L)
    return L, cx, cy, cz


@numba.njit(**NJIT_GENERIC)
def gap_lever(q, ux, uy, uz):
    """``lever`` of the moment: the box gap's moment
    (:func:`~smoothdist._kernels.box_moment.gap_moment`)."""
    return gap_moment(q.L, ux, uy, uz)


@numba.njit(**NJIT_GENERIC)
def split_lever(q, ux, uy, uz):
    """``lever`` of a vertex's motion: a far field's gradient split equally among the query's
    vertices."""
    return ux * q.split, uy * q.split, uz * q.split


@numba.njit(**NJIT_GENERIC)
def halfspace_moment_far(q, lo, hi, node, lever):
    """``fine`` of the moment: the halfspace bound and its moment
    (:func:`~smoothdist._kernels.box_moment.box_lower_bound_moment`)."""
    return box_lower_bound_moment(q.kq, q.Q, q.qlo, q.qhi, lo, hi, node, q.E, q.cx, q.cy, q.cz,
                                  q.L)


@numba.njit(**NJIT_GENERIC)
def moment_far(tree, q, node, bd2, st):
    """``approximate`` of the moment: far fields with their moments about the centroid."""
    return far_field(tree, q, node, bd2, st, box_gap_far, halfspace_moment_far, gap_lever)


@numba.njit(**NJIT_GENERIC)
def vertex_far(tree, q, node, bd2, st):
    """``approximate`` of a vertex's motion: far fields split equally among the vertices."""
    return far_field(tree, q, node, bd2, st, box_gap_far, halfspace_far, split_lever)


@numba.njit(**NJIT)
def smooth_moment_brute_primitive(tree, kq, Q, alpha, S, wgrad_scale):
    """``(d_hat, gx, gy, gz, mx, my, mz)`` summing every data primitive (reference; no tree)."""
    cx, cy, cz = centroid(kq, Q)
    m = np.inf
    s = 0.0
    gx = gy = gz = 0.0
    mx = my = mz = 0.0
    for i in range(tree.kind.size):
        d, W, vx, vy, vz, tx, ty, tz = pair_term_moment(tree, i, kq, Q, S, wgrad_scale, cx, cy, cz)
        m, s, gx, gy, gz, mx, my, mz = _accumulate(m, s, gx, gy, gz, mx, my, mz, d, W, vx, vy,
                                                   vz, tx, ty, tz, alpha, True)
    return m - math.log(s) / alpha, gx / s, gy / s, gz / s, mx / s, my / s, mz / s


@numba.njit(**NJIT)
def smooth_moment_primitive_tasks(tree, qkind, qpts, alpha, beta, S, wgrad_scale, out_d, out_g,
                                  out_m, out_nodes, out_leaves, tol, ntasks, task0, task1):
    """``d_hat``, translation gradient and moment (about the centroid) of every edge and
    triangle query (a point's moment is 0: the caller runs the point kernel for those).

    As :func:`smoothdist._kernels.mesh_query.smooth_distance_primitive_tasks` (a serial task
    kernel), plus ``out_m (m, 3)`` float64.
    """
    stack, dstack, scratch = task_scratch(tree, 33)
    for task in range(task0, task1):
        for j in range(task, qkind.size, ntasks):
            d, gx, gy, gz, mx, my, mz, nodes, leaves = smooth_traverse(
                tree, qkind[j], qpts[j], alpha, beta, S, wgrad_scale, stack, dstack, scratch,
                tol, True, centroid_levers, moment_far, any_leaf)
            out_d[j] = d
            out_g[j, 0] = gx
            out_g[j, 1] = gy
            out_g[j, 2] = gz
            out_m[j, 0] = mx
            out_m[j, 1] = my
            out_m[j, 2] = mz
            out_nodes[j] = nodes
            out_leaves[j] = leaves


@numba.njit(**NJIT)
def smooth_moment_primitives_brute(tree, qkind, qpts, alpha, S, wgrad_scale, out_d, out_g, out_m):
    """:func:`smooth_moment_primitive_tasks` summing every data primitive (the reference of
    ``method="brute"``; serial, no tree). A point's moment is 0."""
    for j in range(qkind.size):
        d, gx, gy, gz, mx, my, mz = smooth_moment_brute_primitive(tree, qkind[j], qpts[j], alpha,
                                                                  S, wgrad_scale)
        out_d[j] = d
        out_g[j, 0] = gx
        out_g[j, 1] = gy
        out_g[j, 2] = gz
        out_m[j, 0] = mx
        out_m[j, 1] = my
        out_m[j, 2] = mz


@numba.njit(**NJIT_IR_INLINE)
def smooth_vertex_primitive(tree, kq, Q, alpha, beta, S, wgrad_scale, stack, dstack, scratch,
                            tol=DEFAULT_TOL):
    """``(d_hat, g (3,), G (kq + 1, 3))`` of an edge or triangle query: the smooth distance, its
    translation gradient and its derivative for a motion of each vertex alone (module notes).

    One traversal per vertex beyond the first (vertex 0's is ``g`` less the others'), from one
    call in a loop: numba merges the traversal into each call (``NJIT_GENERIC``), so a second
    call would type and compile it again.
    """
    G = np.zeros((kq + 1, 3))
    d = gx = gy = gz = 0.0
    for v in range(1, kq + 1):
        dv, tx, ty, tz, ax, ay, az, nodes, leaves = smooth_traverse(
            tree, kq, Q, alpha, beta, S, wgrad_scale, stack, dstack, scratch, tol,
            VERTEX_1 + (v - 1), no_levers, vertex_far, any_leaf)
        if v == 1:      # the distance and its gradient from the first vertex's traversal
            d, gx, gy, gz = dv, tx, ty, tz
        G[v, 0] = ax
        G[v, 1] = ay
        G[v, 2] = az
    G[0, 0] = gx - G[1:, 0].sum()
    G[0, 1] = gy - G[1:, 1].sum()
    G[0, 2] = gz - G[1:, 2].sum()
    return d, gx, gy, gz, G


@numba.njit(**NJIT)
def smooth_vertex_brute_primitive(tree, kq, Q, alpha, S, wgrad_scale):
    """:func:`smooth_vertex_primitive` summing every data primitive (reference; no tree)."""
    G = np.zeros((kq + 1, 3))
    for v in range(1, kq + 1):
        m = np.inf
        s = 0.0
        gx = gy = gz = 0.0
        mx = my = mz = 0.0
        for i in range(tree.kind.size):
            d, W, vx, vy, vz, tx, ty, tz = pair_terms(tree.kind, tree.pts, tree.wc, tree.wcls,
                                                      tree.pwhi, i, kq, Q, S, wgrad_scale,
                                                      VERTEX_1 + v - 1, 0.0, 0.0, 0.0,
                                                      tree.kind[i])
            m, s, gx, gy, gz, mx, my, mz = _accumulate(m, s, gx, gy, gz, mx, my, mz, d, W, vx,
                                                       vy, vz, tx, ty, tz, alpha, True)
        G[v, 0] = mx / s
        G[v, 1] = my / s
        G[v, 2] = mz / s
    G[0, 0] = gx / s - G[1:, 0].sum()
    G[0, 1] = gy / s - G[1:, 1].sum()
    G[0, 2] = gz / s - G[1:, 2].sum()
    return m - math.log(s) / alpha, gx / s, gy / s, gz / s, G


@numba.njit(**NJIT)
def smooth_vertex_primitive_tasks(tree, qkind, qpts, alpha, beta, S, wgrad_scale, out_d, out_g,
                                  out_G, tol, ntasks, task0, task1):
    """``d_hat``, translation gradient and per-vertex derivatives ``out_G (m, 3, 3)`` (slot ``k``
    for the primitive's vertex ``k``; unused slots 0) of every edge and triangle query, as a
    serial task kernel (tasks ``task0 <= t < task1`` of ``ntasks``, as
    :func:`smoothdist._kernels.mesh_query.smooth_distance_primitive_tasks`; a point's row is
    its translation gradient, from the point kernel, which the caller runs)."""
    stack, dstack, scratch = task_scratch(tree, 33)
    for task in range(task0, task1):
        for j in range(task, qkind.size, ntasks):
            kq = qkind[j]
            out_G[j] = 0.0
            d, gx, gy, gz, G = smooth_vertex_primitive(tree, kq, qpts[j], alpha, beta, S,
                                                       wgrad_scale, stack, dstack, scratch, tol)
            # element by element: an array assigned to a slice compiles numba's shape-mismatch
            # error message (string formatting, 3 s of a first vertex gradient's compile)
            for v in range(kq + 1):
                out_G[j, v, 0] = G[v, 0]
                out_G[j, v, 1] = G[v, 1]
                out_G[j, v, 2] = G[v, 2]
            out_d[j] = d
            out_g[j, 0] = gx
            out_g[j, 1] = gy
            out_g[j, 2] = gz


@numba.njit(**NJIT)
def smooth_vertex_primitives_brute(tree, qkind, qpts, alpha, beta, S, wgrad_scale, out_d, out_g,
                                   out_G):
    """:func:`smooth_vertex_primitive_tasks` summing every data primitive for edge and triangle
    queries (the reference of ``method="brute"``; serial; point queries as there, by the
    tree)."""
    k = tree.depth + 4
    stack = np.empty(k, dtype=np.int64)
    dstack = np.empty(k)
    root = ZERO
    for j in range(qkind.size):
        kq = qkind[j]
        Q = qpts[j]
        out_G[j] = 0.0
        if kq == 0:
            d, gx, gy, gz, _, _ = smooth_distance_point(tree, Q[0], Q[1], Q[2], alpha, beta, S,
                                                        wgrad_scale, stack, dstack, root)
            out_G[j, 0, 0] = gx
            out_G[j, 0, 1] = gy
            out_G[j, 0, 2] = gz
        else:
            d, gx, gy, gz, G = smooth_vertex_brute_primitive(tree, kq, Q, alpha, S, wgrad_scale)
            for v in range(kq + 1):     # element by element, as smooth_vertex_primitive_tasks
                out_G[j, v, 0] = G[v, 0]
                out_G[j, v, 1] = G[v, 1]
                out_G[j, v, 2] = G[v, 2]
        out_d[j] = d
        out_g[j, 0] = gx
        out_g[j, 1] = gy
        out_g[j, 2] = gz
