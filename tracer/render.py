"""Render a :class:`~tracer.scene.Scene`: trace, shade, and collect per-pixel buffers."""

import math
import os
import sys
import threading
import time
from typing import NamedTuple

import numpy as np

from smoothdist.kernels import DEFAULT_TOL, PARALLEL, concatenate_trees
from tracer import march
from tracer.camera import box_corners, look_at
from tracer.shading import (load_matcap, shade_headlight, shade_matcap, shade_normals,
                            view_normals)
from tracer.errors import RenderError  # noqa: F401  (defined there; imported from here too)

__all__ = ["render", "RenderResult", "RenderError", "camera_of", "distance_at_camera",
           "scene_arrays", "SceneArrays", "RayArgs", "TraceOptions", "render_threads",
           "ProgressBar"]


class RenderResult(NamedTuple):
    """Everything one render produces. Images are ``(H, W, ...)``, row 0 at the top.

    Attributes
    ----------
    rgb : (H, W, 3) uint8
    hit : (H, W) bool
    depth : (H, W) float32
        Ray parameter ``t`` at the hit (scene units; rays are unit length), NaN on misses.
    normals : (H, W, 3) float64
        Unit world-space gradient of the distance at the hit (0 on misses).
    steps, leaves, bisections : (H, W) int64
        Distance evaluations, leaves visited (summed over the ray) and negative-band
        bisections per pixel.
    seconds : float
        Wall time of the tracing (shading excluded).
    camera : tracer.camera.Camera
    scene : tracer.scene.Scene or None
        The scene rendered (its objects hold the alpha and alpha_U used).
    alpha : (H, W) float32
        Coverage: the fraction of the pixel's samples that hit the surface (with a
        transparent ground, its shadow). ``depth``, ``normals`` and ``hit`` are those of the
        pixel's centre sample.
    samples : (H, W) int32
        Samples traced per pixel (1 everywhere without anti-aliasing).
    aovs : dict
        Further images of the centre samples, for the ``"lit"`` shading: ``shadow`` and
        ``ao`` (0-1), ``object`` (index, -1 on misses), ``ground`` (bool); and the counts
        ``rays`` and ``light_queries``.
    """

    rgb: np.ndarray
    hit: np.ndarray
    depth: np.ndarray
    normals: np.ndarray
    steps: np.ndarray
    leaves: np.ndarray
    bisections: np.ndarray
    seconds: float
    camera: object
    scene: object = None
    alpha: np.ndarray = None
    samples: np.ndarray = None
    aovs: dict = None

    def save(self, path, *, overwrite=True):
        """Write the image as PNG (``.png``), or the depth ``(H, W)`` float32 (NaN on misses)
        or the normals ``(H, W, 3)`` float32 as ``.npy`` (``*depth*.npy`` / ``*normal*.npy``
        by name), atomically. Returns the path."""
        from tracer.image import save_npy, save_png

        name = str(path).lower()
        if name.endswith(".png"):
            return save_png(path, self.rgba if self.transparent else self.rgb,
                            overwrite=overwrite)
        if name.endswith(".npy") and "normal" in os.path.basename(name):
            return save_npy(path, self.normals.astype(np.float32), overwrite=overwrite)
        if name.endswith(".npy"):
            return save_npy(path, self.depth, overwrite=overwrite)
        raise ValueError(f"save: path must end in .png or .npy, got {path}")

    @property
    def rgba(self):
        """``(H, W, 4) uint8``: the image with its coverage as alpha."""
        a = np.ones(self.hit.shape, np.float32) if self.alpha is None else self.alpha
        return np.dstack([self.rgb, np.round(255.0 * a).astype(np.uint8)])

    @property
    def transparent(self):
        """Whether the scene asked for a transparent background (PNGs are then RGBA)."""
        return bool(getattr(self.scene, "transparent", False))

    def _repr_png_(self):
        """The image as PNG bytes: a render shows itself in Jupyter."""
        import io

        from PIL import Image

        buf = io.BytesIO()
        Image.fromarray(np.ascontiguousarray(self.rgba if self.transparent else self.rgb)).save(
            buf, format="PNG")
        return buf.getvalue()

    def summary(self):
        """Dict of scalar statistics: size, seconds, hits, mean steps and leaves per pixel."""
        H, W = self.hit.shape
        return {"width": W, "height": H, "seconds": round(self.seconds, 4),
                "hits": int(self.hit.sum()), "hit_fraction": float(self.hit.mean()),
                "mean_steps": float(self.steps.mean()), "mean_leaves": float(self.leaves.mean()),
                "bisections": int((self.bisections > 0).sum())}


class RayArgs(NamedTuple):
    """The leading arguments of the march kernels (:func:`tracer.march.render_tiles`,
    :func:`tracer.march.sample_tasks`, ...), in their order: a render passes them on with
    ``*args``."""

    tree: object
    #: the kernel form of the roots (:func:`kernel_roots`: an int on the lean path)
    roots: object
    params: np.ndarray
    mode: int
    tol: float
    #: ``tracer.camera.Camera.as_array()``
    cam: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    eps: float
    max_steps: int


class TraceOptions(NamedTuple):
    """The march kernels' trailing options (see :func:`render`)."""

    relax: float
    omega: float
    cone: bool
    newton: float


class SceneArrays(NamedTuple):
    """A scene as the march kernels take it (:func:`scene_arrays`).

    The kernels' leading arguments are ``tree, roots, params, mode, tol`` (see
    :mod:`tracer.march`). ``tol`` comes last here so that positions 0-6 are those of the
    7-tuple this used to be (``[4:6]`` is still ``lo, hi``).

    tree : smoothdist.kernels.TreeData
        The objects' trees, concatenated into one forest when there are several.
    roots : (k,) int64
        Root node of each object.
    params : (k, tracer.march.P_COLUMNS) or (k, tracer.march.P_COLUMNS_POSED) float64
        The per-object parameter table, columns ``tracer.march.P_*``.
    mode : int
        ``tracer.march.MODE_SMOOTH`` or ``MODE_EXACT``.
    lo, hi : (3,) float64
        The grown scene box the rays march in.
    depth_max : int
        Depth of the forest (scratch stacks hold ``depth_max + 4`` entries).
    tol : float
        The scene's tolerance-controlled pruning (0 = off), one scalar for all objects.
    """

    tree: object
    roots: np.ndarray
    params: np.ndarray
    mode: int
    lo: np.ndarray
    hi: np.ndarray
    depth_max: int
    tol: float


def scene_arrays(scene, transforms=None):
    """The :class:`SceneArrays` ``(tree, roots, params, mode, lo, hi, depth_max, tol)`` for the
    march kernels.

    The box ``lo..hi`` is the data's bounding box grown by the largest possible isosurface
    inflation (``log(A^S N) / alpha`` plus the smooth offset per object; the offset in exact
    mode) plus twice ``eps``. ``params[:, P_OFFSET]`` holds each object's offset in the
    scene's mode (:func:`object_level`).
    ``transforms`` (optional): per object a rigid pose ``(R (3, 3), t (3,))``; object ``k`` is
    drawn at ``R_k x + t_k`` (``params`` gets the 12 pose columns ``P_R``, ``P_T`` of
    :mod:`tracer.march`, and the box is the union of the posed, grown object boxes).
    """
    trees = [o.field.tree for o in scene.objects]
    params = np.empty((len(scene.objects), march.P_COLUMNS))
    columns = [march.P_ALPHA, march.P_BETA, march.P_S, march.P_WGS, march.P_OFFSET]
    margin = 0.0
    for k, o in enumerate(scene.objects):
        alpha, beta, S, wgs = o.field.kernel_args(o.alpha, o.beta, o.alpha_u, scene.gradient)
        level = object_level(o, scene.mode)
        params[k, columns] = (alpha, beta, S, wgs, level)
        if scene.mode == "exact":
            margin = max(margin, level)
        else:
            margin = max(margin, o.field.inflation(alpha, o.alpha_u) + level)
    if scene.mode == "smooth" and len(trees) > 1:
        a = params[:, march.P_ALPHA].max()
        margin += np.log(len(trees)) / a
    tol = float(getattr(scene, "tol", DEFAULT_TOL))
    lo, hi = scene.bounds
    grow = margin + 2 * scene.eps + 1e-9 * scene.diagonal
    mode = march.MODE_EXACT if scene.mode == "exact" else march.MODE_SMOOTH
    tree, roots = concatenate_trees(trees) if len(trees) > 1 else (trees[0], np.zeros(1, np.int64))
    if transforms is not None:
        params, lo, hi = _posed(scene, transforms, params, grow)
        return SceneArrays(tree, roots, params, mode, lo, hi, tree.depth, tol)
    return SceneArrays(tree, roots, params, mode, lo - grow, hi + grow, tree.depth, tol)


def object_level(obj, mode):
    """The offset ``c`` an object's surface is drawn at (``d - c = 0`` exact, ``d_hat - c = 0``
    smooth; :meth:`tracer.scene.SceneObject.level`), checked: finite and ``>= 0``."""
    c = float(obj.level(mode))
    if not (math.isfinite(c) and c >= 0.0):
        raise ValueError(f"{obj.name}: offset must be a finite number >= 0, got {c}")
    return c


def _posed(scene, transforms, params, grow):
    """``params`` with the pose columns ``P_R``, ``P_T`` filled in, and the world box of the
    posed, grown objects."""
    if len(transforms) != len(scene.objects):
        raise ValueError(f"{len(transforms)} transforms for {len(scene.objects)} objects")
    posed = np.empty((params.shape[0], march.P_COLUMNS_POSED))
    posed[:, :march.P_COLUMNS] = params
    los, his = [], []
    for k, (o, (R, t)) in enumerate(zip(scene.objects, transforms)):
        R = np.asarray(R, dtype=np.float64).reshape(3, 3)
        t = np.asarray(t, dtype=np.float64).reshape(3)
        if not (np.isfinite(R).all() and np.isfinite(t).all()) or \
                not np.allclose(R @ R.T, np.eye(3), atol=1e-6) or np.linalg.det(R) <= 0:
            raise ValueError("each transform needs a finite rotation matrix R and translation t")
        posed[k, march.P_R:march.P_R + 9] = R.ravel()
        posed[k, march.P_T:march.P_T + 3] = t
        lo, hi = o.field.bounds
        world = box_corners(lo - grow, hi + grow) @ R.T + t
        los.append(world.min(axis=0))
        his.append(world.max(axis=0))
    return posed, np.min(los, axis=0), np.max(his, axis=0)


def kernel_roots(roots, params, mode, tol):
    """The ``roots`` argument for :mod:`tracer.march`: one unposed object in smooth mode
    without tolerance pruning (``tol`` 0) is passed as its root node (an int), which selects
    the kernels' lean path (:func:`tracer.march.scene_distance`; same values, far less code
    to compile); anything else as the ``(k,)`` array."""
    if (mode == march.MODE_SMOOTH and roots.size == 1 and params.shape[1] == march.P_COLUMNS
            and not tol > 0.0):
        return int(roots[0])
    return roots


def camera_of(scene):
    """The scene's :class:`~tracer.camera.Camera` (validated)."""
    return look_at(scene.camera_origin, scene.camera_dest, scene.camera_up, scene.width,
                   scene.height)


def distance_at_camera(scene, arrays=None):
    """Scene distance at the camera origin (> 0 when the camera is outside the surface)."""
    tree, roots, params, mode, lo, hi, depth_max, tol = arrays or scene_arrays(scene)
    o = scene.camera_origin
    return float(march.distance_at(tree, kernel_roots(roots, params, mode, tol), params, mode,
                                   tol, float(o[0]), float(o[1]), float(o[2]), depth_max))


def _pixel_buffers(H, W):
    """The tracing outputs ``(hit, tbuf, grad, steps, leaves, bisect, objs)`` of an ``H x W``
    image, cleared (see :func:`trace_tiles`)."""
    return (np.zeros((H, W), dtype=np.bool_), np.full((H, W), np.nan), np.zeros((H, W, 3)),
            np.zeros((H, W), dtype=np.int64), np.zeros((H, W), dtype=np.int64),
            np.zeros((H, W), dtype=np.int64), np.full((H, W), -1, dtype=np.int32))


def render(scene, *, progress=None, band_rows=None, transforms=None, relax=None, omega=None,
           cone=None, newton=None, samples=None, adaptive=None, device="cpu"):
    """Trace and shade ``scene``.

    Parameters
    ----------
    scene : tracer.scene.Scene
    transforms : list of (R (3, 3), t (3,)), optional
        A rigid pose per object (see :func:`scene_arrays`); the trees are not rebuilt.
    progress : bool, callable(done_pixels, total_pixels, elapsed_s) or None
        A callable is called a few times a second while tracing, and at the end; ``True``
        shows a text progress bar on stderr (:class:`ProgressBar`); ``None`` or ``False``:
        none.
    band_rows : int, optional
        Trace the image in bands of this many rows, one after the other (default: one band;
        the image does not depend on it when it is a multiple of ``tracer.march.TILE``).
    relax : float, optional
        Scenes with ``tol > 0``: a sphere-tracing step may under-estimate the distance by up
        to ``relax`` x the previous step (default ``tracer.march.RELAX``; 0: never).
    omega : float, optional
        Cap of the over-relaxed sphere-tracing steps, as a multiple of the distance (>= 1;
        1: plain steps; each relaxed step is checked, with a safe fallback; smooth mode only;
        default ``tracer.march.OMEGA``); see :func:`tracer.march.march_ray`.
    cone : bool, optional
        Seed each tile's rays with a conservative start depth from a cone march (default
        ``tracer.march.CONE``).
    newton : float, optional
        Newton steps along the ray once the distance is below ``newton x eps`` (at most 1 % of
        the scene box diagonal; 0: plain sphere tracing; default: the scene's ``newton``,
        ``tracer.march.NEWTON`` unless the scene file sets it); see
        :func:`tracer.march.march_ray`.
    samples : int, optional
        Anti-aliasing samples per pixel (default: the scene's ``samples``, 1); see
        :mod:`tracer.film`.
    adaptive : bool, optional
        Give the extra samples only to pixels that disagree with a neighbour (default: the
        scene's ``adaptive``).
    device : {"cpu", "cuda"}
        ``"cuda"``: trace on the GPU (:mod:`tracer.gpu_render`; the ``gpu`` extra; one sample
        per pixel, not the ``"lit"`` shading; ``cone`` and ``band_rows`` do not apply).

    Raises
    ------
    RenderError
        When the camera is inside the surface (distance <= eps at the camera).
    """
    from smoothdist.cuda import check_device

    if check_device(device) == "cuda":
        from tracer.gpu_render import render_cuda

        return render_cuda(scene, progress=progress, transforms=transforms, relax=relax,
                           omega=omega, newton=newton, samples=samples, adaptive=adaptive)
    for name, value in (("newton", newton), ("relax", relax)):
        if value is not None and not (isinstance(value, (int, float, np.number))
                                      and not isinstance(value, bool)
                                      and math.isfinite(value) and value >= 0):
            raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
    progress = _progress_callback(progress, scene)
    camera = camera_of(scene)
    arrays = scene_arrays(scene, transforms)
    tree, roots, params, mode, lo, hi, depth_max, tol = arrays
    d0 = distance_at_camera(scene, arrays)
    if not d0 > scene.eps:
        raise RenderError(f"the camera at {np.round(scene.camera_origin, 6).tolist()} is inside "
                          f"the surface (distance there {d0:.4g} <= eps {scene.eps:.3g}); move "
                          "camera.origin outside or lower alpha's blur")
    H, W = scene.height, scene.width
    hit, tbuf, grad, steps, leaves, bis, objs = _pixel_buffers(H, W)
    cam = camera.as_array()
    args = RayArgs(tree, kernel_roots(roots, params, mode, tol), params, mode, tol, cam, lo, hi,
                   float(scene.eps), int(scene.max_steps))
    options = TraceOptions(
        float(march.RELAX if relax is None else relax),
        float(march.OMEGA if omega is None else max(1.0, float(omega))),
        bool(march.CONE if cone is None else cone),
        march.newton_distance(scene.eps, lo, hi,
                              max(0.0, float(scene.newton if newton is None else newton))))
    band = band_rows or H
    t0 = time.perf_counter()
    for r0 in range(0, H, band):
        r1 = min(H, r0 + band)
        report = None
        if progress is not None:
            def report(done, r0=r0):
                progress(r0 * W + done, H * W, time.perf_counter() - t0)
        trace_tiles(args, r0, r1, depth_max, (hit, tbuf, grad, steps, leaves, bis, objs),
                    options, report)
    normals = np.empty_like(grad)

    def unit(r0, r1):
        g = grad[r0:r1]
        norm = np.linalg.norm(g, axis=2, keepdims=True)
        normals[r0:r1] = np.where(norm > 0, g / np.where(norm > 0, norm, 1.0), 0.0)

    in_bands(unit, H)
    samples = _samples(scene.samples if samples is None else samples)
    adaptive = bool(scene.adaptive if adaptive is None else adaptive)
    if samples == 1 and scene.shading != "lit" and not scene.transparent:
        seconds = time.perf_counter() - t0
        rgb = np.empty((H, W, 3), dtype=np.uint8)
        matcap = load_matcap(scene.matcap) if scene.shading == "matcap" else None

        def colour(r0, r1):
            rgb[r0:r1] = shade(scene, camera, normals[r0:r1], hit[r0:r1], matcap)

        in_bands(colour, H)
        alpha, spp, aovs = hit.astype(np.float32), np.ones((H, W), np.int32), {"rays": H * W}
    else:
        from tracer.film import form_image

        rgb, alpha, spp, aovs = form_image(scene, camera, arrays, args, options,
                                           (hit, tbuf, grad, objs), samples, adaptive)
        seconds = time.perf_counter() - t0
    depth = tbuf.astype(np.float32)
    return RenderResult(rgb=rgb, hit=hit, depth=depth, normals=normals, steps=steps,
                        leaves=leaves, bisections=bis, seconds=seconds, camera=camera,
                        scene=scene, alpha=alpha, samples=spp, aovs=aovs)


def _samples(value):
    from tracer.film import MAX_SAMPLES

    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) \
            or not 1 <= value <= MAX_SAMPLES:
        raise ValueError(f"samples must be an integer from 1 to {MAX_SAMPLES}, got {value!r}")
    return int(value)


def _progress_callback(progress, scene):
    """``render``'s ``progress`` argument as a callable or None (see :func:`render`)."""
    if progress is None or progress is False:
        return None
    if progress is True:
        return ProgressBar(f"render {getattr(scene, 'name', '') or 'scene'}", min_seconds=0.0)
    if callable(progress):
        return progress
    raise TypeError(f"progress must be True, False, None or a callable(done, total, "
                    f"elapsed_s), got {progress!r}")


#: a render's tiles are taken by the threads in chunks of ``1 / CHUNKS_PER_THREAD`` of a
#: thread's share (at least one tile). The chunks follow the scattered tile order of
#: ``tracer.march.render_rows``, so each is a sample of the whole image and costs about the
#: same; a thread that drew expensive tiles takes fewer chunks. Each chunk is one kernel call
#: (8 us of dispatch under the GIL, serial): chunks of 4 tiles gave a 1080p frame 32,400 calls
#: (0.25 s serial); 64 chunks per thread leave at most 1/64 of a share idle at the end
CHUNKS_PER_THREAD = 64
#: seconds between progress reports while tracing
REPORT_SECONDS = 0.25


def render_threads():
    """Threads that trace a render: numba's thread count (``numba.set_num_threads``,
    ``tracer render --threads``), 1 with ``SMOOTHDIST_PARALLEL=0``."""
    import numba

    return numba.get_num_threads() if PARALLEL else 1


def trace_tiles(args, row0, row1, depth_max, outputs, options, report=None, threads=None):
    """Trace image rows ``row0 <= r < row1`` into ``outputs``.

    ``args`` (:class:`RayArgs`) and ``outputs = (hit, tbuf, grad, steps, leaves, bisect,
    objs)`` as for :func:`tracer.march.render_rows`, ``options`` (:class:`TraceOptions`).
    ``threads`` Python threads (default :func:`render_threads`) take chunks of tiles
    (:data:`CHUNKS_PER_THREAD`) from a shared counter and trace them with
    the serial, GIL-free kernel :func:`tracer.march.render_tiles`, so that a thread that
    drew cheap tiles takes more; every tile is traced by one thread start to finish, so the
    result does not depend on the number of threads or the chunking (it equals
    ``render_rows``'). ``report(done_pixels)`` is called from the calling thread a few times
    a second and at the end. Ctrl-C (KeyboardInterrupt) stops the workers after their
    current chunk and is re-raised.
    """
    from tracer.march import TILE, render_tiles

    W = int(args.cam[12])
    n = -(-W // TILE) * -(-(row1 - row0) // TILE)
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
                render_tiles(*args, row0, row1, depth_max, *outputs, *options, j, j + chunk)
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
                if report is not None and t.is_alive() and state["done"]:
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


def in_bands(fn, rows, threads=None):
    """Call ``fn(r0, r1)`` for bands of rows covering ``0 <= r < rows``, one band per thread
    (default :func:`render_threads`), from Python threads: for per-pixel numpy work, whose
    array loops release the GIL. Bands of at least 16 rows; exceptions are re-raised here."""
    bands = max(1, min(threads or render_threads(), rows // 16))
    run_tasks(lambda a, b: fn(rows * a // bands, rows * b // bands), bands, bands)


def run_tasks(fn, ntasks, threads=None):
    """Call ``fn(task0, task1)`` over tasks ``0 <= task < ntasks``, split into contiguous
    groups, one per thread (at most :func:`render_threads`), from Python threads: for the
    serial, GIL-free task kernels (``tracer.march.sample_tasks``,
    ``tracer.lighting.light_tasks``), whose tasks are independent, so the result does not
    depend on the split. Exceptions are re-raised here."""
    threads = max(1, min(threads or render_threads(), ntasks))
    if threads == 1:
        fn(0, ntasks)
        return
    edges = [ntasks * i // threads for i in range(threads + 1)]
    errors = []

    def work(a, b):
        try:
            fn(a, b)
        except BaseException as exc:  # handed to the calling thread
            errors.append(exc)

    workers = [threading.Thread(target=work, args=(edges[i], edges[i + 1]), daemon=True)
               for i in range(1, threads)]
    for t in workers:
        t.start()
    work(edges[0], edges[1])
    for t in workers:
        t.join()
    if errors:
        raise errors[0]


def shade(scene, camera, normals, hit, matcap=None):
    """Colour a render with the scene's shading mode; ``(H, W, 3)`` uint8 (``matcap``: the
    scene's texture, if already loaded)."""
    nv = view_normals(normals, camera)
    bg = tuple(scene.background)
    if scene.shading == "matcap":
        return shade_matcap(nv, hit, load_matcap(scene.matcap) if matcap is None else matcap,
                            background=bg)
    if scene.shading == "headlight":
        return shade_headlight(nv, hit, background=bg)
    return shade_normals(nv, hit, background=bg)


class ProgressBar:
    """A dependency-free text progress bar with an ETA, written to ``stream`` (stderr)."""

    def __init__(self, label, stream=None, min_seconds=0.5):
        self.label = label
        self.stream = stream or sys.stderr
        self.min_seconds = min_seconds
        self.shown = False

    def __call__(self, done, total, elapsed):
        """Update with ``done`` of ``total`` units after ``elapsed`` seconds."""
        if elapsed < self.min_seconds and not self.shown:
            return
        frac = done / max(total, 1)
        tty = getattr(self.stream, "isatty", lambda: False)()
        if not tty:
            # logs: one line per quarter instead of carriage-return animation
            quarter = int(4 * frac)
            if self.shown and quarter == getattr(self, "_quarter", -1):
                return
            self._quarter = quarter
        self.shown = True
        eta = elapsed * (1 - frac) / frac if frac > 0 else float("inf")
        bar = "#" * int(30 * frac)
        self.stream.write(f"{chr(13) if tty else ''}{self.label} [{bar:<30}] {100 * frac:5.1f}% "
                          f"{elapsed:6.1f}s elapsed, ~{eta:5.1f}s left")
        if done >= total or not tty:
            self.stream.write("\n")
        self.stream.flush()
