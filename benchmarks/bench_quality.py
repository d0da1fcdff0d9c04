"""Image quality and cost of the publication look: anti-aliasing, soft shadows, occlusion.

Two measurements on one scene (default ``scenes/bunny_triangles.json``: the paper's bunny as
triangles, alpha 200, its camera), both in one run on this machine:

* **Cost** (``--cost-size``, default 512 x 512): the wall time of today's one-sample
  normal-coloured render against the lit shading (soft shadows, ambient occlusion, ground)
  with 1 sample, with adaptive anti-aliasing (``--samples``, default 16) and with that many
  uniform samples. The variants run in turn, ``--repeat`` rounds (median reported), after a
  warm-up of each; the ratio column divides by the normal-coloured render of the same round.
* **Convergence** (``--quality-size``, default 256 x 256): the lit image with N uniform
  samples per pixel for N = 1, 2, 4, ..., and adaptive with ``--samples``, against a
  reference of ``--reference`` (256) uniform samples: mean absolute error over the image in
  0-255 units, and over the pixels where the reference is not flat (edges: where any
  channel differs from a 4-neighbour by more than 8). The error falls as samples grow; the
  adaptive render is compared with the uniform render of as many samples.

Usage::

    python benchmarks/bench_quality.py                          # both, prints a table
    python benchmarks/bench_quality.py --cost-size 128 --quality-size 64 --reference 64 \
        --repeat 1 --out renders/bench_quality                  # a quick run, with CSV + plot
"""

import argparse
import dataclasses
import json
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run from a checkout without installing
    sys.path.insert(0, str(ROOT))

import numba  # noqa: E402

from tracer.rendering.renderer import render  # noqa: E402
from tracer.scenes.scene import load_scene  # noqa: E402


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--scene", default=str(ROOT / "scenes" / "bunny_triangles.json"))
    p.add_argument("--cost-size", type=int, default=512, metavar="N")
    p.add_argument("--quality-size", type=int, default=256, metavar="N")
    p.add_argument("--samples", type=int, default=16, help="adaptive and uniform AA samples")
    p.add_argument("--reference", type=int, default=256, help="samples of the reference")
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--threads", type=int, default=None)
    p.add_argument("--skip-cost", action="store_true")
    p.add_argument("--skip-quality", action="store_true")
    p.add_argument("--out", metavar="DIR", help="write quality.csv, cost.csv, summary.json and "
                   "convergence.png there")
    return p.parse_args(argv)


def variants(scene, samples):
    lit = dataclasses.replace(scene, shading="lit")
    return [("normals, 1 sample", scene),
            ("lit (shadows, AO, ground), 1 sample", lit),
            (f"lit, adaptive {samples}", dataclasses.replace(lit, samples=samples,
                                                            adaptive=True)),
            (f"lit, uniform {samples}", dataclasses.replace(lit, samples=samples))]


def cost(scene_path, size, samples, repeat):
    scene = load_scene(scene_path, {"width": size, "height": size})
    runs = variants(scene, samples)
    for _, s in runs:                                 # warm-up: compile / load, page in
        render(dataclasses.replace(s, width=32, height=32))
    times = {name: [] for name, _ in runs}
    ratios = {name: [] for name, _ in runs}
    info = {}
    for _ in range(repeat):
        base = None
        for name, s in runs:
            t0 = time.perf_counter()
            res = render(s)
            dt = time.perf_counter() - t0
            base = dt if base is None else base
            times[name].append(dt)
            ratios[name].append(dt / base)
            info[name] = {"rays": int(res.aovs.get("rays", size * size)),
                          "light_queries": int(res.aovs.get("light_queries", 0)),
                          "primary_steps": int(res.steps.sum()),
                          "mean_samples": float(res.samples.mean())}
    return [dict(variant=name, seconds=statistics.median(times[name]),
                 ratio=statistics.median(ratios[name]), **info[name]) for name, _ in runs]


def edge_mask(img, threshold=8):
    a = img.astype(int)
    m = np.zeros(a.shape[:2], dtype=bool)
    for axis in (0, 1):
        d = np.abs(np.diff(a, axis=axis)).max(axis=2) > threshold
        sl = [slice(None)] * 2
        sl[axis] = slice(0, -1)
        m[tuple(sl)] |= d
        sl[axis] = slice(1, None)
        m[tuple(sl)] |= d
    return m


def quality(scene_path, size, samples, reference):
    scene = load_scene(scene_path, {"width": size, "height": size})
    lit = dataclasses.replace(scene, shading="lit")
    ref = render(dataclasses.replace(lit, samples=reference)).rgb.astype(int)
    edges = edge_mask(ref.astype(np.uint8))
    rows = []
    n = 1
    counts = []
    while n <= min(64, reference // 2):
        counts.append(n)
        n *= 2
    if samples not in counts and samples < reference:
        counts.append(samples)
    for n in sorted(counts):
        res = render(dataclasses.replace(lit, samples=n))
        err = np.abs(res.rgb.astype(int) - ref)
        rows.append(dict(samples=n, adaptive=False, rays=int(res.aovs["rays"]),
                         mean_abs_error=float(err.mean()),
                         edge_mean_abs_error=float(err[edges].mean())))
    res = render(dataclasses.replace(lit, samples=samples, adaptive=True))
    err = np.abs(res.rgb.astype(int) - ref)
    rows.append(dict(samples=samples, adaptive=True, rays=int(res.aovs["rays"]),
                     mean_abs_error=float(err.mean()),
                     edge_mean_abs_error=float(err[edges].mean())))
    return rows, float(edges.mean())


def write_csv(path, rows):
    keys = list(rows[0])
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(",".join(keys) + "\n")
        for r in rows:
            fh.write(",".join(str(r[k]) for k in keys) + "\n")


def plot(path, rows, reference, size):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    uni = [r for r in rows if not r["adaptive"]]
    ada = [r for r in rows if r["adaptive"]]
    fig, ax = plt.subplots(figsize=(5.5, 3.8))
    ax.loglog([r["samples"] for r in uni], [r["edge_mean_abs_error"] for r in uni], "o-",
              label="uniform, edge pixels")
    ax.loglog([r["samples"] for r in uni], [r["mean_abs_error"] for r in uni], "s--",
              label="uniform, whole image")
    for r in ada:
        ax.loglog([r["samples"]], [r["edge_mean_abs_error"]], "r*", ms=12,
                  label=f"adaptive {r['samples']}, edge pixels")
    ax.set_xlabel("samples per pixel")
    ax.set_ylabel(f"mean abs error vs {reference} samples (0-255)")
    ax.set_title(f"lit bunny, {size} x {size}", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None):
    args = parse_args(argv)
    if args.threads:
        numba.set_num_threads(args.threads)
    out = Path(args.out) if args.out else None
    if out:
        out.mkdir(parents=True, exist_ok=True)
    summary = {"scene": os.path.relpath(args.scene, ROOT), "threads": numba.get_num_threads(),
               "cpu_count": os.cpu_count()}
    if not args.skip_cost:
        rows = cost(args.scene, args.cost_size, args.samples, args.repeat)
        print(f"\nCost, {args.cost_size} x {args.cost_size}, {summary['threads']} threads, "
              f"median of {args.repeat} rounds (ratio: / the normal-coloured render of the "
              f"same round)")
        print(f"{'variant':40s} {'seconds':>8s} {'ratio':>6s} {'rays':>9s} {'light q.':>9s}")
        for r in rows:
            print(f"{r['variant']:40s} {r['seconds']:8.2f} {r['ratio']:6.2f} {r['rays']:9d} "
                  f"{r['light_queries']:9d}")
        summary["cost"] = rows
        if out:
            write_csv(out / "cost.csv", rows)
    if not args.skip_quality:
        rows, edge_fraction = quality(args.scene, args.quality_size, args.samples,
                                      args.reference)
        print(f"\nConvergence, {args.quality_size} x {args.quality_size}, against "
              f"{args.reference} uniform samples ({100 * edge_fraction:.1f} % edge pixels)")
        print(f"{'samples':>8s} {'mode':>9s} {'rays':>9s} {'error':>8s} {'edge error':>10s}")
        for r in rows:
            print(f"{r['samples']:8d} {'adaptive' if r['adaptive'] else 'uniform':>9s} "
                  f"{r['rays']:9d} {r['mean_abs_error']:8.3f} {r['edge_mean_abs_error']:10.3f}")
        summary["quality"] = rows
        summary["edge_fraction"] = edge_fraction
        if out:
            write_csv(out / "quality.csv", rows)
            plot(out / "convergence.png", rows, args.reference, args.quality_size)
    if out:
        (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
        print(f"\nwrote {out}/")
    return 0


if __name__ == "__main__":
    sys.exit(main())
