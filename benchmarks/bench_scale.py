"""Scale benchmark: a ~1e7-point cloud builds its BVH and renders, within a memory budget.

The cloud is the shipped Autzen LiDAR tile (``scenes/data/pointclouds/lidar_autzen_trim.ply``,
about 110k points, feet) repeated ``--copies`` times, each copy jittered by a Gaussian of
``--jitter`` x the tile's median point spacing (deterministic seed), so the surface is the
same and the density is ``--copies`` times higher. The scene is ``scenes/lidar_autzen.json``'s
camera and alpha (0.5, i.e. a blur of 2 ft, much wider than the new spacing), beta 0.5.

Reported: points, BVH build seconds (with a progress bar), leaf size, nodes, render seconds
and size, hits, mean leaves per pixel, and the peak resident memory of the process (the
kernel's ``ru_maxrss``; everything runs in this one process). Heavy: run it alone.

Usage::

    python benchmarks/bench_scale.py                    # 1e7 points (91 copies), 512²
    python benchmarks/bench_scale.py --points 1e6 --size 128
"""

import argparse
import json
import os
import resource
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import numba  # noqa: E402

import smoothdist  # noqa: E402
from smoothdist import DataMesh, SmoothDistanceField  # noqa: E402
from tracer.rendering.frame import ProgressBar  # noqa: E402
from tracer.rendering.renderer import render  # noqa: E402
from tracer.scenes.scene import scene_from_field  # noqa: E402

SCENE = ROOT / "scenes" / "lidar_autzen.json"


def peak_rss_gb():
    """Peak resident set size of this process, GB (Linux reports ru_maxrss in KiB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024 ** 2


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--points", type=float, default=1e7, help="target number of points")
    p.add_argument("--jitter", type=float, default=0.5,
                   help="jitter, in units of the tile's median point spacing (default 0.5)")
    p.add_argument("--leaf-size", type=int, default=8, dest="leaf_size",
                   help="points per BVH leaf (default 8)")
    p.add_argument("--size", type=int, default=512, help="square image size (default 512)")
    p.add_argument("--beta", type=float, default=0.5)
    p.add_argument("--threads", type=int, default=None)
    p.add_argument("--json", metavar="OUT")
    args = p.parse_args(argv)
    if args.threads:
        numba.set_num_threads(args.threads)
    spec = json.loads(SCENE.read_text())
    obj = spec["objects"][0]
    tile = smoothdist.load_mesh(SCENE.parent / obj["path"], kind="points")
    base = tile.V[tile.points]
    spacing = SmoothDistanceField(tile).point_spacing()
    copies = max(1, int(round(args.points / base.shape[0])))
    rng = np.random.default_rng(20220722)
    n = copies * base.shape[0]
    V = np.empty((n, 3))
    for k in range(copies):
        V[k * base.shape[0]:(k + 1) * base.shape[0]] = base + rng.normal(
            size=base.shape) * (args.jitter * spacing)
    del tile
    print(f"{n:,} points ({copies} jittered copies of {base.shape[0]:,}; spacing "
          f"{spacing:.3g} ft, jitter {args.jitter:g}x); peak RSS so far {peak_rss_gb():.2f} GB",
          file=sys.stderr, flush=True)
    t0 = time.perf_counter()
    mesh = DataMesh(V, name="autzen_x%d" % copies, repair=False)
    del V
    t_mesh = time.perf_counter() - t0
    t0 = time.perf_counter()
    field = SmoothDistanceField(mesh, leaf_size=args.leaf_size,
                                progress=ProgressBar("build BVH", min_seconds=0.0))
    t_build = time.perf_counter() - t0
    print(f"BVH: {field.tree.lo.shape[0]:,} nodes, depth {field.tree.depth}, built in "
          f"{t_build:.1f} s; peak RSS {peak_rss_gb():.2f} GB", file=sys.stderr, flush=True)
    cam = spec["camera"]
    scene = scene_from_field(field, alpha=float(obj["alpha"]), alpha_u=float(obj["alpha_u"]),
                             beta=args.beta, width=args.size, height=args.size,
                             camera=(cam["origin"], cam["dest"], cam["up"]),
                             shading="headlight")
    render(scene_from_field(field, alpha=float(obj["alpha"]), alpha_u=float(obj["alpha_u"]),
                            beta=args.beta, width=8, height=8,
                            camera=(cam["origin"], cam["dest"], cam["up"])))  # compile
    t0 = time.perf_counter()
    res = render(scene, progress=ProgressBar("render"))
    t_render = time.perf_counter() - t0
    rss = peak_rss_gb()
    out = dict(points=n, copies=copies, mesh_s=round(t_mesh, 2), build_s=round(t_build, 2),
               leaf_size=args.leaf_size, nodes=int(field.tree.lo.shape[0]),
               render_s=round(t_render, 2), size=args.size, beta=args.beta,
               hits=int(res.hit.sum()), mean_leaves=round(float(res.leaves.mean()), 1),
               peak_rss_gb=round(rss, 2), threads=numba.get_num_threads(),
               load=os.getloadavg())
    print("| points | build s | nodes (leaf size) | render s | size | mean leaves/px | "
          "peak RSS |")
    print("|---:|---:|---:|---:|---|---:|---:|")
    print(f"| {n:,} | {t_build:.1f} | {out['nodes']:,} ({args.leaf_size}) | {t_render:.1f} | "
          f"{args.size}² | {out['mean_leaves']:.0f} | {rss:.2f} GB |")
    print(f"\n{out['threads']} threads; load average {out['load'][0]:.2f} / "
          f"{out['load'][1]:.2f} / {out['load'][2]:.2f}; DataMesh construction {t_mesh:.1f} s")
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
