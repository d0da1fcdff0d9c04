"""Show renders and animations inline in Jupyter (and in the documentation's notebooks).

A :class:`tracer.rendering.frame.RenderResult` shows itself (it has ``_repr_png_``). For motion,
:func:`show_animation` wraps a simulation's movie, a folder of frames or a list of images in an
:class:`Animation`, which Jupyter displays as a looping ``<video>`` (MP4) or ``<img>`` (GIF)
embedded in the notebook, so that the notebook stays viewable without the files beside it.
Nothing here imports IPython.
"""

import base64
import io
import os
from pathlib import Path

import numpy as np

from tracer.image import gif_frame, load_png
from tracer.outputs import write_bytes

__all__ = ["Animation", "show_animation"]

#: largest movie embedded in a notebook, bytes (base64 makes it a third larger)
MAX_EMBED_BYTES = 32 * 1024 * 1024


class Animation:
    """An animation that Jupyter shows inline (``_repr_html_``).

    Parameters
    ----------
    data : bytes
        The encoded movie.
    mime : {"video/mp4", "image/gif"}
        Its type.
    width : int, optional
        Display width in CSS pixels (default: the movie's own).
    """

    def __init__(self, data, mime, width=None):
        if mime not in ("video/mp4", "image/gif"):
            raise ValueError(f"Animation: mime must be 'video/mp4' or 'image/gif', got {mime!r}")
        if len(data) > MAX_EMBED_BYTES:
            raise ValueError(f"Animation: {len(data) / 2**20:.0f} MiB is too large to embed in a "
                             f"notebook (at most {MAX_EMBED_BYTES // 2**20} MiB); show fewer or "
                             f"smaller frames")
        self.data = bytes(data)
        self.mime = mime
        self.width = width

    def _repr_html_(self):
        b64 = base64.b64encode(self.data).decode("ascii")
        width = f' width="{int(self.width)}"' if self.width else ""
        if self.mime == "video/mp4":
            return (f'<video{width} controls autoplay loop muted playsinline>'
                    f'<source src="data:video/mp4;base64,{b64}" type="video/mp4"></video>')
        return f'<img{width} src="data:image/gif;base64,{b64}" alt="animation"/>'

    def save(self, path):
        """Write the movie to ``path`` (its suffix should match ``mime``); returns it."""
        write_bytes(path, self.data)
        return Path(path)

    def __repr__(self):
        return f"Animation({self.mime}, {len(self.data)} bytes)"


def _frames(source):
    """(H, W, 3) uint8 images from a folder of PNGs or a sequence of images / renders."""
    if isinstance(source, (str, os.PathLike)):
        files = sorted(Path(source).glob("*.png"))
        if not files:
            raise ValueError(f"show_animation: no PNG frames in {source}")
        return [load_png(f) for f in files]
    images = []
    for i, im in enumerate(source):
        im = np.asarray(getattr(im, "rgb", im))
        if im.dtype != np.uint8 or im.ndim != 3 or im.shape[2] not in (3, 4):
            raise ValueError(f"show_animation: frame {i} must be an (H, W, 3) uint8 image or a "
                             f"RenderResult, got {im.dtype} {im.shape}")
        images.append(im[..., :3])
    if not images:
        raise ValueError("show_animation: no frames")
    if any(im.shape != images[0].shape for im in images):
        raise ValueError("show_animation: the frames differ in size")
    return images


def _gif_bytes(images, fps):
    frames = [gif_frame(im) for im in images]
    buf = io.BytesIO()
    frames[0].save(buf, format="GIF", save_all=True, append_images=frames[1:], loop=0,
                   duration=max(int(round(1000.0 / fps)), 20), optimize=True)
    return buf.getvalue()


def show_animation(source, fps=25.0, width=None):
    """An inline animation of a movie file, a folder of frames or a list of images.

    Parameters
    ----------
    source : str or path-like, or sequence
        An ``.mp4`` or ``.gif`` file (as ``tracer animate`` writes), a folder of PNG frames
        (played in name order), or a sequence of ``(H, W, 3)`` uint8 images or
        :class:`~tracer.rendering.frame.RenderResult`\\ s.
    fps : float
        Frames per second when frames are given (ignored for a movie file).
    width : int, optional
        Display width in CSS pixels.

    Returns
    -------
    Animation
        Shown by Jupyter as the last expression of a cell; ``.save(path)`` writes it.

    Examples
    --------
    >>> import numpy as np
    >>> frames = [np.full((8, 8, 3), 40 * k, np.uint8) for k in range(4)]
    >>> anim = show_animation(frames, fps=10)
    >>> anim.mime, anim._repr_html_().startswith("<img")
    ('image/gif', True)
    """
    if not (np.isfinite(fps) and fps > 0):
        raise ValueError(f"show_animation: fps must be > 0, got {fps}")
    if isinstance(source, (str, os.PathLike)) and not Path(source).is_dir():
        path = Path(source)
        if not path.is_file():
            raise FileNotFoundError(f"show_animation: no such file or folder: {path}")
        mime = {".mp4": "video/mp4", ".gif": "image/gif"}.get(path.suffix.lower())
        if mime is None:
            raise ValueError(f"show_animation: {path.name} is not an .mp4 or .gif file")
        return Animation(path.read_bytes(), mime, width)
    return Animation(_gif_bytes(_frames(source), float(fps)), "image/gif", width)
