"""Why a dense cloud of a flat thing renders like stucco, and what per-point weights would do.

A study for issue 62 (item 3), in numpy and scipy only (no library kernel: the weights it tries
do not exist in ``smoothdist`` yet). Points drawn uniformly at random on the unit square
(z = 0) sample a plane; their LogSumExp surface ``d_hat = 0`` at ``alpha = 0.6 / s`` (``s``
the median nearest-neighbour spacing, the sharpness ``auto_alpha`` picks for such clouds) is
found by bisection above a grid in the square's middle, and its slope is measured against the
plane. With unit weights (the paper's, today's) the random clumping of the samples shows as
bumps: each clump adds ``log(local count) / alpha``. Weighting each point by the area it
stands for (the squared distance to its k-th neighbour, divided by the smallest, so every
weight is ``>= 1`` and the sum stays conservative) evens the sum out; a kernel-density
estimate (the smooth sum of the cloud at its own points, scale ``sigma`` spacings) is tried
too, as the one the library could compute with its own kernels.

Usage::

    python benchmarks/bench_point_weights.py --json benchmarks/data/point_weights.json
"""

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np


def _heights(P, tree, XY, w, alpha):
    """Height of the surface ``d_hat = 0`` above each point of ``XY (g, 2)``, by bisection."""
    lo = np.zeros(len(XY))
    hi = np.full(len(XY), 60.0 / alpha)
    near = tree.query_ball_point(np.c_[XY, np.zeros(len(XY))], 40.0 / alpha)
    for _ in range(40):
        h = 0.5 * (lo + hi)
        val = np.empty(len(XY))
        for j, idx in enumerate(near):
            d = np.sqrt(((P[idx, :2] - XY[j]) ** 2).sum(axis=1) + h[j] ** 2)
            m = d.min()
            val[j] = m - np.log((w[idx] * np.exp(-alpha * (d - m))).sum()) / alpha
        below = val < 0.0
        lo = np.where(below, h, lo)
        hi = np.where(below, hi, h)
    return h


def measure(n=40_000, grid=41, seed=1):
    """Rows ``{weights, A, mean_height, std_height, slope_p95_deg}`` (heights in ``1/alpha``)."""
    from scipy.spatial import cKDTree  # scipy (sim extra): loaded on use

    rng = np.random.default_rng(seed)
    P = np.c_[rng.uniform(0.0, 1.0, (n, 2)), np.zeros(n)]
    tree = cKDTree(P)
    s = float(np.median(tree.query(P, 2)[0][:, 1]))
    alpha = 0.6 / s
    g = np.linspace(0.4, 0.6, grid)
    X, Y = np.meshgrid(g, g)
    XY = np.c_[X.ravel(), Y.ravel()]
    schemes = [("unit (the paper's)", np.ones(n))]
    for k in (4, 6, 8, 16):
        r2 = tree.query(P, k + 1)[0][:, -1] ** 2
        schemes.append((f"area, k={k}", r2 / r2.min()))
    for sigma in (1.0, 2.26):
        a2 = 1.0 / (sigma * s)
        near = tree.query_ball_point(P, 30.0 / a2)
        D = np.array([np.exp(-a2 * np.linalg.norm(P[idx] - P[i], axis=1)).sum()
                      for i, idx in enumerate(near)])
        schemes.append((f"density, sigma={sigma} s", np.clip(np.percentile(D, 95) / D, 1.0,
                                                             16.0)))
    rows = []
    for name, w in schemes:
        H = _heights(P, tree, XY, w, alpha).reshape(X.shape)
        gy, gx = np.gradient(H, g, g)
        slope = np.degrees(np.arctan(np.hypot(gx, gy)))
        rows.append({"weights": name, "A": float(w.max()), "mean_height": float(H.mean() * alpha),
                     "std_height": float(H.std() * alpha),
                     "slope_p95_deg": float(np.percentile(slope, 95))})
        print(f"{name:>24}: A {w.max():8.2f}, height {H.mean() * alpha:.2f} +- "
              f"{H.std() * alpha:.3f} / alpha, slope p95 {rows[-1]['slope_p95_deg']:.2f} deg",
              flush=True)
    return {"points": n, "spacing": s, "alpha": alpha, "grid": grid, "seed": seed, "rows": rows}


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--points", type=int, default=40_000)
    p.add_argument("--json", help="write the results here")
    args = p.parse_args(argv)
    t0 = time.perf_counter()
    result = measure(args.points)
    result.update(seconds=time.perf_counter() - t0, cores=os.cpu_count(),
                  date=time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()))
    if args.json:
        Path(args.json).write_text(json.dumps(result, indent=1) + "\n", encoding="utf-8")
    return result


if __name__ == "__main__":
    main()
