"""Would the CPU's common end depth pay on the GPU? The work of its GPU form, counted on the CPU.

On the CPU a tile's rays march in row order, and once one has missed after more than
``tracer.rendering.march.END_AFTER`` evaluations the tile's common end depth
(``march.cone_end``, a cone marched back from the box's far corner) ends its later misses
early. On the GPU every ray is a thread of its own and none knows whether another has missed,
so the end depth can only be marched up front, for every tile that meets the box, in the cone
kernel (one thread per tile) before the render kernel (one per pixel). This script counts what
that would cost and save without a card: it runs the two kernels' per-thread work
(``march.tile_cone``, ``march.cone_end``, ``march.march_ray``, as ``gpu_render``'s kernels call
them) on the CPU, without and with the end depth, and sums the leaves visited (the tree nodes
read, the traversal's memory work) in the way a GPU pays for them: a warp of 32 threads runs
as long as its slowest thread, so each warp costs its largest count. The render kernel's warps
are 8 x 4 pixels (``gpu_render.BLOCK`` 8 x 8), the cone kernel's 16 x 2 tiles
(``CONE_BLOCK`` 16 x 8).

These are counts of work, not a card's time; they say which way the change goes, and by how
much of the two kernels' work.

Usage (from the repository root)::

    python benchmarks/bench_gpu_cone_end.py          # the three bunnies, 1080p, eps 1e-3
    python benchmarks/bench_gpu_cone_end.py --size 480 270 --out out.json
"""

import argparse
import json
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

import numba  # noqa: E402
import numpy as np  # noqa: E402
from numba import prange  # noqa: E402

from tracer.rendering import gpu_render, march  # noqa: E402
from tracer.rendering.camera import camera_ray  # noqa: E402
from tracer.rendering.frame import camera_of, scene_arrays, trace_options  # noqa: E402
from tracer.scenes.scene import load_scene  # noqa: E402

KINDS = ("points", "edges", "triangles")


@numba.njit(parallel=True)
def kernels_work(tree, roots, params, mode, tol, cam, lo, hi, eps, max_steps, relax, omega,
                 newton, depth_max, end, hit, leaves, tile_leaves, tile_evals):
    """The cone kernel's and the render kernel's work, one tile per loop step: ``hit,
    leaves (H, W)`` per pixel, ``tile_leaves, tile_evals (nty, ntx, 2)`` per tile (the cone
    start's, the end depth's). ``end``: march the end depth for every tile that meets the
    box and end each ray of the tile there."""
    H, W = hit.shape
    T = march.TILE
    ntx = (W + T - 1) // T
    for j in prange(tile_leaves.shape[0] * ntx):
        ty = j // ntx
        tx = j - ty * ntx
        r_lo, c_lo = ty * T, tx * T
        r_hi, c_hi = min(H, r_lo + T), min(W, c_lo + T)
        work = march.scratch(depth_max)
        sc = (tree, roots, params, mode, tol)
        limits = (lo, hi, eps, max_steps)
        tile = (r_lo, r_hi, c_lo, c_hi)
        first, t_min, D, gx, gy, gz, ev, lv = march.tile_cone(sc, cam, limits, tile, work,
                                                              relax, newton)
        tile_evals[ty, tx, 0] = ev
        tile_leaves[ty, tx, 0] = lv
        t_end = np.inf
        if end and first >= 0:
            t_end, e_ev, e_lv = march.cone_end(sc, cam, limits, tile, work, relax)
            tile_evals[ty, tx, 1] = e_ev
            tile_leaves[ty, tx, 1] = e_lv
        for r in range(r_lo, r_hi):
            for c in range(c_lo, c_hi):
                ray = camera_ray(cam, float(r), float(c))
                t_pred, d_lb = march.cone_first_step(cam, tile, (t_min, t_end, D, gx, gy, gz),
                                                     ray)
                h, t, _, _, _, st, lv2, _, _ = march.march_ray(
                    sc, ray, limits, (relax, omega, newton, march.NEWTON_COS),
                    (t_min, t_end, t_pred, d_lb), work)
                hit[r, c] = h == 1
                leaves[r, c] = lv2


def warp_cost(per_thread, rows, cols):
    """The sum over warps of ``rows x cols`` threads of their largest count."""
    H, W = per_thread.shape
    Hp, Wp = -(-H // rows) * rows, -(-W // cols) * cols
    padded = np.zeros((Hp, Wp), per_thread.dtype)
    padded[:H, :W] = per_thread
    return int(padded.reshape(Hp // rows, rows, Wp // cols, cols).max(axis=(1, 3)).sum())


def one_case(kind, size, eps=None):
    """Both forms of the kernels on the bunny of ``kind``: the counts and what differs.
    ``eps``: the hit threshold (None: the scene's)."""
    W, H = size
    over = {"width": W, "height": H}
    if eps:
        over["eps"] = eps
    scene = load_scene(REPO / "scenes" / f"bunny_{kind}.json", over)
    tree, roots, params, mode, lo, hi, depth_max, tol = scene_arrays(scene)
    opts = trace_options(scene, lo, hi)
    roots = np.ascontiguousarray(np.atleast_1d(roots), np.int64)
    cam = camera_of(scene).as_array()
    T = march.TILE
    out = {}
    for end in (False, True):
        hit, leaves = np.zeros((H, W), np.bool_), np.zeros((H, W), np.int64)
        tiles = (-(-H // T), -(-W // T), 2)
        tile_leaves, tile_evals = np.zeros(tiles, np.int64), np.zeros(tiles, np.int64)
        t0 = time.perf_counter()
        kernels_work(tree, roots, params, mode, tol, cam, lo, hi, float(scene.march.eps),
                     int(scene.march.max_steps), opts.relax, opts.omega, opts.newton,
                     int(depth_max), end, hit, leaves, tile_leaves, tile_evals)
        # warps as gpu_render launches them: BLOCK (columns, rows) = (8, 8) -> 32 threads of
        # 8 columns x 4 rows; CONE_BLOCK (16, 8) -> 16 tile columns x 2 tile rows
        bc, cc = gpu_render.BLOCK[0], gpu_render.CONE_BLOCK[0]
        cone = warp_cost(tile_leaves.sum(axis=2), 32 // cc, cc)
        render = warp_cost(leaves, 32 // bc, bc)
        out["end" if end else "none"] = dict(
            seconds=time.perf_counter() - t0, cone_warp_leaves=cone, render_warp_leaves=render,
            both_warp_leaves=cone + render, leaves=int(leaves.sum() + tile_leaves.sum()),
            end_evals=int(tile_evals[:, :, 1].sum()), hits=int(hit.sum()), hit=hit)
    a, b = out["none"], out["end"]
    differ = int((a.pop("hit") != b.pop("hit")).sum())
    return dict(what=f"bunny {kind}", size=f"{W}x{H}", eps=float(scene.march.eps),
                without=a, with_end=b,
                hit_differs=differ,
                render_ratio=b["render_warp_leaves"] / a["render_warp_leaves"],
                cone_ratio=b["cone_warp_leaves"] / a["cone_warp_leaves"],
                both_ratio=b["both_warp_leaves"] / a["both_warp_leaves"])


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--size", type=int, nargs=2, default=(1920, 1080), metavar=("W", "H"))
    p.add_argument("--kinds", nargs="+", default=list(KINDS), choices=KINDS)
    p.add_argument("--eps", type=float, default=1e-3,
                   help="hit threshold, absolute (default 1e-3, as benchmarks/bench_gpu.py's "
                        "frames; 0: the scene's)")
    p.add_argument("--out", default=None, help="JSON results file")
    args = p.parse_args(argv)
    rows = []
    for kind in args.kinds:
        row = one_case(kind, tuple(args.size), args.eps)
        rows.append(row)
        print(f"{row['what']} {row['size']}: warp-summed leaves, cone kernel "
              f"{row['without']['cone_warp_leaves']:,} -> {row['with_end']['cone_warp_leaves']:,}"
              f", render kernel {row['without']['render_warp_leaves']:,} -> "
              f"{row['with_end']['render_warp_leaves']:,}; both x{row['both_ratio']:.3f}; "
              f"hits differ: {row['hit_differs']}", flush=True)
    if args.out:
        Path(args.out).write_text(json.dumps(
            {"what": "bench_gpu_cone_end.py: the GPU kernels' work without and with the "
                     "tiles' end depth marched up front, counted on the CPU",
             "rows": rows}, indent=1) + "\n")
        print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
