"""The paper's 2D study (Fig. 9): a point mass dropped into a V-shaped bowl, exact vs smooth.

A single point (the query) falls under gravity (-y) into a V made of two edges in the x-y plane
(the data, static), once with the **exact-minimum** constraint ``d - 1/alpha >= 0`` (C0: its
gradient flips across the medial axis above the V's vertex) and once with the **smooth**
constraint ``d_hat >= 0`` (alpha 20, alpha_U 40, as the authors' ``point_bowl2d``). Both use the
same integrator and interior-point solver (:mod:`tracer.sim.integrator`); only the constraint
differs. Two bowls: a shallow one (arms rising 0.35 over a half-width of 1) and a deep one (1.0);
the point starts just above the left arm, sliding down it.

``python -m tracer.sim.vbowl -o renders/sim`` writes ``vbowl.png`` (trajectories and kinetic
energy) and ``vbowl.json`` (per run: final position, kinetic energy at the end, largest x
reached, time the point first passed x = 0, time it left the bowl (the run stops there),
solver iterations).
"""

import argparse
import json
import os

import numpy as np

from tracer.outputs import atomic_write
from tracer.sim import primitives
from tracer.sim.bodies import Body
from tracer.sim.constraint import ContactConstraint
from tracer.sim.integrator import Integrator

#: V half-width and depth; the point starts ``lift`` above the left arm at ``x0``, sliding down
#: along the arm at ``speed``
BOWLS = {"shallow": {"half_width": 1.0, "depth": 0.35, "x0": -0.9, "lift": 0.08, "speed": 1.5},
         "deep": {"half_width": 1.0, "depth": 1.0, "x0": -0.8, "lift": 0.08, "speed": 1.0}}
ALPHA, ALPHA_U = 20.0, 40.0
DT, STEPS = 0.005, 600
G = np.array([0.0, -9.81, 0.0])


def run(bowl, mode, steps=STEPS, dt=DT):
    """Simulate one case; returns a dict of arrays ``t, x, y, ke`` and solver totals."""
    spec = BOWLS[bowl]
    v = Body.from_mesh(primitives.make({"type": "segment_v", "half_width": spec["half_width"],
                                        "depth": spec["depth"]}), name="bowl", alpha=ALPHA,
                       alpha_u=ALPHA_U, static=True)
    down = np.array([spec["half_width"], -spec["depth"], 0.0])
    down /= np.linalg.norm(down)
    normal = np.array([-down[1], down[0], 0.0])            # up and to the right of the left arm
    on_arm = np.array([spec["x0"], -spec["depth"] * spec["x0"] / spec["half_width"], 0.0])
    p = Body.from_mesh(primitives.make({"type": "point"}), name="point", alpha=ALPHA,
                       position=on_arm + spec["lift"] * normal, velocity=spec["speed"] * down)
    con = ContactConstraint([v, p], beta=0.0, mode=mode)
    sim = Integrator([v, p], con, G, dt)
    t, xs, ys, ke, iters = [0.0], [p.x[0]], [p.x[1]], [0.0], 0
    for _ in range(steps):
        st = sim.step()
        iters += st.iterations
        t.append(sim.time)
        xs.append(p.x[0])
        ys.append(p.x[1])
        ke.append(0.5 * p.mass * float(p.v @ p.v))
        if abs(p.x[0]) > 1.1 * spec["half_width"]:
            break                                          # it rolled out of the bowl
    return {"t": np.array(t), "x": np.array(xs), "y": np.array(ys), "ke": np.array(ke),
            "iterations": iters, "V": v.world_vertices()}


def summary(r):
    """Scalars of one run (for the JSON report)."""
    crossed = np.nonzero(r["x"] >= 0)[0]
    return {"final_x": round(float(r["x"][-1]), 4), "final_y": round(float(r["y"][-1]), 4),
            "final_kinetic_energy": round(float(r["ke"][-1]), 5),
            "max_kinetic_energy": round(float(r["ke"].max()), 5),
            "max_x": round(float(r["x"].max()), 4),
            "first_crossing_time": (None if crossed.size == 0
                                    else round(float(r["t"][crossed[0]]), 3)),
            "left_the_bowl_at": (round(float(r["t"][-1]), 3)
                                 if abs(r["x"][-1]) > r["V"][:, 0].max() else None),
            "ipm_iterations": int(r["iterations"])}


def plot(results, path):
    """Trajectories (left) and kinetic energy (right), one row per bowl."""
    import matplotlib  # matplotlib (studies extra): loaded on use

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # matplotlib (studies extra): loaded on use

    colours = {"exact": "tab:green", "smooth": "tab:orange"}
    fig, axes = plt.subplots(2, 2, figsize=(8.0, 6.0), dpi=90)
    for row, bowl in enumerate(BOWLS):
        ax, ax2 = axes[row]
        V = results[(bowl, "smooth")]["V"]
        ax.plot(V[:, 0], V[:, 1], "k-", lw=2)
        for mode in ("exact", "smooth"):
            r = results[(bowl, mode)]
            ax.plot(r["x"], r["y"], "-", color=colours[mode], lw=1.2, label=mode)
            ax2.plot(r["t"], r["ke"], "-", color=colours[mode], lw=1.2, label=mode)
        ax.set_aspect("equal")
        ax.set_title(f"{bowl} bowl: trajectory")
        ax.set_xlim(-1.3, 1.3)
        ax.set_ylim(-0.1, V[:, 1].max() + 0.3)
        ax2.set_title(f"{bowl} bowl: kinetic energy")
        ax2.set_xlabel("time (s)")
        ax2.set_ylabel("J (unit mass)")
        ax.legend(loc="upper center", fontsize=8)
        ax2.legend(fontsize=8)
    fig.tight_layout()

    with atomic_write(path) as tmp:
        fig.savefig(tmp, format="png")
    plt.close(fig)


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m tracer.sim.vbowl",
                                 description=__doc__.split("\n")[0])
    ap.add_argument("-o", "--out", default="renders/sim", help="output folder")
    ap.add_argument("--steps", type=int, default=STEPS)
    args = ap.parse_args(argv)
    os.makedirs(args.out, exist_ok=True)
    results = {(b, m): run(b, m, steps=args.steps) for b in BOWLS for m in ("exact", "smooth")}
    plot(results, os.path.join(args.out, "vbowl.png"))
    report = {"alpha": ALPHA, "alpha_u": ALPHA_U, "dt": DT, "steps": args.steps,
              "bowls": BOWLS,
              "runs": {f"{b}/{m}": summary(r) for (b, m), r in results.items()}}
    with open(os.path.join(args.out, "vbowl.json"), "w") as fh:
        json.dump(report, fh, indent=1)
    print(json.dumps(report["runs"], indent=1))


if __name__ == "__main__":
    main()
