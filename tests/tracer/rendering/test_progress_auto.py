"""``render_mesh`` shows a progress bar by default once a render runs longer than a few
seconds (issue 46, item 7); short renders stay silent; ``progress=None`` is never shown."""
import numpy as np
import pytest

import tracer
from tracer.rendering import frame

trimesh = pytest.importorskip("trimesh")


def test_short_renders_print_nothing(capsys):
    # the first render on a machine compiles the kernels: the bar says so once that runs
    # past 3 s; the second is short and silent
    tracer.render_mesh(trimesh.creation.icosphere(), size=(16, 16), shading="normals")
    capsys.readouterr()
    tracer.render_mesh(trimesh.creation.icosphere(), size=(16, 16), shading="normals")
    assert capsys.readouterr().err == ""


def test_long_renders_show_the_bar(capsys, monkeypatch):
    monkeypatch.setattr(frame, "AUTO_PROGRESS_AFTER", 0.0)     # every render is "long"
    res = tracer.render_mesh(trimesh.creation.icosphere(), size=(16, 16), shading="normals")
    err = capsys.readouterr().err
    assert "render" in err and "100.0%" in err
    assert res.hit.any()
    tracer.render_mesh(trimesh.creation.icosphere(), size=(16, 16), shading="normals",
                       progress=None)
    assert capsys.readouterr().err == ""


def test_render_accepts_auto_and_refuses_other_words():
    s = tracer.mesh_scene((np.eye(3), [[0, 1, 2]]), size=(8, 8), shading="normals")
    tracer.render(s, progress="auto")
    with pytest.raises(TypeError, match="'auto'"):
        tracer.render(s, progress="yes")
