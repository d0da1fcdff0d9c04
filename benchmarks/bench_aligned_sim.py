"""Axis-aligned bodies resting on a grid plane against the same bodies rotated (issue 37).

An icosphere (trimesh, subdivisions 2, radius 0.5) and a box (0.6 x 0.4 x 0.3), each dropped
from a small height onto a 20 x 20 triangle grid plane and left to settle, once with the body's
edges and faces aligned with the grid (axis-aligned) and once rotated (the ball by a random
rotation, the box by 0.4 rad about the vertical, so that it still lands on a face). Where the
smooth distance jumped with the choice between equally close point pairs, the aligned runs
needed more interior-point iterations and distance evaluations than the rotated ones; the
target is the same number within 20 %.

    python benchmarks/bench_aligned_sim.py                 # the table (about a minute)
    python benchmarks/bench_aligned_sim.py --steps 40 --json OUT.json
    python benchmarks/bench_aligned_sim.py --part barrier --steps 30   # the log-barrier table

Per run: interior-point iterations and distance evaluations in total and per step, seconds
(the time steps only; depends on the machine's load: say so when you report them), and the
aligned / rotated ratios.

A second table drops the same bodies (translation only, sliding at 0.3 and 0.1 m/s across the
grid's lines) with a plain log barrier on ``d_hat``
as a user's own simulator would: each time step minimises the incremental potential
``m |x - x_pred|^2 / (2 dt^2) - kappa log d_hat(x)`` by preconditioned gradient descent with an
Armijo backtracking line search. A jump of ``d_hat`` shows up there as failed line searches
(no step down to 1e-12 satisfies Armijo) and extra distance calls.
"""

import argparse
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

#: a fixed random rotation vector (radians) for the ball
BALL_ROTATION = [0.61, -0.27, 1.13]
BODIES = {
    "ball": ({"type": "icosphere", "radius": 0.5, "subdivisions": 2}, 0.62, BALL_ROTATION),
    "box": ({"type": "box", "size": [0.6, 0.4, 0.3]}, 0.27, [0.0, 0.0, 0.4]),
}


def scene(body, rotated, steps):
    """The simulation file (a dict) of one run."""
    shape, height, rotation = BODIES[body]
    spec = {"name": shape["type"], "primitive": dict(shape), "alpha": 50,
            "position": [0.0, 0.0, height], "velocity": [0.0, 0.0, 0.0]}
    if rotated:
        spec["rotation"] = rotation
    return {"name": f"{body}_{'rotated' if rotated else 'aligned'}", "dt": 0.01, "steps": steps,
            "gravity": [0, 0, -9.81],
            "camera": {"origin": [0, -3, 1.2], "dest": [0, 0, 0.3], "up": [0, 0, 1],
                       "width": 160, "height": 120},
            "bodies": [{"name": "plane", "primitive": {"type": "plane", "size": [4, 4],
                                                       "resolution": 20},
                        "alpha": 50, "static": True}, spec]}


def run_one(body, rotated, steps):
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "sim.json")
        with open(path, "w") as fh:
            json.dump(scene(body, rotated, steps), fh)
        sim = load_simulation(path)
        t0 = time.perf_counter()
        run.simulate(sim, os.path.join(tmp, "trajectory.npz"))
        wall = time.perf_counter() - t0
        z = run.load_trajectory(os.path.join(tmp, "trajectory.npz"))
    it = z["ipm_iterations"][1:]
    ev = z["distance_evaluations"][1:]
    return {"body": body, "pose": "rotated" if rotated else "aligned", "steps": int(it.size),
            "ipm_iterations": int(it.sum()), "distance_evaluations": int(ev.sum()),
            "contact_steps": int((it > 0).sum()),
            "min_exact_distance": float(np.min(z["min_exact_distance"])),
            "seconds": round(float(z["seconds"][1:].sum()), 2), "wall_seconds": round(wall, 2)}


def barrier_drop(body, rotated, steps, dt=0.01, kappa=1e-3, mass=1.0):
    """Drop the body with a log barrier on d_hat; returns the line search's figures."""
    import trimesh

    from smoothdist import MeshDistance
    from tracer.sim.bodies import rotation_matrix
    from tracer.sim.primitives import make

    shape, height, rotation = BODIES[body]
    plane = make({"type": "plane", "size": [4, 4], "resolution": 20})
    if shape["type"] == "icosphere":
        m = trimesh.creation.icosphere(subdivisions=shape["subdivisions"], radius=shape["radius"])
    else:
        m = trimesh.creation.box(extents=shape["size"])
    V = np.asarray(m.vertices) @ (rotation_matrix(rotation).T if rotated else np.eye(3))
    md = MeshDistance(plane, (V, np.asarray(m.faces)), alpha=50.0, alpha_q=50.0, beta=0.5,
                      gradient="exact")
    x = np.array([0.0, 0.0, height + 0.05])
    # sliding across the grid's lines while it settles, as a dropped body does
    v = np.array([0.3, 0.1, 0.0])
    g = np.array([0.0, 0.0, -9.81])
    calls = fails = iters = 0

    def energy(y, pred):
        nonlocal calls
        calls += 1
        d, G = md(None, y)
        if d <= 0.0:
            return np.inf, None
        e = mass * np.dot(y - pred, y - pred) / (2 * dt * dt) - kappa * np.log(d)
        return e, mass * (y - pred) / (dt * dt) - kappa * G.sum(axis=0) / d

    t0 = time.perf_counter()
    for _ in range(steps):
        pred = x + dt * v + dt * dt * g
        y = x.copy()
        e, grad = energy(y, pred)
        for _ in range(100):
            iters += 1
            p = -grad * dt * dt / mass
            if np.linalg.norm(p) < 1e-10:
                break
            a = 1.0
            while a > 1e-12:
                e2, g2 = energy(y + a * p, pred)
                if e2 <= e + 1e-4 * a * np.dot(grad, p):
                    break
                a *= 0.5
            else:
                fails += 1
                break
            y, e, grad = y + a * p, e2, g2
        v = (y - x) / dt
        x = y
    return {"body": body, "pose": "rotated" if rotated else "aligned", "steps": steps,
            "descent_iterations": iters, "distance_calls": calls, "failed_line_searches": fails,
            "final_height": round(float(x[2]), 6), "seconds": round(time.perf_counter() - t0, 2)}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--steps", type=int, default=60, help="time steps per run (default 60)")
    ap.add_argument("--json", metavar="OUT.json", help="also write the rows as JSON")
    ap.add_argument("--part", choices=("both", "simulator", "barrier"), default="both",
                    help="which table to run (default both)")
    args = ap.parse_args(argv)
    rows = []
    for body in (BODIES if args.part in ("both", "simulator") else []):
        pair = [run_one(body, rotated, args.steps) for rotated in (False, True)]
        for key in ("ipm_iterations", "distance_evaluations"):
            pair[0][f"{key}_aligned_over_rotated"] = round(
                pair[0][key] / max(pair[1][key], 1), 3)
        rows += pair
        for r in pair:
            print(json.dumps(r), flush=True)
    keys = ["body", "pose", "steps", "contact_steps", "ipm_iterations", "distance_evaluations",
            "seconds", "ipm_iterations_aligned_over_rotated",
            "distance_evaluations_aligned_over_rotated"]
    print("\n| " + " | ".join(keys) + " |")
    print("|" + "---|" * len(keys))
    for r in rows:
        print("| " + " | ".join(str(r.get(k, "")) for k in keys) + " |")
    barrier = []
    for body in (BODIES if args.part in ("both", "barrier") else []):
        pair = [barrier_drop(body, rotated, args.steps) for rotated in (False, True)]
        for key in ("descent_iterations", "distance_calls"):
            pair[0][f"{key}_aligned_over_rotated"] = round(pair[0][key] / max(pair[1][key], 1), 3)
        barrier += pair
        for r in pair:
            print(json.dumps(r), flush=True)
    keys = ["body", "pose", "steps", "descent_iterations", "distance_calls",
            "failed_line_searches", "final_height", "seconds",
            "descent_iterations_aligned_over_rotated", "distance_calls_aligned_over_rotated"]
    print("\n| " + " | ".join(keys) + " |")
    print("|" + "---|" * len(keys))
    for r in barrier:
        print("| " + " | ".join(str(r.get(k, "")) for k in keys) + " |")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"simulator": rows, "barrier": barrier}, fh, indent=1)


if __name__ == "__main__":
    main()
