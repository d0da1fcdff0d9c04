"""First renders with an empty cache, the code before against this code, run after run.

Our 2-core machine's compile speed drifts by a third within half an hour (the same code's first
render took 21 and 29 s of CPU 25 minutes apart, 2026-12-07), so two runs of
``bench_coldstart.py`` one after the other cannot show a change of a tenth. This script runs
the same children (``bench_coldstart.run``: a fresh process, a new empty kernel cache, the
compile events counted) for both checkouts in turn: per round and case the four runs
``before / after`` of the render in one process (``cold``) and with the light compiled in a
second process (``cold_ahead``), in the order ABBA on odd rounds and BAAB on even ones, so that
a drift during a round falls on both sides alike. Reported per side: every run, and the
smallest and median CPU seconds (``cold``) and wall seconds (``cold_ahead``): the machine's
noise only ever adds time, so the smallest is the best estimate of the code's own cost.

Usage::

    git worktree add /tmp/before <commit>
    python benchmarks/bench_coldstart_ab.py --before /tmp/before --rounds 3 \\
        --out benchmarks/data/coldstart_issue63_renders_ab.json
"""

import argparse
import json
import os
import platform
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run from a checkout without installing
    sys.path.insert(0, str(ROOT))

from benchmarks.bench_coldstart import RENDERS, describe, git_state, run, write_inputs  # noqa: E402
from benchmarks.machine import cpu_name  # noqa: E402

MODES = ("cold", "cold_ahead")


def summary(runs, mode):
    """``{min, median}`` of the runs' CPU seconds (both processes') for ``cold``, of their wall
    seconds for ``cold_ahead``."""
    if mode == "cold":
        values = [r["cpu_s"] + r["cpu_children_s"] for r in runs]
    else:
        values = [r["wall_s"] for r in runs]
    return {"min": min(values), "median": statistics.median(values)}


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--before", required=True, help="the checkout of the code before")
    p.add_argument("--after", default=str(ROOT), help="the checkout of this code (default: "
                   "this one)")
    p.add_argument("--cases", nargs="+", choices=RENDERS, default=["mesh", "cloud"])
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--modes", nargs="+", choices=MODES, default=list(MODES),
                   help="cold: the render in one process; cold_ahead: with its child "
                   "compiling alongside (default: both)")
    p.add_argument("--out", required=True, help="results JSON")
    args = p.parse_args(argv)
    sources = {"before": Path(args.before).resolve(), "after": Path(args.after).resolve()}
    for side, source in sources.items():
        if not (source / "smoothdist" / "__init__.py").is_file():
            p.error(f"--{side} {source} holds no smoothdist package")
    results = {"date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
               "machine": {"cores": os.cpu_count(), "cpu": cpu_name(),
                           "platform": platform.platform(), "python": platform.python_version()},
               "rounds": args.rounds, "modes": args.modes, "cases": {}}
    for side, source in sources.items():
        commit, dirty = git_state(source)
        results[side] = {"commit": commit, "dirty": dirty}
    work = Path(tempfile.mkdtemp(prefix="coldstart-ab-"))
    try:
        inputs = {}
        for side, source in sources.items():
            (work / side).mkdir()
            inputs[side] = write_inputs(work / side, source / "scenes")
        for case in args.cases:
            results["cases"][case] = {"command": describe(case, inputs["after"][case],
                                                          work / "after"),
                                      **{side: {m: [] for m in args.modes}
                                         for side in sources}}
        for k in range(args.rounds):
            order = ("before", "after", "after", "before") if k % 2 == 0 else \
                ("after", "before", "before", "after")
            for case in args.cases:
                for mode in args.modes:
                    for side in order[:2] if mode == args.modes[0] else order[2:]:
                        cache = Path(tempfile.mkdtemp(prefix="cache-", dir=work))
                        r = run(inputs[side][case], cache, work / side, None, sources[side],
                                ahead=mode == "cold_ahead")
                        shutil.rmtree(cache, ignore_errors=True)
                        results["cases"][case][side][mode].append(r)
                        print(f"round {k + 1} {case:6} {mode:10} {side:6} {r['wall_s']:5.1f} s "
                              f"wall {r['cpu_s'] + r['cpu_children_s']:5.1f} s CPU "
                              f"load {r['load_before']:.1f}", flush=True)
        for case, c in results["cases"].items():
            for side in sources:
                c[side]["summary"] = {m: summary(c[side][m], m) for m in args.modes}
    finally:
        shutil.rmtree(work, ignore_errors=True)
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    tmp = f"{args.out}.{os.getpid()}.tmp"
    with open(tmp, "w", encoding="utf-8") as f:
        json.dump(results, f, indent=1)
    os.replace(tmp, args.out)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
