"""End-to-end tests of ``tracer.rendering.renderer``: tiny renders checked against independent computations.

Every render here is at most 64 x 64 (most are 32 x 32) so that the whole file runs in seconds on
a shared 2-core machine. The expected images are computed without the march kernels: ray-sphere
intersections in numpy over :func:`tracer.rendering.camera.primary_rays`, silhouettes through
:func:`tracer.rendering.camera.project`, and the isosurface radius found by bisection on
``SmoothDistanceField.smooth_distance`` (the batch query path, not the tracer's).
"""

import os
import subprocess
import sys
from pathlib import Path

import numba
import numpy as np
import numpy.testing as npt
import pytest

from smoothdist import SmoothDistanceField
from tracer.rendering.camera import look_at, primary_rays, project
from tracer.errors import RenderError
from tracer.rendering.renderer import render
from tracer.scenes.scene import Scene, SceneObject, load_scene, scene_from_field

ROOT = Path(__file__).resolve().parents[3]
SCENES = ROOT / "scenes"


# ----------------------------------------------------------------------------- helpers
def fibonacci_sphere(n, radius=1.0, centre=(0.0, 0.0, 0.0)):
    """``n`` nearly uniform points on a sphere (Fibonacci lattice), ``(n, 3)``."""
    i = np.arange(n) + 0.5
    phi = np.arccos(1.0 - 2.0 * i / n)
    theta = np.pi * (1.0 + 5.0 ** 0.5) * i
    unit = np.stack([np.cos(theta) * np.sin(phi), np.sin(theta) * np.sin(phi), np.cos(phi)], 1)
    return radius * unit + np.asarray(centre, dtype=float)


def ray_sphere(origin, rays, centre, radius):
    """First intersection of unit rays from ``origin`` with a sphere.

    Returns ``(hit (H, W) bool, t (H, W) with NaN on misses, closest (H, W), cos_incidence)``
    where ``closest`` is the distance from the centre to the ray's line and ``cos_incidence``
    the cosine between the ray and the surface normal at the hit.
    """
    oc = np.asarray(origin, float) - np.asarray(centre, float)
    b = rays @ oc
    c = oc @ oc - radius * radius
    disc = b * b - c
    hit = (disc >= 0.0) & (-b > 0.0)
    root = np.sqrt(np.maximum(disc, 0.0))
    t = np.where(hit, -b - root, np.nan)
    closest = np.sqrt(np.maximum(oc @ oc - b * b, 0.0))
    return hit, t, closest, root / radius


def boundary_band(mask):
    """Pixels of ``mask`` with a differing 8-neighbour (either side of the silhouette)."""
    m = np.pad(mask, 1, mode="edge")
    H, W = mask.shape
    band = np.zeros_like(mask)
    for dr in (-1, 0, 1):
        for dc in (-1, 0, 1):
            band |= m[1 + dr:1 + dr + H, 1 + dc:1 + dc + W] != mask
    return band


def iso_radius(field, directions, alpha, beta, lo, hi, iters=60):
    """Outer radius of ``{d_hat = 0}`` along each unit direction (bisection, d_hat <= 0 inside)."""
    lo = np.full(len(directions), float(lo))
    hi = np.full(len(directions), float(hi))
    d_lo = field.smooth_distance(directions * lo[:, None], alpha=alpha, beta=beta)[0]
    d_hi = field.smooth_distance(directions * hi[:, None], alpha=alpha, beta=beta)[0]
    assert np.all(d_lo <= 0) and np.all(d_hi > 0), "bad bisection bracket"
    for _ in range(iters):
        mid = 0.5 * (lo + hi)
        d = field.smooth_distance(directions * mid[:, None], alpha=alpha, beta=beta)[0]
        inside = d <= 0
        lo = np.where(inside, mid, lo)
        hi = np.where(inside, hi, mid)
    return 0.5 * (lo + hi)


def hit_points(result):
    """World positions of the hits, ``(H, W, 3)`` (NaN on misses)."""
    rays = primary_rays(result.camera)
    return result.camera.origin + result.depth.astype(np.float64)[..., None] * rays


@pytest.fixture
def restore_threads():
    n = numba.get_num_threads()
    yield
    numba.set_num_threads(n)


@pytest.fixture(scope="module")
def scene_cache():
    """Shipped scenes loaded once per module (32 x 32), keyed by ``(name, beta)``."""
    cache = {}

    def get(name, **overrides):
        key = (name, tuple(sorted(overrides.items())))
        if key not in cache:
            cache[key] = load_scene(SCENES / f"{name}.json",
                                    {"width": 32, "height": 32, **overrides})
        return cache[key]

    return get


# ----------------------------------------------------------------------------- smooth sphere
FIB_N, FIB_R, FIB_ALPHA = 2000, 1.0, 20.0


@pytest.fixture(scope="module")
def fib_field():
    return SmoothDistanceField(fibonacci_sphere(FIB_N, FIB_R))


@pytest.mark.slow
def test_smooth_point_sphere_is_the_analytic_disc(fib_field):
    """2000 points on the unit sphere, alpha 20, beta 0: at this alpha the blobs merge into a
    closed sphere-like surface whose radius r_iso we find on the axis with the batch query
    (and in 64 other directions, to measure its bumpiness). The render's mask must be the
    analytic disc, its depth the ray-sphere(r_iso) intersection."""
    alpha, D = FIB_ALPHA, 4.0
    axis = np.array([[0.0, 0.0, 1.0]])
    r_axis = iso_radius(fib_field, axis, alpha, 0.0, FIB_R, FIB_R + 1.0)[0]
    # the conservative sandwich d - log(N)/alpha <= d_hat <= d puts the surface outside the data
    # (d_hat(R) <= 0 here) and at most log(N)/alpha beyond it
    assert FIB_R <= r_axis <= FIB_R + np.log(FIB_N) / alpha
    rng = np.random.default_rng(7)
    dirs = rng.normal(size=(64, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    radii = iso_radius(fib_field, dirs, alpha, 0.0, FIB_R, FIB_R + 1.0)
    r_min, r_max = min(radii.min(), r_axis), max(radii.max(), r_axis)
    assert r_max - r_min < 5e-3, "the test needs a nearly spherical isosurface"

    W, H = 40, 32  # non-square on purpose: the disc must stay round
    scene = scene_from_field(fib_field, alpha=alpha, beta=0.0, width=W, height=H,
                             camera=([0.0, 0.0, D], [0.0, 0.0, 0.0], [0.0, 1.0, 0.0]))
    res = render(scene)
    assert res.rgb.shape == (H, W, 3) and res.hit.shape == (H, W)
    assert res.depth.dtype == np.float32

    # (1) mask vs ray-sphere(r_axis), except a one-pixel band around the analytic silhouette
    rays = primary_rays(res.camera)
    ana, t_ana, _, cos_inc = ray_sphere(res.camera.origin, rays, np.zeros(3), r_axis)
    band = boundary_band(ana)
    assert ana.sum() > 100 and (~ana).sum() > 100
    bad = (res.hit != ana) & ~band
    assert not bad.any(), f"{bad.sum()} pixels off the analytic disc outside the boundary band"

    # (2) the same disc from the projected silhouette circle (tracer.rendering.camera.project)
    sil_z = r_axis ** 2 / D
    sil_rho = r_axis * np.sqrt(1.0 - (r_axis / D) ** 2)
    ang = np.linspace(0.0, 2.0 * np.pi, 90, endpoint=False)
    circle = np.stack([sil_rho * np.cos(ang), sil_rho * np.sin(ang), np.full_like(ang, sil_z)], 1)
    rows, cols, _ = project(res.camera, circle)
    crow, ccol, _ = project(res.camera, [0.0, 0.0, 0.0])
    radius_px = np.hypot(rows - crow[0], cols - ccol[0])
    npt.assert_allclose(radius_px, radius_px.mean(), rtol=1e-9)  # a circle, not an ellipse
    rr, cc = np.mgrid[0:H, 0:W]
    dist_px = np.hypot(rr - crow[0], cc - ccol[0])
    assert np.all(dist_px[res.hit] <= radius_px.mean() + 1.0)
    assert np.all(dist_px[~res.hit] >= radius_px.mean() - 1.0)

    # (3) every hit lies on the isosurface (radius within its measured range, plus eps)
    p = hit_points(res)
    rad = np.linalg.norm(p[res.hit], axis=1)
    assert rad.min() >= r_min - 1e-4 and rad.max() <= r_max + 1e-2

    # (4) depth = ray-sphere(r_axis) where the incidence is not grazing
    front = res.hit & ana & (cos_inc > 0.3)
    assert front.sum() > 100
    err = np.abs(res.depth[front] - t_ana[front])
    assert np.all(err <= (r_max - r_min + 2e-3) / cos_inc[front]), err.max()
    assert np.all(np.isnan(res.depth[~res.hit])) and np.all(np.isfinite(res.depth[res.hit]))

    # (5) normals are the sphere's radial directions, up to the surface's bumps
    radial = p[res.hit] / rad[:, None]
    assert np.all(np.sum(res.normals[res.hit] * radial, axis=1) > 0.98)


# ----------------------------------------------------------------------------- exact sphere
def _exact_single_point_check(res, centre, r, eps):
    rays = primary_rays(res.camera)
    ana, t_ana, closest, cos_inc = ray_sphere(res.camera.origin, rays, centre, r)
    assert ana.sum() > 50 and (~ana).sum() > 50
    # the hit test d - r <= eps also accepts rays that pass within eps of the sphere
    undecided = np.abs(closest - r) <= 2 * eps
    bad = (res.hit != ana) & ~undecided
    assert not bad.any(), f"{bad.sum()} pixels differ from the analytic sphere mask"
    h = res.hit & ana
    p = hit_points(res)[h]
    rad = np.linalg.norm(p - centre, axis=1)
    f32 = 2e-7 * np.nanmax(res.depth)  # float32 rounding of the depth buffer
    assert rad.min() >= r - f32 and rad.max() <= r + eps + f32
    # sphere tracing an exact distance never overshoots and stops within eps of the surface
    t = res.depth[h].astype(np.float64)
    assert np.all(t <= t_ana[h] + f32)
    assert np.all(t_ana[h] - t <= eps / np.maximum(cos_inc[h], 1e-3) + f32)
    # normals are the exact radial directions
    npt.assert_allclose(res.normals[h], (p - centre) / rad[:, None], atol=1e-5)


def test_exact_single_point_hits_the_offset_sphere():
    centre, r, eps = np.array([0.2, -0.1, 0.3]), 0.5, 1e-6
    field = SmoothDistanceField(centre[None, :])
    scene = scene_from_field(field, alpha=1.0 / r, mode="exact", offset=r, eps=eps, width=32,
                             height=32, camera=(centre + [0.3, 0.2, 2.5], centre, [0, 1, 0]))
    res = render(scene)
    _exact_single_point_check(res, centre, r, eps)
    assert res.bisections.sum() == 0  # an exact distance cannot overshoot


def test_exact_tiny_cloud_is_union_of_offset_spheres():
    """Two points, offset r: the surface is the union of two spheres; depth = nearer one."""
    P = np.array([[-0.4, 0.0, 0.0], [0.45, 0.1, -0.2]])
    r, eps = 0.3, 1e-6
    scene = scene_from_field(SmoothDistanceField(P), alpha=1.0 / r, mode="exact", offset=r,
                             eps=eps, width=32, height=24,
                             camera=([0.0, 0.3, 2.5], [0.0, 0.0, 0.0], [0, 1, 0]))
    res = render(scene)
    rays = primary_rays(res.camera)
    hits, ts, undecided = [], [], np.zeros(res.hit.shape, bool)
    for c in P:
        a, t, closest, _ = ray_sphere(res.camera.origin, rays, c, r)
        hits.append(a)
        ts.append(np.where(a, t, np.inf))
        undecided |= np.abs(closest - r) <= 2 * eps
    ana = hits[0] | hits[1]
    t_ana = np.minimum(ts[0], ts[1])
    assert hits[0].sum() > 10 and hits[1].sum() > 10
    assert not ((res.hit != ana) & ~undecided).any()
    h = res.hit & ana
    # exact up to eps: allow eps / cos at grazing pixels via a generous but tiny bound
    assert np.all(np.abs(res.depth[h] - t_ana[h]) <= 1e-4)


def test_exact_single_point_default_eps():
    # regression: a zero-size bbox once gave eps = 1e-16, below the rounding of d - offset
    centre, r = np.array([0.2, -0.1, 0.3]), 0.5
    field = SmoothDistanceField(centre[None, :])
    scene = scene_from_field(field, alpha=1.0 / r, mode="exact", offset=r, width=32, height=32,
                             camera=(centre + [0.3, 0.2, 2.5], centre, [0, 1, 0]))
    res = render(scene)
    _exact_single_point_check(res, centre, r, max(scene.eps, 1e-6))


# ----------------------------------------------------------------------------- shipped scenes
@pytest.mark.parametrize("name", ["bunny_points", "trefoil", "torus"])
def test_normals_face_the_camera(scene_cache, name):
    res = render(scene_cache(name))
    assert res.hit.sum() > 30, "the scene should be in view"
    rays = primary_rays(res.camera)
    n = res.normals[res.hit]
    npt.assert_allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-9)
    facing = np.sum(n * rays[res.hit], axis=1)
    assert np.all(facing < 0), f"{(facing >= 0).sum()} hit normals point away from the camera"
    assert np.all(res.normals[~res.hit] == 0)
    # misses are background white, hits are not
    assert np.all(res.rgb[~res.hit] == 255)
    assert not np.all(res.rgb[res.hit] == 255, axis=1).any()


@pytest.mark.parametrize("name", ["bunny_points", "mixed"])
def test_thread_count_does_not_change_the_render(scene_cache, restore_threads, name):
    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("numba was started with a single thread")
    scene = scene_cache(name)
    numba.set_num_threads(1)
    one = render(scene)
    numba.set_num_threads(2)
    two = render(scene)
    assert one.hit.any()
    for key in ("rgb", "hit", "depth", "normals", "steps", "leaves", "bisections"):
        npt.assert_array_equal(getattr(one, key), getattr(two, key), err_msg=key)


def test_mixed_scene_renders(scene_cache):
    res = render(scene_cache("mixed"))
    assert res.hit.sum() > 20
    assert np.all(np.isfinite(res.normals[res.hit]))
    npt.assert_allclose(np.linalg.norm(res.normals[res.hit], axis=1), 1.0, atol=1e-9)
    assert np.all(np.isfinite(res.depth[res.hit])) and np.all(np.isnan(res.depth[~res.hit]))
    s = res.summary()
    assert s["hits"] == int(res.hit.sum()) and (s["width"], s["height"]) == (32, 32)
    assert s["mean_steps"] >= 1 and s["mean_leaves"] > 0


@pytest.mark.slow
def test_barnes_hut_only_grows_the_surface(scene_cache):
    """beta > 0 only lowers d_hat, so the beta = 0 hit mask is inside the beta = 0.5 one."""
    exact = render(scene_cache("bunny_points", beta=0.0))
    bh = render(scene_cache("bunny_points", beta=0.5))
    assert exact.hit.sum() > 100
    lost = exact.hit & ~bh.hit
    assert lost.sum() <= 3, f"{lost.sum()} pixels hit at beta 0 but not at beta 0.5"
    assert lost[~boundary_band(exact.hit)].sum() == 0
    # where both hit, the Barnes-Hut surface is not farther away
    both = exact.hit & bh.hit
    assert np.all(bh.depth[both] <= exact.depth[both] + 1e-4 * scene_cache("bunny_points").diagonal)


# ----------------------------------------------------------------------------- geometry
TWO_CENTRES = np.array([[-0.6, 0.0, 0.0], [0.6, 0.0, 0.0]])
TWO_N, TWO_R, TWO_ALPHA = 300, 0.4, 20.0


@pytest.fixture(scope="module")
def two_clouds():
    return [fibonacci_sphere(TWO_N, TWO_R, c) for c in TWO_CENTRES]


def _two_sphere_scene(objects, width=32, height=32, beta=0.0,
                      camera=((0.0, 0.0, 3.0), (0.0, 0.0, 0.0), (0.0, 1.0, 0.0))):
    objs = [SceneObject(name=f"cloud{k}", field=f, alpha=TWO_ALPHA, alpha_u=TWO_ALPHA, beta=beta,
                        offset=1.0 / TWO_ALPHA) for k, f in enumerate(objects)]
    o, d, u = (np.asarray(v, float) for v in camera)
    scene = Scene(path="two.json", camera_origin=o, camera_dest=d, camera_up=u, objects=objs,
                  width=width, height=height, beta=beta)
    scene.eps = 1e-4 * scene.diagonal
    return scene


def test_two_separated_spheres_give_two_blobs(two_clouds):
    field = SmoothDistanceField(np.concatenate(two_clouds))
    res = render(_two_sphere_scene([field], width=48, height=32))
    cam = res.camera
    rows, cols, _ = project(cam, TWO_CENTRES)
    r0, c0 = np.round(rows).astype(int), np.round(cols).astype(int)
    assert res.hit[r0[0], c0[0]] and res.hit[r0[1], c0[1]]
    assert c0[0] < cam.width / 2 < c0[1]  # -x on the left, +x on the right
    # the gap between them (the view centre) is empty; every hit is within the projected
    # silhouette of a sphere grown by the largest inflation log(N)/alpha
    mid_r, mid_c, _ = project(cam, [0.0, 0.0, 0.0])
    assert not res.hit[int(round(mid_r[0])), int(round(mid_c[0]))]
    rays = primary_rays(cam)
    grown = TWO_R + np.log(2 * TWO_N) / TWO_ALPHA
    allowed = np.zeros(res.hit.shape, bool)
    for c in TWO_CENTRES:
        allowed |= ray_sphere(cam.origin, rays, c, grown)[0]
    assert not (res.hit & ~allowed).any()
    # exactly two 4-connected blobs, split by the vertical centre line
    left = res.hit[:, : int(mid_c[0])]
    right = res.hit[:, int(mid_c[0]) + 1:]
    assert left.sum() > 20 and right.sum() > 20
    assert not res.hit[:, int(mid_c[0])].any()
    assert _components(res.hit) == 2


def _components(mask):
    """Number of 4-connected components of a boolean image (small images only)."""
    seen = np.zeros_like(mask)
    count = 0
    H, W = mask.shape
    for r in range(H):
        for c in range(W):
            if mask[r, c] and not seen[r, c]:
                count += 1
                stack = [(r, c)]
                seen[r, c] = True
                while stack:
                    y, x = stack.pop()
                    for yy, xx in ((y - 1, x), (y + 1, x), (y, x - 1), (y, x + 1)):
                        if 0 <= yy < H and 0 <= xx < W and mask[yy, xx] and not seen[yy, xx]:
                            seen[yy, xx] = True
                            stack.append((yy, xx))
    return count


def test_nothing_in_view_is_a_white_image(two_clouds):
    field = SmoothDistanceField(np.concatenate(two_clouds))
    res = render(_two_sphere_scene([field], camera=((0.0, 0.0, 3.0), (0.0, 0.0, 6.0),
                                                   (0.0, 1.0, 0.0))))
    assert not res.hit.any()
    assert np.all(res.rgb == 255)
    assert np.all(np.isnan(res.depth))
    assert res.summary()["hits"] == 0
    # rays that leave the scene box at once cost no distance evaluation
    assert res.steps.max() == 0


def test_multi_object_logsumexp(two_clouds):
    """Two clouds as two objects: the second LogSumExp (same alpha) of two point-cloud d_hats is
    the d_hat of the merged cloud, so at beta = 0 the render equals the one-object render of the
    union; and its mask contains each single-object render's mask."""
    fields = [SmoothDistanceField(p) for p in two_clouds]
    multi = render(_two_sphere_scene(fields))
    merged = render(_two_sphere_scene([SmoothDistanceField(np.concatenate(two_clouds))]))
    assert multi.hit.sum() > 100
    assert (multi.hit != merged.hit).sum() <= 2
    both = multi.hit & merged.hit
    npt.assert_allclose(multi.depth[both], merged.depth[both], atol=1e-5)
    assert np.all(np.sum(multi.normals[both] * merged.normals[both], axis=-1) > 0.999)
    for f in fields:
        single = render(_two_sphere_scene([f]))
        assert single.hit.sum() > 30
        missing = single.hit & ~multi.hit
        assert missing.sum() <= 2 and not missing[~boundary_band(single.hit)].any()
        # the combined distance is lower, so the combined surface is not farther away (up to
        # the hit tolerance: a hit is a point with |d| <= eps, on either side of the surface)
        common = single.hit & multi.hit
        eps = _two_sphere_scene([f]).eps
        assert np.all(multi.depth[common] <= single.depth[common] + 3 * eps)


def test_camera_inside_the_surface_raises():
    P = np.array([[-0.05, 0.0, 0.0], [0.05, 0.0, 0.0]])
    field = SmoothDistanceField(P)
    # smooth: d_hat(0) = 0.05 - log(2) / 10 < 0 between the two blobs
    scene = scene_from_field(field, alpha=10.0, beta=0.0, width=8, height=8,
                             camera=([0.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]))
    with pytest.raises(RenderError, match="inside"):
        render(scene)
    # exact: the camera is within the offset of a point
    scene = scene_from_field(field, alpha=10.0, mode="exact", offset=0.2, width=8, height=8,
                             camera=([0.0, 0.1, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]))
    with pytest.raises(RenderError, match="inside"):
        render(scene)
    assert issubclass(RenderError, ValueError)


def test_row_zero_is_the_top():
    """A camera looking along -x with up +z (vertical = +z, horizontal = +y): a blob above the
    view centre must appear in the top rows, one to the right in the right columns."""
    origin, dest, up = np.array([3.0, 0.4, -0.2]), np.array([0.0, 0.4, -0.2]), np.array([0, 0, 1.0])
    cam = look_at(origin, dest, up, 32, 32)
    npt.assert_allclose(cam.vertical, [0, 0, 1], atol=1e-12)
    npt.assert_allclose(cam.horizontal, [0, 1, 0], atol=1e-12)
    blob = fibonacci_sphere(200, 0.12)
    for offset, check in ((0.7 * cam.vertical, lambda r, c: r.max() < 16),
                          (-0.7 * cam.vertical, lambda r, c: r.min() >= 16),
                          (0.7 * cam.horizontal, lambda r, c: c.min() >= 16)):
        field = SmoothDistanceField(blob + dest + offset)
        res = render(scene_from_field(field, alpha=30.0, beta=0.0, width=32, height=32,
                                      camera=(origin, dest, up)))
        rows, cols = np.nonzero(res.hit)
        assert rows.size > 5
        assert check(rows, cols), (offset, rows.min(), rows.max(), cols.min(), cols.max())


# ----------------------------------------------------------------------------- CLI
def _cli(*args, cwd):
    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    return subprocess.run([sys.executable, "-m", "tracer", "render", *map(str, args)], cwd=cwd,
                          capture_output=True, text=True, timeout=300, env=env)


@pytest.mark.slow
def test_cli_render_outputs_and_overwrite(tmp_path):
    from PIL import Image

    scene_path = SCENES / "trefoil.json"
    png, depth = tmp_path / "out" / "t.png", tmp_path / "out" / "t_depth.npy"
    W, H = 24, 20
    p = _cli(scene_path, "-o", png, "--depth", depth, "--size", W, H, "-q", cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    assert "Traceback" not in p.stderr

    expected = render(load_scene(scene_path, {"width": W, "height": H}))
    assert expected.hit.any()
    with Image.open(png) as img:
        assert img.mode == "RGB" and img.size == (W, H)
        rgb = np.asarray(img)
    npt.assert_array_equal(rgb, expected.rgb)
    d = np.load(depth, allow_pickle=False)
    assert d.dtype == np.float32 and d.shape == (H, W)
    npt.assert_array_equal(np.isnan(d), ~expected.hit)
    npt.assert_array_equal(d, expected.depth)

    # a second run without --overwrite refuses, with one line, and leaves the file alone
    before = png.read_bytes(), png.stat().st_mtime_ns, depth.read_bytes()
    p = _cli(scene_path, "-o", png, "--depth", depth, "--size", W, H, "--beta", 0.0, "-q",
             cwd=tmp_path)
    assert p.returncode == 2
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: output exists"), p.stderr
    assert (png.read_bytes(), png.stat().st_mtime_ns, depth.read_bytes()) == before

    # with --overwrite it replaces the files (here with a different size, to see the change)
    p = _cli(scene_path, "-o", png, "--depth", depth, "--size", 16, 12, "--overwrite", "-q",
             cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    with Image.open(png) as img:
        assert img.size == (16, 12)
    assert np.load(depth).shape == (12, 16)
    assert sorted(x.name for x in png.parent.iterdir()) == ["t.png", "t_depth.npy"]  # no temps


def test_cli_missing_scene_is_a_one_line_error(tmp_path):
    p = _cli(tmp_path / "nope.json", "-o", tmp_path / "x.png", cwd=tmp_path)
    assert p.returncode == 2
    assert "Traceback" not in p.stderr
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:") and "nope.json" in lines[0]
    assert not (tmp_path / "x.png").exists()


def test_render_overrides_travel_in_the_scene_it_returns():
    # render's newton / samples / adaptive are applied to a copy of the scene (the one the
    # result holds); the scene given is left as it was, and is returned as is without them
    field = SmoothDistanceField(fibonacci_sphere(40))
    scene = scene_from_field(field, alpha=40.0, width=24, height=20, view="front")
    plain = render(scene)
    assert plain.scene is scene
    res = render(scene, samples=3, newton=0.0)
    assert (res.scene.film.samples, res.scene.march.newton) == (3, 0.0)
    assert (scene.film.samples, scene.march.newton) == (1, scene_from_field.__kwdefaults__[
        "newton"])
    assert res.samples.max() == 3 and plain.samples.max() == 1
    assert res.scene.objects == scene.objects and res.scene.film.width == 24
    with pytest.raises(ValueError, match="samples"):
        render(scene, samples=0)
