"""tracer.stages: each stage of a long command is timed and, once it runs past the threshold,
said on stderr; library code stays silent without a clock; ``tracer render --stage-times``
writes the stages of a real render, and a lit render's progress reaches 100 % only when its
film (the light after the trace) is done."""

import io
import json
import time

import numpy as np
import pytest

import tracer
from tracer.cli import main
from tracer.stages import StageClock, stage, stage_progress

trimesh = pytest.importorskip("trimesh")


def test_a_clock_times_and_says_its_stages():
    out = io.StringIO()
    with StageClock("big", stream=out, say_after=0.0) as clock:
        with stage("tree", "building the tree"):
            time.sleep(0.05)
        with stage("parameters", "choosing alpha"):
            pass
        assert stage_progress("building the tree") is not None
    text = out.getvalue()
    assert "big: building the tree ..." in text and "big: building the tree: done in" in text
    d = clock.as_dict()
    assert [s["name"] for s in d["stages"]] == ["tree", "parameters"]
    assert d["stages"][0]["seconds"] >= 0.04
    assert d["total_seconds"] >= d["stages"][0]["seconds"]


def test_short_stages_and_quiet_clocks_say_nothing():
    out = io.StringIO()
    with StageClock("big", stream=out, say_after=5.0) as clock:
        with stage("tree", "building the tree"):
            pass
    with StageClock("big", stream=out, quiet=True, say_after=0.0) as quiet:
        with stage("tree", "building the tree"):
            time.sleep(0.01)
        assert stage_progress("anything") is None
    assert out.getvalue() == ""
    assert len(clock.times) == 1 and len(quiet.times) == 1


def test_without_a_clock_stages_do_nothing():
    with stage("tree", "building the tree"):
        pass
    assert stage_progress("building the tree") is None


def test_render_writes_its_stage_times(tmp_path):
    mesh = tmp_path / "ico.ply"
    trimesh.creation.icosphere(2).export(mesh)
    times = tmp_path / "stages.json"
    rc = main(["render", str(mesh), "--size", "24", "24", "-o", str(tmp_path / "ico.png"),
               "--stage-times", str(times), "-q"])
    assert rc == 0
    d = json.loads(times.read_text())
    names = [s["name"] for s in d["stages"]]
    assert names == ["load", "tree", "parameters", "framing", "trace", "light", "write"]
    assert all(s["seconds"] >= 0 for s in d["stages"])
    assert d["total_seconds"] >= sum(s["seconds"] for s in d["stages"]) * 0.99
    # a second run without --overwrite refuses to replace the file, as every output
    assert main(["render", str(mesh), "--size", "24", "24", "-o", str(tmp_path / "b.png"),
                 "--stage-times", str(times), "-q"]) != 0
    assert not (tmp_path / "b.png").exists()


def test_a_lit_render_reaches_100_percent_after_its_light():
    scene = tracer.mesh_scene(trimesh.creation.icosphere(2), size=(24, 24))
    assert scene.film.shading == "lit"
    calls = []
    tracer.render(scene, progress=lambda done, total, s: calls.append((done, total)))
    done = np.array([c[0] for c in calls])
    total = calls[-1][1]
    assert done[-1] == total and np.all(np.diff(done) >= 0)
    # the trace's own 100 % is the film's start, not the end
    assert np.sum(done == total) == 1
