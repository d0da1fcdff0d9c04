"""Render a trajectory: every body at its pose, frame by frame, then an MP4 and a GIF.

Each body's tree is built **once**, in body coordinates; a frame poses the bodies through the
tracer's per-object rigid transforms (:func:`tracer.render` ``transforms``: object ``k``
is evaluated at ``R_k^T (p - x_k)``), so no tree is rebuilt per frame. The bodies are combined
as any multi-object scene: LogSumExp with the largest alpha, each with its own alpha / alpha_U.

Movies are written with imageio: MP4 through its ffmpeg plugin (libx264, yuv420p) and GIF through
Pillow. Every file is written to a temporary name and renamed (no partial output).
"""

import os
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from smoothdist import SmoothDistanceField
from tracer.image import gif_frame, save_png
from tracer.outputs import atomic_write
from tracer.rendering.frame import ProgressBar
from tracer.rendering.lighting import Lighting
from tracer.rendering.renderer import render
from tracer.scenes.scene import Scene, SceneObject, default_eps
from tracer.sim.simulation import auto_camera

__all__ = ["animate", "body_scene", "render_frames", "frame_indices", "write_mp4", "write_gif"]


def body_scene(sim, size=None, trajectory=None):
    """A :class:`~tracer.scenes.scene.Scene` with one object per body (body coordinates);
    ``size (W, H)`` overrides the camera's image size. A simulation without a camera of its
    own (``camera.auto``, the authors' files) is framed by
    :func:`~tracer.sim.simulation.auto_camera` over ``trajectory`` (a dict with ``rotations``
    and ``centers``), or at the initial state without one."""
    cam = sim.camera
    width, height = (cam.width, cam.height) if size is None else (int(size[0]), int(size[1]))
    origin, dest, up = cam.origin, cam.dest, cam.up
    if cam.auto and trajectory is not None:
        origin, dest, up = auto_camera(sim.bodies, sim.gravity, trajectory["rotations"],
                                       trajectory["centers"], width, height)
    objs = [SceneObject(name=b.name, field=SmoothDistanceField(b.mesh), alpha=b.alpha,
                        alpha_u=b.alpha_u, beta=sim.beta, offset=1.0 / b.alpha)
            for b in sim.bodies]
    # lit clips: the bodies' own floors catch the shadows, so no extra ground plane
    scene = Scene(path=sim.path, camera_origin=origin, camera_dest=dest,
                  camera_up=up, objects=objs, width=width, height=height,
                  beta=sim.beta, shading=cam.shading, matcap=cam.matcap,
                  background=cam.background, lighting=Lighting(ground=False))
    scene.eps = default_eps(scene)
    return scene


def frame_indices(n_frames, every):
    """Frames ``0, every, 2 every, ...`` plus the last one."""
    idx = list(range(0, n_frames, max(1, int(every))))
    if idx[-1] != n_frames - 1:
        idx.append(n_frames - 1)
    return idx


def render_frames(sim, traj, frames_dir, *, every=None, progress=None, overwrite=True,
                  size=None):
    """Render the trajectory's frames to ``frames_dir/frame_NNNNN.png``; returns the images.
    ``size (W, H)``: frame size in pixels (default: the simulation camera's)."""
    scene = body_scene(sim, size, traj)
    every = sim.camera.every if every is None else every
    idx = frame_indices(len(traj["time"]), every)
    os.makedirs(frames_dir, exist_ok=True)
    images = []
    t0 = time.perf_counter()
    # each PNG is encoded in the background while the next frame is traced (zlib releases the
    # GIL); one file at a time, and a failed write is raised here, in frame order
    with ThreadPoolExecutor(1) as writer:
        pending = None
        for n, f in enumerate(idx):
            poses = [(traj["rotations"][f, k], traj["centers"][f, k])
                     for k in range(len(sim.bodies))]
            res = render(scene, transforms=poses)
            if pending is not None:
                pending.result()
            pending = writer.submit(save_png, os.path.join(frames_dir, f"frame_{n:05d}.png"),
                                    res.rgb, overwrite=overwrite)
            images.append(res.rgb)
            if progress is not None:
                progress(n + 1, len(idx), time.perf_counter() - t0)
        if pending is not None:
            pending.result()
    return images


def write_mp4(path, images, fps, overwrite=True):
    """Encode ``images`` ((H, W, 3) uint8 each) as H.264 MP4 at ``fps``."""
    import imageio.v2 as iio  # imageio (sim extra): loaded on use

    with atomic_write(path, overwrite=overwrite) as tmp:
        w = iio.get_writer(str(tmp), format="FFMPEG", mode="I", fps=float(fps), codec="libx264",
                           pixelformat="yuv420p", macro_block_size=2,
                           ffmpeg_log_level="error", output_params=["-crf", "23"])
        try:
            for im in images:
                w.append_data(_even(im))
        finally:
            w.close()


def write_gif(path, images, fps, overwrite=True, max_frames=60):
    """Write ``images`` as a looping GIF (at most ``max_frames`` frames, evenly picked)."""
    pick = np.unique(np.linspace(0, len(images) - 1, min(len(images), max_frames)).round()
                     .astype(int))
    step = len(images) / len(pick)
    frames = [gif_frame(images[i], 64) for i in pick]
    with atomic_write(path, overwrite=overwrite) as tmp:
        frames[0].save(tmp, format="GIF", save_all=True, append_images=frames[1:], loop=0,
                       duration=int(round(1000.0 * step / fps)), optimize=True)


def _even(im):
    H, W = im.shape[:2]
    return np.ascontiguousarray(im[:H - H % 2, :W - W % 2])


def animate(sim, traj, out_dir, *, movie_name=None, every=None, quiet=False, overwrite=True,
            size=None):
    """Frames, MP4 and GIF of a trajectory into ``out_dir``; returns the written paths."""
    bar = None if quiet else ProgressBar("render")
    images = render_frames(sim, traj, os.path.join(out_dir, "frames"), every=every,
                           progress=bar, overwrite=overwrite, size=size)
    name = movie_name or sim.name
    fps = sim.camera.fps
    mp4 = os.path.join(out_dir, f"{name}.mp4")
    gif = os.path.join(out_dir, f"{name}.gif")
    write_mp4(mp4, images, fps, overwrite=overwrite)
    write_gif(gif, images, fps, overwrite=overwrite)
    return mp4, gif
