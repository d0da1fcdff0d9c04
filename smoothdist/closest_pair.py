"""Exact closest pairs between two simplices (point, segment, triangle), both sides' barycentrics.

The paper's generalized query primitives (Madan & Levin 2022, Sec. 3.4, App. B) need the
distance between a query primitive ``g`` and a data primitive ``f``, the closest points on both,
and the barycentric coordinates of both points (the data side's feed the weight function).

Every kernel works on float64 scalars and returns

    ``(d2, rx, ry, rz, qs, qt, qf, ds, dt, df)``

* ``d2``: squared distance;
* ``r = (point on the first primitive) - (point on the second)``: the first is the *query*;
* ``(qs, qt, qf)`` and ``(ds, dt, df)``: parameters and feature code of the closest point on the
  query and on the data primitive, in the conventions of :mod:`smoothdist.closest_point`:
  a point has ``(0, 0, 0)``; a segment ``a + s (b - a)`` has ``(s, 0, SEG_*)``; a triangle
  ``a + s (b - a) + t (c - a)`` has ``(s, t, TRI_*)``.

Method. The squared distance is a convex quadratic in the barycentrics of both sides. Its minimum
is either an intersection (distance 0), an interior stationary point (only possible for two
segments, or when one side is a point), or lies on the boundary of the parameter domain, i.e. one
side at a vertex or on an edge. So segment-segment is the interior solution or the best of four
endpoint-segment pairs (computed by clamping, Ericson 2005 Sec. 5.1.9, when the segments are
well away from parallel); segment-triangle is a crossing or the best of the two endpoint-triangle,
three vertex-segment and three interior edge-edge pairs; triangle-triangle an edge-triangle
crossing or the best of six vertex-triangle and nine interior edge-edge pairs (an edge pair's
boundary candidates are vertex-edge pairs, which the vertex-triangle pairs dominate). Every candidate's distance is measured between two actual
points of the primitives, so rounding can only overestimate by an ulp-level amount, never report a
pair that does not exist.

Robustness: zero-length segments and zero-area triangles (possible on the query side, which is not
repaired) reduce to their vertices and edges; parallel segments and a segment parallel to a
triangle fall back to the boundary candidates, which contain a minimiser.
"""

import math

import numba

from smoothdist._config import NJIT, NJIT_INLINE
from smoothdist.closest_point import (SEG_A, SEG_B, SEG_INTERIOR, TRI_A, TRI_AB, TRI_AC, TRI_B,
                                      TRI_BC, TRI_C, TRI_INTERIOR, closest_point_segment,
                                      closest_point_triangle)

KIND_POINT, KIND_SEGMENT, KIND_TRIANGLE = 0, 1, 2

#: ``|ab x ac|^2 <= DEGENERATE * |ab|^2 |ac|^2`` (sine of the smallest angle below 1e-8):
#: the triangle is treated as its three edges
DEGENERATE = 1e-16
#: ``det <= NEAR_PARALLEL * |d1|^2 |d2|^2``: two segments are checked at their endpoints too
NEAR_PARALLEL = 1e-8


@numba.njit(**NJIT_INLINE)
def segment_feature(u):
    """Feature code of segment parameter ``u`` in [0, 1]."""
    if u <= 0.0:
        return SEG_A
    if u >= 1.0:
        return SEG_B
    return SEG_INTERIOR


@numba.njit(**NJIT)
def triangle_edge_point(edge, u):
    """Triangle parameters ``(s, t, feature)`` of the point at ``u`` on edge 0 ab, 1 ac, 2 bc."""
    if edge == 0:
        if u <= 0.0:
            return 0.0, 0.0, TRI_A
        if u >= 1.0:
            return 1.0, 0.0, TRI_B
        return u, 0.0, TRI_AB
    if edge == 1:
        if u <= 0.0:
            return 0.0, 0.0, TRI_A
        if u >= 1.0:
            return 0.0, 1.0, TRI_C
        return 0.0, u, TRI_AC
    if u <= 0.0:
        return 1.0, 0.0, TRI_B
    if u >= 1.0:
        return 0.0, 1.0, TRI_C
    return 1.0 - u, u, TRI_BC


@numba.njit(**NJIT)
def triangle_is_degenerate(ax, ay, az, bx, by, bz, cx, cy, cz):
    """True when the triangle is (numerically) a segment or a point."""
    abx = bx - ax
    aby = by - ay
    abz = bz - az
    acx = cx - ax
    acy = cy - ay
    acz = cz - az
    nx = aby * acz - abz * acy
    ny = abz * acx - abx * acz
    nz = abx * acy - aby * acx
    n2 = nx * nx + ny * ny + nz * nz
    return n2 <= DEGENERATE * (abx * abx + aby * aby + abz * abz) * (acx * acx + acy * acy + acz * acz)


@numba.njit(**NJIT)
def _edge_vertices(edge, ax, ay, az, bx, by, bz, cx, cy, cz):
    if edge == 0:
        return ax, ay, az, bx, by, bz
    if edge == 1:
        return ax, ay, az, cx, cy, cz
    return bx, by, bz, cx, cy, cz


@numba.njit(**NJIT)
def point_segment(px, py, pz, ax, ay, az, bx, by, bz):
    """Point ``p`` (query) against segment ``ab`` (zero length allowed)."""
    cx, cy, cz, t, f = closest_point_segment(px, py, pz, ax, ay, az, bx, by, bz)
    rx = px - cx
    ry = py - cy
    rz = pz - cz
    return rx * rx + ry * ry + rz * rz, rx, ry, rz, 0.0, 0.0, 0, t, 0.0, f


@numba.njit(**NJIT)
def point_triangle(px, py, pz, ax, ay, az, bx, by, bz, cx, cy, cz):
    """Point ``p`` (query) against triangle ``abc`` (zero area allowed)."""
    if triangle_is_degenerate(ax, ay, az, bx, by, bz, cx, cy, cz):
        best = math.inf
        brx = bry = brz = 0.0
        bs = bt = 0.0
        bf = TRI_A
        for e in range(3):
            ux, uy, uz, vx, vy, vz = _edge_vertices(e, ax, ay, az, bx, by, bz, cx, cy, cz)
            qx, qy, qz, u, f = closest_point_segment(px, py, pz, ux, uy, uz, vx, vy, vz)
            rx = px - qx
            ry = py - qy
            rz = pz - qz
            d2 = rx * rx + ry * ry + rz * rz
            if d2 < best:
                best = d2
                brx, bry, brz = rx, ry, rz
                bs, bt, bf = triangle_edge_point(e, u)
        return best, brx, bry, brz, 0.0, 0.0, 0, bs, bt, bf
    qx, qy, qz, s, t, f = closest_point_triangle(px, py, pz, ax, ay, az, bx, by, bz, cx, cy, cz)
    rx = px - qx
    ry = py - qy
    rz = pz - qz
    return rx * rx + ry * ry + rz * rz, rx, ry, rz, 0.0, 0.0, 0, s, t, f


@numba.njit(**NJIT)
def segment_segment(px, py, pz, qx, qy, qz, ax, ay, az, bx, by, bz):
    """Segment ``pq`` (query) against segment ``ab`` (parallel and zero-length allowed)."""
    d1x = qx - px
    d1y = qy - py
    d1z = qz - pz
    d2x = bx - ax
    d2y = by - ay
    d2z = bz - az
    wx = px - ax
    wy = py - ay
    wz = pz - az
    A = d1x * d1x + d1y * d1y + d1z * d1z
    E = d2x * d2x + d2y * d2y + d2z * d2z
    B = d1x * d2x + d1y * d2y + d1z * d2z
    C = d1x * wx + d1y * wy + d1z * wz
    F = d2x * wx + d2y * wy + d2z * wz
    den = A * E - B * B
    if A > 0.0 and E > 0.0 and den > NEAR_PARALLEL * A * E:
        # well-conditioned: the stationary pair, clamped on one side and then the other
        # (Ericson 2005, Sec. 5.1.9), is the constrained minimum
        u = min(max((B * F - C * E) / den, 0.0), 1.0)
        v = (B * u + F) / E
        if v < 0.0:
            v = 0.0
            u = min(max(-C / A, 0.0), 1.0)
        elif v > 1.0:
            v = 1.0
            u = min(max((B - C) / A, 0.0), 1.0)
        rx = wx + u * d1x - v * d2x
        ry = wy + u * d1y - v * d2y
        rz = wz + u * d1z - v * d2z
        return (rx * rx + ry * ry + rz * rz, rx, ry, rz, u, 0.0, segment_feature(u), v, 0.0,
                segment_feature(v))
    best = math.inf
    brx = bry = brz = 0.0
    bu = bv = 0.0
    if den > 0.0 and den > 1e-30 * A * E:
        u = (B * F - C * E) / den
        v = (A * F - B * C) / den
        if 0.0 < u < 1.0 and 0.0 < v < 1.0:
            rx = wx + u * d1x - v * d2x
            ry = wy + u * d1y - v * d2y
            rz = wz + u * d1z - v * d2z
            best = rx * rx + ry * ry + rz * rz
            brx, bry, brz, bu, bv = rx, ry, rz, u, v
    # near-parallel or degenerate: also every endpoint of one segment against the other segment
    for k in range(4):
        if k == 0:
            cx, cy, cz, v, f = closest_point_segment(px, py, pz, ax, ay, az, bx, by, bz)
            rx = px - cx
            ry = py - cy
            rz = pz - cz
            u = 0.0
        elif k == 1:
            cx, cy, cz, v, f = closest_point_segment(qx, qy, qz, ax, ay, az, bx, by, bz)
            rx = qx - cx
            ry = qy - cy
            rz = qz - cz
            u = 1.0
        elif k == 2:
            cx, cy, cz, u, f = closest_point_segment(ax, ay, az, px, py, pz, qx, qy, qz)
            rx = cx - ax
            ry = cy - ay
            rz = cz - az
            v = 0.0
        else:
            cx, cy, cz, u, f = closest_point_segment(bx, by, bz, px, py, pz, qx, qy, qz)
            rx = cx - bx
            ry = cy - by
            rz = cz - bz
            v = 1.0
        d2 = rx * rx + ry * ry + rz * rz
        if d2 < best:
            best = d2
            brx, bry, brz, bu, bv = rx, ry, rz, u, v
    return (best, brx, bry, brz, bu, 0.0, segment_feature(bu), bv, 0.0, segment_feature(bv))


@numba.njit(**NJIT)
def segment_segment_interior(px, py, pz, qx, qy, qz, ax, ay, az, bx, by, bz):
    """The interior stationary pair of segments ``pq`` and ``ab``, if there is one.

    Returns ``(found, d2, rx, ry, rz, u, v)`` with ``0 < u, v < 1``. When the segments are part of
    triangles whose vertex-simplex pairs are also checked, this is all an edge pair adds: its
    boundary candidates are vertex-edge pairs, dominated by the vertex-triangle ones.
    """
    d1x = qx - px
    d1y = qy - py
    d1z = qz - pz
    d2x = bx - ax
    d2y = by - ay
    d2z = bz - az
    wx = px - ax
    wy = py - ay
    wz = pz - az
    A = d1x * d1x + d1y * d1y + d1z * d1z
    E = d2x * d2x + d2y * d2y + d2z * d2z
    B = d1x * d2x + d1y * d2y + d1z * d2z
    C = d1x * wx + d1y * wy + d1z * wz
    F = d2x * wx + d2y * wy + d2z * wz
    den = A * E - B * B
    if den > 0.0 and den > 1e-30 * A * E:
        u = (B * F - C * E) / den
        v = (A * F - B * C) / den
        if 0.0 < u < 1.0 and 0.0 < v < 1.0:
            rx = wx + u * d1x - v * d2x
            ry = wy + u * d1y - v * d2y
            rz = wz + u * d1z - v * d2z
            return True, rx * rx + ry * ry + rz * rz, rx, ry, rz, u, v
    return False, math.inf, 0.0, 0.0, 0.0, 0.0, 0.0


@numba.njit(**NJIT)
def _plane_sides(px, py, pz, qx, qy, qz, rx_, ry_, rz_, ax, ay, az, bx, by, bz, cx, cy, cz):
    """True if ``p, q, r`` all lie strictly on one side of the plane of ``abc`` (no crossing)."""
    abx = bx - ax
    aby = by - ay
    abz = bz - az
    acx = cx - ax
    acy = cy - ay
    acz = cz - az
    nx = aby * acz - abz * acy
    ny = abz * acx - abx * acz
    nz = abx * acy - aby * acx
    s0 = nx * (px - ax) + ny * (py - ay) + nz * (pz - az)
    s1 = nx * (qx - ax) + ny * (qy - ay) + nz * (qz - az)
    s2 = nx * (rx_ - ax) + ny * (ry_ - ay) + nz * (rz_ - az)
    return (s0 > 0.0 and s1 > 0.0 and s2 > 0.0) or (s0 < 0.0 and s1 < 0.0 and s2 < 0.0)


@numba.njit(**NJIT)
def segment_crosses_triangle(px, py, pz, qx, qy, qz, ax, ay, az, bx, by, bz, cx, cy, cz):
    """Where segment ``pq`` meets the (non-degenerate) triangle ``abc``, if it does.

    Returns ``(hit, u, s, t)``: the point ``p + u (q - p) = a + s (b - a) + t (c - a)``. A segment
    lying in the triangle's plane is reported as not crossing (its boundary candidates find it).
    """
    abx = bx - ax
    aby = by - ay
    abz = bz - az
    acx = cx - ax
    acy = cy - ay
    acz = cz - az
    nx = aby * acz - abz * acy
    ny = abz * acx - abx * acz
    nz = abx * acy - aby * acx
    s0 = nx * (px - ax) + ny * (py - ay) + nz * (pz - az)
    s1 = nx * (qx - ax) + ny * (qy - ay) + nz * (qz - az)
    if s0 == s1 or (s0 > 0.0 and s1 > 0.0) or (s0 < 0.0 and s1 < 0.0):
        return False, 0.0, 0.0, 0.0
    u = s0 / (s0 - s1)
    xx = px + u * (qx - px) - ax
    xy = py + u * (qy - py) - ay
    xz = pz + u * (qz - pz) - az
    n2 = nx * nx + ny * ny + nz * nz
    # s n = (x - a) x ac,  t n = ab x (x - a)
    s = ((xy * acz - xz * acy) * nx + (xz * acx - xx * acz) * ny + (xx * acy - xy * acx) * nz) / n2
    t = ((aby * xz - abz * xy) * nx + (abz * xx - abx * xz) * ny + (abx * xy - aby * xx) * nz) / n2
    if s < 0.0 or t < 0.0 or s + t > 1.0:
        return False, 0.0, 0.0, 0.0
    return True, u, s, t


@numba.njit(**NJIT)
def segment_triangle(px, py, pz, qx, qy, qz, ax, ay, az, bx, by, bz, cx, cy, cz):
    """Segment ``pq`` (query) against triangle ``abc`` (degenerate either side allowed).

    Candidates: a crossing (distance 0); each endpoint against the triangle; each triangle vertex
    against the segment; each triangle edge against the segment at an interior stationary pair.
    """
    if not triangle_is_degenerate(ax, ay, az, bx, by, bz, cx, cy, cz):
        hit, u, s, t = segment_crosses_triangle(px, py, pz, qx, qy, qz, ax, ay, az, bx, by, bz,
                                                cx, cy, cz)
        if hit:
            return 0.0, 0.0, 0.0, 0.0, u, 0.0, segment_feature(u), s, t, TRI_INTERIOR
    best = math.inf
    out = (math.inf, 0.0, 0.0, 0.0, 0.0, 0.0, 0, 0.0, 0.0, 0)
    # the segment's endpoints against the triangle
    for k in range(2):
        ex, ey, ez = (px, py, pz) if k == 0 else (qx, qy, qz)
        c = point_triangle(ex, ey, ez, ax, ay, az, bx, by, bz, cx, cy, cz)
        if c[0] < best:
            best = c[0]
            out = (c[0], c[1], c[2], c[3], float(k), 0.0, SEG_A if k == 0 else SEG_B,
                   c[7], c[8], c[9])
    # the triangle's vertices against the segment
    for k in range(3):
        if k == 0:
            ex, ey, ez, ds, dt, df = ax, ay, az, 0.0, 0.0, TRI_A
        elif k == 1:
            ex, ey, ez, ds, dt, df = bx, by, bz, 1.0, 0.0, TRI_B
        else:
            ex, ey, ez, ds, dt, df = cx, cy, cz, 0.0, 1.0, TRI_C
        gx, gy, gz, u, f = closest_point_segment(ex, ey, ez, px, py, pz, qx, qy, qz)
        rx = gx - ex
        ry = gy - ey
        rz = gz - ez
        d2 = rx * rx + ry * ry + rz * rz
        if d2 < best:
            best = d2
            out = (d2, rx, ry, rz, u, 0.0, f, ds, dt, df)
    # the segment against the triangle's edges, interior pairs only
    for e in range(3):
        ux, uy, uz, vx, vy, vz = _edge_vertices(e, ax, ay, az, bx, by, bz, cx, cy, cz)
        found, d2, rx, ry, rz, u, v = segment_segment_interior(px, py, pz, qx, qy, qz, ux, uy,
                                                               uz, vx, vy, vz)
        if found and d2 < best:
            best = d2
            s, t, f = triangle_edge_point(e, v)
            out = (d2, rx, ry, rz, u, 0.0, SEG_INTERIOR, s, t, f)
    return out


@numba.njit(**NJIT)
def triangle_segment(px, py, pz, qx, qy, qz, rx_, ry_, rz_, ax, ay, az, bx, by, bz):
    """Triangle ``pqr`` (query) against segment ``ab``."""
    c = segment_triangle(ax, ay, az, bx, by, bz, px, py, pz, qx, qy, qz, rx_, ry_, rz_)
    return c[0], -c[1], -c[2], -c[3], c[7], c[8], c[9], c[4], c[5], c[6]


@numba.njit(**NJIT)
def triangle_point(px, py, pz, qx, qy, qz, rx_, ry_, rz_, ax, ay, az):
    """Triangle ``pqr`` (query) against point ``a``."""
    c = point_triangle(ax, ay, az, px, py, pz, qx, qy, qz, rx_, ry_, rz_)
    return c[0], -c[1], -c[2], -c[3], c[7], c[8], c[9], 0.0, 0.0, 0


@numba.njit(**NJIT)
def segment_point(px, py, pz, qx, qy, qz, ax, ay, az):
    """Segment ``pq`` (query) against point ``a``."""
    c = point_segment(ax, ay, az, px, py, pz, qx, qy, qz)
    return c[0], -c[1], -c[2], -c[3], c[7], 0.0, c[9], 0.0, 0.0, 0


@numba.njit(**NJIT)
def triangle_triangle(px, py, pz, qx, qy, qz, rx_, ry_, rz_, ax, ay, az, bx, by, bz, cx, cy, cz):
    """Triangle ``pqr`` (query) against triangle ``abc`` (degenerate either side allowed).

    Candidates: an edge of one crossing the other (distance 0; skipped when the first lies
    strictly on one side of the second's plane); each vertex against the other triangle; each
    edge pair at an interior stationary pair.
    """
    qdeg = triangle_is_degenerate(px, py, pz, qx, qy, qz, rx_, ry_, rz_)
    ddeg = triangle_is_degenerate(ax, ay, az, bx, by, bz, cx, cy, cz)
    if not ddeg and not _plane_sides(px, py, pz, qx, qy, qz, rx_, ry_, rz_, ax, ay, az, bx, by,
                                     bz, cx, cy, cz):
        for e in range(3):
            ux, uy, uz, vx, vy, vz = _edge_vertices(e, px, py, pz, qx, qy, qz, rx_, ry_, rz_)
            hit, u, s, t = segment_crosses_triangle(ux, uy, uz, vx, vy, vz, ax, ay, az, bx, by,
                                                    bz, cx, cy, cz)
            if hit:
                qs, qt, qf = triangle_edge_point(e, u)
                return 0.0, 0.0, 0.0, 0.0, qs, qt, qf, s, t, TRI_INTERIOR
    if not qdeg and not _plane_sides(ax, ay, az, bx, by, bz, cx, cy, cz, px, py, pz, qx, qy, qz,
                                     rx_, ry_, rz_):
        for e in range(3):
            ux, uy, uz, vx, vy, vz = _edge_vertices(e, ax, ay, az, bx, by, bz, cx, cy, cz)
            hit, u, s, t = segment_crosses_triangle(ux, uy, uz, vx, vy, vz, px, py, pz, qx, qy,
                                                    qz, rx_, ry_, rz_)
            if hit:
                ds, dt, df = triangle_edge_point(e, u)
                return 0.0, 0.0, 0.0, 0.0, s, t, TRI_INTERIOR, ds, dt, df
    best = math.inf
    out = (math.inf, 0.0, 0.0, 0.0, 0.0, 0.0, 0, 0.0, 0.0, 0)
    # vertices of each against the other
    for k in range(3):
        if k == 0:
            ex, ey, ez, qs, qt, qf = px, py, pz, 0.0, 0.0, TRI_A
        elif k == 1:
            ex, ey, ez, qs, qt, qf = qx, qy, qz, 1.0, 0.0, TRI_B
        else:
            ex, ey, ez, qs, qt, qf = rx_, ry_, rz_, 0.0, 1.0, TRI_C
        c = point_triangle(ex, ey, ez, ax, ay, az, bx, by, bz, cx, cy, cz)
        if c[0] < best:
            best = c[0]
            out = (c[0], c[1], c[2], c[3], qs, qt, qf, c[7], c[8], c[9])
    for k in range(3):
        if k == 0:
            ex, ey, ez, ds, dt, df = ax, ay, az, 0.0, 0.0, TRI_A
        elif k == 1:
            ex, ey, ez, ds, dt, df = bx, by, bz, 1.0, 0.0, TRI_B
        else:
            ex, ey, ez, ds, dt, df = cx, cy, cz, 0.0, 1.0, TRI_C
        c = point_triangle(ex, ey, ez, px, py, pz, qx, qy, qz, rx_, ry_, rz_)
        if c[0] < best:
            best = c[0]
            out = (c[0], -c[1], -c[2], -c[3], c[7], c[8], c[9], ds, dt, df)
    # edges against edges, interior pairs only
    for e in range(3):
        ux, uy, uz, vx, vy, vz = _edge_vertices(e, px, py, pz, qx, qy, qz, rx_, ry_, rz_)
        for f in range(3):
            gx, gy, gz, hx, hy, hz = _edge_vertices(f, ax, ay, az, bx, by, bz, cx, cy, cz)
            found, d2, rx, ry, rz, u, v = segment_segment_interior(ux, uy, uz, vx, vy, vz, gx, gy,
                                                                   gz, hx, hy, hz)
            if found and d2 < best:
                best = d2
                qs, qt, qf = triangle_edge_point(e, u)
                ds, dt, df = triangle_edge_point(f, v)
                out = (d2, rx, ry, rz, qs, qt, qf, ds, dt, df)
    return out


@numba.njit(**NJIT)
def closest_pair(kq, Q, kd, P):
    """Closest pair between query primitive ``(kq, Q)`` and data primitive ``(kd, P)``.

    ``kq``/``kd``: 0 point, 1 segment, 2 triangle; ``Q``, ``P``: (9,) float64 vertex coordinates
    ``x0 y0 z0 x1 y1 z1 x2 y2 z2`` (unused slots ignored). Returns the 10-tuple described in the
    module docstring.
    """
    if kq == 0:
        if kd == 0:
            rx = Q[0] - P[0]
            ry = Q[1] - P[1]
            rz = Q[2] - P[2]
            return rx * rx + ry * ry + rz * rz, rx, ry, rz, 0.0, 0.0, 0, 0.0, 0.0, 0
        if kd == 1:
            return point_segment(Q[0], Q[1], Q[2], P[0], P[1], P[2], P[3], P[4], P[5])
        return point_triangle(Q[0], Q[1], Q[2], P[0], P[1], P[2], P[3], P[4], P[5], P[6], P[7],
                              P[8])
    if kq == 1:
        if kd == 0:
            return segment_point(Q[0], Q[1], Q[2], Q[3], Q[4], Q[5], P[0], P[1], P[2])
        if kd == 1:
            return segment_segment(Q[0], Q[1], Q[2], Q[3], Q[4], Q[5], P[0], P[1], P[2], P[3],
                                   P[4], P[5])
        return segment_triangle(Q[0], Q[1], Q[2], Q[3], Q[4], Q[5], P[0], P[1], P[2], P[3], P[4],
                                P[5], P[6], P[7], P[8])
    if kd == 0:
        return triangle_point(Q[0], Q[1], Q[2], Q[3], Q[4], Q[5], Q[6], Q[7], Q[8], P[0], P[1],
                              P[2])
    if kd == 1:
        return triangle_segment(Q[0], Q[1], Q[2], Q[3], Q[4], Q[5], Q[6], Q[7], Q[8], P[0], P[1],
                                P[2], P[3], P[4], P[5])
    return triangle_triangle(Q[0], Q[1], Q[2], Q[3], Q[4], Q[5], Q[6], Q[7], Q[8], P[0], P[1],
                             P[2], P[3], P[4], P[5], P[6], P[7], P[8])
