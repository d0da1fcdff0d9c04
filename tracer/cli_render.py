"""``tracer render``: sphere-trace a scene file to a PNG, with optional AOVs."""

import json
import os
import sys

import numpy as np

from tracer.cli import check_outputs, make_parents

#: aim for kernel calls of about this many pixels, so that Ctrl-C / SIGTERM (handled between
#: calls) stops a render within a second or two even for slow scenes
BAND_PIXELS = 16384


def add_arguments(p):
    """Arguments of ``tracer render``."""
    p.add_argument("scene", help="scene JSON file (the authors' format, or ours)")
    p.add_argument("-o", "--output", help="output PNG (default: renders/<scene name>.png)")
    p.add_argument("--size", nargs=2, type=int, metavar=("W", "H"),
                   help="image size in pixels (overrides the scene's width/height)")
    p.add_argument("--beta", type=float, help="Barnes-Hut beta (0 = exact; default: scene's)")
    p.add_argument("--tol", type=float, metavar="TOL",
                   help="tolerance-controlled pruning: d_hat within log(1 + TOL)/alpha of the "
                        "exact sum, never above it (0 = off; default: scene's). With --beta 0 "
                        "it is the only pruning")
    p.add_argument("--alpha", type=float, help="alpha of the first object (overrides the scene)")
    p.add_argument("--mode", choices=("smooth", "exact"),
                   help="smooth distance, or exact distance offset surface")
    p.add_argument("--offset", type=float,
                   help="exact mode: offset distance (default 1/alpha per object)")
    p.add_argument("--eps", type=float, help="hit threshold in scene units "
                   "(default 1e-4 x bbox diagonal)")
    p.add_argument("--shading", choices=("normals", "matcap", "headlight"),
                   help="view-space normal colours, matcap, or diffuse headlight")
    p.add_argument("--depth", metavar="OUT.npy",
                   help="write the depth AOV: ray parameter t, float32 (H, W), NaN on misses")
    p.add_argument("--normals", metavar="OUT.npy",
                   help="write unit world-space normals, float32 (H, W, 3), 0 on misses")
    p.add_argument("--steps-png", metavar="OUT.png",
                   help="false-colour heat map of distance evaluations per pixel")
    p.add_argument("--leaves-png", metavar="OUT.png",
                   help="false-colour heat map of BVH leaves visited per pixel")
    p.add_argument("--stats", metavar="OUT.json", help="write the render statistics as JSON")
    p.add_argument("--threads", type=int, help="number of threads (default: all cores)")
    p.add_argument("--overwrite", action="store_true", help="replace existing output files")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar or summary")


def band_rows(width, height):
    """Rows per kernel call: a multiple of the tile size with about :data:`BAND_PIXELS` pixels
    but at least four tiles per thread (so that threads stay busy), at most the whole image.

    The banding does not change the image: every pixel is traced the same way in any band.
    """
    import numba

    from tracer.march import TILE

    threads = numba.get_num_threads()
    tiles_per_row = max(1, -(-width // TILE))
    rows = max(BAND_PIXELS // max(width, 1), TILE * -(-4 * threads // tiles_per_row))
    rows = TILE * max(1, -(-rows // TILE))
    return min(rows, TILE * max(1, -(-height // TILE)))


def run(args):
    """Render; returns the exit status."""
    from tracer.image import false_color, save_npy, save_png
    from tracer.render import ProgressBar, render
    from tracer.scene import load_scene

    overrides = {"beta": args.beta, "alpha": args.alpha, "mode": args.mode, "eps": args.eps,
                 "shading": args.shading, "offset": args.offset, "tol": args.tol}
    if args.size:
        overrides["width"], overrides["height"] = args.size
    name = os.path.splitext(os.path.basename(args.scene))[0]
    out = args.output or os.path.join("renders", f"{name}.png")
    if not out.lower().endswith(".png"):
        raise ValueError(f"output must be a .png file, got {out}")
    for opt, path, ext in (("--depth", args.depth, ".npy"), ("--normals", args.normals, ".npy"),
                           ("--steps-png", args.steps_png, ".png"),
                           ("--leaves-png", args.leaves_png, ".png"),
                           ("--stats", args.stats, ".json")):
        if path is not None and not path.lower().endswith(ext):
            raise ValueError(f"{opt} must name a {ext} file, got {path}")
    outputs = [out, args.depth, args.normals, args.steps_png, args.leaves_png, args.stats]
    check_outputs(outputs, args.overwrite, create=False)
    scene = load_scene(args.scene, overrides)
    bar = None if args.quiet else ProgressBar(f"render {name}")
    result = render(scene, progress=bar, band_rows=band_rows(scene.width, scene.height))
    make_parents(outputs)
    written = [save_png(out, result.rgb, overwrite=args.overwrite)]
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
    stats = result.summary()
    stats.update(scene=os.path.abspath(args.scene), mode=scene.mode, beta=scene.beta,
                 tol=scene.tol,
                 eps=scene.eps, objects=[{"name": o.name, "alpha": o.alpha, "alpha_u": o.alpha_u,
                                          "primitives": o.field.num_primitives}
                                         for o in scene.objects])
    if args.stats:
        from tracer.image import atomic_write

        with atomic_write(args.stats, overwrite=args.overwrite) as tmp:
            with open(tmp, "w", encoding="utf-8") as fh:
                json.dump(stats, fh, indent=2)
        written.append(args.stats)
    if not args.quiet:
        s = stats
        prims = sum(o["primitives"] for o in s["objects"])
        print(f"Rendered {name}: {s['width']}x{s['height']} px, {len(s['objects'])} object(s) "
              f"with {prims} primitives, {scene.mode} mode, beta {scene.beta:g}, in "
              f"{s['seconds']:.2f} s; {s['hits']} hits ({100 * s['hit_fraction']:.1f}%), "
              f"{s['mean_steps']:.1f} distance evaluations and {s['mean_leaves']:.0f} leaves "
              f"visited per pixel on average. Wrote {', '.join(map(str, written))}.")
    sys.stdout.flush()
    return 0
