"""What a loaded simulation file is: the simulation, its camera, and the automatic camera of
files that give none (:class:`~tracer.sim.simulation.Simulation`,
:class:`~tracer.sim.simulation.MovieCamera`, :func:`~tracer.sim.simulation.auto_camera`).

Both readers build these: :mod:`tracer.sim.simfile` (our format) and
:mod:`tracer.sim.authors_format` (the authors' ``sims/*.json``); neither imports the other's
internals, and ``simfile`` dispatches to ``authors_format`` (so the arrow runs one way).
:mod:`tracer.sim.simfile` re-exports every name here.
"""

from dataclasses import dataclass, field

import numpy as np

from tracer.errors import SimFileError
from tracer.rendering.camera import box_corners, frame_points
from tracer.sim.constraint import DEFAULT_TORQUES

__all__ = ["Simulation", "MovieCamera", "auto_camera", "DEFAULT_FRAMES", "wrap_scene_error"]

#: default number of rendered frames when ``camera.every`` is not given
DEFAULT_FRAMES = 80


@dataclass
class MovieCamera:
    """The camera that films a simulation's movie, and the movie's frames (size, rate, every
    how many steps, shading): the file's ``camera`` object. ``auto``: the view was not given
    (an authors' file); frames are rendered from :func:`auto_camera` of the trajectory instead
    of ``origin``, ``dest`` and ``up`` (which frame the initial state)."""

    origin: np.ndarray
    dest: np.ndarray
    up: np.ndarray
    width: int = 640
    height: int = 360
    fps: float = 25.0
    every: int = 1
    shading: str = "lit"
    matcap: str = ""
    background: tuple = (255, 255, 255)
    auto: bool = False


#: free border of :func:`auto_camera`, a fraction of the image's half-size
AUTO_CAMERA_MARGIN = 0.08
#: elevation of :func:`auto_camera`'s view above the horizontal (degrees), for scenes that
#: are not flat
AUTO_CAMERA_ELEVATION = 20.0
#: :func:`auto_camera`: a static body whose box diagonal exceeds this many times the diagonal
#: of the moving bodies' swept box (terrain under a falling body) is not framed whole: the
#: frame holds the swept box grown by AUTO_CAMERA_FOCUS_GROW of its diagonal on every side,
#: seen from AUTO_CAMERA_FOCUS_ELEVATION degrees (from the side, the body would be lost
#: behind the terrain's own relief)
AUTO_CAMERA_FOCUS = 4.0
AUTO_CAMERA_FOCUS_GROW = 0.5
AUTO_CAMERA_FOCUS_ELEVATION = 40.0


def auto_camera(bodies, gravity, rotations=None, centers=None, width=640, height=360):
    """``(origin, dest, up)`` of a camera that sees every body at every pose.

    ``rotations (F, B, 3, 3)`` and ``centers (F, B, 3)``: the bodies' poses over a trajectory
    (default: their current poses). Up is the coordinate axis closest to ``-gravity`` (+y
    without gravity). The view looks across the thinner horizontal extent of the bodies'
    swept bounding box (so a 2D scene in a vertical plane is seen face on, wide axis to the
    right), from :data:`AUTO_CAMERA_ELEVATION` degrees above unless the box is flat, and is
    as close as :func:`tracer.rendering.camera.frame_points` allows with every drawn surface (within
    about ``(1 + log n) / alpha`` of its mesh) in view. A static body far larger than the
    motion (:data:`AUTO_CAMERA_FOCUS`: terrain) is cut by the frame instead: the view holds the
    moving bodies' swept box with a border and looks down on it from higher.
    """
    if rotations is None:
        rotations = np.array([[b.R for b in bodies]])
        centers = np.array([[b.x for b in bodies]])
    moving, still, radius = [], [], 0.0
    for k, b in enumerate(bodies):
        corners = box_corners(*b.mesh.bounds)
        R, X = np.asarray(rotations)[:, k], np.asarray(centers)[:, k]
        if b.static:
            R, X = R[:1], X[:1]
        (still if b.static else moving).append(
            (np.einsum("fij,cj->fci", R, corners) + X[:, None, :]).reshape(-1, 3))
        radius = max(radius, (1.0 + np.log(max(b.mesh.num_primitives, 1))) / b.alpha)
    elevation = AUTO_CAMERA_ELEVATION
    pts = np.concatenate(moving + still)
    if moving and still:
        swept = np.concatenate(moving)
        lo, hi = swept.min(axis=0), swept.max(axis=0)
        diag = float(np.linalg.norm(hi - lo))
        if np.linalg.norm(np.ptp(np.concatenate(still), axis=0)) > AUTO_CAMERA_FOCUS * diag:
            pts = box_corners(lo - AUTO_CAMERA_FOCUS_GROW * diag,
                              hi + AUTO_CAMERA_FOCUS_GROW * diag)
            elevation = AUTO_CAMERA_FOCUS_ELEVATION
    g = np.asarray(gravity, dtype=float)
    axis = int(np.argmax(np.abs(g))) if np.linalg.norm(g) > 0 else 1
    up = np.zeros(3)
    up[axis] = -np.sign(g[axis]) if np.linalg.norm(g) > 0 else 1.0
    ext = np.ptp(pts, axis=0)
    a, b = [i for i in range(3) if i != axis]
    thin, wide = (a, b) if ext[a] <= ext[b] else (b, a)
    wide_dir = np.zeros(3)
    wide_dir[wide] = 1.0
    eye = np.cross(wide_dir, up)                 # the wide axis to the right of the image
    flat = ext[thin] <= 0.05 * max(ext.max(), 1e-300)
    el = 0.0 if flat else np.radians(elevation)
    direction = np.cos(el) * eye + np.sin(el) * up
    return frame_points(pts, radius, (direction, up), width, height, AUTO_CAMERA_MARGIN)


@dataclass
class Simulation:
    """A loaded simulation file: bodies at their initial state and the run's settings."""

    path: str
    name: str
    bodies: list
    dt: float
    steps: int
    gravity: np.ndarray
    beta: float
    constraint: str
    camera: MovieCamera
    gap_tol: float = None
    spec: dict = field(default_factory=dict)
    torques: str = DEFAULT_TORQUES


def wrap_scene_error(exc):
    """A :class:`~tracer.errors.SceneError` from the shared validators as a
    :class:`~tracer.errors.SimFileError` about the simulation file."""
    return SimFileError(str(exc).replace("scene file", "simulation file")
                        .replace("scene path", "simulation path"))
