"""The Barnes-Hut far-field distances of :mod:`smoothdist._kernels.box_distance` with their
*rotational* derivative: what a small rigid rotation of the query primitive does to them.

A far-field term uses a lower bound ``delta`` of the query primitive's distance to a node box
and its translation gradient ``u``. For a rotation ``omega`` of the query about a point ``c``
(each query point moving by ``omega x (x - c)``) the derivative is ``omega . M`` with ``M`` the
*moment* returned here, about ``c``:

* box-box gap (:func:`~smoothdist._kernels.box_distance.box_box_offset`; also the one-axis gap): the
  gap along axis ``a`` is set by the query vertex extreme along ``a``, so
  ``M = sum_a (Q_{k_a} - c) x (u_a e_a)``: each axis's share of ``u`` acts at its own vertex;
* three separated axes (distance to a box corner ``K``): the closest query point ``p`` is
  ``K + delta u``, and ``M = (p - c) x u = (K - c) x u``;
* two separated axes (distance in the plane across the free axis ``j``): ``M = (p - c) x u``
  with ``p`` the 3-D query point at the planar minimiser's parameters (envelope theorem:
  ``u_j = 0``, so only the in-plane motion counts);
* a triangle's normal gap (the plane of the triangle to the box corner ``K`` furthest along
  ``u``): ``M = (K - c) x u`` (the plane turns about the query; ``K`` is fixed).

These are exact derivatives of the *same* piecewise-smooth bounds (away from the switches
between cases and ties between extreme vertices), so the value and the gradient of the far field
stay consistent. ``delta`` and ``u`` are computed by the same operations as in
:mod:`smoothdist._kernels.box_distance`, bit for bit.
"""

import math

import numba

from smoothdist._config import NJIT
from smoothdist._kernels.box_distance import axis_gaps, box_lower_bound
from smoothdist._kernels.closest_pair import point_segment, point_triangle


@numba.njit(**NJIT)
def _cross_axis(rx, ry, rz, a, ua):
    """``r x (ua e_a)``."""
    if a == 0:
        return 0.0, rz * ua, -ry * ua
    if a == 1:
        return -rz * ua, 0.0, rx * ua
    return ry * ua, -rx * ua, 0.0


@numba.njit(**NJIT)
def extreme_levers(kq, Q, cx, cy, cz, L):
    """Fill ``L (18,)`` with ``(Q_k - c) x e_a`` for the query vertex ``k`` extreme along axis
    ``a``: ``L[6 a : 6 a + 3]`` for the smallest coordinate, ``L[6 a + 3 : 6 a + 6]`` for the
    largest (ties go to the first vertex). ``Q (9,)`` the query's ``kq + 1`` vertices."""
    for a in range(3):
        kmin = 0
        kmax = 0
        for j in range(1, kq + 1):
            if Q[3 * j + a] < Q[3 * kmin + a]:
                kmin = j
            if Q[3 * j + a] > Q[3 * kmax + a]:
                kmax = j
        for side in range(2):
            k = kmin if side == 0 else kmax
            lx, ly, lz = _cross_axis(Q[3 * k] - cx, Q[3 * k + 1] - cy, Q[3 * k + 2] - cz, a, 1.0)
            L[6 * a + 3 * side] = lx
            L[6 * a + 3 * side + 1] = ly
            L[6 * a + 3 * side + 2] = lz


@numba.njit(**NJIT)
def gap_moment(L, ux, uy, uz):
    """Moment of the per-axis box gap whose translation gradient is ``u``, from the query's
    :func:`extreme_levers` ``L``: axis ``a`` with ``u_a < 0`` (query below the box) is set by
    the query's largest coordinate along ``a``, ``u_a > 0`` by its smallest. Returns
    ``(mx, my, mz)``."""
    mx = 0.0
    my = 0.0
    mz = 0.0
    for a in range(3):
        ua = ux if a == 0 else (uy if a == 1 else uz)
        if ua == 0.0:
            continue
        o = 6 * a + (3 if ua < 0.0 else 0)
        mx += ua * L[o]
        my += ua * L[o + 1]
        mz += ua * L[o + 2]
    return mx, my, mz


@numba.njit(**NJIT)
def _cross(ax, ay, az, bx, by, bz):
    return ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx


@numba.njit(**NJIT)
def box_lower_bound_moment(kq, Q, qlo, qhi, lo, hi, node, E, cx, cy, cz, L):
    """:func:`~smoothdist._kernels.box_distance.box_lower_bound` and its moment about ``c``.

    Arguments as there, plus the moment's reference point ``(cx, cy, cz)`` and the query's
    :func:`extreme_levers` ``L`` about it; ``kq`` 1 or 2. Returns
    ``(delta, ux, uy, uz, mx, my, mz)``.
    """
    delta, ux, uy, uz = box_lower_bound(kq, Q, qlo, qhi, lo, hi, node, E)
    if delta == 0.0 or (ux == 0.0 and uy == 0.0 and uz == 0.0):
        return delta, ux, uy, uz, 0.0, 0.0, 0.0
    # which case gave delta: the same per-axis gaps as box_lower_bound
    g0, g1, g2 = axis_gaps(qlo, qhi, lo, hi, node)
    nsep = int(g0 != 0.0) + int(g1 != 0.0) + int(g2 != 0.0)   # numpy bools would add as "or"
    if nsep == 3:
        Kx = lo[node, 0] if g0 < 0.0 else hi[node, 0]
        Ky = lo[node, 1] if g1 < 0.0 else hi[node, 1]
        Kz = lo[node, 2] if g2 < 0.0 else hi[node, 2]
        mx, my, mz = _cross(Kx - cx, Ky - cy, Kz - cz, ux, uy, uz)
        return delta, ux, uy, uz, mx, my, mz
    if nsep == 2:
        # box_lower_bound left the projected query in E: the planar minimiser's parameters
        j = 0 if g0 == 0.0 else (1 if g1 == 0.0 else 2)
        P0 = 0.0 if j == 0 else (lo[node, 0] if g0 < 0.0 else hi[node, 0])
        P1 = 0.0 if j == 1 else (lo[node, 1] if g1 < 0.0 else hi[node, 1])
        P2 = 0.0 if j == 2 else (lo[node, 2] if g2 < 0.0 else hi[node, 2])
        if kq == 1:
            c = point_segment(P0, P1, P2, E[0], E[1], E[2], E[3], E[4], E[5])
            s = c[7]
            t = 0.0
        else:
            c = point_triangle(P0, P1, P2, E[0], E[1], E[2], E[3], E[4], E[5], E[6], E[7], E[8])
            s = c[7]
            t = c[8]
        px = Q[0] + s * (Q[3] - Q[0]) + t * (Q[6] - Q[0]) if kq == 2 else Q[0] + s * (Q[3] - Q[0])
        py = Q[1] + s * (Q[4] - Q[1]) + t * (Q[7] - Q[1]) if kq == 2 else Q[1] + s * (Q[4] - Q[1])
        pz = Q[2] + s * (Q[5] - Q[2]) + t * (Q[8] - Q[2]) if kq == 2 else Q[2] + s * (Q[5] - Q[2])
        mx, my, mz = _cross(px - cx, py - cy, pz - cz, ux, uy, uz)
        return delta, ux, uy, uz, mx, my, mz
    # one separated axis: a unit axis vector is the axis gap, anything else the triangle's normal
    n_axes = int(ux != 0.0) + int(uy != 0.0) + int(uz != 0.0)
    if n_axes == 1 and abs(ux) + abs(uy) + abs(uz) == 1.0 and delta == math.sqrt(
            g0 * g0 + g1 * g1 + g2 * g2):
        mx, my, mz = gap_moment(L, ux, uy, uz)
        return delta, ux, uy, uz, mx, my, mz
    # the normal gap: distance from the triangle's plane to the box corner furthest along u
    Kx = 0.5 * (lo[node, 0] + hi[node, 0]) + (0.5 * (hi[node, 0] - lo[node, 0]) if ux > 0.0 else
                                               (-0.5 * (hi[node, 0] - lo[node, 0]) if ux < 0.0
                                                else 0.0))
    Ky = 0.5 * (lo[node, 1] + hi[node, 1]) + (0.5 * (hi[node, 1] - lo[node, 1]) if uy > 0.0 else
                                               (-0.5 * (hi[node, 1] - lo[node, 1]) if uy < 0.0
                                                else 0.0))
    Kz = 0.5 * (lo[node, 2] + hi[node, 2]) + (0.5 * (hi[node, 2] - lo[node, 2]) if uz > 0.0 else
                                               (-0.5 * (hi[node, 2] - lo[node, 2]) if uz < 0.0
                                                else 0.0))
    mx, my, mz = _cross(Kx - cx, Ky - cy, Kz - cz, ux, uy, uz)
    return delta, ux, uy, uz, mx, my, mz
