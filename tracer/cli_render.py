"""``tracer render``: sphere-trace a scene file to a PNG, with optional AOVs."""

import json
import math
import os
import sys

import numpy as np

from smoothdist.cuda import CudaUnavailable, cuda_module
from smoothdist.mesh import MESH_EXTENSIONS, needs_trimesh
from tracer.errors import CLIError
from tracer.image import false_color, save_npy, save_png
from tracer.outputs import atomic_write, check_outputs, make_parents
from tracer.rendering.camera import (PROJECTIONS, UP_AXES, VIEWS, LookAt, frame_points,
                                     frame_width)
from tracer.rendering.frame import MAX_SAMPLES, ProgressBar, scene_arrays
from tracer.rendering.renderer import render
from tracer.scenes import from_mesh
from tracer.scenes.from_mesh import describe_parameters, resolve_up, scene_dict
from tracer.scenes.scene import (AUTHORS_KEYS, BVH_TYPES, WEIGHT_CHOICES, load_scene, mesh_paths,
                                 read_scene_json)
from tracer.scenes.settings import KINDS, default_text, defaults, table
from tracer.stages import StageClock, stage

HELP = "sphere-trace a scene file to a PNG (and AOVs)"


def add_arguments(p):
    """Arguments of ``tracer render``; the defaults they name come from
    :mod:`tracer.scenes.settings` (``_def(key)``: a scene file's, ``_def(key, "mesh")``: a mesh
    file's)."""
    _def = default_text
    p.add_argument("scene", metavar="PATH",
                   help="a scene JSON file (the authors' format, or ours; see "
                   "docs/scene-format.md) or a mesh / point-cloud file "
                   f"({', '.join(e[1:] for e in MESH_EXTENSIONS)}) to render directly")
    p.add_argument("-o", "--output", help="output PNG (default: renders/<file name>.png)")
    p.add_argument("--size", nargs=2, type=int, metavar=("W", "H"),
                   help="image size in pixels (overrides the scene's width/height; "
                   f"mesh default {_def('width', 'mesh')} {_def('height', 'mesh')})")
    p.add_argument("--beta", type=float, help="Barnes-Hut beta (0 = exact; default: scene's, "
                   f"{_def('beta', 'mesh')} for a mesh)")
    p.add_argument("--alpha", type=_auto_or_number("--alpha"), metavar="auto|A",
                   help="alpha of the (first) object, or 'auto' (default for a mesh): with "
                   "--alpha-u and --offset left out too, triangles get a thin shell, the level "
                   "set d_hat = C at C = 0.3%% of the bbox diagonal or a tenth of the local "
                   "feature size, alpha 20/C; curves a tube, C = 0.75 mean edge lengths, "
                   "alpha 6/C (30/C for wireframes); otherwise mean surface offset <= 2%% of "
                   "the bbox diagonal")
    p.add_argument("--alpha-u", type=_auto_or_number("--alpha-u", "off"),
                   metavar="auto|off|U",
                   help="alpha_U (attenuation) of the (first) object, or 'auto' = 20 x alpha, "
                   "which removes ribbing on tubes (default when the scene has no alpha_u), "
                   "or 'off' = alpha (no attenuation: the paper's weights even out an uneven "
                   "triangle tessellation that 'auto' shows as pleats)")
    p.add_argument("--kind", choices=KINDS,
                   help="mesh file: render its triangles, edges, points, or everything it "
                   "holds (mixed; the default)")
    p.add_argument("--view", choices=tuple(VIEWS),
                   help="camera framing the whole surface from this side (default for a mesh: "
                   f"{_def('view', 'mesh')}); with a scene file it replaces the scene's camera")
    p.add_argument("--up", choices=("auto",) + UP_AXES,
                   help="the data's up axis for --view (mesh files: auto = z for .stl and "
                   ".ply, y otherwise, and for the front view a flat object seen edge-on or "
                   "a long one end-on turned to its largest silhouette; scene files: y)")
    p.add_argument("--camera", nargs=9, type=float,
                   metavar=("OX", "OY", "OZ", "DX", "DY", "DZ", "UX", "UY", "UZ"),
                   help="explicit camera: ORIGIN DEST UP, 9 numbers")
    p.add_argument("--projection", choices=PROJECTIONS,
                   help="perspective (the authors' pinhole; default: scene's, else "
                   f"{_def('projection', 'mesh')}) or orthographic (parallel rays)")
    p.add_argument("--view-width", type=float, metavar="W",
                   help="orthographic: the view's width in scene units (default: the width "
                   "framing the surface, or the perspective camera's width at dest)")
    p.add_argument("--save-scene", metavar="OUT.json",
                   help="write the scene file used (camera, alpha, alpha_U, ...) to edit and "
                   "render again")
    p.add_argument("--tol", type=float, metavar="TOL",
                   help="tolerance-controlled pruning: d_hat within log(1 + TOL)/alpha of the "
                        f"exact sum, never above it (0 = off; default: scene's, else "
                        f"{_def('tol')}). With --beta 0 "
                        "it is the only pruning")
    newton = p.add_mutually_exclusive_group()
    newton.add_argument("--newton", type=float, metavar="N",
                        help="smooth mode: Newton steps along the ray once the distance is "
                        "below N x eps (at most 1%% of the bbox diagonal; default: scene's, "
                        f"else {_def('newton')})")
    newton.add_argument("--no-newton", dest="newton", action="store_const", const=0.0,
                        help="plain sphere tracing (= --newton 0); the images agree, Newton "
                        "steps only save distance evaluations")
    p.add_argument("--mode", choices=("smooth", "exact"),
                   help="smooth distance, or exact distance offset surface")
    p.add_argument("--weights", choices=WEIGHT_CHOICES,
                   help="weights of edges and triangles: paper (the paper's polynomials; "
                   f"default for a scene file: {_def('weights')}), inclusion-exclusion (the "
                   "exact distance's sum above flat faces and outside convex edges: no seams "
                   f"on flat faces), or auto (default for a mesh file: "
                   f"{_def('weights', 'mesh')}): inclusion-exclusion for the automatic "
                   "surface, paper once --alpha, --alpha-u or --offset is given")
    p.add_argument("--offset", type=float, metavar="C",
                   help="the surface's offset C >= 0: smooth mode d_hat = C (default 0; "
                   "with alpha and alpha_U auto, edges and triangles: see --alpha), "
                   "exact mode d = C (default 1/alpha per object)")
    p.add_argument("--eps", type=float, help="hit threshold in scene units "
                   f"(default {_def('eps')})")
    p.add_argument("--shading", choices=("lit", "normals", "matcap", "headlight"),
                   help="lit: key and fill lights, soft shadows, ambient occlusion and a "
                   "ground; normals: the paper's view-space normal colours; matcap; diffuse "
                   f"headlight (default for a mesh file: {_def('shading', 'mesh')}; for a "
                   f"scene file: {_def('shading')}, matcap when it names a matcap)")
    p.add_argument("--samples", type=int, metavar="N",
                   help="anti-aliasing: N samples per pixel, tent-filtered (default: scene's, "
                   f"{_def('samples')})")
    p.add_argument("--adaptive", action="store_true", default=None,
                   help="give the extra samples only to pixels that differ from a neighbour "
                   "(edges, shadow borders)")
    p.add_argument("--transparent", action="store_true", default=None,
                   help="RGBA PNG: transparent background, alpha = coverage (with the lit "
                   "shading's ground: its shadow only)")
    p.add_argument("--color", nargs=3, type=int, metavar=("R", "G", "B"),
                   help="lit shading: base colour of the (first) object, 0-255")
    p.add_argument("--background", nargs=3, type=int, metavar=("R", "G", "B"),
                   help=f"background colour, 0-255 (default {_def('background')})")
    p.add_argument("--penumbra", type=float,
                   help="lit shading: shadow softness > 0 (0.02 nearly hard, default "
                   f"{defaults('file')['lighting'].penumbra:g})")
    p.add_argument("--no-shadows", dest="shadows", action="store_false", default=None,
                   help="lit shading: no shadows")
    p.add_argument("--no-ao", dest="ao", action="store_false", default=None,
                   help="lit shading: no ambient occlusion")
    p.add_argument("--no-ground", dest="ground", action="store_false", default=None,
                   help="lit shading: no ground plane")
    _add_output_arguments(p)


def _add_output_arguments(p):
    """The outputs of ``tracer render`` beside its PNG (AOVs, heat maps, statistics) and how
    it runs (threads, device, overwrite, quiet)."""
    p.add_argument("--depth", metavar="OUT.npy",
                   help="write the depth AOV: ray parameter t, float32 (H, W), NaN on misses")
    p.add_argument("--normals", metavar="OUT.npy",
                   help="write unit world-space normals, float32 (H, W, 3), 0 on misses")
    p.add_argument("--steps-png", metavar="OUT.png",
                   help="false-colour heat map of distance evaluations per pixel")
    p.add_argument("--leaves-png", metavar="OUT.png",
                   help="false-colour heat map of BVH leaves visited per pixel")
    p.add_argument("--stats", metavar="OUT.json", help="write the render statistics as JSON")
    p.add_argument("--stage-times", metavar="OUT.json", dest="stage_times",
                   help="write the seconds of each stage (load, tree, parameters, framing, "
                        "trace, light, write) as JSON")
    p.add_argument("--threads", type=int, help="number of threads (default: all cores)")
    p.add_argument("--device", choices=("cpu", "cuda"), default="cpu",
                   help="trace on the CPU (default) or on an NVIDIA GPU (needs the gpu extra: "
                        "pip install -e '.[gpu]' in the clone)")
    p.add_argument("--overwrite", action="store_true", help="replace existing output files")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar or summary")


def _auto_or_number(flag, *words):
    words = ("auto",) + words

    def parse(text):
        if text in words:
            return text
        try:
            return float(text)
        except ValueError:
            raise ValueError(f"{flag} must be a number or {' or '.join(map(repr, words))}, "
                             f"got {text!r}") from None
    parse.__name__ = flag
    return parse


#: numeric options and what they must be: (flag, attribute, lower bound, bound included)
_NUMBERS = (("--alpha", "alpha", 0.0, False), ("--alpha-u", "alpha_u", 0.0, False),
            ("--beta", "beta", 0.0, True), ("--eps", "eps", 0.0, False),
            ("--tol", "tol", 0.0, True), ("--newton", "newton", 0.0, True),
            ("--offset", "offset", 0.0, True), ("--penumbra", "penumbra", 0.0, False),
            ("--samples", "samples", 1, True), ("--view-width", "view_width", 0.0, False))


def check_options(args):
    """The command line's numbers, checked before any file is read or any output looked at
    (so ``--size 0 0`` is reported as such, not as an existing output). One-line
    :class:`~tracer.errors.CLIError` naming the flag; the scene and mesh loaders check them
    again."""
    if args.size:
        for what, v in zip(("width", "height"), args.size):
            if v <= 0:
                raise CLIError(f"--size {what} must be > 0, got {v}")
    for flag, attr, low, closed in _NUMBERS:
        v = getattr(args, attr, None)
        if v is None or v in ("auto", "off"):
            continue
        if not math.isfinite(v):
            raise CLIError(f"{flag} must be finite, got {v}")
        if v < low or (v == low and not closed):
            raise CLIError(f"{flag} must be {'>=' if closed else '>'} {low:g}, got {v}")

    if args.view_width is not None and args.projection != "orthographic":
        raise CLIError("--view-width applies to --projection orthographic")
    if args.samples is not None and args.samples > MAX_SAMPLES:
        raise CLIError(f"--samples must be at most {MAX_SAMPLES}, got {args.samples}")
    for flag in ("color", "background"):
        v = getattr(args, flag, None)
        if v is not None and not all(0 <= c <= 255 for c in v):
            raise CLIError(f"--{flag} must be three integers 0-255, got {' '.join(map(str, v))}")


def input_kind(path):
    """``"scene"`` or ``"mesh"`` for a render input, from its extension (or a leading ``{``);
    a one-line ``CLIError`` saying what is accepted for anything else."""
    path = os.fspath(path)
    if os.path.isdir(path):
        raise CLIError(f"cannot render {path}: it is a folder, not a file (give a scene file "
                       f"(.json) or a mesh / point-cloud file in it)")
    ext = os.path.splitext(path)[1].lower()
    if ext in MESH_EXTENSIONS:
        return "mesh"
    if ext == ".json":
        return "scene"
    if os.path.isfile(path):
        try:
            with open(path, "rb") as fh:
                head = fh.read(256).lstrip()
        except OSError:
            head = b""
        if head.startswith(b"{"):
            return "scene"
    elif not os.path.exists(path):
        raise CLIError(f"file not found: {path}")
    raise CLIError(f"cannot render {path}: not a scene file (.json) or a mesh / point-cloud "
                   f"file ({', '.join(MESH_EXTENSIONS)})")


def needs(args):
    """The optional packages this render imports (:mod:`tracer.cli` checks them first):
    matplotlib for ``--steps-png`` / ``--leaves-png``, Pillow for the PNG, trimesh for a mesh
    file (given, or named by the scene file) that our own readers do not read."""

    out = ["matplotlib"] if args.steps_png or args.leaves_png else []
    out.append("PIL")
    ext = os.path.splitext(args.scene)[1].lower()
    files = [args.scene] if ext in MESH_EXTENSIONS else mesh_paths(args.scene)
    if any(needs_trimesh(p) for p in files):
        out.append("trimesh")
    return out


def run(args):
    """Render; returns the exit status."""

    source = input_kind(args.scene)
    check_options(args)
    if args.device == "cuda":
        try:
            cuda_module()
        except CudaUnavailable as exc:
            raise CLIError(str(exc)) from None
    if source == "scene" and args.kind:
        raise CLIError("--kind applies to mesh files; a scene file sets kind per object")
    if source == "scene" and args.up and not args.view:
        raise CLIError("--up applies to a --view; a scene file's camera sets its own up")
    overrides = {"beta": args.beta, "alpha": args.alpha, "alpha_u": args.alpha_u,
                 "mode": args.mode, "eps": args.eps, "shading": args.shading,
                 "offset": args.offset, "tol": args.tol, "newton": args.newton,
                 "samples": args.samples, "adaptive": args.adaptive,
                 "transparent": args.transparent, "lighting": _lighting_args(args),
                 "projection": args.projection, "view_width": args.view_width,
                 "weights": args.weights}
    if args.size:
        overrides["width"], overrides["height"] = args.size
    name = os.path.splitext(os.path.basename(args.scene))[0]
    out = args.output or os.path.join("renders", f"{name}.png")
    if not out.lower().endswith(".png"):
        raise ValueError(f"output must be a .png file, got {out}")
    for opt, path, ext in (("--depth", args.depth, ".npy"), ("--normals", args.normals, ".npy"),
                           ("--steps-png", args.steps_png, ".png"),
                           ("--leaves-png", args.leaves_png, ".png"),
                           ("--stats", args.stats, ".json"),
                           ("--stage-times", args.stage_times, ".json")):
        if path is not None and not path.lower().endswith(ext):
            raise ValueError(f"{opt} must name a {ext} file, got {path}")
    if args.save_scene is not None and not args.save_scene.lower().endswith(".json"):
        raise ValueError(f"--save-scene must name a .json file, got {args.save_scene}")
    outputs = [out, args.depth, args.normals, args.steps_png, args.leaves_png, args.stats,
               args.save_scene, args.stage_times]
    check_outputs(outputs, args.overwrite, create=False)
    clock = StageClock(name, quiet=args.quiet)
    with clock:
        _render_and_write(args, source, overrides, name, out, outputs)
    if args.stage_times:
        with atomic_write(args.stage_times, overwrite=args.overwrite) as tmp:
            with open(tmp, "w", encoding="utf-8") as fh:
                json.dump(clock.as_dict(), fh, indent=2)
        if not args.quiet:
            print(f"Stage times: {', '.join(f'{n} {t:.2f} s' for n, t in clock.times)}; "
                  f"wrote {args.stage_times}.")
    sys.stdout.flush()
    return 0


def _render_and_write(args, source, overrides, name, out, outputs):
    """Build the scene, render it and write every output; returns the paths written."""
    if source == "mesh":
        scene = _mesh_scene(args)
    else:
        with stage("load", "reading the scene and building its trees"):
            scene = load_scene(args.scene, overrides)
        if args.view or args.camera:
            _replace_camera(scene, args)
        if args.color is not None:
            scene.objects[0].color = tuple(float(c) for c in args.color)
        if args.background is not None:
            scene.background = tuple(args.background)
    bar = None if args.quiet else ProgressBar(f"render {name}")
    result = render(scene, progress=bar, device=args.device)
    with stage("write", "writing the image"):
        written = _write(args, source, scene, result, out, outputs)
    _summary(args, source, scene, result, name, written)
    return written


def _write(args, source, scene, result, out, outputs):
    """Write the image and the other outputs asked for; returns their paths."""
    make_parents(outputs)
    written = [result.save(out, overwrite=args.overwrite)]
    if args.depth:
        written.append(save_npy(args.depth, result.depth, overwrite=args.overwrite))
    if args.normals:
        written.append(save_npy(args.normals, result.normals.astype(np.float32),
                                overwrite=args.overwrite))
    if args.steps_png:
        written.append(save_png(args.steps_png, false_color(result.steps.astype(float),
                                                            cmap="magma"),
                                overwrite=args.overwrite))
    if args.leaves_png:
        written.append(save_png(args.leaves_png, false_color(result.leaves.astype(float),
                                                             cmap="magma"),
                                overwrite=args.overwrite))
    if args.save_scene:
        written.append(_save_scene(args, scene, source))
    if args.stats:
        with atomic_write(args.stats, overwrite=args.overwrite) as tmp:
            with open(tmp, "w", encoding="utf-8") as fh:
                json.dump(_stats(args, scene, result), fh, indent=2)
        written.append(args.stats)
    return written


def _stats(args, scene, result):
    """The render statistics of ``--stats`` (and the summary line)."""
    stats = result.summary()
    mode = scene.march.mode
    stats.update(scene=os.path.abspath(args.scene), mode=mode, beta=scene.march.beta,
                 tol=scene.march.tol, newton=scene.march.newton, eps=scene.march.eps,
                 objects=[{"name": o.name, "alpha": o.alpha, "alpha_u": o.alpha_u,
                           "offset": o.level(mode), "primitives": o.field.num_primitives}
                          for o in scene.objects])
    return stats


def _summary(args, source, scene, result, name, written):
    """Print the one-line summary of the render (not with ``--quiet``)."""
    if not args.quiet:
        s = _stats(args, scene, result)
        prims = sum(o["primitives"] for o in s["objects"])
        view = ""
        if source == "mesh" and not args.camera:
            why = scene.extra.get("orientation")
            if why and not why.endswith("(the file's convention)"):
                view = f", {why}"
            else:
                view = (f", view {args.view or 'front'} with {resolve_up(args.scene, args.up)} "
                        "up" + ("" if args.up not in (None, "auto") else
                                " (guessed; --up to change)"))
        print(f"Rendered {name}: {s['width']}x{s['height']} px, {len(s['objects'])} object(s) "
              f"with {prims} primitives ({describe_parameters(scene)}), "
              f"{scene.march.mode} mode, beta {scene.march.beta:g}{view}, in "
              f"{s['seconds']:.2f} s; {s['hits']} hits ({100 * s['hit_fraction']:.1f}%), "
              f"{s['mean_steps']:.1f} distance evaluations and {s['mean_leaves']:.0f} leaves "
              f"visited per pixel on average. Wrote {', '.join(map(str, written))}.")


def _lighting_args(args):
    """The lit shading's settings given on the command line (None: not given)."""
    return {"penumbra": args.penumbra, "shadows": args.shadows, "ao": args.ao,
            "ground": args.ground}


def _camera_arg(args):
    c = args.camera
    return (np.array(c[0:3]), np.array(c[3:6]), np.array(c[6:9]))


def _mesh_scene(args):
    """The scene for a mesh file given on the command line (an error about a setting names
    its option, as the scene-file path's ``--eps must be > 0`` does)."""
    try:
        return _build_mesh_scene(args)
    except ValueError as exc:
        msg = str(exc)
        for name in mesh_options(args):
            if msg.startswith(name + " ") and getattr(args, name) is not None:
                raise CLIError(_flag_of(name) + msg[len(name):]) from None
        raise


def mesh_options(args):
    """The settings ``tracer render MESH`` takes from options of the same name: every key of
    the settings table (:func:`tracer.scenes.settings.table`) that the command line has (the
    others keep the mesh entry points' defaults). A new setting with an option of its name is
    taken with no list to edit."""
    return [r.key for r in table() if r.key in vars(args)]


def _flag_of(name):
    """The option of the setting ``name``: ``alpha_u`` -> ``--alpha-u``."""
    return "--" + name.replace("_", "-")


def _build_mesh_scene(args):
    d = defaults("mesh")  # the options left out: as render_mesh's
    given = {k: d[k] if getattr(args, k) is None else getattr(args, k)
             for k in mesh_options(args)}
    given.update(size=args.size or (d["width"], d["height"]),
                 adaptive=bool(given["adaptive"]), transparent=bool(given["transparent"]),
                 background=tuple(given["background"]),
                 lighting={k: v for k, v in _lighting_args(args).items() if v is not None})
    return from_mesh.build_mesh_scene(args.scene, None, args.kind,
                                      *from_mesh.settings_groups(given),
                                      camera=_camera_arg(args) if args.camera else None)


def _replace_camera(scene, args):
    """``--view`` / ``--camera`` for a scene file: a new camera (for ``--view``, framing every
    object's vertices grown by the tracer's conservative margin, which contains the surface)."""

    projection, view_width = scene.camera.projection, args.view_width
    if args.camera:
        pose = _camera_arg(args)
    else:
        grow = float(scene.bounds[0][0] - scene_arrays(scene)[4][0])
        P = np.concatenate([o.field.mesh.used_vertices() for o in scene.objects])
        W, H = scene.film.width, scene.film.height
        pose = frame_points(P, grow, args.view, W, H,
                            up=args.up if args.up not in (None, "auto") else "y")
        if projection == "orthographic" and view_width is None:
            view_width = frame_width(P, grow, pose, W, H)
    camera = LookAt(*pose, projection, view_width)
    camera.camera(scene.film.width, scene.film.height)  # validates
    scene.camera = camera


def _save_scene(args, scene, source):
    """Write ``--save-scene``: a scene file that renders the same picture."""

    if source == "mesh":
        data = scene_dict(scene, args.save_scene, [args.scene])
        if args.eps is not None:
            data["eps"] = scene.march.eps
    else:
        data = _edited_scene(read_scene_json(args.scene), args, scene)
    make_parents([args.save_scene])
    with atomic_write(args.save_scene, overwrite=args.overwrite) as tmp:
        with open(tmp, "w", encoding="utf-8") as fh:
            json.dump(data, fh, indent=2)
            fh.write("\n")
    return args.save_scene


def _edited_scene(data, args, scene):
    """The scene file's dict with the command line's overrides applied and its relative
    paths rewritten for the folder of ``--save-scene``."""
    src = os.path.dirname(os.path.abspath(args.scene))
    dst = os.path.dirname(os.path.abspath(args.save_scene))

    def move(p):
        if not isinstance(p, str) or not p or os.path.isabs(os.path.expanduser(p)):
            return p
        return os.path.relpath(os.path.join(src, p), dst).replace(os.sep, "/")

    data = json.loads(json.dumps(data))
    if "matcap" in data:
        data["matcap"] = move(data["matcap"])
    for od in data["objects"]:
        for part in [od] + list(od.get("parts", [])):
            for key in ("path", "matcap"):
                if key in part:
                    part[key] = move(part[key])
            for old, ours in AUTHORS_KEYS.items():  # written in our spelling
                if old in part:
                    value = part.pop(old)
                    part[ours] = BVH_TYPES.get(value, value) if ours == "kind" else value
    data["camera"] = scene.camera.as_dict()
    first = data["objects"][0]
    if args.alpha is not None:
        first["alpha"] = args.alpha
    if args.alpha_u is not None:
        first["alpha_u"] = (args.alpha_u if args.alpha_u != "off"
                            else float(f"{scene.objects[0].alpha_u:.6g}"))
    if args.size:
        data["width"], data["height"] = args.size
    for key in ("beta", "mode", "eps", "shading", "offset", "tol", "newton", "samples",
                "adaptive", "transparent"):
        if getattr(args, key) is not None:
            data[key] = getattr(args, key)
            if key in ("beta", "offset"):  # the command line overrode per-object values too
                for od in data["objects"]:
                    od.pop(key, None)
    given = {k: v for k, v in _lighting_args(args).items() if v is not None}
    if given:
        data.setdefault("lighting", {}).update(given)
    if args.color is not None:
        first["color"] = list(args.color)
    if args.background is not None:
        data["background"] = list(args.background)
    return data
