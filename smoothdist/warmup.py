"""Compile the kernels ahead of their first use, side by side on the machine's cores.

numba compiles a kernel's specialisation on its first call, on one core, and keeps it in the
per-machine cache (:mod:`smoothdist._kernel_cache`). :func:`run` starts one child process per
job, up to ``workers`` at a time (the machine's cores by default), longest job first; each job
makes the first calls of one entry point on made-up meshes of the sizes at which its path
changes (:data:`LEVELS`), so that its kernels land in
the cache and a user's first call loads them instead. Run it once per machine and version (after
``pip install``, in a Docker image, before a CI suite): ``python -m smoothdist warmup`` for the
library, ``tracer warmup`` for the library and the renderer.

A job is ``(module, name)``: ``module.JOBS[name]()`` runs in the child. Jobs overlap (every
entry point builds a tree): two children that need one kernel both compile it at first, and the
later jobs find it cached. Each child reports the specialisations it compiled (numba's
``numba:compile`` events of our functions); a failed job is reported with the end of its error
output and the others go on.
"""

import argparse
import importlib
import json
import os
import subprocess
import sys
import time

import numpy as np
from numba.core.dispatcher import Dispatcher

import smoothdist as sd
from smoothdist import _kernel_cache
from smoothdist._kernels import bvh

__all__ = ["JOBS", "run", "jobs_of", "main", "cache_folder", "switched_off",
           "build_trees_in_python"]

#: runs in a child process: ``module.JOBS[name]()``, then one JSON line with what it compiled
CHILD = r"""
import importlib, json, resource, sys, time
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
importlib.import_module(sys.argv[1]).JOBS[sys.argv[2]]()
ru = resource.getrusage(resource.RUSAGE_SELF)
print(json.dumps({"compiled": sum(compiled.values()), "kernels": compiled,
                  "cpu_s": ru.ru_utime + ru.ru_stime, "wall_s": time.perf_counter() - t0}))
"""


def cache_folder():
    """This copy's folder of the per-machine kernel cache (:mod:`smoothdist._kernel_cache`), or
    None when it is switched off: where a warm-up's kernels land."""
    return _kernel_cache.folder()


def switched_off(value):
    """Whether an environment variable's ``value`` says off (``off``, ``0``, ``no``,
    ``false``), as ``SMOOTHDIST_CACHE_DIR=off`` does."""
    return str(value).strip().lower() in _kernel_cache.OFF


def build_trees_in_python():
    """Make this process build trees (:class:`smoothdist.SmoothDistanceField`) with the pure
    Python functions of the build kernels: nothing compiled, for a process that compiles other
    kernels ahead on a tiny mesh (``tracer.scenes.compile_ahead``). Slow on a real mesh."""
    for name, value in list(vars(bvh).items()):
        if isinstance(value, Dispatcher):
            setattr(bvh, name, value.py_func)


def sphere(level):
    """``(V, F, E)`` of the octahedron subdivided ``level`` times onto the unit sphere
    (``8 * 4**level`` triangles)."""
    V = [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]]
    F = [[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]]
    V = np.array(V, float)
    F = np.array(F, np.int64)
    for _ in range(level):
        edges = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
        uniq, inv = np.unique(edges, axis=0, return_inverse=True)
        mid = V[uniq].mean(axis=1)
        m = len(V) + inv.reshape(3, -1).T  # the middles of edges 01, 12, 20 of each triangle
        V = np.concatenate([V, mid])
        a, b, c = F.T
        F = np.concatenate([np.stack([a, m[:, 0], m[:, 2]], 1), np.stack([b, m[:, 1], m[:, 0]], 1),
                            np.stack([c, m[:, 2], m[:, 1]], 1), m])
    V /= np.linalg.norm(V, axis=1, keepdims=True)
    E = np.unique(np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1),
                  axis=0)
    return V, F, E


#: the meshes' subdivision levels: 8 triangles (below every size at which a call changes path:
#: serial loops, ``whole_mesh.SERIAL_BELOW``) and 2,048 (above them); the point queries also
#: build a tree of 32,768 triangles (``bvh.RADIX_BUILD_MIN``: the radix-sorted parallel build)
LEVELS = (0, 4)
BIG_LEVEL = 6


def _queries(n=200):
    return np.random.default_rng(0).uniform(-1.5, 1.5, (n, 3))


def _mesh(kind, level):
    V, F, E = sphere(level)
    return {"triangles": (V, F), "edges": (V, E), "points": (V, None)}[kind]


def _distances(kind, which, levels=(*LEVELS, BIG_LEVEL)):
    """A library user's first calls on meshes of ``kind``: ``which`` is ``"exact"`` (exact
    distance, the field's too) or ``"smooth"`` (smooth distance with gradients, alpha_U
    automatic too, and a field's repeated queries, with tolerance pruning too)."""
    meshes = [_mesh(kind, level) for level in levels]
    Q = _queries()

    def job():
        for V, F in meshes:
            if which == "exact":
                sd.exact_distance(Q, V, F)
                sd.SmoothDistanceField(V, F).exact_distance(Q)
            else:
                sd.smooth_distance(Q, V, F, alpha=50.0)
                sd.smooth_distance(Q, V, F, alpha=50.0, alpha_u="auto")
                field = sd.SmoothDistanceField(V, F)
                field.smooth_distance(Q, alpha=50.0)
                field.smooth_distance(Q, alpha=50.0, beta=0.0, tol=1e-3)  # tolerance pruning

    return job


def whole_mesh_pairs(kind, levels=LEVELS):
    """``[(data, query)]``: a sphere of ``kind`` against a copy scaled by 0.3, per level."""
    pairs = []
    for level in levels:
        V, F = _mesh(kind, level)
        pairs.append((V if F is None else (V, F), 0.3 * V if F is None else (0.3 * V, F)))
    return pairs


def mixed_kind_pairs(levels=LEVELS):
    """``[(data, query)]`` of different kinds, per level: triangles on edges, edges on
    triangles, and triangles on a mesh of triangles and edges."""
    pairs = []
    for level in levels:
        V, F, E = sphere(level)
        pairs += [((V, E), (0.3 * V, F)), ((V, F), (0.3 * V, E)),
                  (sd.DataMesh(V, edges=E[::2], triangles=F), (0.3 * V, F))]
    return pairs


def _whole_mesh(kind, which, levels=LEVELS):
    """A collision constraint between two meshes of ``kind``: ``which`` is ``"call"`` (value
    and gradient), ``"vertex"`` (the gradient per query vertex) or ``"exact"`` (the exact
    distance)."""
    pairs = whole_mesh_pairs(kind, levels)

    def job():
        R, t = np.eye(3), np.array([0.0, 0.0, 2.0])
        for data, query in pairs:
            md = sd.MeshDistance(data, query, alpha=50, alpha_q=50)
            if which == "call":
                md(R, t)
            elif which == "vertex":
                md.vertex_gradient(R, t)
            else:
                md.exact(R, t)

    return job


def _mixed_kinds(levels=LEVELS):
    """``MeshDistance`` between meshes of different kinds: triangles on edges, edges on
    triangles, and triangles on a mesh of triangles and edges (each one-kind pair above compiles
    only its own pair kernel; these take the other distance kernels)."""
    pairs = mixed_kind_pairs(levels)

    def job():
        R, t = np.eye(3), np.array([0.0, 0.0, 2.0])
        for data, query in pairs:
            sd.MeshDistance(data, query, alpha=50, alpha_q=50)(R, t)

    return job


def _every_kind():
    """Every entry point above on edges and points (mostly loaded from the cache by then)."""
    calls = [f(kind, w, LEVELS) for kind in ("edges", "points")
             for f, ws in ((_distances, ("exact", "smooth")),
                           (_whole_mesh, ("call", "vertex", "exact"))) for w in ws]

    def job():
        for call in calls:
            call()

    return job


class _Lazy(dict):
    """``{name: factory}`` whose items are made when looked up: a job makes its input (and
    imports what only it needs) in its own child, not in the parent that lists the jobs."""

    def __getitem__(self, name):
        return dict.__getitem__(self, name)()


#: the library's jobs, the longest chain first (a job starts when a worker is free and the jobs
#: it waits for have ended): the entry points on triangles, then every entry point on the
#: other kinds, which by then are loaded from the cache
JOBS = _Lazy({
    "mesh-distance": lambda: _whole_mesh("triangles", "call"),
    "mesh-distance-vertex": lambda: _whole_mesh("triangles", "vertex"),
    "exact-distance": lambda: _distances("triangles", "exact"),
    "smooth-distance": lambda: _distances("triangles", "smooth"),
    "mesh-distance-exact": lambda: _whole_mesh("triangles", "exact"),
    "edges-and-points": _every_kind,
    "mesh-distance-mixed-kinds": _mixed_kinds,
})
#: ``{job: jobs it waits for}``: the vertex gradient and the whole-mesh exact distance share
#: most of ``mesh-distance``'s kernels (66 of 68), so they start once those are cached
AFTER = {"mesh-distance-vertex": ("mesh-distance",), "mesh-distance-exact": ("mesh-distance",),
         "mesh-distance-mixed-kinds": ("mesh-distance",),
         "edges-and-points": ("mesh-distance-vertex", "mesh-distance-exact", "smooth-distance",
                              "exact-distance")}


def jobs_of(module):
    """``[(module name, job name, jobs it waits for)]`` of a jobs module, in its order."""
    mod = importlib.import_module(module)
    after = getattr(mod, "AFTER", {})
    return [(module, name, tuple(after.get(name, ()))) for name in mod.JOBS.keys()]


def interleaved(lists):
    """The jobs of several modules taken in turn, one from each (each module's longest chain
    first): on two cores the renderer's chain runs beside the library's instead of after it."""
    out = []
    for i in range(max(map(len, lists), default=0)):
        out += [jobs[i] for jobs in lists if i < len(jobs)]
    return out


def _next(pending, done, known):
    """Index in ``pending`` of the first job whose prerequisites (those among ``known``) are
    all ``done``; None if every pending job still waits."""
    for i, (_, _, after) in enumerate(pending):
        if all(a in done or a not in known for a in after):
            return i
    return None


def _child(module, name):
    env = dict(os.environ)
    return subprocess.Popen([sys.executable, "-c", CHILD, module, name], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _result(proc):
    out, err = proc.communicate()
    if proc.returncode == 0:
        try:
            return json.loads(out.strip().splitlines()[-1]), None
        except (ValueError, IndexError):
            pass
    tail = (err or out or "").strip().splitlines()[-3:]
    return None, " | ".join(tail) or f"exit status {proc.returncode}"


def run(jobs, workers=None, progress=None):
    """Run ``jobs`` (``[(module, name, after)]``, :func:`jobs_of`) in child processes,
    ``workers`` at a time (default: the machine's cores), each once the jobs it waits for (and
    that are in ``jobs``) have ended, in the order given otherwise; ``progress(done, total,
    line)`` after each. Returns
    ``{"jobs": {name: result or {"error": text}}, "wall_s": s, "compiled": n}``."""
    workers = max(1, int(workers or os.cpu_count() or 1))
    pending = list(jobs)
    running = {}
    results = {}
    t0 = time.perf_counter()
    known = {name for _, name, _ in jobs}
    while pending or running:
        while pending and len(running) < workers:
            i = _next(pending, results, known)
            if i is None:
                break
            module, name, _ = pending.pop(i)
            running[name] = _child(module, name)
        finished = [n for n, p in running.items() if p.poll() is not None]
        if not finished:
            time.sleep(0.05)
            continue
        for name in finished:
            res, err = _result(running.pop(name))
            results[name] = res if err is None else {"error": err}
            if progress is not None:
                line = (f"{name}: {res['compiled']} compiled, {res['wall_s']:.1f} s"
                        if err is None else f"{name}: failed ({err})")
                progress(len(results), len(jobs), line)
    return {"jobs": results, "wall_s": time.perf_counter() - t0,
            "compiled": sum(r.get("compiled", 0) for r in results.values())}


def report(summary, jobs, out=sys.stderr):
    """Print the closing line of a warm-up; returns the exit status (1 if a job failed)."""
    failed = [n for n, r in summary["jobs"].items() if "error" in r]
    where = _kernel_cache.folder() or "numba's default cache folders"
    print(f"warmup: {len(jobs) - len(failed)} of {len(jobs)} jobs, {summary['compiled']} "
          f"kernel specialisations compiled in {summary['wall_s']:.1f} s; cache: {where}",
          file=out)
    return 1 if failed else 0


def _print_progress(done, total, line):
    print(f"warmup [{done}/{total}] {line}", file=sys.stderr, flush=True)


def main(argv=None, modules=("smoothdist.warmup",), prog="python -m smoothdist warmup"):
    """The ``warmup`` command over the jobs of ``modules``; returns the exit status."""
    p = argparse.ArgumentParser(prog=prog, description=__doc__.split("\n\n")[0])
    add_arguments(p)
    args = p.parse_args(argv)
    return warmup_command(args, modules)


def add_arguments(p):
    """The warm-up's options (also ``tracer warmup``'s)."""
    p.add_argument("--workers", type=int, default=None,
                   help="child processes at a time (default: the machine's cores)")
    p.add_argument("--only", nargs="+", metavar="JOB", help="run these jobs only")
    p.add_argument("--list", action="store_true", help="list the jobs and exit")
    p.add_argument("-q", "--quiet", action="store_true", help="print the closing line only")


def warmup_command(args, modules):
    """Run the parsed ``warmup`` command over the jobs of ``modules``."""
    jobs = interleaved([jobs_of(m) for m in modules])
    if args.list:
        print("\n".join(name for _, name, _ in jobs))
        return 0
    if args.only:
        unknown = sorted(set(args.only) - {n for _, n, _ in jobs})
        if unknown:
            print(f"error: unknown job(s) {', '.join(unknown)} (see --list)", file=sys.stderr)
            return 2
        jobs = [j for j in jobs if j[1] in args.only]
    if args.workers is not None and args.workers < 1:
        print("error: --workers must be at least 1", file=sys.stderr)
        return 2
    summary = run(jobs, args.workers, None if args.quiet else _print_progress)
    return report(summary, jobs)
