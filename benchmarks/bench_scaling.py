"""Thread scaling of a 1080p frame: the speedup table and Amdahl's law fitted to it.

The paper's bunny (``scenes/bunny_{points,edges,triangles}.json``: alpha 200, alpha_U 1200,
beta 0.5) at 1920 x 1080, eps 1e-3 (the issue's setting; ``--eps``), rendered with 1, 2, 4, ...
threads up to the machine's cores (``numba.set_num_threads`` in this one process; the
thread counts alternate within each repeat, so that their ratios are measured back to back),
best of ``--repeat`` (3) per count. Two times per render:

* ``seconds``: :attr:`tracer.rendering.frame.RenderResult.seconds`, what ``tracer render --stats``
  reports (tracing, normals and, for the ``lit`` kind, the shading and samples), and
* ``frame``: the whole frame in this process: ``render()`` plus writing the PNG.

The ``lit`` kind is the triangles in the lit shading with 16 adaptive samples per pixel (soft
shadows, occlusion, ground). Amdahl's law ``T(n) = s + p / n`` is fitted to the best times of 1
and 2 threads (``s = 2 T(2) - T(1)``, as the issue measures it) and, with more counts, by least
squares over all of them; reported: the serial seconds ``s`` and the projected efficiency at
16 threads, ``T(1) / (16 T(16))``. The load average is recorded before and after each kind:
on a shared machine the ratios are noisy.

Usage::

    python benchmarks/bench_scaling.py                 # 1920x1080, all kinds, best of 3
    python benchmarks/bench_scaling.py --quick         # 640x360, best of 2
    python benchmarks/bench_scaling.py --kinds points --threads 1 2 --out out/scaling.json
"""

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run from a checkout without installing
    sys.path.insert(0, str(ROOT))

import numba  # noqa: E402
import numpy as np  # noqa: E402

from tracer.image import save_png  # noqa: E402
from tracer.rendering.renderer import render  # noqa: E402
from tracer.scenes.scene import load_scene  # noqa: E402

KINDS = ("points", "edges", "triangles", "lit")
DEFAULT_OUT = ROOT / "benchmarks" / "data" / "scaling.json"
#: the thread count the efficiency is projected to
PROJECT_TO = 16


def thread_counts(limit):
    """1, 2, 4, ... below ``limit``, and ``limit`` itself."""
    counts, n = [], 1
    while n < limit:
        counts.append(n)
        n *= 2
    return counts + [limit]


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    cores = os.cpu_count() or 1
    p.add_argument("--kinds", nargs="+", choices=KINDS, default=list(KINDS),
                   help="what to render (default: all)")
    p.add_argument("--size", type=int, nargs=2, metavar=("W", "H"), default=None,
                   help="image size (default 1920 1080; --quick: 640 360)")
    p.add_argument("--threads", type=int, nargs="+", default=None, metavar="N",
                   help=f"thread counts (default 1, 2, 4, ... up to the {cores} cores)")
    p.add_argument("--repeat", type=int, default=None,
                   help="renders per thread count, best kept (default 3; --quick: 2)")
    p.add_argument("--eps", type=float, default=1e-3, help="hit threshold (default 1e-3)")
    p.add_argument("--quick", action="store_true", help="640x360, best of 2")
    p.add_argument("--out", default=str(DEFAULT_OUT),
                   help="results JSON (default benchmarks/data/scaling.json)")
    args = p.parse_args(argv)
    args.size = args.size or ([640, 360] if args.quick else [1920, 1080])
    args.repeat = args.repeat or (2 if args.quick else 3)
    limit = min(cores, numba.config.NUMBA_NUM_THREADS)
    args.threads = sorted(set(args.threads or thread_counts(limit)))
    if min(args.size) < 1 or args.repeat < 1:
        p.error("--size and --repeat must be positive")
    if not all(1 <= t <= numba.config.NUMBA_NUM_THREADS for t in args.threads):
        p.error(f"--threads must be between 1 and {numba.config.NUMBA_NUM_THREADS}")
    if not args.out.endswith(".json"):
        p.error("--out must name a .json file")
    return args


def scene_for(kind, size, eps):
    name = "triangles" if kind == "lit" else kind
    over = {"width": size[0], "height": size[1], "eps": eps}
    if kind == "lit":
        over.update(shading="lit", samples=16, adaptive=True)
    return load_scene(ROOT / "scenes" / f"bunny_{name}.json", over)


def amdahl(times):
    """``(serial s, parallel p)`` of ``T(n) = s + p / n`` fitted to ``{n: T}``: exactly through
    1 and 2 threads when those are the only counts, by least squares otherwise."""
    n = np.array(sorted(times), dtype=float)
    t = np.array([times[k] for k in sorted(times)])
    if len(n) < 2:
        return None, None
    A = np.stack([np.ones_like(n), 1.0 / n], axis=1)
    s, p = np.linalg.lstsq(A, t, rcond=None)[0]
    return float(s), float(p)


def efficiency(s, p, n=PROJECT_TO):
    """Projected parallel efficiency at ``n`` threads: ``T(1) / (n T(n))``."""
    return (s + p) / (n * (s + p / n))


def machine():
    model = platform.processor() or ""
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            model = next((ln.split(":", 1)[1].strip() for ln in f if ln.startswith("model name")),
                         model)
    except OSError:
        pass
    return {"cpu": model, "cores": os.cpu_count(), "platform": platform.platform(),
            "python": platform.python_version(), "numpy": np.__version__,
            "numba": numba.__version__, "threading_layer": numba.config.THREADING_LAYER}


def measure(kind, args, png):
    scene = scene_for(kind, args.size, args.eps)
    numba.set_num_threads(max(args.threads))
    render(scene)                                 # compile / load the kernels, page in
    load = [os.getloadavg()[0]]
    runs = {n: {"seconds": [], "frame": []} for n in args.threads}
    for _ in range(args.repeat):
        for n in args.threads:                    # alternating: ratios back to back
            numba.set_num_threads(n)
            t0 = time.perf_counter()
            res = render(scene)
            save_png(png, res.rgb)
            runs[n]["frame"].append(time.perf_counter() - t0)
            runs[n]["seconds"].append(res.seconds)
    load.append(os.getloadavg()[0])
    out = {"scene": f"scenes/bunny_{'triangles' if kind == 'lit' else kind}.json",
           "size": list(args.size), "load_average": load, "runs": runs}
    for what in ("seconds", "frame"):
        best = {n: min(runs[n][what]) for n in args.threads}
        s, p = amdahl({n: best[n] for n in (1, 2) if n in best})
        fit = {"serial_1_2": s, "efficiency_16_1_2": None if s is None else efficiency(s, p)}
        if len(best) > 2:
            s_all, p_all = amdahl(best)
            fit.update(serial_all=s_all, efficiency_16_all=efficiency(s_all, p_all))
        out[what] = {"best": best, "speedup": {n: best[min(best)] / best[n] for n in best},
                     **fit}
    return out


def main(argv=None):
    args = parse_args(argv)
    png = Path(args.out).with_suffix(".png")
    results = {"machine": machine(), "size": args.size, "eps": args.eps,
               "threads": args.threads, "repeat": args.repeat, "kinds": {}}
    t_start = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    try:
        for kind in args.kinds:
            results["kinds"][kind] = r = measure(kind, args, str(png))
            print(f"\n{kind}, {args.size[0]}x{args.size[1]}, best of {args.repeat}, load "
                  f"{r['load_average'][0]:.1f} -> {r['load_average'][1]:.1f}")
            print(f"{'threads':>8} {'seconds':>9} {'speedup':>8} {'frame s':>9} {'speedup':>8}")
            for n in args.threads:
                print(f"{n:8d} {r['seconds']['best'][n]:9.3f} {r['seconds']['speedup'][n]:8.2f}"
                      f" {r['frame']['best'][n]:9.3f} {r['frame']['speedup'][n]:8.2f}")
            for what in ("seconds", "frame"):
                f = r[what]
                if f["serial_1_2"] is not None:
                    line = (f"  Amdahl ({what}), 1-2 threads: serial {f['serial_1_2']:.3f} s, "
                            f"projected efficiency at {PROJECT_TO} threads "
                            f"{f['efficiency_16_1_2']:.2f}")
                    if "serial_all" in f:
                        line += (f"; all counts: serial {f['serial_all']:.3f} s, "
                                 f"{f['efficiency_16_all']:.2f}")
                    print(line)
    finally:
        if png.exists():
            png.unlink()
    results["date"] = t_start
    tmp = f"{args.out}.{os.getpid()}.tmp"
    with open(tmp, "w", encoding="utf-8") as fh:
        json.dump(results, fh, indent=1)
    os.replace(tmp, args.out)
    print(f"\nwrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
