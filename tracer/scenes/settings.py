"""A scene's settings and their defaults, written once.

Every option of a render is a field of one of the frozen dataclasses below (plus the
existing :class:`~tracer.rendering.lighting.Lighting`); its default is the field's default and its
one-line meaning the field's ``help``. The entry points read their defaults from here:

* the scene file loader (:func:`tracer.scenes.scene.load_scene`, its keys ``_TOP_KEYS``) and the
  :class:`~tracer.scenes.scene.Scene` dataclass: ``defaults("file")``;
* :func:`tracer.scenes.scene.scene_from_field`, the research API over a built field:
  ``defaults("api")``;
* :func:`tracer.render_mesh`, :func:`tracer.mesh_scene` and ``tracer render MESH``:
  ``defaults("mesh")``;
* the JSON Schema ``tracer/scenes/scene.schema.json`` and the command line's help text are checked
  against this table by ``tests/tracer/scenes/test_settings.py``.

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
from dataclasses import dataclass

from smoothdist.kernels import DEFAULT_TOL
from tracer.rendering.lighting import Lighting
from tracer.rendering.march import NEWTON

__all__ = ["View", "March", "Film", "Surface", "GROUPS", "ENTRIES", "KINDS", "Row", "table",
           "defaults", "default_text", "REQUIRED", "SCENE_KEYS"]

#: the kinds of data an object draws (``kind=`` of the mesh entry points, ``kind`` of scene
#: files): its triangles, its edges, its points, or everything its file holds
KINDS = ("triangles", "edges", "points", "mixed")

#: the entry points: scene files (and ``Scene``), ``scene_from_field``, the mesh entry points
ENTRIES = ("file", "api", "mesh")


class _Required:
    """The default of a setting an entry point requires (no default)."""

    def __repr__(self):
        return "REQUIRED"


#: marks a setting an entry point requires
REQUIRED = _Required()
_SAME = object()


def _opt(default, help, *, api=_SAME, mesh=_SAME, file=_SAME, why="", text=None,
         key=True):
    """A setting: ``default`` everywhere unless ``file`` / ``api`` / ``mesh`` say otherwise
    (``why`` gives the reason); ``text`` describes a default computed at load time (shown
    instead of None); ``key=False``: not a top-level scene-file key."""
    return dataclasses.field(default=default, metadata=dict(
        help=help, file=default if file is _SAME else file, api=default if api is _SAME else api,
        mesh=default if mesh is _SAME else mesh, why=why, text=text, key=key))


@dataclass(frozen=True)
class View:
    """How a camera is chosen when it is not given as three vectors (scene files always give
    ``camera: {origin, dest, up}``): the side it frames the surface from, and the data's up
    axis; and its projection (scene files: ``camera.projection``, ``camera.view_width``).
    The camera itself is :class:`tracer.rendering.camera.Camera`."""

    view: str = _opt(None, "camera framing the whole surface from this side (front, back, "
                     "left, right, top, iso)", mesh="front", file=REQUIRED, key=False,
                     why="scene files carry their camera; the API's None is the paper's "
                         "beta-study camera")
    up: str = _opt("y", "the data's up axis for a view (x, y, z; auto: z for .stl and .ply "
                   "files and trimesh / pyvista objects, y otherwise; for the front view a "
                   "flat object seen edge-on or a long one end-on is turned to its largest "
                   "silhouette)", mesh="auto",
                   file=REQUIRED, key=False,
                   why="a mesh file's extension tells its up axis")
    projection: str = _opt("perspective", "perspective (the authors' pinhole) or orthographic "
                           "(parallel rays, as pyvista's parallel projection)", key=False)
    view_width: float = _opt(None, "orthographic: the view's width in scene units", key=False,
                             text="the width framing the surface (a view), or the "
                                  "perspective camera's width at dest")


@dataclass(frozen=True)
class March:
    """The sphere tracer's settings: which surface, and how rays step to it."""

    mode: str = _opt("smooth", "smooth: the isosurface d_hat = offset of the smooth "
                     "distance; exact: the exact offset surface d = offset")
    beta: float = _opt(0.5, "Barnes-Hut parameter: 0 evaluates every primitive exactly "
                       "(slow); larger is faster and coarser")
    eps: float = _opt(None, "hit threshold in scene units",
                      text="1e-4 x the data's bbox diagonal")
    tol: float = _opt(DEFAULT_TOL, "tolerance-controlled pruning: d_hat within "
                      "log(1 + tol)/alpha of the exact sum, never above it (0 = off)")
    newton: float = _opt(NEWTON, "smooth mode: Newton steps along the ray once the distance "
                         "is below newton x eps (0 = plain sphere tracing)")
    max_steps: int = _opt(1000, "largest number of distance evaluations per ray")
    gradient: str = _opt("metric", "the normal's gradient: metric (the paper's) or exact")
    weights: str = _opt("paper", "weights of edges and triangles: paper (the paper's "
                        "polynomials), inclusion-exclusion (the exact distance's sum above flat "
                        "faces and outside convex edges: no seams), or auto: "
                        "inclusion-exclusion for the automatic surface (alpha, alpha_u and "
                        "offset auto), paper otherwise", mesh="auto",
                        why="scene files and the research API keep the paper's weights "
                            "(golden images); a user's mesh gets the seam-free automatic "
                            "surface")


@dataclass(frozen=True)
class Film:
    """The image: its size, its samples, its background and how hits are shaded."""

    width: int = _opt(512, "image width in pixels")
    height: int = _opt(512, "image height in pixels")
    samples: int = _opt(1, "anti-aliasing samples per pixel, tent-filtered")
    adaptive: bool = _opt(False, "extra samples only to pixels that differ from a neighbour")
    transparent: bool = _opt(False, "RGBA output whose alpha is the pixel's coverage")
    background: tuple = _opt((255, 255, 255), "background colour [r, g, b], 0-255")
    shading: str = _opt("normals", "lit (lights, shadows, ambient occlusion, a ground), "
                        "normals (the paper's view-space normal colours), matcap or headlight",
                        mesh="lit", text='"matcap" when a matcap is given, else "normals"',
                        why="scene files and the research API draw the paper's normal "
                            "colours (golden images); a user's mesh gets a lit picture")
    matcap: str = _opt("", "matcap image (PNG) for the matcap shading; \"\" for none")
    lighting: Lighting = _opt(Lighting(), "settings of the lit shading "
                              "(tracer.rendering.lighting.Lighting)")


@dataclass(frozen=True)
class Surface:
    """The (first) object's surface: sharpness, attenuation, level and colour."""

    alpha: float = _opt(REQUIRED, "sharpness (1 / scene units), or auto: mean surface offset "
                        "<= 2 % of the bbox diagonal", mesh="auto", key=False,
                        why="the authors' format and the research API name alpha")
    alpha_u: float = _opt("auto", "attenuation threshold alpha_U: auto = 20 x alpha (no "
                          "ribbing on tubes), off = alpha (no attenuation)", api="off",
                          key=False,
                          why="the parameter studies and golden images vary alpha alone "
                              "over the paper's unattenuated weights")
    offset: float = _opt(None, "the level of the surface: smooth mode d_hat = offset, exact "
                         "mode d = offset",
                         text="exact mode: 1 / alpha, per object; smooth mode: 0")
    color: tuple = _opt(None, "lit shading: base colour [r, g, b] 0-255 of the object",
                        key=False, text="a light clay for one object; a palette for several")


#: the settings groups, in the order of the reference table
GROUPS = (View, March, Film, Surface)


@dataclass(frozen=True)
class Row:
    """One setting: its group, name, default per entry point, meaning and reasons."""

    group: str
    key: str
    file: object
    api: object
    mesh: object
    help: str
    text: str
    why: str
    scene_key: bool


def table():
    """Every setting as a :class:`Row`, groups in :data:`GROUPS` order."""
    rows = []
    for group in GROUPS:
        for f in dataclasses.fields(group):
            m = f.metadata
            rows.append(Row(group.__name__, f.name, m["file"], m["api"], m["mesh"], m["help"],
                            m["text"], m["why"], m["key"]))
    return rows


def defaults(entry):
    """``{key: default}`` of one entry point (``"file"``, ``"api"`` or ``"mesh"``)."""
    if entry not in ENTRIES:
        raise ValueError(f"entry must be one of {ENTRIES}, got {entry!r}")
    return {r.key: getattr(r, entry) for r in table()}


def default_text(key, entry="file"):
    """The default of ``key`` as help text shows it (``1e-4 x ...`` for computed ones)."""
    row = next(r for r in table() if r.key == key)
    value = getattr(row, entry)
    if value is None and row.text:
        return row.text
    if isinstance(value, tuple):
        return " ".join(str(v) for v in value)
    if isinstance(value, bool):
        return "on" if value else "off"
    return f"{value:g}" if isinstance(value, float) else str(value)


#: the top-level scene-file keys the table defines (``camera``, ``objects``, ``description``
#: and ``name`` are the scene file's own)
SCENE_KEYS = frozenset(r.key for r in table() if r.scene_key)
