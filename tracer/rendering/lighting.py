"""Light for publication images: key and fill lights, soft shadows, ambient occlusion, a ground.

The ``"lit"`` shading. Everything is computed from the same distance the tracer marches, with
the same kernels (:func:`tracer.rendering.march.scene_distance`), so Barnes-Hut, ``tol``, posed
objects and exact-offset mode apply to every shadow and occlusion query as they do to camera rays.

* **Soft shadows** (:func:`soft_shadow`): a ray from the surface towards the key light is
  sphere-traced through the distance; the smallest ``d / (penumbra t)`` seen along it is the
  fraction of the light that gets through (a cone test with the distance as the free radius,
  Quilez 2010). A ray that reaches the surface is in full shadow.
* **Ambient occlusion** (:func:`ambient_occlusion`): :data:`AO_SAMPLES` distance queries along
  the normal at heights ``h_j = j * delta``; open space has ``d(p + h n) = h``, an occluder makes
  it smaller. ``ao = 1 - sum_j w_j (h_j - d_j) / sum_j w_j h_j`` with ``w_j = 2^-j``.
* **Ground** (:func:`ground_height`): an analytic plane under the surface, perpendicular to the
  scene's up vector, at the surface's lowest point (found by tracing one ray up to it). It
  receives shadows and occlusion but casts none, and fades into the background with distance.
* **Shading** (:func:`shade_lit`): Lambert diffuse from a key light (with shadows) and a fill
  light, a hemisphere sky term scaled by the occlusion, and a Blinn-Phong highlight, computed in
  linear light from sRGB base colours; :func:`linear_to_srgb` encodes the result.

Cost, in distance queries per lit pixel: one shadow ray (typically 10-40 queries, at most
:data:`SHADOW_STEPS`) and :data:`AO_SAMPLES` (5) occlusion queries, on top of the camera ray.
Ground pixels pay the same. Anti-aliasing samples reuse the pixel's own shadow and occlusion
when they hit the same object (:mod:`tracer.rendering.film`).
"""

import math
from dataclasses import dataclass

import numba
import numpy as np
from numba import prange

from smoothdist.kernels import NJIT, NJIT_IR_INLINE, NJIT_PARALLEL, borrowed
from tracer.rendering.camera import box_corners
from tracer.rendering.frame import kernel_roots
from tracer.rendering.march import (NEWTON_COS, OMEGA, PLAIN_SPAN, RELAX, march_ray,
                                    nearest_object, object_lower_bound, ray_box, scene_distance,
                                    scratch, visiting_order)

__all__ = ["Lighting", "DEFAULT_COLOR", "PALETTE", "soft_shadow", "ambient_occlusion",
           "light_tasks", "light_point", "object_ids", "ground_height", "light_directions",
           "shade_lit", "shade_ground", "srgb_to_linear", "linear_to_srgb"]

#: at most this many distance queries along a shadow ray
SHADOW_STEPS = 96
#: occlusion queries along the normal
AO_SAMPLES = 5
#: a shadow ray stops once less than this fraction of the light gets through
SHADOW_CUTOFF = 2e-3
#: the kernels can loosen light queries by a slack (tolerance pruning with a bound, as the
#: march does); tried at 2e-3 of the diagonal on the bunny, it visited 20 % fewer leaves but
#: took 25 % longer than the render's own lean queries, so the renders pass 0
LIGHT_SLACK = 0.0
#: shadow rays start this far (fraction of the scene diagonal) from the surface: the first,
#: most expensive queries next to the surface are skipped (contact shadows come from the
#: occlusion term)
SHADOW_START = 2e-3
#: a shadow ray judges the light only from this many times its start distance on (acne:
#: thin dark lines where the Barnes-Hut far field switches, seen on the lit bunny at 2e-3)
SHADOW_JUDGE = 10.0

#: base colour of a single object (sRGB, 0-255): a light clay
DEFAULT_COLOR = (214, 196, 170)
#: base colours of several objects, in order (sRGB, 0-255)
PALETTE = ((214, 196, 170), (92, 142, 199), (222, 129, 92), (124, 180, 112), (200, 168, 82),
           (160, 122, 190), (98, 178, 178), (208, 112, 142))


@dataclass(frozen=True)
class Lighting:
    """Settings of the ``"lit"`` shading (scene key ``"lighting"``).

    Attributes
    ----------
    shadows : bool
        Soft shadows from the key light.
    penumbra : float
        Softness of the shadows (> 0): the light's apparent radius as a slope, ``1/k`` of the
        cone test; 0.02 is nearly hard, 0.3 very soft.
    ao : bool
        Ambient occlusion.
    ao_distance : float
        How far the occlusion looks, as a fraction of the scene's bounding-box diagonal (> 0).
    ground : bool
        A ground plane under the surface that catches shadows.
    ground_color : (3,) int
        Its colour (sRGB, 0-255).
    key : (3,) float
        Direction towards the key light in the camera frame ``(right, up, towards the
        camera)``; the fill light mirrors it left-right, lower and weaker.
    exposure : float
        Multiplies the light (> 0).
    """

    shadows: bool = True
    penumbra: float = 0.08
    ao: bool = True
    ao_distance: float = 0.06
    ground: bool = True
    ground_color: tuple = (236, 236, 236)
    key: tuple = (-0.55, 1.0, 0.75)
    exposure: float = 1.0

    def __post_init__(self):
        for name in ("penumbra", "ao_distance", "exposure"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float, np.number)) \
                    or not math.isfinite(v) or v <= 0:
                raise ValueError(f"lighting.{name} must be a finite number > 0, got {v!r}")
        check_color(self.ground_color, "lighting.ground_color")
        key = np.asarray(self.key, dtype=np.float64)
        if key.shape != (3,) or not np.isfinite(key).all() or not np.linalg.norm(key) > 0:
            raise ValueError(f"lighting.key must be a non-zero vector of 3 numbers, "
                             f"got {self.key!r}")


def check_color(color, name):
    c = np.asarray(color)
    if c.shape != (3,) or not np.issubdtype(c.dtype, np.number) or not np.isfinite(c).all() \
            or (c < 0).any() or (c > 255).any():
        raise ValueError(f"{name} must be 3 numbers in 0..255, got {color!r}")
    return tuple(float(x) for x in c)


# =============================================================================== kernels
@numba.njit(**NJIT_IR_INLINE)
def soft_shadow(sc, p, light, work):
    """Fraction of the key light reaching ``p = (px, py, pz)`` (0 in full shadow, 1 lit), the
    queries made and the leaves they visited, in the scene ``sc`` (as
    :func:`tracer.rendering.march.scene_distance` takes it). ``light``
    (:class:`tracer.rendering.frame.LightArgs`): ``L`` the unit direction towards the light,
    ``lo, hi`` the box the ray marches in, ``eps``, ``k = 1 / penumbra``, ``slack``, ``t_min``
    and ``t_judge``; ``work = (stack, dstack)``.

    The ray starts at ``t_min`` and judges the light from ``t_judge`` on (negative: the
    default, ``SHADOW_JUDGE x t_min``, for a point on the surface; a ground point passes
    ``t_min``: the surface above it is an occluder, not its own relief). Before
    that it only marches, through the surface it starts on too (a neighbouring bump of a
    point cloud's surface under a grazing light: the ray starts ``t_min`` out along the light,
    barely above the surface, and may dip into it), so that the surface's own relief next to
    the start casts no shadow on it. (A ray that ended in full shadow there drew the dark
    specks and scratches of issue 35: 36 and 420 pixels on two random clouds at 512², now 0;
    a surface still there at ``SHADOW_JUDGE x t_min`` shadows as before.)"""
    px, py, pz = p
    L, lo, hi, eps, k, delta, do_shadow, do_ao, slack, t_min, t_judge = light
    lx, ly, lz = L[0], L[1], L[2]
    t0, t1 = ray_box(px, py, pz, lx, ly, lz, lo, hi)
    if t0 > t1:
        return 1.0, 0, 0
    if t_judge < 0.0:
        t_judge = SHADOW_JUDGE * t_min
    t = max(t_min, t0)
    res = 1.0
    n = 0
    leaves = 0
    while t < t1 and n < SHADOW_STEPS:
        r = scene_distance(sc, px + t * lx, py + t * ly, pz + t * lz, work, slack)
        d = r[0]
        leaves += r[5]
        n += 1
        # d <= true distance <= d + slack: step by the lower bound (safe), judge the light by
        # the upper one (a loosened query never casts a shadow the exact one would not)
        if t >= t_judge:
            # next to the surface the distance is the surface's own (tiny, and the
            # Barnes-Hut far field makes it jump): those first steps only march
            if d + slack < eps:
                return 0.0, n, leaves
            res = min(res, k * (d + slack) / t)
            if res < SHADOW_CUTOFF:
                return 0.0, n, leaves
        t += max(abs(d), eps)   # inside the start's own relief: |d| steps out of it
    return min(1.0, res), n, leaves


@numba.njit(**NJIT_IR_INLINE)
def ambient_occlusion(sc, p, n, delta, work, slack):
    """Occlusion factor in ``[0, 1]`` (1: open) at ``p = (px, py, pz)`` with unit normal
    ``n = (nx, ny, nz)``, and the leaves visited: ``AO_SAMPLES`` distances of the scene ``sc``
    (:func:`soft_shadow`), ``delta`` (scene units) apart along ``n``."""
    px, py, pz = p
    nx, ny, nz = n
    occ = 0.0
    tot = 0.0
    w = 1.0
    leaves = 0
    for j in range(1, AO_SAMPLES + 1):
        h = j * delta
        r = scene_distance(sc, px + h * nx, py + h * ny, pz + h * nz, work, slack)
        d = r[0] + slack          # the upper bound of the true distance (see soft_shadow)
        leaves += r[5]
        occ += w * (h - min(max(d, 0.0), h))
        tot += w * h
        w *= 0.5
        if j == 1 and d >= 2.0 * AO_SAMPLES * delta:
            # open space: by the Lipschitz bound every later d_j >= h_j, no occlusion to add
            return 1.0 - occ / _ao_total(delta), leaves
    return 1.0 - occ / tot, leaves


@numba.njit(**NJIT)
def _ao_total(delta):
    tot = 0.0
    w = 1.0
    for j in range(1, AO_SAMPLES + 1):
        tot += w * j * delta
        w *= 0.5
    return tot


@numba.njit(**NJIT)
def light_tasks(tree, objs, points, depth_max, light, out, tasks):
    """Shadow and occlusion at points ``points = (P, N)``: ``P (n, 3)`` with unit normals
    ``N (n, 3)``, in the scene of ``tree`` and ``objs = (roots, params, mode, tol)``
    (:func:`tracer.rendering.march.scene_distance`'s ``sc`` without its tree).

    ``light`` (:class:`tracer.rendering.frame.LightArgs`): ``L (3,)`` the unit direction towards
    the key light, ``lo, hi`` the box the shadow rays march in, ``eps``, ``k = 1 / penumbra``,
    ``delta`` the occlusion step (scene units), ``do_shadow``, ``do_ao``, ``slack`` (scene
    units: each query may be that much below the render's own distance, tolerance pruning
    loosened as in :func:`tracer.rendering.march.scene_distance`; ``roots`` must then be an
    array and ``tol > 0``), ``t_min``, ``t_judge`` (where shadow rays start and judge the
    light, :func:`soft_shadow`). Writes ``out`` (:class:`tracer.rendering.frame.LightBuffers`):
    ``shadow (n,)``, ``ao (n,)`` (1 where not asked for) and ``work (n, 2) int64``: distance
    queries and leaves visited. Every point is
    independent (no dependence on threads or tasks): ``tasks = (ntasks, task0, task1)``, this
    call runs tasks ``task0 <= task < task1`` of ``ntasks`` strided ones (task ``t`` the points
    ``t, t + ntasks, ...``; :mod:`smoothdist.schedule`). Serial and ``nogil``, for Python
    threads (``smoothdist.schedule.run_tasks``): no ``prange`` to compile (a parallel loop
    costs numba as much again as its body)."""
    ntasks, task0, task1 = tasks
    sc = (borrowed(tree), objs[0], borrowed(objs[1]), objs[2], objs[3])
    light = borrowed(light)
    for task in range(task0, task1):
        _light_task(sc, points, depth_max, light, out, task, ntasks)


@numba.njit(**NJIT_IR_INLINE)
def _light_task(sc, points, depth_max, light, out, task, ntasks):
    """Points ``task, task + ntasks, ...`` of :func:`light_tasks`."""
    n = points[0].shape[0]
    work = scratch(depth_max)
    for i in range(task, n, ntasks):  # every ntasks-th point
        light_point(sc, points, light, out, i, work)


@numba.njit(**NJIT_IR_INLINE)
def light_point(sc, points, light, out, i, work):
    """Point ``i`` of :func:`light_tasks`, with the traversal scratch ``work = (stack,
    dstack)`` (the CPU's tasks and the GPU's threads, :mod:`tracer.rendering.gpu_render`, call
    this). Merged into its callers, with :func:`soft_shadow` and :func:`ambient_occlusion`: as
    a kernel of its own it was optimised and compiled to machine code once more in a first lit
    render (performance guide, "Cold start")."""
    P, N = points
    L, lo, hi, eps, k, delta, do_shadow, do_ao, slack, t_min, t_judge = light
    shadow, ao, counts = out
    bias = 2.0 * eps
    nx, ny, nz = N[i, 0], N[i, 1], N[i, 2]
    px = P[i, 0] + bias * nx
    py = P[i, 1] + bias * ny
    pz = P[i, 2] + bias * nz
    s = 1.0
    q = 0
    lv = 0
    if do_shadow and nx * L[0] + ny * L[1] + nz * L[2] > 0.0:
        s, q, lv = soft_shadow(sc, (px, py, pz), light, work)
    elif do_shadow:
        s = 0.0          # facing away from the light: no direct light anyway
    a = 1.0
    if do_ao:
        a, la = ambient_occlusion(sc, (px, py, pz), (nx, ny, nz), delta, work, slack)
        q += AO_SAMPLES
        lv += la
    shadow[i] = s
    ao[i] = a
    counts[i, 0] = q
    counts[i, 1] = lv


@numba.njit(**NJIT_PARALLEL)
def object_ids(tree, objs, P, depth_max, out, ntasks):
    """Index of the object nearest to each point ``P (n, 3)`` (its own distance, smallest)
    in the scene of ``tree`` and ``objs = (roots, params, mode, tol)`` (:func:`light_tasks`);
    ``ntasks`` strided tasks (:mod:`smoothdist.schedule`)."""
    n = P.shape[0]
    ntasks = max(1, min(n, ntasks))
    for task in prange(ntasks):
        roots, params, mode, tol = objs
        sc = (tree, roots, params, mode, tol)
        work = scratch(depth_max)
        for i in range(task, n, ntasks):
            best = np.inf
            arg = 0
            # nearest root box first; an object whose lower bound is not below the best distance
            # so far cannot be nearer
            first = nearest_object(sc, P[i, 0], P[i, 1], P[i, 2], 0.0)
            for j in range(roots.size):
                kk = visiting_order(j, first)
                if j > 0 and object_lower_bound(sc, kk, P[i, 0], P[i, 1], P[i, 2], 0.0) >= best:
                    continue
                d = scene_distance((tree, roots[kk:kk + 1], params[kk:kk + 1], mode, tol),
                                   P[i, 0], P[i, 1], P[i, 2], work, 0.0)[0]
                if d < best:
                    best = d
                    arg = kk
            out[i] = arg


@numba.njit(**NJIT)
def _lowest_hit(sc, starts, up, limits, depth_max):
    """Smallest height (along ``up``) at which upward rays from ``starts`` meet the surface
    of the scene ``sc`` (``limits``: :func:`tracer.rendering.march.march_ray`'s)."""
    work = scratch(depth_max)
    best = np.inf
    for i in range(starts.shape[0]):
        # march_ray's arguments typed as the camera rays' (one specialisation for both)
        pr = (starts[i, 0], starts[i, 1], starts[i, 2], up[0], up[1], up[2])
        h, t = march_ray(sc, pr, limits, (RELAX, OMEGA, 0.0, NEWTON_COS), PLAIN_SPAN, work)[:2]
        if h == 1:
            z = (starts[i, 0] + t * up[0]) * up[0] + (starts[i, 1] + t * up[1]) * up[1] \
                + (starts[i, 2] + t * up[2]) * up[2]
            best = min(best, z)
    return best


# =============================================================================== Python side
def light_directions(lighting, camera, up):
    """Unit world directions ``(key, fill)`` towards the lights, and the unit ``up``."""
    up = np.asarray(up, dtype=np.float64)
    up = up / np.linalg.norm(up)
    right = np.asarray(camera.horizontal, dtype=np.float64)
    back = -np.asarray(camera.forward, dtype=np.float64)
    # the camera's own up, made perpendicular to its view: lights keep their place in the image
    cam_up = np.asarray(camera.vertical, dtype=np.float64)
    kx, ky, kz = np.asarray(lighting.key, dtype=np.float64)
    key = kx * right + ky * cam_up + kz * back
    fill = -0.8 * kx * right + 0.35 * ky * cam_up + kz * back
    return key / np.linalg.norm(key), fill / np.linalg.norm(fill), up


def ground_height(arrays, data_vertices, up, eps, max_steps=400):
    """Height (along ``up``) of the surface's lowest point: upward rays from below the lowest
    data vertices (the ten lowest) to the surface; the smallest height where they land.

    ``arrays``: :class:`tracer.rendering.frame.SceneArrays`. Falls back to the bottom of the scene
    box (which bounds the surface) if no ray lands."""
    tree, roots, params, mode, lo, hi, depth_max, tol = arrays
    up = np.asarray(up, dtype=np.float64)
    heights = data_vertices @ up
    lowest = data_vertices[np.argsort(heights)[:10]]
    box_bottom = float((box_corners(lo, hi) @ up).min())
    starts = lowest - ((lowest @ up) - box_bottom + eps)[:, None] * up
    # the render's own kernel form of the roots: the lean path when the render takes it
    sc = (tree, kernel_roots(np.atleast_1d(roots), params, mode, tol), params, mode, tol)
    h = _lowest_hit(sc, np.ascontiguousarray(starts), up, (lo, hi, eps, max_steps), depth_max)
    return float(h) if np.isfinite(h) else box_bottom


def srgb_to_linear(c):
    """sRGB values in ``[0, 1]`` to linear light."""
    c = np.asarray(c, dtype=np.float64)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def linear_to_srgb(c):
    """Linear light (clipped to ``[0, 1]``) to sRGB values in ``[0, 1]``."""
    c = np.clip(np.asarray(c, dtype=np.float64), 0.0, 1.0)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.power(c, 1.0 / 2.4) - 0.055)


#: light intensities (linear): key, fill, sky, highlight
KEY, FILL, SKY, SPECULAR = 2.2, 0.45, 0.55, 0.35
#: Blinn-Phong exponent of the highlight
SHININESS = 48.0


def shade_lit(normals, view_dirs, base, shadow, ao, key, fill, up, exposure=1.0):
    """Linear colour of surface samples.

    Parameters
    ----------
    normals : (n, 3) float
        Unit world normals.
    view_dirs : (n, 3) float
        Unit directions of the camera rays (from the camera).
    base : (n, 3) float
        Base colours, linear.
    shadow, ao : (n,) float
        Key-light visibility and occlusion, in ``[0, 1]``.
    key, fill, up : (3,) float
        Unit directions towards the lights, and up.
    """
    # the distance's gradient points out of the surface, to the side the rays come from
    n = np.asarray(normals, dtype=np.float64)
    v = -np.asarray(view_dirs, dtype=np.float64)
    ndl = np.clip(n @ key, 0.0, None)
    ndf = np.clip(n @ fill, 0.0, None)
    sky = 0.5 + 0.5 * (n @ up)
    h = key + v
    h /= np.maximum(np.linalg.norm(h, axis=1, keepdims=True), 1e-12)
    spec = SPECULAR * np.clip((n * h).sum(1), 0.0, None) ** SHININESS * ndl * shadow
    light = KEY * ndl * shadow + FILL * ndf + SKY * (0.35 + 0.65 * sky) * ao
    return exposure * (base * light[:, None] * 0.5 + spec[:, None])


def shade_ground(base, shadow, ao, key, up, exposure=1.0):
    """Linear colour of ground samples (``base (3,)`` linear; ``shadow, ao (n,)``)."""
    ndl = max(float(key @ up), 0.0)
    light = KEY * ndl * shadow + SKY * ao
    full = KEY * ndl + SKY
    # normalised so that an unshadowed, open ground shows its own colour
    return exposure * base[None, :] * (light / full)[:, None]
