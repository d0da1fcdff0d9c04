"""A first simulation step's moments kernel compiled in a child process
(``tracer.sim.compile_ahead``).

* On an empty cache ``tracer simulate``'s child compiles the moments' kernel with the types the
  first step calls it with: the simulation compiles none of it (it loads it) and its
  trajectory is the one of a run in this process, bit for bit.
* :func:`~tracer.sim.compile_ahead.needed` starts nothing where it cannot help: outside an
  entry point that allows it, turned off, the exact constraint, split torques, one core, a
  cache that holds the kernel already.
* The child's stand-in data meshes choose the same kernels as the bodies' own.
* A simulation that renders its movie starts the render's child for the frames' scene after
  its first step's (:func:`~tracer.sim.compile_ahead.start_movie`).
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from smoothdist import DataMesh, MeshDistance, SmoothDistanceField
from smoothdist.warmup import cache_folder
from tracer import compiling
from tracer.cli import main
from tracer.sim import cli_simulate, compile_ahead
from tracer.sim.animate import body_scene
from tracer.sim import run as sim_run
from tracer.sim.simfile import load_simulation

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "benchmarks"))
import bench_coldstart  # noqa: E402  (its child script reports what a process compiled)

ICO_BOWL = ROOT / "scenes" / "simulations" / "ico_bowl.json"
CORES = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
MOMENTS = "smoothdist._kernels.mesh_moment.smooth_moment_primitive_tasks"


@pytest.mark.slow
@pytest.mark.skipif(CORES < 2, reason="compiling ahead needs a second core")
def test_a_first_step_loads_the_moments_its_child_compiled(tmp_path):
    """``tracer simulate`` on an empty cache: its child compiles the moments' kernel, which the
    first step loads (the simulation compiles the smooth and exact distances itself); the
    trajectory equals one computed here."""
    out = tmp_path / "sim"
    env = dict(os.environ, SMOOTHDIST_CACHE_DIR=str(tmp_path / "cache"),
               PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    env[compiling.AHEAD_ENV] = "on"
    p = subprocess.run([sys.executable, "-c", bench_coldstart.CHILD, "cli", "simulate",
                        str(ICO_BOWL), "--steps", "1", "--no-render", "-o", str(out), "-q"],
                       env=env, capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr[-3000:]
    report = json.loads(p.stdout.strip().splitlines()[-1])
    assert report["rc"] == 0
    compiled = report["kernels"]
    assert "smoothdist._kernels.mesh_query.segment_distance_tasks" in compiled  # cold cache
    assert MOMENTS not in compiled, compiled
    assert list((tmp_path / "cache").glob("*/smoothdist._kernels/mesh_moment.*.nbi"))
    sim = load_simulation(ICO_BOWL)
    mine = sim_run.simulate(sim, tmp_path / "here.npz", steps=1)
    theirs = sim_run.load_trajectory(out / "trajectory.npz")
    for key in sim_run.FRAME_KEYS:
        if key != "seconds":
            assert np.array_equal(np.asarray(mine[key]), theirs[key]), key


def test_needed_only_where_it_can_help(monkeypatch, tmp_path):
    monkeypatch.delenv(compiling.AHEAD_ENV, raising=False)
    monkeypatch.setenv("SMOOTHDIST_CACHE_DIR", str(tmp_path / "empty"))
    if hasattr(os, "sched_getaffinity"):
        monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0, 1})
    assert not compile_ahead.needed("smooth", "exact")            # not within an entry point
    with compiling.ahead_allowed():
        assert compile_ahead.needed("smooth", "exact")
        assert not compile_ahead.needed("exact", "exact")         # exact distances first
        assert not compile_ahead.needed("smooth", "split")        # no moments
        monkeypatch.setenv(compiling.AHEAD_ENV, "off")
        assert not compile_ahead.needed("smooth", "exact")
        monkeypatch.delenv(compiling.AHEAD_ENV)
        if hasattr(os, "sched_getaffinity"):
            monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0})
            assert not compile_ahead.needed("smooth", "exact")    # one core
            monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0, 1})
        folder = Path(cache_folder()) / "smoothdist._kernels"
        folder.mkdir(parents=True, exist_ok=True)
        (folder / "mesh_moment.smooth_moment_primitive_tasks-120.py311.nbi").write_bytes(b"")
        assert not compile_ahead.needed("smooth", "exact")        # compiled already


def _mesh(kinds, shift=0.0):
    """A mesh with ``kinds`` (a subset of points, edges, triangles) on a subdivided square."""
    n = 4
    g = np.linspace(0.0, 1.0, n)
    V = np.array([[x, y, shift] for y in g for x in g])
    parts = {}
    if "points" in kinds:
        parts["points"] = np.arange(0, n * n, 3)
    if "edges" in kinds:
        parts["edges"] = [[i, i + 1] for i in range(n * n - 1) if (i + 1) % n]
    if "triangles" in kinds:
        parts["triangles"] = [[i, i + 1, i + n] for i in range(n * n - n) if (i + 1) % n]
    return DataMesh(V, **parts)


@pytest.mark.parametrize("kinds", [("points",), ("edges",), ("triangles",),
                                   ("edges", "triangles"), ("points", "edges", "triangles")])
def test_the_stand_in_data_chooses_the_bodys_kernels(kinds):
    """A pair's kernels follow its data mesh's kinds: the child's stand-in has the same."""
    data = _mesh(kinds)
    tiny = compile_ahead.tiny_data_mesh(data)
    for name in ("points", "edges", "triangles"):
        assert bool(getattr(tiny, name).size) == (name in kinds), name
    query = _mesh(("edges",), shift=2.0)
    a, b = (MeshDistance(SmoothDistanceField(m), query, alpha=20.0, alpha_q=20.0)
            for m in (data, tiny))
    assert a._distance_kernel is b._distance_kernel
    assert a._exact_kernels == b._exact_kernels


def test_the_movie_child_gets_the_frames_scene(monkeypatch):
    """``start_movie``: the render's child for the frames' scene (its number of bodies, its
    march and film settings at the movie's size)."""
    calls = []
    monkeypatch.setattr(compile_ahead, "start_ahead",
                        lambda march, film, objects: calls.append((march, film, objects)))
    sim = load_simulation(ICO_BOWL)
    compile_ahead.start_movie(sim, (32, 24))
    scene = body_scene(sim, (32, 24))
    assert calls == [(scene.march, scene.film, len(sim.bodies))]
    assert (scene.film.width, scene.film.height) == (32, 24)


def test_simulate_starts_the_movie_child_unless_it_renders_none(monkeypatch, tmp_path):
    """``tracer simulate`` asks for the movie's child after its first step's, and not with
    ``--no-render``."""
    sizes = []
    monkeypatch.setattr(compile_ahead, "start_movie", lambda sim, size: sizes.append(size))
    monkeypatch.setattr(cli_simulate, "render_movie", lambda *a, **k: None)   # no frames
    for k, extra in enumerate((["--no-render"], ["--size", "16", "12"])):
        assert main(["simulate", str(ICO_BOWL), "--steps", "1", "-o", str(tmp_path / f"o{k}"),
                     "-q", *extra]) == 0
    assert [list(s) for s in sizes] == [[16, 12]]
