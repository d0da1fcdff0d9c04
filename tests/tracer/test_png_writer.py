"""Tests for the threaded PNG writer (tracer.image.write_png_bands, save_png for large images).

Every comparison is exact: PNG is lossless, so a decoded pixel differs from the array written
only if the writer is wrong. The independent reading is Pillow (``load_png``, ``Image.open``)
and, separately, the chunks parsed here with ``zlib.decompress`` (which checks the stream's
Adler-32) and the Up filter undone with a cumulative sum modulo 256.
"""

import io
import struct
import zlib

import numpy as np
import numpy.testing as npt
import pytest
from PIL import Image

import tracer.image as image
from tracer.image import load_png, save_png, write_png_bands

THREADS = (1, 2, 3, 7)
SHAPES = [(1, 1), (1, 53), (53, 1), (5, 1, 3), (1, 9, 4), (37, 41, 3), (31, 29, 4), (23, 101)]


def _image(shape, kind, seed=0):
    if kind == "flat":
        return np.full(shape, 200, dtype=np.uint8)
    return np.random.default_rng(seed).integers(0, 256, size=shape, dtype=np.uint8)


def _png_bytes(arr, threads):
    buf = io.BytesIO()
    write_png_bands(buf, arr, threads=threads)
    return buf.getvalue()


def _chunks(data):
    """``[(type, payload)]`` of a PNG's bytes, each chunk's CRC-32 checked."""
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    out, pos = [], 8
    while pos < len(data):
        (n,) = struct.unpack(">I", data[pos:pos + 4])
        kind, payload = data[pos + 4:pos + 8], data[pos + 8:pos + 8 + n]
        (crc,) = struct.unpack(">I", data[pos + 8 + n:pos + 12 + n])
        assert crc == zlib.crc32(kind + payload)
        out.append((kind, payload))
        pos += 12 + n
    return out


def _decode_here(data):
    """Pixels of a PNG from this writer, decoded without Pillow: every row Up-filtered."""
    chunks = _chunks(data)
    w, h, depth, ctype = struct.unpack(">IIBB", chunks[0][1][:10])
    channels = {0: 1, 2: 3, 6: 4}[ctype]
    raw = zlib.decompress(b"".join(p for k, p in chunks if k == b"IDAT"))  # checks Adler-32
    rows = np.frombuffer(raw, dtype=np.uint8).reshape(h, 1 + w * channels)
    assert depth == 8 and (rows[:, 0] == 2).all()
    pixels = (np.cumsum(rows[:, 1:], axis=0, dtype=np.int64) % 256).astype(np.uint8)
    return pixels.reshape((h, w) if channels == 1 else (h, w, channels)), chunks


@pytest.mark.parametrize("kind", ["random", "flat"])
@pytest.mark.parametrize("shape", SHAPES)
def test_round_trip_through_pillow_at_any_thread_count(shape, kind):
    arr = _image(shape, kind)
    mode = {2: "L", 3: "RGB", 4: "RGBA"}[arr.ndim if arr.ndim == 2 else arr.shape[2]]
    for threads in THREADS:
        data = _png_bytes(arr, threads)
        with Image.open(io.BytesIO(data)) as img:
            img.verify()                              # chunk CRCs and structure
        with Image.open(io.BytesIO(data)) as img:
            assert img.mode == mode and img.size == (shape[1], shape[0])
            npt.assert_array_equal(np.asarray(img), arr)
        here, chunks = _decode_here(data)
        npt.assert_array_equal(here, arr)
        # one IDAT chunk per band: at most one band per row
        assert sum(k == b"IDAT" for k, _ in chunks) == min(threads, shape[0])
        assert [k for k, _ in chunks][0] == b"IHDR" and chunks[-1] == (b"IEND", b"")


def test_pixels_do_not_depend_on_the_thread_count():
    arr = _image((97, 64, 3), "random", seed=3)
    arr[40:60] = 17                                    # a flat stretch across band edges
    decoded = {t: np.asarray(Image.open(io.BytesIO(_png_bytes(arr, t)))) for t in (1, 2, 5, 16)}
    for t, img in decoded.items():
        npt.assert_array_equal(img, decoded[1], err_msg=f"{t} threads")
    npt.assert_array_equal(decoded[1], arr)


@pytest.mark.parametrize("threads", [1, 4])
@pytest.mark.parametrize("shape", [(40, 33, 3), (40, 33, 4), (40, 33)])
def test_save_png_writes_large_images_itself(tmp_path, monkeypatch, shape, threads):
    monkeypatch.setattr(image, "PNG_THREADS_FROM", 1)  # every image counts as large
    monkeypatch.setattr(image, "png_threads", lambda: threads)
    arr = _image(shape, "random", seed=5)
    path = save_png(tmp_path / "big.png", arr)
    data = path.read_bytes()
    assert sum(k == b"IDAT" for k, _ in _chunks(data)) == threads  # our writer's bands
    with Image.open(path) as img:
        img.verify()
    rgba = arr[..., None].repeat(3, axis=2) if arr.ndim == 2 else arr
    npt.assert_array_equal(load_png(path, alpha=shape[-1] == 4), rgba)
    assert not [p for p in tmp_path.iterdir() if ".tmp-" in p.name]


def test_save_png_threshold_and_default_threads(tmp_path):
    small = _image((10, 10, 3), "random")
    big = _image((image.PNG_THREADS_FROM // 1000 + 1, 1000, 3), "random", seed=7)
    assert len(_chunks(save_png(tmp_path / "s.png", small).read_bytes())) >= 3  # Pillow's
    data = save_png(tmp_path / "b.png", big).read_bytes()
    here, chunks = _decode_here(data)                   # only our writer Up-filters every row
    npt.assert_array_equal(here, big)
    assert sum(k == b"IDAT" for k, _ in chunks) == min(image.png_threads(), big.shape[0])


def test_adler32_combine_matches_zlib():
    rng = np.random.default_rng(11)
    for n1, n2 in [(0, 0), (1, 0), (0, 1), (5, 70000), (70000, 3), (65521, 65521)]:
        a = rng.integers(0, 256, n1, dtype=np.uint8).tobytes()
        b = rng.integers(0, 256, n2, dtype=np.uint8).tobytes()
        assert image._adler32_combine(zlib.adler32(a), zlib.adler32(b), n2) == zlib.adler32(a + b)
    ones = b"\xff" * 200000                             # large sums: the modulus matters
    assert image._adler32_combine(zlib.adler32(ones), zlib.adler32(ones), 200000) == \
        zlib.adler32(ones + ones)
