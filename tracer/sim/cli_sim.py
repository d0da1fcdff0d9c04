"""``tracer simulate SIM.json -o DIR`` and ``tracer animate TRAJ.npz -o movie.mp4``.

``simulate`` writes ``DIR/trajectory.npz`` (see :mod:`tracer.sim.run`) and, unless
``--no-render``, ``DIR/frames/frame_NNNNN.png``, ``DIR/<name>.mp4`` and ``DIR/<name>.gif``.
``animate`` renders an existing trajectory (its simulation file is found through the path stored
in the trajectory, or ``--sim``) to ``movie.mp4``, ``movie.gif`` and ``movie_frames/``.
Frames are independent tasks (:mod:`tracer.studies.frames`): ``--scheduler``/``--workers`` run
them on a Dask cluster as the studies do (a short movie stays in this process).

Bad input (a malformed or invalid simulation file, bodies that overlap at the start, an
existing output without ``--overwrite``/``--resume``) is one ``error: ...`` line, exit status 2,
and nothing is written.
"""

import os
import sys

from tracer.cli import CLIError


def add_arguments_simulate(p):
    p.add_argument("sim", metavar="SIM.json", help="simulation file (see tracer/sim/simfile.py)")
    p.add_argument("-o", "--out", metavar="DIR", required=True, help="output folder")
    p.add_argument("--steps", type=int, help="number of steps (default: the file's)")
    p.add_argument("--no-render", action="store_true", help="write the trajectory only")
    p.add_argument("--resume", action="store_true",
                   help="continue DIR/trajectory.npz from its last frame")
    _add_render_arguments(p, "step")


def add_arguments_animate(p):
    p.add_argument("trajectory", metavar="TRAJ.npz", help="a trajectory written by simulate")
    p.add_argument("-o", "--out", metavar="MOVIE.mp4", required=True, help="the MP4 to write "
                   "(a GIF and a frames folder are written next to it)")
    p.add_argument("--sim", metavar="SIM.json", help="the simulation file (default: the one "
                   "recorded in the trajectory)")
    _add_render_arguments(p, "frame")


def _positive(value, name):
    if value is not None and value < 1:
        raise CLIError(f"{name} must be >= 1, got {value}")


def _add_render_arguments(p, unit):
    """Options shared by simulate and animate: which frames, their size, where they render."""
    from tracer.studies import runner

    p.add_argument("--every", type=int, help=f"render every N-th {unit} (default: the file's)")
    p.add_argument("--size", nargs=2, type=int, metavar=("W", "H"),
                   help="frame size in pixels (default: the file's camera size)")
    p.add_argument("--overwrite", action="store_true", help="replace existing outputs")
    p.add_argument("--threads", type=int, help="numba threads (default: all cores)")
    runner.add_arguments(p)
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bars")


def _check_size(size):
    if size is not None and (min(size) < 1 or max(size) > 8192):
        raise CLIError(f"--size must be two integers in 1..8192, got {size[0]} {size[1]}")


def run_simulate(args):
    from tracer.render import ProgressBar
    from tracer.sim import run
    from tracer.sim.simfile import load_simulation
    from tracer.studies.frames import render_movie

    _positive(args.steps, "--steps")
    _positive(args.every, "--every")
    _check_size(args.size)
    scheduler, workers = _check_scheduler(args)
    out = args.out
    traj = os.path.join(out, "trajectory.npz")
    if os.path.exists(out) and not os.path.isdir(out):
        raise CLIError(f"output path is a file, not a folder: {out}")
    if os.path.exists(traj) and not (args.resume or args.overwrite):
        raise CLIError(f"output exists: {traj} (pass --resume to continue it or --overwrite)")
    if args.resume and not os.path.exists(traj):
        raise CLIError(f"--resume: nothing to resume, {traj} does not exist")
    sim = load_simulation(args.sim)
    built = run.build(sim)
    con = built[0]
    if not args.resume:
        run.check_initial_state(sim, con)
    created = not os.path.isdir(out)
    os.makedirs(out, exist_ok=True)
    try:
        bar = None if args.quiet else ProgressBar("simulate")
        frames = run.simulate(sim, traj, steps=args.steps, resume=args.resume,
                              overwrite=args.overwrite or args.resume, progress=bar,
                              built=built)
    except BaseException:
        if created and not os.listdir(out):
            os.rmdir(out)
        raise
    d = min(frames["min_exact_distance"])
    if not args.quiet:
        gap = run.closest_gap(sim, con, frames["centers"][-1], frames["rotations"][-1])
        print(f"wrote {traj}: {len(frames['time'])} frames, minimum exact distance {d:.4g}; "
              f"{run.describe_gap(gap)}", file=sys.stderr)
    if args.no_render:
        return 0
    data = run.load_trajectory(traj)
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


def _check_scheduler(args):
    from tracer.studies import runner

    return runner.check_arguments(args)


def run_animate(args):
    from tracer.sim import run
    from tracer.sim.simfile import load_simulation
    from tracer.studies import frames

    _positive(args.every, "--every")
    _check_size(args.size)
    scheduler, workers = _check_scheduler(args)
    if not args.out.endswith(".mp4"):
        raise CLIError(f"output must be a .mp4 file, got {args.out}")
    stem = args.out[:-4]
    gif = stem + ".gif"
    for p in (args.out, gif):
        if os.path.exists(p) and not args.overwrite:
            raise CLIError(f"output exists: {p} (pass --overwrite to replace it)")
    data = run.load_trajectory(args.trajectory)
    sim_path = args.sim or str(data["sim_file"])
    if not os.path.isfile(sim_path):
        raise CLIError(f"the simulation file {sim_path} recorded in the trajectory is missing; "
                       "give it with --sim")
    sim = load_simulation(sim_path)
    names = [str(n) for n in data["names"]]
    if names != [b.name for b in sim.bodies]:
        raise CLIError(f"the trajectory's bodies {names} do not match {sim_path}")
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    frames.render_movie(sim_path, args.trajectory, stem + "_frames", args.out, gif,
                        n_frames=len(data["time"]),
                        every=sim.camera.every if args.every is None else args.every,
                        fps=sim.camera.fps, size=args.size, scheduler=scheduler,
                        workers=workers, quiet=args.quiet)
    if not args.quiet:
        print(f"wrote {args.out}, {gif}, {stem}_frames/", file=sys.stderr)
    return 0
