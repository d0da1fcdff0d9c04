"""Exact against split torques (issue 17): accuracy, energy, solver effort and cost.

Per shipped scene, one run with each option (``tracer.sim.constraint``, ``torques``):

* the rotation gradient of the constraint against central differences of its value (h = 1e-6)
  at every ``--every``-th step in contact, relative to the true rotation gradient and to
  ``|force| x radius`` (median over the samples);
* steps whose mechanical energy (kinetic + gravitational, moving bodies) rose, and by how much;
* interior-point iterations per step in contact, distance evaluations and seconds per step;

then a rocking box (12 big triangles on a plane, where the two differ most), and the cost of
one pair evaluation, ``MeshDistance.with_couple`` against ``MeshDistance.__call__``, as
interleaved medians in the same process (the machine's load moves absolute times, not much
the ratio).

    python benchmarks/bench_torques.py                     # every scene, the files' steps
    python benchmarks/bench_torques.py --steps 100 bunnies_plane
"""

import argparse
import json
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))

from tracer.sim import primitives, run  # noqa: E402
from tracer.sim.bodies import Body, rotation_matrix  # noqa: E402
from tracer.sim.constraint import ContactConstraint  # noqa: E402
from tracer.sim.integrator import Integrator  # noqa: E402
from tracer.sim.simfile import load_simulation  # noqa: E402

SCENES = ("bunnies_plane", "ico_bowl", "trefoil_ringtoss", "lidar_slide")
MODES = ("exact", "split")


def energy(bodies, gravity):
    return sum(b.kinetic_energy() - b.mass * float(np.dot(gravity, b.x))
               for b in bodies if not b.static)


def gradient_errors(integ, other, h=1e-6):
    """``(err_exact, err_split, torque / (force radius))`` of the current state's rotation
    gradient against central differences (``integ`` and ``other``: the two options)."""
    X0, R0 = integ.current()
    n = len(integ.dyn)
    q = np.zeros(6 * n)
    for i, k in enumerate(integ.dyn):
        q[6 * i:6 * i + 3] = integ.bodies[k].x
    g = {integ.constraint.torques: integ.constraint_at(q, X0, R0)[1],
         other.constraint.torques: other.constraint_at(q, X0, R0)[1]}
    num = np.empty_like(q)
    for k in range(q.size):
        e = np.zeros_like(q)
        e[k] = h
        num[k] = (integ.constraint_at(q + e, X0, R0)[0]
                  - integ.constraint_at(q - e, X0, R0)[0]) / (2 * h)
    rot = np.concatenate([np.arange(6 * i + 3, 6 * i + 6) for i in range(n)])
    tr = np.concatenate([np.arange(6 * i, 6 * i + 3) for i in range(n)])
    radius = max(integ.bodies[k].radius for k in integ.dyn)
    nrm = np.linalg.norm(num[rot])
    return (np.linalg.norm(g["exact"][rot] - num[rot]) / nrm,
            np.linalg.norm(g["split"][rot] - num[rot]) / nrm,
            nrm / (np.linalg.norm(num[tr]) * radius))


def run_scene(name, mode, steps, every):
    sim = load_simulation(os.path.join(HERE, "..", "scenes", "simulations", f"{name}.json"))
    con, integ = run.build(sim, torques=mode)
    other = Integrator(sim.bodies, ContactConstraint(sim.bodies, beta=sim.beta,
                                                     mode=sim.constraint,
                                                     torques=MODES[mode == "exact"]),
                       sim.gravity, sim.dt, gap_tol=sim.gap_tol)
    steps = sim.steps if steps is None else steps
    E = [energy(sim.bodies, sim.gravity)]
    its, evs, secs, errs = [], [], [], []
    for _ in range(steps):
        st = integ.step()
        its.append(st.iterations)
        evs.append(st.evaluations)
        secs.append(st.seconds)
        E.append(energy(sim.bodies, sim.gravity))
        if st.iterations and sum(i > 0 for i in its) % every == 0:
            errs.append(gradient_errors(integ, other))
    its, dE, errs = np.array(its), np.diff(E), np.array(errs).reshape(-1, 3)
    med = np.median(errs, axis=0) if len(errs) else [np.nan] * 3
    return {"scene": name, "torques": mode, "steps": steps,
            "s_per_step": float(np.mean(secs)), "s_per_evaluation": float(sum(secs) / sum(evs)),
            "evaluations_per_step": float(np.mean(evs)),
            "ipm_iterations_per_contact_step": float(its[its > 0].mean()) if its.any() else 0.0,
            "contact_steps": int((its > 0).sum()),
            "energy_rising_steps": int((dE > 1e-12 * abs(E[0])).sum()),
            "energy_gained": float(dE[dE > 0].sum()),
            "fd_samples": len(errs), "fd_error_exact": float(med[0]),
            "fd_error_split": float(med[1]), "torque_over_force_radius": float(med[2])}


def rocking_box(mode, steps=600):
    """A 0.6 x 0.4 x 0.2 box (12 triangles) dropped tilted on a plane (alpha 60)."""
    G = np.array([0.0, 0.0, -9.81])
    plane = Body.from_mesh(primitives.make({"type": "plane", "size": [3, 3], "resolution": 3}),
                           name="plane", alpha=60.0, static=True)
    box = Body.from_mesh(primitives.make({"type": "box", "size": [0.6, 0.4, 0.2]}), name="box",
                         alpha=60.0, rotation=rotation_matrix([0.35, 0.1, 0.0]),
                         position=[0.1, 0.05, 0.0])
    box.x[2] += 0.15 - (box.mesh.V @ box.R.T + box.x)[:, 2].min()
    sim = Integrator([plane, box], ContactConstraint([plane, box], torques=mode), G, 0.005)
    E = [energy([box], G)]
    its = []
    for _ in range(steps):
        its.append(sim.step().iterations)
        E.append(energy([box], G))
    dE = np.diff(E)
    tilt = np.degrees(np.arccos(min(1.0, abs((box.R @ [0, 0, 1.0])[2]))))
    return {"scene": "rocking_box", "torques": mode, "steps": steps,
            "energy_rising_steps": int((dE > 1e-12).sum()), "energy_gained": float(dE[dE > 0].sum()),
            "ipm_iterations_per_step": float(np.mean(its)), "final_tilt_deg": float(tilt),
            "final_speed": float(np.linalg.norm(box.v)),
            "final_angular_speed": float(np.linalg.norm(box.w))}


def cost_ratio(name, warm_steps=60, reps=40):
    """Per pair: median seconds of ``md(R, t)`` and ``md.with_couple(R, t)``, interleaved."""
    sim = load_simulation(os.path.join(HERE, "..", "scenes", "simulations", f"{name}.json"))
    con, integ = run.build(sim)
    for _ in range(warm_steps):
        integ.step()
    X, Rs = integ.current()
    rows = []
    for p in con.pairs:
        R, t = p.relative(X, Rs)
        p.md(R, t)
        p.md.with_couple(R, t)
        a, b = [], []
        for _ in range(reps):
            t0 = time.perf_counter()
            p.md(R, t)
            a.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            p.md.with_couple(R, t)
            b.append(time.perf_counter() - t0)
        rows.append({"scene": name, "pair": f"{sim.bodies[p.i].name}<-{sim.bodies[p.j].name}",
                     "split_ms": 1e3 * float(np.median(a)), "exact_ms": 1e3 * float(np.median(b)),
                     "ratio": float(np.median(b) / np.median(a))})
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenes", nargs="*", default=list(SCENES))
    ap.add_argument("--steps", type=int, help="steps per scene (default: the file's)")
    ap.add_argument("--every", type=int, default=10,
                    help="check the gradient at every N-th step in contact (default 10)")
    ap.add_argument("-o", "--out", help="write the rows as JSON here")
    args = ap.parse_args(argv)
    rows = []
    for name in args.scenes:
        for mode in MODES:
            rows.append(run_scene(name, mode, args.steps, args.every))
            print(json.dumps(rows[-1]), flush=True)
    for mode in MODES:
        rows.append(rocking_box(mode))
        print(json.dumps(rows[-1]), flush=True)
    for name in args.scenes:
        for r in cost_ratio(name):
            rows.append(r)
            print(json.dumps(r), flush=True)
    if args.out:
        with open(args.out, "w") as f:
            json.dump(rows, f, indent=1)


if __name__ == "__main__":
    main()
