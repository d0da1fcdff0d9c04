"""Exact closest points between a query point and one data primitive.

All kernels work on float64 scalars (no arrays) so that numba inlines them into the traversal
loops. Each returns the closest point ``(cx, cy, cz)`` on the primitive, its barycentric
coordinates, and a *feature code* saying which face of the simplex the closest point lies on.
The feature code is what the exact weight gradient needs: the closest-point projection is
constant along the normal of the feature it is clamped to (paper Eq. 7, Fig. "perp").

Feature codes
-------------
* segment ``(a, b)``, parameter ``t`` (point = a + t (b - a)): 0 interior, 1 clamped to
  ``a``, 2 clamped to ``b``.
* triangle ``(a, b, c)``, barycentrics ``(s, t)`` (point = a + s (b - a) + t (c - a)), so
  ``s`` weighs vertex 1 and ``t`` vertex 2 (the paper's phi^1, phi^2): 0 interior, 1 edge ab
  (t = 0), 2 edge ac (s = 0), 3 edge bc (s + t = 1), 4 vertex a, 5 vertex b, 6 vertex c.
"""

import numba

from smoothdist._config import NJIT_INLINE, NJIT_IR_INLINE

SEG_INTERIOR, SEG_A, SEG_B = 0, 1, 2
TRI_INTERIOR, TRI_AB, TRI_AC, TRI_BC, TRI_A, TRI_B, TRI_C = 0, 1, 2, 3, 4, 5, 6


@numba.njit(**NJIT_INLINE)
def closest_point_segment(px, py, pz, ax, ay, az, bx, by, bz):
    """Closest point on segment ``ab`` to ``p``.

    Returns ``(cx, cy, cz, t, feature)``; ``t`` in [0, 1]. The segment must have non-zero
    length (meshes are repaired before they reach a kernel).
    """
    ex = bx - ax
    ey = by - ay
    ez = bz - az
    num = (px - ax) * ex + (py - ay) * ey + (pz - az) * ez
    if num <= 0.0:
        return ax, ay, az, 0.0, SEG_A
    den = ex * ex + ey * ey + ez * ez
    if num >= den:
        return bx, by, bz, 1.0, SEG_B
    t = num / den
    return ax + t * ex, ay + t * ey, az + t * ez, t, SEG_INTERIOR


@numba.njit(**NJIT_INLINE)
def closest_point_triangle(px, py, pz, ax, ay, az, bx, by, bz, cx, cy, cz):
    """Closest point on triangle ``abc`` to ``p`` (Voronoi-region method, Ericson 2005 §5.1.5).

    Returns ``(qx, qy, qz, s, t, feature)`` with the point ``a + s (b - a) + t (c - a)``.
    The triangle must have non-zero area.
    """
    abx = bx - ax
    aby = by - ay
    abz = bz - az
    acx = cx - ax
    acy = cy - ay
    acz = cz - az
    apx = px - ax
    apy = py - ay
    apz = pz - az
    d1 = abx * apx + aby * apy + abz * apz
    d2 = acx * apx + acy * apy + acz * apz
    if d1 <= 0.0 and d2 <= 0.0:
        return ax, ay, az, 0.0, 0.0, TRI_A
    bpx = px - bx
    bpy = py - by
    bpz = pz - bz
    d3 = abx * bpx + aby * bpy + abz * bpz
    d4 = acx * bpx + acy * bpy + acz * bpz
    if d3 >= 0.0 and d4 <= d3:
        return bx, by, bz, 1.0, 0.0, TRI_B
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        v = d1 / (d1 - d3)
        return ax + v * abx, ay + v * aby, az + v * abz, v, 0.0, TRI_AB
    cpx = px - cx
    cpy = py - cy
    cpz = pz - cz
    d5 = abx * cpx + aby * cpy + abz * cpz
    d6 = acx * cpx + acy * cpy + acz * cpz
    if d6 >= 0.0 and d5 <= d6:
        return cx, cy, cz, 0.0, 1.0, TRI_C
    vb = d5 * d2 - d1 * d6
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        w = d2 / (d2 - d6)
        return ax + w * acx, ay + w * acy, az + w * acz, 0.0, w, TRI_AC
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and (d4 - d3) >= 0.0 and (d5 - d6) >= 0.0:
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        return bx + w * (cx - bx), by + w * (cy - by), bz + w * (cz - bz), 1.0 - w, w, TRI_BC
    denom = 1.0 / (va + vb + vc)
    v = vb * denom
    w = vc * denom
    return (ax + abx * v + acx * w, ay + aby * v + acy * w, az + abz * v + acz * w, v, w,
            TRI_INTERIOR)


@numba.njit(**NJIT_INLINE)
def box_distance2(px, py, pz, lo, hi, node):
    """Squared distance from ``p`` to the axis-aligned box ``lo[node]..hi[node]``.

    Returns ``(d2, cx, cy, cz)`` with ``c`` the closest point of the box (``c == p`` inside).
    """
    cx = min(max(px, lo[node, 0]), hi[node, 0])
    cy = min(max(py, lo[node, 1]), hi[node, 1])
    cz = min(max(pz, lo[node, 2]), hi[node, 2])
    dx = px - cx
    dy = py - cy
    dz = pz - cz
    return dx * dx + dy * dy + dz * dz, cx, cy, cz


@numba.njit(**NJIT_IR_INLINE)
def box_children(tree, q, node):
    """``children`` of a point's nearest-first traversal (``q`` has ``px, py, pz``): both
    children of ``node``, keyed by their boxes' squared distance."""
    l = tree.left[node]
    r = tree.right[node]
    return (l, box_distance2(q.px, q.py, q.pz, tree.lo, tree.hi, l)[0],
            r, box_distance2(q.px, q.py, q.pz, tree.lo, tree.hi, r)[0])
