"""Where a first render's compile time goes: every numba compilation, timed.

Runs ``python -m tracer render ARGS`` in a fresh process with an empty ``NUMBA_CACHE_DIR``
for each LLVM optimisation level of ``--opt`` (``NUMBA_OPT``; numba's default is 3), with a
listener on numba's ``numba:compile`` events. Records per run: the wall seconds of the
process, and per compiled function its inclusive seconds and its own (without the
compilations nested in it, i.e. its callees). Writes ``benchmarks/data/compile_profile.json``
(``--out``) and prints the functions that cost most.

Usage::

    python benchmarks/profile_compile.py                      # ball.obj (a 1,280-triangle
                                                              # icosphere), 256x256, opt 3 2 1
    python benchmarks/profile_compile.py --opt 3 -- scenes/bunny_points.json --size 64 64
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_OUT = ROOT / "benchmarks" / "data" / "compile_profile.json"

#: run in the child: the render with a timer on every compilation
CHILD = r"""
import json, sys, time
from numba.core import event

spans, stack = [], []


class Timer(event.Listener):
    def on_start(self, ev):
        stack.append(time.perf_counter())

    def on_end(self, ev):
        t0 = stack.pop()
        fn = getattr(ev.data.get("dispatcher"), "py_func", None)
        name = f"{getattr(fn, '__module__', '')}.{getattr(fn, '__qualname__', '?')}"
        spans.append((name, time.perf_counter() - t0, len(stack)))


event.register("numba:compile", Timer())
import tracer.cli
rc = tracer.cli.main(sys.argv[2:])
json.dump({"rc": rc, "spans": spans}, open(sys.argv[1], "w"))
"""


def own_times(spans):
    """``{function: own seconds}`` from ``(name, seconds, depth)`` spans in the order they
    ended (a nested compilation ends before the one it is nested in)."""
    own, nested = {}, {}
    for name, t, depth in spans:
        inner = nested.pop(depth + 1, 0.0)
        own[name] = own.get(name, 0.0) + t - inner
        nested[depth] = nested.get(depth, 0.0) + t
    return own


def profile(args, opt):
    """One cold run at ``NUMBA_OPT=opt``: a dict of the figures."""
    with tempfile.TemporaryDirectory() as tmp:
        env = dict(os.environ, NUMBA_CACHE_DIR=str(Path(tmp) / "cache"), NUMBA_OPT=str(opt),
                   PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
        env.pop("SMOOTHDIST_CACHE_DIR", None)  # it would win over NUMBA_CACHE_DIR
        spans_file = Path(tmp) / "spans.json"
        out_png = Path(tmp) / "out.png"
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-c", CHILD, str(spans_file), "render", *args, "-o",
                        str(out_png), "-q"], env=env, check=True, cwd=ROOT)
        wall = time.perf_counter() - t0
        spans = json.loads(spans_file.read_text())["spans"]
    own = own_times(spans)
    return {"opt": opt, "wall_s": wall, "load_average": os.getloadavg(),
            "compilations": len(spans),
            "compile_s": sum(t for _, t, depth in spans if depth == 0),
            "own_s": dict(sorted(own.items(), key=lambda kv: -kv[1]))}


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--opt", type=int, nargs="+", default=[3, 2, 1])
    p.add_argument("--out", default=str(DEFAULT_OUT))
    p.add_argument("render_args", nargs="*", help="after --: tracer render's arguments")
    a = p.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        args = a.render_args
        if not args:
            import trimesh

            ball = Path(tmp) / "ball.obj"
            trimesh.creation.icosphere(subdivisions=3).export(ball)
            args = [str(ball), "--size", "256", "256"]
        runs = [profile(args, opt) for opt in a.opt]
    first = args[0] if a.render_args else "ball.obj"
    result = {"command": "tracer render " + " ".join([first] + args[1:]),
              "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), "runs": runs}
    for r in runs:
        top = ", ".join(f"{k.rsplit('.', 1)[-1]} {v:.2f}" for k, v in list(r["own_s"].items())[:8])
        print(f"NUMBA_OPT={r['opt']}: {r['wall_s']:.1f} s wall, {r['compilations']} "
              f"compilations, {r['compile_s']:.1f} s compiling; most: {top}")
    out = Path(a.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(result, indent=1))
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
