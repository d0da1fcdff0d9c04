"""Sphere-tracing kernels: march camera rays against a scene's smooth (or exact-offset) distance.

A scene is one :class:`smoothdist._kernels.bvh.TreeData` *forest* (the objects' trees concatenated
by ``smoothdist.kernels.concatenate_trees``), the root node of each object ``roots (k,) int64``,
a ``(k, P_COLUMNS)`` float64 parameter table ``params``, one row per object, the scene's
``mode`` (``MODE_SMOOTH`` or ``MODE_EXACT``) and its ``tol``: one scalar for the whole
scene, the tolerance-controlled pruning of every object (0 = off, the default
``smoothdist.kernels.DEFAULT_TOL``; see ``smoothdist.kernels.smooth_distance_point_tol``).
The columns of ``params`` (built by ``tracer.rendering.frame.scene_arrays``; the kernels read them
by these names only):

=================== ======= =============================================================
column              index   meaning
=================== ======= =============================================================
:data:`P_ALPHA`     0       alpha, the sharpness (1 / scene units)
:data:`P_BETA`      1       Barnes-Hut beta (>= 0; 0 exact)
:data:`P_S`         2       attenuation exponent ``S = min(alpha / alpha_U, 1)``
:data:`P_WGS`       3       weight-gradient scale (``1/alpha**2`` metric, ``1/alpha`` exact)
:data:`P_OFFSET`    4       the object's offset ``c >= 0``: its distance is ``exact - c``
                            (exact-offset mode) or ``d_hat - c`` (smooth mode)
:data:`P_R`         5-13    posed tables only: rotation ``R``, row-major 3x3
``P_T``             14-16   posed tables only: translation ``t``
=================== ======= =============================================================

An unposed table has :data:`P_COLUMNS` (5) columns; a posed one :data:`P_COLUMNS_POSED` (17):
object ``k`` is then evaluated at its local point ``R^T (p - t)`` and its gradient rotated
back by ``R`` (rigid bodies drawn at their poses without rebuilding a tree). Objects are
combined as the paper combines them: by a second LogSumExp with the largest alpha (smooth
mode), or by the minimum (exact-offset mode, where each object's distance is
``exact - offset``). In smooth mode each object's ``d_hat - c`` is combined (``c`` its
``P_OFFSET``, 0 by default): the surface ``d_hat = c``. ``d_hat - c`` is as Lipschitz as
``d_hat`` and lies below ``d - c``, so every bound below holds for it with ``c`` subtracted. The
object with the nearest root box is evaluated first; an object whose root box alone shows that it
cannot change the result (:func:`object_lower_bound`: not below the minimum, or a LogSumExp term
below one unit in the last place of the sum) is skipped.

Safety (docs/design-notes.md §4): each ray starts where it enters the scene box grown by
``margin`` (the isosurface can lie at most ``log(A^S N) / alpha`` outside the data, Barnes-Hut
included, because a far-field term is never closer than the root box), it ends where it leaves
that box, a step that lands in the negative band is resolved by bisection back to the last
positive point, and the number of steps is capped.
"""

import math

import numba
import numpy as np
from numba import prange
from numba.core import types as nbtypes
from numba.extending import overload

from smoothdist.kernels import (NJIT, NJIT_IR_INLINE, NJIT_PARALLEL, borrowed, box_distance2,
                                exact_distance_point,
                                logsumexp_accumulate, smooth_distance_point,
                                smooth_distance_point_tol)
from tracer.rendering.camera import (block_rays, camera_ray, far_depth, footprint, image_size)

MODE_SMOOTH, MODE_EXACT = 0, 1
#: columns of the per-object parameter table ``params`` (see the module docstring); numba
#: compiles these module-level ints in as constants
P_ALPHA, P_BETA, P_S, P_WGS, P_OFFSET = 0, 1, 2, 3, 4
#: columns of an unposed table
P_COLUMNS = 5
#: posed tables: ``R`` (row-major 3x3) in columns ``P_R .. P_R + 8``, ``t`` in ``P_T .. P_T + 2``
P_R = P_COLUMNS
#: first column of the translation ``t`` in a posed table
P_T = P_R + 9
#: columns of a posed table
P_COLUMNS_POSED = P_T + 3
#: bisection iterations when a step overshoots into d < 0 (halves the bracket each time)
BISECT_ITERS = 40
#: tol mode: a sphere-tracing step may under-estimate by up to this fraction of the previous
#: distance (the evaluation's tolerance is loosened accordingly; 0 disables the relaxation;
#: the fastest measured: performance guide, "Tuning constants")
RELAX = 0.05
#: tol mode: loosened evaluations (far from the surface) also use Barnes-Hut with at least
#: this beta (conservative, so still safe); 0 disables
FAR_BETA = 0.25
#: cap of the over-relaxed sphere-tracing steps, as a multiple of ``d`` (1: plain sphere
#: tracing); their length follows the slope of ``d`` along the ray, see march_ray (measured:
#: performance guide, "Tuning constants")
OMEGA = 2.0
#: an over-relaxed step is this fraction of the longest step whose end sphere still overlaps
#: the start sphere if ``d`` changes linearly (see march_ray; measured: performance guide,
#: "Tuning constants")
OMEGA_SAFETY = 0.9
#: Newton steps along the ray once ``d <= NEWTON x eps`` (0: plain sphere tracing), but never
#: from farther than ``NEWTON_FAR`` x the scene box diagonal; see march_ray and newton_distance
NEWTON = 100.0
NEWTON_FAR = 0.01
#: a Newton step is at most this many times the sphere-tracing step ``d``
NEWTON_CAP = 4.0
#: rays meeting the surface at a smaller cosine (relative to ``|g|``) keep sphere steps: a
#: smaller value is faster but lets a Newton step cross a thin part in a one-sample image (the
#: anti-aliasing samples use 0.02, ``tracer.rendering.film.SAMPLE_NEWTON_COS``; performance guide,
#: "Tuning constants")
NEWTON_COS = 0.2
#: seed each tile's rays with a conservative start depth from a cone march (cone_start)
CONE = True
#: smooth mode, Newton steps on: where the cone pass ends within the Newton distance, each ray
#: of the tile takes its first step to where the tangent plane of the cone's last evaluation
#: meets it (:func:`cone_newton_step`), checked as a Newton step, instead of evaluating the
#: distance at the cone's depth first (fewer evaluations per hit, the same depth error;
#: performance guide, "Tuning constants")
CONE_NEWTON = True
#: largest number of distance evaluations of one tile's cone march
CONE_STEPS = 64
#: the cone passes of a tile: once one of its rays has missed after more than this many
#: evaluations, the tile's :func:`cone_end` depth is computed and ends its later rays (misses
#: then stop behind the silhouette instead of stepping out of the box; performance guide,
#: "Tuning constants")
END_AFTER = 4
#: pixels per side of the square tiles handed to threads (and of the cone pass; 4 beat 8 and 16
#: by 16-18 % CPU time on the bunny at eps 1e-4 x diag, and 2: more cone marches than they save)
TILE = 4
#: a prime: tile j of the parallel loop traces tile (j * STRIDE) mod n
STRIDE = 7919
#: :func:`march_ray`'s ``span`` of a ray marched whole: ``(t_min, t_max, t_pred, d_lb)``
PLAIN_SPAN = (0.0, np.inf, 0.0, 0.0)


def _root_of(roots):
    """The root node of an int ``roots`` (the lean path of :func:`scene_distance`)."""
    raise NotImplementedError("_root_of is called from numba kernels only")


@overload(_root_of)
def _root_of_impl(roots):
    # numba-cuda does not prune the ``isinstance(roots, int)`` branch of scene_distance at
    # compile time (the CPU does), so the branch is typed with the (k,) array ``roots`` of the
    # general path too (tracer/rendering/gpu_render.py): it must compile there, and is never taken
    if isinstance(roots, nbtypes.Integer):
        return lambda roots: roots
    return lambda roots: roots[0]


@numba.njit(**NJIT)
def scene_distance(sc, x, y, z, work, slack=0.0):
    """Scene distance and gradient at ``(x, y, z)``.

    ``sc = (tree, roots, params, mode, tol)``: the scene (see the module docstring; ``tol`` its
    tolerance-controlled pruning, 0 = off). ``work = (stack, dstack)``: traversal scratch.
    ``slack >= 0`` (scene units) loosens a tolerance ``tol > 0`` to
    ``max(tol, expm1(alpha * slack))`` per object, i.e. lets each object's ``d_hat`` be up to
    ``slack`` below the ``tol = 0`` value (never above it).

    Returns ``(d, gx, gy, gz, nodes, leaves, nearest)``; the gradient is not normalised;
    ``nearest`` is the object whose own distance is the smallest (0 for one object; see
    ``_scene_distance_objects``), so that a ray's hit knows what it shows.

    ``roots`` may also be one root node, an int: one unposed object in smooth mode without
    tolerance pruning (``tracer.rendering.renderer.kernel_roots``), the same value as the general
    path with ``roots = [root]``. Numba then compiles only that branch (``isinstance`` is resolved
    at compile time), which is what keeps the first render of such a scene short.
    """
    tree, roots, params, mode, tol = sc
    stack, dstack = work
    if isinstance(roots, int):
        d, gx, gy, gz, nodes, leaves = smooth_distance_point(
            tree, x, y, z, params[0, P_ALPHA], params[0, P_BETA], params[0, P_S],
            params[0, P_WGS], stack, dstack, _root_of(roots))
        return d - params[0, P_OFFSET], gx, gy, gz, nodes, leaves, 0
    nobj = roots.size
    if params.shape[1] >= P_COLUMNS_POSED:
        return _scene_distance_objects(sc, x, y, z, work, slack)
    if nobj == 1:
        if mode == MODE_SMOOTH:
            alpha = params[0, P_ALPHA]
            d, gx, gy, gz, nodes, leaves = smooth_distance_point_tol(
                tree, x, y, z, alpha, _far_beta(params[0, P_BETA], tol, alpha, slack),
                _loosened(tol, alpha, slack), params[0, P_S], params[0, P_WGS], stack, dstack,
                roots[0])
            return d - params[0, P_OFFSET], gx, gy, gz, nodes, leaves, 0
        d, gx, gy, gz, p, nodes, leaves = exact_distance_point(tree, x, y, z, stack, dstack,
                                                               roots[0])
        return d - params[0, P_OFFSET], gx, gy, gz, nodes, leaves, 0
    return _scene_distance_objects(sc, x, y, z, work, slack)


@numba.njit(**NJIT)
def _local_point(params, k, x, y, z):
    """Object ``k``'s own coordinates of ``(x, y, z)``: ``R^T (p - t)`` in a posed table, the
    point itself otherwise."""
    if params.shape[1] < P_COLUMNS_POSED:
        return x, y, z
    px = x - params[k, P_T]
    py = y - params[k, P_T + 1]
    pz = z - params[k, P_T + 2]
    R0 = P_R
    return (params[k, R0] * px + params[k, R0 + 3] * py + params[k, R0 + 6] * pz,
            params[k, R0 + 1] * px + params[k, R0 + 4] * py + params[k, R0 + 7] * pz,
            params[k, R0 + 2] * px + params[k, R0 + 5] * py + params[k, R0 + 8] * pz)


@numba.njit(**NJIT)
def object_lower_bound(sc, k, x, y, z, slack):
    """A lower bound (scene units) of object ``k``'s distance at ``(x, y, z)`` from its root
    box alone: smooth mode ``b - (log N + S max(log whi, 0) + log(1 + tol_k)) / alpha`` (``b``
    the distance to the box; no term of ``N`` primitives is larger than ``whi**S
    exp(-alpha b)``, Barnes-Hut far fields included, and tolerance pruning lowers the sum's
    log by at most ``log(1 + tol_k)``), minus the object's smooth offset; exact-offset mode
    ``b - offset``."""
    tree, roots, params, mode, tol = sc
    lx, ly, lz = _local_point(params, k, x, y, z)
    root = roots[k]
    b = math.sqrt(box_distance2(lx, ly, lz, tree.lo, tree.hi, root)[0])
    if mode == MODE_EXACT:
        return b - params[k, P_OFFSET]
    alpha = params[k, P_ALPHA]
    n = max(tree.count[root], 1)
    return b - (math.log(n) + params[k, P_S] * max(tree.lwhi[root], 0.0)
                + math.log1p(_loosened(tol, alpha, slack))) / alpha - params[k, P_OFFSET]


@numba.njit(**NJIT)
def _object_distance(sc, k, x, y, z, work, slack):
    """Object ``k``'s distance and gradient at ``(x, y, z)`` (posed when ``params`` has the
    pose columns; the object's offset subtracted in both modes). Returns ``(d, gx, gy, gz, nodes,
    leaves)``, the gradient in scene coordinates."""
    tree, roots, params, mode, tol = sc
    stack, dstack = work
    lx, ly, lz = _local_point(params, k, x, y, z)
    if mode == MODE_SMOOTH:
        alpha = params[k, P_ALPHA]
        d, hx, hy, hz, nn, ll = smooth_distance_point_tol(
            tree, lx, ly, lz, alpha, _far_beta(params[k, P_BETA], tol, alpha, slack),
            _loosened(tol, alpha, slack), params[k, P_S], params[k, P_WGS], stack, dstack,
            roots[k])
        d -= params[k, P_OFFSET]
    else:
        d, hx, hy, hz, p, nn, ll = exact_distance_point(tree, lx, ly, lz, stack, dstack,
                                                        roots[k])
        d -= params[k, P_OFFSET]
    if params.shape[1] < P_COLUMNS_POSED:
        return d, hx, hy, hz, nn, ll
    R0 = P_R
    gx = params[k, R0] * hx + params[k, R0 + 1] * hy + params[k, R0 + 2] * hz
    gy = params[k, R0 + 3] * hx + params[k, R0 + 4] * hy + params[k, R0 + 5] * hz
    gz = params[k, R0 + 6] * hx + params[k, R0 + 7] * hy + params[k, R0 + 8] * hz
    return d, gx, gy, gz, nn, ll


@numba.njit(**NJIT)
def nearest_object(sc, x, y, z, slack):
    """The object with the smallest :func:`object_lower_bound` at ``(x, y, z)`` (visited
    first: the one most likely to set the minimum)."""
    first = 0
    lb_first = np.inf
    for k in range(sc[1].size):
        lb = object_lower_bound(sc, k, x, y, z, slack)
        if lb < lb_first:
            lb_first = lb
            first = k
    return first


@numba.njit(**NJIT)
def visiting_order(j, first):
    """The ``j``-th object visited: ``first``, then the others in index order."""
    if j == 0:
        return first
    return j - 1 if j <= first else j


#: objects whose lower bound (:func:`object_lower_bound`) lies this many ``1 / alpha`` beyond
#: the running minimum add less than ``2**-53 / k`` of the scene's LogSumExp sum each (the sum
#: relative to its minimum is >= 1): they are skipped, so the scene's value is that of all
#: objects up to float64 rounding
SKIP_LOG = 53.0 * math.log(2.0)


@numba.njit(**NJIT)
def _scene_distance_objects(sc, x, y, z, work, slack):
    """:func:`scene_distance` of several objects (posed or not): the object with the smallest
    :func:`object_lower_bound` first, then every other one unless its bound shows it cannot
    matter: in exact-offset mode a bound ``>=`` the minimum so far (the minimum is exact), in
    smooth mode a bound past ``m + (SKIP_LOG + log k) / a`` (its term is below one unit in
    the last place of the sum). The last value returned is the object whose own distance is
    the smallest (the first of equals in visiting order; a skipped object cannot be it: its
    bound is not below the minimum), what :func:`tracer.rendering.lighting.object_ids` computes."""
    tree, roots, params, mode, tol = sc
    nobj = roots.size
    nodes = 0
    leaves = 0
    first = nearest_object(sc, x, y, z, slack)
    a = params[0, P_ALPHA]
    for k in range(1, nobj):
        a = max(a, params[k, P_ALPHA])
    reach = (SKIP_LOG + math.log(nobj)) / a
    m = np.inf
    s = 0.0
    sx = 0.0
    sy = 0.0
    sz = 0.0
    nearest = first
    for j in range(nobj):
        k = visiting_order(j, first)
        if j > 0:
            lb = object_lower_bound(sc, k, x, y, z, slack)
            if lb >= (m if mode == MODE_EXACT else m + reach):
                continue
        d, gx, gy, gz, nn, ll = _object_distance(sc, k, x, y, z, work, slack)
        nodes += nn
        leaves += ll
        if d < m:               # m is the smallest object distance so far in both modes
            nearest = k
        if mode == MODE_SMOOTH:
            m, s, sx, sy, sz = logsumexp_accumulate(m, s, sx, sy, sz, d, 1.0, gx, gy, gz, a)
        elif d < m:
            m, sx, sy, sz = d, gx, gy, gz
    if mode == MODE_SMOOTH:
        return m - math.log(s) / a, sx / s, sy / s, sz / s, nodes, leaves, nearest
    return m, sx, sy, sz, nodes, leaves, nearest


@numba.njit(**NJIT)
def _loosened(tol, alpha, slack):
    """``max(tol, expm1(alpha * slack))`` for ``tol > 0`` (error ``log(1 + tol) / alpha``
    at most ``slack``); 0 stays 0 (tolerance pruning off)."""
    if tol > 0.0 and slack > 0.0:
        return max(tol, math.expm1(min(alpha * slack, 700.0)))
    return tol


@numba.njit(**NJIT)
def _far_beta(beta, tol, alpha, slack):
    """Barnes-Hut parameter of an evaluation whose ``tol`` is loosened by ``slack`` (see
    :func:`_loosened`): at least ``FAR_BETA``. The conservative far field only lowers
    ``d_hat`` (never above the ``beta = 0`` value), so a sphere-tracing step stays safe; it
    is only shorter. Unloosened evaluations (``_was_loosened`` false: a hit is accepted as
    it is) keep their own beta."""
    if _loosened(tol, alpha, slack) != tol:
        return max(beta, FAR_BETA)
    return beta


@numba.njit(**NJIT)
def _was_loosened(params, tol, slack):
    """Whether ``slack`` loosened the tolerance of any object (else no re-evaluation)."""
    for k in range(params.shape[0]):
        if _loosened(tol, params[k, P_ALPHA], slack) != tol:
            return True
    return False


def newton_distance(eps, lo, hi, newton=NEWTON):
    """Distance below which rays take Newton steps: ``min(newton x eps, NEWTON_FAR x |hi - lo|)``
    (scene units; ``lo, hi`` the scene box; ``newton = 0``: never)."""
    diag = float(np.linalg.norm(np.asarray(hi, dtype=np.float64)
                                - np.asarray(lo, dtype=np.float64)))
    return max(0.0, min(float(newton) * float(eps), NEWTON_FAR * diag))


@numba.njit(**NJIT)
def ray_box(ox, oy, oz, dx, dy, dz, lo, hi):
    """Slab test: ``(t_enter, t_exit)`` of the ray with box ``lo..hi``; ``t_enter > t_exit``
    misses."""
    t0 = 0.0
    t1 = np.inf
    o = (ox, oy, oz)
    dd = (dx, dy, dz)
    for a in range(3):
        if dd[a] != 0.0:
            inv = 1.0 / dd[a]
            ta = (lo[a] - o[a]) * inv
            tb = (hi[a] - o[a]) * inv
            if ta > tb:
                ta, tb = tb, ta
            t0 = max(t0, ta)
            t1 = min(t1, tb)
        elif o[a] < lo[a] or o[a] > hi[a]:
            return 1.0, 0.0
    return t0, t1


@numba.njit(**NJIT_IR_INLINE)
def _false_position(sc, pr, bracket, g, nearest, eps, work):
    """Root of ``d(t)`` along the ray ``pr = (ox, oy, oz, dx, dy, dz)`` in the bracket
    ``bracket = (a, fa, b, fb)``: ``d(a) = fa > eps``, ``d(b) = fb < -eps``.

    Illinois false position (the kept end's value is halved when the same end is kept twice),
    falling back to the midpoint when the interpolate is not inside the bracket. Stops at the
    first point with ``|d| <= eps``; after ``BISECT_ITERS`` evaluations it returns the inner
    end ``b`` (``d < -eps``). Returns ``(t, gx, gy, gz, evaluations, leaves, nearest)``; the
    gradient and the nearest object are those of the returned point (``g`` and ``nearest`` as
    given if ``b`` is never moved).
    """
    ox, oy, oz, dx, dy, dz = pr
    a, fa, b, fb = bracket
    gx, gy, gz = g
    side = 0
    evals = 0
    leaves = 0
    for _ in range(BISECT_ITERS):
        x = (a * fb - b * fa) / (fb - fa)
        if not (a < x < b):
            x = 0.5 * (a + b)
        dm, mx, my, mz, nn, ll, ob = scene_distance(sc, ox + x * dx, oy + x * dy, oz + x * dz,
                                                    work, 0.0)
        evals += 1
        leaves += ll
        if dm > eps:
            a = x
            fa = dm
            if side == 1:
                fb *= 0.5
            side = 1
        else:
            b = x
            fb = dm
            gx = mx
            gy = my
            gz = mz
            nearest = ob
            if dm >= -eps:
                break
            if side == -1:
                fa *= 0.5
            side = -1
    return b, gx, gy, gz, evals, leaves, nearest


@numba.njit(**NJIT)
def next_step(d, g, slope, mode, omega, near, newton_on, newton_cos):
    """The step from a point outside the band (``d > eps``) with distance gradient
    ``g = (gx, gy, gz)``,
    along which the distance changes at the rate ``slope = g . dir``:
    ``(step, relaxed, newton)``.

    *Over-relaxed* (``omega > 1``, smooth mode; Keinert et al. 2014): where ``d`` changes at
    the rate ``s``, the unbounding spheres at ``t`` and ``t + h`` still overlap for
    ``h <= 2 d / (1 - s)``; the step is :data:`OMEGA_SAFETY` of that, between ``d`` and
    ``omega d``. A ray heading into the surface takes plain steps, one that grazes it or moves
    away lengthens them. ``relaxed``: the step is longer than ``d`` (checked by the caller).

    *Newton* (``newton_on`` and ``d <= near``): ``h = d / -(g . dir)`` capped at
    ``NEWTON_CAP x d``. Sphere tracing converges linearly near a surface it meets at an angle
    (the distance shrinks by about ``1 - cos`` per step); Newton converges quadratically and
    usually lands within ``eps`` in one or two steps. Grazing rays (``-(g . dir) <
    newton_cos |g|``) keep sphere steps. ``newton``: the step is longer than ``d`` (checked by
    :func:`stepped_over`). Smooth mode only, both: the exact-offset field of a point cloud is
    a union of spheres, kinked everywhere; its gradient says little about the next step.
    """
    gx, gy, gz = g
    step = d
    if omega > 1.0 and mode == MODE_SMOOTH:
        step = d * min(omega, max(1.0, 2.0 * OMEGA_SAFETY / (1.0 - min(slope, 0.999))))
    relaxed = step > d
    newton = False
    if d <= near and newton_on and -slope > newton_cos * math.sqrt(gx * gx + gy * gy + gz * gz):
        step = min(d / -slope, NEWTON_CAP * d)
        relaxed = False
        newton = step > d
    return step, relaxed, newton


@numba.njit(**NJIT)
def stepped_over(step, d_prev, d, eps, slope):
    """Whether a Newton step of length ``step``, from a point at distance ``d_prev`` to one at
    ``d`` where the distance changes along the ray at the rate ``slope``, may have stepped
    over a thin shell: it left the part of the ray the sphere at its start certifies
    (``step > d_prev + |d|``) and landed outside (``d >= -eps``) where ``d`` grows along the
    ray (``slope > 0``), so ``d`` had a minimum in the uncertified gap (the zero set around a
    triangle sheet at high alpha is such a shell). The caller undoes it and goes on with plain
    steps: a surface is then only crossed, or landed on from its front side. Not detected: a
    step that crosses a whole shell *and* lands where ``d`` falls again (a second surface
    within ``NEWTON_CAP x newton``)."""
    return step > d_prev + abs(d) and d >= -eps and slope > 0.0


@numba.njit(**NJIT)
def march_ray(sc, pr, limits, stepping, span, work):
    """March the ray ``pr = (ox, oy, oz, dx, dy, dz)`` (unit direction) through the scene
    ``sc``; returns ``(hit, t, gx, gy, gz, steps, leaves, bisections, nearest)``.

    ``limits = (lo, hi, eps, max_steps)``: the box the ray marches in, the hit threshold
    (scene units) and the most distance evaluations; ``stepping = (relax, omega, newton,
    newton_cos)`` and ``span = (t_min, t_max, t_pred, d_lb)`` as below (:data:`PLAIN_SPAN`:
    the whole ray, no first-step prediction); ``work = (stack, dstack)``. Every caller gives
    every tuple whole: one specialisation serves the camera rays, the samples and the ground.

    Each step comes from :func:`next_step`: over-relaxed by up to ``omega >= 1`` (1: plain
    sphere tracing), or a Newton step once ``d <= newton`` (scene units, see
    :func:`newton_distance`; 0: never). An over-relaxed step whose end sphere does not
    overlap its start sphere (``h > d_prev + d``, ``d`` taken as 0 inside) is redone as the
    plain step ``d_prev``; a Newton step that may have stepped over a shell
    (:func:`stepped_over`) is undone, and Newton steps stay off for the rest of the ray.

    ``relax`` (scenes with ``tol > 0``): far from the surface a step may under-estimate the
    distance by up to ``relax`` x the previous step (cheaper evaluations; 0: never).
    ``t_min`` / ``t_max``: depths before / beyond which the ray is known not to meet the
    surface (the tile's cone pass, :func:`cone_end`): the march runs from ``max(box entry,
    t_min)`` to ``min(box exit, t_max)``. ``t_pred > t_min`` and ``d_lb > 0`` (smooth mode,
    Newton on): the distance at ``t_min`` is at least ``d_lb`` and the first step goes to
    ``t_pred`` (:func:`cone_newton_step`), checked as a Newton step. (With ``d_lb <= eps`` the
    ray at ``t_min`` may already lie in the band; it then stops at ``t_pred``, deeper in the
    same band, or, if that overshoots, at a band point false position finds between them.)

    ``hit`` is 1 when ``|d| <= eps`` was reached inside the box; a step into ``d < -eps`` is
    resolved by false position back to the last positive point (``_false_position``).
    Then ``t`` is the ray parameter, ``g`` the (unnormalised) distance gradient there and
    ``nearest`` the object whose own distance is the smallest (:func:`scene_distance`).
    Misses return ``t = nan``, ``nearest = -1``.
    """
    tree, roots, params, mode, tol = sc
    ox, oy, oz, dx, dy, dz = pr
    lo, hi, eps, max_steps = limits
    relax, omega, newton, newton_cos = stepping
    t_min, t_max, t_pred, d_lb = span
    t, t_exit = ray_box(ox, oy, oz, dx, dy, dz, lo, hi)
    t = max(t, t_min)
    t_exit = min(t_exit, t_max)
    relaxable = mode == MODE_SMOOTH and tol > 0.0 and relax > 0.0
    steps = 0
    leaves = 0
    bis = 0
    if t > t_exit:
        return 0, np.nan, 0.0, 0.0, 0.0, steps, leaves, bis, -1
    t_prev = t
    # relaxed accuracy far from the surface (scenes with tol > 0 only): a step may lose up
    # to relax x the previous distance, never more, and stays safe because d_hat_tol only
    # under-estimates; a distance <= eps is re-evaluated at the scene's own tol before it
    # counts as a hit (a Newton step may start from a loosened value: it is only shorter)
    slack = np.inf if relaxable else 0.0
    near = max(eps, newton)
    d_prev = 0.0
    step = 0.0
    newton_on = newton > 0.0 and mode == MODE_SMOOTH
    newton_step = False
    relaxed = False         # the last step was an over-relaxed one (to be checked)
    ob = -1
    if newton_on and d_lb > 0.0 and t < t_pred <= t_exit:
        # the cone pass's predicted first step, from a point at distance >= d_lb; it lands
        # near the surface, so it is evaluated at the scene's own tol at once
        d_prev = d_lb
        step = t_pred - t
        newton_step = step > d_lb
        t = t_pred
        slack = 0.0
    while steps < max_steps:
        d, gx, gy, gz, nn, ll, ob = scene_distance(sc, ox + t * dx, oy + t * dy, oz + t * dz,
                                                   work, slack)
        steps += 1
        leaves += ll
        if d <= eps and slack > 0.0 and relaxable and _was_loosened(params, tol, slack):
            d, gx, gy, gz, nn, ll, ob = scene_distance(sc, ox + t * dx, oy + t * dy,
                                                       oz + t * dz, work, 0.0)
            steps += 1
            leaves += ll
        slope = gx * dx + gy * dy + gz * dz
        if (relaxed and step > d_prev + max(d, 0.0)) or (
                newton_step and stepped_over(step, d_prev, d, eps, slope)):
            # the long step may have jumped over a surface: take the plain one instead
            newton_on = newton_on and not newton_step
            relaxed = False
            newton_step = False
            t = t_prev + d_prev
            step = d_prev
            continue
        newton_step = False
        if d <= eps:
            if d < -eps and t > t_prev:
                # overshoot into the negative band: find the root in [t_prev (d > eps), t]
                bis += 1
                t, gx, gy, gz, ev, lv, ob = _false_position(sc, pr, (t_prev, d_prev, t, d),
                                                            (gx, gy, gz), ob, eps, work)
                steps += ev
                leaves += lv
            return 1, t, gx, gy, gz, steps, leaves, bis, ob
        t_prev = t
        d_prev = d
        step, relaxed, newton_step = next_step(d, (gx, gy, gz), slope, mode, omega, near,
                                               newton_on, newton_cos)
        t += step
        # near the surface the next point is evaluated at full accuracy at once (a loosened
        # value there would mostly fall below eps and be evaluated again)
        slack = relax * d if (relaxable and d > near) else 0.0
        if t > t_exit:
            if t_prev + d_prev >= t_exit:
                break
            # an over-relaxed or Newton step past the end left (t_prev + d_prev, t_exit)
            # uncertified: take the plain step instead
            relaxed = False
            newton_step = False
            t = t_prev + d_prev
            step = d_prev
    return 0, np.nan, 0.0, 0.0, 0.0, steps, leaves, bis, -1


@numba.njit(**NJIT_IR_INLINE)
def cone_start(sc, cam, limits, tile, work, relax):
    """Conservative common start depth for the rays of the pixels of ``tile = (r_lo, r_hi,
    c_lo, c_hi)``: ``[r_lo, r_hi) x [c_lo, c_hi)`` (``sc``, ``limits``, ``work`` as in
    :func:`march_ray`).

    Cone marching along the tile's central ray ``o + t u``: every pixel ray of the tile stays
    within ``near + t spread`` of it at the same ``t`` (the camera's
    :func:`~tracer.rendering.camera.block_rays`: ``near = 0`` and ``spread >= |v - u|`` for the
    pinhole, ``spread = 0`` for parallel rays). A point at parameter ``s`` of a pixel ray lies
    within ``|s - t| + w(t)``, ``w(t) = near + t spread``, of the central point at ``t``, so if
    the scene distance there is ``D``, every ray is surface-free on ``[t, t + D - w(t))`` (the
    ball of radius ``D`` is, by the same Lipschitz argument as sphere tracing,
    docs/design-notes.md §4). Steps ``t += D - w(t)`` start at the camera (outside the
    surface) and stop once the cone is wider than a quarter of ``D`` (or leaves the box).
    For ``tol > 0`` scenes the evaluations are loosened like the march's (``relax``): an
    under-estimated ``D`` is still a surface-free radius. Returns ``(t_start, evaluations,
    leaves, D, gx, gy, gz)``: ``D`` and ``g`` are the distance and gradient at the returned
    depth on the central ray (``D = -1``: none; with ``relax``, ``D`` may be a loosened value,
    which is still a lower bound).
    """
    beam = block_rays(cam, tile[0], tile[1], tile[2], tile[3])
    t_in, t_out = ray_box(beam[0], beam[1], beam[2], beam[3], beam[4], beam[5], limits[0],
                          limits[1])
    return cone_march(sc, beam, limits, work, relax, 0.0, t_out, 1.0)


@numba.njit(**NJIT)
def cone_newton_step(t_min, D, gx, gy, gz, beam, ray):
    """A ray's first step from its tile's cone pass: ``(t_pred, d_lb)``.

    The cone's last evaluation, at depth ``t_min`` on the central ray ``o + t u`` of ``beam``
    (:func:`~tracer.rendering.camera.block_rays`: ``(ox, oy, oz, ux, uy, uz, near,
    spread)``), gave the distance ``D`` and gradient ``g``. The ray ``ray = (px, py, pz, vx,
    vy, vz)`` of the beam is at most ``w = near + t_min spread`` from that point at the same
    depth, so its distance there is at least ``d_lb = D - w`` (Lipschitz, as for
    :func:`cone_start`). ``t_pred`` is where the tangent plane ``D + g . (x - o - t_min u) =
    0`` meets the ray, capped at ``t_min + NEWTON_CAP d_lb`` as a Newton step from distance
    ``d_lb`` would be; 0 where the ray meets the plane at a cosine below ``NEWTON_COS``
    (grazing) or not at all. :func:`march_ray` takes it as its first step and checks it as
    it checks its own Newton steps (an uncertified step that lands where the distance grows
    along the ray is undone)."""
    ox, oy, oz, ux, uy, uz, near, spread = beam
    px, py, pz, dx, dy, dz = ray
    d_lb = D - (near + t_min * spread)
    gv = gx * dx + gy * dy + gz * dz
    if not gv < -NEWTON_COS * math.sqrt(gx * gx + gy * gy + gz * gz):
        return 0.0, d_lb
    # g . (o + t_min u - p): the central point seen from the ray's origin
    cu = t_min * (gx * ux + gy * uy + gz * uz) + (gx * (ox - px) + gy * (oy - py)
                                                  + gz * (oz - pz))
    return min((cu - D) / gv, t_min + NEWTON_CAP * d_lb), d_lb


@numba.njit(**NJIT_IR_INLINE)
def cone_end(sc, cam, limits, tile, work, relax):
    """Conservative common end depth for the rays of the pixels of ``tile`` (arguments as
    :func:`cone_start`'s): :func:`cone_start` run backwards, from the depth beyond which every
    ray has left the box (:func:`~tracer.rendering.camera.far_depth`) towards the camera.

    Every ray of the block is surface-free from the returned ``t_end`` on: beyond that
    depth a point is outside the box (no surface there), and each step ``t -= D - w(t)``
    keeps, by the argument of :func:`cone_start` (symmetric in ``s - t``), the part of every
    ray within ``D - w(t)`` of ``t`` surface-free. A ray
    that passes a silhouette then stops at ``t_end`` instead of stepping out of the box with
    the growing distances behind the silhouette. Stops when the step falls below a quarter
    of ``D`` (or ``eps``), or the cone reaches the camera. Returns ``(t_end, evaluations,
    leaves)``."""
    # every ray is outside the box beyond the camera's far_depth: the cone starts there
    beam = block_rays(cam, tile[0], tile[1], tile[2], tile[3])
    t, evals, leaves = cone_march(sc, beam, limits, work, relax,
                                  far_depth(cam, limits[0], limits[1]), 0.0, -1.0)[:3]
    return t, evals, leaves


@numba.njit(**NJIT)
def cone_march(sc, beam, limits, work, relax, t, t_out, sign):
    """The cone passes' march along the central ray of ``beam``
    (:func:`~tracer.rendering.camera.block_rays`: ``(ox, oy, oz, ux, uy, uz, near, spread)``)
    from depth ``t``: away from the camera up to ``t_out`` (``sign`` 1.0, :func:`cone_start`),
    or towards it down to 0 (``sign`` -1.0, :func:`cone_end`), by steps ``D - (near + t
    spread)``, until one falls below a quarter of ``D`` or ``eps`` (``limits[2]``). One loop for
    both passes (``sign`` a float, not a bool: numba would compile a literal flag twice).
    Returns ``(t, evaluations, leaves, D, gx, gy, gz)``: ``D = -1`` past ``t_out``; ``t = 0``
    at the camera."""
    mode, tol = sc[3], sc[4]
    eps = limits[2]
    ox, oy, oz, ux, uy, uz, near, spread = beam
    evals = 0
    leaves = 0
    loose = mode == MODE_SMOOTH and tol > 0.0 and relax > 0.0
    slack = np.inf if loose else 0.0
    d = -1.0
    gx = gy = gz = 0.0
    while evals < CONE_STEPS:
        d, gx, gy, gz, nn, ll, ob = scene_distance(sc, ox + t * ux, oy + t * uy, oz + t * uz,
                                                   work, slack)
        if loose:
            slack = relax * d
        evals += 1
        leaves += ll
        step = d - (near + t * spread)
        if step <= 0.25 * d or step <= eps:
            break
        t += sign * step        # exactly t - step for sign -1
        if sign < 0.0 and t <= 0.0:
            return 0.0, evals, leaves, d, gx, gy, gz
        if sign > 0.0 and t > t_out:
            return t, evals, leaves, -1.0, gx, gy, gz
    return t, evals, leaves, d, gx, gy, gz


@numba.njit(**NJIT_IR_INLINE)
def tile_cone(sc, cam, limits, tile, work, relax, newton):
    """The cone pass of the tile ``tile = (r_lo, r_hi, c_lo, c_hi)``, as every tile's rays
    start (arguments as :func:`cone_start`'s).

    Returns ``(first, t_min, D, gx, gy, gz, evals, leaves)``: ``first`` the tile-local index
    (``(r - r_lo) * (c_hi - c_lo) + c - c_lo``) of the first ray, in row order, that meets the
    scene box (-1: none, and no cone is marched: every ray misses); ``t_min`` the rays'
    common start depth (:func:`cone_start`); ``D`` and ``g`` the distance and gradient there
    on the central ray when they may seed :func:`cone_newton_step` (``0 < D <= newton`` with
    :data:`CONE_NEWTON`), else ``D = -1``; the cone's evaluations and leaves (booked on the
    ray ``first``). Shared by the CPU tiles and the GPU's tile kernel."""
    r_lo, r_hi, c_lo, c_hi = tile
    lo, hi = limits[0], limits[1]
    first = -1
    k = 0
    for r in range(r_lo, r_hi):
        for c in range(c_lo, c_hi):
            if first < 0:
                ox, oy, oz, dx, dy, dz = camera_ray(cam, float(r), float(c))
                t_in, t_out = ray_box(ox, oy, oz, dx, dy, dz, lo, hi)
                if t_in <= t_out:
                    first = k
            k += 1
    if first < 0:
        return -1, 0.0, -1.0, 0.0, 0.0, 0.0, 0, 0
    t_min, evals, leaves, D, gx, gy, gz = cone_start(sc, cam, limits, tile, work, relax)
    if not (CONE_NEWTON and 0.0 < D <= newton):
        D = -1.0
    return first, t_min, D, gx, gy, gz, evals, leaves


@numba.njit(**NJIT)
def cone_first_step(cam, tile, seed, ray):
    """``(t_pred, d_lb)`` of a ray ``ray = (ox, oy, oz, dx, dy, dz)`` of the tile ``tile``
    from its cone passes ``seed = (t_min, t_max, D, gx, gy, gz)`` (:func:`tile_cone`;
    ``D <= 0``: none, ``(0, 0)``); see :func:`cone_newton_step`."""
    t_min, t_max, D, gx, gy, gz = seed
    if not D > 0.0:
        return 0.0, 0.0
    beam = block_rays(cam, tile[0], tile[1], tile[2], tile[3])
    return cone_newton_step(t_min, D, gx, gy, gz, beam, ray)


@numba.njit(**NJIT_IR_INLINE)
def scene_of(tree, ray):
    """The scene ``sc = (tree, roots, params, mode, tol)`` the distance kernels take, from the
    tree and :class:`tracer.rendering.frame.MarchArgs` (or its plain tuple: the GPU's)."""
    return (tree, ray[0], ray[1], ray[2], ray[3])


@numba.njit(**NJIT_IR_INLINE)
def limits_of(ray):
    """The march's ``limits = (lo, hi, eps, max_steps)`` in
    :class:`tracer.rendering.frame.MarchArgs` ``ray``."""
    return (ray[5], ray[6], ray[7], ray[8])


@numba.njit(**NJIT_IR_INLINE)
def scratch(depth_max):
    """``work = (stack, dstack)``, the traversal scratch of a tree of depth ``depth_max``."""
    return (np.empty(depth_max + 4, dtype=np.int64), np.empty(depth_max + 4))


@numba.njit(**NJIT_IR_INLINE)
def _render_tile(tree, ray, tile, depth_max, out, opts):
    """Trace the pixels ``r_lo <= r < r_hi, c_lo <= c < c_hi`` of one tile ``tile = (r_lo,
    r_hi, c_lo, c_hi)`` (see :func:`render_tiles`; ``tree``, ``ray``, ``out``, ``opts`` as
    there)."""
    sc = scene_of(tree, ray)
    cam = ray[4]
    relax, omega, cone, newton = opts
    work = scratch(depth_max)
    first = -1
    t_min = 0.0
    t_max = np.inf
    D = -1.0
    cgx = cgy = cgz = 0.0
    c_ev0 = c_lv0 = 0
    if cone:
        first, t_min, D, cgx, cgy, cgz, c_ev0, c_lv0 = tile_cone(
            sc, cam, limits_of(ray), tile, work, relax, newton)
    pending_end = cone
    k = 0
    for r in range(tile[0], tile[1]):
        for c in range(tile[2], tile[3]):
            c_ev = c_ev0 if k == first else 0
            c_lv = c_lv0 if k == first else 0
            k += 1
            res = march_pixel(tree, ray, opts, (r, c), tile, (t_min, t_max, D, cgx, cgy, cgz),
                              work)
            if res[0] == 0 and pending_end and res[5] > END_AFTER:
                t_max, e_ev, e_lv = cone_end(sc, cam, limits_of(ray), tile, work, relax)
                c_ev += e_ev
                c_lv += e_lv
                pending_end = False
            store_pixel(out, r, c, res, c_ev, c_lv)


@numba.njit(**NJIT_IR_INLINE)
def march_pixel(tree, ray, opts, pixel, tile, seed, work):
    """The camera ray of pixel ``pixel = (r, c)`` of the tile ``tile = (r_lo, r_hi, c_lo,
    c_hi)``, marched from the tile's cone passes ``seed = (t_min, t_max, D, gx, gy, gz)``
    (:func:`tile_cone`, :func:`cone_end`; ``D <= 0``: no first-step prediction):
    :func:`march_ray`'s nine values. ``ray``: :class:`tracer.rendering.frame.MarchArgs`;
    ``opts``: :class:`tracer.rendering.frame.TraceOptions`. The one per-pixel path of the
    CPU's tiles and the GPU's render kernel."""
    relax, omega, cone, newton = opts
    cam = ray[4]
    pr = camera_ray(cam, float(pixel[0]), float(pixel[1]))
    t_pred, d_lb = cone_first_step(cam, tile, seed, pr)
    return march_ray(scene_of(tree, ray), pr, limits_of(ray), (relax, omega, newton, NEWTON_COS),
                     (seed[0], seed[1], t_pred, d_lb), work)


@numba.njit(**NJIT_IR_INLINE)
def store_pixel(out, r, c, res, evals, leaves):
    """Write :func:`march_pixel`'s result ``res`` into pixel ``(r, c)`` of ``out``
    (:class:`tracer.rendering.frame.PixelBuffers`), with ``evals`` and ``leaves`` of the
    tile's cone passes added to the pixel's own."""
    hit, tbuf, grad, steps, lvs, bisect, objs = out
    store_ray((hit, tbuf, grad, steps, objs), r, c, res, evals)
    lvs[r, c] = res[6] + leaves
    bisect[r, c] = res[7]


@numba.njit(**NJIT_IR_INLINE)
def store_ray(buffers, r, c, res, evals):
    """Write :func:`march_ray`'s result ``res`` into entry ``(r, c)`` of ``buffers = (hit,
    tbuf, grad, steps, objs)`` (a pixel of :func:`store_pixel`'s image, or a sample of
    :func:`sample_ray`'s pixel), with ``evals`` added to its steps."""
    hit, tbuf, grad, steps, objs = buffers
    hit[r, c] = res[0] == 1
    tbuf[r, c] = res[1]
    grad[r, c, 0] = res[2]
    grad[r, c, 1] = res[3]
    grad[r, c, 2] = res[4]
    steps[r, c] = res[5] + evals
    objs[r, c] = res[8]


@numba.njit(**NJIT)
def _tile_grid(cam, band):
    """Tiles of rows ``row0 <= r < row1`` (``band = (row0, row1)``): ``(image width, tiles
    per row, number of tiles, stride of the scattered visiting order)``."""
    W = image_size(cam)[0]
    ntx = (W + TILE - 1) // TILE
    n = ntx * ((band[1] - band[0] + TILE - 1) // TILE)
    return W, ntx, n, (STRIDE if n % STRIDE != 0 else 1)


@numba.njit(**NJIT)
def _tile_rect(j, grid, band):
    """Pixel rectangle ``(r_lo, r_hi, c_lo, c_hi)`` of the ``j``-th tile visited (tile
    ``j * stride mod n``, see :func:`render_tiles`; ``grid``: :func:`_tile_grid`'s)."""
    W, ntx, n, stride = grid
    row0, row1 = band
    tile = (j * stride) % n
    ty = tile // ntx
    tx = tile - ty * ntx
    return (row0 + ty * TILE, min(row1, row0 + (ty + 1) * TILE), tx * TILE,
            min(W, (tx + 1) * TILE))


def compile_helpers(ray, band, opts):
    """Compile the trace's helpers that do not evaluate the distance (the camera's rays, the
    box, the tiles, the cone's first steps, the march's steps) with the types
    :func:`render_tiles` calls them with, by calling each once from Python on ``ray``
    (:class:`tracer.rendering.frame.MarchArgs`), ``band = (row0, row1)`` and ``opts``
    (:class:`tracer.rendering.frame.TraceOptions`); the values are not used. A first render
    calls it while it waits for a child compiling the scene's distance
    (``tracer.scenes.compile_ahead``): its trace kernel then loads them instead of compiling
    them after that wait (``tests/tracer/scenes/test_compile_ahead.py`` checks that nothing
    compiles twice)."""
    cam, lo, hi, eps = ray.cam, ray.lo, ray.hi, float(ray.eps)
    relax, omega, cone, newton = opts
    pr = camera_ray(cam, 0.0, 0.0)
    ray_box(*pr, lo, hi)
    far_depth(cam, lo, hi)
    grid = _tile_grid(cam, (int(band[0]), int(band[1])))
    tile = _tile_rect(0, grid, (int(band[0]), int(band[1])))
    block_rays(cam, *tile)
    # a seed with D > 0: the first step of the cone's Newton prediction too
    cone_first_step(cam, tile, (0.0, np.inf, 1.0, 0.0, 0.0, 1.0), pr)
    next_step(1.0, (0.0, 0.0, 1.0), 0.0, int(ray.mode), float(omega), max(eps, float(newton)),
              True, NEWTON_COS)
    stepped_over(1.0, 1.0, 1.0, eps, 0.0)
    _was_loosened(ray.params, float(ray.tol), 0.0)


def compile_march(tree, ray, depth_max, opts):
    """Compile :func:`march_ray` with the types :func:`render_tiles` calls it with, by marching
    the camera ray of pixel ``(0, 0)`` once from Python (``tree``, ``ray``, ``depth_max``,
    ``opts`` as :func:`render_tiles` takes them; the result is not used). A first render with a
    child compiling its film's kernels (``tracer.scenes.compile_ahead``) calls it as soon as
    the child has compiled the scene's distance, before its trace kernel: the child's ground
    probe and samples' kernel, which march with it too, then load it from the cache instead of
    compiling it again while the trace kernel compiles
    (``tests/tracer/scenes/test_compile_ahead.py`` checks that nothing compiles twice)."""
    relax, omega, cone, newton = opts
    march_ray((tree, ray.roots, ray.params, ray.mode, ray.tol), camera_ray(ray.cam, 0.0, 0.0),
              (ray.lo, ray.hi, ray.eps, ray.max_steps), (relax, omega, newton, NEWTON_COS),
              PLAIN_SPAN, (np.empty(depth_max + 4, dtype=np.int64), np.empty(depth_max + 4)))


@numba.njit(**NJIT)
def distance_at(sc, x, y, z, depth_max):
    """Scene distance at one point (used to check that the camera is outside the surface);
    ``sc`` as in :func:`scene_distance`."""
    return scene_distance(sc, x, y, z, scratch(depth_max), 0.0)[0]


@numba.njit(**NJIT_PARALLEL)
def trace_pixels(tree, ray, rows, cols, depth_max, out, opts):
    """Trace only the pixels ``(rows[i], cols[i])`` (e.g. a subsample for an expensive
    reference render), from the camera (no cone pass: ``opts.cone`` is not read); ``out =
    (hit, tbuf, steps, leaves)`` have the shape of ``rows``; ``tree``, ``ray``, ``opts`` as in
    :func:`render_tiles`."""
    for i in prange(rows.size):
        # a call, not code inlined into the parallel loop: numba's parfors marched no ray
        # with the march's tuples built here
        _trace_pixel(tree, ray, (rows[i], cols[i]), depth_max, out, opts, i)


@numba.njit(**NJIT)
def _trace_pixel(tree, ray, pixel, depth_max, out, opts, i):
    """Pixel ``pixel = (r, c)`` of :func:`trace_pixels`, into entry ``i`` of ``out``."""
    hit, tbuf, steps, leaves = out
    relax, omega, cone, newton = opts
    pr = camera_ray(ray[4], float(pixel[0]), float(pixel[1]))
    h, t, gx, gy, gz, st, lv, bs, ob = march_ray(
        scene_of(tree, ray), pr, limits_of(ray), (relax, omega, newton, NEWTON_COS), PLAIN_SPAN,
        scratch(depth_max))
    hit[i] = h == 1
    tbuf[i] = t
    steps[i] = st
    leaves[i] = lv


@numba.njit(**NJIT)
def sample_tasks(tree, ray, samples, depth_max, out, opts, tasks):
    """Trace anti-aliasing samples: ``samples``
    (:class:`tracer.rendering.frame.SampleRays`: ``rows, cols (m,)``, ``offsets (K, 2)``,
    ``eps_px``, ``newton_cos``); for pixel ``(rows[i], cols[i])`` the rays through
    ``(rows[i] + offsets[k, 0], cols[i] + offsets[k, 1])`` for every ``k``.

    ``offsets`` lie within one pixel of the pixel's own ray (``|offset| <= 1`` per
    axis), so one cone pass over the pixel's 3 x 3 block from the camera (:func:`cone_start`)
    and one from beyond the box (:func:`cone_end`) bound the part of all ``K`` rays that can
    meet the surface: ``[t_lo[i], t_hi[i]]``. ``t_lo, t_hi (m,)`` are read when finite (from
    an earlier call for the same pixels: the cone passes are not repeated) and written
    otherwise. ``out`` (:class:`tracer.rendering.frame.SampleBuffers`) holds those bounds and the
    outputs, ``(m, K)``: ``hit`` bool, ``tbuf``, ``steps`` int64 (the cone
    passes booked on sample 0), ``objs`` int32 (the object each hit shows, -1 for a miss;
    :func:`march_ray`), and ``grad (m, K, 3)``; ``tree``, ``ray`` and ``opts`` as in
    :func:`render_tiles`. Pixels are independent, so the
    result does not depend on the number of threads or tasks: ``tasks = (ntasks, task0,
    task1)``, this call runs tasks ``task0 <= task < task1`` of ``ntasks`` strided ones (task
    ``t`` the pixels ``t, t + ntasks, ...``; :mod:`smoothdist.schedule`: the flagged pixels
    come in image order, and their cost follows the silhouette). Serial and ``nogil``, for
    Python threads (``smoothdist.schedule.run_tasks``): no ``prange`` to compile.

    ``eps_px >= 0``: the hit threshold of these rays is at least ``eps_px`` pixels, measured at
    the cone's start depth (a lower bound of any hit's depth): a sample only decides how much
    of the pixel is covered, and a ray that comes within a fraction of a pixel of the surface
    covers it. ``newton_cos``: as :data:`NEWTON_COS`, for these rays.
    """
    ntasks, task0, task1 = tasks
    tree = borrowed(tree)
    ray = borrowed(ray)
    work = scratch(depth_max)
    n = samples[0].size
    for task in range(task0, task1):
        for i in range(task, n, ntasks):    # every ntasks-th pixel
            # its cone bounds, then its rays: the GPU's threads call the same two functions
            sample_bounds(tree, ray, samples, out, opts, i, work)
            for k in range(samples[2].shape[0]):
                sample_ray(tree, ray, samples, out, opts, i, k, work)


@numba.njit(**NJIT_IR_INLINE)
def sample_bounds(tree, ray, samples, out, opts, i, work):
    """The cone bounds ``out.t_lo[i]``, ``out.t_hi[i]`` of pixel ``i`` of
    :func:`sample_tasks` where they are not given (without the cone: ``0`` and ``inf``), and
    the distance evaluations they took in ``out.steps[i, 0]`` (0 when given), which
    :func:`sample_ray` adds to the pixel's sample 0."""
    t_lo = out[5]
    t_hi = out[6]
    relax, omega, cone, newton = opts
    r = samples[0][i]
    c = samples[1][i]
    c_ev = 0
    if cone and not (math.isfinite(t_lo[i]) and math.isfinite(t_hi[i])):   # CUDA: no ufunc
        sc = scene_of(tree, ray)
        block = (r - 1, r + 2, c - 1, c + 2)
        t_lo[i], ev = cone_start(sc, ray[4], limits_of(ray), block, work, relax)[:2]
        c_ev += ev
        t_hi[i], ev, lv = cone_end(sc, ray[4], limits_of(ray), block, work, relax)
        c_ev += ev
    elif not cone:
        t_lo[i] = 0.0
        t_hi[i] = np.inf
    out[3][i, 0] = c_ev


@numba.njit(**NJIT_IR_INLINE)
def sample_ray(tree, ray, samples, out, opts, i, k, work):
    """Ray ``k`` (``offsets[k]``) of pixel ``i`` of :func:`sample_tasks`, from the pixel's
    cone bounds (:func:`sample_bounds`, done; its evaluations, in ``out.steps[i, 0]``, are
    added to sample 0's)."""
    hit, tbuf, grad, steps, objs, t_lo, t_hi = out
    relax, omega, cone, newton = opts
    rows, cols, offsets, eps_px, newton_cos = samples
    cam = ray[4]
    lo, hi, eps, max_steps = limits_of(ray)
    near_px, pixel = footprint(cam)      # a pixel's size at depth t: near_px + pixel t
    t_min = t_lo[i]
    e = max(eps, eps_px * pixel * t_min + eps_px * near_px)
    pr = camera_ray(cam, rows[i] + offsets[k, 0], cols[i] + offsets[k, 1])
    res = march_ray(scene_of(tree, ray), pr, (lo, hi, e, max_steps),
                    (relax, omega, newton, newton_cos), (t_min, t_hi[i], 0.0, 0.0), work)
    store_ray((hit, tbuf, grad, steps, objs), i, k, res, steps[i, 0] if k == 0 else 0)


@numba.njit(**NJIT)
def gradient_tasks(tree, ray, samples, at, depth_max, out, tasks):
    """The scene's gradient at depth ``at[i]`` of sample ray 0 of pixel ``i``: what
    :func:`sample_tasks` returns for the span ``[at[i], at[i]]`` with a hit threshold of
    ``samples.eps_px`` pixels (the film's shading normals at a lower beta,
    ``tracer.rendering.film._shading_normals``), in one distance evaluation and without the
    march's code (a first render compiles this kernel in a fraction of ``sample_tasks``' time).

    ``samples`` (:class:`tracer.rendering.frame.SampleRays`, one offset), ``at (m,)`` float64,
    ``out = (hit (m,) bool, grad (m, 3) float64, steps (m,) int64)`` written where the point
    lies in the march's box (else ``hit`` stays False, as the march's miss): ``hit`` where
    the distance there meets the threshold (:func:`march_ray`'s ``d <= eps``), ``grad`` the
    unnormalised gradient, ``steps`` the evaluations (one). ``tasks = (ntasks, task0,
    task1)`` as in :func:`sample_tasks`. The same values bit for bit as ``sample_tasks``
    (the same ray, the same point, the distance at the scene's own ``tol``, which the march
    takes for a hit; tested)."""
    ntasks, task0, task1 = tasks
    tree = borrowed(tree)
    ray = borrowed(ray)
    work = scratch(depth_max)
    sc = scene_of(tree, ray)
    hit, grad, steps = out
    rows, cols, offsets, eps_px, newton_cos = samples
    cam = ray[4]
    lo, hi, eps, max_steps = limits_of(ray)
    near_px, pixel = footprint(cam)
    n = rows.size
    for task in range(task0, task1):
        for i in range(task, n, ntasks):
            t = at[i]
            ox, oy, oz, dx, dy, dz = camera_ray(cam, rows[i] + offsets[0, 0],
                                                cols[i] + offsets[0, 1])
            t_in, t_out = ray_box(ox, oy, oz, dx, dy, dz, lo, hi)
            if max(t_in, t) > min(t_out, t) or max_steps < 1:
                continue                # the march's miss before any evaluation
            d, gx, gy, gz, nn, ll, ob = scene_distance(sc, ox + t * dx, oy + t * dy,
                                                       oz + t * dz, work, 0.0)
            steps[i] = 1
            if d <= max(eps, eps_px * pixel * t + eps_px * near_px):
                hit[i] = True
                grad[i, 0] = gx
                grad[i, 1] = gy
                grad[i, 2] = gz


@numba.njit(**NJIT)
def render_tiles(tree, ray, band, depth_max, out, opts, j0, j1):
    """Trace tiles ``j0 <= j < j1`` of the rows ``row0 <= r < row1`` (``band = (row0,
    row1)``) of the image into the per-pixel output arrays, in the calling thread.

    ``tree``: the scene's (forest of) trees; ``ray``:
    :class:`tracer.rendering.frame.MarchArgs` (the rest of the scene's arrays, the camera,
    ``eps``, ``max_steps``); ``opts``:
    :class:`tracer.rendering.frame.TraceOptions` (``relax, omega, cone, newton``);
    ``depth_max``: the tree's depth (stack size). ``out``
    (:class:`tracer.rendering.frame.PixelBuffers`) holds full-image arrays: ``hit (H, W)
    bool``, ``tbuf (H, W) float64``, ``grad (H, W, 3) float64``, ``steps``, ``leaves``,
    ``bisect (H, W) int64`` and ``objs (H, W) int32``, the object each hit shows (its own
    distance the smallest at the hit; -1 where the ray misses; see :func:`march_ray`).

    The band is split into ``TILE x TILE`` tiles so that neighbouring rays share cache lines of
    the tree, visited in a scattered order (the ``j``-th is tile ``j * STRIDE mod n``,
    ``_tile_rect``) so that a run of tiles is a sample of the whole image. With ``cone``,
    a tile's rays start at its :func:`cone_start` depth and, once one of them has missed after
    more than :data:`END_AFTER` evaluations, the later ones end at its :func:`cone_end` depth.

    Serial and ``nogil``: ``tracer.rendering.renderer.trace_tiles`` runs it from a few Python
    threads that take chunks of tiles as they finish; a tile is traced by one call start to
    finish, so the result does not depend on the number of threads or the chunks. Without
    ``prange`` numba compiles the render in seconds less. The scene's arrays are passed down
    as borrowed views (``borrowed``), as ``prange`` would.
    """
    tree = borrowed(tree)
    ray = borrowed(ray)
    grid = _tile_grid(ray.cam, band)
    for j in range(j0, min(j1, grid[2])):
        _render_tile(tree, ray, _tile_rect(j, grid, band), depth_max, out, opts)
