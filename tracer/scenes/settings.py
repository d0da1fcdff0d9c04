"""A scene's settings, their defaults and their valid values, written once.

Every option of a render is a field of one of the frozen dataclasses below (plus the
existing :class:`~tracer.rendering.lighting.Lighting`); its default is the field's default, its
one-line meaning the field's ``help``, and its type and valid values (a number's range, a
string's choices, the words a number may be replaced by, such as ``"auto"``) the field's too.
:func:`check` checks a value against them. The interfaces are made from this table:

* the scene file loader (:func:`tracer.scenes.scene.load_scene`, its keys ``_TOP_KEYS``) and the
  :class:`~tracer.scenes.scene.Scene` dataclass: ``defaults("file")``; the loader reads the
  top-level settings by a loop over :func:`table` with :func:`check`;
* :func:`tracer.scenes.scene.scene_from_field`, the research API over a built field:
  ``defaults("api")``, its keywords made by :func:`settings_entry`;
* :func:`tracer.render_mesh`, :func:`tracer.mesh_scene` and ``tracer render MESH``:
  ``defaults("mesh")``, the keywords made by :func:`settings_entry`;
* ``tracer render``'s options for the settings (:func:`tracer.cli_render.add_arguments`, their
  ``type=`` :func:`check`) and the settings' keys of the JSON Schema
  ``tracer/scenes/scene.schema.json`` (:func:`tracer.scenes.scene_schema.setting_properties`),
  which ``tests/tracer/scenes/test_settings.py`` checks against this table.

Where an entry point deliberately differs, the field says so (``api=`` / ``mesh=``) and
:func:`table` lists the reason:

* ``shading``: ``"normals"`` in scene files (``"matcap"`` when one names a matcap) and in
  ``scene_from_field``, ``"lit"`` for the mesh entry points: scene files and the research API
  draw the paper's normal colours (the golden images), a user's mesh gets a lit picture;
* ``alpha``: required by scene files and ``scene_from_field`` (the authors' format names it),
  ``"auto"`` for the mesh entry points;
* ``alpha_u``: ``"auto"`` in scene files (an object without ``alpha_u``) and for the mesh
  entry points, ``"off"`` in ``scene_from_field``: the parameter studies and golden images
  vary alpha alone over the paper's unattenuated weights;
* ``weights``: ``"paper"`` in scene files and ``scene_from_field`` (the paper's weight
  polynomials: the golden images and the studies), ``"auto"`` for the mesh entry points
  (inclusion-exclusion for the automatic surface, :mod:`smoothdist.junctions`: a user's flat
  faces without seams);
* ``view`` and ``up``: scene files carry their camera; ``scene_from_field``'s ``view=None``
  is the paper's beta-study camera, with up ``"y"``; the mesh entry points frame the
  ``"front"`` view with up ``"auto"`` (a mesh file's extension tells its up axis).

Everything else has one default everywhere.
"""

import dataclasses
import functools
import inspect
import math
import numbers
import textwrap
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from smoothdist.junctions import WEIGHTS
from smoothdist.kernels import DEFAULT_TOL
from tracer.rendering.camera import PROJECTIONS, UP_AXES, VIEWS
from tracer.rendering.frame import MAX_SAMPLES
from tracer.rendering.lighting import Lighting
from tracer.rendering.march import NEWTON
from tracer.validate import show

__all__ = ["View", "March", "Film", "Surface", "GROUPS", "ENTRIES", "KINDS", "Row", "table",
           "defaults", "default_text", "flag_of", "REQUIRED", "SCENE_KEYS", "row", "check",
           "Groups", "groups", "split_size", "settings_entry", "MODES", "SHADINGS", "GRADIENTS",
           "WEIGHT_CHOICES", "MAX_PIXELS", "MAX_STEPS", "RGB", "LIGHTING_KEYS", "table_index"]

#: the kinds of data an object draws (``kind=`` of the mesh entry points, ``kind`` of scene
#: files): its triangles, its edges, its points, or everything its file holds
KINDS = ("triangles", "edges", "points", "mixed")

#: the entry points: scene files (and ``Scene``), ``scene_from_field``, the mesh entry points
ENTRIES = ("file", "api", "mesh")

#: the surfaces a scene draws (``mode``)
MODES = ("smooth", "exact")
#: the shadings of a scene (``shading``)
SHADINGS = ("normals", "matcap", "headlight", "lit")
#: the normal's gradient (``gradient``)
GRADIENTS = ("metric", "exact")
#: ``weights`` of a scene: the schemes of :mod:`smoothdist.junctions`, or ``"auto"``
WEIGHT_CHOICES = ("auto",) + WEIGHTS
#: largest image, in pixels (about 150 bytes of buffers per pixel)
MAX_PIXELS = 64_000_000
#: largest number of distance evaluations per ray (bounds the time of any render)
MAX_STEPS = 1_000_000
#: the ``kind`` of a colour setting: three numbers 0-255 (``[r, g, b]``)
RGB = "rgb"


class _Required:
    """The default of a setting an entry point requires (no default)."""

    def __repr__(self):
        return "REQUIRED"


#: marks a setting an entry point requires
REQUIRED = _Required()
_SAME = object()


def _opt(default, help, *, api=_SAME, mesh=_SAME, file=_SAME, why="", text=None, key=True,
         kind=str, choices=(), words=(), none=False, above=None, at_least=None, at_most=None,
         item=int, flag=True, metavar=None, doc=None, example=None):
    """A setting: ``default`` everywhere unless ``file`` / ``api`` / ``mesh`` say otherwise
    (``why`` gives the reason); ``text`` describes a default computed at load time (shown
    instead of None); ``key=False``: not a top-level scene-file key.

    Its values (:func:`check`): ``kind`` (``float``, ``int``, ``bool``, ``str``,
    :data:`RGB`: three numbers 0-255, integers for ``item=int``, or ``Lighting``), one of
    ``choices``, or one of the ``words`` a number may be replaced by; None where ``none``
    (the API's "not given"); numbers ``> above``, ``>= at_least`` and ``<= at_most``.
    ``flag=False``: no ``tracer render`` option of its name; ``metavar``: the option's value
    in its help; ``doc`` and ``example``: the scene format reference's description (default:
    ``help``) and example."""
    return dataclasses.field(default=default, metadata=dict(
        help=help, file=default if file is _SAME else file, api=default if api is _SAME else api,
        mesh=default if mesh is _SAME else mesh, why=why, text=text, key=key, kind=kind,
        choices=tuple(choices), words=tuple(words), none=none, above=above, at_least=at_least,
        at_most=at_most, item=item, flag=flag, metavar=metavar, doc=doc, example=example))


@dataclass(frozen=True)
class View:
    """How a camera is chosen when it is not given as three vectors (scene files always give
    ``camera: {origin, dest, up}``): the side it frames the surface from, and the data's up
    axis; and its projection (scene files: ``camera.projection``, ``camera.view_width``).
    The camera itself is :class:`tracer.rendering.camera.Camera`."""

    view: str = _opt(None, "camera framing the whole surface from this side (front, back, "
                     "left, right, top, iso)",
                     mesh="front", file=REQUIRED, key=False, choices=tuple(VIEWS), none=True,
                     why="scene files carry their camera; the API's None is the paper's "
                         "beta-study camera")
    up: str = _opt("y", "the data's up axis for a view (x, y, z; auto: z for .stl and .ply "
                   "files and trimesh / pyvista objects, y otherwise; for the front view a "
                   "flat object seen edge-on or a long one end-on is turned to its largest "
                   "silhouette)", mesh="auto",
                   file=REQUIRED, key=False, choices=("auto",) + UP_AXES,
                   why="a mesh file's extension tells its up axis")
    projection: str = _opt("perspective", "perspective (the authors' pinhole) or orthographic "
                           "(parallel rays, as pyvista's parallel projection)", key=False,
                           choices=PROJECTIONS)
    view_width: float = _opt(None, "orthographic: the view's width in scene units", key=False,
                             text="the width framing the surface (a view), or the "
                                  "perspective camera's width at dest",
                             kind=float, above=0, none=True, metavar="W")


@dataclass(frozen=True)
class March:
    """The sphere tracer's settings: which surface, and how rays step to it."""

    mode: str = _opt("smooth", "smooth: the isosurface d_hat = offset of the smooth "
                     "distance; exact: the exact offset surface d = offset", choices=MODES,
                     doc="`smooth`: the isosurface d_hat = offset of the smooth distance (offset "
                         "0 by default); `exact`: the exact offset surface d = offset.",
                     example="exact")
    beta: float = _opt(0.5, "Barnes-Hut parameter: 0 evaluates every primitive exactly "
                       "(slow); larger is faster and coarser", kind=float, at_least=0,
                       example=0.5)
    eps: float = _opt(None, "hit threshold in scene units",
                      text="1e-4 x the data's bbox diagonal", kind=float, above=0, none=True,
                      example=0.001)
    tol: float = _opt(DEFAULT_TOL, "tolerance-controlled pruning: d_hat within "
                      "log(1 + tol)/alpha of the exact sum, never above it (0 = off; with "
                      "beta 0 the only pruning)", kind=float, at_least=0, metavar="TOL",
                      doc="Tolerance-controlled pruning: a subtree is replaced by its "
                          "conservative far field when that bound is below tol x the running "
                          "sum; 0 turns it off.", example=0.001)
    newton: float = _opt(NEWTON, "smooth mode: Newton steps along the ray once the distance "
                         "is below newton x eps and 1 % of the bbox diagonal (0 = plain "
                         "sphere tracing)", kind=float, at_least=0, none=True, metavar="N",
                         doc="Smooth mode: Newton steps along the ray once the distance is "
                             "below newton x eps (and 1 % of the bbox diagonal), for fewer "
                             "evaluations and more accurate depths. A Newton step is not "
                             "certified empty, so it can step over a sliver thinner than 4 x "
                             "newton x eps (fine relief seen at grazing angles); 0 turns them "
                             "off (plain sphere tracing). A number, not a boolean. Exact mode "
                             "ignores it.", example=0)
    max_steps: int = _opt(1000, "largest number of distance evaluations per ray", kind=int,
                          above=0, at_most=MAX_STEPS, flag=False, example=2000)
    gradient: str = _opt("metric", "the normal's gradient: metric (the paper's) or exact",
                         choices=GRADIENTS, flag=False,
                         doc="Normals from the paper's alpha-metric gradient (the renders' "
                             "default, as in the paper's figures; the library's queries "
                             "default to exact), or the exact derivative of d_hat.",
                         example="exact")
    weights: str = _opt("paper", "weights of edges and triangles: paper (the paper's "
                        "polynomials), inclusion-exclusion (the exact distance's sum above flat "
                        "faces and outside convex edges: no seams), or auto: "
                        "inclusion-exclusion for the automatic surface (alpha, alpha_u and "
                        "offset auto), paper otherwise", mesh="auto",
                        why="scene files and the research API keep the paper's weights "
                            "(golden images); a user's mesh gets the seam-free automatic "
                            "surface", choices=WEIGHT_CHOICES,
                        doc="Weights of edges and triangles: the paper's polynomials; "
                            "inclusion-exclusion over the junctions (the exact distance's sum "
                            "above flat faces and outside convex edges and corners: no seams "
                            "along the internal edges of flat faces; for alpha large against "
                            "the edges); auto: inclusion-exclusion when every object's alpha, "
                            "alpha_u and offset are auto (smooth mode), paper otherwise.",
                        example="inclusion-exclusion")


@dataclass(frozen=True)
class Film:
    """The image: its size, its samples, its background and how hits are shaded."""

    width: int = _opt(512, "image width in pixels", kind=int, above=0, flag=False,
                      doc="Image width in pixels (width x height <= 64 megapixels).",
                      example=256)
    height: int = _opt(512, "image height in pixels", kind=int, above=0, flag=False,
                       example=256)
    samples: int = _opt(1, "anti-aliasing samples per pixel, tent-filtered", kind=int, above=0,
                        at_most=MAX_SAMPLES, metavar="N",
                        doc="Anti-aliasing samples per pixel: a low-discrepancy pattern "
                            "distributed like a tent filter of radius one pixel; depth, normals "
                            "and hit come from the pixel's centre sample.", example=16)
    adaptive: bool = _opt(False, "extra samples only to pixels that differ from a neighbour "
                          "(edges, shadow borders)", kind=bool,
                          doc="Give the samples beyond the first only to pixels whose centre "
                              "sample disagrees with a neighbour's (hit, object, ground, "
                              "colour): 4 samples, then all of them where those 4 still "
                              "disagree.", example=True)
    transparent: bool = _opt(False, "RGBA output whose alpha is the pixel's coverage (with the "
                             "lit shading's ground: its shadow only)", kind=bool,
                             doc="Leave the background transparent: the PNG is RGBA and its "
                                 "alpha is the pixel's coverage (with the lit shading's ground: "
                                 "the shadow it catches).", example=True)
    background: tuple = _opt((255, 255, 255), "background colour [r, g, b], 0-255", kind=RGB,
                             metavar=("R", "G", "B"), example=[0, 0, 0])
    shading: str = _opt("normals", "lit (lights, shadows, ambient occlusion, a ground), "
                        "normals (the paper's view-space normal colours), matcap or headlight",
                        mesh="lit", text='"matcap" when a matcap is given, else "normals"',
                        why="scene files and the research API draw the paper's normal "
                            "colours (golden images); a user's mesh gets a lit picture",
                        choices=SHADINGS,
                        doc="View-space normal colours (the paper's), a matcap, a diffuse "
                            "headlight, or \"lit\": key and fill lights, soft shadows and "
                            "ambient occlusion traced through the same distance, and a ground "
                            "(see lighting).", example="headlight")
    matcap: str = _opt("", "matcap image (PNG) for the matcap shading; \"\" for none",
                       flag=False, doc="Matcap image (PNG) for `matcap` shading; \"\" for none.",
                       example="data/textures/jade_matcap.png")
    lighting: Lighting = _opt(Lighting(), "settings of the lit shading "
                              "(tracer.rendering.lighting.Lighting)", kind=Lighting, flag=False)


@dataclass(frozen=True)
class Surface:
    """The (first) object's surface: sharpness, attenuation, level and colour."""

    alpha: float = _opt(REQUIRED, "sharpness (1 / scene units), or auto: with alpha_u and "
                        "offset auto too, triangles get a thin shell, the level set d_hat = C "
                        "at C = 0.3 % of the bbox diagonal or a tenth of the local feature "
                        "size, alpha 20/C; curves a tube, C = 0.75 mean edge lengths, alpha "
                        "6/C (30/C for wireframes); otherwise mean surface offset <= 2 % of "
                        "the bbox diagonal", mesh="auto", key=False,
                        why="the authors' format and the research API name alpha",
                        kind=float, above=0, words=("auto",), metavar="A")
    alpha_u: float = _opt("auto", "attenuation threshold alpha_U: auto = 20 x alpha (no "
                          "ribbing on tubes), off = alpha (no attenuation: the paper's weights "
                          "even out an uneven triangle tessellation that auto shows as pleats)",
                          api="off", key=False,
                          why="the parameter studies and golden images vary alpha alone "
                              "over the paper's unattenuated weights",
                          kind=float, above=0, words=("auto", "off"), none=True, metavar="U")
    offset: float = _opt(None, "the level of the surface: smooth mode d_hat = offset, exact "
                         "mode d = offset",
                         text="exact mode: 1 / alpha, per object; smooth mode: 0",
                         kind=float, at_least=0, none=True, metavar="C",
                         doc="The level of every object's surface (an object's own offset "
                             "wins): exact mode the offset surface d = offset, smooth mode the "
                             "isosurface d_hat = offset.", example=0.02)
    color: tuple = _opt(None, "lit shading: base colour [r, g, b] 0-255 of the object",
                        key=False, text="a light clay for one object; a palette for several",
                        kind=RGB, item=float, none=True, metavar=("R", "G", "B"))


#: the settings groups, in the order of the reference table
GROUPS = (View, March, Film, Surface)


@dataclass(frozen=True)
class Row:
    """One setting: its group, name, default per entry point, meaning and reasons, and its
    valid values (as ``_opt`` takes them)."""

    group: str
    key: str
    file: object
    api: object
    mesh: object
    help: str
    text: str
    why: str
    scene_key: bool
    kind: object = str
    choices: tuple = ()
    words: tuple = ()
    none: bool = False
    above: float = None
    at_least: float = None
    at_most: float = None
    item: type = int
    flag: bool = True
    metavar: object = None
    doc: str = None
    example: object = None


def table():
    """Every setting as a :class:`Row`, groups in :data:`GROUPS` order."""
    return list(_ROWS.values())


def _rows():
    out = {}
    for group in GROUPS:
        for f in dataclasses.fields(group):
            m = dict(f.metadata)
            m["scene_key"] = m.pop("key")
            out[f.name] = Row(group.__name__, f.name, **m)
    return out


_ROWS = _rows()


def row(key):
    """The :class:`Row` of the setting ``key`` (a ``KeyError`` for an unknown one)."""
    return _ROWS[key]


def defaults(entry):
    """``{key: default}`` of one entry point (``"file"``, ``"api"`` or ``"mesh"``)."""
    if entry not in ENTRIES:
        raise ValueError(f"entry must be one of {ENTRIES}, got {entry!r}")
    return {r.key: getattr(r, entry) for r in table()}


def flag_of(key):
    """The ``tracer render`` option of the setting ``key``: ``alpha_u`` -> ``--alpha-u``."""
    return "--" + key.replace("_", "-")


def default_text(key, entry="file"):
    """The default of ``key`` as help text shows it (``1e-4 x ...`` for computed ones)."""
    r = row(key)
    value = getattr(r, entry)
    if value is None and r.text:
        return r.text
    if isinstance(value, tuple):
        return " ".join(str(v) for v in value)
    if isinstance(value, bool):
        return "on" if value else "off"
    return f"{value:g}" if isinstance(value, float) else str(value)


#: the top-level scene-file keys the table defines (``camera``, ``objects``, ``description``
#: and ``name`` are the scene file's own)
SCENE_KEYS = frozenset(r.key for r in table() if r.scene_key)


# ---------------------------------------------------------------------- checking
def check(key, value, where=None, *, none=True, typed=False):
    """``value`` of the setting ``key`` checked against its field (``_opt``) and
    normalised: a float for a number, an int for an integer, a bool, a tuple for a colour, a
    :class:`~tracer.rendering.lighting.Lighting` for ``lighting`` (a dict of its fields too);
    a word (``"auto"``) or None (where the field allows it, and ``none``) as given.

    Raises ``ValueError`` with the one-line message ``<where> <problem>``; ``where`` names
    the value for its reader (the keyword, a command-line flag, a scene file's key; default
    ``key``). The scene loader, :func:`tracer.scenes.scene.field_scene` and ``tracer render``'s
    options all check with it; ``typed``: the message words the rule as a command line's
    values are typed (an integer's bound as its smallest value, ``>= 1``; a colour as three
    integers, ``got 300 0 0``)."""
    try:
        return _checked(row(key), value, none, typed)
    except ValueError as exc:
        raise ValueError(f"{where or key} {exc}") from None


def _checked(r, value, none, typed=False):
    """:func:`check`'s value, or a ``ValueError`` saying what is wrong (without the name)."""
    if value is None and r.none and none:
        return None
    if r.words and isinstance(value, str):
        if value in r.words:
            return value
        raise ValueError(f"must be a number or {' or '.join(map(show, r.words))}, "
                         f"got {show(value)}")
    if r.choices:
        if not isinstance(value, str) or value not in r.choices:
            raise ValueError(f"must be one of {', '.join(r.choices)}; got {show(value)}")
        return value
    if r.kind is bool:
        if not isinstance(value, (bool, np.bool_)):
            raise ValueError(f"must be true or false, got {show(value)}")
        return bool(value)
    if r.kind in (int, float):
        return _number(r, value, typed)
    if r.kind == RGB:
        return _rgb(r, value, typed)
    if r.kind is Lighting:
        return _lighting(value)
    if not isinstance(value, str):
        raise ValueError(f"must be a string, got {show(value)}")
    return value


def _number(r, value, typed=False):
    """A finite number (not a boolean) in the field's range, as a float (an int for ``int``)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise ValueError(f"must be a number, got {show(value)}")
    try:
        fvalue = float(value)
    except OverflowError:
        raise ValueError(f"is too large, got {show(value)}") from None
    if not math.isfinite(fvalue):
        raise ValueError(f"must be finite, got {value}")
    if r.kind is int and not fvalue.is_integer():
        raise ValueError(f"must be an integer, got {value}")
    if r.above is not None and fvalue <= r.above:
        bound = f">= {r.above + 1:g}" if typed and r.kind is int else f"> {r.above:g}"
        raise ValueError(f"must be {bound}, got {value}")
    if r.at_least is not None and fvalue < r.at_least:
        raise ValueError(f"must be >= {r.at_least:g}, got {value}")
    out = int(fvalue) if r.kind is int else fvalue
    if r.at_most is not None and out > r.at_most:
        raise ValueError(f"must be at most {r.at_most}, got {out}")
    return out


def _rgb(r, value, typed=False):
    """Three finite numbers 0-255 (integers for ``item=int``) as a tuple of ``item``."""
    try:
        c = np.asarray(value)
        ok = (c.shape == (3,) and np.issubdtype(c.dtype, np.number)
              and not np.issubdtype(c.dtype, np.bool_) and bool(np.isfinite(c).all())
              and bool(((c >= 0) & (c <= 255)).all()))
    except (TypeError, ValueError):
        ok = False
    if ok and r.item is int:
        ok = all(isinstance(v, numbers.Real) and not isinstance(v, (bool, np.bool_))
                 and float(v).is_integer() for v in value)
    if not ok and typed:
        raise ValueError(f"must be three integers 0-255, got {' '.join(map(str, value))}")
    if not ok:
        what = "[r, g, b] integers 0-255" if r.item is int else "3 numbers in 0..255"
        raise ValueError(f"must be {what}, got {show(_plain(value))}")
    return tuple(r.item(v) for v in c)


def _plain(value):
    """``value`` as JSON shows it (a tuple or an array as a list)."""
    return value.tolist() if isinstance(value, np.ndarray) else (
        list(value) if isinstance(value, tuple) else value)


#: the fields of the lit shading's settings (``lighting``'s keys)
LIGHTING_KEYS = frozenset(f.name for f in dataclasses.fields(Lighting))


def _lighting(value):
    """``lighting``: None (the defaults), a dict of fields or a ``Lighting``."""
    if value is None:
        return Lighting()
    if isinstance(value, dict):
        unknown = sorted(set(value) - LIGHTING_KEYS)
        if unknown:
            raise ValueError(f"has unknown key(s) {', '.join(map(repr, unknown))} "
                             f"(allowed: {', '.join(sorted(LIGHTING_KEYS))})")
        try:
            return Lighting(**value)
        except ValueError as exc:   # Lighting's own message names the field
            raise ValueError(f"is not valid: {exc}") from None
    if not isinstance(value, Lighting):
        raise ValueError(f"must be a tracer.rendering.lighting.Lighting or a dict, got "
                         f"{type(value).__name__}")
    return value


# ---------------------------------------------------------------------- the keyword entry points
class Groups(NamedTuple):
    """The settings of a render as the groups of this module (the order of
    :func:`tracer.scenes.from_mesh.build_mesh_scene`'s and
    :func:`tracer.scenes.scene.field_scene`'s arguments)."""

    surface: Surface
    march: March
    film: Film
    view: View


def groups(entry, given):
    """:class:`Groups` of the settings ``given`` by name (a dict; one not given keeps the
    ``entry``'s default), not yet checked (:func:`tracer.scenes.scene.field_scene` checks
    them)."""
    d = defaults(entry)

    def group(cls):
        return cls(**{f.name: given.get(f.name, d[f.name]) for f in dataclasses.fields(cls)})
    return Groups(group(Surface), group(March), group(Film), group(View))


def split_size(size):
    """``(width, height)`` of the mesh entry points' ``size``."""
    try:
        width, height = size
    except (TypeError, ValueError):
        raise ValueError(f"size must be (width, height), got {size!r}") from None
    return width, height


def settings_entry(entry, *, size=False, leave_out=()):
    """Decorate a keyword entry point: its signature gets one keyword-only parameter per
    setting of the table (``leave_out`` excepted) with the ``entry``'s default (none where
    the entry requires it; ``size``: the mesh entry points' ``size=(width, height)`` instead of
    ``width`` and ``height``), its docstring a line for each setting its ``Parameters`` do not
    describe (from the field's help). A call binds its arguments as Python would (a
    ``TypeError`` names a misspelt keyword) and passes the decorated function its own
    arguments and ``settings=``, the :class:`Groups` of the settings."""
    d = defaults(entry)
    keys = [r.key for r in table() if r.key not in leave_out
            and not (size and r.key in ("width", "height"))]
    new = []
    for r in sorted(table(), key=lambda r: _order(r.key)):
        if size and r.key == "width":
            new.append(inspect.Parameter("size", inspect.Parameter.KEYWORD_ONLY,
                                         default=(d["width"], d["height"])))
        if r.key in keys:
            new.append(inspect.Parameter(r.key, inspect.Parameter.KEYWORD_ONLY,
                                         default=inspect.Parameter.empty
                                         if d[r.key] is REQUIRED else d[r.key]))

    def wrap(fn):
        own = inspect.signature(fn)
        sig = own.replace(parameters=[p for n, p in own.parameters.items() if n != "settings"]
                          + new)
        names = [p.name for p in new]

        @functools.wraps(fn)
        def entry_point(*args, **kwargs):
            try:
                bound = sig.bind(*args, **kwargs)
            except TypeError as exc:    # as Python says it: the function's name first
                raise TypeError(f"{fn.__name__}() {exc}") from None
            bound.apply_defaults()
            given = {n: bound.arguments.pop(n) for n in names}
            if size:
                given["width"], given["height"] = split_size(given.pop("size"))
            return fn(*bound.args, **bound.kwargs, settings=groups(entry, given))

        entry_point.__signature__ = sig
        # as a plain function's: the keyword-only parameters' defaults
        entry_point.__kwdefaults__ = {n: p.default for n, p in sig.parameters.items()
                                      if p.kind is p.KEYWORD_ONLY and p.default is not p.empty}
        entry_point.__doc__ = _with_parameters(fn.__doc__ or "", entry, keys, size)
        return entry_point
    return wrap


def table_index(key):
    """The place of ``key`` in :func:`table`."""
    return list(_ROWS).index(key)


def _type_text(r):
    """The numpydoc type of a setting (``float or "auto"``, ``{"smooth", "exact"}``)."""
    if r.choices:
        text = "{" + ", ".join(f'"{c}"' for c in r.choices) + "}"
    elif r.kind == RGB:
        text = f"(3,) {r.item.__name__}"
    elif r.kind is Lighting:
        text = "tracer.rendering.lighting.Lighting or dict"
    else:
        text = " or ".join([r.kind.__name__] + [f'"{w}"' for w in r.words])
    return text + (", optional" if r.none else "")


def _parameter_lines(entry, key):
    """A setting's lines in a numpydoc ``Parameters`` section."""
    if key == "size":
        size = (row("width"), row("height"))
        head, text = "size : (int, int)", ("Image (width, height) in pixels. Default: "
                                           f"{tuple(getattr(r, entry) for r in size)}.")
    else:
        r = row(key)
        value = getattr(r, entry)
        default = "" if value is REQUIRED else f" Default: {_doc_default(r, value)}."
        head, text = f"{key} : {_type_text(r)}", r.help[0].upper() + r.help[1:] + "." + default
    return [head] + textwrap.wrap(text, 88, initial_indent="    ", subsequent_indent="    ",
                                  break_on_hyphens=False)


def _doc_default(r, value):
    """A default as the docstring shows it (``"lit"``, ``(255, 255, 255)``, the text of a
    computed one)."""
    if value is None:
        return r.text or "None"
    if isinstance(value, Lighting):
        return "Lighting()" if value == Lighting() else repr(value)
    if isinstance(value, str):
        return f'"{value}"'
    return f"{value:g}" if isinstance(value, float) else repr(value)


def _with_parameters(doc, entry, keys, size):
    """``doc`` (a numpydoc docstring) with a ``Parameters`` line for each of the settings
    ``keys`` (and ``size``) it does not describe, at the end of that section (made before the
    first other section when it has none)."""
    lines = inspect.cleandoc(doc).splitlines()
    heads = [i for i in range(len(lines) - 1) if lines[i].strip()
             and set(lines[i + 1].strip()) == {"-"} and len(lines[i + 1].strip()) >= 3]
    start = next((i for i in heads if lines[i].strip() == "Parameters"), None)
    after = [i for i in heads if start is None or i > start]
    end = after[0] if after else len(lines)
    described = set()
    for line in lines[start or 0:end] if start is not None else []:
        if line and not line[0].isspace() and " :" in line + " ":
            described |= {n.strip() for n in line.split(" :")[0].split(",")}
    todo = [k for k in (["size"] if size else []) + keys if k not in described]
    add = [line for k in sorted(todo, key=_order) for line in _parameter_lines(entry, k)]
    if start is None:
        add = ["", "Parameters", "----------"] + add
    while end > 0 and not lines[end - 1].strip():
        end -= 1
    return "\n".join(lines[:end] + add + lines[end:]).rstrip() + "\n"


def _order(key):
    """A setting's place in an entry point's keywords and lines: the surface's first (alpha
    leads, as it did), then the table's order (``size`` where ``width`` is)."""
    index = table_index("width" if key == "size" else key)
    return (row("width" if key == "size" else key).group != "Surface", index)
