"""Render a :class:`~tracer.scenes.scene.Scene`: trace, shade, and collect per-pixel buffers.

:func:`render` and the tile scheduler (:func:`trace_tiles`); the pieces a frame is made of
(:class:`~tracer.rendering.frame.RenderResult`, :func:`~tracer.rendering.frame.scene_arrays`, ...)
live in :mod:`tracer.rendering.frame` and the thread helpers in :mod:`tracer.rendering.threads`,
below the film, the light and the GPU path that use them; import them from there.
"""

import threading
import time
from dataclasses import replace

import numpy as np

from smoothdist.cuda import check_device, cuda_module
from tracer.compiling import (ahead_running, claim_job, claim_trace, tell_children,
                              wait_ahead)
from tracer.rendering import march
from tracer.rendering.camera import image_size
from tracer.rendering.film import _gradients, _trace, form_image, sample_offsets
from tracer.rendering.frame import (PixelBuffers, RayArgs, RenderResult, camera_of,
                                    check_camera_outside, check_steps, kernel_roots,
                                    pixel_buffers, progress_callback, scene_arrays, shade,
                                    trace_options, with_overrides)
from tracer.rendering.gpu_render import render_cuda
from tracer.rendering.lighting import ground_height
from tracer.rendering.shading import load_matcap
from tracer.rendering.threads import in_bands, render_threads
from tracer.stages import stage

__all__ = ["render", "trace_tiles", "ray_args", "checked_camera", "while_waiting",
           "compile_film", "run_trace",
           "run_film", "run_normals", "run_ground", "run_samples", "CHUNKS_PER_THREAD"]


def render(scene, *, progress=None, band_rows=None, transforms=None, relax=None, omega=None,
           cone=None, newton=None, samples=None, adaptive=None, device="cpu"):
    """Trace and shade ``scene``.

    Parameters
    ----------
    scene : tracer.scenes.scene.Scene
        The scene; the result's ``scene`` is the one drawn: this one with the ``newton``,
        ``samples`` and ``adaptive`` given here (:func:`~tracer.rendering.frame.with_overrides`).
    transforms : list of (R (3, 3), t (3,)), optional
        A rigid pose per object (see :func:`~tracer.rendering.frame.scene_arrays`); the trees are
        not rebuilt.
    progress : bool, "auto", callable(done_pixels, total_pixels, elapsed_s) or None
        A callable is called a few times a second while tracing, and at the end; ``True``
        shows a text progress bar on stderr (:class:`~tracer.rendering.frame.ProgressBar`);
        ``"auto"`` the same once the render has run 3 s (``AUTO_PROGRESS_AFTER``); ``None``
        or ``False``: none. A callable with a ``waiting(elapsed_s)`` method (a ``ProgressBar``)
        is told so while nothing is traced yet: the first render compiles the kernels then.
    band_rows : int, optional
        Trace the image in bands of this many rows, one after the other (default: one band;
        the image does not depend on it when it is a multiple of ``tracer.rendering.march.TILE``).
    relax : float, optional
        Scenes with ``tol > 0``: a sphere-tracing step may under-estimate the distance by up
        to ``relax`` x the previous step (default ``tracer.rendering.march.RELAX``; 0: never).
    omega : float, optional
        Cap of the over-relaxed sphere-tracing steps, as a multiple of the distance (>= 1;
        1: plain steps; each relaxed step is checked, with a safe fallback; smooth mode only;
        default ``tracer.rendering.march.OMEGA``); see :func:`tracer.rendering.march.march_ray`.
    cone : bool, optional
        Seed each tile's rays with a conservative start depth from a cone march (default
        ``tracer.rendering.march.CONE``).
    newton : float, optional
        Newton steps along the ray once the distance is below ``newton x eps`` (at most 1 % of
        the scene box diagonal; 0: plain sphere tracing; default: the scene's ``newton``,
        ``tracer.rendering.march.NEWTON`` unless the scene file sets it); see
        :func:`tracer.rendering.march.march_ray`.
    samples : int, optional
        Anti-aliasing samples per pixel (default: the scene's ``samples``, 1); see
        :mod:`tracer.rendering.film`.
    adaptive : bool, optional
        Give the extra samples only to pixels that disagree with a neighbour (default: the
        scene's ``adaptive``).
    device : {"cpu", "cuda"}
        ``"cuda"``: trace on the GPU (:mod:`tracer.rendering.gpu_render`; the ``gpu`` extra; one
        sample per pixel, not the ``"lit"`` shading; ``band_rows`` does not apply).

    Raises
    ------
    RenderError
        When the camera is inside the surface (distance <= eps at the camera).
    """
    on_card = check_device(device) == "cuda"
    if on_card:
        cuda_module()       # no card is the first thing to say (issue 49)
    check_steps(newton, relax)
    scene = with_overrides(scene, newton, samples, adaptive)
    if on_card:
        return render_cuda(scene, progress=progress, transforms=transforms, relax=relax,
                           omega=omega, cone=cone)
    progress = progress_callback(progress, scene)
    camera = camera_of(scene)
    arrays = scene_arrays(scene, transforms)
    tree, roots, params, mode, lo, hi, depth_max, tol = arrays
    film = scene.film
    H, W = film.height, film.width
    args = ray_args(scene, camera, arrays)
    options = trace_options(scene, lo, hi, relax, omega, cone)
    band = band_rows or H
    pending = checked_camera(scene, arrays, args, options, (0, min(band, H)))
    hit, tbuf, grad, steps, leaves, bis, objs = pixel_buffers(H, W)
    t0 = time.perf_counter()
    # a film after the trace (light, samples, RGBA): the trace is the bar's first
    # FILM_SHARE-less part and the film the rest, so that it reaches 100 % at the end
    plain = film.samples == 1 and film.shading != "lit" and not film.transparent
    share = 1.0 if plain else 1.0 - FILM_SHARE
    with stage("trace", "tracing"):
        if pending is not None:     # the child compiles the trace kernel: the bar says so
            while_waiting(pending, progress, H * W, t0)
        for r0 in range(0, H, band):
            r1 = min(H, r0 + band)
            report = None
            if progress is not None:
                def report(done, r0=r0):
                    _report(progress, done and int(share * (r0 * W + done)), H * W,
                            time.perf_counter() - t0)
            trace_tiles(args, r0, r1, depth_max, (hit, tbuf, grad, steps, leaves, bis, objs),
                        options, report)
    normals = np.empty_like(grad)

    def unit(r0, r1):
        g = grad[r0:r1]
        norm = np.linalg.norm(g, axis=2, keepdims=True)
        normals[r0:r1] = np.where(norm > 0, g / np.where(norm > 0, norm, 1.0), 0.0)

    if plain:
        in_bands(unit, H)
        seconds = time.perf_counter() - t0
        rgb = np.empty((H, W, 3), dtype=np.uint8)
        matcap = load_matcap(film.matcap) if film.shading == "matcap" else None

        def colour(r0, r1):
            rgb[r0:r1] = shade(scene, camera, normals[r0:r1], hit[r0:r1], matcap)

        in_bands(colour, H)
        alpha, spp, aovs = hit.astype(np.float32), np.ones((H, W), np.int32), {"rays": H * W}
    else:
        with stage("light", "lighting and sampling"):
            rgb, alpha, spp, aovs = form_image(scene, camera, arrays, args, options,
                                               (hit, tbuf, grad, objs),
                                               progress=_film_report(progress, share, H * W, t0))
        in_bands(unit, H)       # after the film: a lit render's normals are its shading's
        seconds = time.perf_counter() - t0
    depth = tbuf.astype(np.float32)
    return RenderResult(rgb=rgb, hit=hit, depth=depth, normals=normals, steps=steps,
                        leaves=leaves, bisections=bis, seconds=seconds, camera=camera,
                        scene=scene, alpha=alpha, samples=spp, aovs=aovs)


def checked_camera(scene, arrays, args, options, rows):
    """:func:`~tracer.rendering.frame.check_camera_outside` of a render (``args``: its
    :func:`ray_args`, ``options`` its trace options, ``rows = (row0, row1)`` its first band),
    with a compile-ahead child (``tracer.scenes.compile_ahead``) at work, which compiles the
    scene's distance first (the camera check loads it). Then one of the two compiles the trace
    kernel and the other the film's (:func:`tracer.compiling.claim_trace`: the child when it
    has compiled the distance before this process gets here):

    * here: the trace's helpers that do without the scene's distance compile while the child
      compiles that distance; after the camera check, the march (``march.compile_march``),
      which the child's ground probe and samples' kernel load in turn;
    * in the child: this process compiles the film's kernels (:func:`compile_film`) meanwhile
      and waits for the trace kernel; the function that does that is returned (None
      otherwise), for the render to run under its progress bar (:func:`while_waiting`)."""
    ahead = ahead_running()
    here = claim_trace()
    if ahead and here:
        march.compile_helpers(args.march, rows, options)
    wait_ahead("distance")
    check_camera_outside(scene, arrays)
    if ahead and here:
        march.compile_march(arrays.tree, args.march, arrays.depth_max, options)
        tell_children("march")
    elif ahead:
        film = scene.film
        with_film = film.samples > 1 or film.shading == "lit" or film.transparent

        def pending():
            if with_film:
                compile_film(scene, arrays)
            wait_ahead("trace")

        return pending
    return None


def while_waiting(job, progress, total, t0):
    """Run ``job()`` (compiling, or waiting for a child that compiles) in a thread while this
    one reports to ``progress`` that nothing is done yet, as :func:`trace_tiles` does while its
    first chunk waits for its kernel (the bar shows that numba compiles); ``total`` pixels,
    ``t0`` the render's ``time.perf_counter()``. Without ``progress``, just ``job()``."""
    if progress is None:
        job()
        return
    failed = []

    def run():
        try:
            job()
        except BaseException as exc:   # re-raised in the calling thread
            failed.append(exc)

    worker = threading.Thread(target=run, daemon=True)
    worker.start()
    while worker.is_alive():
        _report(progress, 0, total, time.perf_counter() - t0)
        worker.join(REPORT_SECONDS)
    if failed:
        raise failed[0]


def compile_film(scene, arrays):
    """Compile the film's kernels of a render of ``scene`` (its shading normals', light's and
    ground probe's; ``arrays``: its :func:`~tracer.rendering.frame.scene_arrays`) by running
    them on made-up hits of an 8 x 8 image of it (:func:`run_film`, :func:`run_ground`), the
    same types as the render's; then the samples' kernel of a render of several samples per
    pixel (:func:`run_samples`) unless the child has taken it. A first render does this while
    its compile-ahead child compiles the trace kernel (:func:`checked_camera`); the probe and
    the samples march with ``march_ray``, which the child compiles first."""
    small = replace(scene, width=8, height=8, samples=1, adaptive=False,
                    lighting=replace(scene.film.lighting, ground=False))
    run_film(small, arrays)
    if scene.film.shading == "lit":
        wait_ahead("march")
        run_ground(small, arrays)
    if scene.film.samples > 1 and claim_job("samples"):
        wait_ahead("march")
        run_samples(small, arrays)


def run_trace(scene, arrays=None, said=print):
    """Compile the trace of ``scene`` (``arrays``: its
    :func:`~tracer.rendering.frame.scene_arrays`, made here when None): the march
    (``march.compile_march``), then ``said("march")``, then the trace kernel, on its whole
    image (a compile-ahead child's tiny scene, ``tracer.scenes.compile_ahead``)."""
    arrays = scene_arrays(scene) if arrays is None else arrays
    camera = camera_of(scene)
    args = ray_args(scene, camera, arrays)
    options = trace_options(scene, arrays.lo, arrays.hi)
    march.compile_march(arrays.tree, args.march, arrays.depth_max, options)
    said("march")
    H, W = scene.film.height, scene.film.width
    trace_tiles(args, 0, H, arrays.depth_max, pixel_buffers(H, W), options)


def run_film(scene, arrays=None):
    """The film of ``scene`` on made-up hits (a 4 x 4 block of the image): the kernels of
    :func:`tracer.rendering.film.form_image` compiled for ``scene``'s types (``arrays``: its
    :func:`~tracer.rendering.frame.scene_arrays`, made here when None)."""
    camera = camera_of(scene)
    arrays = scene_arrays(scene) if arrays is None else arrays
    hit, tbuf, grad, steps, leaves, bis, objs = pixel_buffers(scene.film.height,
                                                              scene.film.width)
    hit[2:6, 2:6] = True
    tbuf[hit] = 5.0
    grad[hit] = (0.0, 0.0, 1.0)
    objs[hit] = 0
    form_image(scene, camera, arrays, ray_args(scene, camera, arrays),
               trace_options(scene, arrays.lo, arrays.hi), (hit, tbuf, grad, objs))


def run_normals(scene, arrays=None):
    """The shading normals' kernel (:func:`tracer.rendering.march.gradient_tasks`, through
    ``tracer.rendering.film._gradients``) compiled for ``scene``'s types, on four rays
    (``arrays`` as in :func:`run_film`)."""
    camera = camera_of(scene)
    arrays = scene_arrays(scene) if arrays is None else arrays
    _gradients(ray_args(scene, camera, arrays), arrays.depth_max, np.arange(4, dtype=np.int64),
               scene.film.width, np.zeros((1, 2)), np.full(4, 5.0))


def run_ground(scene, arrays=None):
    """The ground probe (:func:`tracer.rendering.lighting.ground_height`) compiled for
    ``scene``'s types, from the first vertices of its objects (``arrays`` as in
    :func:`run_film`)."""
    arrays = scene_arrays(scene) if arrays is None else arrays
    verts = np.concatenate([o.field.mesh.V[:4] for o in scene.objects])
    ground_height(arrays, verts, np.array([0.0, 1.0, 0.0]), scene.march.eps)


def run_samples(scene, arrays=None):
    """The anti-aliasing samples' kernel (:func:`tracer.rendering.march.sample_tasks`, through
    ``tracer.rendering.film._trace``) compiled for ``scene``'s types, on two rays (``arrays``
    as in :func:`run_film`)."""
    camera = camera_of(scene)
    arrays = scene_arrays(scene) if arrays is None else arrays
    _trace(ray_args(scene, camera, arrays), arrays.depth_max,
           trace_options(scene, arrays.lo, arrays.hi), np.arange(2, dtype=np.int64),
           scene.film.width, sample_offsets(2)[1:])


def ray_args(scene, camera, arrays):
    """The march kernels' :class:`~tracer.rendering.frame.RayArgs` of a render of ``scene``
    with ``camera`` and ``arrays`` (:func:`~tracer.rendering.frame.scene_arrays`)."""
    tree, roots, params, mode, lo, hi, depth_max, tol = arrays
    return RayArgs(tree, kernel_roots(roots, params, mode, tol), params, mode, tol,
                   camera.as_array(), lo, hi, float(scene.march.eps),
                   int(scene.march.max_steps))


#: the share of a render's progress bar given to its film (light, samples) when it has one
FILM_SHARE = 0.5


def _film_report(progress, share, total, t0):
    """The film's ``report(fraction)``: the bar from ``share`` of ``total`` to all of it
    (None without a progress display)."""
    if progress is None:
        return None
    return lambda fraction: _report(progress, int(total * (share + (1.0 - share) * fraction)),
                                    total, time.perf_counter() - t0)


def _report(progress, done, total, elapsed):
    """``progress(done, total, elapsed)`` once something is done (a callable sees ``done > 0``
    only); before that ``progress.waiting(elapsed)`` where it has one (a ProgressBar: the first
    render's tiles wait for numba to compile their kernel)."""
    if done:
        progress(done, total, elapsed)
    elif hasattr(progress, "waiting"):
        progress.waiting(elapsed)


#: a render's tiles are taken by the threads in chunks of ``1 / CHUNKS_PER_THREAD`` of a
#: thread's share (at least one tile). The chunks follow the scattered tile order of
#: ``tracer.rendering.march.render_tiles``, so each is a sample of the whole image and costs about
#: the same; a thread that drew expensive tiles takes fewer chunks. Each chunk is one kernel call
#: (8 us of dispatch under the GIL, serial): chunks of 4 tiles gave a 1080p frame 32,400 calls
#: (0.25 s serial); 64 chunks per thread leave at most 1/64 of a share idle at the end
CHUNKS_PER_THREAD = 64
#: seconds between progress reports while tracing
REPORT_SECONDS = 0.25


def trace_tiles(args, row0, row1, depth_max, outputs, options, report=None, threads=None):
    """Trace image rows ``row0 <= r < row1`` into ``outputs``.

    ``args`` (:class:`~tracer.rendering.frame.RayArgs`) and
    ``outputs`` (:class:`~tracer.rendering.frame.PixelBuffers`, or the same arrays in a tuple) as
    for :func:`tracer.rendering.march.render_tiles`, ``options``
    (:class:`~tracer.rendering.frame.TraceOptions`). ``threads`` Python threads (default
    :func:`~tracer.rendering.threads.render_threads`) take chunks of tiles
    (:data:`CHUNKS_PER_THREAD`) from a shared counter and trace them with
    the serial, GIL-free kernel :func:`tracer.rendering.march.render_tiles`, so that a thread that
    drew cheap tiles takes more; every tile is traced by one thread start to finish, so the
    result does not depend on the number of threads or the chunking. ``report(done_pixels)``
    is called from the calling thread a few times a second (with 0 while no chunk is done: the
    first one waits for its kernel to compile) and at the end. Ctrl-C (KeyboardInterrupt)
    stops the workers after their current chunk and is re-raised.
    """
    W = image_size.py_func(args.cam)[0]     # in Python: nothing to compile
    outputs = PixelBuffers(*outputs)
    n = -(-W // march.TILE) * -(-(row1 - row0) // march.TILE)
    threads = max(1, min(threads or render_threads(), n))
    chunk = max(1, n // (CHUNKS_PER_THREAD * threads))
    pixels = W * (row1 - row0)
    lock = threading.Lock()
    state = {"next": 0, "done": 0, "error": None, "stop": False}

    def work():
        try:
            while True:
                with lock:
                    j = state["next"]
                    if j >= n or state["stop"]:
                        return
                    state["next"] = j + chunk
                march.render_tiles(args.tree, args.march, (row0, row1), depth_max, outputs,
                                   options, j, j + chunk)
                with lock:
                    state["done"] += min(chunk, n - j)
        except BaseException as exc:  # handed to the calling thread
            with lock:
                state["error"] = exc
                state["stop"] = True

    workers = [threading.Thread(target=work, name=f"trace-{i}", daemon=True)
               for i in range(threads)]
    try:
        for t in workers:
            t.start()
        for t in workers:
            while t.is_alive():
                t.join(REPORT_SECONDS)
                if report is not None and t.is_alive():
                    report(pixels * state["done"] // n)
    except BaseException:
        with lock:
            state["stop"] = True
        for t in workers:
            t.join()
        raise
    if state["error"] is not None:
        raise state["error"]
    if report is not None:
        report(pixels)
