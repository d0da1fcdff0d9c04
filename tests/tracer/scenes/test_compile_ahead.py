"""A first render's light kernels compiled in a child process (``tracer.scenes.compile_ahead``).

* On an empty cache ``tracer render``'s child compiles the scene's distance, the shading
  normals' and the light's kernels with the types the render calls them with: the render
  compiles none of them (it loads them), and its image is byte for byte the one of a render
  that compiled them itself.
* A child that has compiled the distance before the render asks takes the trace kernel, and
  the render compiles the film's kernels meanwhile: no kernel twice, the same image. The two
  processes share out those jobs through files in a folder of their own
  (:func:`~tracer.compiling.claim_job`).
* An unlit first render's child compiles the scene's distance, which the render loads.
* :func:`~tracer.compiling.ahead_needed` starts nothing where it cannot help: outside an
  entry point that allows it, turned off, one core, a cache that holds the kernels already.
* A child that fails or hangs never fails the render: :func:`tracer.compiling.wait_ahead` stops
  it after its timeout.
"""

import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

from smoothdist.warmup import cache_folder
from tracer import compiling
from tracer.cli import main
from tracer.scenes.settings import Film, March

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "benchmarks"))
import bench_coldstart  # noqa: E402  (its child script reports what a process compiled)

BUNNY = ROOT / "scenes" / "data" / "bunny.off"
CORES = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
#: the light's top-level kernels (what a lit render's film calls from Python for its light)
LIGHT_KERNELS = ("tracer.rendering.lighting.light_tasks", "tracer.rendering.lighting._lowest_hit")
#: the scene's distance, which the child compiles first (the render's camera check calls it)
DISTANCE = "tracer.rendering.march.distance_at"
#: the shading normals' kernel, which the child compiles next (the render calls it after its
#: trace)
NORMALS = "tracer.rendering.march.gradient_tasks"
#: the anti-aliasing samples' kernel, which the child compiles last (the render calls it after
#: its light)
SAMPLES = "tracer.rendering.march.sample_tasks"



def _env(cache, ahead, trace="render"):
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""),
               MPLBACKEND="Agg")
    env[compiling.AHEAD_ENV] = ahead
    # who compiles the trace kernel: left to the race between the two processes, the test
    # would check whichever came first
    env[compiling.AHEAD_TRACE_ENV] = trace
    if cache is not None:
        env["SMOOTHDIST_CACHE_DIR"] = str(cache)
    return env


def _render(out, cache, ahead, *extra, trace="render"):
    """``tracer render BUNNY`` in a fresh process (``bench_coldstart``'s child: it reports the
    specialisations of our functions it compiled, ``kernels``); ``trace``: who compiles the
    trace kernel when a child compiles ahead (``render`` or ``child``)."""
    p = subprocess.run([sys.executable, "-c", bench_coldstart.CHILD, "cli", "render", str(BUNNY),
                        "--size", "24", "20", "-o", str(out), "-q", *extra],
                       env=_env(cache, ahead, trace), capture_output=True, text=True,
                       timeout=600)
    assert p.returncode == 0, p.stderr[-3000:]
    report = json.loads(p.stdout.strip().splitlines()[-1])
    assert report["rc"] == 0
    return report["kernels"]


def _mesh_settings():
    """The settings ``tracer render MESH`` renders with (the table's mesh column)."""
    from tracer.scenes.settings import defaults

    d = defaults("mesh")
    return (March(**{k: d[k] for k in March.__dataclass_fields__}),
            Film(**{k: d[k] for k in Film.__dataclass_fields__}))


@pytest.mark.slow
@pytest.mark.skipif(CORES < 2, reason="compiling ahead needs a second core")
def test_a_first_render_loads_the_film_kernels_its_child_compiled(tmp_path):
    """``tracer render MESH`` on an empty cache: its child compiles the scene's distance, the
    shading normals' and the light's kernels, which the render then loads (it compiles the
    tree's and the trace's), and the image is byte for byte the one of a render that compiles
    those kernels itself."""
    compiled = _render(tmp_path / "ahead.png", tmp_path / "cache", "on")
    assert any(name.startswith("smoothdist._kernels.bvh") for name in compiled)   # cold cache
    assert "tracer.rendering.march.render_tiles" in compiled
    # the trace's helpers compiled while the render waited for the child's distance
    # (march.compile_helpers), with the types the trace calls them with: none compiled twice
    assert {"tracer.rendering.march.next_step", "tracer.rendering.camera.camera_ray",
            "tracer.rendering.march.cone_first_step"} <= set(compiled)
    assert all(n == 1 for n in compiled.values()), compiled
    assert not set(LIGHT_KERNELS + (DISTANCE, NORMALS)) & set(compiled), compiled
    # the same cache without the kernels the child compiled, nothing compiled ahead: the
    # render compiles them itself (and loads the rest: a second empty cache took 15 s more)
    shutil.copytree(tmp_path / "cache", tmp_path / "cache2")
    for name in LIGHT_KERNELS + (DISTANCE, NORMALS):
        package, _, function = name.rpartition(".")
        package, _, module = package.rpartition(".")
        files = list((tmp_path / "cache2").glob(f"*/{package}/{module}.{function}-*.nb[ic]"))
        assert len(files) >= 2, (name, files)          # its index and its compiled code
        for f in files:
            f.unlink()
    alone = _render(tmp_path / "alone.png", tmp_path / "cache2", "off")
    assert set(LIGHT_KERNELS + (DISTANCE, NORMALS)) <= set(alone), alone
    assert (tmp_path / "ahead.png").read_bytes() == (tmp_path / "alone.png").read_bytes()


@pytest.mark.slow
@pytest.mark.skipif(CORES < 2, reason="compiling ahead needs a second core")
def test_a_child_that_takes_the_trace_leaves_the_film_to_the_render(tmp_path):
    """A child that has compiled the scene's distance before the render asks for the trace
    (here made to: ``TRACER_COMPILE_AHEAD_TRACE=child``) compiles the march and the trace
    kernel; the render compiles the film's kernels (the shading normals', the light's, the
    ground probe's and, of 4 samples per pixel, the samples') on a tiny image of its own
    scene meanwhile. Neither the distance nor the trace is compiled by the render, nothing
    twice, and the image is byte for byte the one rendered here."""
    extra = ("--samples", "4")
    compiled = _render(tmp_path / "ahead.png", tmp_path / "cache", "on", *extra, trace="child")
    assert any(name.startswith("smoothdist._kernels.bvh") for name in compiled)   # cold cache
    trace = {"tracer.rendering.march.render_tiles", "tracer.rendering.march.march_ray", DISTANCE}
    assert not trace & set(compiled), compiled
    assert set(LIGHT_KERNELS + (NORMALS, SAMPLES)) <= set(compiled), compiled
    assert all(n == 1 for n in compiled.values()), compiled
    assert main(["render", str(BUNNY), "--size", "24", "20", "-o", str(tmp_path / "here.png"),
                 "-q", *extra]) == 0
    assert (tmp_path / "ahead.png").read_bytes() == (tmp_path / "here.png").read_bytes()


@pytest.mark.slow
@pytest.mark.skipif(CORES < 2, reason="compiling ahead needs a second core")
def test_an_unlit_first_render_loads_the_distance_its_child_compiled(tmp_path):
    """``tracer render MESH --shading normals`` on an empty cache: its child compiles the
    scene's distance while the render builds its tree; the render loads it, and its image is
    the one rendered here."""
    compiled = _render(tmp_path / "ahead.png", tmp_path / "cache", "on", "--shading", "normals")
    assert "tracer.rendering.march.render_tiles" in compiled                # cold cache
    assert DISTANCE not in compiled and not set(LIGHT_KERNELS) & set(compiled), compiled
    assert main(["render", str(BUNNY), "--size", "24", "20", "-o", str(tmp_path / "here.png"),
                 "-q", "--shading", "normals"]) == 0
    assert (tmp_path / "ahead.png").read_bytes() == (tmp_path / "here.png").read_bytes()


def test_needed_only_where_it_can_help(monkeypatch, tmp_path):
    march, film = _mesh_settings()
    cfg = compiling.ahead_config(march, film, 1)
    monkeypatch.delenv(compiling.AHEAD_ENV, raising=False)
    monkeypatch.setenv("SMOOTHDIST_CACHE_DIR", str(tmp_path / "empty"))
    if hasattr(os, "sched_getaffinity"):
        monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0, 1})
    assert not compiling.ahead_needed(cfg)                    # not within an entry point
    with compiling.ahead_allowed():
        assert compiling.ahead_needed(cfg)
        assert compiling.ahead_needed(dict(cfg, shading="normals"))   # no light: the distance
        monkeypatch.setenv(compiling.AHEAD_ENV, "off")
        assert not compiling.ahead_needed(cfg)
        monkeypatch.delenv(compiling.AHEAD_ENV)
        if hasattr(os, "sched_getaffinity"):
            monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0})
            assert not compiling.ahead_needed(cfg)                # one core
            monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0, 1})
        folder = Path(cache_folder()) / "tracer.rendering"
        folder.mkdir(parents=True, exist_ok=True)
        (folder / "lighting.light_tasks-233.py311.nbi").write_bytes(b"")
        assert not compiling.ahead_needed(cfg)                    # compiled already
        assert compiling.ahead_needed(dict(cfg, shading="normals"))
        (folder / "march.distance_at-923.py311.nbi").write_bytes(b"")
        assert not compiling.ahead_needed(dict(cfg, shading="normals"))


def test_a_job_goes_to_the_process_that_claims_it_first(tmp_path):
    """:func:`~tracer.compiling.claim_job`: the render takes a job only where its child has not
    (one file created with ``O_EXCL`` in their folder); it does not wait for its child to say
    the tag of a job it took; ``tell_children`` leaves a file that ``wait_for`` sees, and
    ``wait_for`` gives up when the folder is gone (the render ended)."""
    child = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"],
                             stdout=subprocess.PIPE, bufsize=0)
    folder = tmp_path / "claims"
    folder.mkdir()
    compiling.ahead(child, str(folder))
    try:
        assert compiling.claim(str(folder), "trace")          # the child's claim comes first
        assert not compiling.claim_job("trace")
        assert compiling.claim_job("samples")
        assert compiling.claim_job("samples")                 # still its own the second time
        assert not compiling.claim(str(folder), "samples")   # the child's comes second
        # its own job is not waited for: a wait for the child would time out and stop it
        compiling.wait_ahead("samples", timeout=0.5)
        assert child.poll() is None
        assert not compiling.wait_for(str(folder), "march", timeout=0.1)   # not there: gives up
        compiling.tell_children("march")
        assert compiling.wait_for(str(folder), "march", timeout=30.0)      # there
        assert compiling.wait_for(str(tmp_path / "gone"), "march", timeout=30.0)  # no folder
        assert compiling.ahead_running()
    finally:
        compiling.wait_ahead(timeout=0.5)                      # stopped, its folder removed
    assert child.poll() is not None and not folder.exists()
    assert not compiling.ahead_running()


def test_the_render_waits_for_the_childs_trace_under_its_progress_bar():
    """:func:`tracer.rendering.renderer.while_waiting` (the render compiling its film while its
    child compiles the trace): the job runs while the calling thread tells the progress display
    that nothing is done yet, a few times a second; its error is raised in the caller; without
    a display the job just runs."""
    from tracer.rendering import renderer

    calls = []

    class Bar:
        def __call__(self, done, total, elapsed):
            calls.append(("done", done))

        def waiting(self, elapsed):
            calls.append(("waiting", elapsed))

    renderer.while_waiting(lambda: time.sleep(0.6), Bar(), 100, time.perf_counter())
    assert len(calls) >= 2 and {c[0] for c in calls} == {"waiting"}

    def boom():
        raise ValueError("boom")

    with pytest.raises(ValueError, match="boom"):
        renderer.while_waiting(boom, Bar(), 100, time.perf_counter())
    ran = []
    renderer.while_waiting(lambda: ran.append(1), None, 100, 0.0)
    assert ran == [1]


def test_a_hung_child_is_stopped_and_a_failed_one_ignored():
    hung = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    failed = subprocess.Popen([sys.executable, "-c", "raise SystemExit(3)"])
    compiling.ahead(hung)
    compiling.ahead(failed)
    t0 = time.perf_counter()
    waited = compiling.wait_ahead(timeout=1.0)
    assert 0.9 < waited < 30 and time.perf_counter() - t0 < 30
    assert hung.poll() is not None and failed.poll() == 3
    assert compiling.wait_ahead() < 0.5                         # nothing left to wait for


def test_a_childs_errors_go_to_the_log_it_is_given(monkeypatch, tmp_path):
    """``TRACER_COMPILE_AHEAD_LOG``: a child's error output is appended to that file, after a
    line naming the render's process; without it, nowhere (and a log that cannot be opened
    does not stop the child)."""
    march, film = _mesh_settings()
    child = ("import sys; print('boom from the child', file=sys.stderr); "
             "sys.stdout.write('done\\n'); raise SystemExit(4)")
    monkeypatch.setattr(compiling, "AHEAD_CHILD", child)
    monkeypatch.setattr(compiling, "ahead_needed", lambda cfg: True)
    log = tmp_path / "ahead.log"
    log.write_text("before\n")
    for path in (str(log), str(tmp_path / "no" / "such" / "folder.log"), ""):
        monkeypatch.setenv(compiling.AHEAD_LOG_ENV, path)
        assert compiling.start_ahead(march, film, 1)
        compiling.wait_ahead(timeout=30.0)
    lines = log.read_text().splitlines()
    assert lines[0] == "before" and len(lines) == 3
    assert lines[1].endswith(f"tracer: compile-ahead child of process {os.getpid()}")
    assert lines[2] == "boom from the child"
