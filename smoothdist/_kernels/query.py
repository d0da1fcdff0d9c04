"""Query kernels: smooth distance (LogSumExp + Barnes-Hut) and exact distance over a TreeData.

Three layers, as in the rest of the package:

* ``primitive_term``: one primitive's distance, attenuated weight and gradient numerator;
* ``smooth_distance_point`` / ``exact_distance_point``: one query point, the nearest-child-first
  traversal of :mod:`smoothdist._kernels.traversal` with this module's far-field and leaf
  functions (public: other njit code, e.g. the tracer, calls these);
* ``*_batch``: ``prange`` over chunks of query points, one stack per chunk;
  ``*_tasks``: the same loops as serial task kernels, run from Python threads
  (:func:`smoothdist.schedule.run_tasks`; they compile in about half the time).

Conventions: distances are unsigned, in scene units; gradients are with respect to the query
point. The smooth sum is accumulated in float64 relative to a running shift ``m`` (the smallest
distance seen so far), so ``d_hat = m - log(s) / alpha`` is finite for every finite query
(docs/design-notes.md §1).
"""

import math
from typing import NamedTuple

import numba
import numpy as np
from numba import prange

from smoothdist._config import NJIT, NJIT_INLINE, NJIT_IR_INLINE, NJIT_PARALLEL
from smoothdist._kernels.closest_point import (SEG_INTERIOR, TRI_AB, TRI_AC, TRI_BC, TRI_INTERIOR,
                                               box_children, box_distance2, closest_point_segment,
                                               closest_point_triangle)
from smoothdist._kernels.traversal import (NONE, ZERO, always, beyond_best, nearest_first, never,
                                          no_far_field, within_best)
from smoothdist._kernels.weights import eval_edge_weight, eval_triangle_weight
from smoothdist.junctions import JUNCTION_COLUMNS
from smoothdist.schedule import parallel_tasks

#: queries handled by one parallel task (one traversal stack each)
CHUNK = 64


@numba.njit(**NJIT_INLINE)
def _attenuate(raw, dwfac_in, whi, S):
    """Clamp the raw weight ``A w~`` into ``[1, whi]`` and raise it to ``S``.

    ``dwfac_in`` is the factor that turns the caller's derivative into the raw weight's.
    Returns ``(W, factor)`` with ``grad W = factor * grad(raw)`` (0 where clamped).
    """
    if raw <= 1.0:
        return 1.0, 0.0
    if raw >= whi:
        return (whi if S == 1.0 else math.exp(S * math.log(whi))), 0.0
    if S == 1.0:
        return raw, dwfac_in
    W = math.exp(S * math.log(raw))
    return W, S * W / raw * dwfac_in


#: a junction cell whose exponent ``alpha (d_x - d)`` exceeds this adds less than ``exp(-37)``
#: (1e-16) of the primitive's own term, below a float64's rounding: not added
JUNCTION_REACH = 37.0


@numba.njit(**NJIT_INLINE)
def junction_term(P, k, c, wp, px, py, pz, S, alpha):
    """Term of a primitive with inclusion-exclusion junction weights (:mod:`smoothdist.junctions`):
    corners ``P (9,)``, kind ``k``, coefficient row ``c`` (``a_01 a_12 a_20 b_0 b_1 b_2`` of a
    triangle, ``a_0 a_1`` of an edge), ``wp`` a point's area weight (its ``pwhi``; the term's
    weight is ``wp ** S``). Returns ``(d, W, vx, vy, vz)`` as :func:`primitive_term`;
    the weight and gradient are exact (the junction terms are distances' exponentials)."""
    W = 1.0
    if k == 0:
        cx = P[0]
        cy = P[1]
        cz = P[2]
        W = wp if S == 1.0 else math.exp(S * math.log(wp))
    elif k == 1:
        cx, cy, cz, _, _ = closest_point_segment(px, py, pz, P[0], P[1], P[2], P[3], P[4], P[5])
    else:
        cx, cy, cz, _, _, _ = closest_point_triangle(px, py, pz, P[0], P[1], P[2], P[3], P[4],
                                                     P[5], P[6], P[7], P[8])
    rx = px - cx
    ry = py - cy
    rz = pz - cz
    d = math.sqrt(rx * rx + ry * ry + rz * rz)
    vx = 0.0
    vy = 0.0
    vz = 0.0
    if d > 0.0:
        vx = W * rx / d
        vy = W * ry / d
        vz = W * rz / d
    # the junction cells: a triangle's edges 01, 12, 20 (subtracted) and corners 0, 1, 2
    # (added); an edge's two ends (subtracted). Each adds coef exp(-alpha (d_x - d)) to W and
    # that times the unit gradient of d_x to v
    cells = 0 if k == 0 else (2 if k == 1 else 6)
    for j in range(cells):
        coef = c[j]
        if coef == 0.0:
            continue
        if k == 1:
            coef = -S * coef
            cx = P[3 * j]
            cy = P[3 * j + 1]
            cz = P[3 * j + 2]
        elif j < 3:
            coef = -S * coef
            a = 3 * j
            b = 3 * ((j + 1) % 3)
            cx, cy, cz, _, _ = closest_point_segment(px, py, pz, P[a], P[a + 1], P[a + 2], P[b],
                                                     P[b + 1], P[b + 2])
        else:
            coef = S * coef
            cx = P[3 * (j - 3)]
            cy = P[3 * (j - 3) + 1]
            cz = P[3 * (j - 3) + 2]
        rx = px - cx
        ry = py - cy
        rz = pz - cz
        dx = math.sqrt(rx * rx + ry * ry + rz * rz)
        x = alpha * (dx - d)
        if x > JUNCTION_REACH:
            continue
        e = coef * math.exp(-x)
        W += e
        if dx > 0.0:
            f = e / dx
            vx += f * rx
            vy += f * ry
            vz += f * rz
    return d, W, vx, vy, vz


@numba.njit(**NJIT_INLINE)
def primitive_term(tree, i, px, py, pz, S, wgrad_scale, alpha):
    """Term of primitive ``i`` (tree order) for query ``p``.

    Returns ``(d, W, vx, vy, vz)``: distance, attenuated weight ``W``, and the gradient
    numerator ``W * unit(p - c) - wgrad_scale * grad W`` (to be multiplied by ``exp(-alpha d)``).
    ``wgrad_scale`` is ``1/alpha`` for the exact derivative, ``1/alpha**2`` for the paper's metric.
    A tree with junction weights (rows of ``JUNCTION_COLUMNS`` in ``wc``) takes
    :func:`junction_term` (its weights have no metric: ``wgrad_scale`` is not used).
    """
    k = tree.kind[i]
    P = tree.pts[i]
    if tree.wc.shape[1] == JUNCTION_COLUMNS:
        return junction_term(P, k, tree.wc[tree.wcls[i]], tree.pwhi[i], px, py, pz, S, alpha)
    gwx = 0.0
    gwy = 0.0
    gwz = 0.0
    W = 1.0
    if k == 0:
        cx = P[0]
        cy = P[1]
        cz = P[2]
    elif k == 1:
        cx, cy, cz, t, feat = closest_point_segment(px, py, pz, P[0], P[1], P[2], P[3], P[4], P[5])
        w, dw = eval_edge_weight(tree.wc[tree.wcls[i]], t)
        W, fac = _attenuate(w, dw, tree.pwhi[i], S)
        if fac != 0.0 and feat == SEG_INTERIOR:
            ex = P[3] - P[0]
            ey = P[4] - P[1]
            ez = P[5] - P[2]
            f = fac / (ex * ex + ey * ey + ez * ez)
            gwx = f * ex
            gwy = f * ey
            gwz = f * ez
    else:
        cx, cy, cz, s, t, feat = closest_point_triangle(px, py, pz, P[0], P[1], P[2], P[3], P[4],
                                                       P[5], P[6], P[7], P[8])
        w, dws, dwt = eval_triangle_weight(tree.wc[tree.wcls[i]], s, t)
        W, fac = _attenuate(w, 1.0, tree.pwhi[i], S)
        if fac != 0.0 and feat <= TRI_BC:
            abx = P[3] - P[0]
            aby = P[4] - P[1]
            abz = P[5] - P[2]
            acx = P[6] - P[0]
            acy = P[7] - P[1]
            acz = P[8] - P[2]
            if feat == TRI_INTERIOR:
                # barycentric gradients: altitude vectors over their squared lengths
                u = (abx * acx + aby * acy + abz * acz) / (acx * acx + acy * acy + acz * acz)
                h1x = abx - u * acx
                h1y = aby - u * acy
                h1z = abz - u * acz
                u = (abx * acx + aby * acy + abz * acz) / (abx * abx + aby * aby + abz * abz)
                h2x = acx - u * abx
                h2y = acy - u * aby
                h2z = acz - u * abz
                f1 = fac * dws / (h1x * h1x + h1y * h1y + h1z * h1z)
                f2 = fac * dwt / (h2x * h2x + h2y * h2y + h2z * h2z)
                gwx = f1 * h1x + f2 * h2x
                gwy = f1 * h1y + f2 * h2y
                gwz = f1 * h1z + f2 * h2z
            else:
                # projection clamped to an edge: only the tangential derivative survives
                if feat == TRI_AB:
                    ex, ey, ez, dw = abx, aby, abz, dws
                elif feat == TRI_AC:
                    ex, ey, ez, dw = acx, acy, acz, dwt
                else:
                    ex, ey, ez, dw = acx - abx, acy - aby, acz - abz, dwt - dws
                f = fac * dw / (ex * ex + ey * ey + ez * ez)
                gwx = f * ex
                gwy = f * ey
                gwz = f * ez
    rx = px - cx
    ry = py - cy
    rz = pz - cz
    d = math.sqrt(rx * rx + ry * ry + rz * rz)
    if d > 0.0:
        inv = W / d
        vx = rx * inv - wgrad_scale * gwx
        vy = ry * inv - wgrad_scale * gwy
        vz = rz * inv - wgrad_scale * gwz
    else:
        vx = -wgrad_scale * gwx
        vy = -wgrad_scale * gwy
        vz = -wgrad_scale * gwz
    return d, W, vx, vy, vz


@numba.njit(**NJIT_INLINE)
def logsumexp_accumulate(m, s, gx, gy, gz, d, W, vx, vy, vz, alpha):
    """Add one term to a streaming LogSumExp kept relative to a running shift ``m``.

    The sums are ``s = sum W_i exp(-alpha (d_i - m))`` and ``g = sum exp(-alpha (d_i - m)) v_i``
    with ``m`` the smallest ``d_i`` so far (``inf`` before the first term, with ``s = g = 0``).
    Returns the updated ``(m, s, gx, gy, gz)``; the result is ``m - log(s) / alpha`` and
    ``g / s``. Every exponent is <= 0, so nothing overflows and ``s >= W_min`` never underflows
    to zero (docs/design-notes.md §1).
    """
    if d < m:
        f = math.exp(-alpha * (m - d))
        s *= f
        gx *= f
        gy *= f
        gz *= f
        m = d
    e = math.exp(-alpha * (d - m))
    return m, s + W * e, gx + e * vx, gy + e * vy, gz + e * vz


class _PointQuery(NamedTuple):
    """A query point and the smooth kernel's constants, as its traversal functions read them."""
    px: float
    py: float
    pz: float
    alpha: float
    b2: float       # beta**2 (Barnes-Hut tests diag**2 < beta**2 d**2)
    S: float
    wgrad_scale: float
    sa: float       # S / alpha
    reach: float    # negligible-term pruning (negligible_reach)


class _TolQuery(NamedTuple):
    """A query point and the tol kernel's constants."""
    px: float
    py: float
    pz: float
    alpha: float
    beta: float
    S: float
    wgrad_scale: float
    wa: float       # the largest raw weight to the power S
    budget: float   # tol / N


class _ExactQuery(NamedTuple):
    """A query point of the exact kernel; primitives at squared distance ``<= floor`` are
    ignored."""
    px: float
    py: float
    pz: float
    floor: float


@numba.njit(**NJIT_IR_INLINE)
def _smooth_skip(tree, q, node, bd2, st):
    """Negligible-term pruning: the node is at least ``cut = m + reach`` away."""
    return bd2 >= st[5]


@numba.njit(**NJIT_IR_INLINE)
def _smooth_far(tree, q, node, bd2, st):
    """Barnes-Hut: a node with ``diag < beta d`` (and more than one primitive) becomes
    ``count * whi**S * exp(-alpha d)``, written ``count * exp(-alpha (d - S log(whi) / alpha))``.
    ``st = (m, s, gx, gy, gz, cut2, leaves)``."""
    cnt = tree.count[node]
    dg = tree.diag[node]
    if not (cnt > 1 and dg * dg < q.b2 * bd2):
        return False, st
    px, py, pz, alpha, _, _, _, sa, reach = q
    m, s, gx, gy, gz, _, leaves = st
    d2, cx, cy, cz = box_distance2(px, py, pz, tree.lo, tree.hi, node)
    bd = math.sqrt(bd2)
    f = cnt / bd
    m, s, gx, gy, gz = logsumexp_accumulate(m, s, gx, gy, gz, bd - sa * tree.lwhi[node],
                                            float(cnt), f * (px - cx), f * (py - cy),
                                            f * (pz - cz), alpha)
    cut = m + reach
    return True, (m, s, gx, gy, gz, cut * cut, leaves + 1)


@numba.njit(**NJIT_IR_INLINE)
def _smooth_leaf(tree, q, node, st):
    """Every primitive of a leaf, exactly."""
    if tree.left[node] >= 0:
        return False, st
    px, py, pz, alpha, _, S, wgrad_scale, _, reach = q
    m, s, gx, gy, gz, _, leaves = st
    st_ = tree.start[node]
    cnt = tree.count[node]
    for i in range(st_, st_ + cnt):
        d, W, vx, vy, vz = primitive_term(tree, i, px, py, pz, S, wgrad_scale, alpha)
        m, s, gx, gy, gz = logsumexp_accumulate(m, s, gx, gy, gz, d, W, vx, vy, vz, alpha)
    cut = m + reach
    return True, (m, s, gx, gy, gz, cut * cut, leaves + cnt)


def stack_size(tree):
    """Traversal stack length needed for ``tree`` (nearest-first DFS holds <= depth + 1)."""
    return tree.depth + 4


@numba.njit(**NJIT)
def smooth_distance_point(tree, px, py, pz, alpha, beta, S, wgrad_scale, stack, dstack, root=0):
    """Smooth distance ``d_hat`` and gradient at one point (Madan & Levin 2022, Alg. 1-2).

    Parameters
    ----------
    tree : TreeData
    px, py, pz : float
        Query point.
    alpha : float
        LogSumExp sharpness (1 / scene units), > 0.
    beta : float
        Barnes-Hut parameter: a node with ``diag < beta * dist(p, box)`` (and more than one
        primitive) is replaced by ``count * whi**S * exp(-alpha * dist)``. 0 is exact.
    S : float
        Weight attenuation ``min(alpha / alpha_U, 1)``.
    wgrad_scale : float
        Weight-gradient scale: ``1/alpha`` (exact derivative) or ``1/alpha**2`` (paper metric).
    stack : (k,) int64, dstack : (k,) float64
        Scratch space of length ``stack_size(tree)``.
    root : int
        Node to start from (0; or an object's root in a forest, see ``concatenate_trees``).

    Returns
    -------
    (d_hat, gx, gy, gz, nodes_visited, leaves_visited)
        ``leaves_visited`` counts exact primitive evaluations plus far-field nodes (the
        authors' ``num_visited``).
    """
    # the keys are squared box distances; the square root is taken for far fields only
    # (the test diag < beta d as diag**2 < beta**2 d**2): 3-18 % less CPU time in renders.
    # Negligible-term pruning: a node whose terms are all below NEGLIGIBLE x the sum is skipped
    # once ``dist(p, box) >= cut = m + reach`` (see negligible_reach)
    q = _PointQuery(px, py, pz, alpha, beta * beta, S, wgrad_scale, S / alpha,
                    negligible_reach(tree, root, S, alpha))
    (m, s, gx, gy, gz, _, leaves), nodes = nearest_first(
        tree, q, (np.inf, 0.0, 0.0, 0.0, 0.0, np.inf, ZERO), stack, dstack, root,
        box_distance2(px, py, pz, tree.lo, tree.hi, root)[0], _smooth_skip, _smooth_far,
        _smooth_leaf, box_children, always)
    if s < 1.0:
        s = 1.0     # only junction weights go below: d_hat <= m (JUNCTION_CLAMP)
    inv = 1.0 / s
    return m - math.log(s) / alpha, gx * inv, gy * inv, gz * inv, nodes, leaves


#: negligible-term pruning: the skipped terms of one query add up to at most this fraction of
#: its LogSumExp sum (one unit in the last place of a float64), so the result is that of the
#: full traversal up to rounding
NEGLIGIBLE = 2.0 ** -53


@numba.njit(**NJIT_INLINE)
def negligible_reach(tree, root, S, alpha):
    """Distance beyond the running minimum ``m`` (scene units) past which a node's terms are
    negligible: a box at distance ``>= m + reach`` holding ``n_B`` of the ``N`` primitives
    under ``root`` adds at most ``NEGLIGIBLE x n_B / N`` times the sum, so all skipped nodes
    (disjoint) together add less than ``NEGLIGIBLE`` x the sum.

    Why: the sum, relative to ``m``, is ``>= 1`` (the term that set ``m`` has weight
    ``W >= 1`` and exponent 0), and a node's terms are at most ``n_B x whi**S x
    exp(-alpha (dist - m))`` with ``whi <= whi(root)``:
    ``reach = (log(N / NEGLIGIBLE) + S max(log whi_root, 0)) / alpha``.
    """
    n = max(tree.count[root], 1)
    return (math.log(n / NEGLIGIBLE) + S * max(tree.lwhi[root], 0.0)) / alpha


#: JUNCTION_CLAMP: the sum relative to the smallest distance ``m`` is clamped to ``>= 1`` (``d_hat
#: <= m``) at the end of every smooth kernel. With the paper's weights (every ``W >= 1``) it
#: always is, so nothing changes; with junction weights (:mod:`smoothdist.junctions`), whose
#: terms can be negative, the clamp keeps ``d_hat`` finite and at most the exact distance where
#: they cancel too much.

#: ``tol`` when none is given: tolerance-controlled pruning off. The one definition of that
#: default (the library's functions, ``tracer.rendering.frame.scene_arrays``; ``smoothdist.kernels``
#: exports it)
DEFAULT_TOL = 0.0
#: tol mode: a node with at most this many primitives that is not accepted is evaluated
#: primitive by primitive (they are contiguous in tree order) instead of being descended
#: (the fastest measured; performance guide, "Tuning constants")
TOL_LEAF = 16


@numba.njit(**NJIT_INLINE)
def _shift(m, d, alpha):
    """``(factor, new shift)``: sums relative to ``m`` times ``factor`` are relative to
    ``min(m, d)``."""
    if d < m:
        return math.exp(-alpha * (m - d)), d
    return 1.0, m


@numba.njit(**NJIT_INLINE)
def _shift_sums(m, d, alpha, s, gx, gy, gz, s_ex, e_far, s_ref):
    """The tol kernel's running sums re-expressed relative to ``min(m, d)`` (see
    :func:`_shift`); returns ``(m, s, gx, gy, gz, s_ex, e_far, s_ref)``."""
    f, m = _shift(m, d, alpha)
    return m, s * f, gx * f, gy * f, gz * f, s_ex * f, e_far * f, s_ref * f


@numba.njit(**NJIT_IR_INLINE)
def _box_children_sqrt(tree, q, node):
    """``children`` of the tol kernel: both children, keyed by box distance."""
    l = tree.left[node]
    r = tree.right[node]
    return (l, math.sqrt(box_distance2(q.px, q.py, q.pz, tree.lo, tree.hi, l)[0]),
            r, math.sqrt(box_distance2(q.px, q.py, q.pz, tree.lo, tree.hi, r)[0]))


@numba.njit(**NJIT_INLINE)
def _near(m, alpha, wa, budget, s_ex, n_ref):
    """The distance below which no node can pass the tol test (docs/design-notes.md §3)."""
    return m + math.log(wa / (budget * s_ex * (n_ref + 1))) / alpha


@numba.njit(**NJIT_IR_INLINE)
def _tol_far(tree, q, node, bd, st):
    """The tol kernel's far fields: the budget test, then Barnes-Hut (outside the budget).
    ``st = (m, s, gx, gy, gz, s_ex, e_far, s_ref, n_cov, n_ref, near, leaves)``."""
    px, py, pz, alpha, beta, S, wgrad_scale, wa, budget = q
    m, s, gx, gy, gz, s_ex, e_far, s_ref, n_cov, n_ref, near, leaves = st
    cnt = tree.count[node]
    if s_ex > 0.0 and bd >= near:
        W = cnt * wa
        allow = budget * s_ex * (n_cov + cnt)
        if bd >= m:
            far = e_far + W * math.exp(-alpha * (bd - m)) <= allow
        else:
            f = math.exp(-alpha * (m - bd))
            far = e_far * f + W <= allow * f
        if far:
            n_cov += cnt
            if n_cov + 1 >= 2 * (n_ref + 1):
                n_ref = n_cov
                near = _near(m, alpha, wa, budget, s_ex, n_ref)
            d2, cx, cy, cz = box_distance2(px, py, pz, tree.lo, tree.hi, node)
            m, s, gx, gy, gz, s_ex, e_far, s_ref = _shift_sums(m, bd, alpha, s, gx, gy, gz,
                                                               s_ex, e_far, s_ref)
            e = math.exp(-alpha * (bd - m))
            s += W * e
            e_far += W * e
            if bd > 0.0:
                fw = W / bd
                gx += e * (fw * (px - cx))
                gy += e * (fw * (py - cy))
                gz += e * (fw * (pz - cz))
            return True, (m, s, gx, gy, gz, s_ex, e_far, s_ref, n_cov, n_ref, near, leaves + 1)
    if tree.left[node] >= 0 and cnt > 1 and beta > 0.0 and tree.diag[node] < beta * bd:
        # Barnes-Hut far field, count * whi**S * exp(-alpha bd)
        d2, cx, cy, cz = box_distance2(px, py, pz, tree.lo, tree.hi, node)
        W = float(cnt)
        db = bd - S * tree.lwhi[node] / alpha
        m, s, gx, gy, gz, s_ex, e_far, s_ref = _shift_sums(m, db, alpha, s, gx, gy, gz,
                                                           s_ex, e_far, s_ref)
        e = math.exp(-alpha * (db - m))
        fw = W / bd
        s += W * e
        gx += e * (fw * (px - cx))
        gy += e * (fw * (py - cy))
        gz += e * (fw * (pz - cz))
        return True, (m, s, gx, gy, gz, s_ex, e_far, s_ref, n_cov + cnt, n_ref, near,
                      leaves + 1)
    return False, st


@numba.njit(**NJIT_IR_INLINE)
def _tol_leaf(tree, q, node, st):
    """The tol kernel's exact terms: a leaf, or a node of at most :data:`TOL_LEAF`
    primitives (contiguous in tree order), primitive by primitive."""
    cnt = tree.count[node]
    if tree.left[node] >= 0 and cnt > TOL_LEAF:
        return False, st
    px, py, pz, alpha, beta, S, wgrad_scale, wa, budget = q
    m, s, gx, gy, gz, s_ex, e_far, s_ref, n_cov, n_ref, near, leaves = st
    st_ = tree.start[node]
    for i in range(st_, st_ + cnt):
        d, W, vx, vy, vz = primitive_term(tree, i, px, py, pz, S, wgrad_scale, alpha)
        m, s, gx, gy, gz, s_ex, e_far, s_ref = _shift_sums(m, d, alpha, s, gx, gy, gz, s_ex,
                                                           e_far, s_ref)
        e = math.exp(-alpha * (d - m))
        s += W * e
        s_ex += W * e
        gx += e * vx
        gy += e * vy
        gz += e * vz
    n_cov += cnt
    if s_ex >= 2.0 * s_ref or n_cov + 1 >= 2 * (n_ref + 1):
        s_ref = s_ex
        n_ref = n_cov
        near = _near(m, alpha, wa, budget, s_ex, n_ref)
    return True, (m, s, gx, gy, gz, s_ex, e_far, s_ref, n_cov, n_ref, near, leaves + cnt)


@numba.njit(**NJIT)
def smooth_distance_point_tol(tree, px, py, pz, alpha, beta, tol, S, wgrad_scale, stack, dstack,
                              root=0):
    """Smooth distance at one point with tolerance-controlled pruning (and optional beta).

    Arguments and result as in :func:`smooth_distance_point`, plus ``tol >= 0``: the relative
    error budget of the LogSumExp sum (0: this is :func:`smooth_distance_point`). With
    ``beta = 0`` and ``tol > 0``, for every query and every data mesh,
    ``d_hat_0 - log(1 + tol) / alpha <= d_hat_tol <= d_hat_0`` (scene units).

    Rule (docs/design-notes.md §3, with the proof): nodes are visited nearest-child-first. A
    popped node ``B`` with ``n_B`` primitives at box distance ``delta_B`` has the far-field
    bound ``U_B = n_B A^S exp(-alpha delta_B)`` (``A`` the tree's largest raw weight); it is
    added *instead of* being opened if ``E + U_B <= tol * s_ex * (n_C + n_B) / N`` (``s_ex``
    the exact terms so far, ``E`` the accepted far fields, ``n_C`` the primitives dealt with
    so far, ``N`` all). Barnes-Hut nodes (``beta > 0``) add to the sum, not to ``E`` or
    ``s_ex``. Orders tried: docs/guide/performance.md, "Tuning constants".
    """
    if not tol > 0.0:
        return smooth_distance_point(tree, px, py, pz, alpha, beta, S, wgrad_scale, stack, dstack,
                                     root)
    wa = tree.whi[root]
    wa = wa if (S == 1.0 or wa == 1.0) else math.exp(S * math.log(wa))
    # tol * s_ex * (n_C + n_B) / N, with the constants folded in
    budget = tol / tree.count[root]
    # state: the sums (m, s, g, s_ex, e_far), the primitives dealt with (n_C), the reference
    # sum and count of ``near`` (nodes closer than ``near`` cannot pass the test whatever their
    # size: no exp for them, docs/design-notes.md §3; recomputed when s_ex or n_C + 1 has
    # doubled since), ``near`` and the leaves count
    (m, s, gx, gy, gz, _, _, _, _, _, _, leaves), nodes = nearest_first(
        tree, _TolQuery(px, py, pz, alpha, beta, S, wgrad_scale, wa, budget),
        (np.inf, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, ZERO, ZERO, np.inf, ZERO), stack, dstack, root,
        math.sqrt(box_distance2(px, py, pz, tree.lo, tree.hi, root)[0]), never, _tol_far,
        _tol_leaf, _box_children_sqrt, always)
    if s < 1.0:
        s = 1.0     # only junction weights go below: d_hat <= m (JUNCTION_CLAMP)
    inv = 1.0 / s
    return m - math.log(s) / alpha, gx * inv, gy * inv, gz * inv, nodes, leaves


@numba.njit(**NJIT_IR_INLINE)
def _exact_leaf(tree, q, node, st):
    """A leaf's primitives, exactly; ``st = (best d2, prim, closest point, leaves)``;
    primitives at squared distance ``<= q.floor`` are ignored."""
    if tree.left[node] >= 0:
        return False, st
    px, py, pz, floor = q
    best, bi, bx, by, bz, leaves = st
    st_ = tree.start[node]
    cnt = tree.count[node]
    for i in range(st_, st_ + cnt):
        k = tree.kind[i]
        P = tree.pts[i]
        if k == 0:
            cx = P[0]
            cy = P[1]
            cz = P[2]
        elif k == 1:
            cx, cy, cz, t, f = closest_point_segment(px, py, pz, P[0], P[1], P[2], P[3], P[4],
                                                     P[5])
        else:
            cx, cy, cz, s, t, f = closest_point_triangle(px, py, pz, P[0], P[1], P[2], P[3],
                                                         P[4], P[5], P[6], P[7], P[8])
        d2 = (px - cx) ** 2 + (py - cy) ** 2 + (pz - cz) ** 2
        if floor < d2 < best:
            best = d2
            bi = i
            bx = cx
            by = cy
            bz = cz
    return True, (best, bi, bx, by, bz, leaves + cnt)


@numba.njit(**NJIT)
def exact_distance_point(tree, px, py, pz, stack, dstack, root=0, floor=-1.0):
    """Exact unsigned distance at one point by nearest-first branch and bound.

    Returns ``(d, gx, gy, gz, prim, nodes_visited, leaves_visited)``: the distance, the unit
    gradient ``(p - c) / d`` (zero on the geometry), and the closest primitive's index in the
    mesh numbering (points, then edges, then triangles). ``root`` as in
    :func:`smooth_distance_point`. Primitives at squared distance ``<= floor`` are ignored
    (``floor = 0`` finds the nearest *other* point of a point cloud queried at its own points).
    """
    (best, bi, bx, by, bz, leaves), nodes = nearest_first(
        tree, _ExactQuery(px, py, pz, floor), (np.inf, NONE, px, py, pz, ZERO), stack, dstack, root,
        box_distance2(px, py, pz, tree.lo, tree.hi, root)[0], beyond_best, no_far_field,
        _exact_leaf, box_children, within_best)
    d = math.sqrt(best)
    if d > 0.0:
        return d, (px - bx) / d, (py - by) / d, (pz - bz) / d, tree.orig[bi], nodes, leaves
    return 0.0, 0.0, 0.0, 0.0, tree.orig[bi], nodes, leaves


@numba.njit(**NJIT)
def smooth_distance_brute_point(tree, px, py, pz, alpha, S, wgrad_scale):
    """Smooth distance at one point summing every primitive (no tree): ``(d_hat, gx, gy, gz)``."""
    m = np.inf
    s = 0.0
    gx = 0.0
    gy = 0.0
    gz = 0.0
    for i in range(tree.kind.size):
        d, W, vx, vy, vz = primitive_term(tree, i, px, py, pz, S, wgrad_scale, alpha)
        m, s, gx, gy, gz = logsumexp_accumulate(m, s, gx, gy, gz, d, W, vx, vy, vz, alpha)
    if s < 1.0:
        s = 1.0     # only junction weights go below: d_hat <= m (JUNCTION_CLAMP)
    return m - math.log(s) / alpha, gx / s, gy / s, gz / s


@numba.njit(**NJIT_PARALLEL)
def smooth_distance_batch(tree, Q, alpha, beta, S, wgrad_scale, brute, out_d, out_g, out_nodes,
                          out_leaves, tol=DEFAULT_TOL, ntasks=1):
    """Fill ``out_d (q,)``, ``out_g (q, 3)``, ``out_nodes``, ``out_leaves (q,)`` for ``Q (q, 3)``.

    ``tol > 0``: tolerance-controlled pruning (:func:`smooth_distance_point_tol`).
    ``ntasks``: strided tasks over the chunks of :data:`CHUNK` rows (task ``t`` takes chunks
    ``t, t + ntasks, ...``; pass :func:`smoothdist.schedule.parallel_tasks`); it never changes
    a value.
    """
    n = Q.shape[0]
    nchunks = (n + CHUNK - 1) // CHUNK
    k = tree.depth + 4
    ntasks = max(1, min(nchunks, ntasks))
    for task in prange(ntasks):
        stack = np.empty(k, dtype=np.int64)
        dstack = np.empty(k)
        for c in range(task, nchunks, ntasks):    # every ntasks-th chunk
            for i in range(c * CHUNK, min(n, (c + 1) * CHUNK)):
                if brute:
                    d, gx, gy, gz = smooth_distance_brute_point(tree, Q[i, 0], Q[i, 1], Q[i, 2],
                                                                alpha, S, wgrad_scale)
                    nodes = 0
                    leaves = tree.kind.size
                else:
                    d, gx, gy, gz, nodes, leaves = smooth_distance_point_tol(
                        tree, Q[i, 0], Q[i, 1], Q[i, 2], alpha, beta, tol, S, wgrad_scale, stack,
                        dstack)
                out_d[i] = d
                out_g[i, 0] = gx
                out_g[i, 1] = gy
                out_g[i, 2] = gz
                out_nodes[i] = nodes
                out_leaves[i] = leaves


@numba.njit(**NJIT_PARALLEL)
def exact_distance_batch(tree, Q, out_d, out_g, out_prim, out_nodes, out_leaves, ntasks=1):
    """Exact distance for every row of ``Q (q, 3)`` into the output arrays (``ntasks`` strided
    tasks over the chunks, as in :func:`smooth_distance_batch`)."""
    nchunks = (Q.shape[0] + CHUNK - 1) // CHUNK
    k = tree.depth + 4
    ntasks = max(1, min(nchunks, ntasks))
    for task in prange(ntasks):
        stack = np.empty(k, dtype=np.int64)
        dstack = np.empty(k)
        # the task index and root as int64 (prange's is uint64, a constant a literal): the
        # specialisation exact_distance_tasks compiles too
        _exact_chunks(tree, Q, -1.0, out_d, out_g, out_prim, out_nodes, out_leaves,
                      np.int64(0), ntasks, np.int64(task), stack, dstack)


@numba.njit(**NJIT_IR_INLINE)
def _exact_chunks(tree, Q, floor, out_d, out_g, out_prim, out_nodes, out_leaves, root, ntasks,
                  task, stack, dstack):
    """Chunks ``task, task + ntasks, ...`` of :func:`exact_distance_batch` /
    :func:`exact_distance_tasks` (``stack``, ``dstack``: the task's traversal buffers)."""
    n = Q.shape[0]
    nchunks = (n + CHUNK - 1) // CHUNK
    for c in range(task, nchunks, ntasks):    # every ntasks-th chunk
        for i in range(c * CHUNK, min(n, (c + 1) * CHUNK)):
            d, gx, gy, gz, p, nodes, leaves = exact_distance_point(
                tree, Q[i, 0], Q[i, 1], Q[i, 2], stack, dstack, root, floor)
            out_d[i] = d
            out_g[i, 0] = gx
            out_g[i, 1] = gy
            out_g[i, 2] = gz
            out_prim[i] = p
            out_nodes[i] = nodes
            out_leaves[i] = leaves


@numba.njit(**NJIT)
def smooth_distance_tasks(tree, Q, alpha, beta, S, wgrad_scale, out_d, out_g, out_nodes, out_leaves,
                          root, ntasks, task0, task1):
    """:func:`smooth_distance_batch` without ``tol`` (0) nor ``brute``, as a serial task kernel:
    tasks ``task0 <= t < task1`` of ``ntasks`` strided tasks over the chunks (run from Python
    threads by :func:`smoothdist.schedule.run_tasks`; GIL-free). The same values: with
    ``tol = 0``, :func:`smooth_distance_point_tol` is :func:`smooth_distance_point`, called
    here with ``root`` an int argument (0 for the whole tree: the renderer's specialisation,
    compiled once for both; a constant would be typed as a literal, another one)."""
    n = Q.shape[0]
    nchunks = (n + CHUNK - 1) // CHUNK
    k = tree.depth + 4
    stack = np.empty(k, dtype=np.int64)
    dstack = np.empty(k)
    for task in range(task0, task1):
        for c in range(task, nchunks, ntasks):    # every ntasks-th chunk
            for i in range(c * CHUNK, min(n, (c + 1) * CHUNK)):
                d, gx, gy, gz, nodes, leaves = smooth_distance_point(
                    tree, Q[i, 0], Q[i, 1], Q[i, 2], alpha, beta, S, wgrad_scale, stack, dstack,
                    root)
                out_d[i] = d
                out_g[i, 0] = gx
                out_g[i, 1] = gy
                out_g[i, 2] = gz
                out_nodes[i] = nodes
                out_leaves[i] = leaves


@numba.njit(**NJIT)
def exact_distance_tasks(tree, Q, floor, out_d, out_g, out_prim, out_nodes, out_leaves, root,
                         ntasks, task0, task1):
    """:func:`exact_distance_batch` as a serial task kernel (tasks ``task0 <= t < task1`` of
    ``ntasks``, ``root`` as in :func:`smooth_distance_tasks`), ignoring primitives at squared
    distance ``<= floor`` (``-1.0``: none; ``0.0``: the nearest *other* point, see
    :func:`exact_distance_point`)."""
    k = tree.depth + 4
    stack = np.empty(k, dtype=np.int64)
    dstack = np.empty(k)
    for task in range(task0, task1):
        _exact_chunks(tree, Q, floor, out_d, out_g, out_prim, out_nodes, out_leaves, root,
                      ntasks, task, stack, dstack)


def chunk_tasks(n):
    """Strided tasks for ``n`` queries in chunks of :data:`CHUNK`: one per thread
    (:func:`smoothdist.schedule.parallel_tasks`), at most one per chunk."""
    if n <= CHUNK:          # one chunk: one task (no need to ask numba for its threads)
        return 1
    return max(1, min(parallel_tasks(n), (n + CHUNK - 1) // CHUNK))
