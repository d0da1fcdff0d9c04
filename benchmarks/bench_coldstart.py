"""First calls with an empty kernel cache: library queries, whole-mesh distances, renders, a
simulation step.

Each case runs in a fresh process with ``NUMBA_CACHE_DIR`` pointing at a new empty folder (as
after ``pip install``; ``smoothdist._cache_guard`` then finds nothing to clear), then once more
with that folder filled (warm). Reported per case: wall and CPU seconds of the whole process
(Python, numpy and numba imports included), and the kernel specialisations it compiled: every
``numba:compile`` event of a ``smoothdist`` or ``tracer`` function (each is compiled, optimised
and written to the cache; a function merged into its caller, ``NJIT_IR_INLINE``, is not one),
in total and per function. The cases (geometry made here: the 1,280-triangle icosphere of
trimesh's ``icosphere(3)``, its 1,920 edges, its 642 vertices, 2,000 points on a sphere):

* library: ``exact`` (``smoothdist.exact_distance``, 1,000 points), ``smooth``
  (``smooth_distance``, alpha 50), ``smooth_alpha_u`` (the same with ``alpha_u="auto"``),
  ``md_triangles`` / ``md_edges`` / ``md_points`` (``MeshDistance`` of the mesh against a
  copy scaled by 0.3, alpha 50, and its first call), ``md_tri_edges`` (the copy's triangles on
  the mesh's edges, as the paper's slide-sphere), ``md_exact`` (``MeshDistance.exact``),
  ``md_vertex`` (``MeshDistance.vertex_gradient``), triangles;
* renders (``tracer render ... --size 256 256``, lit, auto alpha): ``mesh`` (``ball.obj``),
  ``edges`` (``ball_edges.obj``, its edges as OBJ lines), ``cloud`` (``cloud.xyz``), ``lit``
  (``scenes/bunny_triangles.json --shading lit --samples 16 --adaptive``); unlit:
  ``mesh_normals`` (``ball.obj --shading normals``), ``two_objects``
  (``scenes/two_objects.json``);
* ``sim``: ``tracer simulate scenes/simulations/ico_bowl.json --steps 1 --no-render``.

Each render case also runs once more with a new empty cache and its film's kernels compiled
in a second process beside it (``cold_ahead``: ``tracer.scenes.compile_ahead``, what ``tracer
render`` does on a machine with two cores; the ``cold`` run has it off, so that one process
compiles, and counts, every kernel); its ``cpu_children_s`` is that second process's CPU. So
does ``sim``, its first step's moments kernel compiled beside it (``tracer.sim.compile_ahead``).

With ``--copies`` (issue 63) each case also runs (a) in a second copy of the source (its
``smoothdist`` and ``tracer`` folders copied elsewhere, as a fresh clone, a new virtual
environment or another install of the same version would be) with the cache the first run
filled, and (b) with a new cache that ``tracer warmup`` filled once beforehand (its wall and CPU
seconds, children included, are reported once); a case may not write into that cache for the
next one, so each gets a copy of it.

Results go to ``benchmarks/data/coldstart.json`` with the load average before and after each
run (other jobs slow a compile down as much as a render), the commit and whether the tree was
dirty. ``--source DIR`` measures another checkout (e.g. a ``git worktree`` of an older
commit) with this script, for a before/after table (the lit and simulation cases read that
checkout's scene files). The README's first-render figures and the
performance guide's cold-start table are read from these files (``tests/repo/test_docs_tables.py``,
``tests/tracer/rendering/test_render_coldstart.py``).

Usage::

    python benchmarks/bench_coldstart.py                       # every case
    python benchmarks/bench_coldstart.py --cases exact smooth md_triangles --out out/cs.json
    git worktree add /tmp/before HEAD~5
    python benchmarks/bench_coldstart.py --source /tmp/before --out benchmarks/data/coldstart_before.json
    python benchmarks/bench_coldstart.py --copies --out benchmarks/data/coldstart_issue63.json
"""

import argparse
import json
import os
import platform
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run from a checkout without installing
    sys.path.insert(0, str(ROOT))

from benchmarks.machine import cpu_name  # noqa: E402
DEFAULT_OUT = ROOT / "benchmarks" / "data" / "coldstart.json"

#: library cases: the code run in the child after the imports (``V``, ``F``, ``E``, ``Q`` given)
LIBRARY = {
    "exact": "sd.exact_distance(Q, V, F)",
    "smooth": "sd.smooth_distance(Q, V, F, alpha=50.0)",
    "smooth_alpha_u": "sd.smooth_distance(Q, V, F, alpha=50.0, alpha_u='auto')",
    "md_triangles": "sd.MeshDistance((V, F), (0.3 * V, F), alpha=50, alpha_q=50)(R, t)",
    "md_edges": "sd.MeshDistance((V, E), (0.3 * V, E), alpha=50, alpha_q=50)(R, t)",
    "md_tri_edges": "sd.MeshDistance((V, E), (0.3 * V, F), alpha=50, alpha_q=50)(R, t)",
    "md_points": "sd.MeshDistance(V, 0.3 * V, alpha=50, alpha_q=50)(R, t)",
    "md_exact": "sd.MeshDistance((V, F), (0.3 * V, F), alpha=50, alpha_q=50).exact(R, t)",
    "md_vertex": ("sd.MeshDistance((V, F), (0.3 * V, F), alpha=50, alpha_q=50)"
                  ".vertex_gradient(R, t)"),
}
#: renders; ``mesh_exact`` (the exact offset surface) and ``mesh_tol`` (tolerance pruning) share
#: a march of their own, which the warm-up's ``render-exact`` job compiles; ``mesh_normals`` and
#: ``two_objects`` (two meshes in one scene file) are unlit
RENDERS = ("mesh", "edges", "cloud", "lit", "mesh_exact", "mesh_tol", "mesh_normals", "two_objects")
CASES = (*LIBRARY, *RENDERS, "sim")
#: the cases whose command compiles part of its kernels in a second process (``cold_ahead``)
AHEAD_CASES = (*RENDERS, "sim")

#: runs in the child: the case, then a count of the compiled specialisations (numba's compile
#: events of smoothdist and tracer functions)
CHILD = r"""
import json, resource, sys, time
t0 = time.perf_counter()
from numba.core import event

compiled = {}


class Count(event.Listener):
    def on_start(self, ev):
        pass

    def on_end(self, ev):
        fn = getattr(ev.data.get("dispatcher"), "py_func", None)
        name = f"{getattr(fn, '__module__', '')}.{getattr(fn, '__qualname__', '?')}"
        if name.split(".")[0] in ("smoothdist", "tracer"):
            compiled[name] = compiled.get(name, 0) + 1


event.register("numba:compile", Count())
case, args = sys.argv[1], sys.argv[2:]
if case == "library":
    import numpy as np
    import smoothdist as sd
    data = np.load(args[0])
    V, F, E, Q = data["V"], data["F"], data["E"], data["Q"]
    R, t = np.eye(3), np.array([0.0, 0.0, 2.0])
    exec(args[1])
    rc = 0
else:
    import tracer.cli
    sys.argv = ["tracer", *args]
    rc = tracer.cli.main()      # as the command runs it: the process is the command's own
wall = time.perf_counter() - t0
ru = resource.getrusage(resource.RUSAGE_SELF)
if case != "library":
    # a compile-ahead child still running is stopped, as at the process's exit, and reaped
    # now: its CPU counts (read before, an unreaped child's was left out)
    from tracer.compiling import wait_ahead
    wait_ahead(timeout=0.0)
kids = resource.getrusage(resource.RUSAGE_CHILDREN)     # a render's compile-ahead child
print(json.dumps({"rc": rc, "in_process_s": wall, "cpu_s": ru.ru_utime + ru.ru_stime,
                  "cpu_children_s": kids.ru_utime + kids.ru_stime,
                  "compiled": sum(compiled.values()), "kernels": dict(sorted(compiled.items()))}))
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


def write_inputs(folder, scenes=ROOT / "scenes"):
    """The cases' input files in ``folder``; ``{case: child arguments}``. The scene files come
    from ``scenes`` (the measured checkout's: its scene format may differ from this one's)."""
    V, F = icosphere(3)
    ball = folder / "ball.obj"
    with open(ball, "w", encoding="ascii") as f:
        f.writelines(f"v {x:.9f} {y:.9f} {z:.9f}\n" for x, y, z in V)
        f.writelines(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in F)
    E = np.unique(np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1),
                  axis=0)
    wire = folder / "ball_edges.obj"
    with open(wire, "w", encoding="ascii") as f:
        f.writelines(f"v {x:.9f} {y:.9f} {z:.9f}\n" for x, y, z in V)
        f.writelines(f"l {a + 1} {b + 1}\n" for a, b in E)
    rng = np.random.default_rng(0)
    P = rng.normal(size=(2000, 3))
    P /= np.linalg.norm(P, axis=1, keepdims=True)
    cloud = folder / "cloud.xyz"
    np.savetxt(cloud, P)
    arrays = folder / "arrays.npz"
    np.savez(arrays, V=V, F=F, E=E, Q=rng.uniform(-1.5, 1.5, (1000, 3)))
    size = ["--size", "256", "256"]
    cases = {name: ["library", str(arrays), code] for name, code in LIBRARY.items()}
    cases.update(
        mesh=["render", str(ball), *size], edges=["render", str(wire), *size],
        cloud=["render", str(cloud), *size],
        mesh_exact=["render", str(ball), *size, "--mode", "exact"],
        mesh_tol=["render", str(ball), *size, "--tol", "1e-3"],
        mesh_normals=["render", str(ball), *size, "--shading", "normals"],
        two_objects=["render", str(scenes / "two_objects.json"), *size],
        lit=["render", str(scenes / "bunny_triangles.json"), *size, "--shading", "lit",
             "--samples", "16", "--adaptive"],
        sim=["simulate", str(scenes / "simulations" / "ico_bowl.json"), "--steps", "1",
             "--no-render"])
    return cases


def run(args, cache, work, threads, source, ahead=False):
    """One child process: ``args`` as given by :func:`write_inputs`, with the kernel cache in
    ``cache`` and ``source`` (a checkout) first on the path; ``ahead``: a render may compile
    its film's kernels in a second process (``tracer.scenes.compile_ahead``), a simulation its
    first step's moments kernel (``tracer.sim.compile_ahead``); off otherwise, so that one
    process compiles every kernel and ``compiled`` counts them all."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache), MPLBACKEND="Agg",
               TRACER_COMPILE_AHEAD="on" if ahead else "off")
    env.pop("SMOOTHDIST_CACHE_DIR", None)  # the kernels' cache: $NUMBA_CACHE_DIR/smoothdist
    env["PYTHONPATH"] = str(source) + os.pathsep + env.get("PYTHONPATH", "")
    if args[0] == "library":
        cmd = [sys.executable, "-c", CHILD, *args]
    else:
        cmd = [sys.executable, "-c", CHILD, "cli", *args]
        cmd += (["-o", str(work / "out.png"), "--overwrite", "-q"] if args[0] == "render" else
                ["-o", str(work / "sim"), "--overwrite"])
        if threads and args[0] == "render":
            cmd += ["--threads", str(threads)]
    if threads:
        env["NUMBA_NUM_THREADS"] = str(threads)
    load = os.getloadavg()[0]
    t0 = time.perf_counter()
    p = subprocess.run(cmd, env=env, capture_output=True, text=True, cwd=work)
    wall = time.perf_counter() - t0
    if p.returncode != 0:
        raise SystemExit(f"error: {' '.join(args)} failed:\n{p.stderr.strip()[-2000:]}")
    r = json.loads(p.stdout.strip().splitlines()[-1])
    if r["rc"] != 0:
        raise SystemExit(f"error: {' '.join(args)} exited {r['rc']}:\n{p.stderr[-2000:]}")
    r.update(wall_s=wall, load_before=load, load_after=os.getloadavg()[0])
    return r


def copy_source(source, dest):
    """The ``smoothdist`` and ``tracer`` packages of ``source`` copied to ``dest`` (no
    ``__pycache__``): a second copy of the same version."""
    skip = shutil.ignore_patterns("__pycache__", "*.pyc")
    for pkg in ("smoothdist", "tracer"):
        if (source / pkg).is_dir():
            shutil.copytree(source / pkg, dest / pkg, ignore=skip)
    return dest


def run_warmup(cache, source):
    """``tracer warmup`` into the empty ``cache``: ``{wall_s, cpu_s (children included),
    compiled}``."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache), MPLBACKEND="Agg")
    env.pop("SMOOTHDIST_CACHE_DIR", None)
    env["PYTHONPATH"] = str(source) + os.pathsep + env.get("PYTHONPATH", "")
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    load = os.getloadavg()[0]
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, "-m", "tracer", "warmup"], env=env, capture_output=True,
                       text=True, cwd=source)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if p.returncode != 0:
        raise SystemExit(f"error: tracer warmup failed:\n{p.stderr.strip()[-2000:]}")
    last = p.stderr.strip().splitlines()[-1]
    compiled = int(last.split(" kernel specialisations")[0].rsplit(" ", 1)[-1])
    return {"wall_s": wall, "cpu_s": (after.ru_utime + after.ru_stime) - (before.ru_utime +
                                                                          before.ru_stime),
            "compiled": compiled, "cores": os.cpu_count(), "load_before": load,
            "load_after": os.getloadavg()[0], "summary": last}


def describe(case, args, work):
    """The case's command as a reader would type it (file names without folders)."""
    if args[0] == "library":
        return LIBRARY[case]
    words = [Path(a).name if a.startswith(str(work)) else
             (str(Path(a).relative_to(ROOT)) if a.startswith(str(ROOT)) else a) for a in args]
    return "tracer " + " ".join(words)


def git_state(source):
    """``(commit, dirty)`` of the checkout ``source`` (None where git cannot tell)."""
    try:
        commit = subprocess.run(["git", "rev-parse", "HEAD"], cwd=source, capture_output=True,
                                text=True, check=True).stdout.strip()
        dirty = bool(subprocess.run(["git", "status", "--porcelain", "--", "smoothdist",
                                     "tracer"], cwd=source, capture_output=True, text=True,
                                    check=True).stdout.strip())
        return commit, dirty
    except (OSError, subprocess.CalledProcessError):
        return None, None


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--cases", nargs="+", choices=CASES, default=list(CASES))
    p.add_argument("--threads", type=int, default=None,
                   help="numba threads of the children (default: numba's)")
    p.add_argument("--source", default=str(ROOT),
                   help="the checkout to measure (default: this one)")
    p.add_argument("--out", default=str(DEFAULT_OUT), help="results JSON")
    p.add_argument("--copies", action="store_true",
                   help="also a second copy of the source, and after tracer warmup (issue 63)")
    args = p.parse_args(argv)
    if not args.out.endswith(".json"):
        p.error("--out must name a .json file")
    source = Path(args.source).resolve()
    if not (source / "smoothdist" / "__init__.py").is_file():
        p.error(f"--source {source} holds no smoothdist package")
    commit, dirty = git_state(source)
    results = {"date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
               "machine": {"cores": os.cpu_count(), "cpu": cpu_name(),
                           "platform": platform.platform(), "python": platform.python_version()},
               "commit": commit, "dirty": dirty, "cases": {}}
    work = Path(tempfile.mkdtemp(prefix="coldstart-"))
    try:
        inputs = write_inputs(work, source / "scenes")
        if args.copies:
            second = copy_source(source, work / "second-copy")
            warmed = work / "cache-warmup"
            warmed.mkdir()
            results["warmup"] = run_warmup(warmed, source)
            print(f"warmup: {results['warmup']['wall_s']:.1f} s wall, "
                  f"{results['warmup']['cpu_s']:.1f} s CPU", flush=True)
        print(f"{'case':15} {'cold s':>7} {'cpu s':>6} {'warm s':>7} {'compiled':>9} "
              f"{'load':>9}{'  copy cpu s  after warmup cpu s' if args.copies else ''}")
        for case in args.cases:
            cache = work / f"cache-{case}"
            cache.mkdir()
            cold = run(inputs[case], cache, work, args.threads, source)
            warm = run(inputs[case], cache, work, args.threads, source)
            r = results["cases"][case] = {"command": describe(case, inputs[case], work),
                                          "cold": cold, "warm": warm}
            if case in AHEAD_CASES:     # the same first call, part of it compiled alongside
                ahead = work / f"cache-{case}-ahead"
                ahead.mkdir()
                r["cold_ahead"] = run(inputs[case], ahead, work, args.threads, source, True)
            extra = ""
            if args.copies:
                r["second_copy"] = run(inputs[case], cache, work, args.threads, second)
                mine = work / f"cache-warmup-{case}"
                shutil.copytree(warmed, mine)
                r["after_warmup"] = run(inputs[case], mine, work, args.threads, source)
                extra = (f"  {r['second_copy']['cpu_s']:11.1f}  "
                         f"{r['after_warmup']['cpu_s']:16.1f}")
            if "cold_ahead" in r:
                a = r["cold_ahead"]
                extra += (f"  ahead {a['wall_s']:.1f} s wall, "
                          f"{a['cpu_s'] + a['cpu_children_s']:.1f} s CPU")
            print(f"{case:15} {cold['wall_s']:7.1f} {cold['cpu_s']:6.1f} {warm['wall_s']:7.1f} "
                  f"{cold['compiled']:9d} {cold['load_before']:4.1f}-{cold['load_after']:.1f}"
                  f"{extra}", flush=True)
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
