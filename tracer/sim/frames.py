"""The frames of a simulated trajectory as independent tasks (``tracer simulate`` / ``animate``).

* :func:`add_frame_arguments` and :func:`check_frame_arguments`: the options both commands
  have for the frames (which frames, their size, where they render);
* :func:`list_tasks`: one task per rendered frame, a small dict (simulation file and trajectory
  by path, frame number, output PNG path, image size);
* :func:`frame_task`: renders one frame with every body at its pose and writes its PNG
  (atomically); returns a small record. A worker process loads the simulation and the
  trajectory by path and builds every body's tree **once** (cached, keyed by path, modification
  time and size), so only the task dict travels through the scheduler. A simulation without a
  camera (the authors' files) is framed on the whole trajectory
  (:func:`tracer.sim.simulation.auto_camera`);
* :func:`render_movie`: runs the tasks through :func:`tracer.runner.run_study` (in this
  process, on a local Dask cluster or on an existing one) and reduces the PNGs, in frame order,
  to an MP4 and a GIF.

The first frame is rendered in this process before the others are handed out: it warms the
kernels and its time gives the estimate that decides whether a local cluster is worth starting.
Renders are deterministic across thread counts, so the frames are the same whatever runs them.
"""

import functools
import os

import numpy as np

from tracer import runner
from tracer.errors import CLIError
from tracer.image import save_png
from tracer.outputs import at_least, check_size
from tracer.rendering.renderer import render
from tracer.runner import file_stamp
from tracer.sim.animate import body_scene, frame_indices, write_gif, write_mp4
from tracer.sim.run import load_trajectory
from tracer.sim.simfile import load_simulation


def add_frame_arguments(p, unit):
    """Options shared by simulate and animate: which frames, their size, where they render
    (``unit`` is what ``--every`` counts: ``step`` or ``frame``)."""
    p.add_argument("--every", type=int, help=f"render every N-th {unit} (default: the file's)")
    p.add_argument("--size", nargs=2, type=int, metavar=("W", "H"),
                   help="frame size in pixels (default: the file's camera size)")
    p.add_argument("--overwrite", action="store_true", help="replace existing outputs")
    p.add_argument("--threads", type=int, help="numba threads (default: all cores)")
    runner.add_arguments(p)
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bars")


def check_frame_arguments(args):
    """Check ``--every``, ``--size``, ``--scheduler`` and ``--workers`` before any work (one-line
    :class:`~tracer.errors.CLIError`); returns ``(scheduler, workers)``."""
    at_least(args.every, "--every")
    check_size(args.size)
    return runner.check_arguments(args)


def frame_needs(args):
    """The optional packages of rendering the frames to a movie (for the commands' ``needs``,
    checked by :mod:`tracer.cli` before any work): imageio and its ffmpeg for the MP4, Pillow
    for the PNGs and the GIF, distributed for a cluster (:func:`tracer.runner.needs`)."""
    return ["imageio", "imageio_ffmpeg"] + runner.needs(args) + ["PIL"]


def list_tasks(sim_path, traj_path, frames_dir, indices, size=None):
    """One task per frame index in ``indices``; frame ``n`` of the movie is
    ``frames_dir/frame_NNNNN.png`` (``n`` its position in ``indices``)."""
    size = None if size is None else [int(size[0]), int(size[1])]
    return [{"key": f"frame={int(f)}", "weight": 1.0, "sim": os.path.abspath(sim_path),
             "trajectory": os.path.abspath(traj_path), "frame": int(f), "index": n,
             "png": os.path.abspath(os.path.join(frames_dir, f"frame_{n:05d}.png")),
             "size": size}
            for n, f in enumerate(indices)]


@functools.lru_cache(maxsize=4)
def _scene(sim_stamp, size, traj_stamp):

    sim = load_simulation(sim_stamp[0])
    traj = None
    if sim.camera.auto:                        # framed on the whole trajectory
        rotations, centers = _poses(traj_stamp)
        traj = {"rotations": rotations, "centers": centers}
    return sim, body_scene(sim, size, traj)


@functools.lru_cache(maxsize=4)
def _poses(traj_stamp):
    data = load_trajectory(traj_stamp[0])
    return np.asarray(data["rotations"]), np.asarray(data["centers"])


def frame_task(task):
    """Render ``task["frame"]`` of the trajectory; write ``task["png"]``; return a record."""

    size = tuple(task["size"]) if task.get("size") else None
    traj_stamp = file_stamp(task["trajectory"])
    sim, scene = _scene(file_stamp(task["sim"]), size, traj_stamp)
    rotations, centers = _poses(traj_stamp)
    f = task["frame"]
    poses = [(rotations[f, k], centers[f, k]) for k in range(len(sim.bodies))]
    res = render(scene, transforms=poses)
    save_png(task["png"], res.rgb, overwrite=True)
    return {"index": task["index"], "frame": f, "png": task["png"],
            "seconds": float(res.seconds), "hits": int(res.hit.sum())}


def render_movie(sim_path, traj_path, frames_dir, mp4, gif, *, n_frames, every, fps, size=None,
                 scheduler="local", workers=None, quiet=False):
    """Render every ``every``-th frame (and the last) of the trajectory to ``frames_dir``, then
    write ``mp4`` and ``gif``. Returns the runner's :class:`~tracer.runner.RunInfo`, with
    ``frame_seconds`` added: each frame's render time in seconds, in frame order.

    Raises :class:`tracer.errors.CLIError` when a frame could not be rendered (nothing of the
    movie is written then)."""
    from PIL import Image  # Pillow (tracer extra): loaded on use


    tasks = list_tasks(sim_path, traj_path, frames_dir, frame_indices(n_frames, every), size)
    os.makedirs(frames_dir, exist_ok=True)
    done = {0: frame_task(tasks[0])}
    failed = []
    info = runner.run_study(frame_task, tasks[1:],
                            on_result=lambda t, r: done.__setitem__(t["index"], r),
                            on_failure=lambda t, err: failed.append((t["key"], err)),
                            scheduler=scheduler, workers=workers, label="render frames",
                            estimate=done[0]["seconds"] * (len(tasks) - 1), quiet=quiet)
    if failed:
        raise CLIError(f"{len(failed)} frame(s) could not be rendered; first {failed[0][0]}: "
                       f"{failed[0][1]}")
    images = [np.asarray(Image.open(done[n]["png"]).convert("RGB")) for n in range(len(tasks))]
    write_mp4(mp4, images, fps)
    write_gif(gif, images, fps)
    info.frame_seconds = [done[n]["seconds"] for n in range(len(tasks))]
    return info
