"""``tracer bench-grid DIR``: the Thingi10K benchmark of Sec. 4.4 (authors' ``app/benchmark_cpu``).

V, E and F of every mesh in a folder are normalised to a bbox centred at (0.5, 0.5, 0.5) with
diagonal 0.5 and queried at the ``N^3`` voxel centres of the unit cube with alpha = alpha_U = 1
and beta = 0.5 (the authors' code uses alpha = 1; the paper gives none). Per mesh and type the
CSV has the number of primitives, the mean leaves visited per query and the seconds of the
queries (BVH construction not included).

As independent tasks: :func:`list_tasks` (one task per mesh file: its path and the protocol's
numbers), :func:`grid_task` (loads the mesh by path, builds its three fields once per process,
times the queries; a mesh that cannot be loaded gives a ``skipped`` record with its error) and
:func:`reduce` (sorted CSV, ``bench_grid.json``, the two scatter plots).
"""

import functools
import os
import time
import warnings
from pathlib import Path

import numba
import numpy as np

from smoothdist import DataMesh, MeshRepairWarning, SmoothDistanceField
from tracer import runner
from tracer.errors import CLIError
from tracer.outputs import non_negative, output_folder, positive, write_json
from tracer.runner import duration, file_stamp
from tracer.studies.common import (REPO, TYPE_LETTER, TYPES, add_common, machine_info,
                                   parse_types, study_needs)
from tracer.studies.plots import bench_plots

HELP = "the paper's Thingi10K grid benchmark over a folder"

MESH_EXTS = (".obj", ".off", ".stl", ".ply")
BENCH_CSV = "bench_grid.csv"
BENCH_FIELDS = ["name", "nV", "leaves_v", "seconds_v", "nE", "leaves_e", "seconds_e", "nF",
                "leaves_f", "seconds_f", "threads", "file"]
COUNT = {"points": "nV", "edges": "nE", "triangles": "nF"}
#: a-priori seconds per query and type, for choosing in-process vs a cluster
SECONDS_PER_QUERY = 1e-6
#: the folder used when none is given: the three small meshes the repository ships
DEFAULT_FOLDER = REPO / "scenes" / "data" / "meshes"


def add_arguments(p):
    """Arguments of ``tracer bench-grid``."""
    p.add_argument("folder", nargs="?", metavar="DIR",
                   help="folder of meshes (.obj, .off, .stl, .ply; default: the three small "
                   "meshes shipped in scenes/data/meshes; the paper uses Thingi10K)")
    p.add_argument("-o", "--output", metavar="OUT",
                   help="result folder: bench_grid.csv, bench_grid.json and the two plots "
                   "(default renders/ablation/grid-<name of DIR>)")
    p.add_argument("--grid", type=int, default=100, help="N for the N^3 voxel grid (default 100)")
    p.add_argument("--alpha", type=float, default=1.0, help="alpha (default 1, the authors' code)")
    p.add_argument("--alpha-u", type=float, help="alpha_U (default: alpha, i.e. S = 1)")
    p.add_argument("--beta", type=float, default=0.5, help="Barnes-Hut beta (default 0.5)")
    p.add_argument("--types", default="points,edges,triangles",
                   help="data types (default points,edges,triangles)")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--overwrite", action="store_true", help="replace earlier results")
    g.add_argument("--resume", action="store_true", help="skip meshes already in the CSV")
    runner.add_arguments(p)
    add_common(p)


def benchmark_normalise(V):
    """The authors' benchmark normalisation: the vertex bbox centred at (0.5, 0.5, 0.5) with
    diagonal 0.5 (translate the centre to 0, divide by 2 x diagonal, add 0.5)."""
    V = np.asarray(V, dtype=np.float64)
    lo, hi = V.min(axis=0), V.max(axis=0)
    diag = float(np.linalg.norm(hi - lo))
    if diag == 0:
        raise ValueError("all vertices coincide")
    return (V - 0.5 * (lo + hi)) / (2.0 * diag) + 0.5


@functools.lru_cache(maxsize=2)
def voxel_centres(n):
    """``(n**3, 3)`` centres ``(i + 0.5) / n`` of an ``n^3`` grid over the unit cube (cached per
    process: do not modify)."""
    c = (np.arange(n) + 0.5) / n
    X, Y, Z = np.meshgrid(c, c, c, indexing="ij")
    return np.ascontiguousarray(np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=1))


def mesh_files(folder):
    return sorted(p for p in Path(folder).iterdir()
                  if p.suffix.lower() in MESH_EXTS and p.is_file())


def list_tasks(files, *, grid, alpha, alpha_u, beta, types):
    """One task per mesh file; its weight (for the ETA) is the file size."""
    return [{"key": f.name, "path": str(Path(f).resolve()), "grid": int(grid),
             "alpha": float(alpha), "alpha_u": float(alpha_u), "beta": float(beta),
             "types": list(types), "weight": max(float(f.stat().st_size), 1.0) * len(types)}
            for f in files]


@functools.lru_cache(maxsize=4)
def _fields(stamp):
    """``{kind: SmoothDistanceField}`` of the normalised mesh ``stamp[0]`` (per process)."""
    name = os.path.basename(stamp[0])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MeshRepairWarning)
        m = DataMesh.load(stamp[0])
        Vn = benchmark_normalise(m.V)
        meshes = {"points": DataMesh(Vn, name=name)}
        if len(m.edges) or len(m.triangles):
            meshes["edges"] = DataMesh(Vn, edges=m.as_kind("edges").edges, name=name)
        if len(m.triangles):
            meshes["triangles"] = DataMesh(Vn, triangles=m.triangles, name=name)
    return {k: SmoothDistanceField(v) for k, v in meshes.items()}


_WARM = []


def grid_task(task):
    """One mesh's grid benchmark; returns its CSV row (``status`` ``skipped`` with the error
    when the mesh cannot be loaded)."""

    path = task["path"]
    row = {"name": Path(path).stem, "file": os.path.basename(path),
           "threads": int(numba.get_num_threads())}
    try:
        fields = _fields(file_stamp(path))
    except (ValueError, OSError) as exc:
        text = str(exc).strip()
        row.update(status="skipped",
                   error=(text.splitlines()[0] if text else type(exc).__name__))
        return row
    Q = voxel_centres(task["grid"])
    kw = dict(alpha=task["alpha"], beta=task["beta"], alpha_u=task["alpha_u"],
              return_stats=True)
    if not _WARM:  # load or compile the kernels outside the timed queries
        warm = SmoothDistanceField(np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]), [[0, 1, 2]])
        for kind in TYPES:
            SmoothDistanceField(warm.mesh.as_kind(kind)).smooth_distance(Q[:8], **kw)
        _WARM.append(True)
    for kind in TYPES:
        L = TYPE_LETTER[kind]
        if kind not in task["types"] or kind not in fields:
            continue
        field = fields[kind]
        t0 = time.perf_counter()
        _, _, st = field.smooth_distance(Q, **kw)
        sec = time.perf_counter() - t0
        row.update({COUNT[kind]: field.num_primitives,
                    f"leaves_{L}": float(st.leaves_visited.mean()), f"seconds_{L}": sec})
    return row


def reduce(out, log, params):
    """Sorted CSV, ``bench_grid.json`` (with the skipped and failed meshes) and the plots;
    returns ``(ok rows, skipped rows, failed rows)``."""
    rows = sorted(log.read(), key=lambda r: r["name"])
    log.start(rows)
    ok = [r for r in rows if r["status"] == "ok"]
    skipped = [r for r in rows if r["status"] == "skipped"]
    failed = [r for r in rows if r["status"] == "failed"]
    params = dict(params, meshes=len(rows), measured=len(ok),
                  skipped=[{"file": r["file"], "error": r["error"]} for r in skipped],
                  failed=[{"file": r["file"], "error": r["error"]} for r in failed])
    write_json(out / "bench_grid.json", params)
    bench_plots(out, ok, params)
    return ok, skipped, failed


def needs(args):
    """The optional packages of the benchmark (:func:`tracer.studies.common.study_needs`, for
    the mesh files in the folder)."""
    folder = Path(args.folder) if args.folder else DEFAULT_FOLDER
    return study_needs(args, mesh_files(folder) if folder.is_dir() else [])


def run(args):
    """Run the grid benchmark over a folder; returns the exit status (1 when a task failed)."""
    sched, workers = runner.check_arguments(args)
    folder = Path(args.folder) if args.folder else DEFAULT_FOLDER
    if not folder.is_dir():
        raise CLIError(f"mesh folder not found: {folder.resolve() if not args.folder else folder}"
                       " (give a folder of meshes as DIR, e.g. the Thingi10K meshes)")
    files = mesh_files(folder)
    if not files:
        raise CLIError(f"no mesh files ({', '.join(MESH_EXTS)}) in {folder}")
    if args.grid < 1 or args.grid > 400:
        raise CLIError(f"--grid must be between 1 and 400, got {args.grid}")
    alpha = positive(args.alpha, "--alpha")
    alpha_u = positive(args.alpha_u, "--alpha-u") if args.alpha_u is not None else alpha
    non_negative(args.beta, "--beta")
    types = parse_types(args.types)
    out = output_folder(args.output or os.path.join(
        "renders", "ablation", f"grid-{folder.resolve().name}"))
    csv_path = out / BENCH_CSV
    products = [csv_path, out / "bench_grid.json", out / "bench_time_vs_leaves.png",
                out / "bench_leaf_fraction.png"]
    existing = [p for p in products if p.exists()]
    if existing and not (args.overwrite or args.resume):
        raise CLIError(f"{out} already holds benchmark results ({existing[0].name}); pass "
                       "--resume to continue them or --overwrite to replace them")
    log = runner.TaskLog(csv_path, BENCH_FIELDS, key="file")
    rows = log.read(["name"]) if args.resume else []
    done = log.done_keys(rows)
    out.mkdir(parents=True, exist_ok=True)
    log.start([r for r in rows if r["file"] in done])
    tasks = list_tasks(files, grid=args.grid, alpha=alpha, alpha_u=alpha_u, beta=args.beta,
                       types=types)
    todo = [t for t in tasks if t["key"] not in done]
    estimate = len(todo) * len(types) * args.grid ** 3 * SECONDS_PER_QUERY
    mode = runner.choose_mode(sched, workers, len(todo), estimate)

    params = {"folder": str(folder.resolve()), "grid": args.grid, "alpha": alpha,
              "alpha_u": alpha_u, "beta": args.beta, "types": types,
              "normalisation": "vertex bbox centred at (0.5,0.5,0.5), diagonal 0.5",
              "queries": f"{args.grid}^3 voxel centres (i+0.5)/N of [0,1]^3",
              "threads": int(numba.get_num_threads()) if mode == "serial" else 1,
              "scheduler": mode, "machine": machine_info()}
    write_json(out / "bench_grid.json", params)
    say = (lambda s: None) if args.quiet else (lambda s: print(s, flush=True))
    if done:
        say(f"resuming: {len(done)} mesh(es) already in {csv_path}, {len(todo)} to go")

    def on_result(task, record):
        log.append(dict(record, file=task["key"]))

    def on_failure(task, err):
        log.append({"file": task["key"], "name": Path(task["path"]).stem, "status": "failed",
                    "error": err})

    def line(task, r):
        if r["status"] == "skipped":
            return f"skipping {task['key']}: {r['error']}"
        parts = [f"{k} N={r[COUNT[k]]} {r['leaves_' + TYPE_LETTER[k]]:.1f} leaves/query "
                 f"{r['seconds_' + TYPE_LETTER[k]]:.2f} s" for k in TYPES if COUNT[k] in r]
        return f"{r['name']}: " + "; ".join(parts)

    info = runner.run_study(grid_task, todo, on_result=on_result, on_failure=on_failure,
                            scheduler=mode, workers=workers, label="bench-grid",
                            quiet=args.quiet, line=line)
    ok, skipped, failed = reduce(out, log, params)
    say(f"Benchmark of {len(ok)} mesh(es) at {args.grid}^3 queries ({len(todo)} task(s) "
        f"{info.describe()}, {duration(info.seconds)}"
        + (f"; {len(skipped)} skipped: " + ", ".join(r["file"] for r in skipped) if skipped
           else "")
        + f"): {csv_path}, bench_time_vs_leaves.png, bench_leaf_fraction.png.")
    if failed:
        print(f"warning: {len(failed)} mesh(es) failed (see the 'error' column of {csv_path}); "
              "rerun with --resume to retry them", flush=True)
        return 1
    return 0
