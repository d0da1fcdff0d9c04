"""Run a :class:`~tracer.sim.simulation.Simulation` and write its trajectory.

The trajectory is a compressed ``.npz`` with, for ``F`` frames (the initial state and one frame
per step) and ``B`` bodies:

==========================  ===============  ===============================================
key                         shape            meaning
==========================  ===============  ===============================================
``rotations``               (F, B, 3, 3)     body rotation ``R``
``translations``            (F, B, 3)        ``t`` with mesh-file vertex ``p`` at ``R p + t``
``centers``                 (F, B, 3)        centre of mass
``velocities``              (F, B, 3)        centre-of-mass velocity
``angular_velocities``      (F, B, 3)        world angular velocity (rad/s)
``time``                    (F,)             seconds
``min_exact_distance``      (F,)             exact minimum distance between any two bodies
``constraint``              (F,)             the smooth constraint ``c`` (scene units)
``ipm_iterations``          (F,)             interior-point iterations of the step (0 at frame 0)
``distance_evaluations``    (F,)             pair-distance evaluations of the step
``seconds``                 (F,)             wall time of the step
``names``, ``static``       (B,)             body names, static flags
``sim_file``, ``dt``                         the simulation file (absolute path) and time step
==========================  ===============  ===============================================

It is written atomically (temporary file + rename) every few steps, so an interrupted run
leaves the last complete checkpoint, from which ``--resume`` continues.
"""

import os
import time

import numpy as np

from smoothdist import SmoothDistanceField
from tracer.errors import OverlapError
from tracer.outputs import atomic_write
from tracer.sim.bodies import thickness
from tracer.sim.constraint import DEFAULT_TORQUES, ContactConstraint
from tracer.sim.integrator import Integrator

__all__ = ["simulate", "build", "torques_of", "check_initial_state", "save_trajectory",
           "load_trajectory", "restore_frame", "closest_gap", "describe_gap", "FRAME_KEYS"]

#: keys with one row per frame
FRAME_KEYS = ("rotations", "translations", "centers", "velocities", "angular_velocities", "time",
              "min_exact_distance", "constraint", "ipm_iterations", "distance_evaluations",
              "seconds")


def build(sim, factory=None, torques=None):
    """``(constraint, integrator)`` for a loaded simulation.

    ``torques``: ``"exact"`` or ``"split"`` (:mod:`tracer.sim.constraint`); None takes the
    simulation's (its file's ``"torques"`` key, default ``"exact"``).
    """
    con = ContactConstraint(sim.bodies, beta=sim.beta, mode=sim.constraint, factory=factory,
                            torques=torques_of(sim, torques))
    integ = Integrator(sim.bodies, con, sim.gravity, sim.dt, gap_tol=sim.gap_tol)
    return con, integ


def torques_of(sim, torques=None):
    """The rotation gradient a run of ``sim`` uses: ``torques`` (``"exact"`` or ``"split"``),
    or, when None, the simulation's (its file's ``"torques"`` key, default ``"exact"``)."""
    if torques is None:
        torques = getattr(sim, "torques", None) or DEFAULT_TORQUES
    return torques


def check_initial_state(sim, con):
    """Refuse an initial state whose constraint is violated: ``c <= 0`` (smooth surfaces already
    overlap) or an exact distance ``<= 0`` (the geometry intersects). Returns ``(c, d_exact)``."""
    X = np.array([b.x for b in sim.bodies])
    Rs = np.array([b.R for b in sim.bodies])
    c = con.evaluate(X, Rs, gradient=False)[0]
    d = con.min_exact_distance(X, Rs)
    name = os.path.basename(sim.path)
    if not d > 0:
        raise OverlapError(f"{name}: the bodies overlap in the initial state (exact distance "
                           f"{d:.4g}); move them apart")
    if not c > 0:
        raise OverlapError(f"{name}: the bodies' smooth surfaces overlap in the initial state "
                           f"(constraint {c:.4g} <= 0, exact distance {d:.4g}); move them apart "
                           "or raise alpha")
    return c, d


def _frame(sim, con, stats=None):
    bodies = sim.bodies
    X = np.array([b.x for b in bodies])
    Rs = np.array([b.R for b in bodies])
    row = {
        "rotations": Rs,
        "translations": np.array([b.x - b.R @ b.offset for b in bodies]),
        "centers": X,
        "velocities": np.array([b.v for b in bodies]),
        "angular_velocities": np.array([b.w for b in bodies]),
        "min_exact_distance": con.min_exact_distance(X, Rs),
        "constraint": stats.c if stats else con.evaluate(X, Rs, gradient=False)[0],
        "ipm_iterations": stats.iterations if stats else 0,
        "distance_evaluations": stats.evaluations if stats else 0,
        "seconds": stats.seconds if stats else 0.0,
    }
    return row


def save_trajectory(path, sim, frames, overwrite=True):
    """Write the frames (a dict of per-frame lists) as a compressed npz, atomically."""
    arrays = {k: np.asarray(frames[k]) for k in FRAME_KEYS}
    arrays["names"] = np.array([b.name for b in sim.bodies])
    arrays["static"] = np.array([b.static for b in sim.bodies])
    arrays["sim_file"] = np.array(os.path.abspath(sim.path))
    arrays["dt"] = np.array(sim.dt)
    with atomic_write(path, overwrite=overwrite) as tmp:
        with open(tmp, "wb") as fh:
            np.savez_compressed(fh, **arrays)


def load_trajectory(path):
    """A trajectory file as a dict of arrays (ValueError when it is not one)."""
    path = os.fspath(path)
    if not os.path.isfile(path):
        raise ValueError(f"trajectory file not found: {path}")
    try:
        with np.load(path, allow_pickle=False) as z:
            data = {k: z[k] for k in z.files}
    except Exception as exc:  # noqa: BLE001 (numpy raises many kinds on garbage)
        raise ValueError(f"{os.path.basename(path)}: not a trajectory .npz file "
                         f"({type(exc).__name__})") from None
    missing = [k for k in FRAME_KEYS + ("names", "sim_file") if k not in data]
    if missing:
        raise ValueError(f"{os.path.basename(path)}: not a trajectory file (missing "
                         f"{', '.join(missing)})")
    return data


def restore_frame(sim, data, frame=-1):
    """Put the bodies of ``sim`` in the state of a trajectory frame; returns the frame's time."""
    names = [str(n) for n in data["names"]]
    if names != [b.name for b in sim.bodies]:
        raise ValueError(f"the trajectory's bodies {names} are not the simulation's "
                         f"{[b.name for b in sim.bodies]}")
    for k, b in enumerate(sim.bodies):
        b.x = data["centers"][frame, k].copy()
        b.R = data["rotations"][frame, k].copy()
        b.v = data["velocities"][frame, k].copy()
        b.w = data["angular_velocities"][frame, k].copy()
    return float(data["time"][frame])


def simulate(sim, out_path, *, steps=None, resume=False, overwrite=False, progress=None,
             factory=None, checkpoint_seconds=20.0, built=None, torques=None):
    """Run ``sim`` and write its trajectory to ``out_path``; returns the frames dict.

    ``steps`` overrides the file's step count. With ``resume`` an existing trajectory is
    continued from its last frame up to ``steps`` in total. ``progress(done, total, elapsed)``
    is called after each step. ``built``: the ``(constraint, integrator)`` of
    :func:`~tracer.sim.run.build` when the caller has them already. ``torques`` (``"exact"`` /
    ``"split"``) overrides the file's rotation gradient (:mod:`tracer.sim.constraint`); not with
    ``built``.
    """
    steps = sim.steps if steps is None else int(steps)
    if built is not None and torques is not None and built[0].torques != torques:
        raise ValueError(f"torques={torques!r} but the built constraint has "
                         f"{built[0].torques!r}")
    con, integ = built if built is not None else build(sim, factory, torques=torques)
    frames = {k: [] for k in FRAME_KEYS}
    if resume and os.path.exists(out_path):
        data = load_trajectory(out_path)
        integ.time = restore_frame(sim, data)
        for k in FRAME_KEYS:
            frames[k] = list(data[k])
    else:
        check_initial_state(sim, con)
        row = _frame(sim, con)
        row["time"] = 0.0
        for k in FRAME_KEYS:
            frames[k].append(row[k])
    done = len(frames["time"]) - 1
    t0 = time.perf_counter()
    last_save = t0
    first_write = not (resume and os.path.exists(out_path))
    for s in range(done, steps):
        stats = integ.step()
        row = _frame(sim, con, stats)
        row["time"] = integ.time
        for k in FRAME_KEYS:
            frames[k].append(row[k])
        now = time.perf_counter()
        if now - last_save > checkpoint_seconds:
            save_trajectory(out_path, sim, frames, overwrite=overwrite or not first_write)
            first_write = False
            last_save = now
        if progress is not None:
            progress(s + 1 - done, steps - done, now - t0)
    save_trajectory(out_path, sim, frames, overwrite=overwrite or not first_write)
    return frames


def closest_gap(sim, con, centers, rotations):
    """How far apart the closest pair of bodies is at a pose, and how it looks.

    ``centers (B, 3)``, ``rotations (B, 3, 3)``: a frame of the trajectory. Returns a dict:
    ``a``, ``b`` (body names), ``exact`` (exact distance between their meshes), ``drawn``
    (estimated mean offsets of the two bodies' rendered surfaces from their meshes,
    :meth:`smoothdist.SmoothDistanceField.offset_estimate`), ``visible`` (``exact`` minus
    both offsets: the gap a render shows; negative when the drawn surfaces overlap) and
    ``thickness`` (the smaller body's :func:`tracer.sim.bodies.thickness`). None without pairs.
    """

    X = np.asarray(centers, dtype=float)
    Rs = np.asarray(rotations, dtype=float)
    best = None
    for p in con.pairs:
        R, t = p.relative(X, Rs)
        d = float(p.md.exact(R, t)[0])
        if best is None or d < best[0]:
            best = (d, p.i, p.j, getattr(p.md, "field", None))
    if best is None:
        return None
    d, i, j, data_field = best
    offsets = []
    for k, field in ((i, data_field), (j, None)):  # the data body's field is the pair's own
        b = sim.bodies[k]
        field = field or SmoothDistanceField(b.mesh)
        offsets.append(field.offset_estimate(b.alpha, alpha_u=b.alpha_u, beta=sim.beta))
    return {"a": sim.bodies[i].name, "b": sim.bodies[j].name, "exact": d,
            "drawn": tuple(offsets), "visible": d - sum(offsets),
            "thickness": min(thickness(sim.bodies[k].mesh) for k in (i, j))}


def describe_gap(gap):
    """One sentence for :func:`closest_gap`'s dict."""
    if gap is None:
        return ""
    return (f"at the end {gap['a']} and {gap['b']} are {gap['exact']:.4g} apart (exact); their "
            f"drawn surfaces lie about {gap['drawn'][0]:.3g} and {gap['drawn'][1]:.3g} outside "
            f"them, a visible gap of {gap['visible']:.3g} "
            f"({100 * gap['visible'] / gap['thickness']:.2g}% of the thinner body, "
            f"{gap['thickness']:.3g} thick)")
