"""``tracer animate TRAJ.npz -o movie.mp4``: render a simulated trajectory to a movie.

Renders an existing trajectory (written by ``tracer simulate``, :mod:`tracer.sim.cli_simulate`;
its simulation file is found through the path stored in the trajectory, or ``--sim``) to
``movie.mp4``, ``movie.gif`` and ``movie_frames/``. Frames are independent tasks
(:mod:`tracer.sim.frames`): ``--scheduler``/``--workers`` run them on a Dask cluster as the
studies do (a short movie stays in this process).

Bad input (a missing trajectory or simulation file, bodies that do not match, an existing
output without ``--overwrite``) is one ``error: ...`` line, exit status 2, and nothing is
written.
"""

import os
import sys

from tracer.errors import CLIError
from tracer.sim import run as sim_run
from tracer.sim.frames import add_frame_arguments, check_frame_arguments, frame_needs, render_movie
from tracer.sim.simfile import load_simulation

HELP = "render a simulated trajectory to PNG frames, MP4 and GIF"


def add_arguments(p):
    """Arguments of ``tracer animate``."""
    p.add_argument("trajectory", metavar="TRAJ.npz", help="a trajectory written by simulate")
    p.add_argument("-o", "--out", metavar="MOVIE.mp4", required=True, help="the MP4 to write "
                   "(a GIF and a frames folder are written next to it)")
    p.add_argument("--sim", metavar="SIM.json", help="the simulation file (default: the one "
                   "recorded in the trajectory)")
    add_frame_arguments(p, "frame")


def needs(args):
    """The optional packages (:mod:`tracer.cli` checks them first): scipy (the trajectory
    module imports the solver) and what the movie needs
    (:func:`tracer.sim.frames.frame_needs`)."""
    return ["scipy"] + frame_needs(args)


def run(args):
    """Render the movie; returns the exit status."""
    scheduler, workers = check_frame_arguments(args)
    if not args.out.endswith(".mp4"):
        raise CLIError(f"output must be a .mp4 file, got {args.out}")
    stem = args.out[:-4]
    gif = stem + ".gif"
    for p in (args.out, gif):
        if os.path.exists(p) and not args.overwrite:
            raise CLIError(f"output exists: {p} (pass --overwrite to replace it)")
    data = sim_run.load_trajectory(args.trajectory)
    sim_path = args.sim or str(data["sim_file"])
    if not os.path.isfile(sim_path):
        raise CLIError(f"the simulation file {sim_path} recorded in the trajectory is missing; "
                       "give it with --sim")
    sim = load_simulation(sim_path)
    names = [str(n) for n in data["names"]]
    if names != [b.name for b in sim.bodies]:
        raise CLIError(f"the trajectory's bodies {names} do not match {sim_path}")
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    render_movie(sim_path, args.trajectory, stem + "_frames", args.out, gif,
                 n_frames=len(data["time"]),
                 every=sim.camera.every if args.every is None else args.every,
                 fps=sim.camera.fps, size=args.size, scheduler=scheduler,
                 workers=workers, quiet=args.quiet)
    if not args.quiet:
        print(f"wrote {args.out}, {gif}, {stem}_frames/", file=sys.stderr)
    return 0
