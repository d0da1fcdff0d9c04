"""``tracer render``: sphere-trace a scene file to a PNG, with optional AOVs."""

import argparse
import json
import math
import os
import sys

import numpy as np

from smoothdist.cuda import CudaUnavailable, cuda_module
from smoothdist.mesh import MESH_EXTENSIONS, needs_trimesh
from tracer.compiling import ahead_allowed
from tracer.errors import CLIError
from tracer.image import false_color, save_npy, save_png
from tracer.outputs import atomic_write, check_outputs, make_parents
from tracer.rendering.camera import LookAt, frame_points, frame_width
from tracer.rendering.frame import ProgressBar, scene_arrays
from tracer.rendering.renderer import render
from tracer.scenes import from_mesh
from tracer.scenes.from_mesh import describe_parameters, resolve_up, scene_dict
from tracer.scenes.scene import AUTHORS_KEYS, BVH_TYPES, load_scene, mesh_paths, read_scene_json
from tracer.scenes.settings import (KINDS, REQUIRED, RGB, check, default_text, defaults,
                                    flag_of, row, table)
from tracer.stages import StageClock, stage

HELP = "sphere-trace a scene file to a PNG (and AOVs)"


def add_arguments(p):
    """Arguments of ``tracer render``: one option per setting of :mod:`tracer.scenes.settings`
    (``_add_setting_options``), the options whose shape is not one setting's, and the
    outputs."""
    p.add_argument("scene", metavar="PATH",
                   help="a scene JSON file (the authors' format, or ours; see "
                   "docs/scene-format.md) or a mesh / point-cloud file "
                   f"({', '.join(e[1:] for e in MESH_EXTENSIONS)}) to render directly")
    p.add_argument("-o", "--output", help="output PNG (default: renders/<file name>.png)")
    # two settings (width, height) in one option
    p.add_argument("--size", nargs=2, type=int, metavar=("W", "H"),
                   help="image size in pixels (overrides the scene's width/height; "
                   f"mesh default {default_text('width', 'mesh')} "
                   f"{default_text('height', 'mesh')})")
    # not a setting: the mesh file's primitives (a scene file sets them per object)
    p.add_argument("--kind", choices=KINDS,
                   help="mesh file: render its triangles, edges, points, or everything it "
                   "holds (mixed; the default)")
    # not a setting: the camera itself, nine numbers
    p.add_argument("--camera", nargs=9, type=float,
                   metavar=("OX", "OY", "OZ", "DX", "DY", "DZ", "UX", "UY", "UZ"),
                   help="explicit camera: ORIGIN DEST UP, 9 numbers")
    p.add_argument("--save-scene", metavar="OUT.json",
                   help="write the scene file used (camera, alpha, alpha_U, ...) to edit and "
                   "render again")
    newton = p.add_mutually_exclusive_group()
    _add_setting_options(p, {"newton": newton})
    # a second spelling of a setting's value (--newton 0), exclusive with --newton
    newton.add_argument("--no-newton", dest="newton", action="store_const", const=0.0,
                        help="plain sphere tracing (= --newton 0); the images agree, Newton "
                        "steps only save distance evaluations")
    # the lit shading's settings: fields of Lighting (the table's lighting), one by one
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


#: what an option adds to its setting's help on the command line
_NOTES = {"view": "; with a scene file it replaces the scene's camera",
          "up": "; for a scene file's --view: y",
          **{k: "; with a scene file: its first object's" for k in ("alpha", "alpha_u",
                                                                    "color")}}


def _add_setting_options(p, groups=None):
    """One option per setting of the table with ``flag`` (:func:`tracer.scenes.settings.table`):
    ``--`` + its key with dashes, its choices, its values checked by
    :func:`tracer.scenes.settings.check` (the error names the option), its help the field's
    with the defaults of scene files and mesh files; argparse's default None is "not given".
    ``groups``: the argument group of a key (``--newton``'s, exclusive with ``--no-newton``)."""
    for r in table():
        if not r.flag:
            continue
        kw = dict(help=f"{r.help} ({_default_phrase(r)}{_NOTES.get(r.key, '')})"
                  .replace("%", "%%"))
        if r.choices:
            kw.update(choices=r.choices)
        elif r.kind is bool:
            kw.update(action="store_true", default=None)
        elif r.kind == RGB:
            kw.update(nargs=3, type=int, metavar=r.metavar, action=_Vector)
        else:
            kw.update(type=_setting_type(r.key),
                      metavar="|".join(r.words + (r.metavar or r.key.upper(),)))
        (groups or {}).get(r.key, p).add_argument(flag_of(r.key), **kw)


def _default_phrase(r):
    """The defaults of a setting as its option's help names them (:func:`default_text`)."""
    mesh = default_text(r.key, "mesh")
    if r.file is REQUIRED:
        return f"default for a mesh file: {mesh}"
    file = r.text or default_text(r.key)
    if file == mesh:
        return f"default: the scene file's, else {file}"
    return f"default: the scene file's, else {file}; for a mesh file: {mesh}"


def _setting_type(key):
    """The ``type=`` of a number setting's option: one of its words (``auto``) as it is, else
    the number checked (:func:`tracer.scenes.settings.check`; the error names the option)."""
    r, flag = row(key), flag_of(key)

    def parse(text):
        if text in r.words:
            return text
        try:
            value = r.kind(text)
        except ValueError:
            if not r.words:
                raise           # argparse: "invalid float value: 'abc'"
            raise argparse.ArgumentTypeError(
                f"{flag} must be a number or {' or '.join(map(repr, r.words))}, "
                f"got {text!r}") from None
        try:
            return check(key, value, flag, typed=True)
        except ValueError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None
    parse.__name__ = r.kind.__name__
    return parse


class _Vector(argparse.Action):
    """A colour setting's option (``--background R G B``): the three numbers checked together
    (:func:`tracer.scenes.settings.check`), kept as given."""

    def __call__(self, parser, namespace, values, option_string=None):
        try:
            check(self.dest, list(values), option_string, typed=True)
        except ValueError as exc:
            raise argparse.ArgumentError(self, str(exc)) from None
        setattr(namespace, self.dest, list(values))


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


def check_options(args):
    """The command line's numbers that no option's ``type=`` checks (``--size``,
    ``--penumbra``) and the options that need another, checked before any file is read or any
    output looked at (so ``--size 0 0`` is reported as such, not as an existing output).
    One-line :class:`~tracer.errors.CLIError` naming the flag; the scene and mesh loaders
    check them again."""
    if args.size:
        for what, v in zip(("width", "height"), args.size):
            if v <= 0:
                raise CLIError(f"--size {what} must be > 0, got {v}")
    if args.penumbra is not None and not (math.isfinite(args.penumbra) and args.penumbra > 0):
        raise CLIError(f"--penumbra must be {'> 0' if math.isfinite(args.penumbra) else 'finite'}"
                       f", got {args.penumbra}")
    if args.view_width is not None and args.projection != "orthographic":
        raise CLIError("--view-width applies to --projection orthographic")


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
    overrides = {k: getattr(args, k) for k in mesh_options(args)}  # None: not given
    overrides["lighting"] = _lighting_args(args)
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
    # a first render may compile its film's kernels in a second process (compile_ahead)
    with clock, ahead_allowed(args.device == "cpu"):
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
    return flag_of(name)


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
    for key in (r.key for r in table() if r.scene_key and r.key in vars(args)):
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
    return data
