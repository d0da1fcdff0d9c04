"""``tracer.show_animation``: an animation that Jupyter shows inline, from frames, a folder of
PNGs or a movie file; the embedded data decodes back to the frames."""

import base64
import io
import re

import numpy as np
import pytest
from PIL import Image

import tracer
from tracer.image import save_png
from tracer.checks.notebook import Animation, show_animation


def _frames(n=5, shape=(12, 20)):
    out = []
    for k in range(n):
        im = np.zeros(shape + (3,), np.uint8)
        im[:, : 4 * (k + 1)] = (200, 40 * k, 30)       # a bar that grows frame by frame
        out.append(im)
    return out


def _embedded(html, mime):
    m = re.search(rf'src="data:{mime};base64,([A-Za-z0-9+/=]+)"', html)
    assert m, html[:200]
    return base64.b64decode(m.group(1))


def _gif_frames(data):
    gif = Image.open(io.BytesIO(data))
    frames = []
    for i in range(gif.n_frames):
        gif.seek(i)
        frames.append(np.asarray(gif.convert("RGB")))
    return gif, frames


def test_frames_play_as_an_embedded_gif():
    frames = _frames()
    anim = show_animation(frames, fps=10, width=300)
    assert isinstance(anim, Animation) and anim.mime == "image/gif"
    html = anim._repr_html_()
    assert html.startswith("<img") and 'width="300"' in html
    gif, decoded = _gif_frames(_embedded(html, "image/gif"))
    assert len(decoded) == len(frames)
    assert gif.info["duration"] == 100 and gif.info.get("loop") == 0
    for got, want in zip(decoded, frames):
        assert got.shape == want.shape
        assert np.abs(got.astype(int) - want).max() <= 8       # palette quantisation only


def test_render_results_and_a_folder_of_frames(tmp_path):
    V = np.array([[0, 0, 0.0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    res = tracer.render_mesh(V, size=(16, 12))
    _, decoded = _gif_frames(show_animation([res, 255 - res.rgb]).data)
    assert len(decoded) == 2 and decoded[0].shape == (12, 16, 3)
    for k, im in enumerate(_frames(3)):
        save_png(tmp_path / f"frame_{k:05d}.png", im)
    _, decoded = _gif_frames(show_animation(tmp_path).data)
    assert len(decoded) == 3
    assert (decoded[2][:, :12, 0] > 150).all() and (decoded[0][:, 8:, 0] < 50).all()


def test_movie_files_are_embedded_as_they_are(tmp_path):
    mp4 = tmp_path / "clip.mp4"
    mp4.write_bytes(b"\x00\x00\x00\x18ftypmp42 not really a movie")
    anim = show_animation(mp4)
    assert anim.mime == "video/mp4" and anim.data == mp4.read_bytes()
    html = anim._repr_html_()
    assert html.startswith("<video") and "loop" in html
    assert _embedded(html, "video/mp4") == mp4.read_bytes()
    gif = tmp_path / "clip.gif"
    show_animation(_frames()).save(gif)
    assert show_animation(gif).data == gif.read_bytes()


@pytest.mark.parametrize("source,kw,message", [
    ("missing.mp4", {}, "no such file"),
    ("notes.txt", {}, "not an .mp4 or .gif"),
    ([], {}, "no frames"),
    ([np.zeros((4, 4), np.uint8)], {}, "frame 0 must be an (H, W, 3) uint8"),
    ([np.zeros((4, 4, 3)), np.zeros((4, 4, 3))], {}, "frame 0 must be an (H, W, 3) uint8"),
    ([np.zeros((4, 4, 3), np.uint8), np.zeros((5, 4, 3), np.uint8)], {}, "differ in size"),
    ([np.zeros((4, 4, 3), np.uint8)], {"fps": 0}, "fps must be > 0"),
])
def test_bad_input_is_one_clear_error(tmp_path, source, kw, message):
    if isinstance(source, str):
        (tmp_path / "notes.txt").write_text("hello")
        source = tmp_path / source
    with pytest.raises((ValueError, FileNotFoundError)) as err:
        show_animation(source, **kw)
    assert message in str(err.value)
