"""Turn per-pixel surface normals into colours (pure numpy).

All shaders take view-space normals from :func:`view_normals`, whose components are
``(right, up, towards the camera)`` in the camera frame: a surface facing the camera has
``n = (0, 0, 1)``. Images are ``(H, W, 3) uint8`` with row 0 at the top, and pixels where
``hit`` is False get the ``background`` colour (the authors paint misses white).
"""


import numpy as np

from tracer.image import load_png

__all__ = [
    "view_normals",
    "shade_normals",
    "shade_matcap",
    "shade_headlight",
    "load_matcap",
]

WHITE = (255, 255, 255)


def _check_normals(n_view, hit):
    """Validate ``(H, W, 3)`` normals and an ``(H, W)`` hit mask; return float64 / bool arrays."""
    n_view = np.asarray(n_view, dtype=np.float64)
    if n_view.ndim != 3 or n_view.shape[2] != 3:
        raise ValueError(f"normals must have shape (H, W, 3), got shape {n_view.shape}")
    hit = np.asarray(hit)
    if hit.shape != n_view.shape[:2]:
        raise ValueError(
            f"hit must have shape {n_view.shape[:2]} to match the normals, got shape {hit.shape}"
        )
    if hit.dtype != np.bool_:
        raise ValueError(f"hit must be a bool array, got dtype {hit.dtype}")
    # Non-finite normals (a NaN gradient) shade as the zero vector instead of garbage bytes.
    n_view = np.where(np.isfinite(n_view), n_view, 0.0)
    return n_view, hit


def _background(background):
    """Validate an RGB background colour; return a (3,) uint8 array."""
    bg = np.asarray(background)
    if bg.shape != (3,) or not np.all((bg >= 0) & (bg <= 255)):
        raise ValueError(f"background must be 3 values in 0..255, got {background!r}")
    return bg.astype(np.uint8)


def _finish(rgb, hit, background):
    """Paint misses with ``background`` and return a C-contiguous uint8 image."""
    out = np.ascontiguousarray(rgb, dtype=np.uint8)
    out[~hit] = _background(background)
    return out


def view_normals(normals_world, camera):
    """Normalise world-space normals and express them in the camera frame.

    Parameters
    ----------
    normals_world : (H, W, 3) array_like of float
        Surface normals or unnormalised gradients ``g`` (for a smooth distance, its gradient).
    camera : tracer.rendering.camera.Camera

    Returns
    -------
    (H, W, 3) float64 array
        ``(g . horizontal, g . vertical, -g . forward)`` for ``g`` normalised to unit length,
        as in the authors' ``sphereTrace``. Zero and non-finite vectors map to ``(0, 0, 0)``.
    """
    g = np.asarray(normals_world, dtype=np.float64)
    if g.ndim < 1 or g.shape[-1] != 3:
        raise ValueError(f"normals_world must have shape (..., 3), got shape {g.shape}")
    norm = np.sqrt(np.sum(g * g, axis=-1, keepdims=True))
    good = np.isfinite(norm) & (norm > 0.0)
    unit = np.where(good, g / np.where(good, norm, 1.0), 0.0)
    return np.stack(
        [unit @ camera.horizontal, unit @ camera.vertical, -(unit @ camera.forward)], axis=-1
    )


def shade_normals(n_view, hit, background=WHITE):
    """Colour pixels by their view-space normal, as the authors do without a matcap.

    Parameters
    ----------
    n_view : (H, W, 3) array_like of float
        View-space unit normals (:func:`view_normals`).
    hit : (H, W) bool array
        True where the ray hit the surface.
    background : (3,) int in 0..255, default (255, 255, 255)
        Colour of the misses.

    Returns
    -------
    (H, W, 3) uint8 array
        ``127 n + 128`` per channel, rounded **toward zero** like the C++ assignment of a float
        to ``unsigned char``, so ``n = (0, 0, 1)`` gives ``(128, 128, 255)`` and ``n = -1``
        gives 1. Values are clipped to 0..255 first, which only matters for normals slightly
        longer than 1.
    """
    n_view, hit = _check_normals(n_view, hit)
    rgb = np.trunc(np.clip(127.0 * n_view + 128.0, 0.0, 255.0))
    return _finish(rgb, hit, background)


def shade_matcap(n_view, hit, texture, background=WHITE):
    """Look the colour up in a matcap (material capture) texture.

    Parameters
    ----------
    n_view : (H, W, 3) array_like of float
        View-space unit normals (:func:`view_normals`).
    hit : (H, W) bool array
        True where the ray hit the surface.
    texture : (h, w, 3) uint8 array
        The matcap as loaded by :func:`load_matcap`, row 0 = top of the picture.
    background : (3,) int in 0..255, default (255, 255, 255)
        Colour of the misses.

    Returns
    -------
    (H, W, 3) uint8 array

    Notes
    -----
    The authors read texel ``(x, y) = (floor((0.5 n_x + 0.5) w), floor((0.5 n_y + 0.5) h))``
    of an image loaded by libigl's ``readPNG``, which flips it vertically, so their ``y = 0``
    is the **bottom** row of the PNG and ``n_y = +1`` reads the top of the picture: surfaces
    facing up get the matcap's top (its highlight), as a matcap is meant to be used. We keep
    that orientation: texture row ``h - 1 - y`` and column ``x``. The authors do not clamp, so
    ``n_x = 1`` or ``n_y = 1`` reads one texel past the end; we clamp ``x`` to ``0..w-1`` and
    ``y`` to ``0..h-1``, which changes only those border lookups.
    """
    n_view, hit = _check_normals(n_view, hit)
    tex = np.asarray(texture)
    if tex.dtype != np.uint8 or tex.ndim != 3 or tex.shape[2] != 3 or 0 in tex.shape:
        raise ValueError(
            f"texture must be a non-empty (h, w, 3) uint8 array, got {tex.dtype} {tex.shape}"
        )
    tex_h, tex_w = tex.shape[:2]
    x = np.floor((0.5 * n_view[..., 0] + 0.5) * tex_w)
    y = np.floor((0.5 * n_view[..., 1] + 0.5) * tex_h)
    x = np.clip(x, 0, tex_w - 1).astype(np.intp)
    y = np.clip(y, 0, tex_h - 1).astype(np.intp)
    rgb = tex[tex_h - 1 - y, x]
    return _finish(rgb, hit, background)


def shade_headlight(n_view, hit, base_color=(0.8, 0.8, 0.8), ambient=0.15, background=WHITE):
    """Lambertian shading with a light at the camera.

    Parameters
    ----------
    n_view : (H, W, 3) array_like of float
        View-space unit normals (:func:`view_normals`); the light direction is ``(0, 0, 1)``.
    hit : (H, W) bool array
        True where the ray hit the surface.
    base_color : (3,) float in 0..1, default (0.8, 0.8, 0.8)
        Albedo (RGB).
    ambient : float in 0..1, default 0.15
        Fraction of light that reaches surfaces facing away from the camera.
    background : (3,) int in 0..255, default (255, 255, 255)
        Colour of the misses.

    Returns
    -------
    (H, W, 3) uint8 array
        ``round(255 * base_color * (ambient + (1 - ambient) * max(n_z, 0)))``.
    """
    n_view, hit = _check_normals(n_view, hit)
    base = np.asarray(base_color, dtype=np.float64)
    if base.shape != (3,) or not np.all((base >= 0.0) & (base <= 1.0)):
        raise ValueError(f"base_color must be 3 values in 0..1, got {base_color!r}")
    if not 0.0 <= ambient <= 1.0:
        raise ValueError(f"ambient must be in 0..1, got {ambient!r}")
    diffuse = np.maximum(n_view[..., 2], 0.0)
    light = ambient + (1.0 - ambient) * diffuse
    rgb = np.rint(np.clip(255.0 * light[..., None] * base, 0.0, 255.0))
    return _finish(rgb, hit, background)


def load_matcap(path):
    """Read a matcap texture.

    Parameters
    ----------
    path : str or os.PathLike
        A PNG (or any image Pillow reads); grey or RGBA images are converted to RGB.

    Returns
    -------
    (h, w, 3) uint8 array
        Row 0 is the top of the picture.

    Raises
    ------
    ValueError
        If the file is missing or cannot be decoded.
    """
    try:
        return load_png(path)
    except FileNotFoundError:
        raise ValueError(f"matcap file not found: {path}") from None
    except ValueError as exc:
        raise ValueError(f"matcap {exc}") from None
