"""``tracer simulate SIM.json -o DIR``: simulate, then render the trajectory to a movie.

Writes ``DIR/trajectory.npz`` (see :mod:`tracer.sim.run`) and, unless ``--no-render``,
``DIR/frames/frame_NNNNN.png``, ``DIR/<name>.mp4`` and ``DIR/<name>.gif``. Frames are
independent tasks (:mod:`tracer.sim.frames`): ``--scheduler``/``--workers`` run them on a Dask
cluster as the studies do (a short movie stays in this process). ``tracer animate``
(:mod:`tracer.sim.cli_animate`) renders an existing trajectory again.

Bad input (a malformed or invalid simulation file, bodies that overlap at the start, an
existing output without ``--overwrite``/``--resume``) is one ``error: ...`` line, exit status 2,
and nothing is written.
"""

import os
import sys

from tracer.compiling import ahead_allowed, wait_ahead
from tracer.errors import CLIError
from tracer.outputs import at_least
from tracer.rendering.frame import ProgressBar
from tracer.sim import compile_ahead
from tracer.sim import run as sim_run
from tracer.sim.frames import add_frame_arguments, check_frame_arguments, frame_needs, render_movie
from tracer.sim.simfile import load_simulation

HELP = "simulate rigid bodies with one smooth-distance constraint"


def add_arguments(p):
    """Arguments of ``tracer simulate``."""
    p.add_argument("sim", metavar="SIM.json", help="simulation file (see tracer/sim/simfile.py)")
    p.add_argument("-o", "--out", metavar="DIR", required=True, help="output folder")
    p.add_argument("--steps", type=int, help="number of steps (default: the file's)")
    p.add_argument("--no-render", action="store_true", help="write the trajectory only")
    p.add_argument("--resume", action="store_true",
                   help="continue DIR/trajectory.npz from its last frame")
    p.add_argument("--torques", choices=("exact", "split"),
                   help="rotation gradient: the exact derivative, or the paper's equal split "
                        "of each primitive's force (the authors' simulator); default: the "
                        "file's \"torques\", else exact")
    add_frame_arguments(p, "step")


def needs(args):
    """The optional packages (:mod:`tracer.cli` checks them first): scipy for the solver, and
    what the movie needs unless ``--no-render`` (:func:`tracer.sim.frames.frame_needs`).
    Bodies built with trimesh (icospheres, boxes) import it when the file is read, before the
    first step."""
    return ["scipy"] + ([] if args.no_render else frame_needs(args))


def run(args):
    """Simulate (and render); returns the exit status."""
    at_least(args.steps, "--steps")
    scheduler, workers = check_frame_arguments(args)
    out = args.out
    traj = os.path.join(out, "trajectory.npz")
    if os.path.exists(out) and not os.path.isdir(out):
        raise CLIError(f"output path is a file, not a folder: {out}")
    if os.path.exists(traj) and not (args.resume or args.overwrite):
        raise CLIError(f"output exists: {traj} (pass --resume to continue it or --overwrite)")
    if args.resume and not os.path.exists(traj):
        raise CLIError(f"--resume: nothing to resume, {traj} does not exist")
    sim = load_simulation(args.sim)
    with ahead_allowed():   # a first step's kernels compiled in a second process meanwhile
        compile_ahead.start(sim, sim_run.torques_of(sim, args.torques))
    built = sim_run.build(sim, torques=args.torques)
    con = built[0]
    if not args.resume:
        sim_run.check_initial_state(sim, con)
    wait_ahead()            # ... and in the cache before the first step
    if not args.no_render:
        with ahead_allowed():   # the movie's kernels compiled while the simulation steps
            compile_ahead.start_movie(sim, args.size)
    created = not os.path.isdir(out)
    os.makedirs(out, exist_ok=True)
    try:
        bar = None if args.quiet else ProgressBar("simulate")
        frames = sim_run.simulate(sim, traj, steps=args.steps, resume=args.resume,
                              overwrite=args.overwrite or args.resume, progress=bar,
                              built=built)
    except BaseException:
        if created and not os.listdir(out):
            os.rmdir(out)
        raise
    d = min(frames["min_exact_distance"])
    if not args.quiet:
        gap = sim_run.closest_gap(sim, con, frames["centers"][-1], frames["rotations"][-1])
        print(f"wrote {traj}: {len(frames['time'])} frames, minimum exact distance {d:.4g}; "
              f"{sim_run.describe_gap(gap)}", file=sys.stderr)
    if args.no_render:
        return 0
    data = sim_run.load_trajectory(traj)
    mp4 = os.path.join(out, f"{sim.name}.mp4")
    gif = os.path.join(out, f"{sim.name}.gif")
    render_movie(args.sim, traj, os.path.join(out, "frames"), mp4, gif,
                 n_frames=len(data["time"]),
                 every=sim.camera.every if args.every is None else args.every,
                 fps=sim.camera.fps, size=args.size, scheduler=scheduler, workers=workers,
                 quiet=args.quiet)
    if not args.quiet:
        print(f"wrote {os.path.join(out, 'frames')}/, {mp4}, {gif}", file=sys.stderr)
    return 0
