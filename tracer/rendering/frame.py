"""What one frame is made of: the scene as the march kernels take it, the camera, the result.

The pieces that :func:`tracer.render`, the film (:mod:`tracer.rendering.film`), the light
(:mod:`tracer.rendering.lighting`) and the GPU path (:mod:`tracer.rendering.gpu_render`) share, kept
below all of them so that none imports another sideways: :class:`RenderResult`, :class:`SceneArrays`
and :func:`scene_arrays`, the march kernels' named arguments (:class:`RayArgs`,
:class:`TraceOptions`), the camera checks, the plain shadings (:func:`shade`) and the
progress bar. :mod:`tracer.rendering.renderer` re-exports every name.
"""

import dataclasses
import io
import math
import os
import sys
from typing import NamedTuple

import numpy as np

from smoothdist.kernels import DEFAULT_TOL, concatenate_trees
from tracer.errors import RenderError
from tracer.compiling import COMPILING, Eta
from tracer.image import save_npy, save_png
from tracer.rendering import march
from tracer.rendering.camera import box_corners, ray_origins
from tracer.rendering.shading import (load_matcap, shade_headlight, shade_matcap, shade_normals,
                            view_normals)

__all__ = ["RenderResult", "RayArgs", "MarchArgs", "PixelBuffers", "SampleBuffers", "LightArgs",
           "LightBuffers", "SampleRays", "TraceOptions", "SceneArrays", "scene_arrays",
           "object_level", "kernel_roots", "camera_of", "distance_at_camera", "shade",
           "ProgressBar", "MAX_SAMPLES", "pixel_buffers", "posed_params", "checked_samples",
           "progress_callback", "check_steps", "with_overrides", "trace_options",
           "check_camera_outside", "check_image_plane"]

#: the most anti-aliasing samples per pixel (:mod:`tracer.rendering.film`)
MAX_SAMPLES = 1024


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
    camera : tracer.rendering.camera.Camera
    scene : tracer.scenes.scene.Scene or None
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
        from PIL import Image  # Pillow (tracer extra): loaded on use

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
    """What the march kernels read about the scene and the camera: the tree, then
    :class:`MarchArgs` (:attr:`march`), the kernels' first two arguments
    (:func:`tracer.rendering.march.render_tiles`, :func:`tracer.rendering.march.sample_tasks`,
    ...)."""

    tree: object
    #: the kernel form of the roots (:func:`kernel_roots`: an int on the lean path)
    roots: object
    params: np.ndarray
    mode: int
    tol: float
    #: ``tracer.rendering.camera.Camera.as_array()``
    cam: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    eps: float
    max_steps: int

    @property
    def march(self):
        """:class:`MarchArgs`: these arguments without the tree."""
        return MarchArgs(self.roots, self.params, self.mode, self.tol, self.cam, self.lo, self.hi,
                         self.eps, self.max_steps)


class MarchArgs(NamedTuple):
    """The march kernels' second argument: the scene's arrays other than the tree, the camera
    and the march's limits (:class:`RayArgs` without the tree). Flat, with the tree passed on its
    own: numba's parallel loops cannot take a NamedTuple that holds another."""

    roots: object
    params: np.ndarray
    mode: int
    tol: float
    cam: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    eps: float
    max_steps: int


class LightArgs(NamedTuple):
    """The light kernels' settings (:func:`tracer.rendering.lighting.light_tasks`)."""

    L: np.ndarray        # (3,) unit direction towards the key light
    lo: np.ndarray       # (3,) the box the shadow rays march in (the ground included)
    hi: np.ndarray
    eps: float
    k: float             # 1 / penumbra
    delta: float         # the occlusion step, scene units
    do_shadow: bool
    do_ao: bool
    slack: float         # each query may be this much below the render's own distance
    t_min: float         # where shadow rays start ...
    t_judge: float       # ... and judge the light (lighting.soft_shadow)


class LightBuffers(NamedTuple):
    """The light kernels' outputs: ``shadow (n,)``, ``ao (n,)`` and ``work (n, 2) int64``
    (distance queries and leaves visited)."""

    shadow: np.ndarray
    ao: np.ndarray
    work: np.ndarray


class PixelBuffers(NamedTuple):
    """The per-pixel outputs of the render kernel (:func:`tracer.rendering.march.render_tiles`),
    full-image arrays."""

    hit: np.ndarray      # (H, W) bool
    tbuf: np.ndarray     # (H, W) float64, the depth along the ray
    grad: np.ndarray     # (H, W, 3) float64, the distance's gradient at the hit
    steps: np.ndarray    # (H, W) int64, distance evaluations
    leaves: np.ndarray   # (H, W) int64, leaves visited
    bisect: np.ndarray   # (H, W) int64, bisection steps
    objs: np.ndarray     # (H, W) int32, the object each hit shows (-1: a miss)


class SampleBuffers(NamedTuple):
    """The outputs of the anti-aliasing sample kernels
    (:func:`tracer.rendering.march.sample_tasks`): ``(m, K)`` per pixel and
    sample, and the pixels' cone bounds ``t_lo, t_hi (m,)`` (read when finite)."""

    hit: np.ndarray
    tbuf: np.ndarray
    grad: np.ndarray     # (m, K, 3)
    steps: np.ndarray
    objs: np.ndarray
    t_lo: np.ndarray
    t_hi: np.ndarray


class SampleRays(NamedTuple):
    """Which anti-aliasing rays the sample kernels trace, and how
    (:func:`tracer.rendering.march.sample_tasks`): for pixel ``(rows[i], cols[i])`` the rays
    through ``(rows[i] + offsets[k, 0], cols[i] + offsets[k, 1])``."""

    rows: np.ndarray     # (m,) int64
    cols: np.ndarray     # (m,) int64
    offsets: np.ndarray  # (K, 2) float64, within one pixel
    eps_px: float        # the rays' hit threshold in pixels, at least
    newton_cos: float    # the rays' Newton cosine (tracer.rendering.march.NEWTON_COS)


class TraceOptions(NamedTuple):
    """The march kernels' trailing options (see :func:`tracer.render`)."""

    relax: float
    omega: float
    cone: bool
    newton: float


class SceneArrays(NamedTuple):
    """A scene as the march kernels take it (:func:`scene_arrays`).

    The kernels' leading arguments are ``tree, roots, params, mode, tol`` (see
    :mod:`tracer.rendering.march`). ``tol`` comes last here so that positions 0-6 are those of the
    7-tuple this used to be (``[4:6]`` is still ``lo, hi``).

    tree : smoothdist.kernels.TreeData
        The objects' trees, concatenated into one forest when there are several.
    roots : (k,) int64
        Root node of each object.
    params : (k, march.P_COLUMNS) or (k, march.P_COLUMNS_POSED) float64
        The per-object parameter table, columns ``tracer.rendering.march.P_*``.
    mode : int
        ``tracer.rendering.march.MODE_SMOOTH`` or ``MODE_EXACT``.
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
    :mod:`tracer.rendering.march`, and the box is the union of the posed, grown object boxes).
    """
    trees = [o.field.tree for o in scene.objects]
    params = np.empty((len(scene.objects), march.P_COLUMNS))
    columns = [march.P_ALPHA, march.P_BETA, march.P_S, march.P_WGS, march.P_OFFSET]
    margin = 0.0
    for k, o in enumerate(scene.objects):
        alpha, beta, S, wgrad_scale = o.field.kernel_args(o.alpha, o.beta, o.alpha_u,
                                                          scene.march.gradient)
        level = object_level(o, scene.march.mode)
        params[k, columns] = (alpha, beta, S, wgrad_scale, level)
        if scene.march.mode == "exact":
            margin = max(margin, level)
        else:
            margin = max(margin, o.field.inflation(alpha, o.alpha_u) + level)
    if scene.march.mode == "smooth" and len(trees) > 1:
        a = params[:, march.P_ALPHA].max()
        margin += np.log(len(trees)) / a
    tol = float(getattr(scene, "tol", DEFAULT_TOL))
    lo, hi = scene.bounds
    grow = margin + 2 * scene.march.eps + 1e-9 * scene.diagonal
    mode = march.MODE_EXACT if scene.march.mode == "exact" else march.MODE_SMOOTH
    tree, roots = concatenate_trees(trees) if len(trees) > 1 else (trees[0], np.zeros(1, np.int64))
    if transforms is not None:
        params, lo, hi = posed_params(scene, transforms, params, grow)
        return SceneArrays(tree, roots, params, mode, lo, hi, tree.depth, tol)
    return SceneArrays(tree, roots, params, mode, lo - grow, hi + grow, tree.depth, tol)


def object_level(obj, mode):
    """The offset ``c`` an object's surface is drawn at (``d - c = 0`` exact, ``d_hat - c = 0``
    smooth; :meth:`tracer.scenes.scene.SceneObject.level`), checked: finite and ``>= 0``."""
    c = float(obj.level(mode))
    if not (math.isfinite(c) and c >= 0.0):
        raise ValueError(f"{obj.name}: offset must be a finite number >= 0, got {c}")
    return c


def posed_params(scene, transforms, params, grow):
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
    """The ``roots`` argument for :mod:`tracer.rendering.march`: one unposed object in smooth mode
    without tolerance pruning (``tol`` 0) is passed as its root node (an int), which selects
    the kernels' lean path (:func:`tracer.rendering.march.scene_distance`; same values, far less
    code to compile); anything else as the ``(k,)`` array."""
    if (mode == march.MODE_SMOOTH and roots.size == 1 and params.shape[1] == march.P_COLUMNS
            and not tol > 0.0):
        return int(roots[0])
    return roots


def camera_of(scene):
    """The scene's :class:`~tracer.rendering.camera.Camera` (validated)."""
    return scene.camera.camera(scene.film.width, scene.film.height)


def distance_at_camera(scene, arrays=None):
    """Scene distance at the camera origin (> 0 when the camera is outside the surface)."""
    tree, roots, params, mode, lo, hi, depth_max, tol = arrays or scene_arrays(scene)
    o = scene.camera.origin
    sc = (tree, kernel_roots(roots, params, mode, tol), params, mode, tol)
    return float(march.distance_at(sc, float(o[0]), float(o[1]), float(o[2]), depth_max))


def check_camera_outside(scene, arrays=None):
    """Raise :class:`~tracer.errors.RenderError` when the camera is inside the surface (the
    distance at the camera is not above ``eps``), or, orthographic, when its image plane, where
    the rays start, cuts the surface (:func:`check_image_plane`)."""
    arrays = arrays or scene_arrays(scene)
    d0 = distance_at_camera(scene, arrays)
    if not d0 > scene.march.eps:
        raise RenderError(f"the camera at {np.round(scene.camera.origin, 6).tolist()} is inside "
                          f"the surface (distance there {d0:.4g} <= eps "
                          f"{scene.march.eps:.3g}); move camera.origin outside or lower "
                          "alpha's blur")
    camera = camera_of(scene)
    if camera.orthographic:
        check_image_plane(scene, camera, arrays)


#: ray origins per image side at which :func:`check_image_plane` looks for the surface
PLANE_PROBES = 64


def check_image_plane(scene, camera, arrays):
    """An orthographic camera's rays start on its image plane: raise
    :class:`~tracer.errors.RenderError` when the surface is there. Nothing to check when the
    whole scene box lies in front of the plane; else the distance is probed at up to
    :data:`PLANE_PROBES` x :data:`PLANE_PROBES` ray origins spread over the image (a surface
    thinner than their spacing may slip between them)."""
    tree, roots, params, mode, lo, hi, depth_max, tol = arrays
    depth = (box_corners(lo, hi) - camera.origin) @ camera.forward
    if depth.min() > 0.0:
        return
    rows = np.unique(np.linspace(0, camera.height - 1, min(PLANE_PROBES, camera.height)).round())
    cols = np.unique(np.linspace(0, camera.width - 1, min(PLANE_PROBES, camera.width)).round())
    origins = ray_origins(camera)[rows.astype(int)][:, cols.astype(int)].reshape(-1, 3)
    sc = (tree, kernel_roots(roots, params, mode, tol), params, mode, tol)
    inside = sum(march.distance_at(sc, float(p[0]), float(p[1]), float(p[2]), depth_max)
                 <= scene.march.eps for p in origins)
    if inside:
        raise RenderError(f"the orthographic camera's image plane through "
                          f"{np.round(camera.origin, 6).tolist()} cuts the surface: rays would "
                          f"start inside it ({inside} of {len(origins)} probed); move "
                          f"camera.origin back along the view direction by "
                          f"{-depth.min():.4g} (the whole scene box is then in front)")


def pixel_buffers(H, W):
    """The tracing outputs (:class:`PixelBuffers`) of an ``H x W`` image, cleared."""
    return PixelBuffers(np.zeros((H, W), dtype=np.bool_), np.full((H, W), np.nan),
                        np.zeros((H, W, 3)), np.zeros((H, W), dtype=np.int64),
                        np.zeros((H, W), dtype=np.int64), np.zeros((H, W), dtype=np.int64),
                        np.full((H, W), -1, dtype=np.int32))


def check_steps(newton, relax):
    """``newton`` and ``relax`` of :func:`tracer.render`: None or a finite number >= 0, else a
    ``ValueError`` naming the argument."""
    for name, value in (("newton", newton), ("relax", relax)):
        if value is not None and not (isinstance(value, (int, float, np.number))
                                      and not isinstance(value, bool)
                                      and math.isfinite(value) and value >= 0):
            raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")


def with_overrides(scene, newton=None, samples=None, adaptive=None):
    """``scene`` as :func:`tracer.render` draws it: its ``march.newton``, ``film.samples`` and
    ``film.adaptive`` replaced by the arguments that are not None, each checked (the scene
    itself when nothing changes; else a copy, the scene given is left as it was)."""
    check_steps(newton, None)
    march_ = scene.march if newton is None else dataclasses.replace(scene.march,
                                                                    newton=float(newton))
    film = dataclasses.replace(
        scene.film, samples=checked_samples(scene.film.samples if samples is None else samples),
        adaptive=bool(scene.film.adaptive if adaptive is None else adaptive))
    if march_ == scene.march and film == scene.film:
        return scene
    return dataclasses.replace(scene, march=march_, film=film)


def trace_options(scene, lo, hi, relax=None, omega=None, cone=None):
    """The :class:`TraceOptions` of a render of ``scene`` in the box ``lo, hi``: ``relax``,
    ``omega`` and ``cone`` as :func:`tracer.render` takes them (None: the defaults of
    :mod:`tracer.rendering.march`), the Newton distance from ``scene.march``
    (:func:`tracer.rendering.march.newton_distance`)."""
    return TraceOptions(
        float(march.RELAX if relax is None else relax),
        float(march.OMEGA if omega is None else max(1.0, float(omega))),
        bool(march.CONE if cone is None else cone),
        march.newton_distance(scene.march.eps, lo, hi, max(0.0, float(scene.march.newton))))


def checked_samples(value):
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) \
            or not 1 <= value <= MAX_SAMPLES:
        raise ValueError(f"samples must be an integer from 1 to {MAX_SAMPLES}, got {value!r}")
    return int(value)


#: ``progress="auto"``: the bar appears once a render has run this long (seconds)
AUTO_PROGRESS_AFTER = 3.0


def progress_callback(progress, scene):
    """``render``'s ``progress`` argument as a callable or None (see :func:`tracer.render`)."""
    if progress is None or progress is False:
        return None
    if progress is True or (isinstance(progress, str) and progress == "auto"):
        return ProgressBar(f"render {getattr(scene, 'name', '') or 'scene'}",
                           min_seconds=0.0 if progress is True else AUTO_PROGRESS_AFTER)
    if callable(progress):
        return progress
    raise TypeError(f"progress must be True, False, None, 'auto' or a callable(done, total, "
                    f"elapsed_s), got {progress!r}")


def shade(scene, camera, normals, hit, matcap=None):
    """Colour a render with the scene's shading mode; ``(H, W, 3)`` uint8 (``matcap``: the
    scene's texture, if already loaded)."""
    nv = view_normals(normals, camera)
    bg = tuple(scene.film.background)
    if scene.film.shading == "matcap":
        return shade_matcap(nv, hit, load_matcap(scene.film.matcap) if matcap is None else matcap,
                            background=bg)
    if scene.film.shading == "headlight":
        return shade_headlight(nv, hit, background=bg)
    return shade_normals(nv, hit, background=bg)


class ProgressBar:
    """A dependency-free text progress bar with an ETA, written to ``stream`` (stderr).

    While numba compiles the kernels (the first run on a machine) it says
    ``compiling kernels (once per machine)`` with the seconds elapsed, and its ETA counts only
    the progress made after the compilation (:class:`tracer.compiling.Eta`). ``eta``: an
    :class:`~tracer.compiling.Eta` to use (default: one on the process's compile watch).
    """

    def __init__(self, label, stream=None, min_seconds=0.5, eta=None):
        self.label = label
        self.stream = stream or sys.stderr
        self.min_seconds = min_seconds
        self.shown = False
        self.eta = eta or Eta()
        self._frac = 0.0
        self._step = None  # logs: (quarter, compiling) of the last line written

    def __call__(self, done, total, elapsed):
        """Update with ``done`` of ``total`` units after ``elapsed`` seconds."""
        self._frac = done / max(total, 1)
        self._show(elapsed, done >= total)

    def waiting(self, elapsed):
        """Nothing done yet after ``elapsed`` seconds (:func:`tracer.render` calls it while its
        tiles wait for their kernel): shown while numba compiles it."""
        if self.eta.compiling:
            self._show(elapsed, False)

    def text(self, elapsed):
        """The bar's line after ``elapsed`` seconds."""
        left = self.eta.left(self._frac, elapsed)
        if self.eta.compiling:
            return f"{self.label} {COMPILING}, {elapsed:6.1f}s elapsed"
        left = "?" if left is None else f"{left:5.1f}"
        return (f"{self.label} [{'#' * int(30 * self._frac):<30}] {100 * self._frac:5.1f}% "
                f"{elapsed:6.1f}s elapsed, ~{left}s left")

    def _show(self, elapsed, last):
        line = self.text(elapsed)  # also when not shown: the ETA sees every update
        if elapsed < self.min_seconds and not self.shown:
            return
        tty = getattr(self.stream, "isatty", lambda: False)()
        if not tty:
            # logs: one line per quarter, and when a compilation starts or ends
            step = (int(4 * self._frac), self.eta.compiling)
            if self.shown and step == self._step:
                return
            self._step = step
        self.shown = True
        self.stream.write(("\r\033[K" if tty else "") + line)
        if last or not tty:
            self.stream.write("\n")
        self.stream.flush()
