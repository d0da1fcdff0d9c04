"""Where a first render's wall time goes: both processes' compilations and waits on one clock.

Runs ``tracer render ARGS`` (default: the 1,280-triangle ``ball.obj`` of
``bench_coldstart.py`` at 256²) in a fresh process with a new empty kernel cache and its light
compiled in a second process (``tracer.scenes.compile_ahead``), and records on one clock (seconds
since the render's process started its script): in the render, each outermost numba compilation
(its end and length), each wait for the child (``tracer.compiling.wait_ahead``: its start, tag
and length) and its end; in the child, its start, its imports, its outermost compilations and
its end. A compilation's length includes the kernels it compiled inside it (its callees).
Writes ``benchmarks/data/first_render_timeline.json`` (``--out``) and prints the events in
order.

Usage::

    python benchmarks/timeline_first_render.py
    python benchmarks/timeline_first_render.py --out /tmp/t.json -- scenes/bunny_points.json
"""

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run from a checkout without installing
    sys.path.insert(0, str(ROOT))

from benchmarks.bench_coldstart import git_state, icosphere  # noqa: E402
from benchmarks.machine import cpu_name  # noqa: E402

DEFAULT_OUT = ROOT / "benchmarks" / "data" / "first_render_timeline.json"

#: both scripts: a listener of numba's compile events that notes each outermost compilation
#: (``note`` is the script's own)
TIMER = r"""
from numba.core import event
stack = []
class Timer(event.Listener):
    def on_start(self, ev):
        stack.append(time.perf_counter())
    def on_end(self, ev):
        t0 = stack.pop()
        if not stack:
            fn = getattr(ev.data.get("dispatcher"), "py_func", None)
            note("compiled", name=getattr(fn, "__qualname__", "?"), s=time.perf_counter() - t0)
event.register("numba:compile", Timer())
"""

#: the child's code: compile_ahead's, with its events logged (``log`` a JSON line each)
CHILD = r"""
import json, os, sys, time
T0 = float(os.environ["TIMELINE_T0"])
log = open(os.environ["TIMELINE_CHILD_LOG"], "a")
def note(what, **kw):
    log.write(json.dumps(dict(kw, who="child", what=what, at=time.time() - T0)) + "\n")
    log.flush()
note("start")
""" + TIMER + r"""
from tracer.scenes import compile_ahead
note("imported")
compile_ahead.child_main(sys.argv[1])
note("end")
"""

#: the render's process: the command with its events logged, as the command runs it
MAIN = r"""
import json, os, sys, time
T0 = time.time()
os.environ["TIMELINE_T0"] = repr(T0)
events = []
def note(what, **kw):
    events.append(dict(kw, who="render", what=what, at=time.time() - T0))
""" + TIMER + r"""
import tracer.compiling as compiling
compiling.AHEAD_CHILD = sys.argv[2]
wait = compiling.wait_ahead
def timed_wait(tag="done", timeout=compiling.AHEAD_WAIT):
    at = time.time() - T0
    s = wait(tag, timeout)
    events.append({"who": "render", "what": "waited", "tag": tag, "at": at, "s": s})
    return s
compiling.wait_ahead = timed_wait
import tracer.cli
import tracer.rendering.film as film
import tracer.rendering.renderer as renderer
film.wait_ahead = renderer.wait_ahead = timed_wait    # they import it by name
note("imported")
sys.argv = ["tracer", *sys.argv[3:]]
rc = tracer.cli.main()
note("end")
with open(os.environ["TIMELINE_MAIN_LOG"], "w") as f:
    json.dump({"rc": rc, "events": events}, f)
"""


def timeline(args, work):
    """One cold render with its light compiled alongside: ``{wall_s, events}`` (both
    processes' events, in time order; ``at`` seconds since the render's script started)."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(work / "cache"), MPLBACKEND="Agg",
               TRACER_COMPILE_AHEAD="on", TIMELINE_CHILD_LOG=str(work / "child.jsonl"),
               TIMELINE_MAIN_LOG=str(work / "main.json"),
               PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    env.pop("SMOOTHDIST_CACHE_DIR", None)  # it would win over NUMBA_CACHE_DIR
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, "-c", MAIN, "-", CHILD, "render", *args, "-o",
                        str(work / "out.png"), "--overwrite", "-q"], env=env, cwd=work,
                       capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if p.returncode != 0:
        raise SystemExit(f"error: the render failed:\n{p.stderr[-2000:]}")
    main = json.loads((work / "main.json").read_text())
    if main["rc"] != 0:
        raise SystemExit(f"error: the render exited {main['rc']}:\n{p.stderr[-2000:]}")
    child_log = work / "child.jsonl"
    child = [json.loads(ln) for ln in child_log.read_text().splitlines()] \
        if child_log.exists() else []
    return {"wall_s": wall, "rc": main["rc"],
            "events": sorted(main["events"] + child, key=lambda e: e["at"])}


def describe(e):
    """One event as a line."""
    what = e["what"]
    if what == "compiled":
        what = f"compiled {e['name']} ({e['s']:.2f} s)"
    elif what == "waited":
        what = f"waited {e['s']:.2f} s for the child's {e['tag']!r}"
    return f"{e['at']:6.2f}  {e['who']:6}  {what}"


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", default=str(DEFAULT_OUT))
    p.add_argument("render_args", nargs="*", help="after --: tracer render's arguments")
    a = p.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="timeline-") as tmp:
        work = Path(tmp)
        # files named relative to here (the render runs in the temporary folder)
        args = [str(Path(x).resolve()) if os.path.exists(x) else x for x in a.render_args]
        if not args:
            V, F = icosphere(3)
            ball = work / "ball.obj"
            with open(ball, "w", encoding="ascii") as f:
                f.writelines(f"v {x:.9f} {y:.9f} {z:.9f}\n" for x, y, z in V)
                f.writelines(f"f {i + 1} {j + 1} {k + 1}\n" for i, j, k in F)
            args = [str(ball), "--size", "256", "256"]
        run = timeline(args, work)
    commit, dirty = git_state(ROOT)
    first = a.render_args[0] if a.render_args else "ball.obj"
    result = {"command": "tracer render " + " ".join([first] + args[1:]),
              "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), "commit": commit,
              "dirty": dirty, "machine": {"cores": os.cpu_count(), "cpu": cpu_name(),
                                          "python": platform.python_version()},
              "load_average": os.getloadavg(), **run}
    for e in run["events"]:
        print(describe(e))
    print(f"{run['wall_s']:6.2f}  wall")
    out = Path(a.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(result, indent=1))
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
