"""From a user's mesh to an image in one call: :func:`~tracer.render_mesh` and
:func:`~tracer.mesh_scene`.

``tracer.render_mesh(mesh)`` takes a mesh file path, numpy ``(V, F)`` arrays, a
``trimesh.Trimesh`` / ``PointCloud`` / ``path.Path3D``, a ``pyvista.PolyData`` or a
:class:`smoothdist.DataMesh`, picks ``alpha="auto"`` and ``alpha_u="auto"`` (see
:meth:`smoothdist.SmoothDistanceField.auto_alpha`), frames the whole surface with
:func:`tracer.rendering.camera.frame_points` and returns a
:class:`tracer.rendering.frame.RenderResult` of numpy arrays (``rgb``, ``depth``, ``normals``,
``hit``, ``steps``, ...; ``.save(path)``).
"""

import os
import warnings
from dataclasses import asdict, fields, replace

import numpy as np

import smoothdist
from smoothdist import DataMesh, SmoothDistanceField
from smoothdist.convert import is_foreign_geometry
from smoothdist.field import AUTO_RANDOM_SPREAD
from tracer.compiling import ahead_allowed, start_ahead
from tracer.errors import ThinFeatureWarning, user_stacklevel
from tracer.rendering.camera import UP_AXES, LookAt, frame_points, frame_width
from tracer.rendering.renderer import render
from tracer.scenes.scene import (automatic_surface, field_scene, planned_weights,
                                 with_default_eps, with_weights)
from tracer.scenes.settings import (KINDS, Surface, defaults, groups, settings_entry,
                                     split_size)
from tracer.stages import StageClock, stage, stage_progress

__all__ = ["render_mesh", "mesh_scene", "build_mesh_scene", "settings_groups", "is_mesh_list",
           "load_geometry", "guess_up", "resolve_up", "describe_parameters", "scene_dict"]


def load_geometry(mesh, F=None, kind=None):
    """A :class:`smoothdist.DataMesh` from a path or any object ``as_data_mesh`` accepts,
    reduced to ``kind`` (``"triangles"``, ``"edges"``, ``"points"``; ``"mixed"`` or None keep
    everything it holds)."""
    if kind is not None and kind not in KINDS:
        raise ValueError(f"kind must be one of {', '.join(KINDS)}; got {kind!r}")
    if isinstance(mesh, (str, os.PathLike)):
        if F is not None:
            raise ValueError("pass F only together with a vertex array, not with a file path")
        data = smoothdist.load_mesh(mesh)
    else:
        data = smoothdist.as_data_mesh(mesh, F)
    return data.as_kind(kind) if kind not in (None, "mixed") else data


#: file formats whose data are z-up by convention (3D printing; scanners and lidar)
Z_UP_EXTENSIONS = (".stl", ".ply")
#: libraries whose objects are z-up by convention (their own viewers show z up)
Z_UP_LIBRARIES = ("trimesh", "pyvista", "vtkmodules")


def guess_up(mesh):
    """The up axis ``up="auto"`` picks for ``mesh``: ``"z"`` for STL and PLY files and for
    trimesh / pyvista objects (z-up conventions), ``"y"`` for everything else (OBJ, OFF,
    numpy arrays, :class:`smoothdist.DataMesh`: the graphics convention)."""
    if isinstance(mesh, (str, os.PathLike)):
        return "z" if os.path.splitext(os.fspath(mesh))[1].lower() in Z_UP_EXTENSIONS else "y"
    if isinstance(mesh, (np.ndarray, list, tuple)):
        return "y"
    return "z" if type(mesh).__module__.split(".")[0] in Z_UP_LIBRARIES else "y"


def resolve_up(mesh, up):
    """``up`` checked (``"x"``, ``"y"``, ``"z"``), or :func:`~tracer.scenes.from_mesh.guess_up` for
    ``"auto"`` / None."""
    if up is None or up == "auto":
        return guess_up(mesh)
    if up not in UP_AXES:
        raise ValueError(f"up must be one of auto, {', '.join(UP_AXES)}; got {up!r}")
    return up


#: the settings the mesh entry points do not take (the scene files' and the research API's)
_NOT_MESH = ("max_steps", "gradient")


@settings_entry("mesh", size=True, leave_out=_NOT_MESH)
def mesh_scene(mesh, F=None, *, kind=None, camera=None, name=None, settings):
    """A one-object :class:`tracer.scenes.scene.Scene` for ``mesh``, camera framing the surface.

    Every setting of :mod:`tracer.scenes.settings` but ``max_steps`` and ``gradient`` is a
    keyword (:func:`~tracer.scenes.settings.settings_entry`; the lines of those not described
    here are made from the table), as in :func:`tracer.scenes.scene.scene_from_field`.

    Parameters
    ----------
    mesh : path, DataMesh, (n, 3) array_like, or a trimesh / pyvista object; or a list of them
        The data (see :func:`smoothdist.as_data_mesh`); ``F`` as in ``DataMesh``. A list
        (``is_mesh_list``: paths, DataMeshes, trimesh / pyvista objects, ``(V, F)`` pairs or
        ``(n, 3)`` arrays) makes one object per entry, framed together; ``kind``,
        ``alpha``, ``alpha_u``, ``offset``, ``color`` and ``matcap`` may then be lists too,
        one value per object (a single value applies to every object; ``color`` None gives
        the palette). ``F`` must be None then.
    kind : {None, "triangles", "edges", "points", "mixed"}
        Reduce the data to one primitive kind; None or "mixed" keep what it holds.
    alpha : float or "auto"
        Sharpness (1 / scene units). ``"auto"``: mean surface offset <= 2 % of the bbox
        diagonal (:meth:`~smoothdist.SmoothDistanceField.auto_alpha`); with ``alpha_u`` and
        ``offset`` left out too, edges and triangles get ``alpha``, ``alpha_u`` and the
        offset chosen together (:meth:`~smoothdist.SmoothDistanceField.auto_surface`:
        triangles as a thin shell, the level set ``d_hat = C`` at 0.3 % of the diagonal or a
        tenth of the local feature size, ``alpha = 20 / C``; curves as a tube about 0.75 mean
        edge lengths thick, ``alpha = 6 / C`` (30 / C for a wireframe's wires); no
        attenuation).
    alpha_u : float, "auto" or None
        Attenuation threshold; ``"auto"`` is 20 x alpha (no ribbing); ``"off"`` or None: no
        attenuation.
    beta : float
        Barnes-Hut parameter (0 = exact, slow on big meshes).
    size : (int, int)
        Image ``(width, height)`` in pixels.
    view : str
        ``front``, ``back``, ``left``, ``right``, ``top`` or ``iso`` (see
        :data:`tracer.rendering.camera.VIEWS`, turned to ``up``): the camera frames, from there, the
        region the surface can occupy (the data's vertices grown by the largest possible
        inflation; :func:`tracer.rendering.camera.frame_points`).
    up : {"auto", "x", "y", "z"}
        The data's up axis for ``view``. ``"auto"`` (:func:`~tracer.scenes.from_mesh.guess_up`): z
        for STL and PLY files and for trimesh / pyvista objects, y otherwise (OBJ, OFF, arrays).
    camera : (origin, dest, up) or tracer.rendering.camera.Camera, optional
        An explicit camera instead of ``view``; the ``camera`` of a
        :class:`~tracer.rendering.frame.RenderResult` renders the same view again.
    projection : {"perspective", "orthographic"}
        The authors' pinhole (the default), or parallel rays (pyvista's parallel projection;
        :mod:`tracer.rendering.camera`).
    view_width : float, optional
        Orthographic: the image's width in scene units (None: the width that frames the
        surface from ``view``, with the same border as the perspective framing).
    weights : {"auto", "paper", "inclusion-exclusion"}
        The weights of edges and triangles (:mod:`smoothdist.junctions`). ``"auto"`` (the
        default here): inclusion-exclusion over the junctions for the automatic surface (no
        seams along the internal edges of flat faces, the exact offset surface over convex
        parts), the paper's polynomials once alpha, alpha_u or the offset is given.
    shading : {"lit", "normals", "matcap", "headlight"}
        ``"lit"`` (the default here): key and fill lights, soft shadows, ambient occlusion
        and a ground (:mod:`tracer.rendering.lighting`); ``"normals"``: the paper's normal colours.
    name : str, optional
        The scene's name (default: the mesh's).
    """
    return build_mesh_scene(mesh, F, kind, *settings, camera=camera, name=name)


def settings_groups(settings):
    """``(surface, march, film, view)``, the groups of :mod:`tracer.scenes.settings`, from the
    keyword arguments of :func:`mesh_scene` or :func:`render_mesh` by name (``size`` is the
    film's ``(width, height)``; a setting not given keeps its ``"mesh"`` default); not yet
    checked (:func:`tracer.scenes.scene.field_scene` checks them)."""
    given = dict(settings)
    if "size" in given:
        given["width"], given["height"] = split_size(given.pop("size"))
    return groups("mesh", given)


def build_mesh_scene(mesh, F, kind, surface, march, film, view, camera=None, name=None):
    """:func:`mesh_scene` with its settings as groups (:func:`settings_groups`): one object,
    or one per entry of a list of meshes (``kind``, the surface's fields and ``film.matcap``
    may then hold one value per mesh)."""
    several = is_mesh_list(mesh)
    if several and F is not None:
        raise ValueError("F must be None with a list of meshes: give (V, F) pairs")
    start_ahead(march, film, len(mesh) if several else 1)     # where it helps and is allowed
    if several:
        return _several_objects(mesh, kind, surface, march, film, view, camera, name)
    up = view.up
    guessed = up is None or up == "auto"
    up = resolve_up(mesh, up)
    with stage("load", "reading the mesh"):
        data = load_geometry(mesh, F, kind)
    with stage("tree", "building the tree"):
        # with the weights the scene will have (not the paper's, then the scene's)
        field = SmoothDistanceField(data, progress=stage_progress("building the tree"),
                                    weights=planned_weights(march.weights,
                                                            automatic_surface(surface, march)))
    with stage("parameters", "choosing alpha and the offset"):
        scene = field_scene(field, surface, march, film,
                            replace(view, view=view.view if camera is None else None, up=up),
                            camera=camera, name=name or os.path.splitext(data.name)[0])
    with stage("framing", "framing the view"):
        if guessed and camera is None and view.view == "front":
            new_up, front, why = auto_orientation(data, up)
            scene.extra["orientation"] = why
            if front != "front" or new_up != up:
                frame_scene(scene, front, new_up, view.view_width)
        warn_thin_tubes(scene)
        auto = automatic_surface(surface, march)
        note_sparse_clouds(scene, {o.name: sparse_cloud(o) for o in scene.objects} if auto
                           else {})
    return scene


def is_mesh_list(mesh):
    """Whether ``mesh`` is a list (or tuple) of several meshes rather than one: every entry a
    path, a :class:`smoothdist.DataMesh`, a trimesh / pyvista object, a ``(V, F)`` pair or a
    2-D array. A list of 3-vectors is one point cloud; a ``(V, F)`` pair is one mesh."""
    if not isinstance(mesh, (list, tuple)) or not mesh:
        return False
    if (isinstance(mesh, tuple) and len(mesh) == 2 and np.ndim(mesh[0]) == 2
            and (mesh[1] is None or np.ndim(mesh[1]) == 2)):
        return False                                   # one (V, F) pair

    def one(m):
        if isinstance(m, (str, os.PathLike, DataMesh)) or is_foreign_geometry(m):
            return True
        if isinstance(m, tuple) and len(m) == 2:
            return np.ndim(m[0]) == 2
        return isinstance(m, np.ndarray) and m.ndim == 2
    return all(one(m) for m in mesh)


#: per-object arguments of a list of meshes (:func:`mesh_scene`)
PER_OBJECT = ("kind", "alpha", "alpha_u", "offset", "color", "matcap")


def _per_object(name, value, n):
    """``value`` as ``n`` per-object values: a list of ``n``, or one value for all. A colour
    (three numbers) is one value."""
    if isinstance(value, (list, tuple)) and not (
            name == "color" and len(value) == 3 and all(np.isscalar(v) for v in value)):
        if len(value) != n:
            raise ValueError(f"{name} has {len(value)} values for {n} meshes: give one value "
                             "or one per mesh")
        return list(value)
    return [value] * n


def _several_objects(meshes, kind, surface, march, film, view, camera, name):
    """A scene of one object per entry of ``meshes`` (:func:`build_mesh_scene` with a list)."""
    n = len(meshes)
    given = dict(asdict(surface), kind=kind, matcap=film.matcap)
    per = {k: _per_object(k, given[k], n) for k in PER_OBJECT}
    ups = [resolve_up(m, view.up) for m in meshes]
    parts, names = [], set()
    for i, m in enumerate(meshes):
        V_F = m if isinstance(m, tuple) else (m, None)
        mine = Surface(**{f.name: per[f.name][i] for f in fields(Surface)})
        try:
            with warnings.catch_warnings():     # warned once, for the whole scene, below
                warnings.simplefilter("ignore", ThinFeatureWarning)
                s = build_mesh_scene(V_F[0], V_F[1], per["kind"][i], mine, march,
                                     replace(film, matcap=per["matcap"][i]),
                                     replace(view, up=ups[0]), camera=camera)
        except ValueError as exc:
            raise ValueError(f"mesh {i}: {exc}") from None
        o = s.objects[0]
        base, k = o.name, 1
        while o.name in names:                 # unique object names
            k += 1
            o.name = f"{base}_{k}"
        names.add(o.name)
        parts.append(s)
    scene = parts[0]
    scene.objects = [s.objects[0] for s in parts]
    # one weight scheme for the scene (its trees make one forest): auto chose per object
    weights = {s.march.weights for s in parts}
    if len(weights) > 1:
        scene.march = replace(scene.march, weights=with_weights(scene.objects, "paper", []))
    scene.path = f"{name or '+'.join(o.name for o in scene.objects)}.json"
    if march.eps is None:
        scene.march = replace(scene.march, eps=None)
        with_default_eps(scene)
    if camera is None:      # frame every object's surface (each grown by its own bound)
        frame_scene(scene, view.view, ups[0], view.view_width)
    warn_thin_tubes(scene)
    notes = {o.name: note for o, part in zip(scene.objects, parts)
             for note in part.extra.get("sparse", {}).values()}
    note_sparse_clouds(scene, notes)
    return scene


def frame_scene(scene, view, up="y", view_width=None):
    """Point ``scene``'s camera from ``view`` (a name of
    :data:`tracer.rendering.camera.VIEWS`, or ``(direction to the eye, image up)``) at the
    region every object's surface can occupy: its data's vertices grown by its inflation
    bound and offset (exact mode: its offset), plus two hit tolerances
    (:func:`tracer.rendering.camera.frame_points`). The camera keeps its projection; an
    orthographic one gets ``view_width``, or else the width that frames that region
    (:func:`tracer.rendering.camera.frame_width`)."""
    P, grow = [], 0.0
    for o in scene.objects:
        P.append(o.field.mesh.used_vertices())
        g = (o.level("exact") if scene.march.mode == "exact" else
             o.field.inflation(o.alpha, o.alpha_u) + o.level("smooth"))
        grow = max(grow, g)
    fit = (np.concatenate(P), grow + 2.0 * scene.march.eps)
    pose = frame_points(*fit, view, scene.film.width, scene.film.height, up=up)
    projection = scene.camera.projection
    if projection == "orthographic" and view_width is None:
        view_width = frame_width(*fit, pose, scene.film.width, scene.film.height)
    scene.camera = LookAt(*pose, projection, view_width)


#: keep the up axis the file's convention gives while its front view shows at least this
#: share of the data's largest outline (:func:`auto_orientation`)
KEEP_CONVENTION = 0.8
#: the axis a named view's "front" looks along, per up axis (tracer.rendering.camera.VIEWS)
_FRONT_AXIS = {"x": 2, "y": 2, "z": 1}
_AXES = "xyz"


#: cells across the largest extent of the grid on which :func:`outline_areas` draws
OUTLINE_CELLS = 64
#: surface samples drawn by :func:`outline_areas`
OUTLINE_SAMPLES = 40_000


def outline_areas(data, seed=0):
    """``(3,)`` the area of the data's silhouette seen along x, y and z (scene units squared).

    Samples (:data:`OUTLINE_SAMPLES`, area- or length-weighted; every point primitive) are
    projected along each axis onto a grid of square cells, :data:`OUTLINE_CELLS` across the
    largest extent, and the covered cells counted: holes and concave parts count as the
    silhouette shows them (a text's strokes seen end-on cover one thin strip, not every wall).
    """
    rng = np.random.default_rng(seed)
    V = data.V
    parts = [V[data.points]] if data.points.size else []
    T, E = data.triangles, data.edges
    wt = (0.5 * np.linalg.norm(np.cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]]),
                               axis=1) if T.shape[0] else np.zeros(0))
    we = np.linalg.norm(V[E[:, 1]] - V[E[:, 0]], axis=1) if E.shape[0] else np.zeros(0)
    total = wt.sum() + we.sum()
    if total > 0:
        n_t = int(round(OUTLINE_SAMPLES * wt.sum() / total))
        if n_t:
            i = rng.choice(T.shape[0], n_t, p=wt / wt.sum())
            u, v = rng.random((2, n_t, 1))
            flip = (u + v) > 1
            u, v = np.where(flip, 1 - u, u), np.where(flip, 1 - v, v)
            A = V[T[i, 0]]
            parts.append(A + u * (V[T[i, 1]] - A) + v * (V[T[i, 2]] - A))
        n_e = OUTLINE_SAMPLES - n_t
        if n_e and we.sum() > 0:
            i = rng.choice(E.shape[0], n_e, p=we / we.sum())
            t = rng.random((n_e, 1))
            parts.append(V[E[i, 0]] + t * (V[E[i, 1]] - V[E[i, 0]]))
    P = np.concatenate(parts) if parts else data.used_vertices()
    lo = P.min(axis=0)
    h = float((P.max(axis=0) - lo).max()) / OUTLINE_CELLS
    if not h > 0:
        return np.zeros(3)
    cells = np.minimum(((P - lo) / h).astype(np.int64), OUTLINE_CELLS)
    out = np.empty(3)
    for k in range(3):
        a, b = [j for j in range(3) if j != k]
        out[k] = np.unique(cells[:, a] * (OUTLINE_CELLS + 1) + cells[:, b]).size * h * h
    return out


def auto_orientation(data, convention):
    """``(up, view, why)`` for ``up="auto"`` and the default ``front`` view.

    ``convention`` is the up axis of the file's convention (:func:`guess_up`). Its front view
    is kept when it shows at least :data:`KEEP_CONVENTION` of the data's largest silhouette
    (:func:`outline_areas`): ``(convention, "front", why)``. Otherwise the data does not follow
    the convention (z-up data in a y-up OBJ, as 3D-printing files often are; a flat text in a
    z-up STL), and the first of these that passes the same test is taken: the other common
    convention's front view (z up for y, y up for z and x), its side view (along the third
    axis), the convention's side view: between them they look along every axis, so one of
    them shows the largest silhouette. A side view is ``(direction to the eye, image up)``.
    """
    A = outline_areas(data)
    top = A.max()
    if not top > 0 or A[_FRONT_AXIS[convention]] >= KEEP_CONVENTION * top:
        return convention, "front", f"{convention} up (the file's convention)"
    lost = (f"the {convention}-up front view would show "
            f"{100 * A[_FRONT_AXIS[convention]] / top:.0f} % of the largest silhouette; --up "
            "or --view to choose")
    other = "y" if convention == "z" else "z"
    for up in (other, convention):
        u = _AXES.index(up)
        front = _FRONT_AXIS[up]
        side = 3 - u - front
        for axis, name in ((front, "front"), (side, None)):
            if (up, name) == (convention, "front") or A[axis] < KEEP_CONVENTION * top:
                continue
            if name == "front":
                return up, "front", f"{up} up, from the data ({lost})"
            return (up, (np.eye(3)[axis], np.eye(3)[u]),
                    f"looking along {_AXES[axis]} with {up} up, from the data ({lost})")
    return convention, "front", f"{convention} up (the file's convention; {lost})"


def warn_thin_tubes(scene, probes=128):
    """Warn (:class:`~tracer.errors.ThinFeatureWarning`) when the first object is edges only
    and its smooth surface is thinner than half a pixel: at most points half a pixel from
    the edges (the pixel at the camera's distance to ``dest``: the shorter image axis spans
    that distance) ``d_hat`` is above the surface's level. The message gives the largest
    alpha (alpha_U in the same ratio), found in steps of 0.8, at which they are covered."""
    o = scene.objects[0]
    fld = o.field
    m = fld.mesh
    if scene.march.mode != "smooth" or not m.edges.size or m.triangles.size or m.points.size \
            or not fld.diagonal > 0:
        return
    dist = float(np.linalg.norm(np.asarray(scene.camera.dest) - scene.camera.origin))
    half = 0.5 * float(scene.camera.camera(scene.film.width, scene.film.height).pixel_size(dist))
    q, _ = fld._offset_probes(half, count=probes)
    c = o.level("smooth")
    ratio = o.alpha_u / o.alpha

    def covered(a):
        dh = fld.smooth_distance(q, alpha=a, alpha_u=ratio * a, beta=scene.march.beta).distance
        return float(np.median(dh)) <= c

    if covered(o.alpha):
        return
    a = o.alpha
    for _ in range(60):
        a *= 0.8
        if a * fld.diagonal < 1.0 or covered(a):
            break
    warnings.warn(f"the {m.edges.shape[0]} edges are drawn as tubes thinner than half a pixel "
                  f"({half:.3g} scene units at {scene.film.width}x{scene.film.height}) at alpha "
                  f"{o.alpha:.4g}: they show as specks; alpha {a:.3g} or lower, or a larger "
                  f"offset (--offset {half:.3g}), would show them", ThinFeatureWarning,
                  stacklevel=user_stacklevel())


#: a point cloud whose ``auto_alpha`` times its median spacing falls below this is too sparse
#: for its shape: random samples of surfaces close at 0.57-1.0 (the fidelity corpus: scans,
#: random and even samples of meshes, a box's faces, a grid), an airborne LiDAR tile, dense
#: along its scan lines, at 0.40; 500 random points on a circle need 0.30, their widest gaps
#: being 8 median spacings
SPARSE_ALPHA_SPACING = 0.35


def sparse_cloud(obj):
    """A phrase when ``obj`` (a scene object of points only, drawn on its automatic surface)
    is a random sample (:meth:`~smoothdist.SmoothDistanceField.spacing_spread` above
    ``AUTO_RANDOM_SPREAD``) too sparse for its shape (:data:`SPARSE_ALPHA_SPACING`), else
    None."""
    fld = obj.field
    m = fld.mesh
    if m.points.size < 3 or m.edges.size or m.triangles.size:
        return None
    s = fld.point_spacing()
    # auto_alpha (cached: the object is on its automatic surface), before the smoothing
    # margin of a dense random sample: how sharp closing the gaps allows, not a look chosen;
    # and only for a random sample: an even one's widest gap is its spacing, so a surface
    # several spacings out is the smoothing auto_alpha chose, not a gap it had to close
    if not (fld.auto_alpha() * s < SPARSE_ALPHA_SPACING
            and fld.spacing_spread() > AUTO_RANDOM_SPREAD):
        return None
    return (f"too sparse for its shape (surface about {2 / obj.alpha:.3g} from points "
            f"{s:.3g} apart)")


def note_sparse_clouds(scene, notes):
    """Keep ``notes`` (object name to :func:`sparse_cloud`'s phrase or None; only objects
    drawn on their automatic surface) in ``scene.extra["sparse"]``, and warn
    (:class:`~tracer.errors.ThinFeatureWarning`) for each phrase; the summary line
    (:func:`describe_parameters`) says so too."""
    scene.extra["sparse"] = {k: v for k, v in notes.items() if v}
    for name, note in scene.extra["sparse"].items():
        warnings.warn(f"{name} is a point cloud {note}: its widest gaps are many times its "
                      "median spacing, and the surface that closes them is thicker than the "
                      "spacing; a denser or more even sample draws it thinner",
                      ThinFeatureWarning, stacklevel=user_stacklevel())


@settings_entry("mesh", size=True, leave_out=_NOT_MESH)
def render_mesh(mesh, F=None, *, kind=None, camera=None, progress="auto", device="cpu",
                settings):
    """Sphere-trace the smooth-distance surface of ``mesh``; arrays back, nothing written.

    Parameters are those of :func:`mesh_scene` (the ``"lit"`` shading by default;
    ``shading="normals"`` gives the paper's normal colours; the settings' lines below are made
    from :mod:`tracer.scenes.settings`); ``progress`` and ``device``
    (``"cpu"`` or ``"cuda"``) as in :func:`tracer.render`: by default (``"auto"``) a progress
    bar appears on stderr once the render has run 3 s, and each stage before and after the
    trace that runs longer (reading a big mesh, building its tree, the automatic parameters,
    the light) says what it is doing (``tracer.stages``; ``progress=None``: never).

    Returns
    -------
    tracer.rendering.frame.RenderResult
        ``rgb (H, W, 3) uint8``, ``hit (H, W) bool``, ``depth (H, W) float32`` (ray
        parameter, NaN on misses), ``normals (H, W, 3)``, ``steps (H, W)``, ``leaves``,
        ``camera``, ``scene`` (``scene.objects[0].alpha`` / ``.alpha_u`` are the values used)
        and ``save(path)``.

    Examples
    --------
    .. code-block:: python

        import trimesh, tracer
        res = tracer.render_mesh(trimesh.creation.icosphere(), kind="edges", size=(256, 256),
                                 samples=8, adaptive=True)     # anti-aliased, lit
        res.save("renders/ico.png")         # res.rgb, res.depth, res.hit, ... are arrays
    """
    # a progress bar asked for (or "auto"): the stages before and after the trace say what
    # they do once they pass a few seconds too (a big mesh's tree, the light)
    talk = progress is True or (isinstance(progress, str) and progress == "auto")
    label = (os.path.splitext(os.path.basename(os.fspath(mesh)))[0]
             if isinstance(mesh, (str, os.PathLike)) else "render_mesh")
    # a first render may compile its film's kernels in a second process (compile_ahead)
    with StageClock(label, quiet=not talk), ahead_allowed(device == "cpu"):
        scene = build_mesh_scene(mesh, F, kind, *settings, camera=camera)
        return render(scene, progress=progress, device=device)


def describe_parameters(scene):
    """One phrase per object: ``alpha 43.3, alpha_U 866, inflation <= 0.021 (0.6% of the
    diagonal)`` (the worst-case inflation bound ``log(A^S N) / alpha``); exact mode ``offset
    0.023 (...)``; smooth mode with an offset ``c > 0`` adds ``, offset 0.03 (...)``: the
    surface ``d_hat = c``, within ``c`` + the inflation bound of the data."""
    diag = scene.diagonal if scene.diagonal > 0 else 1.0
    parts = []
    for o in scene.objects:
        infl = (o.offset if scene.march.mode == "exact" else o.field.inflation(o.alpha, o.alpha_u))
        what = "offset" if scene.march.mode == "exact" else "inflation <="
        text = (f"alpha {o.alpha:.4g}, alpha_U {o.alpha_u:.4g}, {what} {infl:.3g} "
                f"({100 * infl / diag:.2g}% of the diagonal)")
        c = o.level(scene.march.mode)
        if scene.march.mode == "smooth" and c > 0:
            text += f", offset {c:.3g} ({100 * c / diag:.2g}%)"
        note = scene.extra.get("sparse", {}).get(o.name)
        if note:
            text += f", a cloud {note}"
        parts.append(text)
    return "; ".join(parts)


def scene_dict(scene, scene_path, source_paths):
    """A scene-file dict (our JSON format) that reproduces ``scene``.

    ``source_paths`` lists each object's mesh file; paths are written relative to the folder
    of ``scene_path`` (where the dict will be saved). ``tol`` and ``newton`` are written when
    they are not the defaults.
    """
    file = defaults("file")  # what a scene file means when a key is left out
    base = os.path.dirname(os.path.abspath(scene_path))

    def rel(p):
        return os.path.relpath(os.path.abspath(p), base).replace(os.sep, "/")

    objs = []
    for o, src in zip(scene.objects, source_paths):
        od = {"path": rel(src), "alpha": float(f"{o.alpha:.6g}"),
              "alpha_u": float(f"{o.alpha_u:.6g}"), "kind": o.field.mesh.kind}
        if scene.march.mode == "exact" or o.level(scene.march.mode) > 0:
            od["offset"] = float(f"{o.level(scene.march.mode):.6g}")
        objs.append(od)
    out = {"description": ("written by tracer render --save-scene from "
                           f"{os.path.basename(source_paths[0])}"),
           "camera": scene.camera.as_dict(),
           "objects": objs, "width": int(scene.film.width), "height": int(scene.film.height),
           "beta": float(scene.march.beta), "mode": scene.march.mode, "shading": scene.film.shading}
    if scene.film.matcap:
        out["matcap"] = rel(scene.film.matcap)
    if scene.march.tol != file["tol"]:
        out["tol"] = float(scene.march.tol)
    if scene.march.weights != file["weights"]:
        out["weights"] = scene.march.weights
    if scene.film.samples != file["samples"]:
        out["samples"] = int(scene.film.samples)
    if scene.film.adaptive != file["adaptive"]:
        out["adaptive"] = bool(scene.film.adaptive)
    if scene.film.transparent != file["transparent"]:
        out["transparent"] = bool(scene.film.transparent)
    if tuple(scene.film.background) != tuple(file["background"]):
        out["background"] = [int(v) for v in scene.film.background]
    if scene.film.shading == "lit":
        default = asdict(file["lighting"])
        changed = {k: (list(v) if isinstance(v, tuple) else v)
                   for k, v in asdict(scene.film.lighting).items() if v != default[k]}
        if changed:
            out["lighting"] = changed
    for od, o in zip(objs, scene.objects):
        if o.color is not None:
            od["color"] = [int(round(v)) for v in o.color]
    if scene.march.newton != file["newton"]:
        out["newton"] = float(scene.march.newton)
    return out

