"""Tolerance-controlled evaluation (``tol``) in a render: time, and depth error against beta = 0.

The bunny (``scenes/data/bunny.off``) as points, edges and triangles, alpha 200, alpha_U 1200,
the paper's camera, ``--size`` squared pixels (default 512), 2 threads, our default eps
(1e-4 x the bbox diagonal) unless ``--eps`` is given. For each ``--tol``: the render time
(one ``tracer.render`` call, best of ``--repeat``), mean leaves per pixel, and the
depth error against a ``beta = 0`` reference, in units of the bbox diagonal: mean and max
of ``|t_tol - t_0|`` over pixels where both hit (the authors' metric), and the number of
pixels whose hit/miss differs. A full ``beta = 0`` render takes minutes (about 0.3 / 2.3 /
1.6 min at 512² on 2 cores, 2026-11-26), so the reference is traced on every
``--stride``-th pixel in each direction only (default 8: 1/64 of the pixels). The beta 0.5 render is listed for comparison
(its error and time), with the authors' beta 0.5 times from ``bench_authors.py``'s published
table (same machine class; measure side by side with ``bench_authors.py --tol``). With
``--full-beta0`` the whole ``beta = 0`` render is timed as well (once; about 6 / 40 / 28 s at
256², 2 threads) and every row gets its time as a fraction of it, the ratio of issue 20's
third target (tol at beta-0 accuracy against our own beta-0 render).

Usage::

    python benchmarks/bench_tol.py                         # 512², tol 1e-2 3e-3 1e-3
    python benchmarks/bench_tol.py --size 128 --tol 1e-2 --types points --stride 4
    python benchmarks/bench_tol.py --size 256 --tol 3e-3 4e-3 --stride 4 --full-beta0
"""

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import numba  # noqa: E402

import smoothdist  # noqa: E402
from smoothdist import SmoothDistanceField  # noqa: E402
from tracer.rendering import march  # noqa: E402
from tracer.rendering.frame import MarchArgs, TraceOptions  # noqa: E402
from tracer.rendering.frame import camera_of, scene_arrays  # noqa: E402
from tracer.rendering.renderer import render  # noqa: E402
from tracer.scenes.scene import scene_from_field  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_authors import ALPHA, ALPHA_U, MESH, PUBLISHED, TYPES, load, paper_camera  # noqa: E402


def reference_depths(scene, stride):
    """``beta = 0`` (tol 0) depths on every ``stride``-th pixel: ``(rows, cols, hit, t)``."""
    H, W = scene.height, scene.width
    rr, cc = np.meshgrid(np.arange(stride // 2, H, stride), np.arange(stride // 2, W, stride),
                         indexing="ij")
    rows, cols = rr.ravel().astype(np.int64), cc.ravel().astype(np.int64)
    tree, roots, params, mode, lo, hi, depth_max, tol = scene_arrays(scene)
    hit = np.zeros(rows.size, dtype=np.bool_)
    t = np.full(rows.size, np.nan)
    steps = np.zeros(rows.size, dtype=np.int64)
    leaves = np.zeros(rows.size, dtype=np.int64)
    ray = MarchArgs(roots, params, mode, tol, camera_of(scene).as_array(), lo, hi,
                    float(scene.eps), int(scene.max_steps))
    march.trace_pixels(tree, ray, rows, cols, depth_max, (hit, t, steps, leaves),
                       TraceOptions(0.0, march.OMEGA, False,
                                    march.newton_distance(scene.eps, lo, hi)))
    return rows, cols, hit, t


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--size", type=int, default=512)
    p.add_argument("--types", nargs="+", choices=TYPES, default=list(TYPES))
    p.add_argument("--tol", type=float, nargs="+", default=[1e-2, 3e-3, 1e-3])
    p.add_argument("--eps", type=float, default=None,
                   help="hit threshold, scene units (default 1e-4 x bbox diagonal)")
    p.add_argument("--stride", type=int, default=8, help="reference pixel stride (default 8)")
    p.add_argument("--repeat", type=int, default=1)
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--full-beta0", action="store_true", dest="full_beta0",
                   help="also time the whole beta 0 render and give each row's time over it")
    args = p.parse_args(argv)
    numba.set_num_threads(args.threads)
    full = smoothdist.load_mesh(MESH)
    camera = paper_camera(full.V)
    print(f"# {load()} before; {args.threads} threads", file=sys.stderr)
    lines = ["| type | setting | render s | / beta 0 | mean leaves/px | depth error mean (diag) "
             "| max (diag) | hit/miss differ | authors beta 0.5 s (published) |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|"]
    for kind in args.types:
        field = SmoothDistanceField(full.as_kind(kind))
        diag = field.diagonal
        eps = args.eps if args.eps is not None else 1e-4 * diag

        def scene(beta, tol, size=args.size):
            return scene_from_field(field, alpha=ALPHA, alpha_u=ALPHA_U, beta=beta, tol=tol,
                                    camera=camera, width=size, height=size, eps=eps)

        render(scene(0.5, 0.0, 16))
        render(scene(0.0, args.tol[0], 16))
        t0 = time.perf_counter()
        rows, cols, rhit, rt = reference_depths(scene(0.0, 0.0), args.stride)
        print(f"# {kind}: beta 0 reference on {rows.size} pixels in "
              f"{time.perf_counter() - t0:.1f} s ({load()})", file=sys.stderr, flush=True)
        authors = PUBLISHED.get(args.size, {}).get(kind, (None,))[0]
        full0 = None
        if args.full_beta0:
            t0 = time.perf_counter()
            res0 = render(scene(0.0, 0.0))
            full0 = time.perf_counter() - t0
            lines.append(f"| {kind} | beta 0 (whole render) | {full0:.2f} | 1 | "
                         f"{res0.leaves.mean():.0f} | 0 | 0 | 0 | - |")
            print(lines[-1], file=sys.stderr, flush=True)
        for beta, tol in [(0.5, 0.0)] + [(0.0, t) for t in args.tol]:
            best = None
            for _ in range(args.repeat):
                t0 = time.perf_counter()
                res = render(scene(beta, tol))
                wall = time.perf_counter() - t0
                if best is None or wall < best[0]:
                    best = (wall, res)
            wall, res = best
            h = res.hit[rows, cols]
            both = h & rhit
            err = np.abs(res.depth[rows, cols][both].astype(float) - rt[both]) / diag
            name = f"beta {beta:g}" if tol == 0 else f"beta 0, tol {tol:g}"
            frac = "-" if full0 is None else f"{wall / full0:.3f}"
            lines.append(f"| {kind} | {name} | {wall:.2f} | {frac} | {res.leaves.mean():.0f} | "
                         f"{err.mean():.2e} | {err.max():.2e} | {int((h != rhit).sum())} | "
                         f"{'-' if authors is None else f'{authors:.2f}'} |")
            print(lines[-1], file=sys.stderr, flush=True)
    print(f"Bunny {args.size}², alpha {ALPHA:g}, alpha_U {ALPHA_U:g}, eps "
          f"{'1e-4 x diag' if args.eps is None else f'{args.eps:g}'}, {args.threads} threads; "
          f"depth error against beta 0 on every {args.stride}th pixel; {load()} after.")
    print()
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
