"""
A log-barrier contact solver on MeshDistance
============================================

A box is pulled into a bumpy floor; a log barrier on the smooth distance keeps it out. The
unknowns are the box's translation ``t`` and a rotation, the objective
``0.5 |t - goal|^2 - mu log d_hat(R, t)``, and each step is a gradient step with a backtracking
(Armijo) line search that also rejects any trial with ``d_hat <= 0``. A step moves no vertex
further than ``0.9 d_hat``: since ``d_hat`` never exceeds the true gap, the box cannot tunnel
through the floor between two feasible placements. The barrier needs the
derivative of the value it is given: ``MeshDistance.rigid_gradient`` returns it (force and
torque, the library's default ``gradient="exact"``), and ``alpha=sd.within(e)`` sets the
sharpness so that ``d_hat`` is at most ``e`` below the true gap near contact (the guide's
advice; ``beta=0`` for triangle queries). Two placements: aligned, and tilted by 30 degrees,
which the barrier's torque lays flat.
"""

import matplotlib.pyplot as plt
import numpy as np
import trimesh

import smoothdist as sd


def rotation(w):
    """Rotation matrix of the rotation vector ``w`` (Rodrigues)."""
    th = np.linalg.norm(w)
    if th < 1e-15:
        return np.eye(3)
    k = w / th
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(th) * K + (1 - np.cos(th)) * K @ K


def floor(n=16, size=3.0, bump=0.03):
    """A bumpy square of triangles at z = 0 (the data)."""
    x = np.linspace(-size / 2, size / 2, n)
    X, Y = np.meshgrid(x, x)
    Z = bump * np.sin(3 * X) * np.cos(2 * Y)
    V = np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=1)
    i = np.arange(n - 1)[:, None] * n + np.arange(n - 1)[None, :]
    F = np.concatenate([np.stack([i, i + 1, i + n], -1), np.stack([i + 1, i + n + 1, i + n], -1)])
    return V, F.reshape(-1, 3)


def solve(tilt_deg=0.0, e=0.005, mu=1e-3, rounds=4, steps=40, n=16):
    """Pull a 0.6 x 0.4 x 0.2 box from 0.3 above the floor towards a goal 0.5 below it."""
    box = trimesh.creation.box(extents=[0.6, 0.4, 0.2])
    md = sd.MeshDistance(floor(n), (box.vertices, box.faces), alpha=sd.within(e), beta=0.0)
    R, t = rotation(np.radians([tilt_deg, 0.0, 0.0])), np.array([0.1, 0.0, 0.45])
    goal = np.array([0.1, 0.0, -0.5])
    radius = np.linalg.norm(box.vertices, axis=1).max()
    stats = {"steps": 0, "backtracks": 0, "infeasible": 0, "min_d_hat": np.inf, "min_gap": np.inf}
    history = []                                     # (d_hat, exact gap, tilt) per step

    def objective(R, t):
        d = md(R, t)[0]
        return (0.5 * (t - goal) @ (t - goal) - mu * np.log(d)) if d > 0 else np.inf, d

    for _ in range(rounds):                          # barrier continuation: mu, mu/4, ...
        for _ in range(steps):
            f, d = objective(R, t)
            _, force, torque = md.rigid_gradient(R, t)
            g = np.concatenate([t - goal - mu / d * force, -mu / d * torque])
            J = np.concatenate([force, torque])      # Gauss-Newton: the barrier's mu/d^2 J J^T
            H = np.diag([1.0, 1, 1, radius**2, radius**2, radius**2]) + mu / d**2 * np.outer(J, J)
            p = -np.linalg.solve(H, g)
            if -(g @ p) < 1e-12:                     # Newton decrement: converged for this mu
                break
            # no vertex moves further than 0.9 d_hat <= 0.9 x the true gap: no tunnelling
            step = min(1.0, 0.9 * d / (np.linalg.norm(p[:3]) + radius * np.linalg.norm(p[3:])))
            while True:                              # backtracking: feasible and Armijo
                R1, t1 = rotation(step * p[3:]) @ R, t + step * p[:3]
                f1, d1 = objective(R1, t1)
                if d1 <= 0:
                    stats["infeasible"] += 1
                elif f1 <= f + 1e-4 * step * (g @ p):
                    break
                stats["backtracks"] += 1
                step *= 0.5
                if step < 1e-12:
                    break
            if step < 1e-12:                         # no descent left at float64 precision
                break
            R, t = R1, t1
            stats["steps"] += 1
            gap = md.exact(R, t)[0]
            stats["min_d_hat"] = min(stats["min_d_hat"], d1)
            stats["min_gap"] = min(stats["min_gap"], gap)
            history.append((d1, gap, np.degrees(np.arccos(np.clip(R[2, 2], -1, 1)))))
        mu /= 4
    tilt = np.degrees(np.arccos(np.clip(R[2, 2], -1, 1)))
    return {**stats, "t": t, "tilt_deg": tilt, "d_hat": md(R, t)[0], "gap": md.exact(R, t)[0],
            "alpha": md.alpha, "alpha_q": md.alpha_q, "history": np.array(history)}


results = {tilt: solve(tilt) for tilt in (0.0, 30.0)}
for tilt, r in results.items():
    print(f"start tilt {tilt:4.1f} deg: {r['steps']} steps, {r['backtracks']} backtracks "
          f"({r['infeasible']} infeasible trials); rests at z = {r['t'][2]:.4f}, tilt "
          f"{r['tilt_deg']:.1f} deg, d_hat {r['d_hat']:.4f}, exact gap {r['gap']:.4f} "
          f"(smallest on the path {r['min_gap']:.4f}); alpha {r['alpha']:.0f}")

fig, (top, bottom) = plt.subplots(2, 1, figsize=(6.5, 4.6), sharex=True)
for (tilt, r), colour in zip(results.items(), ("C0", "C1")):
    h = r["history"]
    top.semilogy(h[:, 1], colour, label=f"start tilt {tilt:.0f} deg: exact gap")
    top.semilogy(h[:, 0], colour + ":", label="d_hat")
    bottom.plot(h[:, 2], colour)
top.axhline(0.005, color="k", lw=1, ls="--", label="error budget e")
top.set_ylabel("distance (scene units)")
top.legend(fontsize=7, ncol=2)
bottom.set_ylabel("tilt (degrees)")
bottom.set_xlabel("solver step (mu divided by 4 after each round of at most 40 steps)")
plt.tight_layout()
