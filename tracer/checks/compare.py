"""``tracer compare``: check a sphere-traced render against a pyvista isosurface of the same field.

Two independent pipelines look at the same surface from the same camera:

* **tracer** -- :func:`tracer.render` sphere-traces the scene distance (smooth
  LogSumExp, several objects combined by a second LogSumExp with the largest alpha; or exact
  distance minus ``offset``, combined by the minimum).
* **pyvista** -- the same scene distance is sampled on a regular ``N x N x N`` grid of points
  spanning the tracer's grown scene box (:func:`tracer.rendering.frame.scene_arrays`: the data's box
  plus the largest possible isosurface inflation, so every grid face is outside the surface
  and the contour is closed), the zero isosurface is extracted by VTK's flying-edges marching
  cubes, its points get the field's gradient as normals (evaluated *at the contour points*,
  the same gradient the tracer shades with) and VTK rasterises it from the same camera
  (:func:`tracer.rendering.camera.pyvista_camera_params`, window centre included) without lighting,
  each vertex coloured ``127 n + 128`` by its view-space normal.

Per pixel we compare the hit masks (silhouette IoU), the normals over pixels both hit (the
pyvista normal is decoded from its colour: ``n = (c - 128) / 127``, quantisation <= 0.5 / 127
per component, about 0.3 degrees), and the depth along the ray (VTK's z-buffer gives the view
depth ``z``; the tracer's ``t`` along a unit ray is ``z / cos``, ``cos`` the angle between the
pixel's ray and ``forward``), relative to the data's bounding-box diagonal.

Residuals and where they come from
----------------------------------
Measured with ``tracer compare SCENE --size 96 96`` (default grid 128) on every shipped scene
(``scenes/*.json``; ``tests/tracer/rendering/test_render_golden.py`` re-checks four scenes
and a sphere at a 64^3 grid). "only": pixels hit by the tracer only / by pyvista only; normal
angles in degrees; depth: mean ``|t_pyvista - t_tracer|`` / data diagonal; cell: the largest
grid spacing / data diagonal (the grid spans the data box grown by the inflation margin, hence
cells of 0.6-0.9 % of the diagonal)::

    scene             IoU    only   mean  median  p95   depth    cell
    bunny_edges       0.998  7/0    0.26  0.23    0.5   3.1e-4   0.0080
    bunny_points      0.997  8/0    0.34  0.28    0.8   4.2e-4   0.0075
    bunny_triangles   0.998  6/0    0.28  0.24    0.6   3.7e-4   0.0078
    capillary         0.992  8/0    1.10  0.71    3.3   3.8e-4   0.0080
    capillary_exact   0.995  3/1    4.97  1.30   25.7   7.6e-4   0.0071
    capillary_smooth  0.997  4/0    0.51  0.34    1.4   3.9e-4   0.0087
    lidar_autzen      0.975  94/5   4.36  1.14   18.7   6.3e-4   0.0074
    lion_points       0.999  2/0    0.92  0.69    2.2   5.0e-4   0.0060
    mixed             0.989  7/0    2.47  1.03    7.6   1.2e-3   0.0063
    octopus           0.996  2/0    1.50  0.96    3.7   5.0e-4   0.0064
    torus             0.998  7/0    0.39  0.31    0.9   4.3e-4   0.0066
    trefoil           0.980  11/1   1.15  0.49    4.5   1.3e-3   0.0070
    two_objects       0.995  15/0   0.60  0.36    1.3   5.7e-4   0.0067

What is left is the marching-cubes discretisation, not a camera or field mismatch (with these
camera settings a finely tessellated sphere rasterised by VTK covers exactly the pixels whose
rays hit the analytic sphere, and the sampled field equals the tracer's to 1e-12):

* **Silhouette (IoU < 1).** Marching cubes interpolates the zero crossing linearly along grid
  edges, so the extracted surface is a chordal approximation with facets about one cell wide
  that lies slightly *inside* convex parts (hence almost all disagreeing pixels are
  tracer-only), cuts off bumps smaller than a cell and thins or breaks tubes and blobs only a
  few cells thick: a one-pixel rim along silhouettes, thickest where the geometry is thin
  (the trefoil and capillary tubes, the ``mixed`` scene's small lion point blobs). The LiDAR
  tile is the worst case: its box is flat (1224 x 610 x 161 ft), so with N points per axis
  the cells are 9.6 ft long in x but the surface has 2-ft detail (trees, poles, kerbs).
  Everything shrinks as the grid is refined.
* **Normals.** The vertex normals are the exact field gradient, but VTK interpolates them
  linearly across facets (Gouraud) while the tracer evaluates the gradient at the exact hit.
  The error grows with curvature x cell size: small on smooth blobs (0.3 degrees), larger at
  creases of the smooth distance between blobs (point clouds, ``mixed``, LiDAR) and largest
  on the exact-offset surface of ``capillary_exact``, a union of capsules with concave
  creases wherever tubes meet, where interpolated normals straddle the crease (isolated
  speckle pixels: median 1.3, p95 26 degrees).
* **Depth.** The chord error of the facets (a fraction of a cell) plus the 24-bit z-buffer.

With ``--exact`` the same holds; exact-offset surfaces of point clouds are unions of balls of
radius ``1 / alpha``, about one cell or less (LiDAR: 2 ft balls, 9.6 ft cells, IoU 0.93 at a
128 grid and 0.96 at 256; ``lion_points``: normal error 26 degrees mean at 128, 16 at 256),
which a grid cannot resolve; meshes and curves stay at IoU >= 0.97.

Outputs of ``tracer compare SCENE -o DIR``: ``metrics.json``, ``tracer.png`` (the trace, shaded
by view-space normals whatever the scene's shading, so both pictures use the same colours),
``pyvista.png``, ``diff.png`` (pixels both hit: ``|depth difference| / diagonal`` in
``inferno`` from 0 (black) to 1 % (pale yellow); only the tracer hit: blue; only pyvista hit:
green; neither: the background) and ``side_by_side.png`` (the three, titled "sphere tracer",
"pyvista marching cubes" and "difference", with the difference's colour bar and legend).

``--exact`` compares the exact-offset isosurface ``d - offset = 0`` (``offset`` defaulting to
``1 / alpha`` per object) instead of the smooth one, on both sides; scenes whose ``mode`` is
already ``"exact"`` use it anyway.

pyvista, VTK and the numba kernels are imported only when the command runs.
"""

import json
import os
import re
import subprocess
import sys
import time
from typing import NamedTuple

import numpy as np

from smoothdist.mesh import needs_trimesh
from tracer.errors import CLIError
from tracer.image import compare_images, false_color, save_png
from tracer.outputs import atomic_write, check_outputs
from tracer.rendering.camera import primary_rays, pyvista_camera_params
from tracer.rendering.frame import camera_of, scene_arrays
from tracer.rendering.renderer import render
from tracer.rendering.shading import shade_normals, view_normals
from tracer.scenes.scene import load_scene, mesh_paths

__all__ = [
    "OUTPUT_FILES",
    "offscreen_problem",
    "scene_field",
    "sample_grid",
    "isosurface",
    "PyvistaRender",
    "render_isosurface",
    "compare_renders",
    "Comparison",
    "compare_scene",
    "diff_image",
    "side_by_side",
    "labelled_side_by_side",
]

#: the command's one-line help (``tracer compare``)
HELP = "compare a render with a pyvista isosurface of the same field"

#: files written into the output folder
OUTPUT_FILES = ("metrics.json", "tracer.png", "pyvista.png", "side_by_side.png", "diff.png")

#: ``|depth difference| / diagonal`` mapped to the top of the colormap in ``diff.png``
DIFF_VMAX = 0.01
TRACER_ONLY = (40, 110, 255)
PYVISTA_ONLY = (0, 190, 70)
SEPARATOR = (128, 128, 128)

#: points per batch when sampling the field (bounds the temporary memory to ~50 MB)
_CHUNK = 1 << 18

_PROBE = (
    "import numpy as np, pyvista as pv\n"
    "p = pv.Plotter(off_screen=True, window_size=(16, 16))\n"
    "p.add_mesh(pv.Sphere())\n"
    "img = p.screenshot(None, return_img=True)\n"
    "assert img.shape[:2] == (16, 16), img.shape\n"
    "assert np.isfinite(p.get_image_depth()).any(), 'empty depth buffer'\n"
    "p.close()\n"
)
_probe_result = {}


# ------------------------------------------------------------------------ environment
def offscreen_problem(timeout=120.0):
    """Why VTK cannot render off-screen here, or None when it can.

    The check runs a tiny pyvista render in a child process (once per process; the answer is
    cached), because a VTK without a usable OpenGL context may abort or crash rather than
    raise. Returns a one-line reason (the child's last line of error output) or None.
    """
    if "answer" in _probe_result:
        return _probe_result["answer"]
    try:
        proc = subprocess.run([sys.executable, "-c", _PROBE], capture_output=True, text=True,
                              timeout=timeout)
    except subprocess.TimeoutExpired:
        answer = f"a test render did not finish within {timeout:g} s"
    except OSError as exc:
        answer = f"cannot start a test render: {exc}"
    else:
        if proc.returncode == 0:
            answer = None
        else:
            lines = [_clean_log_line(ln) for ln in proc.stderr.splitlines()]
            lines = [ln for ln in lines if ln]
            why = lines[-1] if lines else f"exit status {proc.returncode}"
            if proc.returncode < 0:
                why = f"the test render was killed by signal {-proc.returncode} ({why})"
            answer = why[:300]
    _probe_result["answer"] = answer
    return answer


def _clean_log_line(line):
    """A stderr line without ANSI colours and VTK's ``date (time) [thread] file:line WARN|``."""
    line = re.sub(r"\x1b\[[0-9;]*m", "", line).strip()
    m = re.match(r".*?\b(?:WARN|ERR|ERROR|INFO|FATAL)\s*\|\s*(.*)$", line)
    return (m.group(1) if m else line).strip()


def _quiet_vtk():
    """Keep VTK's log (e.g. the X11 fallback warning before EGL is used) off stderr."""
    try:
        # VTK (with pyvista, studies extra): loaded on use
        from vtkmodules.vtkCommonCore import vtkLogger

        vtkLogger.SetStderrVerbosity(vtkLogger.VERBOSITY_ERROR)
    except Exception:  # pragma: no cover - logging is cosmetic
        pass


# ------------------------------------------------------------------------ the field
def scene_field(scene, points, chunk=_CHUNK):
    """The scene distance the tracer marches, and its gradient, at many points.

    Parameters
    ----------
    scene : tracer.scenes.scene.Scene
    points : (q, 3) array_like of float

    Returns
    -------
    d : (q,) float64
    grad : (q, 3) float64
        Not normalised (the metric gradient of the smooth distance, or the exact distance's
        unit gradient), as in :func:`tracer.rendering.march.scene_distance`.

    Notes
    -----
    Same formula as :func:`tracer.rendering.march.scene_distance`, evaluated with the library's
    parallel batch queries per object: smooth mode
    ``d_k = field_k.smooth_distance(alpha_k, beta_k, alpha_u_k, scene.march.gradient) - c_k``
    (``c_k`` the object's smooth offset), combined for several objects by
    ``m - log(sum exp(-a (d_k - m))) / a`` with ``a`` the largest alpha and ``m = min d_k``
    (gradient: the ``exp``-weighted mean); exact mode ``min_k (exact_k - offset_k)`` with the
    gradient of the minimiser.
    """
    P = np.ascontiguousarray(np.asarray(points, dtype=np.float64).reshape(-1, 3))
    n = P.shape[0]
    d = np.empty(n)
    g = np.empty((n, 3))
    for s in range(0, n, chunk):
        d[s:s + chunk], g[s:s + chunk] = _scene_field_chunk(scene, P[s:s + chunk])
    return d, g


def _scene_field_chunk(scene, Q):
    objs = scene.objects
    if scene.march.mode == "exact":
        best = None
        for o in objs:
            dk, gk = o.field.exact_distance(Q)
            dk = dk - o.offset
            if best is None:
                best, bg = dk, gk
            else:
                closer = dk < best
                best = np.where(closer, dk, best)
                bg = np.where(closer[:, None], gk, bg)
        return best, bg
    ds, gs = [], []
    for o in objs:
        dk, gk = o.field.smooth_distance(Q, alpha=o.alpha, beta=o.beta, alpha_u=o.alpha_u,
                                         gradient=scene.march.gradient, tol=scene.march.tol)
        ds.append(dk - o.level("smooth"))
        gs.append(gk)
    if len(objs) == 1:
        return ds[0], gs[0]
    a = max(o.alpha for o in objs)
    D = np.stack(ds)                       # (k, q)
    m = D.min(axis=0)
    E = np.exp(-a * (D - m))               # the minimiser contributes exactly 1
    s = E.sum(axis=0)
    grad = np.einsum("kq,kqc->qc", E, np.stack(gs)) / s[:, None]
    return m - np.log(s) / a, grad


def positive_margin(scene):
    """Scene distance is certainly > 0 where the exact distance to the data exceeds this.

    Smooth mode: ``(1 + beta_max) (max_k log(A_k^S_k N_k) / alpha_k + log(K) / a)`` (the
    second term only for ``K > 1`` objects). Every term of the smooth distance's LogSumExp is
    at a distance ``>= d / (1 + beta)`` from the query (``d``: the exact distance): exact terms
    trivially, a Barnes-Hut far-field node at its box distance ``bd`` because the node is only
    used when its diagonal is ``< beta bd``, so that its primitives are within
    ``(1 + beta) bd``; the weights sum to at most ``A^S N``; and the objects' LogSumExp is at
    least ``min_k d_hat_k - log(K) / a``; an object's smooth offset ``c_k`` adds to its
    term. Exact mode: the largest offset.
    """
    objs = scene.objects
    if scene.march.mode == "exact":
        return max(o.offset for o in objs)
    margin = max(o.field.inflation(o.alpha, o.alpha_u) + o.level("smooth") for o in objs)
    if len(objs) > 1:
        margin += np.log(len(objs)) / max(o.alpha for o in objs)
    return float((1.0 + max(o.beta for o in objs)) * margin)


def exact_scene_distance(scene, points, chunk=_CHUNK):
    """Exact (unsigned, un-offset) distance from ``points (q, 3)`` to all objects' data."""
    P = np.ascontiguousarray(np.asarray(points, dtype=np.float64).reshape(-1, 3))
    d = np.full(P.shape[0], np.inf)
    for s in range(0, P.shape[0], chunk):
        for o in scene.objects:
            d[s:s + chunk] = np.minimum(d[s:s + chunk], o.field.exact_distance(P[s:s + chunk])[0])
    return d


def _grid_points(axes, iz, iy, ix):
    """World coordinates of the grid points with index arrays ``iz, iy, ix`` (same shape)."""
    xs, ys, zs = axes
    return np.stack([xs[ix].ravel(), ys[iy].ravel(), zs[iz].ravel()], axis=1)


def _certainly_positive(scene, n, axes, spacing, stride=4):
    """``(n, n, n)`` bool, ``[z, y, x]``: grid points where the scene distance is provably > 0.

    The exact distance ``d`` is 1-Lipschitz, so a block of the ``stride``-coarse grid whose
    corners all have ``d > margin + half the block diagonal`` has ``d > margin`` everywhere
    (``margin``: :func:`positive_margin`); points in the other blocks are tested one by one.
    """
    thr = positive_margin(scene) * (1.0 + 1e-6) + 1e-12 * max(scene.diagonal, 1e-300)
    idx = np.unique(np.r_[np.arange(0, n, stride), n - 1])
    m = idx.size
    cz, cy, cx = np.meshgrid(idx, idx, idx, indexing="ij")
    dc = exact_scene_distance(scene, _grid_points(axes, cz, cy, cx)).reshape(m, m, m)
    corner_min = dc[:-1, :-1, :-1]
    for sz in (0, 1):
        for sy in (0, 1):
            for sx in (0, 1):
                corner_min = np.minimum(corner_min, dc[sz:m - 1 + sz, sy:m - 1 + sy,
                                                       sx:m - 1 + sx])
    ext = np.diff(idx).astype(np.float64)
    half = 0.5 * np.sqrt((ext[:, None, None] * spacing[2]) ** 2
                         + (ext[None, :, None] * spacing[1]) ** 2
                         + (ext[None, None, :] * spacing[0]) ** 2)
    block_ok = corner_min - half > thr
    blk = np.minimum(np.searchsorted(idx, np.arange(n), side="right") - 1, m - 2)
    cert = block_ok[np.ix_(blk, blk, blk)]
    iz, iy, ix = np.nonzero(~cert)
    if iz.size:
        cert[iz, iy, ix] = exact_scene_distance(scene, _grid_points(axes, iz, iy, ix)) > thr
    return cert, thr


def sample_grid(scene, n, prune=True):
    """Sample the scene distance on ``n`` points per axis spanning the grown scene box.

    Parameters
    ----------
    scene : tracer.scenes.scene.Scene
    n : int
        Grid points per axis (>= 2).
    prune : bool, default True
        Smooth mode only: skip the (expensive) smooth distance at points that are provably
        outside the surface -- exact distance above :func:`positive_margin` -- and whose six
        grid neighbours are too; they get a positive placeholder value instead. No grid edge
        touching such a point crosses zero, so the marching-cubes surface is the same as
        with every point evaluated (``tests/tracer/rendering/test_render_golden.py`` checks it).

    Returns
    -------
    values : (n, n, n) float64
        Indexed ``[z, y, x]`` (so ``values.ravel()`` has x varying fastest, VTK's order).
    origin : (3,) float64
        The box's low corner (the first grid point).
    spacing : (3,) float64
        ``(hi - lo) / (n - 1)`` per axis.
    evaluated : float
        Fraction of the grid points where the scene distance was evaluated.
    """
    n = int(n)
    if n < 2:
        raise ValueError(f"the grid needs at least 2 points per axis, got {n}")
    lo, hi = (np.asarray(v, dtype=np.float64) for v in scene_box(scene))
    spacing = (hi - lo) / (n - 1)
    axes = tuple(lo[a] + spacing[a] * np.arange(n) for a in range(3))
    if prune and scene.march.mode == "smooth":
        cert, thr = _certainly_positive(scene, n, axes, spacing)
        need = ~cert
        grown = need.copy()
        grown[1:] |= need[:-1]
        grown[:-1] |= need[1:]
        grown[:, 1:] |= need[:, :-1]
        grown[:, :-1] |= need[:, 1:]
        grown[:, :, 1:] |= need[:, :, :-1]
        grown[:, :, :-1] |= need[:, :, 1:]
        values = np.full((n, n, n), thr)
        iz, iy, ix = np.nonzero(grown)
        if iz.size:
            values[iz, iy, ix] = scene_field(scene, _grid_points(axes, iz, iy, ix))[0]
        return values, lo, spacing, float(iz.size) / n ** 3
    values = np.empty((n, n, n))
    slab = max(1, _CHUNK // (n * n))
    for k0 in range(0, n, slab):
        k1 = min(n, k0 + slab)
        iz, iy, ix = np.meshgrid(np.arange(k0, k1), np.arange(n), np.arange(n), indexing="ij")
        values[k0:k1] = scene_field(scene, _grid_points(axes, iz, iy, ix))[0].reshape(
            k1 - k0, n, n)
    return values, lo, spacing, 1.0


def isosurface(scene, n, prune=True):
    """Zero isosurface of the scene distance from an ``n``-point-per-axis grid.

    Returns
    -------
    pyvista.PolyData
        Triangles (flying-edges marching cubes) with point data ``"normals"``: the unit field
        gradient at each vertex, and field data ``"evaluated_fraction"`` (see
        :func:`sample_grid`). May be empty when the grid sees no sign change.
    """
    import pyvista as pv  # pyvista (studies extra): loaded on use

    values, origin, spacing, evaluated = sample_grid(scene, n, prune=prune)
    grid = pv.ImageData(dimensions=(n, n, n), spacing=tuple(spacing), origin=tuple(origin))
    grid.point_data["d"] = values.ravel()
    surf = grid.contour([0.0], scalars="d", method="flying_edges")
    if surf.n_points:
        _, g = scene_field(scene, np.asarray(surf.points, dtype=np.float64))
        norm = np.linalg.norm(g, axis=1, keepdims=True)
        surf.point_data["normals"] = np.where(norm > 0, g / np.where(norm > 0, norm, 1.0), 0.0)
    surf.field_data["evaluated_fraction"] = np.array([evaluated])
    return surf


# ------------------------------------------------------------------------ pyvista render
class PyvistaRender(NamedTuple):
    """A VTK rasterisation; images ``(H, W, ...)``, row 0 at the top.

    rgb : (H, W, 3) uint8, ``127 n + 128`` of the interpolated view-space normal.
    hit : (H, W) bool, where the z-buffer holds a surface.
    depth : (H, W) float64, distance along the pixel's unit ray (the tracer's ``t``), NaN off.
    view_normals : (H, W, 3) float64, decoded from ``rgb`` and normalised (0 off the surface).
    """

    rgb: np.ndarray
    hit: np.ndarray
    depth: np.ndarray
    view_normals: np.ndarray


def render_isosurface(surface, camera, background=(255, 255, 255), focal_distance=1.0):
    """Rasterise ``surface`` (with point data ``"normals"``) as the tracer's ``camera`` sees it.

    Lighting, anti-aliasing and multisampling are off, so every pixel is the colour of the
    surface point on its pixel centre, and the window centre reproduces the authors' half-pixel
    shift (:func:`tracer.rendering.camera.pyvista_camera_params`).

    Raises
    ------
    tracer.errors.CLIError
        ``VTK cannot render off-screen here: ...`` when VTK fails.
    """
    W, H = camera.width, camera.height
    params = pyvista_camera_params(camera, focal_distance=focal_distance)
    has_mesh = bool(surface.n_points and surface.n_cells)
    if has_mesh:
        nw = np.asarray(surface.point_data["normals"], dtype=np.float64)
        nv = np.stack([nw @ camera.horizontal, nw @ camera.vertical, -(nw @ camera.forward)],
                      axis=1)
        mesh = surface.copy(deep=False)
        mesh.point_data["rgb"] = np.clip((127.0 * nv + 128.0) / 255.0, 0.0, 1.0)
    try:
        import pyvista as pv  # pyvista (studies extra): loaded on use

        _quiet_vtk()
        plotter = pv.Plotter(off_screen=True, window_size=list(params["window_size"]))
        try:
            plotter.disable_anti_aliasing()
            plotter.render_window.SetMultiSamples(0)
            plotter.set_background(tuple(int(c) for c in background))
            if has_mesh:
                plotter.add_mesh(mesh, scalars="rgb", rgb=True, lighting=False,
                                 show_scalar_bar=False, smooth_shading=False, show_edges=False)
            cam = plotter.camera
            cam.position = tuple(params["position"])
            cam.focal_point = tuple(params["focal_point"])
            cam.up = tuple(params["view_up"])
            if params["parallel_projection"]:
                cam.enable_parallel_projection()
                cam.parallel_scale = params["parallel_scale"]
            else:
                cam.view_angle = params["view_angle"]
            cam.SetWindowCenter(*params["window_center"])
            plotter.renderer.ResetCameraClippingRange()
            plotter.render()
            rgb = np.asarray(plotter.screenshot(None, return_img=True))[..., :3].copy()
            zval = np.asarray(plotter.get_image_depth(fill_value=np.nan,
                                                      reset_camera_clipping_range=False),
                              dtype=np.float64)
        finally:
            plotter.close()
    except Exception as exc:  # VTK / OpenGL failures of any kind
        msg = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise CLIError(f"VTK cannot render off-screen here: {msg}") from None
    if rgb.shape[:2] != (H, W) or zval.shape != (H, W):
        raise CLIError(f"VTK cannot render off-screen here: got a {rgb.shape[1]}x{rgb.shape[0]} "
                       f"image for a {W}x{H} window")
    if not has_mesh:
        zval[:] = np.nan
    rays = primary_rays(camera)
    cos = rays @ camera.forward
    depth = -zval / cos                       # VTK gives -z (view depth); t = z / cos
    hit = np.isfinite(depth)
    depth[~hit] = np.nan
    nv = (rgb.astype(np.float64) - 128.0) / 127.0
    norm = np.linalg.norm(nv, axis=2, keepdims=True)
    nv = np.where(hit[..., None] & (norm > 0), nv / np.where(norm > 0, norm, 1.0), 0.0)
    return PyvistaRender(rgb=rgb, hit=hit, depth=depth, view_normals=nv)


# ------------------------------------------------------------------------ metrics and images
def compare_renders(trace, pvr, diagonal):
    """Metrics between a :class:`~tracer.rendering.frame.RenderResult` and a :class:`PyvistaRender`.

    Returns a dict: ``iou`` (hit masks; 1 when both are empty), ``tracer_only`` /
    ``pyvista_only`` (pixel counts), ``both_hit``, ``normal_angle_mean_deg``,
    ``normal_angle_median_deg``, ``normal_angle_p95_deg``, ``depth_error_rel_diag`` (mean
    ``|t_pyvista - t_tracer|`` over pixels both hit / ``diagonal``),
    ``depth_error_p95_rel_diag``. Metrics over an empty set of pixels are None.
    """
    a = np.asarray(trace.hit, dtype=bool)
    b = np.asarray(pvr.hit, dtype=bool)
    union = int(np.sum(a | b))
    both = a & b
    out = {
        "iou": float(np.sum(both) / union) if union else 1.0,
        "tracer_hits": int(a.sum()),
        "pyvista_hits": int(b.sum()),
        "both_hit": int(both.sum()),
        "tracer_only": int(np.sum(a & ~b)),
        "pyvista_only": int(np.sum(b & ~a)),
    }
    if both.any():
        nt = view_normals(trace.normals, trace.camera)[both]
        npv = pvr.view_normals[both]
        cosang = np.clip(np.sum(nt * npv, axis=1), -1.0, 1.0)
        ang = np.degrees(np.arccos(cosang))
        dz = np.abs(pvr.depth[both] - trace.depth[both].astype(np.float64)) / diagonal
        out.update(normal_angle_mean_deg=float(ang.mean()),
                   normal_angle_median_deg=float(np.median(ang)),
                   normal_angle_p95_deg=float(np.percentile(ang, 95)),
                   depth_error_rel_diag=float(dz.mean()),
                   depth_error_p95_rel_diag=float(np.percentile(dz, 95)))
    else:
        out.update(normal_angle_mean_deg=None, normal_angle_median_deg=None,
                   normal_angle_p95_deg=None,
                   depth_error_rel_diag=None, depth_error_p95_rel_diag=None)
    return out


def diff_image(trace, pvr, diagonal, background=(255, 255, 255), vmax=DIFF_VMAX):
    """``diff.png``: depth difference where both hit, mask disagreement elsewhere.

    Pixels both hit: ``|t_pyvista - t_tracer| / diagonal`` in ``inferno``, 0 (black) to
    ``vmax`` (pale yellow, clipped above). Only the tracer hit: blue; only pyvista: green;
    neither: ``background``.
    """
    both = trace.hit & pvr.hit
    rel = np.where(both, np.abs(pvr.depth - trace.depth) / diagonal, 0.0)
    img = false_color(rel, mask=both, cmap="inferno", vmin=0.0, vmax=vmax,
                      background=tuple(background))
    img[trace.hit & ~pvr.hit] = TRACER_ONLY
    img[pvr.hit & ~trace.hit] = PYVISTA_ONLY
    return img


def side_by_side(*images, gap=2):
    """Concatenate same-height RGB images left to right with grey ``gap``-pixel separators."""
    H = images[0].shape[0]
    sep = np.empty((H, gap, 3), dtype=np.uint8)
    sep[:] = SEPARATOR
    parts = []
    for k, img in enumerate(images):
        if k:
            parts.append(sep)
        parts.append(np.asarray(img, dtype=np.uint8))
    return np.concatenate(parts, axis=1)


#: titles of the three panels of ``side_by_side.png``
PANEL_TITLES = ("sphere tracer", "pyvista marching cubes", "difference")


def labelled_side_by_side(tracer_rgb, pyvista_rgb, diff, vmax=DIFF_VMAX, panel_px=256):
    """``side_by_side.png``: the three images titled ``PANEL_TITLES``, with a colour bar
    for the difference (``|depth difference| / diagonal`` in ``inferno``, 0 to ``vmax``) and
    a legend for the pixels only one side hit. Returns an ``(H', W', 3)`` uint8 array.

    Each panel is shown at least ``panel_px`` pixels wide (nearest-neighbour enlargement of
    small renders) so that the titles stay readable.
    """
    import matplotlib  # matplotlib (studies extra): loaded on use

    matplotlib.use("Agg", force=False)
    # matplotlib (studies extra): loaded on use
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.colors import Normalize
    from matplotlib.figure import Figure
    from matplotlib.patches import Patch

    H, W = tracer_rgb.shape[:2]
    scale = max(1, -(-panel_px // max(W, 1)))
    dpi = 100.0
    pw, ph = W * scale / dpi, H * scale / dpi
    fig = Figure(figsize=(3 * pw + 1.6, ph + 1.0), dpi=dpi)
    FigureCanvasAgg(fig)
    left, gap, top = 0.15 / (3 * pw + 1.6), 0.1 / (3 * pw + 1.6), 1.0 - 0.45 / (ph + 1.0)
    bottom = 0.55 / (ph + 1.0)
    fw = pw / (3 * pw + 1.6)
    axes = []
    for k, (img, title) in enumerate(zip((tracer_rgb, pyvista_rgb, diff), PANEL_TITLES)):
        ax = fig.add_axes([left + k * (fw + gap), bottom, fw, top - bottom])
        ax.imshow(np.asarray(img, dtype=np.uint8), interpolation="nearest")
        ax.set_title(title, fontsize=10)
        ax.set_xticks([])
        ax.set_yticks([])
        axes.append(ax)
    cax = fig.add_axes([left + 3 * (fw + gap) + 0.01, bottom, 0.12 / (3 * pw + 1.6),
                        top - bottom])
    sm = matplotlib.cm.ScalarMappable(norm=Normalize(0.0, 100.0 * vmax), cmap="inferno")
    cb = fig.colorbar(sm, cax=cax)
    cb.set_label("|depth difference|, % of diagonal", fontsize=8)
    cb.ax.tick_params(labelsize=7)
    fig.legend(handles=[Patch(color=np.array(TRACER_ONLY) / 255, label="only the tracer hit"),
                        Patch(color=np.array(PYVISTA_ONLY) / 255, label="only pyvista hit")],
               loc="lower center", ncol=2, fontsize=8, frameon=False)
    fig.canvas.draw()
    return np.asarray(fig.canvas.buffer_rgba())[..., :3].copy()


class Comparison(NamedTuple):
    """Result of :func:`compare_scene`: ``metrics`` (dict, as written to metrics.json), the
    ``trace`` (RenderResult) and ``pyvista`` (PyvistaRender), the normal-shaded ``tracer_rgb``,
    the ``diff`` image and the ``surface`` (pyvista.PolyData)."""

    metrics: dict
    trace: object
    pyvista: PyvistaRender
    tracer_rgb: np.ndarray
    diff: np.ndarray
    surface: object


def compare_scene(scene, grid=128, trace=None):
    """Sphere-trace ``scene`` and rasterise its ``grid``-point marching-cubes isosurface.

    Parameters
    ----------
    scene : tracer.scenes.scene.Scene
        Its width and height are the image size.
    grid : int, default 128
        Grid points per axis over the grown scene box.
    trace : tracer.rendering.frame.RenderResult, optional
        A render of ``scene`` to reuse (otherwise rendered here).

    Returns
    -------
    Comparison
    """

    t_start = time.perf_counter()
    camera = camera_of(scene)
    secs = {}
    t0 = time.perf_counter()
    if trace is None:
        trace = render(scene)
    secs["tracer"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    surface = isosurface(scene, grid)
    secs["isosurface"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    focal = float(np.linalg.norm(np.asarray(scene.camera.dest) - np.asarray(scene.camera.origin)))
    pvr = render_isosurface(surface, camera, background=scene.film.background,
                            focal_distance=focal if focal > 0 else 1.0)
    secs["pyvista"] = time.perf_counter() - t0
    diag = scene.diagonal if scene.diagonal > 0 else 1.0
    metrics = {"scene": scene.name, "mode": scene.march.mode, "grid": int(grid),
               "size": [int(scene.film.width), int(scene.film.height)]}
    metrics.update(compare_renders(trace, pvr, diag))
    tracer_rgb = shade_normals(view_normals(trace.normals, trace.camera), trace.hit,
                               background=tuple(scene.film.background))
    img = compare_images(tracer_rgb, pvr.rgb)
    lo, hi = (np.asarray(v) for v in scene_box(scene))
    metrics.update(
        image_mean_abs_error=img.mean_abs_error, image_fraction_over_16=img.fraction_over,
        diagonal=diag, grid_spacing=((hi - lo) / (int(grid) - 1)).tolist(),
        grid_spacing_rel_diag=float(np.max((hi - lo) / (int(grid) - 1)) / diag),
        triangles=int(surface.n_cells), objects=len(scene.objects),
        grid_evaluated_fraction=float(surface.field_data["evaluated_fraction"][0]))
    secs["total"] = time.perf_counter() - t_start
    metrics["seconds"] = {k: round(v, 3) for k, v in secs.items()}
    diff = diff_image(trace, pvr, diag, background=scene.film.background)
    return Comparison(metrics=metrics, trace=trace, pyvista=pvr, tracer_rgb=tracer_rgb,
                      diff=diff, surface=surface)


def scene_box(scene):
    """The grown scene box ``(lo, hi)`` that the grid spans (the tracer's ray box)."""
    return scene_arrays(scene)[4:6]


# ------------------------------------------------------------------------ command line
def add_arguments(p):
    """Arguments of ``tracer compare``."""
    p.add_argument("scene", help="scene JSON file")
    p.add_argument("-o", "--output", metavar="DIR",
                   help="output folder (default: renders/compare/<scene name>)")
    p.add_argument("--grid", type=int, default=128, metavar="N",
                   help="grid points per axis for marching cubes (default 128)")
    p.add_argument("--size", nargs=2, type=int, metavar=("W", "H"),
                   help="image size in pixels (default: the scene's)")
    p.add_argument("--exact", action="store_true",
                   help="compare the exact-offset isosurface (d - offset = 0) on both sides")
    p.add_argument("--threads", type=int, help="number of threads (default: all cores)")
    p.add_argument("--overwrite", action="store_true", help="replace existing output files")
    p.add_argument("-q", "--quiet", action="store_true", help="no summary line")


def needs(args):
    """The optional packages of a comparison (:mod:`tracer.cli` checks them first): pyvista for
    the isosurface, matplotlib for the figure, Pillow for the PNGs, trimesh for the scene's mesh
    files that our own readers do not read."""

    out = ["pyvista", "matplotlib", "PIL"]
    return out + (["trimesh"] if any(map(needs_trimesh, mesh_paths(args.scene))) else [])


def run(args):
    """Compare; returns the exit status (0, or 2 with one ``error:`` line)."""

    if not 2 <= args.grid <= 512:
        raise CLIError(f"--grid must be between 2 and 512, got {args.grid}")
    if args.size and (args.size[0] <= 0 or args.size[1] <= 0):
        raise CLIError(f"--size must be two positive integers, got {args.size[0]} {args.size[1]}")
    name = os.path.splitext(os.path.basename(args.scene))[0]
    out_dir = args.output or os.path.join("renders", "compare", name)
    if os.path.exists(out_dir) and not os.path.isdir(out_dir):
        raise CLIError(f"output folder is a file: {out_dir}")
    paths = [os.path.join(out_dir, f) for f in OUTPUT_FILES]
    overrides = {}
    if args.size:
        overrides["width"], overrides["height"] = args.size
    if args.exact:
        overrides["mode"] = "exact"
    scene = load_scene(args.scene, overrides)
    problem = offscreen_problem()
    if problem is not None:
        raise CLIError(f"VTK cannot render off-screen here: {problem}")
    check_outputs(paths, args.overwrite)
    result = compare_scene(scene, grid=args.grid)
    m = result.metrics
    m["scene_path"] = os.path.abspath(args.scene)
    row_imgs = (result.tracer_rgb, result.pyvista.rgb, result.diff)
    save_png(paths[1], result.tracer_rgb, overwrite=args.overwrite)
    save_png(paths[2], result.pyvista.rgb, overwrite=args.overwrite)
    save_png(paths[3], labelled_side_by_side(*row_imgs), overwrite=args.overwrite)
    save_png(paths[4], result.diff, overwrite=args.overwrite)
    with atomic_write(paths[0], overwrite=args.overwrite) as tmp:
        with open(tmp, "w", encoding="utf-8") as fh:
            json.dump(m, fh, indent=2)
            fh.write("\n")
    if not args.quiet:
        def fmt(v, spec):
            return "n/a" if v is None else format(v, spec)

        print(f"Compared {name} ({m['mode']}, {m['size'][0]}x{m['size'][1]} px, grid "
              f"{m['grid']}): IoU {m['iou']:.4f}, normal angle mean "
              f"{fmt(m['normal_angle_mean_deg'], '.2f')} deg / p95 "
              f"{fmt(m['normal_angle_p95_deg'], '.2f')} deg, depth error "
              f"{fmt(m['depth_error_rel_diag'], '.2e')} x diagonal, in "
              f"{m['seconds']['total']:.1f} s. Wrote {len(paths)} files to {out_dir}.")
    sys.stdout.flush()
    return 0
