"""Warm whole-mesh distances of two checkouts, side by side: ``bench_mesh_distance.py`` run in
the code before (``--before``, e.g. a ``git worktree`` of an older commit) and in this one,
alternating round by round, so that both see the same machine.

Writes ``{"mesh_distance_ms_best": {"before": {case: [ms per round]}, "after": {...}}}`` (and
``"mesh_exact_ms_best"``, the exact distance ``MeshDistance.exact``, alike) with
the commits, the date and the load averages (``--out``). Each run is a fresh process that
loads its kernels from the per-machine cache (the first run of a checkout compiles them, and
is not timed differently: ``bench_mesh_distance.py`` warms up before it times).

Usage::

    git worktree add /tmp/before 2d0cc4e
    python benchmarks/bench_mesh_distance_ab.py --before /tmp/before --rounds 3 \\
        --out benchmarks/data/coldstart_issue63_kinds_warm.json
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
if str(ROOT) not in sys.path:  # run from a checkout without installing
    sys.path.insert(0, str(ROOT))

from benchmarks.machine import cpu_name  # noqa: E402


def run(checkout, args, out):
    """One ``bench_mesh_distance.py`` run in ``checkout``: its results dict."""
    subprocess.run([sys.executable, "benchmarks/bench_mesh_distance.py", *args, "--json", out],
                   cwd=checkout, check=True, capture_output=True)
    return json.loads(Path(out).read_text(encoding="utf-8"))


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--before", required=True, help="the checkout of the code before")
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--repeat", type=int, default=10, help="timed calls per case and run")
    p.add_argument("--out", required=True)
    a = p.parse_args(argv)
    sides = {"before": Path(a.before).resolve(), "after": ROOT}
    best = {side: {} for side in sides}
    exact = {side: {} for side in sides}
    commits, loads = {}, []
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(a.rounds):
            for side, checkout in sides.items():
                loads.append(os.getloadavg()[0])
                d = run(checkout, ["--repeat", str(a.repeat), "--tol", "0"],
                        os.path.join(tmp, "run.json"))
                commits[side] = d["commit"]
                for row in d["results"]:
                    best[side].setdefault(row["case"], []).append(round(row["ms_best"], 3))
                    exact[side].setdefault(row["case"], []).append(round(row["exact_ms_best"], 3))
    out = {"what": f"warm MeshDistance calls, best of {a.repeat} (ms), bench_mesh_distance.py "
                   f"--tol 0 in each checkout, alternating, one value per round",
           "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
           "commit_before": commits["before"], "commit_after": commits["after"],
           "cpu": cpu_name(), "cores": os.cpu_count(),
           "load_average": [round(min(loads), 2), round(max(loads), 2)],
           "mesh_distance_ms_best": best, "mesh_exact_ms_best": exact}
    Path(a.out).write_text(json.dumps(out, indent=1) + "\n", encoding="utf-8")
    print(json.dumps(best))
    return 0


if __name__ == "__main__":
    sys.exit(main())
