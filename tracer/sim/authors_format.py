"""The authors' simulation files (``sims/*.json`` of abhimadan/smoothdists), read unchanged.

:func:`tracer.sim.simfile.load_simulation` hands a file with a top-level ``objects`` list here;
:func:`build_simulation` turns it into the same :class:`~tracer.sim.simulation.Simulation` as our
own format. Format (keys not listed are refused; lengths in scene units, times in seconds)::

    {
      "name": "point_v_long",           label (default: the file name)
      "timestep": 0.01,                 time step h (> 0)                          required
      "num_steps": 600,                 number of steps (integer > 0)              required
      "gravity": [0, -1, 0],            m/s^2                                      required
      "beta": 0.5,                      Barnes-Hut parameter of every pair, default 0.5
      "use_exact_dist": false,          true: the exact-distance constraint ("exact")
      "objects": [                      at least two, at least one dynamic
        {
          "name": "V",                  unique                                     required
          "meshes": [                   one or more; several make one mixed body   required
            {"path": "bowl.obj", "bvh_type": "edges"},  a mesh file, relative to THIS file, or
            {"data": {"points": [[x, y, z], ...],       inline: 3-index faces are triangles,
                      "faces": [[i, j], ...]},          2-index faces edges, [] points
             "bvh_type": "edges"}       "faces" | "edges" | "points"             required
          ],
          "alpha": 20,                  smooth-distance sharpness (> 0)            required
          "max_alpha": 40,              alpha_U (> 0), default 1: no attenuation
          "is_dynamic": true,           default false
          "init_state": {               dynamic objects only (see below)
            "position": [x, y, z],      the centre of mass in the world
            "rotation": [[..], [..], [..]],  3x3 rotation matrix, row by row
            "velocity": [..], "angular_velocity": [..]   world axes, rad/s
          }
        }
      ]
    }

Semantics (those of their ``readJSONSimulationScene`` and ``rigid_body_simulator``):

* ``bvh_type`` picks the geometry the distance sees: ``faces`` the triangles (the mesh must hold
  some), ``edges`` the edges (a triangle mesh's unique edges), ``points`` every vertex. OBJ files
  are read as theirs are: a 2-vertex ``f`` record (or an ``l`` record) is an edge.
* Mass properties come from what the mesh **holds**, whatever its ``bvh_type``: triangles are
  integrated as a solid of unit density (any triangle mesh, closed or not, as theirs; we sum
  tetrahedra to the vertex centroid, so an open mesh counts as closed by a cone to it); edges as
  wires of unit density per length, their mass and inertia scaled by ``1e-3``
  (:data:`EDGE_MASS_SCALE`); points as unit masses (every vertex). An object's meshes add their
  masses, their mass-weighted centres, and their inertia tensors each about its own centre (as
  theirs: no parallel-axis term, exact when the meshes share their centre, as the spikeball's
  sphere and spikes do).
* A **dynamic** object is re-centred on its centre of mass: ``position`` is where that centre
  goes and ``rotation`` turns the body about it, so the file's vertex ``p`` is placed at
  ``rotation (p - com) + position``. A **static** object stays at its file coordinates; its
  ``init_state`` is ignored (theirs ignores it too).
* ``max_alpha`` is alpha_U with the attenuation ``S = min(alpha / alpha_U, 1)``; their default 1
  leaves ``S = 1`` (no attenuation) for ``alpha >= 1``. We store ``alpha_u = max(max_alpha,
  alpha)``, which gives the same ``S``.
* ``use_exact_dist: true`` is our ``"exact"`` constraint (minimum over pairs of the exact
  distance minus ``1 / alpha`` of the pair's data body), as theirs.

What differs: mesh paths resolve relative to the simulation file (theirs: to the working
directory, so their files keep working when run from their ``sims/`` folder); the files have
no camera, so frames get an automatic one (:func:`tracer.sim.simulation.auto_camera`: 640 x 360,
lit, up against gravity, framing every body over the whole trajectory); in smooth mode a pair
whose data object is one mesh of one primitive keeps the smooth distance (theirs switches it to
the exact one); resting contacts keep the integrator's gap ``gap_tol``
(:mod:`tracer.sim.integrator`).
"""

import os
import warnings

import numpy as np

from smoothdist import DataMesh
from smoothdist.connectivity import unique_edges
from smoothdist.mesh import read_mesh_file
from tracer.errors import SceneError, SimFileError
from tracer.sim.bodies import INERTIA_FLOOR, Body
from tracer.sim.simulation import DEFAULT_FRAMES, MovieCamera, Simulation, auto_camera
from tracer.sim.simulation import wrap_scene_error as _wrap
from tracer.validate import check_keys, choice, number, resolve_path, show, vec3

__all__ = ["build_simulation", "EDGE_MASS_SCALE", "BVH_TYPES"]

_TOP = {"objects", "gravity", "timestep", "num_steps", "beta", "use_exact_dist", "name"}
_OBJECT = {"name", "meshes", "alpha", "max_alpha", "is_dynamic", "init_state"}
_MESH = {"path", "data", "bvh_type"}
_DATA = {"points", "faces"}
_STATE = {"position", "rotation", "velocity", "angular_velocity"}
#: the values of ``bvh_type``
BVH_TYPES = ("faces", "edges", "points")
#: mass (and inertia) factor of edge meshes (theirs: "approximate as a bunch of cylinders")
EDGE_MASS_SCALE = 1e-3
#: their ``max_alpha`` when the key is absent
DEFAULT_MAX_ALPHA = 1.0


def _err(path, where, msg):
    return SimFileError(f"{os.path.basename(path)}: {where} {msg}")


def _flag(d, key, path, where, default=False):
    value = d.get(key, default)
    if not isinstance(value, bool):
        raise _err(path, where, f"must be true or false, got {show(value)}")
    return value


def _read_obj(full, path, where):
    """``(V, E, T)`` of an OBJ file as their reader sees it: ``f`` records of 2 vertices (and
    ``l`` records) are edges, of 3 or more triangles (fanned)."""
    verts, edges, tris = [], [], []
    try:
        with open(full, "rb") as fh:
            raw = fh.read()
    except OSError as exc:
        raise _err(path, where, f"cannot be read: {exc.strerror or type(exc).__name__}") from None
    if b"\0" in raw[:4096]:
        raise _err(path, where, "is not a text OBJ file (it holds binary data)")
    for lineno, line in enumerate(raw.decode("utf-8", errors="replace").splitlines(), 1):
        parts = line.split()
        if not parts or parts[0] not in ("v", "f", "l"):
            continue
        try:
            if parts[0] == "v":
                verts.append((float(parts[1]), float(parts[2]), float(parts[3])))
                continue
            idx = [int(p.split("/")[0]) for p in parts[1:]]
            if 0 in idx or len(idx) < 2:
                raise ValueError("indices start at 1 and a record needs 2 or more")
            idx = [i - 1 if i > 0 else len(verts) + i for i in idx]
            if parts[0] == "l" or len(idx) == 2:
                edges.extend(zip(idx[:-1], idx[1:]))
            else:
                tris.extend((idx[0], idx[j], idx[j + 1]) for j in range(1, len(idx) - 1))
        except (ValueError, IndexError) as exc:
            raise _err(path, where, f"line {lineno} of {os.path.basename(full)} is malformed: "
                                    f"{line.strip()[:60]!r} ({exc})") from None
    return (np.array(verts, dtype=float).reshape(-1, 3),
            np.array(edges, dtype=np.int64).reshape(-1, 2),
            np.array(tris, dtype=np.int64).reshape(-1, 3))


def _inline(data, path, where):
    """``(V, E, T)`` of a mesh's ``data`` object."""
    check_keys(data, _DATA, path, where)
    for k in ("points", "faces"):
        if k not in data:
            raise _err(path, where, f"is missing the required key {k!r}")
    pts, faces = data["points"], data["faces"]
    if not isinstance(pts, list) or not pts:
        raise _err(path, f"{where}.points",
                   f"must be a non-empty list of [x, y, z], got {show(pts)}")
    V = np.array([vec3(p, path, f"{where}.points[{i}]") for i, p in enumerate(pts)])
    if not isinstance(faces, list):
        raise _err(path, f"{where}.faces",
                   f"must be a list of [i, j] or [i, j, k], got {show(faces)}")
    k = len(faces[0]) if faces and isinstance(faces[0], list) else 0
    F = []
    for i, f in enumerate(faces):
        if not isinstance(f, list) or len(f) not in (2, 3) or len(f) != k:
            size = (f"{k} vertex indices, as faces[0]" if i and k in (2, 3)
                    else "2 or 3 vertex indices")
            raise _err(path, f"{where}.faces[{i}]", f"must be a list of {size}, got {show(f)}")
        F.append([number(j, path, f"{where}.faces[{i}][{n}]", non_negative=True, integer=True)
                  for n, j in enumerate(f)])
        if max(F[-1]) >= len(V):
            raise _err(path, f"{where}.faces[{i}]", f"refers to vertex {max(F[-1])} but there are "
                                                     f"{len(V)} points")
    F = np.array(F, dtype=np.int64).reshape(-1, max(k, 2))
    empty2, empty3 = np.zeros((0, 2), np.int64), np.zeros((0, 3), np.int64)
    return V, (F if k == 2 else empty2), (F if k == 3 else empty3)


def _mesh_arrays(md, path, where, base):
    """``(V, E, T)`` of one entry of ``meshes``."""
    check_keys(md, _MESH, path, where)
    if ("path" in md) == ("data" in md):
        raise _err(path, where, "needs exactly one of 'path' (a mesh file) or 'data' (inline)")
    if "bvh_type" not in md:
        raise _err(path, where, "is missing the required key 'bvh_type' (faces, edges or points)")
    if "data" in md:
        return _inline(md["data"], path, f"{where}.data")
    full = resolve_path(base, md["path"], path, f"{where}.path")
    if full.lower().endswith(".obj"):
        V, E, T = _read_obj(full, path, f"{where}.path")
    else:
        try:
            V, E, T, _ = read_mesh_file(full)
        except ValueError as exc:
            raise _err(path, f"{where}.path",
                       f"cannot be read: {str(exc).splitlines()[0]}") from None
    if V.shape[0] == 0:
        raise _err(path, f"{where}.path", f"holds no vertices: {md['path']}")
    n = V.shape[0]
    for a, what in ((E, "edge"), (T, "face")):
        if a.size and (a.min() < 0 or a.max() >= n):
            raise _err(path, f"{where}.path", f"has a {what} index out of range (0..{n - 1}): "
                                              f"{md['path']}")
    return V, E, T


def _part(md, path, where, base):
    """One mesh of an object: ``(kind its mass comes from, DataMesh of its bvh_type geometry)``."""
    V, E, T = _mesh_arrays(md, path, where, base)
    held = "triangles" if len(T) else "edges" if len(E) else "points"
    bvh = choice(md["bvh_type"], BVH_TYPES, path, f"{where}.bvh_type")
    if bvh == "faces" and held != "triangles":
        raise _err(path, f"{where}.bvh_type", f"is 'faces' but the mesh holds no triangles "
                                              f"({len(E)} edges, {len(V)} vertices)")
    if bvh == "edges" and held == "points":
        raise _err(path, f"{where}.bvh_type",
                   f"is 'edges' but the mesh holds no edges or triangles ({len(V)} vertices)")
    try:
        if bvh == "faces":
            geo = DataMesh(V, triangles=T, name=where)
        elif bvh == "edges":
            Es = np.concatenate([E, unique_edges(T)]) if len(T) else E
            geo = DataMesh(V, edges=np.unique(np.sort(Es, axis=1), axis=0), name=where)
        else:
            geo = DataMesh(V, points=np.arange(V.shape[0]), name=where)
    except ValueError as exc:
        raise _err(path, where, f"cannot be built: {str(exc).splitlines()[0]}") from None
    return held, (V, E, T), geo


def _outer_sum(P):
    """``sum_i P_i P_i^T + (sum_i P_i)(sum_i P_i)^T`` over the ``k`` vertices of ``P (m, k, 3)``."""
    s = P.sum(axis=1)
    return np.einsum("mki,mkj->mij", P, P) + np.einsum("mi,mj->mij", s, s)


def part_mass(held, V, E, T):
    """``(mass, com (3,), inertia about com (3, 3))`` of one mesh by the authors' rules (see the
    module notes; unscaled: :data:`EDGE_MASS_SCALE` is applied when the meshes are combined).
    Raises ValueError when the mass is not positive."""
    o = V.mean(axis=0)                        # integrate about the vertex centroid
    if held == "points":
        Y = V - o
        m, first, C = float(len(V)), Y.sum(axis=0), Y.T @ Y
    elif held == "edges":
        a, b = V[E[:, 0]] - o, V[E[:, 1]] - o
        L = np.linalg.norm(b - a, axis=1)
        m = float(L.sum())
        first = (L[:, None] * 0.5 * (a + b)).sum(axis=0)
        C = np.einsum("m,mij->ij", L / 6.0, _outer_sum(np.stack([a, b], axis=1)))
    else:                                     # tetrahedra (o, a, b, c)
        P = V[T] - o
        vol = np.einsum("mi,mi->m", P[:, 0], np.cross(P[:, 1], P[:, 2])) / 6.0
        if vol.sum() < 0:                     # inward-facing triangles
            vol = -vol
        m = float(vol.sum())
        first = (vol[:, None] * P.sum(axis=1) / 4.0).sum(axis=0)
        C = np.einsum("m,mij->ij", vol / 20.0, _outer_sum(P))
    ext = float(np.linalg.norm(np.ptp(V, axis=0))) if len(V) > 1 else 1.0
    if not m > 1e-12 * max(ext, 1e-300) ** (3 if held == "triangles" else 1):
        raise ValueError({"triangles": "the triangles enclose no volume (flat or open)",
                          "edges": "the edges have no length"}.get(held, "no mass"))
    c = first / m
    Cc = C - m * np.outer(c, c)
    return m, o + c, np.trace(Cc) * np.eye(3) - Cc


def _floor(inertia, mass, size):
    """The inertia with degenerate principal moments raised as :mod:`tracer.sim.bodies` does."""
    inertia = 0.5 * (inertia + inertia.T)
    w, U = np.linalg.eigh(inertia)
    top = w.max()
    floor = INERTIA_FLOOR * top if top > 1e-12 * mass * max(size, 1e-300) ** 2 else mass
    return (U * np.maximum(w, floor)) @ U.T


def _rotation(value, path, where):
    if not (isinstance(value, list) and len(value) == 3):
        raise _err(path, where, f"must be a 3x3 rotation matrix (three rows), got {show(value)}")
    R = np.array([vec3(r, path, f"{where}[{i}]") for i, r in enumerate(value)])
    if not np.allclose(R @ R.T, np.eye(3), atol=1e-6) or np.linalg.det(R) <= 0:
        raise _err(path, where, "must be a rotation matrix (orthonormal rows, det +1)")
    return R


def _object(od, i, path, base):
    """The :class:`~tracer.sim.bodies.Body` of ``objects[i]``."""
    where = f"objects[{i}]"
    check_keys(od, _OBJECT, path, where)
    for k in ("name", "meshes", "alpha"):
        if k not in od:
            raise _err(path, where, f"is missing the required key {k!r}")
    name = od["name"]
    if not isinstance(name, str) or not name:
        raise _err(path, f"{where}.name", f"must be a non-empty string, got {show(name)}")
    alpha = number(od["alpha"], path, f"{where}.alpha", positive=True)
    max_alpha = number(od.get("max_alpha", DEFAULT_MAX_ALPHA), path, f"{where}.max_alpha",
                       positive=True)
    dynamic = _flag(od, "is_dynamic", path, f"{where}.is_dynamic")
    state = od.get("init_state", {})
    check_keys(state, _STATE, path, f"{where}.init_state")
    pos = vec3(state.get("position", [0, 0, 0]), path, f"{where}.init_state.position")
    R = (_rotation(state["rotation"], path, f"{where}.init_state.rotation")
         if "rotation" in state else np.eye(3))
    vel = vec3(state.get("velocity", [0, 0, 0]), path, f"{where}.init_state.velocity")
    omega = vec3(state.get("angular_velocity", [0, 0, 0]), path,
                 f"{where}.init_state.angular_velocity")
    meshes = od["meshes"]
    if not isinstance(meshes, list) or not meshes:
        raise _err(path, f"{where}.meshes",
                   f"must be a non-empty list of meshes, got {show(meshes)}")
    parts = [_part(md, path, f"{where}.meshes[{j}]", base) for j, md in enumerate(meshes)]
    # one body: the meshes' bvh_type geometry side by side (duplicated vertices merged silently)
    Vs, P, E, T, n = [], [], [], [], 0
    for _, _, g in parts:
        Vs.append(g.V)
        P.append(g.points + n)
        E.append(g.edges + n)
        T.append(g.triangles + n)
        n += g.V.shape[0]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mesh = DataMesh(np.concatenate(Vs), points=np.concatenate(P), edges=np.concatenate(E),
                        triangles=np.concatenate(T), name=name)
    size = mesh.diagonal
    try:
        mass, first, inertia = 0.0, np.zeros(3), np.zeros((3, 3))
        for j, (held, (V, Ej, Tj), _) in enumerate(parts):
            try:
                m, c, I = part_mass(held, V, Ej, Tj)
            except ValueError as exc:
                raise _err(path, f"{where}.meshes[{j}]", f"has no mass: {exc}") from None
            s = EDGE_MASS_SCALE if held == "edges" else 1.0
            mass += s * m
            first += s * m * c
            inertia += s * I
        com = first / mass
    except SceneError:
        if dynamic:
            raise
        lo, hi = mesh.bounds                  # a static body's mass is never used
        mass, com, inertia = 1.0, 0.5 * (lo + hi), np.eye(3)
    inertia = _floor(inertia, mass, size)
    local = DataMesh(mesh.V - com, points=mesh.points, edges=mesh.edges,
                     triangles=mesh.triangles, name=name, repair=False)
    if not dynamic:                           # theirs ignores a static object's init_state
        pos, R, vel, omega = com, np.eye(3), np.zeros(3), np.zeros(3)
    return Body(name=name, mesh=local, kind=mesh.kind, alpha=alpha,
                alpha_u=max(max_alpha, alpha), mass=mass, inertia=inertia, static=not dynamic,
                x=np.asarray(pos, dtype=float).copy(), R=R.copy(), v=vel.copy(),
                w=omega.copy(), offset=com)


def build_simulation(data, path):
    """The :class:`~tracer.sim.simulation.Simulation` of an authors' file already parsed into
    ``data`` (a dict with ``objects``); raises :class:`~tracer.errors.SimFileError` with a
    one-line message ``<file>: <key> <problem>``."""
    try:
        check_keys(data, _TOP, path, "the top level")
        for k in ("objects", "gravity", "timestep", "num_steps"):
            if k not in data:
                raise _err(path, "the top level", f"is missing the required key {k!r}")
        dt = number(data["timestep"], path, "timestep", positive=True)
        steps = number(data["num_steps"], path, "num_steps", positive=True, integer=True)
        if steps > 10_000_000:
            raise _err(path, "num_steps", f"must be at most 10000000, got {steps}")
        gravity = vec3(data["gravity"], path, "gravity")
        beta = number(data.get("beta", 0.5), path, "beta", non_negative=True)
        exact = _flag(data, "use_exact_dist", path, "use_exact_dist")
        name = data.get("name", os.path.splitext(os.path.basename(path))[0])
        if not isinstance(name, str) or not name:
            raise _err(path, "name", f"must be a non-empty string, got {show(name)}")
        objects = data["objects"]
        if not isinstance(objects, list) or len(objects) < 2:
            raise _err(path, "objects",
                       f"must be a list of at least 2 objects, got {show(objects)}")
        names = [od.get("name") if isinstance(od, dict) else None for od in objects]
        for i, n in enumerate(names):
            if n is not None and names.index(n) != i:
                raise _err(path, f"objects[{i}].name", f"{show(n)} is already the name of "
                                                       f"objects[{names.index(n)}]")
        if not any(isinstance(od, dict) and od.get("is_dynamic") is True for od in objects):
            raise _err(path, "objects", "are all static (no \"is_dynamic\": true): nothing "
                                        "would move")
        base = os.path.dirname(os.path.abspath(path))
        bodies = [_object(od, i, path, base) for i, od in enumerate(objects)]
        width, height = 640, 360
        origin, dest, up = auto_camera(bodies, gravity, width=width, height=height)
        camera = MovieCamera(origin=origin, dest=dest, up=up, width=width, height=height,
                        every=max(1, steps // DEFAULT_FRAMES), shading="lit", auto=True)
    except SimFileError:
        raise
    except SceneError as exc:
        raise _wrap(exc) from None
    return Simulation(path=path, name=name, bodies=bodies, dt=dt, steps=steps, gravity=gravity,
                      beta=beta, constraint="exact" if exact else "smooth", camera=camera,
                      spec=data)
