"""Pinhole camera that reproduces the view of the authors' sphere tracer.

Conventions
-----------
The camera follows ``lookAt`` and ``sphereTrace`` of ``abhimadan/smoothdists`` (Madan & Levin
2022; ``src/camera.cpp``, ``src/sphere_trace.cpp``) exactly:

* ``forward = normalize(dest - origin)``, ``horizontal = normalize(forward x up)``,
  ``vertical = normalize(horizontal x forward)``. A camera on +z looking at the origin with
  ``up = +y`` has ``horizontal = +x`` and ``vertical = +y``.
* The authors' pixel ``(x, y)`` has ``y = 0`` at the **bottom** of the saved PNG. They sample it
  at ``dx = x / W - 0.5`` and ``dy = y / H - 0.5`` (no half-pixel offset), multiply the
  **longer** image axis by ``max(W, H) / min(W, H)`` and trace
  ``normalize(forward + dx * horizontal + dy * vertical)``.
* Our images are ``(H, W, C)`` arrays whose row 0 is the **top** row, so our ``(row, col)`` is
  their ``(x, y) = (col, H - 1 - row)``.

The shorter image axis therefore spans ``2 atan(0.5) ~ 53.13`` degrees. Because there is no
half-pixel offset, the sample for column ``col`` sits at the *left edge* of a pixel of a
symmetric frustum rather than at its centre, and likewise the sample for row ``row`` sits at
the *bottom* edge: the whole picture is shifted by half a pixel towards the top-right compared
with a symmetric pinhole camera (the view direction ``forward`` is hit by the sample at
``col = W / 2``, ``row = H / 2 - 1``, when those are integers).  :func:`pyvista_camera_params`
gives the VTK window centre that reproduces this shift.

Projections
-----------
``projection="perspective"`` (the default) is the authors' pinhole above: every ray starts at
``origin``. ``projection="orthographic"`` keeps the same image-plane offsets ``(dx, dy)`` but
turns them into parallel rays: the ray of ``(row, col)`` starts at ``origin + s (dx horizontal +
dy vertical)`` and runs along ``forward``, where ``s = view_width / scale_x``, so the image is
``view_width`` scene units wide at any distance (pyvista's ``enable_parallel_projection``). A
ray's parameter ``t`` is then the depth in front of the image plane through ``origin``.

The camera seam
---------------
Kernels see a camera only as the (16,) float64 array :meth:`Camera.as_array` and read it
only through the functions of this module: :func:`camera_ray` (a pixel, or a sample of it, to
a ray's origin and unit direction), :func:`block_rays` (the central ray of a block of pixels
and how far its rays stray from it: what the cone passes may assume), :func:`far_depth`,
:func:`footprint` (a pixel's size at a depth), :func:`image_size` and
:func:`view_coordinates`; the numpy twins :func:`sample_rays`, :func:`primary_rays`,
:func:`ray_origins` and :func:`pixel_points` give the same rays to the film and the checks.
"""

import math
from numbers import Integral
from typing import NamedTuple

import numba
import numpy as np

from smoothdist.kernels import NJIT, NJIT_IR_INLINE

__all__ = [
    "Camera",
    "PROJECTIONS",
    "camera_ray",
    "block_rays",
    "far_depth",
    "footprint",
    "image_size",
    "view_coordinates",
    "sample_rays",
    "ray_origins",
    "pixel_points",
    "frame_width",
    "LookAt",
    "look_at",
    "ray_direction",
    "primary_rays",
    "project",
    "pyvista_camera_params",
    "default_camera_for_bounds",
    "UP_AXES",
    "VIEWS",
    "frame_box",
    "frame_points",
    "view_vectors",
]

#: Number of values in :meth:`Camera.as_array`.
CAMERA_ARRAY_SIZE = 16
#: entries of that array: the origin at 0-2 (then forward, horizontal, vertical), the image's
#: width and height in pixels, the projection (:data:`PROJECTIONS` index) and the view width
#: (orthographic, scene units). Only this module reads them.
CAM_WIDTH, CAM_HEIGHT, CAM_PROJECTION, CAM_VIEW_WIDTH = 12, 13, 14, 15
#: the projections, by their index in the camera array
PROJECTIONS = ("perspective", "orthographic")
#: the orthographic projection's index (numba compiles it in as a constant)
ORTHOGRAPHIC = 1.0

#: ``|forward x up| / |up|`` (the sine of the angle between them) below which ``up`` counts as
#: parallel to the view direction.
_PARALLEL_TOL = 1e-9


class Camera(NamedTuple):
    """An orthonormal camera, its image size and its projection.

    Build one with :func:`look_at` rather than by hand, so that the frame is orthonormal.

    Attributes
    ----------
    origin : (3,) float64 array
        Eye position, world units.
    forward : (3,) float64 array
        Unit view direction.
    horizontal : (3,) float64 array
        Unit vector pointing to the right of the image (increasing column).
    vertical : (3,) float64 array
        Unit vector pointing to the top of the image (decreasing row).
    width : int
        Image width ``W`` in pixels (number of columns).
    height : int
        Image height ``H`` in pixels (number of rows).
    projection : {"perspective", "orthographic"}
        Perspective rays start at ``origin``; orthographic rays are parallel to ``forward``
        and start on the image plane through ``origin`` (see the module notes).
    view_width : float
        Orthographic: the image's width in scene units (> 0); 0 for a perspective camera.
    """

    origin: np.ndarray
    forward: np.ndarray
    horizontal: np.ndarray
    vertical: np.ndarray
    width: int
    height: int
    projection: str = "perspective"
    view_width: float = 0.0

    @property
    def orthographic(self):
        """bool: the rays are parallel (``projection == "orthographic"``)."""
        return self.projection == "orthographic"

    def pixel_size(self, depth=1.0):
        """The size of one pixel in scene units at ``depth`` along the rays (float or
        array): ``depth / min(W, H)`` for a perspective camera, ``view_width / W`` at every
        depth for an orthographic one (:func:`footprint`)."""
        a, b = footprint.py_func(self.as_array())      # in Python: nothing to compile
        return a + b * np.asarray(depth, dtype=np.float64)

    @property
    def scale_x(self):
        """float: multiplier of the horizontal offset ``dx``; ``W / H`` if ``W >= H``, else 1."""
        return _scales(float(self.width), float(self.height))[0]

    @property
    def scale_y(self):
        """float: multiplier of the vertical offset ``dy``; ``H / W`` if ``H > W``, else 1."""
        return _scales(float(self.width), float(self.height))[1]

    def fov_deg(self):
        """Full field of view of the image, in degrees.

        Returns
        -------
        (float, float)
            ``(horizontal_fov, vertical_fov)``, each ``2 atan(0.5 * scale)``; the shorter image
            axis spans ``2 atan(0.5) ~ 53.13`` degrees. These are the extents of the pixel
            footprints; the sample rays themselves span one pixel less (see the module notes).
            An orthographic camera has no field of view: ``(0.0, 0.0)``.
        """
        if self.orthographic:
            return 0.0, 0.0
        return (
            float(np.degrees(2.0 * np.arctan(0.5 * self.scale_x))),
            float(np.degrees(2.0 * np.arctan(0.5 * self.scale_y))),
        )

    def as_array(self):
        """Flatten the camera for numba kernels.

        Returns
        -------
        (16,) float64 array
            ``origin[0:3], forward[3:6], horizontal[6:9], vertical[9:12], width[12],
            height[13], projection[14]`` (the index in :data:`PROJECTIONS`) ``and
            view_width[15]``; kernels read it only through this module (:func:`camera_ray`).
        """
        out = np.empty(CAMERA_ARRAY_SIZE, dtype=np.float64)
        out[0:3] = self.origin
        out[3:6] = self.forward
        out[6:9] = self.horizontal
        out[9:12] = self.vertical
        out[CAM_WIDTH] = self.width
        out[CAM_HEIGHT] = self.height
        out[CAM_PROJECTION] = PROJECTIONS.index(self.projection)
        out[CAM_VIEW_WIDTH] = self.view_width
        return out


def _vector3(value, name):
    """Return ``value`` as a finite (3,) float64 array or raise ValueError."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be 3 numbers, got {value!r}") from None
    if arr.shape != (3,):
        raise ValueError(f"{name} must have shape (3,), got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite, got {arr.tolist()}")
    return arr


def _pixels(value, name):
    """Return ``value`` as a positive Python int or raise ValueError."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, Integral):
        raise ValueError(f"{name} must be a positive integer, got {value!r}")
    if value <= 0:
        raise ValueError(f"{name} must be a positive integer, got {value}")
    return int(value)


class LookAt(NamedTuple):
    """A camera as scene files give it (``camera: {origin, dest, up, projection,
    view_width}``), without an image size: the eye ``origin``, the point ``dest`` it looks at
    and an approximate ``up``, each a (3,) float64 array in world units, the ``projection``
    (:data:`PROJECTIONS`) and, orthographic, the view's width in scene units (None: the width
    the perspective camera sees at ``dest``, :func:`look_at`). ``pose.camera(width,
    height)`` builds its :class:`Camera`."""

    origin: np.ndarray
    dest: np.ndarray
    up: np.ndarray
    projection: str = "perspective"
    view_width: float = None

    def camera(self, width, height):
        """The :class:`Camera` of this pose for a ``width x height`` image."""
        return look_at(self.origin, self.dest, self.up, width, height,
                       projection=self.projection, view_width=self.view_width)

    def as_dict(self):
        """The scene file's ``camera`` object: ``origin``, ``dest``, ``up`` (9 significant
        digits), and ``projection`` / ``view_width`` when orthographic."""
        out = {k: [float(f"{v:.9g}") for v in np.asarray(vec, dtype=float)]
               for k, vec in (("origin", self.origin), ("dest", self.dest), ("up", self.up))}
        if self.projection != "perspective":
            out["projection"] = self.projection
            if self.view_width is not None:
                out["view_width"] = float(f"{self.view_width:.9g}")
        return out


def check_projection(projection, view_width):
    """``(projection, view_width)`` checked: a name of :data:`PROJECTIONS`, and None or a
    finite number > 0 (orthographic only); raises ValueError otherwise."""
    if projection not in PROJECTIONS:
        raise ValueError(f"projection must be one of {', '.join(PROJECTIONS)}; "
                         f"got {projection!r}")
    if view_width is None:
        return projection, None
    if projection != "orthographic":
        raise ValueError("view_width applies to the orthographic projection only "
                         "(give projection=\"orthographic\")")
    if isinstance(view_width, (bool, np.bool_)) or not isinstance(view_width, (int, float,
                                                                              np.number)):
        raise ValueError(f"view_width must be a number > 0 (scene units), got {view_width!r}")
    if not (math.isfinite(view_width) and view_width > 0):
        raise ValueError(f"view_width must be a finite number > 0 (scene units), "
                         f"got {view_width!r}")
    return projection, float(view_width)


def look_at(origin, dest, up, width, height, projection="perspective", view_width=None):
    """Build the authors' ``lookAt`` camera.

    Parameters
    ----------
    origin : (3,) array_like of float
        Eye position, world units.
    dest : (3,) array_like of float
        Point the camera looks at; must differ from ``origin``.
    up : (3,) array_like of float
        Approximate up direction; any length, not parallel to ``dest - origin``.
    width, height : int
        Image size in pixels, both > 0.
    projection : {"perspective", "orthographic"}
        Rays from ``origin``, or parallel rays from the image plane through ``origin``.
    view_width : float, optional
        Orthographic: the image's width in scene units; None: the width the perspective
        camera sees at ``dest`` (``|dest - origin| x scale_x``), so that the object at
        ``dest`` keeps its size in the image.

    Returns
    -------
    Camera
        ``forward = normalize(dest - origin)``, ``horizontal = normalize(forward x up)``,
        ``vertical = normalize(horizontal x forward)``.

    Raises
    ------
    ValueError
        For non-finite or wrongly shaped vectors, ``dest == origin``, ``up`` zero or parallel
        to the view direction, a size that is not a positive integer, an unknown projection
        or a view width that is not a number > 0.

    Examples
    --------
    >>> cam = look_at([0, 0, 3], [0, 0, 0], [0, 1, 0], 64, 48)
    >>> np.allclose(cam.horizontal, [1, 0, 0]), np.allclose(cam.vertical, [0, 1, 0])
    (True, True)
    """
    origin = _vector3(origin, "origin")
    dest = _vector3(dest, "dest")
    up = _vector3(up, "up")
    width = _pixels(width, "width")
    height = _pixels(height, "height")
    projection, view_width = check_projection(projection, view_width)

    view = dest - origin
    view_len = np.linalg.norm(view)
    if not view_len > 0.0:
        raise ValueError(f"camera dest must differ from origin, both are {origin.tolist()}")
    forward = view / view_len
    up_len = np.linalg.norm(up)
    if not up_len > 0.0:
        raise ValueError("camera up must be a non-zero vector")
    side = np.cross(forward, up)
    side_len = np.linalg.norm(side)
    if not side_len > _PARALLEL_TOL * up_len:
        raise ValueError(
            f"camera up {up.tolist()} is parallel to the view direction {forward.tolist()}"
        )
    horizontal = side / side_len
    vertical = np.cross(horizontal, forward)
    vertical /= np.linalg.norm(vertical)
    if projection == "perspective":
        return Camera(origin, forward, horizontal, vertical, width, height)
    if view_width is None:
        view_width = float(view_len * _scales(float(width), float(height))[0])
    return Camera(origin, forward, horizontal, vertical, width, height, projection, view_width)


@numba.njit(**NJIT)
def _scales(width, height):
    """Aspect multipliers ``(scale_x, scale_y)``: the longer axis gets ``max / min``."""
    if width >= height:
        return width / height, 1.0
    return 1.0, height / width


@numba.njit(**NJIT_IR_INLINE)
def _image_offsets(cam, row, col):
    """The authors' image-plane offsets ``(dx, dy)`` of ``(row, col)`` (module notes):
    ``dx = scale_x (col / W - 0.5)``, ``dy = scale_y ((H - 1 - row) / H - 0.5)``."""
    width = cam[CAM_WIDTH]
    height = cam[CAM_HEIGHT]
    sx, sy = _scales(width, height)
    dx = (col / width - 0.5) * sx
    dy = ((height - 1.0 - row) / height - 0.5) * sy
    return dx, dy


@numba.njit(**NJIT_IR_INLINE)
def _plane_scale(cam):
    """Orthographic: scene units per unit of ``dx`` / ``dy`` (``view_width / scale_x``)."""
    return cam[CAM_VIEW_WIDTH] / _scales(cam[CAM_WIDTH], cam[CAM_HEIGHT])[0]


@numba.njit(**NJIT)
def camera_ray(cam, row, col):
    """The ray through one pixel, or a sample of one: ``(ox, oy, oz, dx, dy, dz)``.

    Parameters
    ----------
    cam : (16,) float64 array
        :meth:`Camera.as_array`.
    row : float
        Image row, 0 = top (a pixel's own row, or a sample's row with its sub-pixel offset:
        callers pass floats, so that one specialisation serves both).
    col : float
        Image column, 0 = left.

    Returns
    -------
    (float, float, float, float, float, float)
        The ray's origin (world units) and unit direction: perspective, the eye and
        ``normalize(forward + dx horizontal + dy vertical)``; orthographic, the image-plane
        point ``origin + s (dx horizontal + dy vertical)`` and ``forward`` (module notes).
    """
    dx, dy = _image_offsets(cam, row, col)
    if cam[CAM_PROJECTION] == ORTHOGRAPHIC:
        s = _plane_scale(cam)
        return (cam[0] + s * (dx * cam[6] + dy * cam[9]),
                cam[1] + s * (dx * cam[7] + dy * cam[10]),
                cam[2] + s * (dx * cam[8] + dy * cam[11]), cam[3], cam[4], cam[5])
    rx = cam[3] + dx * cam[6] + dy * cam[9]
    ry = cam[4] + dx * cam[7] + dy * cam[10]
    rz = cam[5] + dx * cam[8] + dy * cam[11]
    norm = math.sqrt(rx * rx + ry * ry + rz * rz)
    return cam[0], cam[1], cam[2], rx / norm, ry / norm, rz / norm


@numba.njit(**NJIT_IR_INLINE)
def ray_direction(cam, row, col):
    """Unit direction ``(dx, dy, dz)`` of the ray through ``(row, col)`` (:func:`camera_ray`'s
    last three values; ``forward`` for an orthographic camera)."""
    ray = camera_ray(cam, row, col)
    return ray[3], ray[4], ray[5]


@numba.njit(**NJIT)
def block_rays(cam, r_lo, r_hi, c_lo, c_hi):
    """The rays of pixels ``[r_lo, r_hi) x [c_lo, c_hi)`` as one beam, for the cone passes:
    ``(ox, oy, oz, ux, uy, uz, near, spread)``.

    ``o + t u`` is the beam's central ray (``u`` unit) and every pixel ray ``p + t v`` of the
    block stays within ``near + spread t`` of it at the same ``t``:
    ``|p + t v - o - t u| <= near + spread t``. Perspective: ``o`` is the eye, ``near = 0`` and
    ``spread >= |v - u|`` (the rays of a rectangle form a spherically convex set, whose
    farthest point from ``u`` is a corner). Orthographic: ``u = forward``, ``o`` the mean of
    the corner rays' origins, ``near`` their largest distance from it and ``spread = 0``.
    Both bounds carry a relative margin of 1e-4 (and 1e-12 absolute)."""
    ox = 0.0
    oy = 0.0
    oz = 0.0
    ux = 0.0
    uy = 0.0
    uz = 0.0
    for r in (r_lo, r_hi - 1):
        for c in (c_lo, c_hi - 1):
            px, py, pz, vx, vy, vz = camera_ray(cam, float(r), float(c))
            ox += 0.25 * px
            oy += 0.25 * py
            oz += 0.25 * pz
            ux += vx
            uy += vy
            uz += vz
    n = math.sqrt(ux * ux + uy * uy + uz * uz)
    ux /= n
    uy /= n
    uz /= n
    if cam[CAM_PROJECTION] == ORTHOGRAPHIC:
        near = 0.0
        for r in (r_lo, r_hi - 1):
            for c in (c_lo, c_hi - 1):
                px, py, pz, vx, vy, vz = camera_ray(cam, float(r), float(c))
                near = max(near, math.sqrt((px - ox) ** 2 + (py - oy) ** 2 + (pz - oz) ** 2))
        return ox, oy, oz, cam[3], cam[4], cam[5], near * 1.0001 + 1e-12, 0.0
    delta = 0.0
    for r in (r_lo, r_hi - 1):
        for c in (c_lo, c_hi - 1):
            vx, vy, vz = ray_direction(cam, float(r), float(c))
            delta = max(delta, math.sqrt((vx - ux) ** 2 + (vy - uy) ** 2 + (vz - uz) ** 2))
    return cam[0], cam[1], cam[2], ux, uy, uz, 0.0, delta * 1.0001 + 1e-12


@numba.njit(**NJIT_IR_INLINE)
def far_depth(cam, lo, hi):
    """A ray parameter ``t`` beyond which every camera ray is outside the box ``lo..hi``
    (rays have unit speed): the farthest corner's distance from the eye (perspective), or
    its depth in front of the image plane (orthographic)."""
    t = 0.0
    ortho = cam[CAM_PROJECTION] == ORTHOGRAPHIC
    for k in range(8):
        cx = (hi[0] if k & 1 else lo[0]) - cam[0]
        cy = (hi[1] if k & 2 else lo[1]) - cam[1]
        cz = (hi[2] if k & 4 else lo[2]) - cam[2]
        if ortho:
            t = max(t, cx * cam[3] + cy * cam[4] + cz * cam[5])
        else:
            t = max(t, math.sqrt(cx ** 2 + cy ** 2 + cz ** 2))
    return t


@numba.njit(**NJIT_IR_INLINE)
def footprint(cam):
    """``(a, b)``: one pixel is ``a + b t`` scene units across at depth ``t`` along the rays;
    ``(0, 1 / min(W, H))`` for a perspective camera (the shorter image axis spans one unit at
    unit depth), ``(view_width / W, 0)`` for an orthographic one."""
    shorter = min(cam[CAM_WIDTH], cam[CAM_HEIGHT])
    if cam[CAM_PROJECTION] == ORTHOGRAPHIC:
        return _plane_scale(cam) / shorter, 0.0
    return 0.0, 1.0 / shorter


@numba.njit(**NJIT_IR_INLINE)
def image_size(cam):
    """``(W, H)``: the image's width and height in pixels (ints)."""
    return int(cam[CAM_WIDTH]), int(cam[CAM_HEIGHT])


@numba.njit(**NJIT_IR_INLINE)
def view_coordinates(cam, x, y, z):
    """A world vector in the camera frame: ``(v . horizontal, v . vertical, -v . forward)``
    (right, up, towards the camera)."""
    return (x * cam[6] + y * cam[7] + z * cam[8], x * cam[9] + y * cam[10] + z * cam[11],
            -(x * cam[3] + y * cam[4] + z * cam[5]))


def sample_rays(cam, rows, cols):
    """Rays through fractional image positions (vectorised :func:`camera_ray`).

    Parameters
    ----------
    cam : (16,) float64 array
        :meth:`Camera.as_array`.
    rows, cols : (n,) float64 arrays
        Image positions (0 = top row, left column; sub-pixel offsets allowed).

    Returns
    -------
    origins : (3,) or (n, 3) float64 array
        The eye (perspective: one origin for every ray), or each ray's image-plane origin.
    dirs : (n, 3) float64 array
        Unit directions.
    """
    width, height = cam[CAM_WIDTH], cam[CAM_HEIGHT]
    sx, sy = _scales(width, height)
    dx = (cols / width - 0.5) * sx
    dy = ((height - 1.0 - rows) / height - 0.5) * sy
    if cam[CAM_PROJECTION] == ORTHOGRAPHIC:
        s = _plane_scale(cam)
        origins = cam[0:3][None, :] + s * (dx[:, None] * cam[6:9][None, :]
                                           + dy[:, None] * cam[9:12][None, :])
        return origins, np.repeat(cam[3:6][None, :], len(dx), axis=0)
    d = cam[3:6][None, :] + dx[:, None] * cam[6:9][None, :] + dy[:, None] * cam[9:12][None, :]
    norm = np.sqrt(d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1] + d[:, 2] * d[:, 2])
    return cam[0:3].copy(), d / norm[:, None]


def _grid_rays(camera, rows=None):
    """:func:`sample_rays` of every pixel of rows ``rows = (r0, r1)`` (None: all), as
    ``(origins, dirs)``: ``(3,)`` or ``(h, W, 3)``, and ``(h, W, 3)``."""
    r0, r1 = (0, camera.height) if rows is None else rows
    rr, cc = np.meshgrid(np.arange(r0, r1, dtype=np.float64),
                         np.arange(camera.width, dtype=np.float64), indexing="ij")
    origins, dirs = sample_rays(camera.as_array(), rr.ravel(), cc.ravel())
    shape = (r1 - r0, camera.width, 3)
    return (origins if origins.ndim == 1 else origins.reshape(shape)), dirs.reshape(shape)


def primary_rays(camera, rows=None):
    """Unit directions of all primary rays (vectorised :func:`ray_direction`).

    Parameters
    ----------
    camera : Camera
    rows : (int, int), optional
        ``(r0, r1)``: only the image rows ``r0 <= row < r1`` (the same values as those rows of
        the whole image).

    Returns
    -------
    (H, W, 3) float64 array
        ``rays[row, col]`` is the world-space unit direction for image row ``row`` (0 = top)
        and column ``col``; the rays start at :func:`ray_origins`. With ``rows``:
        ``(r1 - r0, W, 3)``.
    """
    return _grid_rays(camera, rows)[1]


def ray_origins(camera, rows=None):
    """Where the primary rays start: ``camera.origin`` (3,) for a perspective camera (every
    ray), an ``(H, W, 3)`` float64 array of image-plane points for an orthographic one
    (``rows`` as in :func:`primary_rays`)."""
    if not camera.orthographic:
        return np.asarray(camera.origin, dtype=np.float64)
    return _grid_rays(camera, rows)[0]


def pixel_points(camera, depth):
    """World points ``(H, W, 3)`` float64 at ray parameter ``depth (H, W)`` along every
    pixel's primary ray (a render's t-buffer: its hit points)."""
    depth = np.asarray(depth, dtype=np.float64)
    return ray_origins(camera) + depth[..., None] * primary_rays(camera)


def project(camera, points):
    """Map world points to fractional pixel coordinates (inverse of :func:`primary_rays`).

    Parameters
    ----------
    camera : Camera
    points : (n, 3) or (3,) array_like of float
        World positions.

    Returns
    -------
    rows : (n,) float64 array
        Fractional image row (0 = top) in the sampling convention of :func:`ray_direction`:
        integer values land exactly on sample rays, so ``project(origin + t * rays[r, c])``
        gives back ``(r, c, t)``. Values outside ``[0, H - 1]`` are off screen.
    cols : (n,) float64 array
        Fractional image column (0 = left), same convention.
    depth_along_ray : (n,) float64 array
        The ``t`` of the unit primary ray through the point (the quantity a sphere tracer's
        t-buffer stores): the distance from ``camera.origin`` (perspective), or the depth in
        front of the image plane (orthographic).

    Points on or behind the camera plane (``(p - origin) . forward <= 0``) get NaN in all three
    outputs. A (3,) input gives (1,) outputs.
    """
    pts = np.asarray(points, dtype=np.float64)
    if pts.ndim == 1:
        pts = pts[None, :]
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise ValueError(f"points must have shape (n, 3), got shape {np.shape(points)}")
    width, height = float(camera.width), float(camera.height)
    sx, sy = _scales(width, height)
    rel = pts - camera.origin
    along = rel @ camera.forward
    right = rel @ camera.horizontal
    upward = rel @ camera.vertical
    with np.errstate(divide="ignore", invalid="ignore"):
        front = along > 0.0
        scale = camera.view_width / sx if camera.orthographic else along
        dx = np.where(front, right / scale, np.nan)
        dy = np.where(front, upward / scale, np.nan)
        cols = (dx / sx + 0.5) * width
        rows = height - 1.0 - (dy / sy + 0.5) * height
        depth = np.where(front, along if camera.orthographic else np.linalg.norm(rel, axis=1),
                         np.nan)
    return rows, cols, depth


def pyvista_camera_params(camera, focal_distance=1.0):
    """Camera settings that make a VTK / pyvista render match this camera.

    Parameters
    ----------
    camera : Camera
    focal_distance : float, default 1.0
        Distance from the eye to the returned ``focal_point`` along ``forward``; it does not
        change a perspective image (use the scene's ``|dest - origin|`` for nicer clipping).

    Returns
    -------
    dict
        * ``position`` : (3,) float64, the eye.
        * ``focal_point`` : (3,) float64, ``origin + focal_distance * forward``.
        * ``view_up`` : (3,) float64, ``camera.vertical`` (already orthogonal to forward).
        * ``view_angle`` : float, the **vertical** field of view in degrees,
          ``2 atan(0.5 scale_y)`` (VTK's ``ViewAngle`` with ``UseHorizontalViewAngle`` off).
        * ``window_center`` : (float, float), ``(-1 / W, -1 / H)``.
        * ``window_size`` : (int, int), ``(W, H)`` for ``pyvista.Plotter(window_size=...)``.
        * ``parallel_projection`` : bool, the camera is orthographic; then
          ``parallel_scale`` : float, half the view's height in scene units (VTK's
          ``ParallelScale``), and ``view_angle`` is 0.

    Notes
    -----
    The authors sample column ``x`` at ``dx = x / W - 0.5``, so column 0 is at ``-0.5`` and
    column ``W - 1`` at ``0.5 - 1 / W``: the sample grid is centred on ``dx = -0.5 / W``, not
    on 0. A rasteriser samples pixel centres of a symmetric frustum, i.e. at
    ``(x + 0.5) / W - 0.5``. Both grids coincide once VTK's frustum is shifted by half a pixel
    left and (in their bottom-up ``y``) half a pixel down, which is what
    ``vtkCamera.SetWindowCenter(-1 / W, -1 / H)`` does (the window centre is in viewport units
    of ``[-1, 1]``, so half a pixel is ``1 / W``). Apply it with::

        p = pyvista.Plotter(off_screen=True, window_size=params["window_size"])
        p.camera.position = params["position"]
        p.camera.focal_point = params["focal_point"]
        p.camera.up = params["view_up"]
        p.camera.SetWindowCenter(*params["window_center"])
        if params["parallel_projection"]:
            p.camera.enable_parallel_projection()
            p.camera.parallel_scale = params["parallel_scale"]
        else:
            p.camera.view_angle = params["view_angle"]

    Without the window centre the pyvista image is shifted by half a pixel (a sub-pixel
    error; fine for a visual comparison, not for pixel-exact diffs).
    """
    width, height = float(camera.width), float(camera.height)
    return {
        "position": np.array(camera.origin, dtype=np.float64),
        "focal_point": camera.origin + float(focal_distance) * camera.forward,
        "view_up": np.array(camera.vertical, dtype=np.float64),
        "view_angle": camera.fov_deg()[1],
        "window_center": (-1.0 / width, -1.0 / height),
        "window_size": (camera.width, camera.height),
        "parallel_projection": camera.orthographic,
        "parallel_scale": 0.5 * camera.view_width * height / width,
    }


_AXES = {
    "+x": (1.0, 0.0, 0.0), "-x": (-1.0, 0.0, 0.0),
    "+y": (0.0, 1.0, 0.0), "-y": (0.0, -1.0, 0.0),
    "+z": (0.0, 0.0, 1.0), "-z": (0.0, 0.0, -1.0),
}


def _direction(value, name):
    """Parse an axis name such as ``"+z"`` or a 3-vector into a unit (3,) float64 array."""
    if isinstance(value, str):
        key = value.strip().lower()
        if key in ("x", "y", "z"):
            key = "+" + key
        if key not in _AXES:
            raise ValueError(f"{name} must be one of {sorted(_AXES)} or a 3-vector, got {value!r}")
        return np.array(_AXES[key])
    vec = _vector3(value, name)
    norm = np.linalg.norm(vec)
    if norm == 0.0:
        raise ValueError(f"{name} must be a non-zero vector")
    return vec / norm


def default_camera_for_bounds(lo, hi, axis="+z", up="+y", width=512, height=512):
    """The paper's automatic camera for a bounding box.

    The eye sits at the box centre plus ``2 * max(hi - lo)`` along ``axis`` and looks at the
    centre. With the defaults this is the camera of the authors' ``beta_error_test`` (512 x 512,
    +z, up +y); ``axis="+y", up="+z", width=1920, height=1080`` is ``scene_builder``'s default.

    Parameters
    ----------
    lo, hi : (3,) array_like of float
        Box corners, ``lo <= hi``.
    axis : {"+x", "-x", "+y", "-y", "+z", "-z"} or (3,) array_like, default "+z"
        Direction from the centre to the eye.
    up : {"+x", "-x", "+y", "-y", "+z", "-z"} or (3,) array_like, default "+y"
        Up direction; must not be parallel to ``axis``.
    width, height : int, default 512
        Image size in pixels.

    Returns
    -------
    Camera

    Raises
    ------
    ValueError
        For a malformed box, a degenerate (single-point) box, or an invalid axis / up / size.
    """
    lo = _vector3(lo, "lo")
    hi = _vector3(hi, "hi")
    if np.any(hi < lo):
        raise ValueError(f"bounds must satisfy lo <= hi, got lo={lo.tolist()} hi={hi.tolist()}")
    extent = float(np.max(hi - lo))
    if not extent > 0.0:
        raise ValueError(f"bounds are a single point {lo.tolist()}; no camera distance")
    direction = _direction(axis, "axis")
    up_vec = _direction(up, "up")
    centre = 0.5 * (lo + hi)
    return look_at(centre + 2.0 * extent * direction, centre, up_vec, width, height)


#: Named views for :func:`frame_box`: ``name -> (direction from the centre to the eye, up)``.
#: y is up (the OBJ / graphics convention): ``front`` looks down -z from +z, ``top`` looks
#: down -y with -z at the top of the image, ``iso`` looks from the (+x, +y, +z) octant.
VIEWS = {
    "front": ((0.0, 0.0, 1.0), (0.0, 1.0, 0.0)),
    "back": ((0.0, 0.0, -1.0), (0.0, 1.0, 0.0)),
    "left": ((-1.0, 0.0, 0.0), (0.0, 1.0, 0.0)),
    "right": ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0)),
    "top": ((0.0, 1.0, 0.0), (0.0, 0.0, -1.0)),
    "iso": ((1.0, 1.0, 1.0), (0.0, 1.0, 0.0)),
}

#: World up axes a named view can be turned to (:func:`view_vectors`).
UP_AXES = ("x", "y", "z")
#: Rotations that take the y-up views to an x- or z-up world (right-handed; for z up,
#: ``front`` looks along +y from -y with x to the right, as in Blender, and ``top`` looks
#: down -z).
_UP_ROTATIONS = {
    "x": np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]),
    "y": np.eye(3),
    "z": np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]]),
}


def view_vectors(view, up="y"):
    """``(direction from the centre to the eye, image up)`` of the named ``view`` (a key of
    :data:`VIEWS`) in a world whose up axis is ``up`` (``"x"``, ``"y"`` or ``"z"``): the
    y-up definitions of :data:`VIEWS` rotated so that y goes to ``up``."""
    if view not in VIEWS:
        raise ValueError(f"view must be one of {', '.join(VIEWS)}; got {view!r}")
    if up not in _UP_ROTATIONS:
        raise ValueError(f"up must be one of {', '.join(UP_AXES)}; got {up!r}")
    R = _UP_ROTATIONS[up]
    direction, upv = VIEWS[view]
    return R @ np.asarray(direction), R @ np.asarray(upv)


#: Default free border of :func:`frame_box`, as a fraction of the image's half-size.
FRAME_MARGIN = 0.05


def frame_box(lo, hi, view="front", width=512, height=512, margin=FRAME_MARGIN):
    """A camera from which the whole box ``lo..hi`` is in view, with a small free border.

    :func:`frame_points` of the box's eight corners; the box may be flat but not a single
    point. Returns ``(origin, dest, up)``.
    """
    lo = _vector3(lo, "lo")
    hi = _vector3(hi, "hi")
    if np.any(hi < lo):
        raise ValueError(f"bounds must satisfy lo <= hi, got lo={lo.tolist()} hi={hi.tolist()}")
    if not np.linalg.norm(hi - lo) > 0.0:
        raise ValueError(f"bounds are a single point {lo.tolist()}; nothing to frame")
    return frame_points(box_corners(lo, hi), 0.0, view, width, height, margin)


def box_corners(lo, hi):
    """The eight corners ``(8, 3)`` float64 of the axis-aligned box ``lo..hi``."""
    lo = np.asarray(lo, dtype=np.float64)
    hi = np.asarray(hi, dtype=np.float64)
    return np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                     for z in (lo[2], hi[2])])


def frame_points(points, radius, view="front", width=512, height=512, margin=FRAME_MARGIN,
                 up="y"):
    """A camera from which every ball of ``radius`` around ``points`` is in view.

    The eye looks at the centre of the points' bounding box from the named ``view``
    direction and is placed at the smallest distance at which every ball lies inside the
    view pyramid shrunk by ``margin`` (a fraction of the image's half-size) and one pixel,
    and the eye lies outside every ball by at least ``margin x`` their extent. A surface
    known to lie within ``radius`` of the convex hull of ``points`` (the smooth surface lies
    within its inflation bound of the data's vertices' hull) is therefore wholly in view, at
    any scale and position.

    Parameters
    ----------
    points : (n, 3) array_like of float
    radius : float >= 0
    view : str or ((3,), (3,))
        A key of :data:`VIEWS`, or ``(direction from the centre to the eye, up)``.
    width, height : int
        Image size in pixels.
    margin : float
        Free border as a fraction of the image's half-size, in ``[0, 0.9]``.
    up : {"x", "y", "z"}
        The world's up axis for a named ``view`` (:func:`view_vectors`).

    Returns
    -------
    (origin, dest, up) : three (3,) float64 arrays, for :func:`look_at` or a scene file.
    """
    P = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    radius = float(radius)
    if P.shape[0] == 0 or not np.all(np.isfinite(P)) or not (radius >= 0.0):
        raise ValueError("frame_points needs finite points and a radius >= 0")
    lo, hi = P.min(axis=0), P.max(axis=0)
    extent = float(np.linalg.norm(hi - lo)) + 2.0 * radius
    if not extent > 0.0:
        raise ValueError(f"nothing to frame: a single point {lo.tolist()} and radius 0")
    if isinstance(view, str):
        direction, up = view_vectors(view, up)
    else:
        try:
            direction, up = view
        except (TypeError, ValueError):
            raise ValueError(f"view must be a name or (direction, up), got {view!r}") from None
    if not 0.0 <= float(margin) <= 0.9:
        raise ValueError(f"margin must be between 0 and 0.9, got {margin!r}")
    centre = 0.5 * (lo + hi)
    direction = _direction(direction, "view direction")
    up = _direction(up, "view up")
    cam = look_at(centre + direction, centre, up, width, height)
    rel = P - centre
    right = np.abs(rel @ cam.horizontal)
    upward = np.abs(rel @ cam.vertical)
    along = rel @ cam.forward
    # a ball at (right, upward, along) from the centre, eye at distance D: inside the
    # half-space |x| <= k z of the view pyramid iff right + radius sqrt(1 + k^2) <= k (D + along)
    kx = cam.scale_x * max(0.5 * (1.0 - margin) - 1.0 / cam.width, 0.05)
    ky = cam.scale_y * max(0.5 * (1.0 - margin) - 1.0 / cam.height, 0.05)
    dist = max(float(np.max((right + radius * np.hypot(1.0, kx)) / kx - along)),
               float(np.max((upward + radius * np.hypot(1.0, ky)) / ky - along)),
               float(np.max(-along)) + radius + max(margin, 0.01) * extent)
    return centre + dist * direction, centre, up


def frame_width(points, radius, pose, width, height, margin=FRAME_MARGIN):
    """The orthographic view width (scene units) at which every ball of ``radius`` around
    ``points`` lies in the image of ``pose = (origin, dest, up)``, with a free border of
    ``margin`` (a fraction of the image's half-size) and one pixel, as :func:`frame_points`
    frames them for a perspective camera."""
    P = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    cam = look_at(*pose, width, height)
    rel = P - np.asarray(pose[1], dtype=np.float64)
    right = float(np.max(np.abs(rel @ cam.horizontal))) + float(radius)
    upward = float(np.max(np.abs(rel @ cam.vertical))) + float(radius)
    kx = max(0.5 * (1.0 - margin) - 1.0 / width, 0.05)
    ky = max(0.5 * (1.0 - margin) - 1.0 / height, 0.05)
    view_width = max(right / kx, upward / ky * width / height)
    return view_width if view_width > 0.0 else 1.0
