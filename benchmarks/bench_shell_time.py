"""Render time of the default surface against the rule it replaced (issue 46: at most 1.5x).

For every shape of ``bench_fidelity``'s corpus that has triangles, ``tracer.render_mesh`` at
``--size`` (lit, the defaults) twice: with the defaults (the thin shell of
:meth:`smoothdist.SmoothDistanceField.auto_surface`) and with the rule before issue 46 given
explicitly (``C = min(0.75 x mean edge length, 0.08 x diagonal)``, ``alpha = 6 / C``, or
``14 / C`` where that exceeds 16 over the mean edge length, no attenuation). Same process, the
two alternating, best of ``--repeat`` after a warm-up render; the ratio shell / before.

Usage (from the repository root)::

    python benchmarks/bench_shell_time.py --thingi10k --json benchmarks/data/shell_time.json
"""

import argparse
import json
import os
import sys
import time
import warnings
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
for p in (str(REPO), str(REPO / "benchmarks")):
    if p not in sys.path:
        sys.path.insert(0, p)

import numpy as np  # noqa: E402


def before_rule(field):
    """``(alpha, alpha_u, offset)`` of the rule before issue 46 (issue 35's level set)."""
    h = field.mean_edge_length()
    c = min(0.75 * h, 0.08 * field.diagonal)
    a = 6.0 / c if 6.0 / c * h <= 16.0 else 14.0 / c
    return a, a, c


def time_render(shape, F, size, kw, repeat):
    import tracer

    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        tracer.render_mesh(shape, F, size=(size, size), progress=None, **kw)
        best = min(best, time.perf_counter() - t0)
    return best


def main(argv=None):
    import bench_fidelity as bf
    import tracer

    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--size", type=int, default=512)
    p.add_argument("--repeat", type=int, default=2)
    p.add_argument("--shapes", nargs="+")
    p.add_argument("--thingi10k", action="store_true",
                   help="also the 12 Thingi10K meshes (fetched on first use) and the lion scan")
    p.add_argument("--json")
    args = p.parse_args(argv)
    shapes = bf.corpus(args.thingi10k)
    if args.shapes:
        shapes = {k: shapes[k] for k in args.shapes}
    rows = []
    warnings.simplefilter("ignore")
    for name, shape in shapes.items():
        F = None
        if isinstance(shape, tuple):
            shape, F = shape
        scene = tracer.mesh_scene(shape, F, size=(8, 8))
        field = scene.objects[0].field
        if not field.mesh.triangles.size or field.mesh.points.size:
            continue
        a, au, c = before_rule(field)
        old = dict(alpha=a, alpha_u=au, offset=c)
        tracer.render_mesh(shape, F, size=(64, 64), progress=None)           # warm-up
        tracer.render_mesh(shape, F, size=(64, 64), progress=None, **old)
        t_new, t_old = np.inf, np.inf
        for _ in range(args.repeat):
            t_new = min(t_new, time_render(shape, F, args.size, {}, 1))
            t_old = min(t_old, time_render(shape, F, args.size, old, 1))
        rows.append({"shape": name, "shell_s": t_new, "before_s": t_old,
                     "ratio": t_new / t_old})
        print(f"{name:>28}: shell {t_new:.2f} s, before {t_old:.2f} s, ratio "
              f"{t_new / t_old:.2f}", flush=True)
    r = np.array([row["ratio"] for row in rows])
    out = {"size": args.size, "repeat": args.repeat, "rows": rows,
           "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
           "cores": os.cpu_count(), "load": list(os.getloadavg()),
           "ratio_min": float(r.min()), "ratio_median": float(np.median(r)),
           "ratio_max": float(r.max())}
    print(f"shell / before: {out['ratio_min']:.2f}-{out['ratio_max']:.2f} "
          f"(median {out['ratio_median']:.2f}) over {len(rows)} shapes at {args.size}²")
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=1) + "\n", encoding="utf-8")
    return out


if __name__ == "__main__":
    main()
