"""Benchmark the shipped simulations (``scenes/simulations/*.json``, and with ``--table3`` the
paper's Table 3 scenes ``scenes/simulations/table3/*.json``, named ``table3/<name>``).

Per scene: seconds per step (the time step only: constraint evaluations and the interior-point
solve; the per-frame exact distance for the report is excluded), pair-distance evaluations per
step, interior-point iterations per step (mean and max), the fraction of steps in contact, and
the minimum exact distance between any two bodies over the whole run (must stay > 0).

    python benchmarks/bench_sim.py                       # run every scene (no rendering)
    python benchmarks/bench_sim.py --steps 50 bunnies_plane
    python benchmarks/bench_sim.py --from DIR            # summarise DIR/<scene>/trajectory.npz
    python benchmarks/bench_sim.py --table3 --steps 20 table3/ico_bowl   # a Table 3 scene
    python benchmarks/bench_sim.py --table3 --from DIR   # DIR/<scene>/ or DIR/<name>/trajectory.npz

The Table 3 scenes are large (up to 6.6 million points, up to hours per run at their step
counts): they run only when asked for (``--table3``), and a row then also gives the bodies'
primitive counts.

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


def primitive_counts(sim):
    """``"736 edges + (960 triangles + 6 edges)"``: each body's primitives, in file order."""
    def count(m):
        parts = [f"{n} {k}" for k, n in (("points", len(m.points)), ("edges", len(m.edges)),
                                         ("triangles", len(m.triangles))) if n]
        return parts[0] if len(parts) == 1 else "(" + " + ".join(parts) + ")"

    return " + ".join(count(b.mesh) for b in sim.bodies)


def scene_files(table3=False):
    """``[(name, path)]`` of the shipped scenes (and the Table 3 ones, ``table3/<name>``)."""
    root = os.path.join(HERE, "..", "scenes", "simulations")
    out = [(os.path.splitext(os.path.basename(f))[0], f)
           for f in sorted(glob.glob(os.path.join(root, "*.json")))]
    if table3:
        out += [("table3/" + os.path.splitext(os.path.basename(f))[0], f)
                for f in sorted(glob.glob(os.path.join(root, "table3", "*.json")))]
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scenes", nargs="*", help="scene names (default: all)")
    ap.add_argument("--table3", action="store_true",
                    help="also the Table 3 scenes (scenes/simulations/table3/, table3/<name>)")
    ap.add_argument("--steps", type=int, help="override every scene's step count")
    ap.add_argument("--from", dest="src", metavar="DIR",
                    help="summarise DIR/<scene>/trajectory.npz instead of running")
    ap.add_argument("--json", metavar="OUT.json", help="also write the rows as JSON")
    args = ap.parse_args(argv)
    scenes = scene_files(args.table3)
    pick = args.scenes or [n for n, _ in scenes]
    unknown = sorted(set(pick) - {n for n, _ in scenes})
    if unknown:
        ap.error(f"unknown scene(s) {', '.join(unknown)}"
                 + ("" if args.table3 else " (Table 3 scenes need --table3)"))
    rows = []
    for name, f in scenes:
        if name not in pick:
            continue
        if args.src:
            cands = [os.path.join(args.src, name, "trajectory.npz"),
                     os.path.join(args.src, os.path.basename(name), "trajectory.npz")]
            p = next((c for c in cands if os.path.exists(c)), None)
            if p is None:
                print(f"skip {name}: no {cands[0]}", file=sys.stderr)
                continue
            rows.append(summarise(name, run.load_trajectory(p)))
            if name.startswith("table3/"):
                rows[-1]["primitives"] = primitive_counts(load_simulation(f))
        else:
            sim = load_simulation(f)
            with tempfile.TemporaryDirectory() as tmp:
                t0 = time.perf_counter()
                run.simulate(sim, os.path.join(tmp, "trajectory.npz"), steps=args.steps)
                wall = time.perf_counter() - t0
                rows.append(summarise(name, run.load_trajectory(os.path.join(tmp,
                                                                            "trajectory.npz")),
                                      wall))
            if name.startswith("table3/"):
                rows[-1]["primitives"] = primitive_counts(sim)
        print(json.dumps(rows[-1]), flush=True)
    if rows:
        keys = list(dict.fromkeys(k for r in rows for k in r))
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
