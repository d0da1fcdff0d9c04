"""Lower bounds on the distance between a query primitive (point, segment, triangle) and a box.

Barnes-Hut (Madan & Levin 2022, Sec. 3.5, App. D) replaces a far BVH node by one term at the
node's distance ``delta`` from the query. The result stays conservative (``d_hat_beta <= d_hat_0``)
only if ``delta`` never exceeds the distance from the query to any primitive in the node; the
distance to the node's bounding box is such a value, and so is anything below it.

The paper's halfspace test classifies each axis: the primitive lies entirely below the box, entirely
above it, or neither. With ``k`` separated axes:

* ``k = 3``: every point of the primitive has the same closest box point, a corner, so the box
  distance is exactly the corner-to-primitive distance;
* ``k = 2``: every point's closest box point lies on one box edge (along the free axis ``j``). We
  return the distance in the plane across ``j`` from the edge to the projected primitive (a 2D
  point-segment or point-triangle distance): a lower bound, and the exact box distance whenever
  the planar minimiser lies within the edge's extent along ``j``, which is the usual case;
* ``k = 1``: the closest box points lie on one face. We do not compute the face distance; we return
  the gap along the separated axis, and for triangles the larger of it and the gap along the
  triangle's normal (both are distances between parallel planes that separate the two sets, so
  both are <= the box distance);
* ``k = 0``: the primitive's bounding box overlaps the node's, and the bound is 0.

The authors' code gets this wrong in three ways (it picks the lower x face for a primitive above the
box, and uses the nearest *vertex* for ``k = 1``), and both overestimate; see
docs/authors-code.md §11, items 2-3. :func:`box_lower_bound` returns the bound and its gradient
with respect to a rigid translation of the query (the far-field term's gradient direction).
"""

import math

import numba

from smoothdist._config import NJIT, NJIT_INLINE
from smoothdist._kernels.closest_pair import (point_segment, point_triangle, segment_point,
                                              segment_triangle, triangle_point,
                                              triangle_triangle)


@numba.njit(**NJIT)
def box_box_distance(qlo, qhi, lo, hi, node):
    """Distance between the query's box ``qlo..qhi`` ((3,) arrays) and node ``node``'s box.

    A lower bound on the distance from anything inside the query box to the node box (cheap:
    used to order and prune the traversal).
    """
    g0, g1, g2 = axis_gaps(qlo, qhi, lo, hi, node)
    return math.sqrt(g0 * g0 + g1 * g1 + g2 * g2)


@numba.njit(**NJIT_INLINE)
def signed_gap(ql, qh, nl, nh):
    """The gap between the query's interval ``[ql, qh]`` and the node's ``[nl, nh]`` on one axis:
    ``-(nl - qh)`` when the node lies above the query, ``ql - nh`` when below, 0 when they
    overlap (always ``+0.0`` then). The sign is that of the query's offset from the node."""
    g = nl - qh
    if g > 0.0:
        return -g
    g = ql - nh
    if g <= 0.0:
        return 0.0
    return g


@numba.njit(**NJIT_INLINE)
def axis_gaps(qlo, qhi, lo, hi, node):
    """:func:`signed_gap` on the three axes between the query box ``qlo, qhi (3,)`` and node
    ``node``'s box: ``(g0, g1, g2)``, the offset of the query box from the node box."""
    return (signed_gap(qlo[0], qhi[0], lo[node, 0], hi[node, 0]),
            signed_gap(qlo[1], qhi[1], lo[node, 1], hi[node, 1]),
            signed_gap(qlo[2], qhi[2], lo[node, 2], hi[node, 2]))


@numba.njit(**NJIT)
def box_box_offset(qlo, qhi, lo, hi, node):
    """:func:`box_box_distance` and its gradient for a translation of the query box.

    Returns ``(d, ux, uy, uz)`` (a unit vector, or 0 when the boxes overlap).
    """
    g0, g1, g2 = axis_gaps(qlo, qhi, lo, hi, node)
    d = math.sqrt(g0 * g0 + g1 * g1 + g2 * g2)
    if d > 0.0:
        return d, g0 / d, g1 / d, g2 / d
    return 0.0, 0.0, 0.0, 0.0


@numba.njit(**NJIT)
def _normal_gap(Q, lo, hi, node):
    """Gap between triangle ``Q`` (9,) and a node's box along the triangle's unit normal:
    ``(gap, ux, uy, uz)``, ``u`` the normal pointing from the box to the triangle (a
    negative gap where the box straddles the triangle's plane; ``-inf`` for a degenerate
    triangle)."""
    abx = Q[3] - Q[0]
    aby = Q[4] - Q[1]
    abz = Q[5] - Q[2]
    acx = Q[6] - Q[0]
    acy = Q[7] - Q[1]
    acz = Q[8] - Q[2]
    nx = aby * acz - abz * acy
    ny = abz * acx - abx * acz
    nz = abx * acy - aby * acx
    nn = math.sqrt(nx * nx + ny * ny + nz * nz)
    if not nn > 0.0:
        return -math.inf, 0.0, 0.0, 0.0
    nx /= nn
    ny /= nn
    nz /= nn
    h = nx * Q[0] + ny * Q[1] + nz * Q[2]
    cx = 0.5 * (lo[node, 0] + hi[node, 0])
    cy = 0.5 * (lo[node, 1] + hi[node, 1])
    cz = 0.5 * (lo[node, 2] + hi[node, 2])
    rad = 0.5 * (abs(nx) * (hi[node, 0] - lo[node, 0]) + abs(ny) * (hi[node, 1] - lo[node, 1])
                 + abs(nz) * (hi[node, 2] - lo[node, 2]))
    off = h - (nx * cx + ny * cy + nz * cz)
    sgn = 1.0 if off > 0.0 else -1.0
    return abs(off) - rad, sgn * nx, sgn * ny, sgn * nz


@numba.njit(**NJIT)
def box_lower_bound(kq, Q, qlo, qhi, lo, hi, node, E):
    """Lower bound ``delta`` on the distance from query primitive ``(kq, Q)`` to a node's box.

    Parameters
    ----------
    kq : int
        0 point, 1 segment, 2 triangle.
    Q : (9,) float64
        The query's vertex coordinates.
    qlo, qhi : (3,) float64
        The query's bounding box.
    lo, hi : (n, 3) float64, node : int
        The BVH node boxes and the node.
    E : (9,) float64
        Scratch space (the box corner, or the query projected across the box edge).

    Returns
    -------
    (delta, ux, uy, uz)
        ``0 <= delta <= dist(query, box)``, and the derivative of ``delta`` with respect to a
        translation of the query (a unit vector, or 0 when ``delta = 0``).
    """
    g0, g1, g2 = axis_gaps(qlo, qhi, lo, hi, node)
    nsep = int(g0 != 0.0) + int(g1 != 0.0) + int(g2 != 0.0)   # numpy bools would add as "or"
    gap2 = g0 * g0 + g1 * g1 + g2 * g2
    if nsep == 0:
        return 0.0, 0.0, 0.0, 0.0
    if kq == 0:
        # a point: the gap vector is the exact offset from the box
        d = math.sqrt(gap2)
        return d, g0 / d, g1 / d, g2 / d
    if nsep == 3:
        # every query point's closest box point is one corner: the exact distance to it
        E[0] = lo[node, 0] if g0 < 0.0 else hi[node, 0]
        E[1] = lo[node, 1] if g1 < 0.0 else hi[node, 1]
        E[2] = lo[node, 2] if g2 < 0.0 else hi[node, 2]
        # closest_pair(kq, Q, 0, E) for kq 1 or 2, called directly: a constant kind would
        # compile closest_pair again for it (a literal argument), with every kind pair
        if kq == 1:
            c = segment_point(Q[0], Q[1], Q[2], Q[3], Q[4], Q[5], E[0], E[1], E[2])
        else:
            c = triangle_point(Q[0], Q[1], Q[2], Q[3], Q[4], Q[5], Q[6], Q[7], Q[8], E[0],
                               E[1], E[2])
        d = math.sqrt(c[0])
        if d > 0.0:
            return d, c[1] / d, c[2] / d, c[3] / d
        return 0.0, 0.0, 0.0, 0.0
    if nsep == 2:
        # every query point's closest box point is on one box edge, along the free axis j: the
        # distance in the plane across j (to the edge's corner point) is a lower bound, exact
        # when the planar minimiser lies within the edge's extent along j (the common case)
        j = 0 if g0 == 0.0 else (1 if g1 == 0.0 else 2)
        for v in range(kq + 1):
            for a in range(3):
                E[3 * v + a] = 0.0 if a == j else Q[3 * v + a]
        P0 = lo[node, 0] if g0 < 0.0 else hi[node, 0]
        P1 = lo[node, 1] if g1 < 0.0 else hi[node, 1]
        P2 = lo[node, 2] if g2 < 0.0 else hi[node, 2]
        if j == 0:
            P0 = 0.0
        elif j == 1:
            P1 = 0.0
        else:
            P2 = 0.0
        if kq == 1:
            c = point_segment(P0, P1, P2, E[0], E[1], E[2], E[3], E[4], E[5])
        else:
            c = point_triangle(P0, P1, P2, E[0], E[1], E[2], E[3], E[4], E[5], E[6], E[7], E[8])
        d = math.sqrt(c[0])
        if d > 0.0:
            # c's r points from the query to the box: the query moves away along -r
            return d, -c[1] / d, -c[2] / d, -c[3] / d
        return 0.0, 0.0, 0.0, 0.0
    # k = 1: the gap along the separated axis ...
    best = math.sqrt(gap2)
    ux = 1.0 if g0 > 0.0 else (-1.0 if g0 < 0.0 else 0.0)
    uy = 1.0 if g1 > 0.0 else (-1.0 if g1 < 0.0 else 0.0)
    uz = 1.0 if g2 > 0.0 else (-1.0 if g2 < 0.0 else 0.0)
    if kq == 2:
        # ... or along the triangle's normal, whichever separates more
        g, nx, ny, nz = _normal_gap(Q, lo, hi, node)
        if g > best:
            return g, nx, ny, nz
    return best, ux, uy, uz


@numba.njit(**NJIT)
def box_distance_exact(kq, Q, lo, hi, node, E):
    """The exact distance from query primitive ``(kq, Q)`` to node ``node``'s box, and its
    derivative for a translation of the query: the quadratic program that the paper's
    halfspace test (:func:`box_lower_bound`) avoids (Sec. 3.5), here for measuring what that
    test saves (``MeshDistance(box_test=False)``).

    0 when a query vertex lies in the box (the primitive meets it); otherwise the primitive
    meets the box, if at all, on its surface, so the distance is the smallest to the box's 12
    face triangles (:func:`smoothdist._kernels.closest_pair.closest_pair`). ``E`` (9,) scratch.
    Returns ``(delta, ux, uy, uz)`` as :func:`box_lower_bound`, with ``delta`` >= its value.
    """
    for v in range(kq + 1):
        inside = True
        for a in range(3):
            x = Q[3 * v + a]
            if x < lo[node, a] or x > hi[node, a]:
                inside = False
        if inside:
            return 0.0, 0.0, 0.0, 0.0
    best = math.inf
    bx = by = bz = 0.0
    for a in range(3):          # the face's normal axis
        b = (a + 1) % 3
        c = (a + 2) % 3
        for side in range(2):
            fa = lo[node, a] if side == 0 else hi[node, a]
            for t in range(2):  # the face's two triangles: corners (0,0)(1,0)(1,1), (0,0)(1,1)(0,1)
                for k in range(3):
                    if k == 0:
                        ub, uc = 0, 0
                    elif k == 1:
                        ub, uc = (1, 0) if t == 0 else (1, 1)
                    else:
                        ub, uc = (1, 1) if t == 0 else (0, 1)
                    E[3 * k + a] = fa
                    E[3 * k + b] = hi[node, b] if ub else lo[node, b]
                    E[3 * k + c] = hi[node, c] if uc else lo[node, c]
                # closest_pair(kq, Q, 2, E), called directly (as above)
                if kq == 1:
                    r = segment_triangle(Q[0], Q[1], Q[2], Q[3], Q[4], Q[5], E[0], E[1],
                                         E[2], E[3], E[4], E[5], E[6], E[7], E[8])
                else:
                    r = triangle_triangle(Q[0], Q[1], Q[2], Q[3], Q[4], Q[5], Q[6], Q[7],
                                          Q[8], E[0], E[1], E[2], E[3], E[4], E[5], E[6],
                                          E[7], E[8])
                if r[0] < best:
                    best = r[0]
                    bx, by, bz = r[1], r[2], r[3]
    d = math.sqrt(best)
    if d > 0.0:
        return d, bx / d, by / d, bz / d
    return 0.0, 0.0, 0.0, 0.0
