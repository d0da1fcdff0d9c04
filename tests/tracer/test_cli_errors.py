"""Hardening: a catalogue of bad inputs, numerical safety, and no lost data.

The catalogue (:data:`CATALOGUE`) is the specification: one row per bad (or valid but
extreme) input, with the layer it is tested at and the expected behaviour:

* ``error: <text>``: the API raises ``ValueError`` whose message contains ``<text>``; the CLI
  exits with status 2, prints exactly one stderr line ``error: ...`` containing ``<text>``, no
  traceback, and leaves no output (nor temporary) file behind;
* ``warning: <text>``: the input is repaired with a ``MeshRepairWarning`` containing ``<text>``
  (one ``warning: ...`` line from the CLI) and the result is finite;
* ``ok``: a valid but extreme input; the result is computed and finite.

CLI rows are errors detected before rendering: they run ``python -m tracer render`` in
subprocesses (started together, in a small pool, to keep the file fast) and
:func:`test_cli_errors_compile_no_kernels` checks that none of them loads or compiles a numba
kernel. Everything that needs the kernels is tested in-process at the API level.
"""

import json
import os
import signal
import subprocess
import sys
import time
import warnings
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

import smoothdist
import smoothdist.mesh
import tracer.validate
from smoothdist import DataMesh, MeshRepairWarning, SmoothDistanceField
from tracer.image import save_npy, save_png
from tracer.outputs import atomic_write
from tracer.rendering.frame import RenderResult
from tracer.rendering.renderer import render
from tracer.scenes.scene import load_scene, scene_from_field

REPO = Path(__file__).resolve().parents[2]
LIDAR = REPO / "scenes" / "lidar_autzen.json"
IS_ROOT = hasattr(os, "geteuid") and os.geteuid() == 0

# ----------------------------------------------------------------------------- the catalogue
#: (id, input, layer, expected). ``expected`` is ``"error: <substring>"``,
#: ``"warning: <substring>"`` or ``"ok"`` (see the module docstring).
CATALOGUE = [
    # --- files -----------------------------------------------------------------------------
    ("file-missing-scene", "scene file that does not exist", "cli",
     "error: scene file not found"),
    ("file-missing-mesh", "object path names a mesh that does not exist", "cli",
     "error: file not found"),
    ("file-unreadable-scene", "scene file with mode 000 (skipped as root: see the api row)",
     "cli", "error: permission denied"),
    ("file-unreadable-scene-api", "scene file that cannot be opened (PermissionError, emulated)",
     "api", "error: permission denied"),
    ("file-unreadable-mesh-api", "mesh file that cannot be opened (PermissionError, emulated)",
     "api", "error: permission denied"),
    ("file-empty-scene", "scene file of 0 bytes", "cli", "error: scene file is empty"),
    ("file-blank-scene", "scene file of white space only", "cli", "error: scene file is empty"),
    ("file-empty-mesh", "mesh file of 0 bytes", "cli", "error: mesh file is empty"),
    ("file-truncated-scene", "scene JSON cut off mid-way", "cli", "error: malformed JSON"),
    ("file-truncated-obj", "OBJ whose last vertex has 2 coordinates", "cli",
     "error: malformed OBJ record"),
    ("file-truncated-ply", "binary PLY cut off after 3000 bytes", "cli",
     "error: could not read mesh file"),
    ("file-wrong-ext-mesh", "mesh file with extension .abc", "cli",
     "error: unsupported mesh format"),
    ("file-wrong-ext-output", "-o out.jpg", "cli", "error: output must be a .png file"),
    ("file-wrong-ext-aov", "--depth depth.png", "cli", "error: --depth must name a .npy file"),
    ("file-garbage-scene", "scene file of random bytes", "cli", "error: not a text JSON file"),
    ("file-garbage-obj", "OBJ file of random bytes", "cli", "error: not a text OBJ file"),
    ("file-garbage-ply", "PLY file of random bytes", "cli", "error: could not read mesh file"),
    ("file-mesh-is-folder", "object path names a folder", "cli", "error: is a folder"),
    ("file-render-folder", "tracer render FOLDER (a folder named like a mesh too)", "cli",
     "error: it is a folder, not a file"),
    ("file-nan-coords", "OBJ vertex 'v nan 0 0'", "cli", "error: NaN or infinite"),
    ("file-inf-coords", "OBJ vertex 'v 1e999 0 0' (inf)", "cli", "error: NaN or infinite"),
    ("file-huge-coords", "OBJ vertices at +-1e300", "cli", "error: coordinates beyond"),
    ("file-large-coords", "unit tetrahedron translated by 1e12 (distance + render)", "api",
     "ok"),
    ("file-output-exists", "existing -o file without --overwrite (kept unchanged)", "cli",
     "error: output exists"),
    ("file-aov-exists", "existing --depth file without --overwrite", "cli",
     "error: output exists"),
    ("file-duplicate-vertex-cli", "OBJ with a vertex listed twice (renders)", "cli",
     "warning: merged 1 duplicated vertices"),
    # --- meshes ----------------------------------------------------------------------------
    ("mesh-no-vertices-file", "OBJ with faces but no 'v' records", "cli",
     "error: has no vertices"),
    ("mesh-no-vertices", "DataMesh(V of shape (0, 3))", "api", "error: has no vertices"),
    ("mesh-no-faces", "DataMesh(V, F of shape (0, 3))", "api", "error: F has no rows"),
    ("mesh-index-out-of-range-file", "OBJ face 'f 1 2 9' with 4 vertices", "cli",
     "error: out of range"),
    ("mesh-index-zero-file", "OBJ face 'f 0 1 2' (OBJ counts from 1)", "cli",
     "error: start at 1"),
    ("mesh-index-negative-file", "OBJ face 'f 1 2 -9' (relative index before the start)",
     "cli", "error: negative vertex indices"),
    ("mesh-index-out-of-range", "triangle referring to vertex 7 of 4", "api",
     "error: out of range"),
    ("mesh-index-negative", "triangle with index -1", "api", "error: negative vertex indices"),
    ("mesh-index-float", "triangle with index 0.5", "api", "error: integer vertex indices"),
    ("mesh-nan-vertex", "V with a NaN coordinate", "api", "error: NaN or infinite"),
    ("mesh-huge-vertex", "V with a coordinate of 1e60", "api", "error: coordinates beyond"),
    ("mesh-duplicate-vertices", "triangle mesh with one vertex stored twice", "api",
     "warning: merged 1 duplicated vertices"),
    ("mesh-zero-length-edge", "edge mesh with one edge from a vertex to itself", "api",
     "warning: dropped 1 zero-length edges"),
    ("mesh-zero-area-triangle", "triangle mesh with one collinear triangle", "api",
     "warning: dropped 1 zero-area triangles"),
    ("mesh-only-degenerate-file", "OBJ whose only triangle is collinear", "cli",
     "error: no valid primitives left"),
    ("mesh-only-degenerate", "edge mesh whose edges all have zero length", "api",
     "error: no valid primitives left"),
    ("mesh-nonmanifold-edges", "4 triangles sharing one edge (a book)", "api", "ok"),
    ("mesh-isolated-triangles", "3 disjoint triangles", "api", "ok"),
    ("mesh-single-point", "one point: distances and a 16x16 render", "api", "ok"),
    ("mesh-identical-points", "50 copies of the same point (merged to one)", "api",
     "warning: merged 49 duplicated vertices"),
    # --- parameters ------------------------------------------------------------------------
    ("param-alpha-zero", "object alpha 0", "cli", "error: objects[0].alpha must be > 0"),
    ("param-alpha-negative", "--alpha -1", "cli", "error: --alpha must be > 0"),
    ("param-alpha-nan", "--alpha nan", "cli", "error: --alpha must be finite"),
    ("param-alpha-zero-api", "smooth_distance(alpha=0)", "api",
     "error: alpha must be a finite number > 0"),
    ("param-alpha-tiny", "alpha x bbox diagonal = 1e-15", "api", "error: is too small"),
    ("param-alpha-huge", "alpha x bbox diagonal = 1e7 (distance + render)", "api", "ok"),
    ("param-alpha-u-zero", "object alpha_u 0", "cli",
     "error: objects[0].alpha_u must be > 0"),
    ("param-alpha-u-negative-api", "smooth_distance(alpha_u=-1)", "api",
     "error: alpha_u must be a finite number > 0"),
    ("param-beta-negative", "--beta -0.5", "cli", "error: --beta must be >= 0"),
    ("param-beta-negative-api", "smooth_distance(beta=-1)", "api",
     "error: beta must be a finite number >= 0"),
    ("param-beta-inf-api", "smooth_distance(beta=inf)", "api",
     "error: beta must be a finite number >= 0"),
    ("param-beta-huge", "beta = 1e6 (distance + render)", "api", "ok"),
    ("param-size-zero", "--size 0 16", "cli", "error: --size width must be > 0"),
    ("param-size-enormous", "--size 100000 100000", "cli", "error: larger than 64 megapixels"),
    ("param-size-zero-api", "scene_from_field(width=0)", "api", "error: width must be > 0"),
    ("param-eps-zero", "--eps 0", "cli", "error: --eps must be > 0"),
    ("param-eps-negative", "top-level eps -1", "cli", "error: eps must be > 0"),
    ("param-eps-zero-api", "scene_from_field(eps=0)", "api", "error: eps must be > 0"),
    ("param-threads-zero", "--threads 0", "cli", "error: --threads must be between 1"),
    ("param-not-a-number", "--beta abc", "cli", "error: invalid float value"),
    ("query-nan", "query point with NaN", "api", "error: Q contains NaN or infinite"),
    ("query-huge", "query point at 1e60", "api", "error: Q has coordinates beyond"),
    # --- cameras ---------------------------------------------------------------------------
    ("camera-dest-is-origin", "camera dest == origin", "cli",
     "error: camera dest must differ from origin"),
    ("camera-up-parallel", "camera up parallel to dest - origin", "cli",
     "error: parallel to the view direction"),
    ("camera-up-zero", "camera up [0, 0, 0]", "cli", "error: camera up must be a non-zero"),
    ("camera-dest-is-origin-api", "scene_from_field camera with dest == origin", "api",
     "error: camera dest must differ from origin"),
    ("camera-inside-surface", "camera on a face of the mesh (d_hat <= eps there)", "api",
     "error: is inside the surface"),
    ("camera-inside-bounds", "camera at the centre of a spherical point cloud (inside its "
     "bounds, outside the surface)", "api", "ok"),
    # --- scene JSON ------------------------------------------------------------------------
    ("json-malformed", "trailing comma in an object", "cli", "error: malformed JSON at line"),
    ("json-deeply-nested", "100000 nested lists", "cli", "error: nested too deeply"),
    ("json-top-level-list", "top level is a list", "cli",
     "error: the top level must be a JSON object"),
    ("json-missing-camera", "no 'camera' key", "cli",
     "error: is missing the required key 'camera'"),
    ("json-missing-origin", "camera without 'origin'", "cli",
     "error: camera is missing the required key 'origin'"),
    ("json-missing-objects", "no 'objects' key", "cli",
     "error: is missing the required key 'objects'"),
    ("json-missing-alpha", "object without 'alpha'", "cli",
     "error: objects[0] is missing the required key 'alpha'"),
    ("json-missing-path", "object without 'path' or 'parts'", "cli",
     "error: is missing the required key 'path'"),
    ("json-unknown-top-key", "top-level key 'colour'", "cli",
     "error: has unknown key(s) 'colour'"),
    ("json-unknown-object-key", "object key 'alhpa' (typo)", "cli",
     "error: objects[0] has unknown key(s) 'alhpa'"),
    ("json-wrong-type-alpha", "alpha \"big\"", "cli",
     "error: objects[0].alpha must be a number or \"auto\""),
    ("json-wrong-type-origin", "camera.origin \"here\"", "cli",
     "error: camera.origin must be a list of 3 numbers"),
    ("json-wrong-type-width", "width 12.5", "cli", "error: width must be an integer"),
    ("json-wrong-type-objects", "objects is an object, not a list", "cli",
     "error: objects must be a non-empty list"),
    ("json-wrong-type-bool", "beta true", "cli", "error: beta must be a number"),
    ("json-huge-integer", "width 1 followed by 400 zeros", "cli", "error: width is too large"),
    ("json-nan-literal", "camera.origin [NaN, 0, 5]", "cli",
     "error: camera.origin[0] must be finite"),
    ("json-path-escapes", "path '../../no/such/folder/m.obj'", "cli", "error: file not found"),
    ("json-empty-objects", "objects []", "cli", "error: objects must be a non-empty list"),
]

CASES = {row[0]: row for row in CATALOGUE}
SETUP = {}


def setup(case_id):
    """Register the builder of a catalogue row: ``fn(folder, monkeypatch)``.

    CLI rows return the arguments after ``render`` (scene first); API rows return a
    zero-argument callable whose result must be finite.
    """
    def deco(fn):
        assert case_id in CASES, case_id
        SETUP[case_id] = fn
        return fn
    return deco


# ----------------------------------------------------------------------------- file helpers
TET_OBJ = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"
CAMERA = {"origin": [0.3, 0.3, 4.0], "dest": [0.3, 0.3, 0.3], "up": [0, 1, 0]}


def write(folder, name, content):
    p = Path(folder) / name
    p.parent.mkdir(parents=True, exist_ok=True)
    if isinstance(content, bytes):
        p.write_bytes(content)
    else:
        p.write_text(content)
    return p


def scene(folder, *, mesh_name="tet.obj", mesh=TET_OBJ, obj=None, camera=None, raw=None,
          **top):
    """Write a mesh and a scene referring to it; return the scene's path as a string."""
    if mesh is not None:
        write(folder, mesh_name, mesh)
    if raw is not None:
        return str(write(folder, "scene.json", raw))
    o = {"path": mesh_name, "alpha": 20}
    o.update(obj or {})
    data = {"camera": camera or CAMERA, "objects": [o], "width": 16, "height": 16}
    data.update(top)
    return str(write(folder, "scene.json", json.dumps(data)))


def garbage(n=4096, seed=1):
    return np.random.default_rng(seed).integers(0, 256, n, dtype=np.uint8).tobytes()


# ----------------------------------------------------------------------------- CLI setups
@setup("file-missing-scene")
def _(d, mp):
    return [str(d / "nope.json")]


@setup("file-missing-mesh")
def _(d, mp):
    return [scene(d, mesh=None, obj={"path": "missing.obj"})]


@setup("file-unreadable-scene")
def _(d, mp):
    if IS_ROOT:
        pytest.skip("running as root: chmod 000 does not block reads (see the api row)")
    p = scene(d)
    os.chmod(p, 0)
    return [p]


@setup("file-empty-scene")
def _(d, mp):
    return [scene(d, raw="")]


@setup("file-blank-scene")
def _(d, mp):
    return [scene(d, raw="  \n\t\n")]


@setup("file-empty-mesh")
def _(d, mp):
    return [scene(d, mesh="")]


@setup("file-truncated-scene")
def _(d, mp):
    return [scene(d, raw='{"camera": {"origin": [0, 0,')]


@setup("file-truncated-obj")
def _(d, mp):
    return [scene(d, mesh="v 0 0 0\nv 1 0 0\nv 0 1")]


@setup("file-truncated-ply")
def _(d, mp):
    ply = (REPO / "scenes" / "data" / "pointclouds" / "lidar_autzen_trim.ply").read_bytes()
    return [scene(d, mesh_name="cut.ply", mesh=ply[:3000], obj={"kind": "points"})]


@setup("file-wrong-ext-mesh")
def _(d, mp):
    return [scene(d, mesh_name="tet.abc")]


@setup("file-wrong-ext-output")
def _(d, mp):
    return [scene(d), "-o", str(d / "out" / "render.jpg")]


@setup("file-wrong-ext-aov")
def _(d, mp):
    return [scene(d), "--depth", str(d / "out" / "depth.png")]


@setup("file-garbage-scene")
def _(d, mp):
    return [scene(d, raw=garbage())]


@setup("file-garbage-obj")
def _(d, mp):
    return [scene(d, mesh=garbage())]


@setup("file-garbage-ply")
def _(d, mp):
    return [scene(d, mesh_name="junk.ply", mesh=garbage())]


@setup("file-mesh-is-folder")
def _(d, mp):
    (d / "folder.obj").mkdir()
    return [scene(d, mesh=None, obj={"path": "folder.obj"})]


@setup("file-render-folder")
def _(d, mp):
    (d / "meshes.obj").mkdir()
    return [str(d / "meshes.obj")]


@setup("file-nan-coords")
def _(d, mp):
    return [scene(d, mesh=TET_OBJ.replace("v 1 0 0", "v nan 0 0"))]


@setup("file-inf-coords")
def _(d, mp):
    return [scene(d, mesh=TET_OBJ.replace("v 1 0 0", "v 1e999 0 0"))]


@setup("file-huge-coords")
def _(d, mp):
    return [scene(d, mesh="v 1e300 0 0\nv -1e300 0 0\nv 0 1e300 0\nf 1 2 3\n")]


@setup("file-output-exists")
def _(d, mp):
    write(d, "out/render.png", b"keep me")
    return [scene(d)]


@setup("file-aov-exists")
def _(d, mp):
    write(d, "out/depth.npy", b"keep me")
    return [scene(d), "--depth", str(d / "out" / "depth.npy")]


@setup("file-duplicate-vertex-cli")
def _(d, mp):
    mesh = TET_OBJ.replace("f 2 3 4", "v 1 0 0\nf 5 3 4")  # vertex 5 repeats vertex 2
    return [scene(d, mesh=mesh), "--size", "8", "8"]


@setup("mesh-no-vertices-file")
def _(d, mp):
    return [scene(d, mesh="# faces only\nf 1 2 3\n")]


@setup("mesh-index-out-of-range-file")
def _(d, mp):
    return [scene(d, mesh=TET_OBJ + "f 1 2 9\n")]


@setup("mesh-index-zero-file")
def _(d, mp):
    return [scene(d, mesh=TET_OBJ + "f 0 1 2\n")]


@setup("mesh-index-negative-file")
def _(d, mp):
    return [scene(d, mesh=TET_OBJ + "f 1 2 -9\n")]


@setup("mesh-only-degenerate-file")
def _(d, mp):
    return [scene(d, mesh="v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n")]


@setup("param-alpha-zero")
def _(d, mp):
    return [scene(d, obj={"alpha": 0})]


@setup("param-alpha-negative")
def _(d, mp):
    return [scene(d), "--alpha", "-1"]


@setup("param-alpha-nan")
def _(d, mp):
    return [scene(d), "--alpha", "nan"]


@setup("param-alpha-u-zero")
def _(d, mp):
    return [scene(d, obj={"alpha_u": 0})]


@setup("param-beta-negative")
def _(d, mp):
    return [scene(d), "--beta", "-0.5"]


@setup("param-size-zero")
def _(d, mp):
    return [scene(d), "--size", "0", "16"]


@setup("param-size-enormous")
def _(d, mp):
    return [scene(d), "--size", "100000", "100000"]


@setup("param-eps-zero")
def _(d, mp):
    return [scene(d), "--eps", "0"]


@setup("param-eps-negative")
def _(d, mp):
    return [scene(d, eps=-1)]


@setup("param-threads-zero")
def _(d, mp):
    return [scene(d), "--threads", "0"]


@setup("param-not-a-number")
def _(d, mp):
    return [scene(d), "--beta", "abc"]


@setup("camera-dest-is-origin")
def _(d, mp):
    return [scene(d, camera={"origin": [1, 2, 3], "dest": [1, 2, 3], "up": [0, 1, 0]})]


@setup("camera-up-parallel")
def _(d, mp):
    return [scene(d, camera={"origin": [0, 0, 5], "dest": [0, 0, 0], "up": [0, 0, 2]})]


@setup("camera-up-zero")
def _(d, mp):
    return [scene(d, camera={"origin": [0, 0, 5], "dest": [0, 0, 0], "up": [0, 0, 0]})]


@setup("json-malformed")
def _(d, mp):
    return [scene(d, raw='{"camera": {"origin": [0, 0, 5], "dest": [0, 0, 0], "up": [0, 1, 0],},'
                         ' "objects": []}')]


@setup("json-deeply-nested")
def _(d, mp):
    return [scene(d, raw="[" * 100_000 + "]" * 100_000)]


@setup("json-top-level-list")
def _(d, mp):
    return [scene(d, raw="[]")]


@setup("json-missing-camera")
def _(d, mp):
    return [scene(d, raw=json.dumps({"objects": [{"path": "tet.obj", "alpha": 20}]}))]


@setup("json-missing-origin")
def _(d, mp):
    return [scene(d, camera={"dest": [0, 0, 0], "up": [0, 1, 0]})]


@setup("json-missing-objects")
def _(d, mp):
    return [scene(d, raw=json.dumps({"camera": CAMERA}))]


@setup("json-missing-alpha")
def _(d, mp):
    return [scene(d, raw=json.dumps({"camera": CAMERA, "objects": [{"path": "tet.obj"}]}))]


@setup("json-missing-path")
def _(d, mp):
    return [scene(d, raw=json.dumps({"camera": CAMERA, "objects": [{"alpha": 3}]}))]


@setup("json-unknown-top-key")
def _(d, mp):
    return [scene(d, colour="red")]


@setup("json-unknown-object-key")
def _(d, mp):
    return [scene(d, obj={"alhpa": 3})]


@setup("json-wrong-type-alpha")
def _(d, mp):
    return [scene(d, obj={"alpha": "big"})]


@setup("json-wrong-type-origin")
def _(d, mp):
    return [scene(d, camera={"origin": "here", "dest": [0, 0, 0], "up": [0, 1, 0]})]


@setup("json-wrong-type-width")
def _(d, mp):
    return [scene(d, width=12.5)]


@setup("json-wrong-type-objects")
def _(d, mp):
    return [scene(d, raw=json.dumps({"camera": CAMERA,
                                     "objects": {"path": "tet.obj", "alpha": 20}}))]


@setup("json-wrong-type-bool")
def _(d, mp):
    return [scene(d, beta=True)]


@setup("json-huge-integer")
def _(d, mp):
    text = json.dumps({"camera": CAMERA, "objects": [{"path": "tet.obj", "alpha": 20}],
                       "width": 7})
    return [scene(d, raw=text.replace('"width": 7', '"width": 1' + "0" * 400))]


@setup("json-nan-literal")
def _(d, mp):
    return [scene(d, camera={"origin": [float("nan"), 0, 5], "dest": [0, 0, 0],
                             "up": [0, 1, 0]})]


@setup("json-path-escapes")
def _(d, mp):
    return [scene(d, mesh=None, obj={"path": "../../no/such/folder/m.obj"})]


@setup("json-empty-objects")
def _(d, mp):
    return [scene(d, raw=json.dumps({"camera": CAMERA, "objects": []}))]


# ----------------------------------------------------------------------------- API setups
def fibonacci_sphere(n, radius=1.0):
    i = np.arange(n) + 0.5
    phi = np.arccos(1.0 - 2.0 * i / n)
    theta = np.pi * (1.0 + 5.0 ** 0.5) * i
    return radius * np.stack([np.cos(theta) * np.sin(phi), np.sin(theta) * np.sin(phi),
                              np.cos(phi)], 1)


def tet():
    V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    F = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    return V, F


def probe_points(field, seed=0):
    """A few queries: on the data, near it, inside its box, and far away."""
    lo, hi = field.bounds
    c = 0.5 * (lo + hi)
    L = max(field.diagonal, 1.0 if field.diagonal == 0 else field.diagonal)
    r = np.random.default_rng(seed)
    dirs = r.normal(size=(6, 3))
    dirs /= np.linalg.norm(dirs, axis=1)[:, None]
    far = c + dirs * (L * np.array([0.01, 0.3, 2.0, 1e2, 1e4, 1e6]))[:, None]
    return np.concatenate([field.mesh.V[:3], c[None], far])


def distances(field, alpha, **kw):
    """Smooth (value, gradient) and exact (value, gradient) at :func:`probe_points`."""
    Q = probe_points(field)
    return (*field.smooth_distance(Q, alpha=alpha, **kw), *field.exact_distance(Q))


def small_render(field, alpha, **kw):
    kw.setdefault("width", 16)
    kw.setdefault("height", 16)
    return render(scene_from_field(field, alpha=alpha, **kw))


def deny_open(*args, **kwargs):
    raise PermissionError(13, "Permission denied", str(args[0]) if args else "")


@setup("file-unreadable-scene-api")
def _(d, mp):
    p = scene(d)
    mp.setattr(tracer.validate, "open", deny_open, raising=False)
    return lambda: load_scene(p)


@setup("file-unreadable-mesh-api")
def _(d, mp):
    p = write(d, "tet.obj", TET_OBJ)
    mp.setattr(smoothdist.mesh, "open", deny_open, raising=False)
    return lambda: smoothdist.load_mesh(p)


@setup("file-large-coords")
def _(d, mp):
    V, F = tet()
    field = SmoothDistanceField(V + 1e12, F)
    return lambda: (distances(field, alpha=20.0), small_render(field, alpha=20.0))


@setup("mesh-no-vertices")
def _(d, mp):
    return lambda: DataMesh(np.zeros((0, 3)))


@setup("mesh-no-faces")
def _(d, mp):
    return lambda: DataMesh(tet()[0], np.zeros((0, 3), dtype=int))


@setup("mesh-index-out-of-range")
def _(d, mp):
    return lambda: DataMesh(tet()[0], [[0, 1, 7]])


@setup("mesh-index-negative")
def _(d, mp):
    return lambda: DataMesh(tet()[0], [[0, 1, -1]])


@setup("mesh-index-float")
def _(d, mp):
    return lambda: DataMesh(tet()[0], [[0, 1, 0.5]])


@setup("mesh-nan-vertex")
def _(d, mp):
    V = tet()[0]
    V[2, 1] = np.nan
    return lambda: DataMesh(V, tet()[1])


@setup("mesh-huge-vertex")
def _(d, mp):
    V = tet()[0]
    V[2, 1] = 1e60
    return lambda: SmoothDistanceField(V, tet()[1])


@setup("mesh-duplicate-vertices")
def _(d, mp):
    V, F = tet()
    V = np.concatenate([V, V[1:2]])
    F = F.copy()
    F[3, 0] = 4
    return lambda: distances(SmoothDistanceField(V, F), alpha=20.0)


@setup("mesh-zero-length-edge")
def _(d, mp):
    V = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0]])
    return lambda: distances(SmoothDistanceField(V, [[0, 1], [1, 2], [2, 2]]), alpha=20.0)


@setup("mesh-zero-area-triangle")
def _(d, mp):
    V, F = tet()
    V = np.concatenate([V, [[2.0, 0, 0]]])
    F = np.concatenate([F, [[0, 1, 4]]])  # (0,0,0), (1,0,0), (2,0,0): collinear
    return lambda: distances(SmoothDistanceField(V, F), alpha=20.0)


@setup("mesh-only-degenerate")
def _(d, mp):
    return lambda: DataMesh(tet()[0], [[0, 0], [3, 3]])


@setup("mesh-nonmanifold-edges")
def _(d, mp):
    V = [[0.0, 0, 0], [0, 0, 1]]
    F = []
    for k in range(4):
        a = 2 * np.pi * k / 4 + 0.3
        V.append([np.cos(a), np.sin(a), 0.5])
        F.append((0, 1, len(V) - 1))
    field = SmoothDistanceField(np.array(V), np.array(F))
    return lambda: (distances(field, alpha=10.0), small_render(field, alpha=10.0))


@setup("mesh-isolated-triangles")
def _(d, mp):
    V, F = [], []
    for off in ([0.0, 0, 0], [3.0, 2.0, 0.5], [0, 3.0, 1.0]):
        o = np.array(off)
        V += [o, o + [1, 0, 0], o + [0.2, 0.9, 0.3]]
        F.append((len(V) - 3, len(V) - 2, len(V) - 1))
    field = SmoothDistanceField(np.array(V), np.array(F))
    return lambda: (distances(field, alpha=5.0), small_render(field, alpha=5.0))


@setup("mesh-single-point")
def _(d, mp):
    field = SmoothDistanceField(np.array([[0.5, -1.0, 2.0]]))
    return lambda: (distances(field, alpha=3.0), small_render(field, alpha=3.0),
                    small_render(field, alpha=3.0, mode="exact"))


@setup("mesh-identical-points")
def _(d, mp):
    return lambda: (lambda f: (distances(f, alpha=2.0), small_render(f, alpha=2.0,
                                                                      mode="exact")))(
        SmoothDistanceField(np.tile([[1.0, 2.0, 3.0]], (50, 1))))


@setup("param-alpha-zero-api")
def _(d, mp):
    field = SmoothDistanceField(*tet())
    return lambda: field.smooth_distance([[0, 0, 2.0]], alpha=0)


@setup("param-alpha-tiny")
def _(d, mp):
    field = SmoothDistanceField(*tet())
    return lambda: field.smooth_distance([[0, 0, 2.0]], alpha=1e-15 / field.diagonal)


@setup("param-alpha-huge")
def _(d, mp):
    field = SmoothDistanceField(*tet())
    alpha = 1e7 / field.diagonal
    return lambda: (distances(field, alpha=alpha), small_render(field, alpha=alpha))


@setup("param-alpha-u-negative-api")
def _(d, mp):
    field = SmoothDistanceField(*tet())
    return lambda: field.smooth_distance([[0, 0, 2.0]], alpha=3.0, alpha_u=-1)


@setup("param-beta-negative-api")
def _(d, mp):
    field = SmoothDistanceField(*tet())
    return lambda: field.smooth_distance([[0, 0, 2.0]], alpha=3.0, beta=-1)


@setup("param-beta-inf-api")
def _(d, mp):
    field = SmoothDistanceField(*tet())
    return lambda: field.smooth_distance([[0, 0, 2.0]], alpha=3.0, beta=np.inf)


@setup("param-beta-huge")
def _(d, mp):
    field = SmoothDistanceField(fibonacci_sphere(300))
    return lambda: (distances(field, alpha=30.0, beta=1e6),
                    small_render(field, alpha=30.0, beta=1e6))


@setup("param-size-zero-api")
def _(d, mp):
    field = SmoothDistanceField(*tet())
    return lambda: scene_from_field(field, alpha=20.0, width=0)


@setup("param-eps-zero-api")
def _(d, mp):
    field = SmoothDistanceField(*tet())
    return lambda: scene_from_field(field, alpha=20.0, eps=0.0)


@setup("query-nan")
def _(d, mp):
    field = SmoothDistanceField(*tet())
    return lambda: field.smooth_distance([[0, np.nan, 2.0]], alpha=3.0)


@setup("query-huge")
def _(d, mp):
    field = SmoothDistanceField(*tet())
    return lambda: field.smooth_distance([[0, 1e60, 2.0]], alpha=3.0)


@setup("camera-dest-is-origin-api")
def _(d, mp):
    field = SmoothDistanceField(*tet())
    return lambda: scene_from_field(field, alpha=20.0, camera=([1, 1, 1], [1, 1, 1], [0, 1, 0]))


@setup("camera-inside-surface")
def _(d, mp):
    field = SmoothDistanceField(*tet())
    return lambda: small_render(field, alpha=20.0,
                                camera=([0.2, 0.2, 0.0], [0.2, 0.2, 1.0], [0, 1, 0]))


@setup("camera-inside-bounds")
def _(d, mp):
    field = SmoothDistanceField(fibonacci_sphere(400))
    return lambda: small_render(field, alpha=60.0,
                                camera=([0.0, 0.0, 0.1], [1.0, 0.2, 0.0], [0, 0, 1]))


# ----------------------------------------------------------------------------- checkers
def assert_finite(result):
    """Every float in ``result`` (nested tuples of arrays, a RenderResult, ...) is finite."""
    if isinstance(result, RenderResult):
        assert result.rgb.dtype == np.uint8
        assert np.isfinite(result.normals).all()
        norm = np.linalg.norm(result.normals[result.hit], axis=1)
        assert np.all((np.abs(norm - 1.0) < 1e-6) | (norm == 0.0)), norm
        assert np.isfinite(result.depth[result.hit]).all()
        assert np.isnan(result.depth[~result.hit]).all()
        return
    if isinstance(result, (tuple, list)):
        for r in result:
            assert_finite(r)
        return
    if isinstance(result, np.ndarray) and result.dtype.kind in "fc":
        assert np.isfinite(result).all(), result


def expectation(case_id):
    kind, _, text = CASES[case_id][3].partition(": ")
    return kind, text


def test_catalogue_is_complete():
    assert len(CATALOGUE) >= 25
    assert len(CASES) == len(CATALOGUE), "duplicate ids"
    assert set(SETUP) == set(CASES)
    for case_id, what, layer, expected in CATALOGUE:
        assert layer in ("api", "cli") and what
        kind, text = expectation(case_id)
        assert kind in ("error", "warning", "ok") and (kind == "ok") == (not text), case_id


# ----------------------------------------------------------------------------- API rows
API_IDS = [r[0] for r in CATALOGUE if r[2] == "api"]
CLI_IDS = [r[0] for r in CATALOGUE if r[2] == "cli"]


@pytest.mark.parametrize("case_id", API_IDS)
def test_api_catalogue(case_id, tmp_path, monkeypatch):
    kind, text = expectation(case_id)
    run = SETUP[case_id](tmp_path, monkeypatch)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        if kind == "error":
            with pytest.raises(ValueError) as info:
                run()
            msg = str(info.value)
            assert text in msg, msg
            assert "\n" not in msg.strip(), "messages are one line"
        else:
            assert_finite(run())
    other = [w for w in caught if not issubclass(w.category, MeshRepairWarning)]
    assert not other, [str(w.message) for w in other]
    repairs = [str(w.message) for w in caught if issubclass(w.category, MeshRepairWarning)]
    if kind == "warning":
        assert any(text in m for m in repairs), repairs
    elif kind == "ok":
        assert not repairs, repairs


# ----------------------------------------------------------------------------- CLI rows
def cli_env():
    env = dict(os.environ)
    env["PYTHONPATH"] = str(REPO) + os.pathsep + env.get("PYTHONPATH", "")
    env.pop("TRACER_DEBUG", None)
    return env


def cli_argv(case_id, folder, args):
    """``python -m tracer render SCENE -o folder/out/render.png -q ARGS...``."""
    return ["render", args[0], "-o", str(folder / "out" / "render.png"), "-q", *args[1:]]


class _Skip:
    def __init__(self, reason):
        self.reason = reason


@pytest.fixture(scope="module")
def cli_runs(tmp_path_factory):
    """Start every CLI row at once (a few at a time) and hand out the results by id."""
    base = tmp_path_factory.mktemp("cli_catalogue")
    jobs = {}
    for case_id in CLI_IDS:
        d = base / case_id
        d.mkdir()
        try:
            args = SETUP[case_id](d, None)
        except pytest.skip.Exception as exc:
            jobs[case_id] = (d, _Skip(str(exc)))
            continue
        jobs[case_id] = (d, cli_argv(case_id, d, args))

    def run(item):
        d, argv = item
        if isinstance(argv, _Skip):
            return argv
        t0 = time.perf_counter()
        p = subprocess.run([sys.executable, "-m", "tracer", *argv], cwd=d, env=cli_env(),
                           capture_output=True, text=True, timeout=240)
        return p, time.perf_counter() - t0

    pool = ThreadPoolExecutor(max_workers=max(2, min(4, os.cpu_count() or 2)))
    futures = {k: pool.submit(run, v) for k, v in jobs.items()}
    yield {k: (jobs[k][0], jobs[k][1], f) for k, f in futures.items()}
    pool.shutdown(wait=True)


@pytest.mark.parametrize("case_id", CLI_IDS)
def test_cli_catalogue(case_id, cli_runs):
    kind, text = expectation(case_id)
    folder, argv, future = cli_runs[case_id]
    res = future.result()
    if isinstance(res, _Skip):
        pytest.skip(res.reason)
    p, seconds = res
    out = folder / "out"
    assert "Traceback" not in p.stderr + p.stdout, p.stderr
    lines = p.stderr.strip().splitlines()
    temps = [q.name for q in folder.rglob("*") if ".tmp-" in q.name]
    assert not temps, temps
    if kind == "error":
        assert p.returncode == 2, (p.returncode, p.stderr)
        assert len(lines) == 1, p.stderr
        assert lines[0].startswith("error: "), lines
        assert text in lines[0], lines[0]
        if case_id in ("file-output-exists", "file-aov-exists"):
            kept = {q.name: q.read_bytes() for q in out.iterdir()}
            assert list(kept.values()) == [b"keep me"], kept
        else:
            assert not out.exists() or not any(out.iterdir()), list(out.iterdir())
    else:
        assert p.returncode == 0, p.stderr
        assert (out / "render.png").is_file()
        assert all(line.startswith("warning: ") for line in lines), lines
        if kind == "warning":
            assert any(text in line for line in lines), lines
        else:
            assert not lines, lines


def test_cli_errors_compile_no_kernels(cli_runs, tmp_path):
    """The pre-render errors of the catalogue neither load nor compile any numba kernel.

    All error rows run in one fresh interpreter through ``tracer.cli.main``; afterwards no
    numba dispatcher of ``smoothdist`` or ``tracer`` holds a compiled (or cache-loaded)
    overload.
    """
    argvs = []
    for case_id in CLI_IDS:
        folder, argv, _ = cli_runs[case_id]
        if isinstance(argv, _Skip) or expectation(case_id)[0] != "error":
            continue
        argvs.append([case_id, argv, str(folder)])
    spec = tmp_path / "argvs.json"
    spec.write_text(json.dumps(argvs))
    script = r"""
import contextlib, io, json, os, sys
from numba.core.dispatcher import Dispatcher
import tracer.cli
bad = []
for case_id, argv, folder in json.load(open(sys.argv[1])):
    os.chdir(folder)
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        rc = tracer.cli.main(argv)
    if rc != 2:
        bad.append([case_id, rc, err.getvalue()])
compiled = sorted(f"{name}.{attr}" for name, mod in list(sys.modules.items())
                  if name.split(".")[0] in ("smoothdist", "tracer")
                  for attr, obj in vars(mod).items()
                  if isinstance(obj, Dispatcher) and obj.overloads)
print(json.dumps({"bad": bad, "compiled": compiled,
                  "loaded": sorted(m for m in sys.modules if m.startswith("tracer.rendering.march"))}))
"""
    p = subprocess.run([sys.executable, "-c", script, str(spec)], env=cli_env(), cwd=tmp_path,
                       capture_output=True, text=True, timeout=240)
    assert p.returncode == 0, p.stderr
    report = json.loads(p.stdout.strip().splitlines()[-1])
    assert report["bad"] == []
    assert report["compiled"] == [], report["compiled"]


# ----------------------------------------------------------------------------- numerical safety
def _meshes():
    """Points, edges, triangles and a mixed mesh, each about unit size."""
    pts = fibonacci_sphere(200)
    a = 2 * np.pi * np.arange(40) / 40
    circle = np.stack([np.cos(a), np.sin(a), 0.1 * np.sin(3 * a)], 1)
    E = np.stack([np.arange(40), (np.arange(40) + 1) % 40], 1)
    import trimesh

    ico = trimesh.creation.icosphere(subdivisions=1)
    V = np.concatenate([np.asarray(ico.vertices), circle * 1.5, pts[:20] * 0.3])
    n = len(ico.vertices)
    mixed = DataMesh(V, triangles=np.asarray(ico.faces), edges=E + n,
                     points=np.arange(n + 40, n + 60), name="mixed")
    return {"points": DataMesh(pts), "edges": DataMesh(circle, E),
            "triangles": DataMesh(np.asarray(ico.vertices), np.asarray(ico.faces)),
            "mixed": mixed}


@pytest.fixture(scope="module")
def fields():
    return {k: SmoothDistanceField(m) for k, m in _meshes().items()}


@pytest.mark.parametrize("kind", ["points", "edges", "triangles", "mixed"])
@pytest.mark.parametrize("alpha_diag", [1e-3, 1.0, 1e2, 1e4])
@pytest.mark.parametrize("gradient", ["metric", "exact"])
def test_far_queries_are_finite_and_bounded(fields, kind, alpha_diag, gradient):
    """d_hat and its gradient are finite up to 1e6 diagonals away, for alpha x diag up to 1e4,
    and within the conservative bounds d - log(A^S N)/alpha <= d_hat <= d."""
    field = fields[kind]
    L = field.diagonal
    alpha = alpha_diag / L
    r = np.random.default_rng(3)
    dirs = r.normal(size=(60, 3))
    dirs /= np.linalg.norm(dirs, axis=1)[:, None]
    scale = L * 10.0 ** np.linspace(-3, 6, 60)
    lo, hi = field.bounds
    Q = 0.5 * (lo + hi) + dirs * scale[:, None]
    d, _ = field.exact_distance(Q)
    for beta in (0.0, 0.5, 2.0):
        for alpha_u in (None, 2 * alpha):
            dh, g = field.smooth_distance(Q, alpha=alpha, beta=beta, alpha_u=alpha_u,
                                          gradient=gradient)
            assert np.isfinite(dh).all() and np.isfinite(g).all()
            tol = 1e-9 * (d + L)
            assert np.all(dh <= d + tol)
            if beta == 0.0:
                assert np.all(dh >= d - field.inflation(alpha, alpha_u) - tol)
    # far from the data the gradient points away from it, with length about 1
    far = scale > 10 * L
    dh, g = field.smooth_distance(Q[far], alpha=alpha, beta=0.0, gradient=gradient)
    assert np.all(np.einsum("ij,ij->i", g, dirs[far]) > 0.9)


@pytest.mark.parametrize("kind", ["points", "edges", "triangles", "mixed"])
@pytest.mark.parametrize("mode", ["smooth", "exact"])
def test_render_has_no_nan(fields, kind, mode):
    field = fields[kind]
    res = small_render(field, alpha=10.0, mode=mode, width=24, height=20)
    assert res.hit.sum() > 20
    assert_finite(res)
    assert np.isfinite(res.normals).all() and not np.isnan(res.rgb.astype(float)).any()


@pytest.mark.parametrize("prim", ["point", "edge", "triangle"])
def test_one_primitive_renders(prim):
    V = np.array([[0.0, 0, 0], [1, 0.2, 0], [0.3, 1, 0.1]])
    F = {"point": None, "edge": [[0, 1]], "triangle": [[0, 1, 2]]}[prim]
    field = SmoothDistanceField(V[:1] if F is None else V, F)
    assert field.num_primitives == 1
    for mode in ("smooth", "exact"):
        res = small_render(field, alpha=4.0, mode=mode)
        assert_finite(res)
    assert res.hit.any()  # the exact-mode offset surface (radius 1/alpha) is in view


@pytest.mark.slow
def test_million_points_build_and_render():
    """1e6 points: the field builds and a 16x16 render is finite (about 10 s)."""
    V = np.random.default_rng(0).random((1_000_000, 3))
    t0 = time.perf_counter()
    field = SmoothDistanceField(V)
    res = small_render(field, alpha=200.0)
    assert_finite(res)
    assert res.hit.any()
    dh, g = field.smooth_distance([[0.5, 0.5, 1e6]], alpha=200.0)
    assert np.isfinite(dh).all() and np.isfinite(g).all()
    assert time.perf_counter() - t0 < 120


# ----------------------------------------------------------------------------- no data lost
class Boom(Exception):
    pass


def test_atomic_write_leaves_nothing_on_failure(tmp_path):
    target = tmp_path / "a.png"
    with pytest.raises(Boom):
        with atomic_write(target) as tmp:
            tmp.write_bytes(b"half")
            raise Boom
    assert list(tmp_path.iterdir()) == []
    target.write_bytes(b"old")
    for exc in (Boom, KeyboardInterrupt):
        with pytest.raises(exc):
            with atomic_write(target) as tmp:
                tmp.write_bytes(b"new, partial")
                raise exc
    assert target.read_bytes() == b"old"
    assert [p.name for p in tmp_path.iterdir()] == ["a.png"]


def test_savers_write_complete_files_or_nothing(tmp_path, monkeypatch):
    import PIL.Image

    rgb = np.zeros((4, 5, 3), np.uint8)
    save_png(tmp_path / "x.png", rgb)
    save_npy(tmp_path / "x.npy", np.ones((2, 2), np.float32))
    with pytest.raises(FileExistsError, match="--overwrite"):
        save_png(tmp_path / "x.png", rgb, overwrite=False)

    def half_save(self, fp, *a, **k):  # a writer that dies half-way
        Path(fp).write_bytes(b"\x89PNG partial")
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(PIL.Image.Image, "save", half_save)
    with pytest.raises(OSError):
        save_png(tmp_path / "y.png", rgb)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.npy", "x.png"]


def _wait_for(proc, needle, timeout):
    """Read ``proc``'s stderr until a line contains ``needle``; return what was read."""
    import selectors

    sel = selectors.DefaultSelector()
    sel.register(proc.stderr, selectors.EVENT_READ)
    seen = ""
    t_end = time.monotonic() + timeout
    while needle not in seen and time.monotonic() < t_end and proc.poll() is None:
        if sel.select(timeout=0.2):
            line = proc.stderr.readline()
            seen += line
    return seen


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
@pytest.mark.slow
def test_interrupted_render_leaves_no_file(tmp_path, sig):
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "tracer", "render", str(LIDAR), "-o", str(out / "big.png"),
           "--size", "2000", "2000", "--depth", str(out / "big.npy")]
    proc = subprocess.Popen(cmd, cwd=tmp_path, env=cli_env(), stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    try:
        # wait until the render itself runs (its first progress line), at least ~3 s
        t0 = time.monotonic()
        seen = _wait_for(proc, "render lidar_autzen", timeout=90)
        assert "render lidar_autzen" in seen, seen  # the progress bar: it is rendering
        time.sleep(max(0.0, 3.0 - (time.monotonic() - t0)))
        assert proc.poll() is None, "the render should still be running"
        proc.send_signal(sig)
        t_sig = time.monotonic()
        stdout, stderr = proc.communicate(timeout=60)
        stopped_after = time.monotonic() - t_sig
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    stderr = seen + stderr
    assert proc.returncode == 130, stderr
    assert "interrupted:" in stderr and "Traceback" not in stderr + stdout, stderr
    assert stopped_after < 30, stopped_after
    assert not out.exists() or not any(out.iterdir()), list(out.iterdir())
    assert not [p for p in tmp_path.rglob("*") if ".tmp-" in p.name]
