"""Tests for tracer.image: atomic I/O, false colour and image comparison."""

import numpy as np
import numpy.testing as npt
import pytest

from tracer.image import (
    ImageDiff,
    compare_images,
    false_color,
    load_png,
    save_npy,
    save_png,
)
from tracer.outputs import atomic_write


@pytest.fixture
def rgb():
    rng = np.random.default_rng(1)
    return rng.integers(0, 256, size=(12, 17, 3), dtype=np.uint8)


def _leftovers(folder):
    return sorted(p.name for p in folder.iterdir() if ".tmp-" in p.name)


def test_png_round_trip(tmp_path, rgb):
    path = save_png(tmp_path / "img.png", rgb)
    back = load_png(path)
    assert back.dtype == np.uint8 and back.shape == rgb.shape
    npt.assert_array_equal(back, rgb)
    assert _leftovers(tmp_path) == []


def test_png_row_zero_is_top(tmp_path):
    from PIL import Image

    img = np.zeros((4, 3, 3), dtype=np.uint8)
    img[0] = 255                         # top row white
    save_png(tmp_path / "top.png", img)
    with Image.open(tmp_path / "top.png") as pil:
        assert pil.size == (3, 4)
        assert pil.getpixel((0, 0)) == (255, 255, 255)
        assert pil.getpixel((0, 3)) == (0, 0, 0)


def test_grey_png_loads_as_rgb(tmp_path):
    grey = np.arange(20, dtype=np.uint8).reshape(4, 5)
    back = load_png(save_png(tmp_path / "grey.png", grey))
    assert back.shape == (4, 5, 3)
    for c in range(3):
        npt.assert_array_equal(back[..., c], grey)


def test_npy_round_trip(tmp_path):
    t = np.linspace(0.0, 1.0, 30).reshape(5, 6)
    path = save_npy(tmp_path / "t.bin", t)      # suffix kept, no ".npy" appended
    assert path.name == "t.bin" and path.is_file()
    npt.assert_array_equal(np.load(path), t)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.bin"]


@pytest.mark.parametrize(
    "bad",
    [np.zeros((4, 4, 3), dtype=np.float64), np.zeros((4, 4, 2), dtype=np.uint8),
     np.zeros((4,), dtype=np.uint8), np.zeros((0, 4, 3), dtype=np.uint8)],
)
def test_save_png_validates(tmp_path, bad):
    with pytest.raises(ValueError):
        save_png(tmp_path / "bad.png", bad)
    assert list(tmp_path.iterdir()) == []


def test_save_npy_refuses_objects(tmp_path):
    with pytest.raises(ValueError):
        save_npy(tmp_path / "o.npy", np.array([object()]))
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("exc", [RuntimeError, KeyboardInterrupt])
def test_atomic_write_cleans_up_on_error(tmp_path, exc):
    target = tmp_path / "out.png"
    with pytest.raises(exc):
        with atomic_write(target) as tmp:
            assert tmp.parent == tmp_path and tmp.suffix == ".png" and tmp.name.startswith(".")
            tmp.write_bytes(b"partial")
            raise exc()
    assert list(tmp_path.iterdir()) == []


def test_atomic_write_keeps_old_file_on_error(tmp_path):
    target = tmp_path / "out.txt"
    target.write_text("old")
    with pytest.raises(RuntimeError):
        with atomic_write(target) as tmp:
            tmp.write_text("new")
            raise RuntimeError
    assert target.read_text() == "old"
    assert _leftovers(tmp_path) == []


def test_atomic_write_replaces(tmp_path):
    target = tmp_path / "out.txt"
    target.write_text("old")
    with atomic_write(target) as tmp:
        tmp.write_text("new")
    assert target.read_text() == "new"
    assert _leftovers(tmp_path) == []


def test_overwrite_false_refuses_and_keeps_file(tmp_path, rgb):
    target = tmp_path / "img.png"
    target.write_bytes(b"precious")
    with pytest.raises(FileExistsError, match="--overwrite"):
        save_png(target, rgb, overwrite=False)
    with pytest.raises(FileExistsError, match="--overwrite"):
        save_npy(target, rgb, overwrite=False)
    assert target.read_bytes() == b"precious"
    assert _leftovers(tmp_path) == []
    # a fresh path is fine with overwrite=False
    save_png(tmp_path / "new.png", rgb, overwrite=False)
    npt.assert_array_equal(load_png(tmp_path / "new.png"), rgb)


def test_overwrite_false_detects_file_created_during_write(tmp_path):
    target = tmp_path / "race.txt"
    with pytest.raises(FileExistsError):
        with atomic_write(target, overwrite=False) as tmp:
            tmp.write_text("mine")
            target.write_text("theirs")
    assert target.read_text() == "theirs"
    assert _leftovers(tmp_path) == []


def test_missing_folder_and_missing_file(tmp_path, rgb):
    with pytest.raises(FileNotFoundError):
        save_png(tmp_path / "nope" / "img.png", rgb)
    with pytest.raises(FileNotFoundError):
        load_png(tmp_path / "absent.png")
    (tmp_path / "junk.png").write_bytes(b"not an image")
    with pytest.raises(ValueError):
        load_png(tmp_path / "junk.png")


def test_compare_identical(rgb):
    result = compare_images(rgb, rgb.copy())
    assert isinstance(result, ImageDiff)
    assert result.mean_abs_error == 0.0
    assert result.fraction_over == 0.0
    assert result.max_abs_error == 0
    assert result.diff.shape == rgb.shape and result.diff.dtype == np.uint8
    assert result.diff.max() < 10          # inferno's low end is (near) black


def test_compare_shifted_image():
    img = np.zeros((32, 32, 3), dtype=np.uint8)
    img[8:24, 8:24] = 255
    shifted = np.roll(img, 4, axis=1)
    result = compare_images(img, shifted)
    # 2 columns of 16 px changed, each 4 px wide: 128 of 1024 pixels, all channels by 255
    assert result.fraction_over == pytest.approx(128 / 1024)
    assert result.mean_abs_error == pytest.approx(255 * 128 / 1024)
    assert result.max_abs_error == 255
    changed = np.any(img != shifted, axis=2)
    assert result.diff[changed].max(axis=1).min() > 200   # bright where different
    assert result.diff[~changed].max() < 10          # dark where equal


def test_compare_threshold_and_paths(tmp_path, rgb):
    other = rgb.astype(np.int16)
    other[0, 0, 1] = (other[0, 0, 1] + 10) % 256
    other = other.astype(np.uint8)
    assert compare_images(rgb, other, threshold=16).fraction_over == 0.0
    assert compare_images(rgb, other, threshold=5).fraction_over == pytest.approx(1 / (12 * 17))
    a, b = save_png(tmp_path / "a.png", rgb), save_png(tmp_path / "b.png", other)
    assert compare_images(a, b).max_abs_error == compare_images(rgb, other).max_abs_error


def test_compare_shape_mismatch(rgb):
    with pytest.raises(ValueError, match=r"\(12, 17, 3\).*\(12, 16, 3\)"):
        compare_images(rgb, rgb[:, :16])


def test_false_color_shape_dtype_background():
    values = np.arange(12, dtype=np.float64).reshape(3, 4)
    mask = values % 3 != 0
    out = false_color(values, mask, background=(1, 2, 3))
    assert out.shape == (3, 4, 3) and out.dtype == np.uint8
    npt.assert_array_equal(out[~mask], np.tile([1, 2, 3], (int((~mask).sum()), 1)))
    # colored pixels follow viridis, which is not the background
    assert not np.any(np.all(out[mask] == [1, 2, 3], axis=1))
    # vmin/vmax: lowest shown value maps to viridis(0), a dark purple
    low = out[0, 1]
    assert low[2] > low[1]
    # non-finite values are background too
    values[0, 1] = np.nan
    out = false_color(values, mask)
    npt.assert_array_equal(out[0, 1], [255, 255, 255])


def test_false_color_validation():
    with pytest.raises(ValueError):
        false_color(np.zeros((2, 2)), np.zeros((2, 3), dtype=bool))
    with pytest.raises(ValueError, match="colormap"):
        false_color(np.zeros((2, 2)), np.ones((2, 2), dtype=bool), cmap="no-such-map")


@pytest.mark.parametrize("colors", [64, 128])
def test_gif_frames_keep_a_small_saturated_body(colors):
    """A 12 x 12 blue body on a large textured beige-brown background (a body on LiDAR trees):
    every one of its pixels stays blue in the GIF palette (median cut drew it grey), and the
    background stays close to its colours."""
    from tracer.image import gif_frame

    rng = np.random.default_rng(0)
    t = rng.random((180, 320, 1))
    img = (np.array([235, 215, 180]) * (1 - t) + np.array([90, 75, 60]) * t).astype(np.uint8)
    img[80:92, 150:162] = (60, 110, 200)
    out = np.asarray(gif_frame(img, colors).convert("RGB")).astype(int)
    assert gif_frame(img, colors).mode == "P"
    body = out[80:92, 150:162]
    assert ((body[..., 2] - body[..., 0]) > 100).all()
    assert np.abs(out - img.astype(int)).mean() < 4.0
