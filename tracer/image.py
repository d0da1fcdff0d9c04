"""Image and array I/O, false colour and image comparison.

Images are numpy arrays ``(H, W, 3) uint8`` (or ``(H, W)`` grey) with row 0 at the top, which
is also the top row of the saved PNG. Every writer goes through
:func:`tracer.outputs.atomic_write`, so an interrupted render never leaves a truncated file
behind. Large PNGs (:data:`PNG_THREADS_FROM` pixels and more) are encoded on every thread
(:func:`write_png_bands`); smaller ones by Pillow.
"""

import os
import struct
import zlib
from pathlib import Path
from typing import NamedTuple

import numpy as np

from tracer.outputs import atomic_write

__all__ = [
    "save_png",
    "save_npy",
    "load_png",
    "false_color",
    "ImageDiff",
    "compare_images",
    "gif_frame",
    "write_png_bands",
    "png_threads",
    "PNG_THREADS_FROM",
    "PNG_LEVEL",
]

WHITE = (255, 255, 255)
#: pixels from which :func:`save_png` writes the PNG itself on every thread; smaller images
#: (thumbnails, test baselines) keep Pillow's bytes, where threads would save milliseconds
PNG_THREADS_FROM = 500_000
#: zlib level of :func:`write_png_bands`: Pillow's, for files of the same size
PNG_LEVEL = 6
_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
_COLOR_TYPE = {1: 0, 3: 2, 4: 6}  # channels -> PNG colour type (grey, RGB, RGBA)
_ADLER_BASE = 65521


def save_png(path, rgb, overwrite=True):
    """Save an image as PNG, atomically.

    Parameters
    ----------
    path : str or os.PathLike
        Destination; the format is PNG whatever the suffix.
    rgb : (H, W, 3), (H, W, 4) or (H, W) uint8 array
        Colour, colour with alpha (straight, not premultiplied) or grey image, row 0 = top.
    overwrite : bool, default True
        If False, raise FileExistsError when ``path`` exists.

    Returns
    -------
    pathlib.Path
        ``path``.

    Notes
    -----
    Images of :data:`PNG_THREADS_FROM` pixels and more are encoded by
    :func:`write_png_bands`, one band of rows per thread (:func:`png_threads`); smaller ones by
    Pillow. Either file decodes to the same pixels.
    """
    from PIL import Image  # Pillow (tracer extra): loaded on use

    arr = np.asarray(rgb)
    if arr.dtype != np.uint8:
        raise ValueError(f"image must be uint8, got dtype {arr.dtype}")
    if not (arr.ndim == 2 or (arr.ndim == 3 and arr.shape[2] in (3, 4))) or 0 in arr.shape:
        raise ValueError(f"image must have shape (H, W, 3), (H, W, 4) or (H, W), got shape "
                         f"{arr.shape}")
    path = Path(path)
    if arr.shape[0] * arr.shape[1] >= PNG_THREADS_FROM:
        with atomic_write(path, overwrite=overwrite) as tmp:
            with open(tmp, "wb") as fh:
                write_png_bands(fh, arr)
        return path
    img = Image.fromarray(np.ascontiguousarray(arr))  # "RGB", "RGBA" or "L" from the shape
    with atomic_write(path, overwrite=overwrite) as tmp:
        img.save(tmp, format="PNG")
    return path


def png_threads():
    """Threads that encode a large PNG: numba's thread count, as the render's
    (``tracer.rendering.threads.render_threads``), 1 with ``SMOOTHDIST_PARALLEL=0``."""
    # numba, smoothdist: loaded on use, PNG files (tracer diff, the pytest plugin) need no kernels
    import numba
    from smoothdist.kernels import PARALLEL

    return numba.get_num_threads() if PARALLEL else 1


def write_png_bands(fh, arr, threads=None, level=PNG_LEVEL):
    """Write ``arr`` ((H, W, 3), (H, W, 4) or (H, W) uint8, checked by the caller) to the
    binary file ``fh`` as an 8-bit PNG, one band of rows per thread, as pigz does.

    Every row gets the Up filter (its difference from the row above: files within a few per
    cent of Pillow's per-row choice on renders, and a band needs only the row above it). Each
    thread filters its band and deflates it with a raw ``zlib.compressobj`` (zlib releases
    the GIL), ending with a full flush (the last band: the stream's end), so the pieces,
    behind a zlib header and before the Adler-32 of all the filtered bytes (combined from the
    bands'), make one zlib stream. One IDAT chunk per band. The decoded pixels do not depend
    on ``threads`` (default :func:`png_threads`); the bytes do.
    """
    # smoothdist: loaded on use, PNG files (tracer diff, the pytest plugin) need no kernels
    from smoothdist.schedule import run_tasks

    arr = np.ascontiguousarray(arr)
    h, w = arr.shape[:2]
    rows = arr.reshape(h, -1)
    bands = max(1, min(int(threads or png_threads()), h))
    edges = [h * i // bands for i in range(bands + 1)]
    pieces = [None] * bands

    def encode(b0, b1):
        for b in range(b0, b1):
            pieces[b] = _deflate_band(rows, edges[b], edges[b + 1], level, b == bands - 1)

    run_tasks(encode, bands, bands)
    adler = pieces[0][1]
    for data, adler_b, size in pieces[1:]:
        adler = _adler32_combine(adler, adler_b, size)
    channels = 1 if arr.ndim == 2 else arr.shape[2]
    fh.write(_PNG_SIGNATURE)
    _chunk(fh, b"IHDR", struct.pack(">IIBBBBB", w, h, 8, _COLOR_TYPE[channels], 0, 0, 0))
    for b, (data, _, _) in enumerate(pieces):
        head = b"\x78\x9c" if b == 0 else b""  # deflate, 32 KiB window, default level
        tail = struct.pack(">I", adler) if b == bands - 1 else b""
        _chunk(fh, b"IDAT", head + data + tail)
    _chunk(fh, b"IEND", b"")


def _deflate_band(rows, r0, r1, level, last):
    """Rows ``r0 <= r < r1`` of ``rows`` (H, row bytes) Up-filtered, each behind its filter
    byte (2), deflated (raw): ``(bytes, adler32 of the filtered bytes, their count)``."""
    band = np.empty((r1 - r0, rows.shape[1] + 1), dtype=np.uint8)
    band[:, 0] = 2
    above = rows[r0 - 1] if r0 > 0 else np.zeros_like(rows[0])  # PNG: zeros above the top
    np.subtract(rows[r0], above, out=band[0, 1:])                # uint8: wraps modulo 256
    np.subtract(rows[r0 + 1:r1], rows[r0:r1 - 1], out=band[1:, 1:])
    raw = memoryview(band).cast("B")
    comp = zlib.compressobj(level, zlib.DEFLATED, -15)
    data = comp.compress(raw) + comp.flush(zlib.Z_FINISH if last else zlib.Z_FULL_FLUSH)
    return data, zlib.adler32(raw), len(raw)


def _adler32_combine(adler1, adler2, len2):
    """Adler-32 of ``A + B`` from those of ``A`` and of ``B`` (``len2`` bytes): the sums
    ``s1 = 1 + sum(bytes)``, ``s2 = sum of the running s1`` (modulo 65521) of ``B`` run on from
    ``A``'s ``s1``."""
    a1, b1 = adler1 & 0xFFFF, adler1 >> 16
    a2, b2 = adler2 & 0xFFFF, adler2 >> 16
    s1 = (a1 + a2 - 1) % _ADLER_BASE
    s2 = (b1 + b2 + len2 * (a1 - 1)) % _ADLER_BASE
    return (s2 << 16) | s1


def _chunk(fh, kind, data):
    """A PNG chunk: length, type, data, CRC-32 of type and data."""
    fh.write(struct.pack(">I", len(data)) + kind)
    fh.write(data)
    fh.write(struct.pack(">I", zlib.crc32(data, zlib.crc32(kind))))


def gif_frame(rgb, colors=128):
    """A palette image (PIL, mode ``"P"``) of ``rgb (H, W, 3) uint8`` for a GIF frame.

    The palette is an octree's: it keeps a small, saturated object (a blue body on LiDAR trees)
    that median cut merges into the large background's colours (at 64 or 128 colours median cut
    drew such a body grey), at a slightly larger mean error on smooth gradients."""
    from PIL import Image  # Pillow (tracer extra): loaded on use

    return Image.fromarray(np.ascontiguousarray(rgb)).quantize(
        colors=int(colors), method=Image.Quantize.FASTOCTREE)


def save_npy(path, array, overwrite=True):
    """Save an array in ``.npy`` format, atomically (no pickled objects).

    Parameters
    ----------
    path : str or os.PathLike
        Destination, written as given (no ``.npy`` is appended).
    array : array_like
        Any numeric or bool array; object arrays are refused.
    overwrite : bool, default True
        If False, raise FileExistsError when ``path`` exists.

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    arr = np.asarray(array)
    if arr.dtype.hasobject:
        raise ValueError("cannot save an object array to .npy (it would need pickle)")
    path = Path(path)
    with atomic_write(path, overwrite=overwrite) as tmp:
        with open(tmp, "wb") as fh:
            np.save(fh, arr, allow_pickle=False)
    return path


def load_png(path, alpha=False):
    """Read an image as RGB (or RGBA).

    Parameters
    ----------
    path : str or os.PathLike
    alpha : bool, default False
        Return ``(H, W, 4)`` with the alpha channel (255 where the file has none).

    Returns
    -------
    (H, W, 3) uint8 array
        Row 0 is the top row; grey images are replicated to three channels and alpha is
        dropped.

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    ValueError
        If the file cannot be decoded as an image.
    """
    from PIL import Image, UnidentifiedImageError  # Pillow (tracer extra): loaded on use

    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"image not found: {path}")
    try:
        with Image.open(path) as img:
            return np.array(img.convert("RGBA" if alpha else "RGB"), dtype=np.uint8)
    except (OSError, UnidentifiedImageError) as exc:
        raise ValueError(f"cannot read image {path}: {exc}") from None


def false_color(values, mask=None, cmap="viridis", vmin=None, vmax=None, background=WHITE):
    """Map a scalar image to colours with a matplotlib colormap.

    Parameters
    ----------
    values : (H, W) array_like of float
        Scalar per pixel (e.g. a t-buffer or an iteration count).
    mask : (H, W) bool array, optional
        True where ``values`` is meaningful; other pixels, and non-finite values, get
        ``background``. None means every finite value.
    cmap : str or matplotlib.colors.Colormap, default "viridis"
        Colormap name, looked up in ``matplotlib.colormaps``.
    vmin, vmax : float, optional
        Values mapped to the ends of the colormap (values beyond are clipped). Default: the
        minimum and maximum over the coloured pixels. If ``vmax == vmin`` everything maps to
        the low end.
    background : (3,) int in 0..255, default (255, 255, 255)
        Colour of the masked-out pixels.

    Returns
    -------
    (H, W, 3) uint8 array
    """
    import matplotlib  # matplotlib (studies extra): loaded on use

    vals = np.asarray(values, dtype=np.float64)
    if vals.ndim != 2:
        raise ValueError(f"values must have shape (H, W), got shape {vals.shape}")
    if mask is None:
        mask = np.ones(vals.shape, dtype=bool)
    mask = np.asarray(mask)
    if mask.shape != vals.shape or mask.dtype != np.bool_:
        raise ValueError(
            f"mask must be a bool array of shape {vals.shape}, got {mask.dtype} {mask.shape}"
        )
    bg = np.asarray(background)
    if bg.shape != (3,) or not np.all((bg >= 0) & (bg <= 255)):
        raise ValueError(f"background must be 3 values in 0..255, got {background!r}")
    if isinstance(cmap, str):
        try:
            colormap = matplotlib.colormaps[cmap]
        except KeyError:
            raise ValueError(f"unknown matplotlib colormap {cmap!r}") from None
    else:
        colormap = cmap

    show = mask & np.isfinite(vals)
    shown = vals[show]
    lo = float(vmin) if vmin is not None else (float(shown.min()) if shown.size else 0.0)
    hi = float(vmax) if vmax is not None else (float(shown.max()) if shown.size else 1.0)
    span = hi - lo
    with np.errstate(invalid="ignore"):
        unit = (vals - lo) / span if span > 0 else np.zeros_like(vals)
    unit = np.clip(np.where(show, unit, 0.0), 0.0, 1.0)
    rgba = colormap(unit, bytes=True)
    out = np.ascontiguousarray(rgba[..., :3], dtype=np.uint8)
    out[~show] = bg.astype(np.uint8)
    return out


class ImageDiff(NamedTuple):
    """Result of :func:`compare_images`; errors are in 0..255 intensity units.

    Attributes
    ----------
    mean_abs_error : float
        Mean of ``|a - b|`` over all pixels and channels.
    fraction_over : float
        Fraction of pixels whose largest channel difference exceeds the threshold.
    max_abs_error : int
        Largest ``|a - b|`` of any channel.
    diff : (H, W, 3) uint8 array
        Heat map of the per-pixel largest channel difference (``inferno``): black where the
        images agree, brightest at the worst pixel.
    """

    mean_abs_error: float
    fraction_over: float
    max_abs_error: int
    diff: np.ndarray


def _as_image(img, name):
    if isinstance(img, (str, os.PathLike)):
        return load_png(img)
    arr = np.asarray(img)
    if arr.dtype != np.uint8:
        raise ValueError(f"{name} must be a uint8 image, got dtype {arr.dtype}")
    if arr.ndim == 2:
        arr = arr[..., None]
    if arr.ndim != 3:
        raise ValueError(f"{name} must have shape (H, W, C) or (H, W), got shape {arr.shape}")
    return arr


def compare_images(a, b, threshold=16):
    """Compare two images pixel by pixel.

    Parameters
    ----------
    a, b : (H, W, 3) or (H, W) uint8 array, or path to an image file
        Images of the same shape (paths are read with :func:`load_png`).
    threshold : int, default 16
        A pixel counts as different when the largest of its channel differences exceeds this.

    Returns
    -------
    ImageDiff
        ``mean_abs_error`` (the metric of pyvista's ``compare_images(use_vtk=False)`` divided
        by the channel count), ``fraction_over``, ``max_abs_error`` and a ``diff`` heat map
        scaled from 0 (black) to ``max(max_abs_error, threshold)``, so that differences below
        the threshold stay dark.

    Raises
    ------
    ValueError
        If the shapes differ (both are named) or an input is not uint8.
    """
    a = _as_image(a, "a")
    b = _as_image(b, "b")
    if a.shape != b.shape:
        raise ValueError(f"image shapes differ: {a.shape} vs {b.shape}")
    err = np.abs(a.astype(np.int16) - b.astype(np.int16))
    per_pixel = err.max(axis=2)
    max_err = int(per_pixel.max()) if per_pixel.size else 0
    heat = false_color(
        per_pixel, cmap="inferno", vmin=0.0, vmax=float(max(max_err, threshold, 1))
    )
    return ImageDiff(
        mean_abs_error=float(err.mean()) if err.size else 0.0,
        fraction_over=float(np.mean(per_pixel > threshold)) if per_pixel.size else 0.0,
        max_abs_error=max_err,
        diff=heat,
    )
