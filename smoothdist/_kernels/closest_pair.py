"""Exact closest pairs between two simplices (point, segment, triangle), both sides' barycentrics.

The paper's generalized query primitives (Madan & Levin 2022, Sec. 3.4, App. B) need the
distance between a query primitive ``g`` and a data primitive ``f``, the closest points on both,
and the barycentric coordinates of both points (the data side's feed the weight function).

Every kernel works on float64 scalars and returns

    ``(d2, rx, ry, rz, qs, qt, qf, ds, dt, df)``

* ``d2``: squared distance;
* ``r = (point on the first primitive) - (point on the second)``: the first is the *query*;
* ``(qs, qt, qf)`` and ``(ds, dt, df)``: parameters and feature code of the closest point on the
  query and on the data primitive, in the conventions of :mod:`smoothdist._kernels.closest_point`:
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
boundary candidates are vertex-edge pairs, which the vertex-triangle pairs dominate). Every
candidate's distance is measured between two actual points of the primitives, so rounding can only
overestimate by an ulp-level amount, never report a pair that does not exist.

Robustness: zero-length segments and zero-area triangles (possible on the query side, which is not
repaired) reduce to their vertices and edges; parallel segments and a segment parallel to a
triangle fall back to the boundary candidates, which contain a minimiser.
"""

import math

import numba
import numpy as np

from smoothdist._config import NJIT, NJIT_INLINE, NJIT_IR_INLINE
from smoothdist._kernels.closest_point import (SEG_A, SEG_B, SEG_INTERIOR, TRI_A, TRI_AB, TRI_AC,
                                               TRI_B, TRI_BC, TRI_C, TRI_INTERIOR,
                                               closest_point_segment, closest_point_triangle)

KIND_POINT, KIND_SEGMENT, KIND_TRIANGLE = 0, 1, 2
#: the kinds, and 0 for counters and unset feature codes, as int64: a plain ``1`` or ``0`` is
#: typed as a literal, and each literal kind, literal counter and tuple type holding a literal
#: feature compiled the tie kernels again (7 copies of :func:`tie_of_two`, 4 of
#: :func:`tied_pair`; numba's compile events, issue 51)
_SEG = np.int64(KIND_SEGMENT)
_TRI = np.int64(KIND_TRIANGLE)
_ZERO = np.int64(0)
#: ``seg_query`` of :func:`_segment_triangle` as a run-time bool (a constant True / False is a
#: literal: the whole pair kernel compiled twice, once per role, for a branch taken on ties only)
_SEGMENT_QUERY = np.bool_(True)
_TRIANGLE_QUERY = np.bool_(False)

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
    return n2 <= (DEGENERATE * (abx * abx + aby * aby + abz * abz)
                  * (acx * acx + acy * acy + acz * acz))


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
    M, L = pair_scale(px, py, pz, qx, qy, qz, qx, qy, qz, ax, ay, az, bx, by, bz, bx, by, bz)
    ntie = _ZERO
    # the other of two tied pairs (the common case of a tie: handled without tied_pair)
    r2x = r2y = r2z = u2 = v2 = 0.0
    if den > 0.0 and den > 1e-30 * A * E:
        u = (B * F - C * E) / den
        v = (A * F - B * C) / den
        if 0.0 < u < 1.0 and 0.0 < v < 1.0:
            rx = wx + u * d1x - v * d2x
            ry = wy + u * d1y - v * d2y
            rz = wz + u * d1z - v * d2z
            best = rx * rx + ry * ry + rz * rz
            brx, bry, brz, bu, bv = rx, ry, rz, u, v
            ntie = 1
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
        nt = count_ties(d2, u, 0.0, best, bu, 0.0, ntie, M, L)
        if nt == 2 and ntie == 1:
            if d2 < best:
                r2x, r2y, r2z, u2, v2 = brx, bry, brz, bu, bv
            else:
                r2x, r2y, r2z, u2, v2 = rx, ry, rz, u, v
        ntie = nt
        if d2 < best:
            best = d2
            brx, bry, brz, bu, bv = rx, ry, rz, u, v
    if ntie == 2 and best > 0.0:
        return tie_of_two(_SEG, _flat(px, py, pz, qx, qy, qz, qx, qy, qz), _SEG, best,
                          (best, brx, bry, brz, bu, 0.0, segment_feature(bu), bv, 0.0,
                           segment_feature(bv)),
                          (best, r2x, r2y, r2z, u2, 0.0, segment_feature(u2), v2, 0.0,
                           segment_feature(v2)))
    if ntie > 2 and best > 0.0:
        return tied_pair(_SEG, _flat(px, py, pz, qx, qy, qz, qx, qy, qz), _SEG,
                         _flat(ax, ay, az, bx, by, bz, bx, by, bz))
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


#: the four wrappers below are merged into their callers (``NJIT_IR_INLINE``): a compiled
#: wrapper would optimise and generate its callee's whole code again (performance guide, "Cold
#: start")
@numba.njit(**NJIT_IR_INLINE)
def segment_triangle(px, py, pz, qx, qy, qz, ax, ay, az, bx, by, bz, cx, cy, cz):
    """Segment ``pq`` (query) against triangle ``abc`` (degenerate either side allowed).

    Candidates: a crossing (distance 0); each endpoint against the triangle; each triangle vertex
    against the segment; each triangle edge against the segment at an interior stationary pair.
    Tied candidates: :func:`tied_pair`.
    """
    return _segment_triangle(px, py, pz, qx, qy, qz, ax, ay, az, bx, by, bz, cx, cy, cz,
                             _SEGMENT_QUERY)


@numba.njit(**NJIT_INLINE)
def _segment_triangle(px, py, pz, qx, qy, qz, ax, ay, az, bx, by, bz, cx, cy, cz, seg_query):
    """:func:`segment_triangle`; ``seg_query`` False: the triangle is the query (ties are
    resolved on its side), the result still in the segment-first convention. Inlined into
    both, with ``seg_query`` a constant (a call, compiled once, made the edge-triangle pairs of
    the whole-mesh distance slower warm)."""
    if not triangle_is_degenerate(ax, ay, az, bx, by, bz, cx, cy, cz):
        hit, u, s, t = segment_crosses_triangle(px, py, pz, qx, qy, qz, ax, ay, az, bx, by, bz,
                                                cx, cy, cz)
        if hit:
            return 0.0, 0.0, 0.0, 0.0, u, 0.0, segment_feature(u), s, t, TRI_INTERIOR
    best = math.inf
    out = (math.inf, 0.0, 0.0, 0.0, 0.0, 0.0, _ZERO, 0.0, 0.0, _ZERO)
    M, L = pair_scale(px, py, pz, qx, qy, qz, qx, qy, qz, ax, ay, az, bx, by, bz, cx, cy, cz)
    ntie = _ZERO
    out2 = out
    # the segment's endpoints against the triangle
    for k in range(2):
        ex, ey, ez = (px, py, pz) if k == 0 else (qx, qy, qz)
        c = point_triangle(ex, ey, ez, ax, ay, az, bx, by, bz, cx, cy, cz)
        nt = count_ties(c[0], float(k), 0.0, best, out[4], 0.0, ntie, M, L)
        if nt == 2 and ntie == 1:
            out2 = out if c[0] < best else (c[0], c[1], c[2], c[3], float(k), 0.0,
                                            SEG_A if k == 0 else SEG_B, c[7], c[8], c[9])
        ntie = nt
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
        nt = count_ties(d2, u, 0.0, best, out[4], 0.0, ntie, M, L)
        if nt == 2 and ntie == 1:
            out2 = out if d2 < best else (d2, rx, ry, rz, u, 0.0, f, ds, dt, df)
        ntie = nt
        if d2 < best:
            best = d2
            out = (d2, rx, ry, rz, u, 0.0, f, ds, dt, df)
    # the segment against the triangle's edges, interior pairs only
    for e in range(3):
        ux, uy, uz, vx, vy, vz = _edge_vertices(e, ax, ay, az, bx, by, bz, cx, cy, cz)
        found, d2, rx, ry, rz, u, v = segment_segment_interior(px, py, pz, qx, qy, qz, ux, uy,
                                                               uz, vx, vy, vz)
        if found:
            nt = count_ties(d2, u, 0.0, best, out[4], 0.0, ntie, M, L)
            if nt == 2 and ntie == 1:
                if d2 < best:
                    out2 = out
                else:
                    s, t, f = triangle_edge_point(e, v)
                    out2 = (d2, rx, ry, rz, u, 0.0, SEG_INTERIOR, s, t, f)
            ntie = nt
            if d2 < best:
                best = d2
                s, t, f = triangle_edge_point(e, v)
                out = (d2, rx, ry, rz, u, 0.0, SEG_INTERIOR, s, t, f)
    if ntie > 1 and best > 0.0:
        S = _flat(px, py, pz, qx, qy, qz, qx, qy, qz)
        T = _flat(ax, ay, az, bx, by, bz, cx, cy, cz)
        if seg_query:
            if ntie == 2:
                return tie_of_two(_SEG, S, _TRI, best, out, out2)
            return tied_pair(_SEG, S, _TRI, T)
        if ntie == 2:
            c = tie_of_two(_TRI, T, _SEG, best, _swap(out), _swap(out2))
        else:
            c = tied_pair(_TRI, T, _SEG, S)
        return _swap(c)
    return out


@numba.njit(**NJIT_IR_INLINE)
def triangle_segment(px, py, pz, qx, qy, qz, rx_, ry_, rz_, ax, ay, az, bx, by, bz):
    """Triangle ``pqr`` (query) against segment ``ab``."""
    c = _segment_triangle(ax, ay, az, bx, by, bz, px, py, pz, qx, qy, qz, rx_, ry_, rz_,
                          _TRIANGLE_QUERY)
    return c[0], -c[1], -c[2], -c[3], c[7], c[8], c[9], c[4], c[5], c[6]


@numba.njit(**NJIT_IR_INLINE)
def triangle_point(px, py, pz, qx, qy, qz, rx_, ry_, rz_, ax, ay, az):
    """Triangle ``pqr`` (query) against point ``a``."""
    c = point_triangle(ax, ay, az, px, py, pz, qx, qy, qz, rx_, ry_, rz_)
    return c[0], -c[1], -c[2], -c[3], c[7], c[8], c[9], 0.0, 0.0, 0


@numba.njit(**NJIT_IR_INLINE)
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
    out = (math.inf, 0.0, 0.0, 0.0, 0.0, 0.0, _ZERO, 0.0, 0.0, _ZERO)
    M, L = pair_scale(px, py, pz, qx, qy, qz, rx_, ry_, rz_, ax, ay, az, bx, by, bz, cx, cy, cz)
    ntie = _ZERO
    out2 = out
    # vertices of each against the other
    for k in range(3):
        if k == 0:
            ex, ey, ez, qs, qt, qf = px, py, pz, 0.0, 0.0, TRI_A
        elif k == 1:
            ex, ey, ez, qs, qt, qf = qx, qy, qz, 1.0, 0.0, TRI_B
        else:
            ex, ey, ez, qs, qt, qf = rx_, ry_, rz_, 0.0, 1.0, TRI_C
        c = point_triangle(ex, ey, ez, ax, ay, az, bx, by, bz, cx, cy, cz)
        nt = count_ties(c[0], qs, qt, best, out[4], out[5], ntie, M, L)
        if nt == 2 and ntie == 1:
            out2 = out if c[0] < best else (c[0], c[1], c[2], c[3], qs, qt, qf, c[7], c[8],
                                            c[9])
        ntie = nt
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
        nt = count_ties(c[0], c[7], c[8], best, out[4], out[5], ntie, M, L)
        if nt == 2 and ntie == 1:
            out2 = out if c[0] < best else (c[0], -c[1], -c[2], -c[3], c[7], c[8], c[9], ds,
                                            dt, df)
        ntie = nt
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
            if found:
                qs, qt, qf = triangle_edge_point(e, u)
                nt = count_ties(d2, qs, qt, best, out[4], out[5], ntie, M, L)
                if nt == 2 and ntie == 1:
                    if d2 < best:
                        out2 = out
                    else:
                        ds, dt, df = triangle_edge_point(f, v)
                        out2 = (d2, rx, ry, rz, qs, qt, qf, ds, dt, df)
                ntie = nt
                if d2 < best:
                    best = d2
                    ds, dt, df = triangle_edge_point(f, v)
                    out = (d2, rx, ry, rz, qs, qt, qf, ds, dt, df)
    if ntie == 2 and best > 0.0:
        return tie_of_two(_TRI, _flat(px, py, pz, qx, qy, qz, rx_, ry_, rz_), _TRI, best, out,
                          out2)
    if ntie > 2 and best > 0.0:
        return tied_pair(_TRI, _flat(px, py, pz, qx, qy, qz, rx_, ry_, rz_), _TRI,
                         _flat(ax, ay, az, bx, by, bz, cx, cy, cz))
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


# --- ties: a canonical closest pair where the closest set is not a single pair ----------------
#
# Two simplices at distance d > 0 have a unique closest *offset* r = x - y (the closest point of
# the convex Minkowski difference), but where a query edge or face is parallel to a data edge or
# face the closest *pairs* (x, x - r) form a segment or a polygon S. The candidates above find its
# corners, all at the same distance up to rounding, and picking the first or the smallest of them
# lets rounding choose an end of S: the data barycentrics, hence the weight and d_hat, jump as
# the query moves (issue 37). Where several candidates tie, the pair reported is instead the
# point of S nearest the query's centroid (a projection onto a convex set, so it moves
# continuously with S). Each case of that rule moves the way :func:`smoothdist._kernels.mesh_query.
# weight_gradient` assumes for the reported features: the centroid itself is fixed on the query;
# a projection onto an edge of S that lies on a data edge slides along that edge; one onto a
# crossing of a query and a data edge moves as that crossing does.

#: candidates whose squared distances differ by at most ``TIE * M * (sqrt(d2) + L)`` are tied
#: (``M`` the largest coordinate magnitude, ``L`` the pair's extent): rounding of the candidates'
#: squared distances is about ``20 eps M |r|``, 2,000x below it, while a genuine near-tie that it
#: merges is a tilt of the parallel features below ``1e-10 M / L`` radians
TIE = 1e-10
#: candidates one pair can have (triangle-triangle: 3 + 3 vertex pairs and 9 edge pairs)
MAX_CANDIDATES = 15

_TRI_MASK = (7, 3, 5, 6, 1, 2, 4)     # feature code -> vertex set (a = 1, b = 2, c = 4)
_TRI_CODE = (0, 4, 5, 1, 6, 2, 3, 0)  # vertex set -> feature code
_SEG_MASK = (3, 1, 2)
_SEG_CODE = (0, 1, 2, 0)


@numba.njit(**NJIT_INLINE)
def pair_scale(px, py, pz, qx, qy, qz, rx_, ry_, rz_, ax, ay, az, bx, by, bz, cx, cy, cz):
    """``(M, L)`` of the tie rule for the six vertices of a pair (a segment repeats a vertex)."""
    lx = min(min(px, qx, rx_), min(ax, bx, cx))
    hx = max(max(px, qx, rx_), max(ax, bx, cx))
    ly = min(min(py, qy, ry_), min(ay, by, cy))
    hy = max(max(py, qy, ry_), max(ay, by, cy))
    lz = min(min(pz, qz, rz_), min(az, bz, cz))
    hz = max(max(pz, qz, rz_), max(az, bz, cz))
    M = max(max(-lx, hx), max(-ly, hy), max(-lz, hz))
    L = max(hx - lx, hy - ly, hz - lz)
    return M, L


@numba.njit(**NJIT_INLINE)
def _flat(px, py, pz, qx, qy, qz, rx_, ry_, rz_):
    """The nine coordinates as a tuple (indexable like an array, no allocation)."""
    return (px, py, pz, qx, qy, qz, rx_, ry_, rz_)


@numba.njit(**NJIT_INLINE)
def _swap(c):
    """A result with the roles of the two primitives exchanged."""
    return c[0], -c[1], -c[2], -c[3], c[7], c[8], c[9], c[4], c[5], c[6]


@numba.njit(**NJIT)
def tie_of_two(kq, Q, kd, best, a, b):
    """:func:`tied_pair` where exactly two distinct candidates ``a`` and ``b`` (10-tuples) tie:
    the closest set is the segment between them, and its point nearest the query's centroid
    is a clamped projection (no candidate is computed again)."""
    xa0 = Q[0] + a[4] * (Q[3] - Q[0])
    xa1 = Q[1] + a[4] * (Q[4] - Q[1])
    xa2 = Q[2] + a[4] * (Q[5] - Q[2])
    xb0 = Q[0] + b[4] * (Q[3] - Q[0])
    xb1 = Q[1] + b[4] * (Q[4] - Q[1])
    xb2 = Q[2] + b[4] * (Q[5] - Q[2])
    c0 = (Q[0] + Q[3]) * 0.5
    c1 = (Q[1] + Q[4]) * 0.5
    c2 = (Q[2] + Q[5]) * 0.5
    if kq == 2:
        xa0 += a[5] * (Q[6] - Q[0])
        xa1 += a[5] * (Q[7] - Q[1])
        xa2 += a[5] * (Q[8] - Q[2])
        xb0 += b[5] * (Q[6] - Q[0])
        xb1 += b[5] * (Q[7] - Q[1])
        xb2 += b[5] * (Q[8] - Q[2])
        c0 = (Q[0] + Q[3] + Q[6]) / 3.0
        c1 = (Q[1] + Q[4] + Q[7]) / 3.0
        c2 = (Q[2] + Q[5] + Q[8]) / 3.0
    e0 = xb0 - xa0
    e1 = xb1 - xa1
    e2 = xb2 - xa2
    ee = e0 * e0 + e1 * e1 + e2 * e2
    lam = 0.0
    if ee > 0.0:
        lam = min(max(((c0 - xa0) * e0 + (c1 - xa1) * e1 + (c2 - xa2) * e2) / ee, 0.0), 1.0)
    return _between(kq, kd, best, a, b, lam)


@numba.njit(**NJIT_INLINE)
def _row(C, i):
    """Row ``i`` of a candidate buffer as the module's 10-tuple."""
    return (C[i, 0], C[i, 1], C[i, 2], C[i, 3], C[i, 4], C[i, 5], int(C[i, 6]), C[i, 7],
            C[i, 8], int(C[i, 9]))


@numba.njit(**NJIT_INLINE)
def _between(kq, kd, best, a, b, lam):
    """The pair at ``lam`` in [0, 1] between tied pairs ``a`` and ``b`` (10-tuples), at squared
    distance ``best``: an affine map takes the query's parameters to the data's on the closest
    set, so both sides interpolate; the features are the smallest faces holding both ends."""
    if lam <= 0.0:
        return best, a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8], a[9]
    if lam >= 1.0:
        return best, b[1], b[2], b[3], b[4], b[5], b[6], b[7], b[8], b[9]
    u = 1.0 - lam
    return (best, u * a[1] + lam * b[1], u * a[2] + lam * b[2], u * a[3] + lam * b[3],
            u * a[4] + lam * b[4], u * a[5] + lam * b[5], _union_feature(kq, a[6], b[6]),
            u * a[7] + lam * b[7], u * a[8] + lam * b[8], _union_feature(kd, a[9], b[9]))


@numba.njit(**NJIT_INLINE)
def is_tied(d2, best, M, L):
    """True when squared distances ``d2`` and ``best`` are equal under the tie rule."""
    return abs(d2 - best) <= TIE * M * (math.sqrt(min(d2, best)) + L)


#: tied candidates whose query parameters differ by less than this are one pair found twice
#: (a vertex pair is found from both sides), not a closest set
SAME_PAIR = 1e-9


@numba.njit(**NJIT_INLINE)
def count_ties(d2, s, t, best, bs, bt, ntie, M, L):
    """Running count of the distinct pairs tied with the running minimum: candidate ``d2`` at
    query parameters ``(s, t)`` against ``best`` at ``(bs, bt)``, before ``d2`` is taken."""
    if best == math.inf:
        return 1
    if is_tied(d2, best, M, L):
        if abs(s - bs) + abs(t - bt) > SAME_PAIR:
            return ntie + 1
        return ntie
    if d2 < best:
        return 1
    return ntie


@numba.njit(**NJIT)
def _vertex_params(kind, i):
    """Parameters ``(s, t, feature)`` of vertex ``i`` of a segment (kind 1) or triangle."""
    if kind == 1:
        return float(i), 0.0, SEG_A if i == 0 else SEG_B
    if i == 0:
        return 0.0, 0.0, TRI_A
    if i == 1:
        return 1.0, 0.0, TRI_B
    return 0.0, 1.0, TRI_C


@numba.njit(**NJIT)
def _point_to(kind, x, y, z, X):
    """Closest point of primitive ``X`` (kind 1 or 2) to ``(x, y, z)``: ``(d2, r, s, t, f)`` with
    ``r = (x, y, z) - closest point``."""
    if kind == 1:
        c = point_segment(x, y, z, X[0], X[1], X[2], X[3], X[4], X[5])
    else:
        c = point_triangle(x, y, z, X[0], X[1], X[2], X[3], X[4], X[5], X[6], X[7], X[8])
    return c[0], c[1], c[2], c[3], c[7], c[8], c[9]


@numba.njit(**NJIT)
def _union_feature(kind, f, g):
    """The smallest face of a segment or triangle holding both features ``f`` and ``g``."""
    if kind == 1:
        return _SEG_CODE[_SEG_MASK[f] | _SEG_MASK[g]]
    return _TRI_CODE[_TRI_MASK[f] | _TRI_MASK[g]]


@numba.njit(**NJIT_INLINE)
def _put(C, n, d2, rx, ry, rz, qs, qt, qf, ds, dt, df):
    """Write a candidate (the module's 10-tuple) into row ``n`` of ``C``."""
    C[n, 0] = d2
    C[n, 1] = rx
    C[n, 2] = ry
    C[n, 3] = rz
    C[n, 4] = qs
    C[n, 5] = qt
    C[n, 6] = qf
    C[n, 7] = ds
    C[n, 8] = dt
    C[n, 9] = df


@numba.njit(**NJIT)
def _candidates(kq, Q, kd, P, C):
    """Fill ``C`` (MAX_CANDIDATES, >= 10) with every candidate pair of query ``(kq, Q)`` and data
    ``(kd, P)`` (kinds 1 or 2), as rows of the module's 10-tuple; returns their number."""
    n = _ZERO
    for i in range(kq + 1):
        d2, rx, ry, rz, s, t, f = _point_to(kd, Q[3 * i], Q[3 * i + 1], Q[3 * i + 2], P)
        qs, qt, qf = _vertex_params(kq, i)
        _put(C, n, d2, rx, ry, rz, qs, qt, qf, s, t, f)
        n += 1
    for j in range(kd + 1):
        d2, rx, ry, rz, s, t, f = _point_to(kq, P[3 * j], P[3 * j + 1], P[3 * j + 2], Q)
        ds, dt, df = _vertex_params(kd, j)
        _put(C, n, d2, -rx, -ry, -rz, s, t, f, ds, dt, df)
        n += 1
    ne_q = 1 if kq == 1 else 3
    ne_d = 1 if kd == 1 else 3
    for e in range(ne_q):
        ux, uy, uz, vx, vy, vz = _edge_vertices(e, Q[0], Q[1], Q[2], Q[3], Q[4], Q[5], Q[6],
                                                Q[7], Q[8])
        for g in range(ne_d):
            gx, gy, gz, hx, hy, hz = _edge_vertices(g, P[0], P[1], P[2], P[3], P[4], P[5], P[6],
                                                    P[7], P[8])
            found, d2, rx, ry, rz, u, v = segment_segment_interior(ux, uy, uz, vx, vy, vz, gx,
                                                                   gy, gz, hx, hy, hz)
            if not found:
                continue
            if kq == 1:
                qs, qt, qf = u, 0.0, SEG_INTERIOR
            else:
                qs, qt, qf = triangle_edge_point(e, u)
            if kd == 1:
                ds, dt, df = v, 0.0, SEG_INTERIOR
            else:
                ds, dt, df = triangle_edge_point(g, v)
            _put(C, n, d2, rx, ry, rz, qs, qt, qf, ds, dt, df)
            n += 1
    return n


@numba.njit(**NJIT)
def tied_pair(kq, Q, kd, P):
    """The canonical closest pair of query ``(kq, Q)`` and data ``(kd, P)`` (kinds 1 or 2; ``Q``,
    ``P`` flat (9,) float64) where several candidates tie: the point of the closest set nearest
    the query's centroid (see the comment above ``TIE``). Returns the module's 10-tuple; the
    squared distance is the smallest candidate's."""
    # one buffer: the candidates (columns 0-9), and in rows 0..m-1 the tied ones' points on the
    # query (10-12) and row numbers (13)
    C = np.empty((MAX_CANDIDATES, 14))
    n = _candidates(kq, Q, kd, P, C)
    best = math.inf
    ib = _ZERO
    for i in range(n):
        if C[i, 0] < best:
            best = C[i, 0]
            ib = i
    M, L = pair_scale(Q[0], Q[1], Q[2], Q[3], Q[4], Q[5], Q[6], Q[7], Q[8], P[0], P[1], P[2],
                      P[3], P[4], P[5], P[6], P[7], P[8])
    X = C[:, 10:13]
    m = 0
    for i in range(n):
        if is_tied(C[i, 0], best, M, L):
            s = C[i, 4]
            t = C[i, 5]
            for a in range(3):
                X[m, a] = Q[a] + s * (Q[3 + a] - Q[a])
                if kq == 2:
                    X[m, a] += t * (Q[6 + a] - Q[a])
            C[m, 13] = i
            m += 1
    if m <= 1:
        return _row(C, ib)
    # the query's centroid, and its nearest point on the hull of the tied points: the nearest
    # over every tied point and every segment between two (the hull's nearest point lies on an
    # edge of the hull, and every such segment lies in the hull)
    cx = cy = cz = 0.0
    for i in range(kq + 1):
        cx += Q[3 * i]
        cy += Q[3 * i + 1]
        cz += Q[3 * i + 2]
    cx /= kq + 1
    cy /= kq + 1
    cz /= kq + 1
    bd = math.inf
    bi = bj = 0
    bl = 0.0
    for i in range(m):
        for j in range(i, m):
            ex = X[j, 0] - X[i, 0]
            ey = X[j, 1] - X[i, 1]
            ez = X[j, 2] - X[i, 2]
            ee = ex * ex + ey * ey + ez * ez
            lam = 0.0
            if ee > 0.0:
                lam = ((cx - X[i, 0]) * ex + (cy - X[i, 1]) * ey + (cz - X[i, 2]) * ez) / ee
                lam = min(max(lam, 0.0), 1.0)
            px = X[i, 0] + lam * ex - cx
            py = X[i, 1] + lam * ey - cy
            pz = X[i, 2] + lam * ez - cz
            dd = px * px + py * py + pz * pz
            if dd < bd:
                bd, bi, bj, bl = dd, i, j, lam
    px = X[bi, 0] + bl * (X[bj, 0] - X[bi, 0]) - cx
    py = X[bi, 1] + bl * (X[bj, 1] - X[bi, 1]) - cy
    pz = X[bi, 2] + bl * (X[bj, 2] - X[bi, 2]) - cz
    # the centroid lies outside the hull iff every tied point is beyond the plane through the
    # nearest point normal to (nearest - centroid); else it lies inside and is its own nearest
    inside = False
    slack = 1e-9 * L * L
    for k in range(m):
        if ((X[k, 0] - cx) * px + (X[k, 1] - cy) * py + (X[k, 2] - cz) * pz) < bd - slack:
            inside = True
            break
    if inside:
        d2, rx, ry, rz, ds, dt, df = _point_to(kd, cx, cy, cz, P)
        if kq == 1:
            return best, rx, ry, rz, 0.5, 0.0, SEG_INTERIOR, ds, dt, df
        return best, rx, ry, rz, 1.0 / 3.0, 1.0 / 3.0, TRI_INTERIOR, ds, dt, df
    return _between(kq, kd, best, _row(C, int(C[bi, 13])), _row(C, int(C[bj, 13])),
                    bl if bi != bj else 0.0)


@numba.njit(**NJIT)
def distinct_ties(kq, Q, kd, P):
    """Number of distinct candidate pairs of query ``(kq, Q)`` and data ``(kd, P)`` (kinds 1 or
    2, flat (9,) coordinates, a segment's third vertex repeating its second) tied at the
    smallest distance: 1 for a unique closest pair, more where :func:`tied_pair` decides; 0 at
    distance 0. For tests and diagnostics."""
    C = np.empty((MAX_CANDIDATES, 10))
    n = _candidates(kq, Q, kd, P, C)
    best = math.inf
    for i in range(n):
        best = min(best, C[i, 0])
    if best == 0.0:
        return 0
    M, L = pair_scale(Q[0], Q[1], Q[2], Q[3], Q[4], Q[5], Q[6], Q[7], Q[8], P[0], P[1], P[2],
                      P[3], P[4], P[5], P[6], P[7], P[8])
    m = 0
    for i in range(n):
        if not is_tied(C[i, 0], best, M, L):
            continue
        new = True
        for j in range(i):
            if (is_tied(C[j, 0], best, M, L)
                    and abs(C[i, 4] - C[j, 4]) + abs(C[i, 5] - C[j, 5]) <= SAME_PAIR):
                new = False
                break
        if new:
            m += 1
    return m
