"""Clips of the Table 3 simulations: MP4 and GIF at 640 x 360, lit, one colour per body.

For each scene (default: all eight) the simulation is run with ``tracer simulate --no-render``
(or its trajectory is taken from ``--from DIR``: ``DIR/<name>/trajectory.npz``), then about
``--frames`` evenly spaced frames are rendered (``tracer.sim.frames.render_movie``: in this
process, on a local Dask cluster or on ``--scheduler ADDRESS``) to ``OUT/<name>/<name>.mp4``,
``.gif`` and ``_frames/``. With ``--readme DIR`` a small copy of each GIF (``--readme-size``,
default 320 x 180, at most 24 frames) is written to ``DIR/<name>.gif`` for the README.

Printed per scene: steps simulated, simulation seconds, frames, seconds per frame (median of
the frames' render times, and the whole render stage's wall time divided by the frames).

Usage::

    python scenes/simulations/table3/make_clips.py                       # all (hours: see README)
    python scenes/simulations/table3/make_clips.py ico_bowl --frames 12  # one, quickly
    python scenes/simulations/table3/make_clips.py --from out/table3 --readme renders/sim/table3
    python scenes/simulations/table3/make_clips.py octopus_lidar --steps 263   # a partial run

Expensive scenes: ``octopus_lidar`` comes to rest in a tree crown at step 229; from there every
step costs about 7 s here (the solver's line searches find no step to take), so its 1,000 steps
take about 1.5 hours on a 2-core machine: ``--steps 263`` shows all of its motion. Frames of
the two terrain scenes take 0.5-1 minute each at 640 x 360.
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", "..", ".."))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

SCENES = ["ico_bowl", "spikeball_bowl", "bunny_lidar", "octopus_lidar", "bunny_bunny",
          "bunny_bunny_plane", "sphere_slide", "trefoil_ringtoss"]


def simulate(path, out_dir, steps=None, threads=None):
    """Run ``tracer simulate`` without frames; returns (trajectory path, wall seconds)."""
    cmd = [sys.executable, "-m", "tracer", "simulate", path, "-o", out_dir, "--no-render",
           "--overwrite"]
    if steps is not None:
        cmd += ["--steps", str(steps)]
    if threads is not None:
        cmd += ["--threads", str(threads)]
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, cwd=ROOT)
    return os.path.join(out_dir, "trajectory.npz"), time.perf_counter() - t0


def small_gif(frames, path, size, max_frames, fps):
    """A small looping GIF of ``frames`` (PNG paths), resized to ``size``."""
    import numpy as np
    from PIL import Image

    from tracer.image import gif_frame
    from tracer.outputs import atomic_write

    pick = np.unique(np.linspace(0, len(frames) - 1, min(len(frames), max_frames)).round()
                     .astype(int))
    ims = [gif_frame(np.asarray(Image.open(frames[i]).convert("RGB")
                                .resize(size, Image.LANCZOS))) for i in pick]
    duration = int(round(1000.0 * len(frames) / len(pick) / fps))
    with atomic_write(path, overwrite=True) as tmp:
        ims[0].save(tmp, format="GIF", save_all=True, append_images=ims[1:], loop=0,
                    duration=duration, optimize=True)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scenes", nargs="*", metavar="SCENE",
                    help=f"scene names (default: all): {', '.join(SCENES)}")
    ap.add_argument("-o", "--out", default=os.path.join(ROOT, "out", "table3_clips"))
    ap.add_argument("--from", dest="src", metavar="DIR",
                    help="take DIR/<name>/trajectory.npz instead of simulating")
    ap.add_argument("--steps", type=int, help="simulate only this many steps")
    ap.add_argument("--frames", type=int, default=48, help="about this many frames per clip")
    ap.add_argument("--size", nargs=2, type=int, default=(640, 360), metavar=("W", "H"))
    ap.add_argument("--scheduler", default="serial",
                    help="'serial' (default), 'local' or a Dask scheduler address")
    ap.add_argument("--readme", metavar="DIR", help="also write small GIFs to DIR/<name>.gif")
    ap.add_argument("--readme-size", nargs=2, type=int, default=(320, 180), metavar=("W", "H"))
    ap.add_argument("--json", metavar="OUT.json", help="also write the rows as JSON")
    args = ap.parse_args(argv)

    from tracer.sim import run
    from tracer.sim.frames import render_movie
    from tracer.sim.simfile import load_simulation

    unknown = [s for s in args.scenes if s not in SCENES]
    if unknown:
        ap.error(f"unknown scene(s) {', '.join(unknown)}; choose from {', '.join(SCENES)}")
    rows = []
    for name in args.scenes or SCENES:
        path = os.path.join(HERE, name + ".json")
        out = os.path.join(args.out, name)
        os.makedirs(out, exist_ok=True)
        sim_s = None
        if args.src:
            traj = os.path.join(args.src, name, "trajectory.npz")
            if not os.path.isfile(traj):
                sys.exit(f"error: {traj} is missing (run without --from to simulate)")
        else:
            traj, sim_s = simulate(path, out, args.steps)
        data = run.load_trajectory(traj)
        sim = load_simulation(path)
        n = len(data["time"])
        every = max(1, (n - 1) // max(1, args.frames - 1))
        stem = os.path.join(out, name)
        t0 = time.perf_counter()
        info = render_movie(path, traj, stem + "_frames", stem + ".mp4", stem + ".gif",
                            n_frames=n, every=every, fps=sim.camera.fps, size=args.size,
                            scheduler=args.scheduler, quiet=True)
        wall = time.perf_counter() - t0
        secs = info.frame_seconds
        row = {"scene": name, "steps": n - 1, "simulate_s": sim_s, "frames": len(secs),
               "size": f"{args.size[0]}x{args.size[1]}",
               "s_per_frame_median": statistics.median(secs),
               "s_per_frame_wall": wall / len(secs), "where": info.describe(),
               "mp4_bytes": os.path.getsize(stem + ".mp4"),
               "gif_bytes": os.path.getsize(stem + ".gif")}
        if args.readme:
            os.makedirs(args.readme, exist_ok=True)
            frames = sorted(os.path.join(stem + "_frames", f)
                            for f in os.listdir(stem + "_frames") if f.endswith(".png"))
            small = os.path.join(args.readme, name + ".gif")
            small_gif(frames, small, tuple(args.readme_size), 24, sim.camera.fps)
            row["readme_gif_bytes"] = os.path.getsize(small)
        rows.append(row)
        print(f"{name:18s} steps {row['steps']:5d}  "
              f"{'' if sim_s is None else f'simulate {sim_s:7.1f} s  '}"
              f"frames {row['frames']:3d}  s/frame {row['s_per_frame_median']:6.2f} "
              f"(wall {row['s_per_frame_wall']:6.2f})  {row['where']}", flush=True)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(rows, fh, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
