"""Tests for tracer.rendering.camera: the authors' lookAt frame and pixel-to-ray mapping."""

import numpy as np
import numpy.testing as npt
import pytest

from tracer.rendering.camera import (
    Camera,
    default_camera_for_bounds,
    look_at,
    primary_rays,
    project,
    pyvista_camera_params,
    ray_direction,
)


@pytest.fixture
def tilted_camera():
    """A camera in general position with a wide image."""
    return look_at([1.5, -2.0, 3.0], [0.2, 0.4, -0.1], [0.3, 1.0, 0.2], 24, 10)


def test_authors_example_frame():
    """docs/authors-code.md §7: on +z looking at the origin, up +y."""
    cam = look_at([0, 0, 3], [0, 0, 0], [0, 1, 0], 64, 48)
    npt.assert_allclose(cam.forward, [0, 0, -1])
    npt.assert_allclose(cam.horizontal, [1, 0, 0])
    npt.assert_allclose(cam.vertical, [0, 1, 0])
    assert isinstance(cam, Camera)
    assert (cam.width, cam.height) == (64, 48)


def test_frame_is_orthonormal(tilted_camera):
    frame = np.stack([tilted_camera.forward, tilted_camera.horizontal, tilted_camera.vertical])
    npt.assert_allclose(frame @ frame.T, np.eye(3), atol=1e-14)
    # right-handed: horizontal x vertical points back at the viewer
    npt.assert_allclose(np.cross(tilted_camera.horizontal, tilted_camera.vertical),
                        -tilted_camera.forward, atol=1e-14)


@pytest.mark.parametrize("size", [(24, 10), (10, 24), (7, 7)])
def test_ray_direction_matches_primary_rays(size):
    cam = look_at([1.5, -2.0, 3.0], [0.2, 0.4, -0.1], [0.3, 1.0, 0.2], *size)
    rays = primary_rays(cam)
    assert rays.shape == (size[1], size[0], 3) and rays.dtype == np.float64
    arr = cam.as_array()
    assert arr.shape == (16,) and arr.dtype == np.float64
    kernel = np.array([[ray_direction(arr, r, c) for c in range(cam.width)]
                       for r in range(cam.height)])
    npt.assert_allclose(kernel, rays, rtol=0, atol=1e-15)
    npt.assert_allclose(np.linalg.norm(rays, axis=-1), 1.0, atol=1e-15)


def test_sample_at_half_size_is_forward(tilted_camera):
    # dx = 0 at col = W/2 and dy = 0 at y = H/2, i.e. row = H - 1 - H/2 (no half-pixel offset)
    cam = tilted_camera
    rays = primary_rays(cam)
    npt.assert_allclose(rays[cam.height // 2 - 1, cam.width // 2], cam.forward, atol=1e-15)
    # and the neighbouring centre pixels are within a pixel's angle of it
    centre = rays[cam.height // 2, cam.width // 2]
    assert np.dot(centre, cam.forward) > np.cos(2.0 / cam.height)


def test_corner_samples_follow_authors_mapping():
    cam = look_at([0, 0, 3], [0, 0, 0], [0, 1, 0], 8, 4)   # wide: x scaled by 2
    rays = primary_rays(cam)
    # top-left pixel (row 0, col 0) is their (x=0, y=H-1): dx = -0.5*2, dy = (3/4 - 0.5)
    expected = np.array([-1.0, 0.25, -1.0])
    npt.assert_allclose(rays[0, 0], expected / np.linalg.norm(expected), atol=1e-15)
    # bottom-right (row H-1, col W-1) is (x=W-1, y=0): dx = (7/8 - 0.5)*2, dy = -0.5
    expected = np.array([0.75, -0.5, -1.0])
    npt.assert_allclose(rays[-1, -1], expected / np.linalg.norm(expected), atol=1e-15)


def test_row_zero_points_up_and_col_zero_left(tilted_camera):
    rays = primary_rays(tilted_camera)
    assert np.all(rays[0] @ tilted_camera.vertical > 0)
    assert np.all(rays[-1] @ tilted_camera.vertical < 0)
    assert np.all(rays[:, 0] @ tilted_camera.horizontal < 0)
    assert np.all(rays[:, -1] @ tilted_camera.horizontal > 0)


def test_square_fov_is_53_13_degrees():
    cam = look_at([0, 0, 3], [0, 0, 0], [0, 1, 0], 32, 32)
    h_fov, v_fov = cam.fov_deg()
    assert h_fov == pytest.approx(53.130102354, abs=1e-8)
    assert v_fov == pytest.approx(53.130102354, abs=1e-8)
    assert (cam.scale_x, cam.scale_y) == (1.0, 1.0)


@pytest.mark.parametrize("width, height", [(1920, 1080), (1080, 1920), (30, 20)])
def test_longer_axis_is_scaled(width, height):
    cam = look_at([0, 0, 3], [0, 0, 0], [0, 1, 0], width, height)
    ratio = max(width, height) / min(width, height)
    h_fov, v_fov = cam.fov_deg()
    if width > height:
        assert (cam.scale_x, cam.scale_y) == (pytest.approx(ratio), 1.0)
        assert v_fov == pytest.approx(53.130102354)
        assert h_fov == pytest.approx(np.degrees(2 * np.arctan(0.5 * ratio)))
    else:
        assert (cam.scale_x, cam.scale_y) == (1.0, pytest.approx(ratio))
        assert h_fov == pytest.approx(53.130102354)
        assert v_fov == pytest.approx(np.degrees(2 * np.arctan(0.5 * ratio)))
    if (width, height) == (1920, 1080):
        # the authors' camera (docs/authors-code.md §7)
        assert h_fov == pytest.approx(83.3, abs=0.05)
    # the ray through the left-most column really is scaled
    ray = primary_rays(cam)[height // 2 - 1, 0]
    assert np.dot(ray, cam.horizontal) / np.dot(ray, cam.forward) == pytest.approx(
        -0.5 * cam.scale_x)


def test_project_inverts_primary_rays(tilted_camera):
    cam = tilted_camera
    rays = primary_rays(cam)
    rng = np.random.default_rng(0)
    t = rng.uniform(0.1, 10.0, size=rays.shape[:2])
    points = cam.origin + t[..., None] * rays
    rows, cols, depth = project(cam, points.reshape(-1, 3))
    grid_r, grid_c = np.meshgrid(np.arange(cam.height), np.arange(cam.width), indexing="ij")
    npt.assert_allclose(rows, grid_r.ravel(), atol=1e-9)
    npt.assert_allclose(cols, grid_c.ravel(), atol=1e-9)
    npt.assert_allclose(depth, t.ravel(), rtol=1e-12)


def test_project_behind_camera_is_nan(tilted_camera):
    cam = tilted_camera
    rows, cols, depth = project(cam, cam.origin - 2.0 * cam.forward)
    assert rows.shape == (1,)
    assert np.isnan(rows[0]) and np.isnan(cols[0]) and np.isnan(depth[0])


def test_default_camera_for_bounds_is_beta_study_camera():
    lo, hi = np.array([-1.0, 0.0, 2.0]), np.array([1.0, 3.0, 2.5])
    cam = default_camera_for_bounds(lo, hi)
    centre = 0.5 * (lo + hi)
    npt.assert_allclose(cam.origin, centre + [0.0, 0.0, 6.0])   # 2 * largest extent (3)
    npt.assert_allclose(cam.forward, [0, 0, -1])
    npt.assert_allclose(cam.vertical, [0, 1, 0])
    assert (cam.width, cam.height) == (512, 512)
    side = default_camera_for_bounds(lo, hi, axis="+y", up="+z", width=16, height=9)
    npt.assert_allclose(side.origin, centre + [0.0, 6.0, 0.0])
    npt.assert_allclose(side.vertical, [0, 0, 1])


def test_pyvista_params():
    cam = look_at([0, 0, 3], [0, 0, 0], [0, 1, 0], 40, 20)
    params = pyvista_camera_params(cam, focal_distance=3.0)
    npt.assert_allclose(params["position"], [0, 0, 3])
    npt.assert_allclose(params["focal_point"], [0, 0, 0], atol=1e-15)
    npt.assert_allclose(params["view_up"], [0, 1, 0])
    assert params["view_angle"] == pytest.approx(cam.fov_deg()[1])
    assert params["window_center"] == (-1 / 40, -1 / 20)
    assert params["window_size"] == (40, 20)


@pytest.mark.parametrize(
    "origin, dest, up, width, height, match",
    [
        ([0, 0, 1], [0, 0, 1], [0, 1, 0], 8, 8, "differ"),
        ([0, 0, 1], [0, 0, 0], [0, 0, 5], 8, 8, "parallel"),
        ([0, 0, 1], [0, 0, 0], [0, 0, 0], 8, 8, "non-zero"),
        ([0, 0, 1], [0, 0, 0], [0, 1, 0], 0, 8, "width"),
        ([0, 0, 1], [0, 0, 0], [0, 1, 0], 8, -1, "height"),
        ([0, 0, 1], [0, 0, 0], [0, 1, 0], 8.0, 8, "width"),
        ([0, 0, 1], [0, 0, 0], [0, 1, 0], True, 8, "width"),
        ([0, 0, np.nan], [0, 0, 0], [0, 1, 0], 8, 8, "finite"),
        ([0, 0, 1], [0, np.inf, 0], [0, 1, 0], 8, 8, "finite"),
        ([0, 0], [0, 0, 0], [0, 1, 0], 8, 8, "shape"),
    ],
)
def test_look_at_validation(origin, dest, up, width, height, match):
    with pytest.raises(ValueError, match=match):
        look_at(origin, dest, up, width, height)


def test_look_at_accepts_numpy_integers():
    cam = look_at([0, 0, 1], [0, 0, 0], [0, 1, 0], np.int64(8), np.int32(6))
    assert type(cam.width) is int and type(cam.height) is int
