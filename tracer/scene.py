"""Scene files: the authors' JSON format, read unchanged, plus our extensions.

Authors' keys (abhimadan/smoothdists ``scenes/*.json``)::

    {"camera": {"origin": [x, y, z], "dest": [x, y, z], "up": [x, y, z]},
     "objects": [{"path": "mesh.obj", "alpha": 100, "max_alpha": 200,
                  "bvh_type": "faces" | "edges" | "points", "matcap": "jade.png"}]}

Extensions (all optional): top level ``width``, ``height``, ``beta``, ``eps`` (absolute, scene
units; default ``1e-4 x`` the data's bbox diagonal), ``mode`` (``"smooth"`` or ``"exact"``),
``offset`` (exact mode; default ``1/alpha`` per object), ``shading`` (``"normals"``,
``"matcap"``, ``"headlight"``), ``matcap``, ``background`` ([r, g, b] 0-255), ``max_steps``,
``gradient`` (``"metric"`` or ``"exact"``), ``description``. Per object: ``beta``, ``offset``,
``bvh_type`` may also be ``"mixed"`` (keep all primitives of the file), and instead of ``path``
an object may list ``parts``: ``[{"path": ..., "bvh_type": ..., "scale": s,
"translate": [x, y, z]}, ...]`` merged into one mixed mesh (one BVH). ``alpha`` may be
``"auto"``. Several objects are combined by LogSumExp with the largest alpha (paper Sec. 3.6).

Relative paths resolve against the scene file's folder.
"""

import json
import math
import os
from dataclasses import dataclass, field as dc_field

import numpy as np

import smoothdist
from smoothdist import DataMesh, SmoothDistanceField

BVH_TYPES = {"faces": "triangles", "triangles": "triangles", "edges": "edges",
             "points": "points", "mixed": "mixed"}
SHADINGS = ("normals", "matcap", "headlight")
MODES = ("smooth", "exact")

_TOP_KEYS = {"camera", "objects", "width", "height", "beta", "eps", "mode", "offset", "shading",
             "matcap", "background", "max_steps", "gradient", "description", "name"}
_CAMERA_KEYS = {"origin", "dest", "up"}
_OBJECT_KEYS = {"path", "parts", "alpha", "max_alpha", "bvh_type", "matcap", "beta", "offset",
                "name", "scale", "translate"}
_PART_KEYS = {"path", "bvh_type", "scale", "translate"}


class SceneError(ValueError):
    """A scene file that cannot be used; the message names the file and the bad key."""


@dataclass
class SceneObject:
    """One object: a data mesh with its field and parameters."""

    name: str
    field: SmoothDistanceField
    alpha: float
    alpha_u: float
    beta: float
    offset: float
    matcap: str = ""


@dataclass
class Scene:
    """A validated, loaded scene; meshes are built into fields on load."""

    path: str
    camera_origin: np.ndarray
    camera_dest: np.ndarray
    camera_up: np.ndarray
    objects: list
    width: int = 512
    height: int = 512
    beta: float = 0.5
    eps: float = None
    mode: str = "smooth"
    shading: str = "normals"
    matcap: str = ""
    background: tuple = (255, 255, 255)
    max_steps: int = 1000
    gradient: str = "metric"
    description: str = ""
    extra: dict = dc_field(default_factory=dict)

    @property
    def name(self):
        """The scene's file stem."""
        return os.path.splitext(os.path.basename(self.path))[0]

    @property
    def bounds(self):
        """``(lo, hi)`` of all objects' data."""
        los = [o.field.bounds[0] for o in self.objects]
        his = [o.field.bounds[1] for o in self.objects]
        return np.min(los, axis=0), np.max(his, axis=0)

    @property
    def diagonal(self):
        """Bounding-box diagonal of all objects' data."""
        lo, hi = self.bounds
        return float(np.linalg.norm(hi - lo))


# ---------------------------------------------------------------------- validation helpers
def _err(path, where, msg):
    return SceneError(f"{os.path.basename(path)}: {where} {msg}")


def _number(value, path, where, *, positive=False, non_negative=False, integer=False):
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise _err(path, where, f"must be a number, got {json.dumps(value)}")
    if not math.isfinite(value):
        raise _err(path, where, f"must be finite, got {value}")
    if integer and (not float(value).is_integer()):
        raise _err(path, where, f"must be an integer, got {value}")
    if positive and value <= 0:
        raise _err(path, where, f"must be > 0, got {value}")
    if non_negative and value < 0:
        raise _err(path, where, f"must be >= 0, got {value}")
    return int(value) if integer else float(value)


def _vec3(value, path, where):
    if not isinstance(value, list) or len(value) != 3:
        raise _err(path, where, f"must be a list of 3 numbers, got {json.dumps(value)}")
    return np.array([_number(v, path, f"{where}[{i}]") for i, v in enumerate(value)])


def _choice(value, choices, path, where):
    if not isinstance(value, str) or value not in choices:
        raise _err(path, where, f"must be one of {', '.join(choices)}; got {json.dumps(value)}")
    return value


def _keys(d, allowed, path, where):
    if not isinstance(d, dict):
        raise _err(path, where, f"must be a JSON object, got {type(d).__name__}")
    unknown = sorted(set(d) - allowed)
    if unknown:
        raise _err(path, where, f"has unknown key(s) {', '.join(map(repr, unknown))} "
                                f"(allowed: {', '.join(sorted(allowed))})")


def _resolve(base, p, path, where):
    if not isinstance(p, str) or not p:
        raise _err(path, where, f"must be a non-empty file path, got {json.dumps(p)}")
    full = os.path.normpath(os.path.join(base, os.path.expanduser(p)))
    if not os.path.isfile(full):
        raise _err(path, where, f"file not found: {p} (looked for {full})")
    return full


# ---------------------------------------------------------------------- loading
def read_scene_json(path):
    """Parse a scene file into a dict, with one-line errors for unreadable or malformed JSON."""
    path = os.fspath(path)
    if not os.path.exists(path):
        raise SceneError(f"scene file not found: {path}")
    if os.path.isdir(path):
        raise SceneError(f"scene path is a folder, not a file: {path}")
    try:
        with open(path, "r", encoding="utf-8") as fh:
            data = json.load(fh)
    except PermissionError:
        raise SceneError(f"scene file is not readable (permission denied): {path}") from None
    except UnicodeDecodeError:
        raise SceneError(f"{os.path.basename(path)}: not a text (UTF-8) JSON file") from None
    except json.JSONDecodeError as exc:
        raise SceneError(f"{os.path.basename(path)}: malformed JSON at line {exc.lineno} "
                         f"column {exc.colno}: {exc.msg}") from None
    return data


def load_scene(path, overrides=None):
    """Read, validate and build a scene.

    Parameters
    ----------
    path : str
        The scene JSON file.
    overrides : dict, optional
        Values that replace the file's: ``width``, ``height``, ``beta``, ``alpha`` (first
        object), ``mode``, ``eps``, ``shading``, ``offset``.

    Raises
    ------
    SceneError
        With a one-line message naming the file and the key.
    """
    path = os.fspath(path)
    data = read_scene_json(path)
    overrides = dict(overrides or {})
    _keys(data, _TOP_KEYS, path, "the top level")
    base = os.path.dirname(os.path.abspath(path))
    if "camera" not in data:
        raise _err(path, "the top level", "is missing the required key 'camera'")
    cam = data["camera"]
    _keys(cam, _CAMERA_KEYS, path, "camera")
    for k in ("origin", "dest", "up"):
        if k not in cam:
            raise _err(path, "camera", f"is missing the required key {k!r}")
    origin = _vec3(cam["origin"], path, "camera.origin")
    dest = _vec3(cam["dest"], path, "camera.dest")
    up = _vec3(cam["up"], path, "camera.up")

    def top(key, default, **kw):
        if key in overrides and overrides[key] is not None:
            value, where = overrides[key], f"--{key}"
        elif key in data:
            value, where = data[key], key
        else:
            return default
        return _number(value, path, where, **kw)

    width = top("width", 512, positive=True, integer=True)
    height = top("height", 512, positive=True, integer=True)
    if width * height > 64_000_000:
        raise _err(path, "width x height", f"is {width}x{height}: larger than 64 megapixels")
    beta = top("beta", 0.5, non_negative=True)
    eps = top("eps", None, positive=True)
    max_steps = top("max_steps", 1000, positive=True, integer=True)
    mode = _choice(overrides.get("mode") or data.get("mode", "smooth"), MODES, path, "mode")
    gradient = _choice(data.get("gradient", "metric"), ("metric", "exact"), path, "gradient")
    bg = data.get("background", [255, 255, 255])
    if (not isinstance(bg, list) or len(bg) != 3
            or not all(isinstance(v, int) and not isinstance(v, bool) and 0 <= v <= 255 for v in bg)):
        raise _err(path, "background", f"must be [r, g, b] integers 0-255, got {json.dumps(bg)}")
    objs = data.get("objects")
    if objs is None:
        raise _err(path, "the top level", "is missing the required key 'objects'")
    if not isinstance(objs, list) or not objs:
        raise _err(path, "objects", "must be a non-empty list of objects")
    objects = []
    for i, od in enumerate(objs):
        where = f"objects[{i}]"
        _keys(od, _OBJECT_KEYS, path, where)
        mesh = _object_mesh(od, base, path, where)
        fld = SmoothDistanceField(mesh)
        if i == 0 and overrides.get("alpha") is not None:
            alpha = _number(overrides["alpha"], path, "--alpha", positive=True)
        elif "alpha" not in od:
            raise _err(path, where, "is missing the required key 'alpha'")
        elif od["alpha"] == "auto":
            alpha = fld.auto_alpha()
        else:
            alpha = _number(od["alpha"], path, f"{where}.alpha", positive=True)
        alpha_u = (_number(od["max_alpha"], path, f"{where}.max_alpha", positive=True)
                   if "max_alpha" in od else alpha)
        obeta = (_number(od["beta"], path, f"{where}.beta", non_negative=True)
                 if "beta" in od and overrides.get("beta") is None else beta)
        if overrides.get("offset") is not None:
            offset = _number(overrides["offset"], path, "--offset", non_negative=True)
        elif "offset" in od:
            offset = _number(od["offset"], path, f"{where}.offset", non_negative=True)
        elif "offset" in data:
            offset = _number(data["offset"], path, "offset", non_negative=True)
        else:
            offset = 1.0 / alpha
        matcap = od.get("matcap", "")
        if not isinstance(matcap, str):
            raise _err(path, f"{where}.matcap", f"must be a file path or \"\", got {json.dumps(matcap)}")
        matcap = _resolve(base, matcap, path, f"{where}.matcap") if matcap else ""
        name = od.get("name", os.path.basename(od.get("path", f"object{i}")))
        objects.append(SceneObject(name=str(name), field=fld, alpha=alpha, alpha_u=alpha_u,
                                   beta=obeta, offset=offset, matcap=matcap))
    matcap = data.get("matcap", "")
    if not isinstance(matcap, str):
        raise _err(path, "matcap", f"must be a file path or \"\", got {json.dumps(matcap)}")
    matcap = _resolve(base, matcap, path, "matcap") if matcap else ""
    if not matcap:
        matcap = next((o.matcap for o in objects if o.matcap), "")
    default_shading = "matcap" if matcap else "normals"
    shading = _choice(overrides.get("shading") or data.get("shading", default_shading), SHADINGS,
                      path, "shading")
    if shading == "matcap" and not matcap:
        raise _err(path, "shading", "is 'matcap' but no matcap file is given (key 'matcap')")
    desc = data.get("description", "")
    scene = Scene(path=path, camera_origin=origin, camera_dest=dest, camera_up=up,
                  objects=objects, width=width, height=height, beta=beta, eps=eps, mode=mode,
                  shading=shading, matcap=matcap, background=tuple(bg), max_steps=max_steps,
                  gradient=gradient, description=str(desc))
    if scene.eps is None:
        scene.eps = 1e-4 * max(scene.diagonal, 1e-12)
    return scene


def _object_mesh(od, base, path, where):
    if "path" in od and "parts" in od:
        raise _err(path, where, "has both 'path' and 'parts'; give one")
    if "parts" in od:
        parts = od["parts"]
        if not isinstance(parts, list) or not parts:
            raise _err(path, f"{where}.parts", "must be a non-empty list")
        meshes = []
        for j, pd in enumerate(parts):
            pw = f"{where}.parts[{j}]"
            _keys(pd, _PART_KEYS, path, pw)
            meshes.append(_part_mesh(pd, base, path, pw))
        return merge_meshes(meshes, name=od.get("name", "mixed"))
    if "path" not in od:
        raise _err(path, where, "is missing the required key 'path' (or 'parts')")
    return _part_mesh(od, base, path, where)


def _part_mesh(pd, base, path, where):
    full = _resolve(base, pd.get("path"), path, f"{where}.path")
    kind = BVH_TYPES[_choice(pd.get("bvh_type", "mixed"), tuple(BVH_TYPES), path,
                             f"{where}.bvh_type")]
    try:
        mesh = smoothdist.load_mesh(full, kind=None if kind == "mixed" else kind)
    except ValueError as exc:
        raise _err(path, f"{where}.path", f"({os.path.basename(full)}): {exc}") from None
    scale = _number(pd["scale"], path, f"{where}.scale", positive=True) if "scale" in pd else 1.0
    shift = _vec3(pd["translate"], path, f"{where}.translate") if "translate" in pd else np.zeros(3)
    if scale != 1.0 or np.any(shift):
        mesh = DataMesh(mesh.V * scale + shift, points=mesh.points, edges=mesh.edges,
                        triangles=mesh.triangles, name=mesh.name)
    return mesh


def merge_meshes(meshes, name="mixed"):
    """Concatenate several :class:`DataMesh` into one mixed mesh over a shared vertex array."""
    V, P, E, T = [], [], [], []
    off = 0
    for m in meshes:
        V.append(m.V)
        P.append(m.points + off)
        E.append(m.edges + off)
        T.append(m.triangles + off)
        off += m.V.shape[0]
    return DataMesh(np.concatenate(V), points=np.concatenate(P), edges=np.concatenate(E),
                    triangles=np.concatenate(T), name=name)


def scene_from_field(field, *, alpha, alpha_u=None, beta=0.5, camera=None, width=512,
                     height=512, mode="smooth", eps=None, offset=None, shading="normals",
                     matcap="", gradient="metric", name="scene", max_steps=1000):
    """Build a one-object :class:`Scene` in code (no JSON), e.g. for parameter studies.

    Parameters
    ----------
    field : smoothdist.SmoothDistanceField
        The object's data (built once; reuse it across renders).
    alpha, alpha_u, beta : float
        As in the scene file (``alpha_u`` defaults to ``alpha``, i.e. no attenuation).
    camera : (origin, dest, up), optional
        Three 3-vectors; default: the paper's beta-study camera (bbox centre + 2 x the largest
        extent along +z, looking at the centre, up +y).
    """
    lo, hi = field.bounds
    if camera is None:
        c = 0.5 * (lo + hi)
        camera = (c + np.array([0.0, 0.0, 2.0 * float((hi - lo).max())]), c, np.array([0.0, 1, 0]))
    origin, dest, up = (np.asarray(v, dtype=float) for v in camera)
    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
    if shading not in SHADINGS:
        raise ValueError(f"shading must be one of {SHADINGS}, got {shading!r}")
    alpha = float(alpha)
    alpha_u = float(alpha_u) if alpha_u is not None else alpha
    field.kernel_args(alpha, beta, alpha_u, gradient)  # validates alpha, beta, alpha_u
    obj = SceneObject(name=name, field=field, alpha=alpha, alpha_u=alpha_u, beta=float(beta),
                      offset=float(offset) if offset is not None else 1.0 / alpha,
                      matcap=matcap)
    scene = Scene(path=f"{name}.json", camera_origin=origin, camera_dest=dest, camera_up=up,
                  objects=[obj], width=int(width), height=int(height), beta=float(beta),
                  eps=eps, mode=mode, shading=shading, matcap=matcap, max_steps=int(max_steps),
                  gradient=gradient)
    if scene.eps is None:
        scene.eps = 1e-4 * max(scene.diagonal, 1e-12)
    return scene
