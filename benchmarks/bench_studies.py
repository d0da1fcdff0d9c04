"""Scaling of the studies' task runner: in-process vs a local Dask cluster of 1 and 2 workers.

Three measurements, each in the three modes (``serial``: in this process with all numba
threads; ``local-1`` / ``local-2``: a ``LocalCluster`` with that many worker processes of one
numba thread each, started inside the timed region, as a user's run pays for it):

* ``beta``: the beta study's renders of the three data types at the given betas (default
  0.5 and 1: beta = 0 takes minutes) of the bunny at 256 x 256, through
  :func:`tracer.runner.run_study` with :func:`tracer.studies.beta.render_task`;
* ``grid``: the grid study (``tracer bench-grid``) over a folder of meshes, default the 12
  Thingi10K meshes (:mod:`tracer.datasets`: fetched with checksums on first use, or a local
  copy), N = 100;
* ``overhead``: ``--trivial`` no-op tasks; wall time per task once the cluster is up.

Usage (from the repository root)::

    python benchmarks/bench_studies.py [--only beta,grid,overhead] [--modes serial,local-2]
        [--json out.json]

The machine's load average is printed with every figure: on a shared machine the numbers
move with the other jobs.
"""

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

from tracer.cli import main as tracer_main  # noqa: E402
from tracer import datasets, runner  # noqa: E402
from tracer.studies import beta  # noqa: E402

MODES = (("serial", "serial", None), ("local-1", "local", 1), ("local-2", "local", 2))


def noop(task):
    return {"x": task["x"]}


def _load():
    return [round(x, 2) for x in os.getloadavg()]


def bench_beta(betas, size, mesh, modes=MODES):
    tasks = beta.list_tasks(mesh, list(beta.TYPES), betas, [0.0], size=size, alpha=200.0,
                            alpha_u=1200.0, eps=None)
    tasks = [t for t in tasks if t["beta"] in betas]  # no beta = 0 reference
    beta.probe(tasks[:1], 8)  # compile or load the kernels in this process, untimed
    out = {}
    for name, sched, workers in modes:
        secs = {}
        t0 = time.perf_counter()
        info = runner.run_study(beta.render_task, tasks, scheduler=sched, workers=workers,
                                quiet=True, on_result=lambda t, r: secs.__setitem__(
                                    t["key"], (r["seconds"], r["task_seconds"])))
        wall = time.perf_counter() - t0
        out[name] = {"wall": wall, "renders": {k: round(v[0], 3) for k, v in secs.items()},
                     "tasks_sum": sum(v[1] for v in secs.values()), "failed": len(info.failed),
                     "load": _load()}
        print(f"beta {name}: {wall:.1f} s wall for {len(tasks)} renders (sum of render "
              f"times {sum(v[0] for v in secs.values()):.1f} s), load {_load()}", flush=True)
    return out


def bench_grid(folder, n, modes=MODES):
    out = {}
    for name, sched, workers in modes:
        with tempfile.TemporaryDirectory() as tmp:
            args = ["bench-grid", str(folder), "-o", str(Path(tmp) / "g"), "--grid", str(n),
                    "-q", "--scheduler", sched] + (["--workers", str(workers)] if workers else [])
            t0 = time.perf_counter()
            status = tracer_main(args)
            wall = time.perf_counter() - t0
        out[name] = {"wall": wall, "status": status, "load": _load()}
        print(f"grid {name}: {wall:.1f} s wall (exit {status}), load {_load()}", flush=True)
    return out


def bench_overhead(count, modes=MODES):
    tasks = [{"key": f"t{i}", "x": i} for i in range(count)]
    out = {}
    for name, sched, workers in modes:
        if sched == "serial":
            t0 = time.perf_counter()
            runner.run_study(noop, tasks, scheduler="serial", quiet=True,
                             on_result=lambda t, r: None)
            per = (time.perf_counter() - t0) / count
            out[name] = {"per_task": per, "startup": 0.0}
        else:
            t0 = time.perf_counter()
            client, cluster = runner.connect("local", workers)
            startup = time.perf_counter() - t0
            try:
                address = cluster.scheduler_address
                runner.run_study(noop, tasks[:4], scheduler=address, quiet=True,
                                 on_result=lambda t, r: None)  # workers import the module
                t0 = time.perf_counter()
                runner.run_study(noop, tasks, scheduler=address, quiet=True,
                                 on_result=lambda t, r: None)
                per = (time.perf_counter() - t0) / count
            finally:
                runner._shutdown(client, cluster)
            out[name] = {"per_task": per, "startup": startup}
        out[name]["load"] = _load()
        print(f"overhead {name}: {1e3 * out[name]['per_task']:.2f} ms per task, cluster start "
              f"{out[name]['startup']:.1f} s, load {_load()}", flush=True)
    return out


def _grid_folder():
    """The Thingi10K meshes' folder, or the shipped meshes where they cannot be had (said)."""
    try:
        return str(datasets.group_folder("thingi10k", progress=print))
    except datasets.DataUnavailable as exc:
        print(f"grid: {exc}; the shipped scenes/data/meshes instead", flush=True)
        return str(REPO / "scenes" / "data" / "meshes")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", default="beta,grid,overhead")
    ap.add_argument("--betas", default="0.5,1")
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--mesh", default=str(REPO / "scenes" / "data" / "bunny.off"))
    ap.add_argument("--folder", default=None,
                    help="meshes for the grid study (default: the 12 Thingi10K meshes, fetched "
                         "on first use; where they cannot be had, the shipped "
                         "scenes/data/meshes, said so)")
    ap.add_argument("--grid", type=int, default=100)
    ap.add_argument("--trivial", type=int, default=200)
    ap.add_argument("--modes", default=",".join(m[0] for m in MODES),
                    help="which of serial, local-1, local-2 (default: all three)")
    ap.add_argument("--json")
    a = ap.parse_args(argv)
    only = a.only.split(",")
    names = a.modes.split(",")
    unknown = sorted(set(names) - {m[0] for m in MODES})
    if unknown:
        ap.error(f"unknown mode(s) {', '.join(unknown)}: choose from "
                 f"{', '.join(m[0] for m in MODES)}")
    modes = tuple(m for m in MODES if m[0] in names)
    res = {"cpu_count": runner.cpu_count(), "load_before": _load()}
    if "overhead" in only:
        res["overhead"] = bench_overhead(a.trivial, modes)
    if "beta" in only:
        res["beta"] = bench_beta([float(b) for b in a.betas.split(",")], a.size, a.mesh,
                                 modes)
    if "grid" in only:
        res["grid"] = bench_grid(a.folder or _grid_folder(), a.grid, modes)
    if a.json:
        Path(a.json).write_text(json.dumps(res, indent=2) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
