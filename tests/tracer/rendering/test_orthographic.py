"""The orthographic camera (issue 64), through the camera seam of tracer.rendering.camera.

The analytic answer: the exact-offset surface of one point at offset ``R`` is a sphere of
radius ``R``, and its orthographic silhouette is a disc of radius ``R`` in scene units at any
distance; every hit lies at depth ``z0 - sqrt(R^2 - rho^2)`` in front of the image plane. The
kernels' rays are held to the numpy twins (another pipeline), the cone passes' beam bounds to
brute force over every pixel ray, and each interface (``render_mesh``, ``scene_from_field``,
scene files, the command line) to the same camera.
"""

import json

import numpy as np
import numpy.testing as npt
import pytest

import tracer
from smoothdist import SmoothDistanceField
from tracer.cli import main
from tracer.rendering.camera import (LookAt, block_rays, camera_ray, far_depth, footprint,
                                     look_at, pixel_points, primary_rays, project,
                                     pyvista_camera_params, ray_origins, sample_rays)
from tracer.rendering.renderer import render
from tracer.scenes.scene import load_scene, scene_from_field

R = 1.0
#: the silhouette band where a grazing ray may hit or miss: the hit threshold eps is 1e-4
#: scene units here (1e-4 x the surface's size for data of no extent), this is ten times it
BAND = 1e-3


def ortho(width=24, height=10, view_width=3.0):
    return look_at([1.5, -2.0, 3.0], [0.2, 0.4, -0.1], [0.3, 1.0, 0.2], width, height,
                   projection="orthographic", view_width=view_width)


# ------------------------------------------------------------------------ the camera alone
@pytest.mark.parametrize("size", [(24, 10), (10, 24), (7, 7)])
def test_orthographic_rays_are_parallel_and_span_the_view_width(size):
    cam = ortho(*size, view_width=2.5)
    arr = cam.as_array()
    rays = np.array([[camera_ray(arr, float(r), float(c)) for c in range(cam.width)]
                     for r in range(cam.height)])
    npt.assert_allclose(rays[..., 3:], np.broadcast_to(cam.forward, rays[..., 3:].shape),
                        rtol=0, atol=0)
    origins = rays[..., :3]
    # every origin on the image plane through camera.origin
    npt.assert_allclose((origins - cam.origin) @ cam.forward, 0.0, atol=1e-15)
    # neighbouring pixels one pixel apart, square pixels of view_width / W
    step = cam.view_width / cam.width
    npt.assert_allclose(np.diff(origins, axis=1) @ cam.horizontal, step, rtol=1e-12)
    npt.assert_allclose(np.diff(origins, axis=0) @ cam.vertical, -step, rtol=1e-12)
    npt.assert_allclose(cam.pixel_size(5.0), step, rtol=1e-15)
    npt.assert_allclose(footprint(arr), (step, 0.0), rtol=1e-15)
    # the image spans view_width: column 0 sits at -view_width / 2 (the authors' sampling,
    # no half-pixel offset), as the perspective camera's column 0 sits at dx = -0.5 scale_x
    npt.assert_allclose((origins[0, 0] - cam.origin) @ cam.horizontal, -0.5 * cam.view_width,
                        rtol=1e-12)


@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
def test_numpy_twins_equal_the_kernel(projection):
    """sample_rays / primary_rays / ray_origins (the film's) against camera_ray (the kernels')
    at pixel centres and sub-pixel samples."""
    cam = look_at([1.5, -2.0, 3.0], [0.2, 0.4, -0.1], [0.3, 1.0, 0.2], 13, 9,
                  projection=projection, view_width=2.0 if projection == "orthographic" else None)
    arr = cam.as_array()
    rng = np.random.default_rng(1)
    rows = rng.uniform(-1, cam.height, 50)
    cols = rng.uniform(-1, cam.width, 50)
    org, dirs = sample_rays(arr, rows, cols)
    kernel = np.array([camera_ray(arr, r, c) for r, c in zip(rows, cols)])
    npt.assert_allclose(np.broadcast_to(org, dirs.shape), kernel[:, :3], rtol=0, atol=1e-14)
    npt.assert_allclose(dirs, kernel[:, 3:], rtol=0, atol=1e-15)
    grid = np.array([[camera_ray(arr, float(r), float(c)) for c in range(cam.width)]
                     for r in range(cam.height)])
    npt.assert_allclose(primary_rays(cam), grid[..., 3:], rtol=0, atol=1e-15)
    npt.assert_allclose(np.broadcast_to(ray_origins(cam), grid[..., :3].shape), grid[..., :3],
                        rtol=0, atol=1e-14)


def test_project_inverts_orthographic_rays():
    cam = ortho()
    t = np.linspace(0.5, 4.0, cam.width * cam.height).reshape(cam.height, cam.width)
    P = pixel_points(cam, t).reshape(-1, 3)
    rows, cols, depth = project(cam, P)
    rr, cc = np.mgrid[0:cam.height, 0:cam.width]
    npt.assert_allclose(rows, rr.ravel(), atol=1e-9)
    npt.assert_allclose(cols, cc.ravel(), atol=1e-9)
    npt.assert_allclose(depth, t.ravel(), atol=1e-12)
    # behind the image plane: NaN, as for the pinhole
    assert np.isnan(project(cam, cam.origin - cam.forward)[0]).all()


@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
def test_block_rays_bound_every_pixel_ray(projection):
    """What the cone passes assume: every ray of a pixel block stays within ``near + spread t``
    of the beam's central ray (brute force over the block's rays, sub-pixel samples too)."""
    cam = look_at([1.5, -2.0, 3.0], [0.2, 0.4, -0.1], [0.3, 1.0, 0.2], 31, 17,
                  projection=projection, view_width=2.0 if projection == "orthographic" else None)
    arr = cam.as_array()
    t = np.linspace(0.0, 20.0, 41)
    for r_lo, r_hi, c_lo, c_hi in ((0, 4, 0, 4), (5, 8, 27, 31), (-1, 2, 14, 17), (10, 17, 3, 9)):
        ox, oy, oz, ux, uy, uz, near, spread = block_rays(arr, r_lo, r_hi, c_lo, c_hi)
        assert near >= 0.0 and spread >= 0.0
        assert (near == 0.0) == (projection == "perspective")
        assert (spread == 0.0) == (projection == "orthographic")
        rr, cc = np.meshgrid(np.linspace(r_lo, r_hi - 1, 7), np.linspace(c_lo, c_hi - 1, 7))
        org, dirs = sample_rays(arr, rr.ravel(), cc.ravel())
        org = np.broadcast_to(org, dirs.shape)
        central = np.array([ox, oy, oz]) + t[:, None] * np.array([ux, uy, uz])
        pts = org[None] + t[:, None, None] * dirs[None]
        gap = np.linalg.norm(pts - central[:, None], axis=2)
        assert np.all(gap <= (near + spread * t)[:, None] + 1e-12)
        # and the bound is not loose by more than its margin (the corners reach it)
        assert np.isclose(gap.max(), (near + spread * t).max(), rtol=1e-3)


@pytest.mark.parametrize("projection", ["perspective", "orthographic"])
def test_far_depth_leaves_the_box(projection):
    cam = ortho() if projection == "orthographic" else look_at(
        [1.5, -2.0, 3.0], [0.2, 0.4, -0.1], [0.3, 1.0, 0.2], 24, 10)
    lo, hi = np.array([-0.5, -0.2, -1.0]), np.array([0.7, 0.9, 0.3])
    t_far = far_depth(cam.as_array(), lo, hi)
    P = pixel_points(cam, np.full((cam.height, cam.width), t_far * (1 + 1e-12)))
    inside = np.all((P >= lo) & (P <= hi), axis=-1)
    assert not inside.any()
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                        for z in (lo[2], hi[2])])
    reach = ((corners - cam.origin) @ cam.forward if projection == "orthographic"
             else np.linalg.norm(corners - cam.origin, axis=1))
    assert t_far == pytest.approx(reach.max(), rel=1e-12)


def test_look_at_checks_the_projection():
    pose = ([0, 0, 3], [0, 0, 0], [0, 1, 0], 8, 8)
    with pytest.raises(ValueError, match="projection must be one of perspective, orthographic"):
        look_at(*pose, projection="fisheye")
    with pytest.raises(ValueError, match="view_width must be a finite number > 0"):
        look_at(*pose, projection="orthographic", view_width=-1.0)
    with pytest.raises(ValueError, match="view_width must be a finite number > 0"):
        look_at(*pose, projection="orthographic", view_width=float("nan"))
    with pytest.raises(ValueError, match="orthographic projection only"):
        look_at(*pose, view_width=2.0)
    # left out: the width the pinhole sees at dest (3 units away: 3 x scale_x)
    assert look_at(*pose, projection="orthographic").view_width == pytest.approx(3.0)
    wide = look_at([0, 0, 3], [0, 0, 0], [0, 1, 0], 16, 8, projection="orthographic")
    assert wide.view_width == pytest.approx(6.0)


def test_pyvista_params_of_an_orthographic_camera():
    cam = ortho(24, 10, view_width=3.0)
    p = pyvista_camera_params(cam)
    assert p["parallel_projection"] is True
    assert p["parallel_scale"] == pytest.approx(0.5 * 3.0 * 10 / 24)     # half the height
    assert pyvista_camera_params(look_at([0, 0, 3], [0, 0, 0], [0, 1, 0], 8, 8))[
        "parallel_projection"] is False


# ---------------------------------------------------------------- renders: the analytic sphere
def _ball_scene(distance, projection, size=(48, 36), view_width=3.2):
    """One point at the origin, exact mode, offset R: the sphere of radius R, seen from
    ``distance`` along +z."""
    field = SmoothDistanceField(np.zeros((1, 3)))
    return scene_from_field(field, alpha=10.0, mode="exact", offset=R, width=size[0],
                            height=size[1], camera=([0.0, 0.0, distance], [0, 0, 0], [0, 1, 0]),
                            projection=projection,
                            view_width=view_width if projection == "orthographic" else None)


def _radius_of(cam):
    """``rho (H, W)``: each pixel ray's distance from the sphere's centre line (z axis)."""
    org = np.broadcast_to(ray_origins(cam), (cam.height, cam.width, 3))
    return np.hypot(org[..., 0], org[..., 1])


@pytest.mark.parametrize("cone", [True, False])
def test_orthographic_silhouette_is_a_disc_of_the_radius_at_any_distance(cone):
    hits = []
    for distance in (3.0, 10.0):
        res = render(_ball_scene(distance, "orthographic"), cone=cone)
        assert res.camera.orthographic
        rho = _radius_of(res.camera)
        clear = np.abs(rho - R) > BAND
        npt.assert_array_equal(res.hit[clear], (rho < R)[clear])
        # the depth in front of the image plane is the analytic one, within eps along a
        # ray that meets the surface at cosine cos
        h = res.hit & clear
        cos = np.sqrt(1.0 - (rho[h] / R) ** 2)
        want = distance - R * cos
        assert np.all(np.abs(res.depth[h] - want) <= 1e-4 / cos + 1e-6)
        hits.append(res.hit)
    # the same disc from both distances (the pinhole's would shrink to a tenth of the area)
    assert (hits[0] != hits[1]).sum() <= np.sum(np.abs(rho - R) <= BAND)
    disc = np.pi * (R / res.camera.pixel_size()) ** 2
    assert abs(hits[0].sum() - disc) <= 2 * np.pi * R / res.camera.pixel_size()


def test_perspective_disc_shrinks_with_distance():
    """The check above can fail: the pinhole's disc is not the same at both distances."""
    near, far = (render(_ball_scene(d, "perspective")).hit.sum() for d in (3.0, 10.0))
    assert far < 0.5 * near


def test_orthographic_samples_and_lit_look():
    """Anti-aliasing samples (their rays start on the image plane too) and the lit look: the
    coverage of each pixel is the share of its tent filter inside the disc."""
    scene = _ball_scene(4.0, "orthographic", size=(40, 40), view_width=3.0)
    scene.film = scene.film.__class__(**{**scene.film.__dict__, "samples": 8,
                                         "adaptive": True, "shading": "lit"})
    res = render(scene)
    rho = _radius_of(res.camera)
    px = res.camera.pixel_size()
    inside, outside = rho < R - 2 * px, rho > R + 2 * px
    assert np.all(res.alpha[inside] == 1.0)
    assert np.all(res.alpha[outside] == 0.0)
    edge = ~inside & ~outside
    assert 0.0 < res.alpha[edge].mean() < 1.0


# ------------------------------------------------------------------------------ interfaces
def test_render_mesh_frames_an_orthographic_view(tmp_path):
    trimesh = pytest.importorskip("trimesh")
    mesh = trimesh.creation.box(extents=(2.0, 1.0, 0.5))
    res = tracer.render_mesh(mesh, size=(64, 48), shading="normals", projection="orthographic",
                             progress=None)
    cam = res.camera
    assert cam.orthographic and cam.view_width > 2.0
    # framed: the box fills most of the width, with a free border on every side
    cols = np.flatnonzero(res.hit.any(axis=0))
    rows = np.flatnonzero(res.hit.any(axis=1))
    assert cols[0] > 0 and cols[-1] < 63 and rows[0] > 0 and rows[-1] < 47
    assert cols[-1] - cols[0] > 0.8 * 64
    # a render's camera renders the same view again, orthographic still
    again = tracer.render_mesh(mesh, size=(64, 48), shading="normals", camera=cam,
                               progress=None)
    assert again.camera.orthographic and again.camera.view_width == cam.view_width
    npt.assert_array_equal(again.hit, res.hit)
    # a width of our own: the box's width in pixels follows it
    half = tracer.render_mesh(mesh, size=(64, 48), shading="normals", camera=cam,
                              projection="orthographic", view_width=2 * cam.view_width,
                              progress=None)
    wide = np.flatnonzero(half.hit.any(axis=0))
    assert abs((wide[-1] - wide[0]) - 0.5 * (cols[-1] - cols[0])) <= 2


def test_scene_file_camera_projection(tmp_path):
    data = {"camera": {"origin": [0, 0, 3], "dest": [0, 0, 0], "up": [0, 1, 0],
                       "projection": "orthographic", "view_width": 3.2},
            "objects": [{"path": "pt.xyz", "alpha": 10, "kind": "points"}],
            "mode": "exact", "offset": 1.0, "width": 48, "height": 36}
    (tmp_path / "pt.xyz").write_text("0 0 0\n")
    path = tmp_path / "ball.json"
    path.write_text(json.dumps(data))
    scene = load_scene(path)
    assert scene.camera == LookAt(scene.camera.origin, scene.camera.dest, scene.camera.up,
                                  "orthographic", 3.2)
    res = render(scene)
    ref = render(_ball_scene(3.0, "orthographic"))
    npt.assert_array_equal(res.hit, ref.hit)
    # the command line's options override the file's
    over = load_scene(path, {"view_width": 6.4})
    assert over.camera.view_width == 6.4
    for cam, message in (({"projection": "fisheye"}, "camera.projection must be one of"),
                         ({"projection": "orthographic", "view_width": 0},
                          "camera.view_width must be > 0"),
                         ({"view_width": 2.0}, "camera.view_width applies to the orthographic")):
        bad = dict(data, camera=dict(origin=[0, 0, 3], dest=[0, 0, 0], up=[0, 1, 0], **cam))
        path.write_text(json.dumps(bad))
        with pytest.raises(ValueError, match=message):
            load_scene(path)


def test_cli_projection_and_save_scene(tmp_path, capsys):
    (tmp_path / "pt.xyz").write_text("0 0 0\n1 0 0\n0 1 0\n")
    out, saved = tmp_path / "o.png", tmp_path / "o.json"
    assert main(["render", str(tmp_path / "pt.xyz"), "--size", "32", "24", "--projection",
                 "orthographic", "--view-width", "4", "--shading", "normals", "-o", str(out),
                 "--save-scene", str(saved), "-q"]) == 0
    cam = json.loads(saved.read_text())["camera"]
    assert cam["projection"] == "orthographic" and cam["view_width"] == 4.0
    again = tmp_path / "again.png"
    assert main(["render", str(saved), "-o", str(again), "-q"]) == 0
    assert out.read_bytes() == again.read_bytes()
    assert main(["render", str(tmp_path / "pt.xyz"), "--view-width", "4", "-o",
                 str(tmp_path / "x.png"), "-q"]) == 2
    assert "--view-width applies to --projection orthographic" in capsys.readouterr().err
    assert not (tmp_path / "x.png").exists()


def test_pyvista_comparison_uses_a_parallel_projection():
    """``tracer compare``'s VTK camera (pyvista_camera_params) for an orthographic scene: the
    marching-cubes sphere seen with parallel projection matches the trace (a perspective VTK
    camera from 3 radii draws it larger: IoU 0.80 against 0.98 measured)."""
    pytest.importorskip("pyvista")
    from tracer.checks import compare

    problem = compare.offscreen_problem()
    if problem is not None:
        pytest.skip(f"VTK cannot render off-screen here: {problem}")
    m = compare.compare_scene(_ball_scene(3.0, "orthographic", size=(48, 48)), grid=48).metrics
    assert m["both_hit"] > 300, m
    assert m["iou"] >= 0.97, m
    assert m["depth_error_rel_diag"] <= 0.02, m


def test_image_plane_through_the_surface_is_refused():
    """Parallel rays start on the image plane: a plane that cuts the sphere (its centre
    outside it) would start rays inside the surface, drawn as hits at depth 0; it is refused
    with the distance to move back, and moving back that far renders."""
    from tracer.errors import RenderError

    field = SmoothDistanceField(np.zeros((1, 3)))

    def scene(z):
        return scene_from_field(field, alpha=10.0, mode="exact", offset=R, width=32, height=32,
                                camera=([2.5, 0, z], [2.5, 0, -1], [0, 1, 0]),
                                projection="orthographic", view_width=8.0)

    with pytest.raises(RenderError, match="image plane .* cuts the surface") as err:
        render(scene(0.5))
    back = float(str(err.value).split("by ")[-1].split(" ")[0])
    res = render(scene(0.5 + back))
    assert res.hit.any() and np.nanmin(res.depth) > 0.0
