"""Benchmark the shipped simulations (``scenes/simulations/*.json``).

Per scene: seconds per step (the time step only: constraint evaluations and the interior-point
solve; the per-frame exact distance for the report is excluded), pair-distance evaluations per
step, interior-point iterations per step (mean and max), the fraction of steps in contact, and
the minimum exact distance between any two bodies over the whole run (must stay > 0).

    python benchmarks/bench_sim.py                       # run every scene (no rendering)
    python benchmarks/bench_sim.py --steps 50 bunnies_plane
    python benchmarks/bench_sim.py --from DIR            # summarise DIR/<scene>/trajectory.npz

Timings depend on the machine's load; say so when you report them.
"""

import argparse
import glob
import json
import os
import sys
import tempfile
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))

from tracer.sim import run  # noqa: E402
from tracer.sim.simfile import load_simulation  # noqa: E402


def summarise(name, z, wall=None):
    """A dict of the benchmark figures from a trajectory's arrays."""
    it = z["ipm_iterations"][1:]
    ev = z["distance_evaluations"][1:]
    sec = z["seconds"][1:]
    row = {"scene": name, "steps": int(it.size),
           "seconds_per_step": round(float(sec.mean()), 4),
           "distance_evaluations_per_step": round(float(ev.mean()), 2),
           "ipm_iterations_per_step": round(float(it.mean()), 2),
           "ipm_iterations_max": int(it.max()),
           "contact_steps": round(float((it > 0).mean()), 3),
           "min_exact_distance": float(np.min(z["min_exact_distance"])),
           "simulate_seconds": round(float(sec.sum()), 1)}
    if wall is not None:
        row["wall_seconds"] = round(wall, 1)
    return row


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scenes", nargs="*", help="scene names (default: all)")
    ap.add_argument("--steps", type=int, help="override every scene's step count")
    ap.add_argument("--from", dest="src", metavar="DIR",
                    help="summarise DIR/<scene>/trajectory.npz instead of running")
    ap.add_argument("--json", metavar="OUT.json", help="also write the rows as JSON")
    args = ap.parse_args(argv)
    files = sorted(glob.glob(os.path.join(HERE, "..", "scenes", "simulations", "*.json")))
    names = [os.path.splitext(os.path.basename(f))[0] for f in files]
    pick = args.scenes or names
    rows = []
    for f, name in zip(files, names):
        if name not in pick:
            continue
        if args.src:
            p = os.path.join(args.src, name, "trajectory.npz")
            if not os.path.exists(p):
                print(f"skip {name}: no {p}", file=sys.stderr)
                continue
            rows.append(summarise(name, run.load_trajectory(p)))
        else:
            sim = load_simulation(f)
            with tempfile.TemporaryDirectory() as tmp:
                t0 = time.perf_counter()
                run.simulate(sim, os.path.join(tmp, "trajectory.npz"), steps=args.steps)
                wall = time.perf_counter() - t0
                rows.append(summarise(name, run.load_trajectory(os.path.join(tmp,
                                                                            "trajectory.npz")),
                                      wall))
        print(json.dumps(rows[-1]), flush=True)
    if rows:
        keys = list(rows[0])
        print("\n| " + " | ".join(keys) + " |")
        print("|" + "---|" * len(keys))
        for r in rows:
            print("| " + " | ".join(f"{r.get(k, '')}" if not isinstance(r.get(k), float)
                                    else f"{r[k]:.4g}" for k in keys) + " |")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(rows, fh, indent=1)


if __name__ == "__main__":
    main()
