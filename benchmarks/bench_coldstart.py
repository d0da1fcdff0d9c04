"""First render with an empty kernel cache: a mesh file, a point cloud, a lit adaptive render.

Each case runs ``python -m tracer render ...`` in a fresh process with ``NUMBA_CACHE_DIR``
pointing at a new empty folder (as after ``pip install``; ``smoothdist._cache_guard`` then
finds nothing to clear), then once more with that folder filled (warm). Reported per case:
wall seconds cold and warm, the CPU seconds of the cold run, and how many kernel
specialisations it compiled (every ``@njit`` function of ``smoothdist`` and ``tracer`` with its
signatures, each kernel counted once: every one is compiled, optimised and written to the
cache). The cases:

* ``mesh``: a trimesh-style icosphere (``ball.obj``, 1,280 triangles, written here) rendered
  as ``tracer render ball.obj --size 256 256`` (lit, auto alpha);
* ``cloud``: 2,000 points on the unit sphere (``cloud.xyz``), the same command;
* ``lit``: ``scenes/bunny_triangles.json --size 256 256 --shading lit --samples 16
  --adaptive``.

Results go to ``benchmarks/data/coldstart.json`` with the load average before and after each
run (other jobs slow a compile down as much as a render). The README's first-render figure is
read from that file (``tests/test_render_coldstart.py`` checks it).

Usage::

    python benchmarks/bench_coldstart.py                  # all three cases
    python benchmarks/bench_coldstart.py --cases lit --out out/coldstart.json
"""

import argparse
import json
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
CASES = ("mesh", "cloud", "lit")
DEFAULT_OUT = ROOT / "benchmarks" / "data" / "coldstart.json"

#: runs in the child: the CLI, then a count of the compiled specialisations
CHILD = r"""
import json, resource, sys, time
t0 = time.perf_counter()
from numba.core.dispatcher import Dispatcher
import tracer.cli
rc = tracer.cli.main(sys.argv[1:])
wall = time.perf_counter() - t0
kernels = {id(obj): (f"{name}.{attr}", len(obj.signatures))
           for name, mod in list(sys.modules.items()) if name.split(".")[0] in ("smoothdist", "tracer")
           for attr, obj in vars(mod).items() if isinstance(obj, Dispatcher) and obj.signatures}
ru = resource.getrusage(resource.RUSAGE_SELF)
print(json.dumps({"rc": rc, "in_process_s": wall, "cpu_s": ru.ru_utime + ru.ru_stime,
                  "compiled": sum(n for _, n in kernels.values()),
                  "kernels": dict(sorted(kernels.values()))}))
"""


def icosphere(subdivisions=3):
    """Vertices and faces of the unit icosphere (as ``trimesh.creation.icosphere``: 1,280
    faces at 3 subdivisions), without trimesh."""
    t = (1.0 + 5 ** 0.5) / 2.0
    V = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t),
         (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    F = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
         (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
         (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    V = [np.array(v, dtype=float) / np.linalg.norm(v) for v in V]
    for _ in range(subdivisions):
        mid, out = {}, []

        def middle(a, b):
            key = (min(a, b), max(a, b))
            if key not in mid:
                m = V[a] + V[b]
                V.append(m / np.linalg.norm(m))
                mid[key] = len(V) - 1
            return mid[key]

        for a, b, c in F:
            ab, bc, ca = middle(a, b), middle(b, c), middle(c, a)
            out += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        F = out
    return np.array(V), np.array(F)


def write_inputs(folder):
    V, F = icosphere(3)
    ball = folder / "ball.obj"
    with open(ball, "w", encoding="ascii") as f:
        f.writelines(f"v {x:.9f} {y:.9f} {z:.9f}\n" for x, y, z in V)
        f.writelines(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in F)
    rng = np.random.default_rng(0)
    P = rng.normal(size=(2000, 3))
    P /= np.linalg.norm(P, axis=1, keepdims=True)
    cloud = folder / "cloud.xyz"
    np.savetxt(cloud, P)
    return {"mesh": [str(ball), "--size", "256", "256"],
            "cloud": [str(cloud), "--size", "256", "256"],
            "lit": [str(ROOT / "scenes" / "bunny_triangles.json"), "--size", "256", "256",
                    "--shading", "lit", "--samples", "16", "--adaptive"]}


def run(args, cache, out_png, threads):
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache), MPLBACKEND="Agg")
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    cmd = [sys.executable, "-c", CHILD, "render", *args, "-o", str(out_png), "--overwrite", "-q"]
    if threads:
        cmd += ["--threads", str(threads)]
    load = os.getloadavg()[0]
    t0 = time.perf_counter()
    p = subprocess.run(cmd, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if p.returncode != 0:
        raise SystemExit(f"error: {' '.join(args)} failed:\n{p.stderr.strip()[-2000:]}")
    r = json.loads(p.stdout.strip().splitlines()[-1])
    r.update(wall_s=wall, load_before=load, load_after=os.getloadavg()[0])
    return r


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--cases", nargs="+", choices=CASES, default=list(CASES))
    p.add_argument("--threads", type=int, default=None, help="--threads of the renders")
    p.add_argument("--out", default=str(DEFAULT_OUT), help="results JSON")
    args = p.parse_args(argv)
    if not args.out.endswith(".json"):
        p.error("--out must name a .json file")
    results = {"date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
               "machine": {"cores": os.cpu_count(), "platform": platform.platform(),
                           "python": platform.python_version()},
               "cases": {}}
    work = Path(tempfile.mkdtemp(prefix="coldstart-"))
    try:
        inputs = write_inputs(work)
        print(f"{'case':6} {'cold s':>7} {'cpu s':>6} {'warm s':>7} {'compiled':>9} {'load':>9}")
        for case in args.cases:
            cache = work / f"cache-{case}"
            cache.mkdir()
            cold = run(inputs[case], cache, work / f"{case}.png", args.threads)
            warm = run(inputs[case], cache, work / f"{case}.png", args.threads)
            results["cases"][case] = {"command": "tracer render " + " ".join(
                Path(a).name if a.startswith(str(work)) or a.startswith(str(ROOT)) else a
                for a in inputs[case]), "cold": cold, "warm": warm}
            print(f"{case:6} {cold['wall_s']:7.1f} {cold['cpu_s']:6.1f} {warm['wall_s']:7.1f} "
                  f"{cold['compiled']:9d} {cold['load_before']:4.1f}-{cold['load_after']:.1f}")
    finally:
        shutil.rmtree(work, ignore_errors=True)
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    tmp = f"{args.out}.{os.getpid()}.tmp"
    with open(tmp, "w", encoding="utf-8") as fh:
        json.dump(results, fh, indent=1)
    os.replace(tmp, args.out)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
