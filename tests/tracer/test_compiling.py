"""``tracer/compiling.py``: the watch on numba's compile events and the ETA that leaves the
compile time out, and the progress displays that use them (``ProgressBar``, ``StudyProgress``).

The displays are driven by hand with a watch of their own whose compile flag the test sets
(as numba's ``on_start`` / ``on_end`` events would); only :func:`test_the_watch_sees_a_compile`
compiles (a one-line function), and :func:`test_a_render_shows_the_compile_then_the_bar` renders
a tiny scene whose first tile "compiles" for 0.7 s.
"""

import io
import threading
import time
from pathlib import Path

import numba
from numba.core import event

from tracer.compiling import COMPILING, CompileWatch, Eta, compile_watch
from tracer.rendering import march
from tracer.rendering.frame import ProgressBar
from tracer.rendering.renderer import render
from tracer.runner import StudyProgress
from tracer.scenes.scene import load_scene

SCENES = Path(__file__).resolve().parents[2] / "scenes"


class Stream(io.StringIO):
    """A terminal (``tty=True``) or a log file."""

    def __init__(self, tty):
        super().__init__()
        self.tty = tty

    def isatty(self):
        return self.tty


def _compiled(watch, seconds_ago):
    """End the watch's compilation ``seconds_ago`` seconds before now."""
    watch.on_end(None)
    watch.ended = time.perf_counter() - seconds_ago


def test_the_bar_says_compiling_then_counts_the_eta_from_the_compile_end():
    watch = CompileWatch()
    out = Stream(tty=True)
    bar = ProgressBar("render bunny", stream=out, min_seconds=0.0, eta=Eta(watch))
    watch.on_start(None)  # a kernel, and one of its callees inside it
    watch.on_start(None)
    bar.waiting(3.0)
    watch.on_end(None)
    bar.waiting(12.0)
    assert out.getvalue() == ("\r\033[Krender bunny compiling kernels (once per machine),"
                              "    3.0s elapsed\r\033[Krender bunny compiling kernels (once per "
                              "machine),   12.0s elapsed")
    _compiled(watch, 0.5)  # at 20 s: 10 % done half a second later
    bar(48, 480, 20.5)
    assert out.getvalue().endswith("render bunny [###                           ]  10.0%   "
                                   "20.5s elapsed, ~  4.5s left")  # not ~184.5 s
    bar(96, 480, 21.0)
    assert out.getvalue().endswith("20.0%   21.0s elapsed, ~  4.0s left")
    bar(480, 480, 23.0)
    assert out.getvalue().endswith("100.0%   23.0s elapsed, ~  0.0s left\n")


def test_a_bar_without_compiling_is_as_before():
    watch = CompileWatch()
    out = Stream(tty=True)
    bar = ProgressBar("render", stream=out, min_seconds=0.5, eta=Eta(watch))
    bar.waiting(1.0)  # nothing compiles: nothing to say
    bar(10, 100, 0.2)  # before min_seconds
    assert out.getvalue() == ""
    bar(25, 100, 1.0)
    assert out.getvalue().endswith("[#######                       ]  25.0%    1.0s elapsed, "
                                   "~  3.0s left")


def test_a_log_gets_a_line_when_compiling_starts_and_per_quarter():
    watch = CompileWatch()
    out = Stream(tty=False)
    bar = ProgressBar("render", stream=out, min_seconds=0.0, eta=Eta(watch))
    watch.on_start(None)
    for t in (1.0, 2.0, 3.0):
        bar.waiting(t)
    _compiled(watch, 1.0)  # at 3 s
    for done, t in ((10, 4.0), (20, 5.0), (30, 6.0), (50, 7.0), (100, 8.0)):
        bar(done, 100, t)
    lines = out.getvalue().splitlines()
    assert lines[0] == f"render {COMPILING},    1.0s elapsed"
    assert [ln.split("]")[1].split("%")[0].strip() for ln in lines[1:]] == ["10.0", "30.0",
                                                                            "50.0", "100.0"]
    assert lines[1].endswith("~  9.0s left")  # 10 % in the second after the compile


def test_the_eta_restarts_with_a_new_run_and_ignores_a_compile_before_it():
    watch = CompileWatch()
    eta = Eta(watch)
    _compiled(watch, 100.0)  # long before the run
    assert eta.left(0.0, 0.1) is None
    assert eta.left(0.5, 10.0) == 10.0
    assert eta.left(0.25, 1.0) == 3.0  # the clock went back: another run
    watch.on_start(None)
    assert eta.left(0.3, 2.0) is None and eta.compiling


def test_study_progress_says_compiling():
    watch = CompileWatch()
    out = Stream(tty=True)
    prog = StudyProgress("ablate-beta bunny.off", 2.0, n_tasks=2, stream=out)
    prog.eta = Eta(watch)
    cb = prog.item(1.0)
    watch.on_start(None)
    cb.waiting(1.0)
    assert out.getvalue().endswith(f"0/2 done, 0.0s elapsed, {COMPILING}")
    _compiled(watch, 0.0)
    prog.finish(1.0, "points beta 0")
    assert "50.0% 1/2 done" in out.getvalue().splitlines()[-1]
    assert COMPILING not in out.getvalue().splitlines()[-1]


def test_the_watch_sees_a_compile():
    watch = compile_watch()
    assert compile_watch() is watch  # registered once
    before = watch.ended
    seen = []

    @numba.njit(cache=False)
    def inner(x):
        return x + 1

    @numba.njit(cache=False)
    def outer(x):
        return inner(x) * 2

    class Probe(CompileWatch):  # the depth while numba's events arrive
        def on_start(self, ev):
            seen.append(watch.depth)

    probe = Probe()
    event.register("numba:compile", probe)
    try:
        assert outer(1) == 4
    finally:
        event.unregister("numba:compile", probe)
    assert watch.depth == 0 and watch.ended is not None and watch.ended != before
    assert seen == [1, 2]  # outer, then inner inside it


def test_a_render_shows_the_compile_then_the_bar(monkeypatch):
    """``tracer.render`` tells the bar while its tiles wait for their kernel (the first tile
    holds them 0.7 s, flagged as compiling, as numba's compiler lock would), then shows the
    bar; a plain callable still sees ``done > 0`` only."""
    watch = CompileWatch()
    real, lock, first = march.render_tiles, threading.Lock(), []

    def render_tiles(*args):
        with lock:
            if not first:
                first.append(True)
                watch.on_start(None)
                time.sleep(0.7)
                watch.on_end(None)
        return real(*args)

    monkeypatch.setattr(march, "render_tiles", render_tiles)
    out = Stream(tty=False)
    scene = load_scene(SCENES / "bunny_points.json", {"width": 24, "height": 20})
    render(scene, progress=ProgressBar("render bunny", stream=out, min_seconds=0.0,
                                       eta=Eta(watch)))
    lines = out.getvalue().splitlines()
    assert lines[0].startswith(f"render bunny {COMPILING},") and len(lines) >= 2, lines
    assert "100.0%" in lines[-1] and COMPILING not in lines[-1], lines
    calls = []
    first.clear()
    render(scene, progress=lambda done, total, t: calls.append(done))
    assert calls and min(calls) > 0
