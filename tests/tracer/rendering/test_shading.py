"""Tests for tracer.rendering.shading: view-space normals and the three shaders."""

import numpy as np
import numpy.testing as npt
import pytest

from tracer.rendering.camera import look_at
from tracer.image import save_png
from tracer.rendering.shading import (
    load_matcap,
    shade_headlight,
    shade_matcap,
    shade_normals,
    view_normals,
)


@pytest.fixture
def camera():
    return look_at([1.0, 2.0, 3.0], [0.0, 0.5, -1.0], [0.0, 1.0, 0.2], 4, 3)


@pytest.fixture
def texture():
    """A 4 x 6 matcap whose texel (row, col) has colour (row, col, 7)."""
    rows, cols = np.meshgrid(np.arange(4), np.arange(6), indexing="ij")
    return np.stack([rows, cols, np.full_like(rows, 7)], axis=-1).astype(np.uint8)


def _one(n):
    return np.asarray(n, dtype=np.float64).reshape(1, 1, 3), np.ones((1, 1), dtype=bool)


def test_view_normals_of_minus_forward(camera):
    g = np.broadcast_to(-3.0 * camera.forward, (3, 4, 3))   # length does not matter
    npt.assert_allclose(view_normals(g, camera), np.broadcast_to([0, 0, 1], (3, 4, 3)),
                        atol=1e-15)


def test_view_normals_frame_and_zero(camera):
    g = np.stack([camera.horizontal, camera.vertical, np.zeros(3), [np.nan, 0, 0]])[None]
    n = view_normals(g, camera)
    npt.assert_allclose(n[0, 0], [1, 0, 0], atol=1e-15)
    npt.assert_allclose(n[0, 1], [0, 1, 0], atol=1e-15)
    npt.assert_array_equal(n[0, 2:], 0.0)


def test_shade_normals_facing_camera():
    n, hit = _one([0, 0, 1])
    npt.assert_array_equal(shade_normals(n, hit)[0, 0], [128, 128, 255])


def test_shade_normals_truncates_toward_zero():
    n, hit = _one([-1.0, 0.5, -0.3])
    # 127*-1+128 = 1; 127*0.5+128 = 191.5 -> 191; 127*-0.3+128 = 89.9 -> 89
    npt.assert_array_equal(shade_normals(n, hit)[0, 0], [1, 191, 89])


def test_misses_are_background():
    n = np.zeros((2, 3, 3))
    n[..., 2] = 1.0
    hit = np.array([[True, False, True], [False, False, True]])
    for out in (shade_normals(n, hit), shade_headlight(n, hit)):
        assert out.dtype == np.uint8 and out.shape == (2, 3, 3)
        npt.assert_array_equal(out[~hit], 255)
        assert not np.any(np.all(out[hit] == 255, axis=1))
    out = shade_normals(n, hit, background=(10, 20, 30))
    npt.assert_array_equal(out[~hit], np.tile([10, 20, 30], (3, 1)))


def test_matcap_clamps_at_the_border(texture):
    # n_x = +1 would read column w (one past the end) without the clamp
    n, hit = _one([1.0, 0.0, 0.0])
    npt.assert_array_equal(shade_matcap(n, hit, texture)[0, 0], [1, 5, 7])
    n, hit = _one([-1.0, 0.0, 0.0])
    npt.assert_array_equal(shade_matcap(n, hit, texture)[0, 0], [1, 0, 7])


def test_matcap_up_reads_top_row(texture):
    n, hit = _one([0.0, 1.0, 0.0])
    npt.assert_array_equal(shade_matcap(n, hit, texture)[0, 0], [0, 3, 7])    # row 0 = top
    n, hit = _one([0.0, -1.0, 0.0])
    npt.assert_array_equal(shade_matcap(n, hit, texture)[0, 0], [3, 3, 7])    # bottom row


def test_matcap_facing_camera_reads_centre(texture):
    # x = floor(0.5 * 6) = 3, y = floor(0.5 * 4) = 2 counted from the bottom -> row 4-1-2 = 1
    n, hit = _one([0.0, 0.0, 1.0])
    npt.assert_array_equal(shade_matcap(n, hit, texture)[0, 0], [1, 3, 7])


def test_matcap_misses_and_validation(texture):
    n = np.zeros((1, 2, 3))
    hit = np.array([[False, True]])
    out = shade_matcap(n, hit, texture, background=(0, 0, 0))
    npt.assert_array_equal(out[0, 0], [0, 0, 0])
    with pytest.raises(ValueError):
        shade_matcap(n, hit, texture.astype(np.float32))
    with pytest.raises(ValueError):
        shade_matcap(n, np.ones((2, 1), dtype=bool), texture)


def test_headlight():
    n = np.array([[[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]]])
    out = shade_headlight(n, np.ones((1, 3), dtype=bool), base_color=(1.0, 0.5, 0.0),
                          ambient=0.2)
    npt.assert_array_equal(out[0, 0], [255, 128, 0])        # full light, round(127.5) = 128
    npt.assert_array_equal(out[0, 1], [51, 26, 0])          # ambient only: 0.2 * 255 = 51
    npt.assert_array_equal(out[0, 2], out[0, 1])            # back faces get ambient too


def test_load_matcap(tmp_path, texture):
    path = save_png(tmp_path / "m.png", texture)
    npt.assert_array_equal(load_matcap(path), texture)
    with pytest.raises(ValueError, match="not found"):
        load_matcap(tmp_path / "missing.png")
    (tmp_path / "bad.png").write_bytes(b"garbage")
    with pytest.raises(ValueError, match="cannot read"):
        load_matcap(tmp_path / "bad.png")
