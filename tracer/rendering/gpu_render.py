"""Sphere tracing on an NVIDIA GPU: ``tracer.render(scene, device="cuda")``.

One GPU thread marches one pixel's ray with :func:`tracer.rendering.march.march_ray`, the CPU's own
kernel (numba-cuda compiles it, the scene distance and the smoothdist kernels below it as CUDA
device functions from the same Python source; see :mod:`smoothdist.cuda`), with a fixed-size
local traversal stack, and colours the pixel by its normal (:func:`normal_colour`, the
``"normals"`` shading of :func:`tracer.rendering.shading.shade_normals`). The ``"matcap"`` and
``"headlight"`` shadings are applied on the host to the normals that come back.

The cone pass runs first, one thread per ``TILE x TILE`` tile (``_cone_kernel``, the CPU's
:func:`tracer.rendering.march.tile_cone`): the tile's rays then start at its conservative
depth with the same predicted first step as on the CPU. What differs from the CPU path: no
common end depth (the CPU's ``cone_end``, marched once a ray of the tile has missed; it
only shortens misses); the same hit test, steps, Newton steps and bisection otherwise. Under
numba's CUDA simulator the images equal the CPU's bit for bit
(``tests/smoothdist/test_cuda_sim.py``); on a card, fused multiply-add may move a grazing pixel
(one of the 1080p bunnies' 6.2 million pixels in ``benchmarks/data/gpu_h100.json``).

The lit look, anti-aliasing samples (adaptive too) and transparent backgrounds (issue 49) take
the CPU's film (:func:`tracer.rendering.film.form_image`) over the GPU's centre samples, with
its two per-ray kernels on the GPU: the extra samples (``_samples_kernel``, the CPU's
:func:`tracer.rendering.march.sample_tasks`) and the shadow and occlusion rays
(``_light_kernel``, :func:`tracer.rendering.lighting.light_point`), one thread per sample
or point. What stays on the host: the film's bookkeeping (which pixels get samples, the light
interpolated between centre samples, the colours), the ground's height and, with several
objects, which object a lit point shows.
"""

import math
import sys
import time
from typing import NamedTuple

import numba
import numpy as np

from smoothdist import cuda as sdcuda
from smoothdist.kernels import NJIT
from tracer.rendering import lighting, march
from tracer.rendering.camera import camera_ray, image_size, view_coordinates
from tracer.rendering.film import form_image
from tracer.rendering.frame import (ProgressBar, RayArgs, RenderResult, camera_of,
                                    check_camera_outside, check_steps, progress_callback,
                                    scene_arrays, shade, trace_options)

__all__ = ["render_cuda", "normal_colour", "BLOCK", "trace_samples_cuda",
           "light_points_cuda"]

#: entries of each thread's traversal stack (a constant of this module: a local array's size
#: must be a compile-time constant)
STACK = sdcuda.STACK
#: threads per block of the render kernel, (columns, rows): 8 x 8 was the fastest of 16 x 8,
#: 8 x 8, 32 x 4 and 32 x 8 on an H100 and again on an H200, by 0.4-5.0 % against 16 x 8
#: (``gpu_by_block`` in ``benchmarks/data/gpu_h100.json`` and ``gpu_h200.json``)
BLOCK = (8, 8)
#: threads per block of the cone kernel (one thread per tile), as every card run launched it
CONE_BLOCK = (16, 8)
#: threads per block of the one-dimensional kernels (samples, light)
THREADS = 128
#: the parts of ``_samples_kernel``: a pixel's bounds and rays in one thread, the bounds only,
#: the rays only (one thread per ray)
WHOLE, BOUNDS, RAYS = 0, 1, 2
#: whether the film's samples run one thread per ray (a bounds launch, then a rays launch),
#: rather than one thread per pixel marching its K rays one after the other: K times the
#: threads, for the film's small batches of flagged pixels (issue 49 item 3)
SPLIT_SAMPLES = True


class GpuArgs(NamedTuple):
    """The render kernel's leading arguments (:func:`prepare`): the scene on the device and
    the march's settings."""
    data: tuple        # (tree, roots, params, cam, lo, hi, bg), device arrays and the colour
    mode: int
    tol: float
    eps: float
    max_steps: int
    relax: float
    omega: float
    newton: float


#: what the progress bar says before the first GPU render of a process: the kernels load
#: from numba-cuda's disk cache in a second, but the first run on a machine compiles them
#: (minutes, with no progress to show: ``benchmarks/data/gpu_h200_lit.json``, gpu_first_s)
FIRST_LAUNCH = ("CUDA kernels: loading them from numba-cuda's cache, or compiling them (the "
                "first run on a machine: 1-3 minutes)")

#: ``numba.cuda`` once the kernel exists (a module global: see ``smoothdist.cuda.cuda``)
cuda = None
_KERNELS = {}


@numba.njit(**NJIT)
def _channel(v):
    """``127 v + 128`` clipped to 0..255 and truncated, as
    :func:`tracer.rendering.shading.shade_normals`."""
    x = 127.0 * v + 128.0
    if x < 0.0:
        x = 0.0
    elif x > 255.0:
        x = 255.0
    return int(x)


@numba.njit(**NJIT)
def normal_colour(gx, gy, gz, cam):
    """The ``"normals"`` colour ``(r, g, b)`` of a hit with distance gradient ``g``: the unit
    gradient in the camera frame ``(g . horizontal, g . vertical, -g . forward)``
    (:func:`tracer.rendering.shading.view_normals`), ``127 n + 128`` per channel, truncated; a zero
    or non-finite gradient gives the zero normal."""
    n = math.sqrt(gx * gx + gy * gy + gz * gz)
    ux = 0.0
    uy = 0.0
    uz = 0.0
    if n > 0.0 and n < np.inf:
        ux = gx / n
        uy = gy / n
        uz = gz / n
    vx, vy, vz = view_coordinates(cam, ux, uy, uz)
    return _channel(vx), _channel(vy), _channel(vz)


def _cone_kernel(data, how, cone, cone_n):
    # one thread per TILE x TILE tile: the CPU's cone pass (march.tile_cone) into
    # ``cone[ty, tx] = (first, t_min, D, gx, gy, gz)`` and ``cone_n[ty, tx] = (evals, leaves)``;
    # ``how``: GpuArgs' scalars, ``(mode, tol, eps, max_steps, relax, omega, newton)``
    tree, roots, params, cam, lo, hi, bg = data
    mode, tol, eps, max_steps, relax, omega, newton = how
    tx, ty = cuda.grid(2)
    if ty < cone.shape[0] and tx < cone.shape[1]:
        work = (cuda.local.array(STACK, numba.int64), cuda.local.array(STACK, numba.float64))
        first, t_min, D, gx, gy, gz, ev, lv = march.tile_cone(
            (tree, roots, params, mode, tol), cam, (lo, hi, eps, max_steps),
            _tile_of(cam, ty, tx), work, relax, newton)
        cone[ty, tx, 0] = first
        cone[ty, tx, 1] = t_min
        cone[ty, tx, 2] = D
        cone[ty, tx, 3] = gx
        cone[ty, tx, 4] = gy
        cone[ty, tx, 5] = gz
        cone_n[ty, tx, 0] = ev
        cone_n[ty, tx, 1] = lv


@numba.njit(**NJIT)
def _tile_of(cam, ty, tx):
    """Pixel rectangle ``(r_lo, r_hi, c_lo, c_hi)`` of tile ``(ty, tx)`` (``march.TILE``
    square, clipped to the image)."""
    T = march.TILE
    W, H = image_size(cam)
    return ty * T, min(H, (ty + 1) * T), tx * T, min(W, (tx + 1) * T)


def _render_kernel(data, how, cone, cone_n, out, rgb):
    # ``data = (tree, roots, params, cam, lo, hi, bg)``, ``how`` (GpuArgs' scalars, ``(mode,
    # tol, eps, max_steps, relax, omega, newton)``) and ``out`` (the PixelBuffers arrays),
    # tuples: the simulator hands tuples to the kernel as they are (and top-level arrays as
    # its own wrappers, which the CPU-compiled functions it calls cannot take). ``cone``: the
    # tile kernel's results (no cone pass: ``first = -1``, ``t_min = 0``, ``D = -1``
    # everywhere). The pixel itself is march.march_pixel and march.store_pixel, as on the CPU
    tree, roots, params, cam, lo, hi, bg = data
    mode, tol, eps, max_steps, relax, omega, newton = how
    c, r = cuda.grid(2)
    if r < rgb.shape[0] and c < rgb.shape[1]:
        work = (cuda.local.array(STACK, numba.int64), cuda.local.array(STACK, numba.float64))
        ty = r // march.TILE
        tx = c // march.TILE
        tile = _tile_of(cam, ty, tx)
        seed = (cone[ty, tx, 1], np.inf, cone[ty, tx, 2], cone[ty, tx, 3], cone[ty, tx, 4],
                cone[ty, tx, 5])
        ray = (roots, params, mode, tol, cam, lo, hi, eps, max_steps)
        res = march.march_pixel(tree, ray, (relax, omega, True, newton), (r, c), tile, seed,
                                work)
        ev = 0
        lv = 0
        if (r - tile[0]) * (tile[3] - tile[2]) + c - tile[2] == int(cone[ty, tx, 0]):
            ev = cone_n[ty, tx, 0]
            lv = cone_n[ty, tx, 1]
        march.store_pixel(out, r, c, res, ev, lv)
        if res[0] == 1:
            cr, cg, cb = normal_colour(res[2], res[3], res[4], cam)
        else:
            cr = bg[0]
            cg = bg[1]
            cb = bg[2]
        rgb[r, c, 0] = cr
        rgb[r, c, 1] = cg
        rgb[r, c, 2] = cb


def _samples_kernel(data, n, part):
    # the film's extra samples: ``data = (tree, ray, samples, out, opts)`` as
    # :func:`tracer.rendering.march.sample_tasks` takes them, one tuple (see _render_kernel).
    # ``part`` WHOLE: one thread per pixel, its bounds and then its K rays (as the CPU's
    # march.sample_tasks); BOUNDS: one thread per pixel, its bounds (their evaluations parked
    # in ``steps[i, 0]``, as on the CPU); RAYS: one thread per ray (pixel ``j // K``, ray
    # ``j % K``), after a BOUNDS launch. One call site each of sample_bounds and sample_ray:
    # the device functions are inlined, and march_ray is the kernel's bulk
    tree, ray, samples, out, opts = data
    j = cuda.grid(1)
    K = samples[2].shape[0]
    work = (cuda.local.array(STACK, numba.int64), cuda.local.array(STACK, numba.float64))
    if part == RAYS:
        if j >= n * K:
            return
        i = j // K
        k0 = j - i * K
        k1 = k0 + 1
    else:
        if j >= n:
            return
        i = j
        march.sample_bounds(tree, ray, samples, out, opts, i, work)
        if part == BOUNDS:
            return
        k0 = 0
        k1 = K
    for k in range(k0, k1):
        march.sample_ray(tree, ray, samples, out, opts, i, k, work)


def _light_kernel(data, n):
    # one thread per lit point: ``data = (tree, objs, points, light, out)`` as
    # :func:`tracer.rendering.lighting.light_tasks` takes them
    tree, objs, points, light, out = data
    i = cuda.grid(1)
    if i < n:
        work = (cuda.local.array(STACK, numba.int64), cuda.local.array(STACK, numba.float64))
        lighting.light_point((tree, objs[0], objs[1], objs[2], objs[3]), points, light, out, i,
                             work)


def kernel(name="render"):
    """The ``"render"`` (one thread per pixel), ``"cone"`` (one thread per tile),
    ``"samples"`` (one per pixel of extra samples) or ``"light"`` (one per lit point) kernel
    as a CUDA kernel (compiled at its first launch)."""
    global cuda
    if not _KERNELS:
        cuda = sdcuda.cuda_module()
        _KERNELS["render"] = cuda.jit(_render_kernel, cache=True)
        _KERNELS["cone"] = cuda.jit(_cone_kernel, cache=True)
        _KERNELS["samples"] = cuda.jit(_samples_kernel, cache=True)
        _KERNELS["light"] = cuda.jit(_light_kernel, cache=True)
    return _KERNELS[name]


def _to_device(values):
    """``values`` (a tuple or NamedTuple) with its arrays on the device (the simulator: as
    they are), and the host arrays to copy back into: ``(on_device, pairs)``."""
    if sdcuda.simulated():
        return values, []
    moved = [cuda.to_device(np.ascontiguousarray(v)) if isinstance(v, np.ndarray) else v
             for v in values]
    pairs = [(v, m) for v, m in zip(values, moved) if isinstance(v, np.ndarray)]
    return type(values)(*moved) if hasattr(values, "_fields") else tuple(moved), pairs


def _root_array(roots):
    """``roots`` (an int or an array) as a ``(k,) int64`` array."""
    return np.ascontiguousarray(np.atleast_1d(roots), np.int64)


def _copy_back(pairs):
    for host, dev in pairs:
        host[...] = dev.copy_to_host()


def trace_samples_cuda(tree, ray, samples, out, opts):
    """:func:`tracer.rendering.march.sample_tasks` on the GPU: ``samples``
    (:class:`tracer.rendering.frame.SampleRays`), written into ``out``
    (:class:`tracer.rendering.frame.SampleBuffers`, host arrays) as the CPU writes them."""
    kernel()
    n = int(samples.rows.size)
    if n == 0:
        return
    # roots as the (k,) array: the general path (see prepare); CUDA types no int root
    dray, _ = _to_device(ray._replace(roots=_root_array(ray.roots)))
    dout, pairs = _to_device(out)
    dsamples, _ = _to_device(samples)
    data = (sdcuda.device_tree(tree), dray, dsamples, dout, opts)
    K = int(samples.offsets.shape[0])
    if SPLIT_SAMPLES and K > 1:
        parts = ((BOUNDS, n), (RAYS, n * K))
    else:
        parts = ((WHOLE, n),)
    with sdcuda.quiet_small_launches():
        for part, threads in parts:
            kernel("samples")[(threads + THREADS - 1) // THREADS, THREADS](data, n, part)
    _copy_back(pairs)


def light_points_cuda(tree, objs, points, light, out):
    """:func:`tracer.rendering.lighting.light_tasks` on the GPU: shadow and occlusion at
    ``points = (P (n, 3), N (n, 3))`` (unit normals) in the scene of ``tree`` and ``objs =
    (roots, params, mode, tol)``, written into ``out``
    (:class:`tracer.rendering.frame.LightBuffers`, host arrays) as the CPU writes them."""
    kernel()
    roots, params, mode, tol = objs
    n = int(points[0].shape[0])
    if n == 0:
        return
    dlight, _ = _to_device(light)
    dout, pairs = _to_device(out)
    (droots, dparams, dP, dN), _ = _to_device((_root_array(roots), params) + tuple(points))
    data = (sdcuda.device_tree(tree), (droots, dparams, mode, tol), (dP, dN), dlight, dout)
    with sdcuda.quiet_small_launches():
        kernel("light")[(n + THREADS - 1) // THREADS, THREADS](data, n)
    _copy_back(pairs)


def prepare(scene, transforms=None, relax=None, omega=None, cone=None):
    """Everything a launch needs, on the device: ``(camera, args, shape, options)`` with
    ``args`` the kernel's leading arguments (up to ``newton``), ``shape = (H, W)`` and
    ``options`` the render's :class:`~tracer.rendering.frame.TraceOptions` (``relax``,
    ``omega``, ``cone`` as :func:`tracer.render` takes them). Checks the camera as ``render``
    does."""

    cu = sdcuda.cuda_module()
    kernel()
    camera = camera_of(scene)
    arrays = scene_arrays(scene, transforms)
    tree, roots, params, mode, lo, hi, depth_max, tol = arrays
    sdcuda.check_depth(int(depth_max))
    march_ = scene.march
    check_camera_outside(scene, arrays)
    on = (lambda a: a) if sdcuda.simulated() else cu.to_device
    bg = tuple(int(v) for v in scene.film.background)
    # roots as the (k,) array: the general path of tracer.rendering.march.scene_distance (the same
    # values as the lean one that tracer.rendering.renderer.kernel_roots picks for the CPU with an
    # int root)
    data = (sdcuda.device_tree(tree), on(np.ascontiguousarray(roots, np.int64)), on(params),
            on(camera.as_array()), on(np.asarray(lo, np.float64)),
            on(np.asarray(hi, np.float64)), bg)
    options = trace_options(scene, lo, hi, relax, omega, cone)
    args = GpuArgs(data, int(mode), float(tol), float(march_.eps), int(march_.max_steps),
                   options.relax, options.omega, options.newton)
    return camera, args, (scene.film.height, scene.film.width), options


def _launch_grid(W, H, block):
    return ((W + block[0] - 1) // block[0], (H + block[1] - 1) // block[1])


def to_host(a):
    """A host copy of one of :func:`launch`'s outputs (the simulator's are host arrays)."""
    return a if isinstance(a, np.ndarray) else a.copy_to_host()


def launch(args, shape, cone=True, block=BLOCK, out=None, kernels=None):
    """Trace one frame on the device; returns the device output arrays ``(hit, tbuf, grad,
    steps, leaves, bisect, objs, rgb)`` (the launches are asynchronous). ``cone``: the tile
    kernel's cone pass first (as the CPU's ``cone``); ``block``: threads per block of the
    render kernel, (columns, rows); ``out``: the output arrays of an earlier launch of the
    same shape, to be written again (none: new ones); ``kernels``: ``{"cone": ..., "render":
    ...}``, other compilations of the two kernels to launch (``benchmarks/bench_gpu.py``'s
    variants; none: :func:`kernel`'s)."""
    kernels = kernels or {"cone": kernel("cone"), "render": kernel()}
    H, W = shape
    T = march.TILE
    nty, ntx = (H + T - 1) // T, (W + T - 1) // T
    if cone:
        cone_f = cuda.device_array((nty, ntx, 6))
        cone_n = cuda.device_array((nty, ntx, 2), dtype=np.int64)
        with sdcuda.quiet_small_launches():     # small images: a few blocks of tiles
            kernels["cone"][_launch_grid(ntx, nty, CONE_BLOCK), CONE_BLOCK](
                args.data, args[1:], cone_f, cone_n)
    else:
        none = np.zeros((nty, ntx, 6))
        none[:, :, 0] = -1.0
        none[:, :, 2] = -1.0
        cone_f = cuda.to_device(none)
        cone_n = cuda.to_device(np.zeros((nty, ntx, 2), dtype=np.int64))
    if out is None:
        # the simulator: host arrays, which the kernel's CPU-compiled functions can take
        empty = np.empty if sdcuda.simulated() else cuda.device_array
        out = (empty((H, W), dtype=np.bool_), empty((H, W)), empty((H, W, 3)),
               empty((H, W), dtype=np.int64), empty((H, W), dtype=np.int64),
               empty((H, W), dtype=np.int64), empty((H, W), dtype=np.int32),
               empty((H, W, 3), dtype=np.uint8))
    with sdcuda.quiet_small_launches():
        kernels["render"][_launch_grid(W, H, block), block](args.data, args[1:], cone_f,
                                                             cone_n, out[:7], out[7])
    return out


def render_cuda(scene, *, progress=None, transforms=None, relax=None, omega=None, cone=None):
    """:func:`tracer.render` on the GPU (its arguments, the scene's ``newton``, ``samples``
    and ``adaptive`` already applied; ``band_rows`` does not apply). Returns a
    :class:`tracer.rendering.frame.RenderResult`; ``seconds`` is the time of the launch, the
    copies back and (lit, sampled or transparent renders) the film."""
    # no card is the first thing to say (issue 49): an option the card would refuse matters
    # only where there is a card
    sdcuda.cuda_module()
    check_steps(None, relax)
    progress = progress_callback(progress, scene)
    if isinstance(progress, ProgressBar) and not _KERNELS:     # this process's first
        progress.stream.write(f"{progress.label}: {FIRST_LAUNCH}\n")
        progress.stream.flush()
    camera, args, (H, W), options = prepare(scene, transforms, relax, omega, cone)
    t0 = time.perf_counter()
    out = launch(args, (H, W), options.cone)
    hit, tbuf, grad, steps, leaves, bis, objs, rgb = (to_host(a) for a in out)
    film = scene.film
    use_film = film.samples != 1 or film.shading == "lit" or film.transparent
    alpha, spp, aovs = hit.astype(np.float32), np.ones((H, W), np.int32), {"rays": H * W}
    if use_film:
        arrays = scene_arrays(scene, transforms)
        tree, roots, params, mode, lo, hi, depth_max, tol = arrays
        kargs = RayArgs(tree, _root_array(roots), params, mode, tol, camera.as_array(), lo, hi,
                        float(scene.march.eps), int(scene.march.max_steps))
        rgb, alpha, spp, aovs = form_image(scene, camera, arrays, kargs, options,
                                           (hit, tbuf, grad, objs), gpu=sys.modules[__name__])
    seconds = time.perf_counter() - t0
    if progress is not None:
        progress(H * W, H * W, seconds)
    norm = np.linalg.norm(grad, axis=2, keepdims=True)
    normals = np.where(norm > 0, grad / np.where(norm > 0, norm, 1.0), 0.0)
    if not use_film and film.shading != "normals":
        rgb = shade(scene, camera, normals, hit)
    return RenderResult(rgb=rgb, hit=hit, depth=tbuf.astype(np.float32), normals=normals,
                        steps=steps, leaves=leaves, bisections=bis, seconds=seconds,
                        camera=camera, scene=scene, alpha=alpha, samples=spp, aovs=aovs)
