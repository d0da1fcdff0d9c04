"""Scene files: the authors' JSON format, read unchanged, plus our extensions.

Keys (the authors' scenes, abhimadan/smoothdists ``scenes/*.json``, in our spelling)::

    {"camera": {"origin": [x, y, z], "dest": [x, y, z], "up": [x, y, z]},
     "objects": [{"path": "mesh.obj", "alpha": 100, "alpha_u": 200,
                  "kind": "triangles" | "edges" | "points", "matcap": "jade.png"}]}

Two keys are spelled as in the API (``render_mesh(kind=..., alpha_u=...)``) rather than as
the authors spelled them; their spellings are read too (``AUTHORS_KEYS``):
``max_alpha`` is ``alpha_u``, and ``bvh_type`` is ``kind``, with ``"faces"`` for
``"triangles"``. Files and scenes written here use ours.

Extensions (all optional): top level ``width``, ``height``, ``beta``, ``eps`` (absolute, scene
units; default ``1e-4 x`` the data's bbox diagonal), ``mode`` (``"smooth"`` or ``"exact"``),
``offset`` (the level of the surface: exact mode ``d = offset``, default ``1/alpha`` per
object; smooth mode ``d_hat = offset``, default 0), ``shading`` (``"normals"``,
``"matcap"``, ``"headlight"``), ``matcap``, ``background`` ([r, g, b] 0-255), ``max_steps``,
``gradient`` (``"metric"`` or ``"exact"``), ``description``, ``tol`` (tolerance-controlled
pruning, a number >= 0, default 0 = off; see ``smoothdist.kernels.smooth_distance_point_tol``),
``newton`` (smooth mode: Newton steps along the ray once the distance is below ``newton x eps``,
a number >= 0, default ``tracer.rendering.march.NEWTON``; 0 = plain sphere tracing; see
``tracer.rendering.march.march_ray``).
Per object: ``beta``, ``offset``,
``kind`` may also be ``"mixed"`` (keep all primitives of the file), and instead of ``path``
an object may list ``parts``: ``[{"path": ..., "kind": ..., "scale": s,
"translate": [x, y, z]}, ...]`` merged into one mixed mesh (one BVH). ``alpha`` may be
``"auto"``; ``alpha_u`` (alpha_U) may be ``"auto"``, its default (20 x alpha, see
``SmoothDistanceField.auto_alpha_u``; the authors' files without it meant no attenuation).
An object whose ``alpha`` is ``"auto"`` with ``alpha_u`` and ``offset`` left out, in smooth
mode, gets all three from ``SmoothDistanceField.auto_surface`` (triangles: a thin shell at
0.3 % of the diagonal or a tenth of the local feature size, issue 46; curves: a tube about 0.75
mean edge lengths thick, without rings, issue 35).
Several objects are combined by LogSumExp with the largest alpha (paper Sec. 3.6).

The complete reference (every key: type, default, example) is the JSON Schema
``tracer/scenes/scene.schema.json``, rendered as ``docs/scene-format.md``; a test keeps both equal
to what this loader accepts.

Relative paths resolve against the scene file's folder.

Validation: :func:`load_scene` checks every key, value, camera and referenced file before it
reads any mesh, and raises :class:`~tracer.errors.SceneError` (a ``ValueError``) with a one-line
message ``<scene file>: <key> <problem>``. Limits: images up to 64 megapixels, ``max_steps`` up to
1e6, scene files up to 16 MiB, coordinates up to 1e50 in absolute value. When the data has
no extent (a single point) the default ``eps`` is ``1e-4 x`` the surface's size
(``max(1/alpha, offset)``) instead of the bbox diagonal.
"""

import dataclasses
import os
import warnings
from dataclasses import dataclass, field as dc_field, fields

import numpy as np

import smoothdist
from smoothdist import DataMesh, SmoothDistanceField
from tracer.compiling import start_ahead
from tracer.errors import SceneError, user_stacklevel
from tracer.rendering.camera import (PROJECTIONS, LookAt, check_projection, frame_points,
                                      frame_width, look_at)
from tracer.rendering.lighting import Lighting
from tracer.scenes.settings import (KINDS, LIGHTING_KEYS, MAX_PIXELS, MAX_STEPS,
                                    MODES, SCENE_KEYS, SHADINGS, WEIGHT_CHOICES, Film, March,
                                    View, check, defaults, flag_of, settings_entry, table)
from tracer.validate import (check_keys, choice, file_error, number, read_json, resolve_path, show,
                             vec3)

__all__ = ["Scene", "SceneObject", "load_scene", "read_scene_json",
           "scene_from_field", "field_scene", "default_eps", "with_default_eps", "merge_meshes",
           "AUTHORS_KEYS", "MODES", "SHADINGS", "WEIGHT_CHOICES", "MAX_PIXELS", "MAX_STEPS"]

#: the values of ``bvh_type``, the authors' spelling of ``kind`` (their ``"faces"`` is
#: ``"triangles"``)
BVH_TYPES = {"faces": "triangles", **{k: k for k in KINDS}}
#: the authors' spelling of a key -> ours; files in either are read, a file giving both is
#: refused (the vocabulary: docs/design-notes.md)
AUTHORS_KEYS = {"max_alpha": "alpha_u", "bvh_type": "kind"}

#: defaults of scene files and of ``Scene`` (:mod:`tracer.scenes.settings`)
_FILE = defaults("file")
#: the scene file's top-level keys: the settings table's, and the file's own
_TOP_KEYS = set(SCENE_KEYS) | {"camera", "objects", "description", "name"}
_LIGHTING_KEYS = set(LIGHTING_KEYS)
_CAMERA_KEYS = {"origin", "dest", "up", "projection", "view_width"}
_OBJECT_KEYS = {"path", "parts", "alpha", "alpha_u", "max_alpha", "kind", "bvh_type", "matcap",
                "beta", "offset", "name", "scale", "translate", "color"}
_PART_KEYS = {"path", "kind", "bvh_type", "scale", "translate"}


@dataclass
class SceneObject:
    """One object: a data mesh with its field and parameters.

    ``offset`` is the exact mode's offset (the surface ``d = offset``), ``smooth_offset`` the
    smooth mode's (the surface ``d_hat = smooth_offset``, default 0). The scene key and the
    ``offset`` argument set both; left out, they are ``1/alpha`` and 0 (:meth:`level`)."""

    name: str
    field: SmoothDistanceField
    alpha: float
    alpha_u: float
    beta: float
    offset: float
    matcap: str = ""
    #: base colour of the ``"lit"`` shading, sRGB 0-255 (None: the default or the palette)
    color: tuple = None
    #: smooth mode: the level ``c >= 0`` of the rendered surface ``d_hat = c``
    smooth_offset: float = 0.0

    def level(self, mode):
        """The offset the object's surface is drawn at in ``mode``: ``offset`` in exact
        mode, ``smooth_offset`` in smooth mode."""
        return float(self.offset if mode == "exact" else self.smooth_offset)


@dataclass(init=False)
class Scene:
    """A validated, loaded scene; meshes are built into fields on load.

    Its settings travel as the frozen groups of :mod:`tracer.scenes.settings`: ``camera``
    (:class:`~tracer.rendering.camera.LookAt`), ``march``
    (:class:`~tracer.scenes.settings.March`) and ``film``
    (:class:`~tracer.scenes.settings.Film`, with its
    :class:`~tracer.rendering.lighting.Lighting`). Every setting is also an attribute of its
    own, a shorthand that reads and writes the group: ``scene.width`` is
    ``scene.film.width``, ``scene.eps = e`` replaces ``scene.march`` by one with ``eps = e``,
    and ``camera_origin``, ``camera_dest``, ``camera_up`` are the camera's vectors. The
    constructor and ``dataclasses.replace`` take the same names (``replace(scene,
    width=64)``), applied on top of the groups given.
    """

    path: str
    camera: LookAt
    objects: list
    march: March = dc_field(default_factory=March)
    film: Film = dc_field(default_factory=Film)
    description: str = ""
    extra: dict = dc_field(default_factory=dict)

    def __init__(self, path, *, camera=None, objects=(), march=None, film=None,
                 description="", extra=None, **settings):
        unknown = sorted(set(settings) - set(_SHORTHANDS))
        if unknown:
            raise TypeError(f"Scene() got unknown setting(s) {', '.join(map(repr, unknown))}")
        vectors = {k[len("camera_"):]: np.asarray(settings[k], dtype=float)
                   for k in _CAMERA_SHORTHANDS if k in settings}
        if camera is None:
            if len(vectors) != 3:
                raise TypeError("Scene() needs camera=LookAt(origin, dest, up) (or "
                                "camera_origin, camera_dest and camera_up)")
            camera = LookAt(**vectors)
        self.path = path
        self.camera = _pose(camera)._replace(**vectors)
        self.objects = list(objects)
        self.march = _replaced(march or March(), settings)
        self.film = _replaced(film or Film(), settings)
        self.description = description
        self.extra = {} if extra is None else extra

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


def _pose(camera):
    """``camera`` (a :class:`~tracer.rendering.camera.LookAt`, or ``(origin, dest, up)``) as a
    ``LookAt`` whose vectors are float arrays."""
    vectors = [np.asarray(v, dtype=float) for v in tuple(camera)[:3]]
    if isinstance(camera, LookAt):
        return camera._replace(origin=vectors[0], dest=vectors[1], up=vectors[2])
    return LookAt(*vectors)


def _replaced(group, settings):
    """``group`` (a frozen settings dataclass) with the values ``settings`` gives its fields."""
    mine = {f.name: settings[f.name] for f in fields(group) if f.name in settings}
    return dataclasses.replace(group, **mine) if mine else group


def _shorthand(group, name):
    """The property ``Scene.<name>``: ``scene.<group>.<name>``, set by replacing the group."""
    def get(self):
        return getattr(getattr(self, group), name)

    def set_(self, value):
        setattr(self, group, dataclasses.replace(getattr(self, group), **{name: value}))

    return property(get, set_, doc=f"Shorthand of ``scene.{group}.{name}`` (settable).")


def _camera_shorthand(name):
    """The property ``Scene.camera_<name>``: ``scene.camera.<name>`` (settable)."""
    def get(self):
        return getattr(self.camera, name)

    def set_(self, value):
        self.camera = self.camera._replace(**{name: np.asarray(value, dtype=float)})

    return property(get, set_, doc=f"Shorthand of ``scene.camera.{name}`` (settable).")


#: the shorthand attributes of :class:`Scene`: each setting of its groups, by name
_CAMERA_SHORTHANDS = ("camera_origin", "camera_dest", "camera_up")
_SHORTHANDS = {**{f.name: "march" for f in fields(March)}, **{f.name: "film" for f in fields(Film)},
               **{k: "camera" for k in _CAMERA_SHORTHANDS}}
for _name, _group in _SHORTHANDS.items():
    setattr(Scene, _name, _camera_shorthand(_name[len("camera_"):]) if _group == "camera"
            else _shorthand(_group, _name))


# ---------------------------------------------------------------------- loading
def read_scene_json(path):
    """Parse a scene file into a dict, with one-line errors for unreadable or malformed JSON
    (:func:`tracer.validate.read_json`)."""
    return read_json(path, "scene")


def mesh_paths(path):
    """The files a scene file's objects and parts name as ``path``, resolved against its folder
    as :func:`load_scene` resolves them, without checking anything else; ``[]`` for a file that
    cannot be read or parsed (:func:`load_scene` says why)."""
    try:
        data = read_scene_json(path)
    except (ValueError, RecursionError):
        return []
    base = os.path.dirname(os.path.abspath(path))
    objects = data.get("objects") if isinstance(data, dict) else None
    out = []
    for od in objects if isinstance(objects, list) else []:
        parts = od.get("parts") if isinstance(od, dict) else None
        for part in [od] + (parts if isinstance(parts, list) else []):
            p = part.get("path") if isinstance(part, dict) else None
            if isinstance(p, str) and p:
                out.append(os.path.normpath(os.path.join(base, os.path.expanduser(p))))
    return out


def load_scene(path, overrides=None):
    """Read, validate and build a scene.

    Every key is validated (and every referenced file checked to exist) before any mesh is
    read or any BVH built, so a bad scene fails fast.

    Parameters
    ----------
    path : str
        The scene JSON file.
    overrides : dict, optional
        Values that replace the file's (None: not given), named as the command line's flags
        in messages: every top-level setting of :mod:`tracer.scenes.settings` (``width``,
        ``height``, ``beta``, ``mode``, ``eps``, ``shading``, ``offset``, ``tol``,
        ``newton``, ``samples``, ``adaptive``, ``transparent``, ``background``, ``weights``,
        ...), ``alpha`` (first object; a number or "auto"), ``alpha_u`` (first object's
        ``alpha_u``; a number, "auto" or "off"), ``projection`` and ``view_width`` (the
        camera's) and ``lighting`` (a dict of :class:`~tracer.rendering.lighting.Lighting`
        fields).

    Raises
    ------
    SceneError
        With a one-line message naming the file and the key.
    """
    path = os.fspath(path)
    data = read_scene_json(path)
    overrides = dict(overrides or {})
    check_keys(data, _TOP_KEYS, path, "the top level")
    base = os.path.dirname(os.path.abspath(path))
    if "camera" not in data:
        raise file_error(path, "the top level", "is missing the required key 'camera'")
    cam = data["camera"]
    check_keys(cam, _CAMERA_KEYS, path, "camera")
    for k in ("origin", "dest", "up"):
        if k not in cam:
            raise file_error(path, "camera", f"is missing the required key {k!r}")
    origin = vec3(cam["origin"], path, "camera.origin")
    dest = vec3(cam["dest"], path, "camera.dest")
    up = vec3(cam["up"], path, "camera.up")
    projection, view_width = _projection(cam, overrides, path)

    top = _top_settings(data, overrides, path)
    width, height = top["width"], top["height"]
    if width * height > MAX_PIXELS:
        raise file_error(path, "width x height", f"is {width}x{height}: larger than "
                                                 f"{MAX_PIXELS // 1_000_000} megapixels")
    lighting = _lighting(data.get("lighting", {}), overrides.get("lighting"), path)
    for key in ("description", "name"):
        if key in data and not isinstance(data[key], str):
            raise file_error(path, key, f"must be a string, got {show(data[key])}")
    # the camera, before any mesh is loaded

    pose = LookAt(origin, dest, up, projection, view_width)
    try:
        pose.camera(width, height)
    except ValueError as exc:
        raise SceneError(f"{os.path.basename(path)}: {exc}") from None
    objs = data.get("objects")
    if objs is None:
        raise file_error(path, "the top level", "is missing the required key 'objects'")
    if not isinstance(objs, list) or not objs:
        raise file_error(path, "objects", f"must be a non-empty list of objects, got {show(objs)}")
    specs = [_object_spec(od, i, base, path, data, overrides, top["beta"])
             for i, od in enumerate(objs)]
    matcap = data.get("matcap", "")
    if not isinstance(matcap, str):
        raise file_error(path, "matcap", f"must be a file path or \"\", got {show(matcap)}")
    matcap = resolve_path(base, matcap, path, "matcap") if matcap else ""
    if not matcap:
        matcap = next((sp["matcap"] for sp in specs if sp["matcap"]), "")
    if overrides.get("shading") is not None:
        shading = _setting("shading", overrides["shading"], path, "--shading")
    else:   # "matcap" by default when the file names a matcap
        shading = _setting("shading", data.get("shading", "matcap" if matcap else
                                               _FILE["shading"]), path, "shading")
    if shading == "matcap" and not matcap:
        raise file_error(path, "shading", "is 'matcap' but no matcap file is given (key 'matcap')")
    # everything checked: now read the meshes and build the fields (a first render may compile
    # its film's kernels meanwhile, in a second process: tracer.scenes.compile_ahead)
    mode = top["mode"]
    film = Film(**_group(Film, top), shading=shading, matcap=matcap, lighting=lighting)
    start_ahead(March(**_group(March, top)), film, len(specs))
    objects = [_build_object(dict(sp, mode=mode), path, top["gradient"]) for sp in specs]
    weights = with_weights(objects, top["weights"], [
        sp["alpha"] == "auto" and sp["alpha_u"] == "auto" and sp["offset"] is None
        and mode == "smooth" for sp in specs])
    desc = data.get("description", "")
    march = March(**dict(_group(March, top), weights=weights))
    return with_default_eps(Scene(path=path, camera=pose, objects=objects,
                                  march=march, film=film, description=str(desc)))


#: top-level settings the loader reads by rules of their own: ``offset`` per object
#: (:func:`_object_spec`: an object's own wins), ``matcap`` a file (or an object's),
#: ``shading`` "matcap" by default when a matcap is named, ``lighting`` an object of fields
_OWN_RULES = {"offset", "matcap", "shading", "lighting"}
#: the command-line flag of an override whose flag is not the key's (``--size W H``)
_OVERRIDE_FLAGS = {"width": "--size width", "height": "--size height"}


def _top_settings(data, overrides, path):
    """``{key: value}`` of the scene file's top-level settings of the table (but
    :data:`_OWN_RULES`), each checked (:func:`tracer.scenes.settings.check`): the command
    line's override when given (named by its flag), else the file's value, else the file
    default."""
    if isinstance(data.get("newton"), bool) and overrides.get("newton") is None:
        raise file_error(path, "newton", f"must be a number (a multiple of eps; 0 turns Newton "
                                         f"steps off), got {show(data['newton'])}")
    out = {}
    for r in table():
        if not r.scene_key or r.key in _OWN_RULES:
            continue
        if overrides.get(r.key) is not None:
            out[r.key] = _setting(r.key, overrides[r.key], path,
                                  _OVERRIDE_FLAGS.get(r.key, flag_of(r.key)))
        elif r.key in data:
            out[r.key] = _setting(r.key, data[r.key], path, r.key)
        else:
            out[r.key] = r.file
    return out


def _setting(key, value, path, where):
    """:func:`tracer.scenes.settings.check` for a scene file (no null): a
    :class:`~tracer.errors.SceneError` ``<file name>: <where> <problem>``."""
    try:
        return check(key, value, where, none=False)
    except ValueError as exc:
        raise SceneError(f"{os.path.basename(path)}: {exc}") from None


def _group(cls, values):
    """The values of ``cls``'s fields (a settings group) in ``values``, by name."""
    return {f.name: values[f.name] for f in fields(cls) if f.name in values}


def _projection(cam, overrides, path):
    """``(projection, view_width)`` of a scene file's ``camera`` (the command line's
    ``--projection`` / ``--view-width``, when given, win)."""
    projection = overrides.get("projection") or cam.get("projection", "perspective")
    where = "--projection" if overrides.get("projection") else "camera.projection"
    projection = choice(projection, PROJECTIONS, path, where)
    view_width = cam.get("view_width")
    where = "camera.view_width"
    if overrides.get("view_width") is not None:
        view_width, where = overrides["view_width"], "--view-width"
    if view_width is None:
        return projection, None
    if projection != "orthographic":
        raise file_error(path, where, "applies to the orthographic projection only (give "
                                      "camera.projection \"orthographic\")")
    return projection, number(view_width, path, where, positive=True)


def with_default_eps(scene):
    """``scene``, its ``march.eps`` set to :func:`default_eps` when it is None."""
    if scene.march.eps is None:
        scene.march = dataclasses.replace(scene.march, eps=default_eps(scene))
    return scene


def default_eps(scene):
    """``1e-4 x`` the data's bounding-box diagonal (or the largest blur / offset for data of
    zero extent, such as a single point)."""
    ref = scene.diagonal
    if not ref > 0:
        ref = max(max(1.0 / o.alpha, o.offset) for o in scene.objects)
    return 1e-4 * max(ref, 1e-12)


def color(value, path, where):
    """``[r, g, b]`` integers 0-255 as a tuple of floats."""
    if (not isinstance(value, list) or len(value) != 3
            or not all(isinstance(v, int) and not isinstance(v, bool) and 0 <= v <= 255
                       for v in value)):
        raise file_error(path, where, f"must be [r, g, b] integers 0-255, got {show(value)}")
    return tuple(float(v) for v in value)


def _lighting(ld, override, path):
    """The ``lighting`` object as :class:`~tracer.rendering.lighting.Lighting` (``override``: a dict
    of already-checked values from the command line, applied on top)."""
    check_keys(ld, _LIGHTING_KEYS, path, "lighting")
    kw = {}
    for key in ("shadows", "ao", "ground"):
        if key in ld:
            if not isinstance(ld[key], bool):
                raise file_error(path, f"lighting.{key}", f"must be true or false, got "
                                                         f"{show(ld[key])}")
            kw[key] = ld[key]
    for key in ("penumbra", "ao_distance", "exposure"):
        if key in ld:
            kw[key] = number(ld[key], path, f"lighting.{key}", positive=True)
    if "ground_color" in ld:
        kw["ground_color"] = color(ld["ground_color"], path, "lighting.ground_color")
    if "key" in ld:
        key = vec3(ld["key"], path, "lighting.key")
        if not np.linalg.norm(key) > 0:
            raise file_error(path, "lighting.key", "must be a non-zero vector")
        kw["key"] = tuple(key)
    kw.update({k: v for k, v in (override or {}).items() if v is not None})
    try:
        return Lighting(**kw)
    except ValueError as exc:
        raise SceneError(f"{os.path.basename(path)}: {exc}") from None


def _object_spec(od, i, base, path, data, overrides, beta):
    """Validate one object's keys and files (no mesh is read); return a dict for
    :func:`_build_object`."""
    where = f"objects[{i}]"
    check_keys(od, _OBJECT_KEYS, path, where)
    if "path" in od and "parts" in od:
        raise file_error(path, where, "has both 'path' and 'parts'; give one")
    if "parts" in od:
        parts = od["parts"]
        if not isinstance(parts, list) or not parts:
            raise file_error(path, f"{where}.parts", f"must be a non-empty list, got {show(parts)}")
        specs = []
        for j, pd in enumerate(parts):
            pw = f"{where}.parts[{j}]"
            check_keys(pd, _PART_KEYS, path, pw)
            specs.append(_part_spec(pd, base, path, pw))
        merged = True
    elif "path" not in od:
        raise file_error(path, where, "is missing the required key 'path' (or 'parts')")
    else:
        specs = [_part_spec(od, base, path, where)]
        merged = False
    if i == 0 and overrides.get("alpha") is not None:
        alpha, alpha_where = overrides["alpha"], "--alpha"
        if alpha != "auto":
            alpha = number(alpha, path, "--alpha", positive=True)
    elif "alpha" not in od:
        raise file_error(path, where, "is missing the required key 'alpha'")
    elif od["alpha"] == "auto":
        alpha, alpha_where = "auto", f"{where}.alpha"
    else:
        if isinstance(od["alpha"], str):
            raise file_error(path, f"{where}.alpha", f"must be a number or \"auto\", got "
                                                     f"{show(od['alpha'])}")
        alpha = number(od["alpha"], path, f"{where}.alpha", positive=True)
        alpha_where = f"{where}.alpha"
    if i == 0 and overrides.get("alpha_u") is not None:
        alpha_u, au_where = overrides["alpha_u"], "--alpha-u"
    else:
        key = _spelling(od, "alpha_u", path, where)
        alpha_u, au_where = od.get(key, _FILE["alpha_u"]), f"{where}.{key}"
    if alpha_u == "off" and au_where == "--alpha-u":
        pass  # no attenuation: alpha_U = alpha, once alpha is known (the command line only)
    elif alpha_u != "auto":
        if isinstance(alpha_u, str):
            raise file_error(path, au_where, f"must be a number or \"auto\", got {show(alpha_u)}")
        alpha_u = number(alpha_u, path, au_where, positive=True)
    obeta = (number(od["beta"], path, f"{where}.beta", non_negative=True)
             if "beta" in od and overrides.get("beta") is None else beta)
    if overrides.get("offset") is not None:
        offset = number(overrides["offset"], path, "--offset", non_negative=True)
    elif "offset" in od:
        offset = number(od["offset"], path, f"{where}.offset", non_negative=True)
    elif "offset" in data:
        offset = number(data["offset"], path, "offset", non_negative=True)
    else:
        offset = None
    matcap = od.get("matcap", "")
    if not isinstance(matcap, str):
        raise file_error(path, f"{where}.matcap",
                         f"must be a file path or \"\", got {show(matcap)}")
    matcap = resolve_path(base, matcap, path, f"{where}.matcap") if matcap else ""
    name = od.get("name", os.path.basename(od.get("path", f"object{i}")))
    if not isinstance(name, str):
        raise file_error(path, f"{where}.name", f"must be a string, got {show(name)}")
    ocolor = color(od["color"], path, f"{where}.color") if "color" in od else None
    return dict(where=where, parts=specs, merged=merged, merged_name=od.get("name", "mixed"),
                alpha=alpha, alpha_where=alpha_where, alpha_u=alpha_u, beta=obeta,
                offset=offset, matcap=matcap, name=name, color=ocolor)


def _spelling(od, key, path, where):
    """The key of ``od`` that holds the setting ``key``: ``key`` itself, or its authors'
    spelling (``AUTHORS_KEYS``) when only that is given; a file giving both is refused."""
    old = next(o for o, k in AUTHORS_KEYS.items() if k == key)
    if key in od and old in od:
        raise file_error(path, where, f"has both {key!r} and {old!r} (the authors' spelling of "
                                      f"{key!r}); give one")
    return old if old in od else key


def _part_spec(pd, base, path, where):
    full = resolve_path(base, pd.get("path"), path, f"{where}.path")
    key = _spelling(pd, "kind", path, where)
    values = BVH_TYPES if key == "bvh_type" else {k: k for k in KINDS}
    kind = values[choice(pd.get(key, "mixed"), tuple(values), path, f"{where}.{key}")]
    scale = number(pd["scale"], path, f"{where}.scale", positive=True) if "scale" in pd else 1.0
    shift = vec3(pd["translate"], path, f"{where}.translate") if "translate" in pd else np.zeros(3)
    return dict(where=where, full=full, kind=kind, scale=scale, shift=shift)


def with_weights(objects, weights, automatic):
    """Give every object's field the weight scheme ``weights`` (one of
    :data:`~tracer.scenes.settings.WEIGHT_CHOICES`; ``"auto"``: ``"inclusion-exclusion"`` when
    every object's surface is the automatic one, ``automatic`` a bool per object, ``"paper"``
    otherwise: one scheme per scene, as its objects' trees make one forest). Returns the
    scheme."""
    if weights not in WEIGHT_CHOICES:
        raise ValueError(f"weights must be one of {', '.join(map(repr, WEIGHT_CHOICES))}, "
                         f"got {weights!r}")
    weights = planned_weights(weights, all(automatic))
    for o in objects:
        o.field = o.field.with_weights(weights)
    return weights


def planned_weights(weights, automatic):
    """The scheme :func:`with_weights` gives a scene of the ``weights`` setting whose objects
    all have the automatic surface (``automatic``, :func:`automatic_surface`) or not, so that
    a field can be built with it from the start; ``"paper"`` for a name it refuses."""
    if weights == "auto":
        return "inclusion-exclusion" if automatic else "paper"
    return weights if weights in WEIGHT_CHOICES else "paper"


def _build_object(spec, path, gradient):
    """Read an object's meshes, build its field and check its parameters against the data."""
    meshes = [_part_mesh(ps, path) for ps in spec["parts"]]
    if spec["merged"]:
        try:
            mesh = merge_meshes(meshes, name=spec["merged_name"])
        except ValueError as exc:
            raise file_error(path, f"{spec['where']}.parts", f"cannot be merged: {exc}") from None
    else:
        mesh = meshes[0]
    fld = SmoothDistanceField(mesh)
    if spec["alpha"] == "auto" and spec["alpha_u"] == "auto" and spec["offset"] is None \
            and spec.get("mode") == "smooth":
        # all three left to "auto": chosen together (edges and triangles: a level set
        # about an edge length out, without dimples; issue 35)
        alpha, alpha_u, smooth_offset = fld.auto_surface()
        offset = 1.0 / alpha
    else:
        alpha = fld.auto_alpha() if spec["alpha"] == "auto" else spec["alpha"]
        alpha_u = (fld.auto_alpha_u(alpha) if spec["alpha_u"] == "auto" else
                   alpha if spec["alpha_u"] == "off" else spec["alpha_u"])
        offset = spec["offset"] if spec["offset"] is not None else 1.0 / alpha
        smooth_offset = spec["offset"] if spec["offset"] is not None else 0.0
    try:
        fld.check_alpha(alpha)
    except ValueError as exc:
        raise file_error(path, spec["alpha_where"], f"is unusable: {exc}") from None
    fld.kernel_args(alpha, spec["beta"], alpha_u, gradient)
    return SceneObject(name=str(spec["name"]), field=fld, alpha=float(alpha),
                       alpha_u=float(alpha_u), beta=spec["beta"], offset=float(offset),
                       matcap=spec["matcap"], color=spec["color"],
                       smooth_offset=float(smooth_offset))


def _part_mesh(ps, path):
    full, kind, where = ps["full"], ps["kind"], ps["where"]
    try:
        mesh = smoothdist.load_mesh(full, kind=None if kind == "mixed" else kind)
    except ValueError as exc:
        msg = str(exc)
        name = os.path.basename(full)
        msg = msg[len(name) + 2:] if msg.startswith(f"{name}: ") else msg
        raise file_error(path, f"{where}.path", f"({name}): {msg}") from None
    scale, shift = ps["scale"], ps["shift"]
    if scale != 1.0 or np.any(shift):
        try:
            mesh = DataMesh(mesh.V * scale + shift, points=mesh.points, edges=mesh.edges,
                            triangles=mesh.triangles, name=mesh.name)
        except ValueError as exc:
            raise file_error(path, f"{where}.scale/translate",
                             f"give unusable data: {exc}") from None
    return mesh


def merge_meshes(meshes, name="mixed"):
    """Concatenate several :class:`~smoothdist.DataMesh` into one mixed mesh over a shared vertex
    array."""
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


@settings_entry("api")
def scene_from_field(field, *, camera=None, name="scene", settings):
    """Build a one-object :class:`Scene` in code (no JSON), e.g. for parameter studies.

    Parameters
    ----------
    field : smoothdist.SmoothDistanceField
        The object's data (built once; reuse it across renders).
    alpha : float or "auto"
        As in the scene file; ``"auto"`` is ``field.auto_alpha()``.
    alpha_u : float, "auto", "off" or None
        As ``alpha_u`` in the scene file; ``"auto"`` is ``field.auto_alpha_u(alpha)`` (no
        ribbing); ``"off"`` (the default here, unlike scene files: see
        :mod:`tracer.scenes.settings`) or None is ``alpha``, i.e. no attenuation.
    beta : float
        Barnes-Hut parameter.
    view : str, optional
        A key of :data:`tracer.rendering.camera.VIEWS` (``"front"``, ``"iso"``, ...): a camera
        framing the whole surface from that side (:func:`tracer.rendering.camera.frame_points`:
        the data's vertices grown by the inflation bound, which contains the surface), as
        ``mesh_scene``'s ``view``. Default (with ``camera`` None too): the paper's beta-study
        camera (bbox centre + 2 x the largest extent along +z, looking at the centre, up +y),
        which may crop a blurry surface.
    camera : (origin, dest, up) or tracer.rendering.camera.Camera, optional
        The camera itself: three 3-vectors, or a render's ``res.camera``; instead of ``view``.
        A view name here still works, with a ``DeprecationWarning`` (until 0.2).
    mode : {"smooth", "exact"}
        The smooth distance's isosurface, or the exact distance's offset surface.
    offset : float, optional
        The level of the surface (finite, >= 0), as the scene key ``offset``: smooth mode
        ``d_hat = offset`` (default 0), exact mode ``d = offset`` (default ``1/alpha``).
    tol : float
        Tolerance-controlled pruning (>= 0; 0 = off), as the scene key ``tol``.
    newton : float, optional
        Smooth mode: Newton steps once the distance is below ``newton x eps`` (>= 0; 0 =
        plain sphere tracing; default ``tracer.rendering.march.NEWTON``), as the scene key
        ``newton``.
    up : {"x", "y", "z"}
        The data's up axis, for ``view``
        (:func:`tracer.rendering.camera.view_vectors`).
    samples : int
        Anti-aliasing samples per pixel (1 to ``tracer.rendering.frame.MAX_SAMPLES``), as the scene
        key.
    adaptive : bool
        Extra samples only where neighbouring pixels disagree (:mod:`tracer.rendering.film`).
    transparent : bool
        Leave the background transparent: RGBA PNGs whose alpha is the coverage.
    lighting : tracer.rendering.lighting.Lighting or dict, optional
        Settings of the ``"lit"`` shading (a dict of its fields; default ``Lighting()``).
    color : (3,) int, optional
        Base colour of the object in the ``"lit"`` shading, sRGB 0-255.
    background : (3,) int
        Background colour, sRGB 0-255.
    projection : {"perspective", "orthographic"}
        The authors' pinhole, or parallel rays (:mod:`tracer.rendering.camera`); a
        ``camera`` given as a render's ``res.camera`` keeps its own unless this says
        ``"orthographic"``.
    view_width : float, optional
        Orthographic: the image's width in scene units. None: the width that frames the
        surface (with ``view``), else the width the perspective camera sees at ``dest``.
    weights : {"paper", "inclusion-exclusion", "auto"}
        The weights of edges and triangles (:mod:`smoothdist.junctions`): the paper's
        polynomials (the default here), inclusion-exclusion over the junctions (no seams on
        flat faces), or ``"auto"``: inclusion-exclusion for the automatic surface (alpha,
        alpha_u and offset ``"auto"``), the paper's otherwise. The scene's object gets
        ``field.with_weights(...)``; ``field`` itself is not changed.
    name : str
        The scene's name.
    """
    return field_scene(field, *settings, camera=camera, name=name)


def field_scene(field, surface, march, film, view=View(), camera=None, name="scene"):
    """:func:`scene_from_field` with its settings as the groups of
    :mod:`tracer.scenes.settings`: ``surface`` (:class:`~tracer.scenes.settings.Surface`),
    ``march``, ``film`` and ``view`` hold the keyword arguments of the same names, unchecked;
    each is checked here (a ``ValueError`` naming the setting) and the scene holds the checked
    groups. ``camera`` as in :func:`scene_from_field`."""
    surface, march, film = (_checked(surface, _API_CHECKED), _checked(march, _API_CHECKED),
                            _checked(film, _API_CHECKED))
    if film.width * film.height > MAX_PIXELS:
        raise ValueError(f"width x height is {film.width}x{film.height}: larger than "
                         f"{MAX_PIXELS // 1_000_000} megapixels")
    automatic = automatic_surface(surface, march)
    surface, beta = _api_surface(field, surface, march)
    march = dataclasses.replace(march, beta=beta, newton=_NEWTON if march.newton is None
                                else march.newton)
    camera = _api_camera(field, _view_or_camera(view.view, camera), surface, march, film, view)
    offset = surface.offset
    obj = SceneObject(name=name, field=field, alpha=surface.alpha, alpha_u=surface.alpha_u,
                      beta=beta, offset=offset if offset is not None else 1.0 / surface.alpha,
                      matcap=film.matcap, color=surface.color,
                      smooth_offset=offset if offset is not None else 0.0)
    march = dataclasses.replace(march, weights=with_weights([obj], march.weights, [automatic]))
    return with_default_eps(Scene(path=f"{name}.json", camera=camera, objects=[obj],
                                  march=march, film=film))


#: the settings :func:`field_scene` checks (:func:`tracer.scenes.settings.check`); the view's
#: are the camera's (:func:`_api_camera`), ``matcap`` is read by the renderer (a path)
_API_CHECKED = {"alpha", "alpha_u", "offset", "color", "mode", "beta", "eps", "tol", "newton",
                "max_steps", "gradient", "weights", "width", "height", "samples", "adaptive",
                "transparent", "background", "shading", "lighting"}
#: ``newton=None`` of :func:`scene_from_field`: the default
_NEWTON = March().newton


def _checked(group, keys):
    """``group`` (a frozen settings group) with its fields in ``keys`` checked and normalised
    (:func:`tracer.scenes.settings.check`: a ``ValueError`` naming the keyword)."""
    return dataclasses.replace(group, **{f.name: check(f.name, getattr(group, f.name))
                                         for f in fields(group) if f.name in keys})


def automatic_surface(surface, march):
    """Whether ``surface`` leaves alpha, alpha_U and the offset to ``"auto"`` in smooth mode:
    the automatic surface (:meth:`smoothdist.SmoothDistanceField.auto_surface`)."""
    return (isinstance(surface.alpha, str) and surface.alpha == "auto"
            and isinstance(surface.alpha_u, str) and surface.alpha_u == "auto"
            and surface.offset is None and march.mode == "smooth")


def _api_surface(field, surface, march):
    """``(surface, beta)`` of :func:`field_scene`: ``"auto"`` and ``"off"`` resolved, alpha,
    alpha_U and beta checked together against the data (``offset`` None: the mode's default
    level)."""
    alpha, alpha_u, offset = surface.alpha, surface.alpha_u, surface.offset
    if automatic_surface(surface, march):
        # all three left to "auto": chosen together (issue 35; see
        # SmoothDistanceField.auto_surface)
        alpha, alpha_u, offset = field.auto_surface()
        offset = offset if offset > 0 else None
    if isinstance(alpha, str) and alpha == "auto":
        alpha = field.auto_alpha()
    if isinstance(alpha_u, str) and alpha_u == "auto":
        alpha_u = field.auto_alpha_u(field.check_alpha(alpha))
    alpha_u = alpha if alpha_u is None or (isinstance(alpha_u, str) and alpha_u == "off") \
        else alpha_u
    # validates alpha, beta and alpha_U together
    alpha, beta, _, _ = field.kernel_args(alpha, march.beta, alpha_u, march.gradient)
    return dataclasses.replace(surface, alpha=alpha, alpha_u=float(alpha_u), offset=offset), beta


def _view_or_camera(view, camera):
    """What :func:`_api_camera` frames: ``view`` (a name) or ``camera`` (vectors); a name given
    as ``camera`` (the old spelling) warns and counts as ``view``."""
    if isinstance(camera, str):
        warnings.warn(f"scene_from_field(camera={camera!r}): a view name is view={camera!r} now; "
                      "camera= takes (origin, dest, up) (the old use goes in the next release)",
                      DeprecationWarning, stacklevel=user_stacklevel())
        if view is None:
            camera, view = None, camera
    if view is not None and camera is not None:
        raise ValueError("give view (a name) or camera (origin, dest, up), not both")
    return camera if view is None else view


def _api_camera(field, camera, surface, march, film, view):
    """The :class:`~tracer.rendering.camera.LookAt` of :func:`field_scene`'s ``camera``: three
    vectors, a render's camera, a view name framing the surface (``view.up``: the data's up
    axis), or None (the paper's beta-study camera), with ``view``'s projection; validated."""
    lo, hi = field.bounds
    alpha, alpha_u, offset, eps = surface.alpha, surface.alpha_u, surface.offset, march.eps
    projection, view_width = check_projection(view.projection, view.view_width)
    if hasattr(camera, "forward") and hasattr(camera, "vertical"):
        # a tracer.rendering.camera.Camera (a render's ``res.camera``): the same view
        if projection == "perspective" and camera.projection == "orthographic":
            projection, view_width = camera.projection, camera.view_width
        camera = (camera.origin, np.asarray(camera.origin) + np.asarray(camera.forward),
                  camera.vertical)
    elif isinstance(camera, LookAt) and projection == "perspective":
        projection, view_width = camera.projection, camera.view_width
    fit = None
    if isinstance(camera, str):
        # the surface lies within its inflation bound plus its offset (exact mode: the
        # offset) of the data
        grow = (offset if march.mode == "exact" and offset is not None else
                1.0 / alpha if march.mode == "exact" else
                field.inflation(alpha, alpha_u) + (offset or 0.0))
        fit = (field.mesh.used_vertices(), grow + 2.0 * (eps or 0.0))
        camera = frame_points(*fit, camera, film.width, film.height, up=view.up)
    elif camera is None:
        c = 0.5 * (lo + hi)
        # a single point (or identical points) has no extent: back off by the surface's size
        ext = max(float((hi - lo).max()), field.inflation(alpha, alpha_u) + (offset or 0.0),
                  offset if offset is not None else 1.0 / alpha)
        camera = (c + np.array([0.0, 0.0, 2.0 * ext]), c, np.array([0.0, 1, 0]))
    try:
        origin, dest, up = (np.asarray(v, dtype=float) for v in tuple(camera)[:3])
    except (TypeError, ValueError):
        raise ValueError(f"camera must be (origin, dest, up), three 3-vectors; got {camera!r}") \
            from None
    if projection == "orthographic" and view_width is None and fit is not None:
        view_width = frame_width(*fit, (origin, dest, up), film.width, film.height)
    pose = LookAt(origin, dest, up, projection, view_width)
    pose.camera(film.width, film.height)  # validates the camera
    return pose
