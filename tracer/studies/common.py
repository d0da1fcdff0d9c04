"""Helpers shared by the studies: the data types, their ``--types`` and common options, mesh
loading with a per-process cache, "weights off" fields, and the machine description written
into reports. Option checks and atomic CSV/JSON/text output are in :mod:`tracer.outputs`, the
task runner in :mod:`tracer.runner`.

Everything here runs both in the process that drives a study and in Dask worker processes;
nothing imports matplotlib or dask.
"""

import copy
import functools
import math
import os
import platform
import warnings
from pathlib import Path

import numba
import numpy as np

from smoothdist import DataMesh, MeshRepairWarning, SmoothDistanceField
from smoothdist.mesh import needs_trimesh
from tracer.errors import CLIError
from tracer.rendering.camera import UP_AXES, VIEWS, frame_points
from tracer.runner import file_stamp, needs as cluster_needs
from tracer.scenes.from_mesh import auto_orientation, resolve_up

#: repository root (``tracer/studies/../..``)
REPO = Path(__file__).resolve().parents[2]
#: the paper's three data-mesh types, in its order
TYPES = ("points", "edges", "triangles")
#: colours of the paper's beta figure: vertices green, edges orange, triangles purple
TYPE_COLORS = {"points": "#2ca02c", "edges": "#ff7f0e", "triangles": "#8e44ad"}
TYPE_LETTER = {"points": "v", "edges": "e", "triangles": "f"}


# =============================================================================== arguments
def parse_types(text):
    """``"v,edges,faces"`` -> ``["points", "edges", "triangles"]`` (one-line errors)."""
    out = []
    for part in str(text).split(","):
        part = part.strip()
        if not part:
            continue
        part = {"faces": "triangles", "vertices": "points", "v": "points", "e": "edges",
                "f": "triangles"}.get(part, part)
        if part not in TYPES:
            raise CLIError(f"--types: unknown type {part!r} (choose from {', '.join(TYPES)})")
        if part not in out:
            out.append(part)
    if not out:
        raise CLIError("--types: give at least one of points, edges, triangles")
    return out


def add_common(p):
    """``--threads`` and ``-q`` (every study)."""
    p.add_argument("--threads", type=int, help="numba threads of in-process work (default: all "
                   "cores; Dask workers always use one thread each)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar or log lines")
    return p


def add_view_arguments(p, default):
    """``--view`` and ``--up`` of ``tracer render`` (the same choices, the same framing:
    :func:`tracer.rendering.camera.frame_points`, and the same up axis guess:
    :func:`tracer.scenes.from_mesh.resolve_up`); ``default`` says which camera the study uses
    without them."""
    p.add_argument("--view", choices=tuple(VIEWS),
                   help="camera framing the whole surface from this side, as in tracer render "
                   f"(default: {default})")
    p.add_argument("--up", choices=("auto",) + UP_AXES,
                   help="the data's up axis for --view, as in tracer render (auto = z for .stl "
                   "and .ply, y otherwise); given alone, it implies --view front")


def study_needs(args, meshes=()):
    """A study's ``needs`` (:mod:`tracer.cli` checks them before any work): matplotlib and
    Pillow for its plots and images, distributed for a cluster
    (:func:`tracer.runner.needs`), trimesh when one of the mesh files ``meshes`` is a format
    our own readers do not read."""
    out = ["matplotlib"] + cluster_needs(args) + ["PIL"]
    return out + (["trimesh"] if any(needs_trimesh(m) for m in meshes) else [])


def resolve_view(args, mesh):
    """``(view, up)`` of the study's ``--view`` / ``--up`` for the mesh file ``mesh``, or
    ``(None, None)`` when neither is given (the study's own camera)."""
    view, up = getattr(args, "view", None), getattr(args, "up", None)
    if not view and not up:
        return None, None
    return view or "front", resolve_up(os.fspath(mesh), up)


def render_orientation(mesh, data):
    """``(view, up, why)`` of a study of a mesh of one's own given neither ``--view`` nor
    ``--up``: the orientation ``tracer render FILE`` chooses (the file's up convention, or else
    the view that shows the data's largest silhouette:
    :func:`tracer.scenes.from_mesh.auto_orientation`); ``view`` a name or ``(direction to the
    eye, image up)``, ``data`` the :class:`smoothdist.DataMesh` of the file ``mesh``."""
    up, view, why = auto_orientation(data, resolve_up(os.fspath(mesh), None))
    return view, up, why


def view_name(view):
    """A view for the study's report: its name, or ``along (x, y, z)`` for a side view."""
    if isinstance(view, str) or view is None:
        return view
    d = np.asarray(view[0], float)
    return "along (" + ", ".join(f"{-v:g}" for v in d) + ")"


def view_camera(fields, view, up, grow, size):
    """The camera of ``tracer render --view VIEW --up UP`` for the data of ``fields`` (one
    field or several, framed together) at ``size`` x ``size`` pixels: their vertices grown by
    ``grow`` (scene units: the surface's inflation bound and eps) all in view. Returns
    ``(origin, dest, up)`` as lists."""
    if not isinstance(fields, (list, tuple)):
        fields = [fields]
    P = np.concatenate([f.mesh.used_vertices() for f in fields])
    return [np.asarray(v, float).tolist()
            for v in frame_points(P, grow, view, size, size, up=up)]


def is_paper_bunny(mesh):
    """Whether the mesh file ``mesh`` holds the paper's bunny (``scenes/data/bunny.off``:
    the same vertices and triangles, in any file format), whose beta-study errors the
    authors published."""
    ref = REPO / "scenes" / "data" / "bunny.off"
    if not ref.is_file():
        return False
    try:
        if os.path.samefile(mesh, ref):
            return True
    except OSError:
        pass
    a, b = load_mesh_checked(mesh), load_mesh_checked(ref)
    if a.V.shape != b.V.shape or a.triangles.shape != b.triangles.shape:
        return False
    # another file format may round the coordinates (e.g. 6 significant digits)
    diag = float(np.linalg.norm(b.V.max(0) - b.V.min(0)))
    return bool(np.array_equal(a.triangles, b.triangles)
                and np.allclose(a.V, b.V, rtol=0, atol=1e-5 * diag))


# =============================================================================== meshes
def load_mesh_checked(path, kind=None):
    """Load a mesh file as a DataMesh (``kind`` as in ``DataMesh.as_kind``), one-line errors
    (:class:`tracer.errors.CLIError`)."""
    path = os.fspath(path)
    if not os.path.exists(path):
        raise CLIError(f"mesh file not found: {path}")
    if os.path.isdir(path):
        raise CLIError(f"mesh path is a folder, not a file: {path}")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", MeshRepairWarning)
            mesh = DataMesh.load(path)
            return mesh.as_kind(kind) if kind is not None else mesh
    except (ValueError, OSError) as exc:
        msg = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise CLIError(f"cannot use {path}: {msg}") from None


@functools.lru_cache(maxsize=8)
def _cached_field(stamp, kind):
    return SmoothDistanceField(load_mesh_checked(stamp[0], kind))


def cached_field(path, kind):
    """The ``SmoothDistanceField`` of the mesh file ``path`` as ``kind``, built once per
    process (a small LRU keyed by path, modification time, size and kind): a Dask worker that
    runs many tasks on one mesh builds its BVH once, and only the path travels with a task."""
    return _cached_field(file_stamp(path), kind)


def field_of(mesh):
    return SmoothDistanceField(mesh)


def unweighted_field(field):
    """A shallow copy of ``field`` whose every primitive has weight 1 ("weights off").

    The raw weight polynomial ``A w~`` of edges and triangles becomes the constant 1
    (``wc[:, 0] = 1``, all other coefficients 0; see ``smoothdist.kernels.TreeData`` and
    ``smoothdist._kernels.query.primitive_term``), the per-primitive clamp ``pwhi`` and the node
    bounds ``whi`` become 1 (so that the Barnes-Hut far field ``count * whi**S`` and the tracer's
    inflation margin ``log(A**S N) / alpha`` use the unweighted bound), and ``A`` becomes 1.
    Point clouds are unchanged (their weight is already 1).
    """
    field = field.with_weights("paper")     # the constant polynomial 1 (junction rows differ)
    t = field.tree
    wc = np.zeros_like(t.wc)
    wc[:, 0] = 1.0
    out = copy.copy(field)
    out.tree = t._replace(wc=wc, pwhi=np.ones_like(t.pwhi), whi=np.ones_like(t.whi),
                          lwhi=np.zeros_like(t.lwhi), A=1.0)
    return out


# =============================================================================== reports
def fmt(v, digits=4):
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return ""
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    return f"{float(v):.{digits}g}"


def machine_info():
    return {"platform": platform.platform(), "processor": platform.processor() or "",
            "cpu_count": os.cpu_count(), "numba_threads": int(numba.get_num_threads()),
            "python": platform.python_version(), "numba": numba.__version__,
            "load_average": [round(x, 2) for x in os.getloadavg()]
            if hasattr(os, "getloadavg") else None}


def beta_tag(beta):
    """``0.5`` -> ``"0.5"`` for file names."""
    return f"{beta:g}".replace("-", "m")


def close(a, b, rel=1e-9):
    return abs(float(a) - float(b)) <= rel * max(1.0, abs(float(a)), abs(float(b)))
