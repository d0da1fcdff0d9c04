"""Warm library calls of two checkouts, in turn: a whole-mesh vertex gradient and a point
cloud's closing alpha.

Each round runs, for the code before (``--before``, e.g. a ``git worktree`` of an older commit)
and this code (``--after``, default this checkout), a fresh process that imports that checkout's
``smoothdist`` (its folder first on ``sys.path``), calls each case once (compiling it, or
loading it from that checkout's own cache folder) and then times it:

* ``vertex_gradient``: ``MeshDistance((V, F), (0.3 V, F), alpha=50, alpha_q=50)
  .vertex_gradient(R, t)``, ``V, F`` trimesh's ``icosphere(3)`` (1,280 triangles), the copy
  moved by ``t = (0, 0, 1.6)``: the best of ``--repeat`` calls, milliseconds;
* ``closing_alpha``: ``SmoothDistanceField(P).closing_alpha(30.0)`` of 2,000 normal random
  points put on the unit sphere (seed 0): the best of 5 calls, seconds. Its value is written
  too: it must be the same on both sides.

Usage::

    git worktree add /tmp/before 7142e07
    python benchmarks/bench_library_ab.py --before /tmp/before --rounds 3 \\
        --out benchmarks/data/library_issue63_ab.json
"""

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run from a checkout without installing
    sys.path.insert(0, str(ROOT))

from benchmarks.bench_coldstart import git_state  # noqa: E402
from benchmarks.machine import cpu_name  # noqa: E402

#: the child: ``argv[1]`` the checkout, ``argv[2]`` the vertex gradient's timed calls
CHILD = r"""
import json, sys, time
sys.path.insert(0, sys.argv[1])
import numpy as np, trimesh
import smoothdist as sd
from smoothdist.field import SmoothDistanceField
assert sd.__file__.startswith(sys.argv[1]), sd.__file__

def best(f, n):
    f()
    out = []
    for _ in range(n):
        t0 = time.perf_counter()
        f()
        out.append(time.perf_counter() - t0)
    return min(out)

m = trimesh.creation.icosphere(subdivisions=3)
V, F = np.asarray(m.vertices), np.asarray(m.faces)
md = sd.MeshDistance((V, F), (0.3 * V, F), alpha=50, alpha_q=50)
R, t = np.eye(3), np.array([0.0, 0.0, 1.6])
vg = best(lambda: md.vertex_gradient(R, t), int(sys.argv[2]))
P = np.random.default_rng(0).normal(size=(2000, 3))
P /= np.linalg.norm(P, axis=1, keepdims=True)
field = SmoothDistanceField(P)
ca = best(lambda: field.closing_alpha(30.0), 5)
print(json.dumps({"vertex_gradient_ms": 1e3 * vg, "closing_alpha_s": ca,
                  "closing_alpha": field.closing_alpha(30.0)}))
"""


def run(checkout, repeat):
    """One fresh process of ``CHILD`` in ``checkout``; its JSON report."""
    env = dict(os.environ, MPLBACKEND="Agg")
    env.pop("PYTHONPATH", None)
    p = subprocess.run([sys.executable, "-c", CHILD, str(checkout), str(repeat)], env=env,
                       cwd=checkout, capture_output=True, text=True, timeout=1800)
    if p.returncode:
        raise SystemExit(f"{checkout}: the child failed\n{p.stderr[-3000:]}")
    return json.loads(p.stdout.strip().splitlines()[-1])


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--before", required=True, help="the checkout of the code before")
    p.add_argument("--after", default=str(ROOT), help="the checkout of this code (default: "
                   "this one)")
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--repeat", type=int, default=30, help="timed vertex gradients per run")
    p.add_argument("--out", required=True, help="results JSON")
    args = p.parse_args(argv)
    sides = {"before": Path(args.before).resolve(), "after": Path(args.after).resolve()}
    for side, path in sides.items():
        if not (path / "smoothdist" / "__init__.py").is_file():
            p.error(f"--{side} {path} holds no smoothdist package")
    res = {"date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
           "machine": {"cores": os.cpu_count(), "cpu": cpu_name()},
           "settings": {"rounds": args.rounds, "repeat": args.repeat}}
    for side, path in sides.items():
        commit, dirty = git_state(path)
        res[side] = {"commit": commit, "dirty": dirty, "runs": []}
    for r in range(args.rounds):
        order = ("before", "after") if r % 2 == 0 else ("after", "before")
        for side in order:
            report = dict(run(sides[side], args.repeat), load=os.getloadavg()[0])
            res[side]["runs"].append(report)
            print(f"round {r + 1} {side:6s} vertex_gradient {report['vertex_gradient_ms']:.2f} "
                  f"ms, closing_alpha {report['closing_alpha_s']:.3f} s", flush=True)
    alphas = {run["closing_alpha"] for side in sides for run in res[side]["runs"]}
    if len(alphas) != 1:
        raise SystemExit(f"the closing alpha differs between the sides: {sorted(alphas)}")
    tmp = Path(args.out).with_suffix(".json.tmp")
    tmp.write_text(json.dumps(res, indent=1) + "\n", encoding="utf-8")
    tmp.replace(args.out)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
