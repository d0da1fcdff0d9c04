"""Simulation files: a JSON description of rigid bodies, gravity, time step and camera.

Format (keys not listed are refused; lengths in scene units, times in seconds)::

    {
      "name": "bunnies",                 optional label
      "description": "...",              optional
      "dt": 0.005,                       time step h (> 0)                        required
      "steps": 400,                      number of steps (integer > 0)            required
      "gravity": [0, 0, -9.81],          default [0, 0, -9.81]
      "beta": 0.5,                       Barnes-Hut parameter of every pair, default 0.5
      "constraint": "smooth",            "smooth" (LSE of pair smooth distances) or "exact"
      "gap_tol": 1e-5,                   optional interior-point gap tolerance (scene units)
      "torques": "exact",                rotation gradient: "exact" (default) or "split" (the
                                         paper's equal split, as the authors' simulator;
                                         tracer.sim.constraint)
      "camera": {                        required (used when rendering)
        "origin": [x, y, z], "dest": [x, y, z], "up": [x, y, z],
        "width": 640, "height": 360,     image size (default 640 x 360)
        "fps": 25,                       movie frame rate (default 25)
        "every": 4,                      render every N-th step (default: about 80 frames)
        "shading": "lit",                "lit" | "normals" | "headlight" | "matcap"
        "matcap": "path.png",            with shading "matcap"
        "background": [255, 255, 255]
      },
      "bodies": [                        at least two
        {
          "name": "bunny",               default "body<i>"
          "mesh": "../data/bunny.off",   a mesh file (relative to this file), or
          "primitive": {"type": "icosphere", "radius": 0.5},   (tracer.sim.primitives;
                                         numbers, lists of numbers, and "path": a file
                                         relative to this file, e.g. lidar_terrain's tile)
          "kind": "triangles",           "points" | "edges" | "triangles" | "mixed" (default:
                                         what the file holds)
          "scale": 1.0,                  uniform scale of the file's coordinates
          "crop": [[x0, y0, z0], [x1, y1, z1]],  keep only primitives inside this box (file
                                         coordinates, before scale; e.g. a window of a scan)
          "alpha": 200,                  smooth-distance sharpness (> 0), or "auto"
                                         (tracer.sim.bodies.auto_alpha)        required
          "alpha_u": 400,                attenuation threshold alpha_U, "auto" (20 x alpha)
                                         or "off" (= alpha, the default)
          "density": 1.0,                per volume (closed triangles), area (open), length
                                         (edges) or per point (tracer.sim.bodies)
          "position": [x, y, z],         the file's vertex p is placed at R p + position
          "rotation": [[..], [..], [..]] a 3x3 rotation matrix (rows), or [rx, ry, rz] a
                                         rotation vector in radians (default identity)
          "velocity": [vx, vy, vz],      of the centre of mass (default 0)
          "angular_velocity": [..],      world axes, rad/s (default 0)
          "static": false                static bodies never move
        }
      ]
    }

The authors' simulator (``sims/*.json``) names these ``timestep``, ``num_steps``, ``objects``,
``is_dynamic``, ``max_alpha``, ``bvh_type`` and ``init_state``; we use one flat object per body.
:func:`load_simulation` reads their files too, unchanged (a top-level ``objects`` list instead
of ``bodies``): :mod:`tracer.sim.authors_format`. They have no camera; theirs get
:func:`~tracer.sim.simulation.auto_camera` (``MovieCamera.auto``), which frames the whole
trajectory when frames are rendered.

:func:`load_simulation` validates every key and value (and that every referenced file exists)
before it reads any mesh, and raises :class:`~tracer.errors.SimFileError` (a ``ValueError``) with a
one-line message ``<file>: <key> <problem>``. Bodies that already overlap are refused later, by
:func:`tracer.sim.run.check_initial_state`.
"""

import os

import numpy as np

from smoothdist import DataMesh
from smoothdist.field import AUTO_ALPHA_U_FACTOR
from tracer.errors import SceneError, SimFileError
from tracer.rendering.camera import look_at
from tracer.scenes.scene import SHADINGS
from tracer.sim import primitives
from tracer.sim.authors_format import build_simulation
from tracer.sim.bodies import AUTO_THICKNESS_OFFSET, Body, auto_alpha, rotation_matrix, thickness
from tracer.sim.constraint import DEFAULT_TORQUES, TORQUES
from tracer.sim.simulation import DEFAULT_FRAMES, MovieCamera, Simulation
from tracer.sim.simulation import wrap_scene_error as _wrap
from tracer.validate import check_keys, choice, number, read_json, resolve_path, show, vec3

__all__ = ["load_simulation", "read_simulation_json"]

_TOP = {"name", "description", "dt", "steps", "gravity", "beta", "constraint", "gap_tol",
        "torques", "camera", "bodies"}
_CAMERA = {"origin", "dest", "up", "width", "height", "fps", "every", "shading", "matcap",
           "background"}
_BODY = {"name", "mesh", "primitive", "kind", "scale", "crop", "alpha", "alpha_u", "density",
         "position", "rotation", "velocity", "angular_velocity", "static"}
KINDS = ("points", "edges", "triangles", "mixed")
def _err(path, where, msg):
    return SimFileError(f"{os.path.basename(path)}: {where} {msg}")


def read_simulation_json(path):
    """Parse the file into a dict (one-line :class:`~tracer.errors.SimFileError` on
    unreadable/malformed JSON)."""
    try:
        return read_json(path, "simulation")
    except SceneError as exc:
        raise _wrap(exc) from None


def _rotation(value, path, where):
    if isinstance(value, list) and len(value) == 3 and all(isinstance(r, list) for r in value):
        rows = [vec3(r, path, f"{where}[{i}]") for i, r in enumerate(value)]
        R = np.array(rows)
        if not np.allclose(R @ R.T, np.eye(3), atol=1e-6) or np.linalg.det(R) <= 0:
            raise _err(path, where, "must be a rotation matrix (orthonormal rows, det +1)")
        return R
    if isinstance(value, list) and len(value) == 3:
        return rotation_matrix(vec3(value, path, where))
    raise _err(path, where, f"must be a 3x3 rotation matrix or a rotation vector [rx, ry, rz], "
                            f"got {show(value)}")


def _camera(cd, path):
    check_keys(cd, _CAMERA, path, "camera")
    for k in ("origin", "dest", "up"):
        if k not in cd:
            raise _err(path, "camera", f"is missing the required key {k!r}")
    cam = MovieCamera(origin=vec3(cd["origin"], path, "camera.origin"),
                 dest=vec3(cd["dest"], path, "camera.dest"),
                 up=vec3(cd["up"], path, "camera.up"))
    for k in ("width", "height", "every"):
        if k in cd:
            setattr(cam, k, number(cd[k], path, f"camera.{k}", positive=True, integer=True))
    if cam.width * cam.height > 4_000_000:
        raise _err(path, "camera.width", f"x height is {cam.width}x{cam.height}: too large for "
                                         "an animation (limit 4 megapixels)")
    if "fps" in cd:
        cam.fps = number(cd["fps"], path, "camera.fps", positive=True)
    if "shading" in cd:
        cam.shading = choice(cd["shading"], SHADINGS, path, "camera.shading")
    if "matcap" in cd:
        cam.matcap = resolve_path(os.path.dirname(os.path.abspath(path)), cd["matcap"], path,
                                  "camera.matcap")
    if cam.shading == "matcap" and not cam.matcap:
        raise _err(path, "camera.shading", "is 'matcap' but camera.matcap is not given")
    if "background" in cd:
        bg = vec3(cd["background"], path, "camera.background")
        if ((bg < 0) | (bg > 255)).any():
            raise _err(path, "camera.background", f"must hold values 0-255, got {cd['background']}")
        cam.background = tuple(int(v) for v in bg)

    try:
        look_at(cam.origin, cam.dest, cam.up, cam.width, cam.height)
    except ValueError as exc:
        raise _err(path, "camera", str(exc)) from None
    return cam


def _body_spec(bd, i, base, path):
    where = f"bodies[{i}]"
    check_keys(bd, _BODY, path, where)
    if "alpha" not in bd:
        raise _err(path, where, "is missing the required key 'alpha'")
    if ("mesh" in bd) == ("primitive" in bd):
        raise _err(path, where, "needs exactly one of 'mesh' (a file) or 'primitive'")
    spec = {"name": bd.get("name", f"body{i}")}
    if not isinstance(spec["name"], str) or not spec["name"]:
        raise _err(path, f"{where}.name", f"must be a non-empty string, got {show(bd['name'])}")
    if "mesh" in bd:
        spec["mesh"] = resolve_path(base, bd["mesh"], path, f"{where}.mesh")
    else:
        prim = bd["primitive"]
        if not isinstance(prim, dict) or not isinstance(prim.get("type"), str):
            raise _err(path, f"{where}.primitive", "must be an object with a 'type' "
                       f"({', '.join(sorted(primitives.GENERATORS))})")
        if prim["type"] not in primitives.GENERATORS:
            raise _err(path, f"{where}.primitive.type", f"must be one of "
                       f"{', '.join(sorted(primitives.GENERATORS))}; got {show(prim['type'])}")
        prim = dict(prim)
        for k, v in list(prim.items()):
            if k == "type":
                continue
            if k == "path":                  # a generator's input file, relative to this file
                prim[k] = resolve_path(base, v, path, f"{where}.primitive.path")
            elif isinstance(v, list):
                [number(x, path, f"{where}.primitive.{k}[{j}]") for j, x in enumerate(v)]
            else:
                number(v, path, f"{where}.primitive.{k}", non_negative=True)
        spec["primitive"] = prim
    spec["kind"] = choice(bd["kind"], KINDS, path, f"{where}.kind") if "kind" in bd else None
    spec["scale"] = number(bd.get("scale", 1.0), path, f"{where}.scale", positive=True)
    spec["crop"] = None
    if "crop" in bd:
        c = bd["crop"]
        if not isinstance(c, list) or len(c) != 2:
            raise _err(path, f"{where}.crop",
                       f"must be [[x0, y0, z0], [x1, y1, z1]], got {show(c)}")
        lo, hi = vec3(c[0], path, f"{where}.crop[0]"), vec3(c[1], path, f"{where}.crop[1]")
        if not (lo < hi).all():
            raise _err(path, f"{where}.crop", "must have its first corner below the second")
        spec["crop"] = (lo, hi)
    for key, words in (("alpha", ("auto",)), ("alpha_u", ("auto", "off"))):
        value = bd.get(key, "off" if key == "alpha_u" else None)
        if isinstance(value, str) and value not in words:
            raise _err(path, f"{where}.{key}", f"must be a number or "
                       f"{' or '.join(chr(34) + w + chr(34) for w in words)}, got {show(value)}")
        spec[key] = value if value in words else number(value, path, f"{where}.{key}",
                                                        positive=True)
    spec["density"] = number(bd.get("density", 1.0), path, f"{where}.density", positive=True)
    spec["position"] = vec3(bd.get("position", [0, 0, 0]), path, f"{where}.position")
    spec["rotation"] = (_rotation(bd["rotation"], path, f"{where}.rotation") if "rotation" in bd
                        else np.eye(3))
    spec["velocity"] = vec3(bd.get("velocity", [0, 0, 0]), path, f"{where}.velocity")
    spec["angular_velocity"] = vec3(bd.get("angular_velocity", [0, 0, 0]), path,
                                    f"{where}.angular_velocity")
    static = bd.get("static", False)
    if not isinstance(static, bool):
        raise _err(path, f"{where}.static", f"must be true or false, got {show(static)}")
    spec["static"] = static
    return spec


def _body_mesh(spec, i, path):
    """The body's mesh in file coordinates (loaded or generated, reduced, cropped, scaled)."""
    where = f"bodies[{i}]"
    try:
        if "mesh" in spec:
            mesh = DataMesh.load(spec["mesh"], kind=spec["kind"])
        else:
            mesh = primitives.make(spec["primitive"])
            if spec["kind"] is not None:
                mesh = mesh.as_kind(spec["kind"])
        if spec["crop"] is not None:
            mesh = _crop(mesh, *spec["crop"])
        if spec["scale"] != 1.0:
            mesh = DataMesh(mesh.V * spec["scale"], points=mesh.points, edges=mesh.edges,
                            triangles=mesh.triangles, name=mesh.name, repair=False)
        return mesh
    except SceneError:
        raise
    except (ValueError, OSError, RuntimeError) as exc:
        raise _err(path, where, f"cannot be built: {str(exc).splitlines()[0]}") from None


def _build_body(spec, i, path, mesh, length):
    """The :class:`Body` of ``spec``; ``"auto"`` alphas aim at an offset of ``length``."""
    where = f"bodies[{i}]"
    try:
        alpha, alpha_u = spec["alpha"], spec["alpha_u"]
        if alpha == "auto":
            alpha = auto_alpha(mesh, length, "auto" if alpha_u == "auto" else "off")
        if alpha_u == "auto":  # SmoothDistanceField.auto_alpha_u, without building a tree
            alpha_u = AUTO_ALPHA_U_FACTOR * alpha
        elif alpha_u == "off":
            alpha_u = alpha
        return Body.from_mesh(mesh, name=spec["name"], alpha=alpha,
                              alpha_u=alpha_u, density=spec["density"],
                              position=spec["position"], rotation=spec["rotation"],
                              velocity=spec["velocity"],
                              angular_velocity=spec["angular_velocity"], static=spec["static"])
    except SceneError:
        raise
    except (ValueError, OSError, RuntimeError) as exc:
        raise _err(path, where, f"cannot be built: {str(exc).splitlines()[0]}") from None


def _crop(mesh, lo, hi):
    """The primitives of ``mesh`` whose vertices all lie in the box ``lo..hi``."""
    inside = np.all((mesh.V >= lo) & (mesh.V <= hi), axis=1)
    P = mesh.points[inside[mesh.points]]
    E = mesh.edges[inside[mesh.edges].all(axis=1)]
    T = mesh.triangles[inside[mesh.triangles].all(axis=1)]
    if P.size + len(E) + len(T) == 0:
        raise ValueError("crop keeps no primitive")
    used = np.unique(np.concatenate([P, E.ravel(), T.ravel()]))
    remap = np.full(mesh.V.shape[0], -1)
    remap[used] = np.arange(used.size)
    return DataMesh(mesh.V[used], points=remap[P], edges=remap[E], triangles=remap[T],
                    name=mesh.name, repair=False)


def load_simulation(path):
    """Read, validate and build a simulation file into a :class:`~tracer.sim.simulation.Simulation`:
    ours (top-level ``bodies``) or the authors' (top-level ``objects``,
    :mod:`tracer.sim.authors_format`)."""
    path = os.fspath(path)
    data = read_simulation_json(path)
    if isinstance(data, dict) and "objects" in data and "bodies" not in data:
        return build_simulation(data, path)
    try:
        if not isinstance(data, dict):
            raise _err(path, "the top level", "must be a JSON object")
        check_keys(data, _TOP, path, "the top level")
        for k in ("dt", "steps", "camera", "bodies"):
            if k not in data:
                raise _err(path, "the top level", f"is missing the required key {k!r}")
        dt = number(data["dt"], path, "dt", positive=True)
        steps = number(data["steps"], path, "steps", positive=True, integer=True)
        if steps > 10_000_000:
            raise _err(path, "steps", f"must be at most 10000000, got {steps}")
        gravity = vec3(data.get("gravity", [0, 0, -9.81]), path, "gravity")
        beta = number(data.get("beta", 0.5), path, "beta", non_negative=True)
        constraint = choice(data.get("constraint", "smooth"), ("smooth", "exact"), path,
                            "constraint")
        gap_tol = (number(data["gap_tol"], path, "gap_tol", positive=True)
                   if "gap_tol" in data else None)
        torques = choice(data.get("torques", DEFAULT_TORQUES), TORQUES, path, "torques")
        name = data.get("name", os.path.splitext(os.path.basename(path))[0])
        if not isinstance(name, str):
            raise _err(path, "name", f"must be a string, got {show(name)}")
        if "description" in data and not isinstance(data["description"], str):
            raise _err(path, "description", "must be a string")
        camera = _camera(data["camera"], path)
        if "every" not in data["camera"]:
            camera.every = max(1, steps // DEFAULT_FRAMES)
        bodies = data["bodies"]
        if not isinstance(bodies, list) or len(bodies) < 2:
            raise _err(path, "bodies", f"must be a list of at least 2 bodies, got {show(bodies)}")
        base = os.path.dirname(os.path.abspath(path))
        specs = [_body_spec(bd, i, base, path) for i, bd in enumerate(bodies)]
        if all(s["static"] for s in specs):
            raise _err(path, "bodies", "are all static: nothing would move")
        names = [s["name"] for s in specs]
        if len(set(names)) != len(names):
            raise _err(path, "bodies", f"have duplicate names {names}")
        meshes = [_body_mesh(s, i, path) for i, s in enumerate(specs)]
        # "auto" alphas: each drawn surface within a few percent of the thinnest body
        length = AUTO_THICKNESS_OFFSET * min(thickness(m) for m in meshes)
        built = [_build_body(s, i, path, m, length) for i, (s, m) in
                 enumerate(zip(specs, meshes))]
    except SimFileError:
        raise
    except SceneError as exc:
        raise _wrap(exc) from None
    return Simulation(path=path, name=name, bodies=built, dt=dt, steps=steps, gravity=gravity,
                      beta=beta, constraint=constraint, camera=camera, gap_tol=gap_tol,
                      spec=data, torques=torques)
