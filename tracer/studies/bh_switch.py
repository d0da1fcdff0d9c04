"""``tracer bh-switch CLOUD``: the Barnes-Hut near/far switch study of Sec. 4.3 (authors'
``app/barnes_hut_smoothness_test``).

Rays are marched along z onto the zero set of a point cloud normalised to a unit bbox diagonal;
past the first hit a short segment is sampled, and wherever the number of BVH leaves visited
changes from one sample to the next (a near/far switch of the Barnes-Hut rule), ``d_hat`` and
its gradient are compared with an evaluation at ``beta + dbeta``.

As independent tasks: :func:`list_tasks` (the rays, drawn from the seed, in chunks),
:func:`rays_task` (marches and samples one chunk; the normalised field is built once per
process) and :func:`reduce` (CSV, JSON summary, histograms). Rays are independent, so the
rows do not depend on the chunking or on where the chunks run.
"""

import functools
import os

import numpy as np

from smoothdist import DataMesh, SmoothDistanceField
from tracer import runner
from tracer.errors import CLIError
from tracer.outputs import at_least, non_negative, output_folder, positive, write_csv, write_json
from tracer.runner import duration, file_stamp
from tracer.studies.common import REPO, add_common, load_mesh_checked, machine_info, study_needs
from tracer.studies.plots import PAPER_BH, bh_plot

HELP = "Barnes-Hut near/far switch discontinuity study"

BH_FIELDS = ["trial", "sample", "x", "y", "z", "leaves", "d_hat", "dz_d_hat", "leaves_dbeta",
             "d_hat_dbeta", "discrepancy", "discrepancy_orig_units", "cosine", "kept"]
#: rays per task
CHUNK = 100
DEFAULT_CLOUD = REPO / "scenes" / "data" / "pointclouds" / "lidar_autzen_trim.ply"


def add_arguments(p):
    """Arguments of ``tracer bh-switch``."""
    p.add_argument("cloud", nargs="?", default=None,
                   help="point cloud (or mesh: its vertices are used); default "
                   "scenes/data/pointclouds/lidar_autzen_trim.ply")
    p.add_argument("-o", "--output", metavar="OUT",
                   help="result folder: bh_switch.csv, bh_switch.json, bh_switch.png (default "
                   "renders/ablation/bh-switch)")
    p.add_argument("--alpha", type=float, default=100.0,
                   help="alpha in 1/(normalised units), i.e. per unit bbox diagonal (default 100)")
    p.add_argument("--beta", type=float, default=0.5, help="Barnes-Hut beta (default 0.5)")
    p.add_argument("--dbeta", type=float, default=1e-4,
                   help="beta increment of the comparison evaluation (default 1e-4)")
    p.add_argument("--trials", type=int, default=500, help="number of rays (default 500)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--iso", type=float, default=0.01,
                   help="stop marching once d_hat <= iso, as a fraction of the bbox diagonal "
                   "(default 0.01 = 1/alpha at alpha 100; the authors use 0.1 in their city "
                   "scan's units, which on a unit diagonal lies above the whole inflated "
                   "surface, so that no ray would march at all)")
    p.add_argument("--start", type=float, default=0.01,
                   help="rays start this far (fraction of the diagonal; default 0.01, the "
                   "authors' value) outside the top or bottom of the bbox grown by the largest "
                   "inflation log(N)/alpha")
    p.add_argument("--segment", type=float, default=0.005,
                   help="length of the sampled segment (fraction of the diagonal; 0.005)")
    p.add_argument("--samples", type=int, default=101,
                   help="samples along the segment (default 101)")
    p.add_argument("--max-steps", type=int, default=20, help="march steps per ray (default 20)")
    p.add_argument("--overwrite", action="store_true", help="replace earlier results")
    runner.add_arguments(p)
    add_common(p)


@functools.lru_cache(maxsize=2)
def _normalised(stamp):
    """``(field, scale)``: the cloud's points translated to the bbox min corner and divided by
    the bbox diagonal ``scale`` (built once per process)."""
    mesh = load_mesh_checked(stamp[0], "points")
    V = mesh.V[mesh.points]
    lo0, hi0 = V.min(axis=0), V.max(axis=0)
    scale = float(np.linalg.norm(hi0 - lo0))
    if scale == 0:
        raise CLIError(f"{stamp[0]}: all points coincide")
    Vn = (V - lo0) / scale  # unit bbox diagonal, min corner at the origin
    return SmoothDistanceField(DataMesh(Vn, name=os.path.basename(stamp[0]))), scale


def normalised_field(path):
    return _normalised(file_stamp(path))


def list_tasks(path, *, trials, seed, alpha, beta, dbeta, iso, start, segment, samples,
               max_steps, chunk=CHUNK):
    """The rays (drawn from ``seed`` over the normalised bbox, half from above, half from
    below, starting ``start`` beyond the bbox grown by the inflation), in tasks of ``chunk``."""
    field, _ = normalised_field(path)
    lo, hi = field.bounds
    rng = np.random.default_rng(seed)
    x = rng.uniform(lo[0], hi[0], trials)
    y = rng.uniform(lo[1], hi[1], trials)
    top = rng.random(trials) < 0.5
    # the zero set can lie up to log(N)/alpha outside the data (inflation): start beyond it
    grow = field.inflation(alpha)
    z = np.where(top, hi[2] + grow + start, lo[2] - grow - start)
    dz = np.where(top, -1.0, 1.0)
    common = {"cloud": os.path.abspath(path), "alpha": float(alpha), "beta": float(beta),
              "dbeta": float(dbeta), "iso": float(iso), "segment": float(segment),
              "samples": int(samples), "max_steps": int(max_steps)}
    tasks = []
    for i0 in range(0, trials, chunk):
        i1 = min(trials, i0 + chunk)
        tasks.append(dict(common, key=f"rays-{i0}-{i1 - 1}", first=i0, x=x[i0:i1].tolist(),
                          y=y[i0:i1].tolist(), z=z[i0:i1].tolist(), dz=dz[i0:i1].tolist(),
                          weight=float(i1 - i0)))
    return tasks, grow


def rays_task(task):
    """March and sample one chunk of rays; returns ``{"rows": switch rows, "hits": int,
    "steps": [march steps per ray]}`` (``trial`` is the ray's index in the whole study)."""
    field, scale = normalised_field(task["cloud"])
    alpha, beta = task["alpha"], task["beta"]
    x, y, z, dz = (np.array(task[k], dtype=np.float64) for k in ("x", "y", "z", "dz"))
    T = x.size
    # 1. march each ray along z with steps d_hat until d_hat <= iso (hit), d_hat grows (miss)
    #    or max_steps steps were taken
    active = np.ones(T, bool)
    hit = np.zeros(T, bool)
    prev = np.full(T, np.inf)
    steps = np.zeros(T, np.int64)
    for _ in range(task["max_steps"] + 1):
        idx = np.flatnonzero(active)
        if idx.size == 0:
            break
        d, _ = field.smooth_distance(np.stack([x[idx], y[idx], z[idx]], axis=1), alpha=alpha,
                                     beta=beta)
        reached = d <= task["iso"]
        hit[idx[reached]] = True
        grew = ~reached & (d > prev[idx])
        stop = reached | grew | (steps[idx] >= task["max_steps"])
        go = idx[~stop]
        z[go] += dz[go] * d[~stop]
        prev[go] = d[~stop]
        steps[go] += 1
        active[idx[stop]] = False
    # 2. sample the further segment; 3. compare at every change of leaves visited
    hits = np.flatnonzero(hit)
    K = task["samples"]
    frac = np.arange(K) / (K - 1)
    rows = []
    if hits.size:
        Z = z[hits, None] + dz[hits, None] * task["segment"] * frac[None, :]
        Q = np.stack([np.repeat(x[hits], K), np.repeat(y[hits], K), Z.ravel()], axis=1)
        d, g, st = field.smooth_distance(Q, alpha=alpha, beta=beta, gradient="metric",
                                         return_stats=True)
        lv = st.leaves_visited.reshape(hits.size, K)
        sw = np.zeros((hits.size, K), bool)
        sw[:, 1:] = lv[:, 1:] != lv[:, :-1]
        flat = np.flatnonzero(sw.ravel())
        if flat.size:
            d2, g2, st2 = field.smooth_distance(Q[flat], alpha=alpha, beta=beta + task["dbeta"],
                                                gradient="metric", return_stats=True)
            g1 = g[flat]
            n1 = np.linalg.norm(g1, axis=1)
            n2 = np.linalg.norm(g2, axis=1)
            cos = np.einsum("ij,ij->i", g1, g2) / np.maximum(n1 * n2, 1e-300)
            for j, fi in enumerate(flat):
                ti, k = divmod(int(fi), K)
                disc = abs(float(d[fi] - d2[j]))
                rows.append({"trial": task["first"] + int(hits[ti]), "sample": k,
                             "x": float(Q[fi, 0]), "y": float(Q[fi, 1]), "z": float(Q[fi, 2]),
                             "leaves": int(st.leaves_visited[fi]), "d_hat": float(d[fi]),
                             "dz_d_hat": float(g[fi, 2]),
                             "leaves_dbeta": int(st2.leaves_visited[j]),
                             "d_hat_dbeta": float(d2[j]), "discrepancy": disc,
                             "discrepancy_orig_units": disc * scale, "cosine": float(cos[j]),
                             "kept": int(st2.leaves_visited[j] < st.leaves_visited[fi])})
    return {"rows": rows, "hits": int(hits.size), "steps": steps.tolist()}


def _stats(rs, scale):
    if not rs:
        return {"count": 0, "mean_discrepancy": None, "max_discrepancy": None,
                "mean_cosine": None, "min_cosine": None}
    dd = np.array([r["discrepancy"] for r in rs])
    cc = np.array([r["cosine"] for r in rs])
    return {"count": len(rs), "mean_discrepancy": float(dd.mean()),
            "max_discrepancy": float(dd.max()), "median_discrepancy": float(np.median(dd)),
            "mean_cosine": float(cc.mean()), "min_cosine": float(cc.min()),
            "mean_discrepancy_orig_units": float(dd.mean() * scale),
            "max_discrepancy_orig_units": float(dd.max() * scale)}


def reduce(out, records, summary, scale):
    """CSV (rows sorted by ray and sample), JSON summary and plot; returns the summary."""
    rows = sorted((r for rec in records for r in rec["rows"]),
                  key=lambda r: (r["trial"], r["sample"]))
    steps = [s for rec in records for s in rec["steps"]]
    kept = [r for r in rows if r["kept"]]
    hits = sum(rec["hits"] for rec in records)
    summary = dict(summary, hits=hits, samples_total=hits * summary["samples"],
                   march_steps_mean=float(np.mean(steps)) if steps else 0.0,
                   switch_points=len(rows), kept=_stats(kept, scale),
                   all_switches=_stats(rows, scale), paper=PAPER_BH,
                   paper_note="paper: city LiDAR scan, 259 kept points (beta + 1e-4 visits "
                   "fewer leaves), in that scan's units")
    out.mkdir(parents=True, exist_ok=True)
    write_csv(out / "bh_switch.csv", BH_FIELDS, rows)
    write_json(out / "bh_switch.json", summary)
    bh_plot(out / "bh_switch.png", rows, summary)
    return summary


def needs(args):
    """The optional packages of the study (:func:`tracer.studies.common.study_needs`; the
    default cloud is a PLY file, read by trimesh)."""
    return study_needs(args, [args.cloud or str(DEFAULT_CLOUD)])


def run(args):
    """Run the Barnes-Hut switch study; returns the exit status."""
    sched, workers = runner.check_arguments(args)
    src = args.cloud or str(DEFAULT_CLOUD)
    alpha = positive(args.alpha, "--alpha")
    for name in ("iso", "start", "segment", "dbeta"):
        positive(getattr(args, name), f"--{name}")
    beta = non_negative(args.beta, "--beta")
    at_least(args.trials, "--trials")
    at_least(args.samples, "--samples", 2)
    at_least(args.max_steps, "--max-steps")
    out = output_folder(args.output or os.path.join("renders", "ablation", "bh-switch"))
    products = [out / "bh_switch.csv", out / "bh_switch.json", out / "bh_switch.png"]
    for p in products:
        if p.exists() and not args.overwrite:
            raise CLIError(f"{p} exists (pass --overwrite to replace it)")
    load_mesh_checked(src, "points")  # one-line errors for a missing or broken file
    field, scale = normalised_field(src)
    n_points = field.num_primitives
    tasks, grow = list_tasks(src, trials=args.trials, seed=args.seed, alpha=alpha, beta=beta,
                             dbeta=args.dbeta, iso=args.iso, start=args.start,
                             segment=args.segment, samples=args.samples,
                             max_steps=args.max_steps)
    records = []
    info = runner.run_study(rays_task, tasks, on_result=lambda t, r: records.append(r),
                            scheduler=sched, workers=workers, estimate=0.005 * args.trials,
                            label="bh-switch", quiet=args.quiet)
    if info.failed:
        raise CLIError(f"bh-switch: {len(info.failed)} chunk(s) of rays failed: "
                       f"{info.failed[0][1]}")
    summary = {"cloud": src, "points": n_points, "normalisation":
               "translated to the bbox min corner and divided by the bbox diagonal (unit "
               "diagonal), so that alpha = 100 means 1/alpha = 1% of the diagonal; discrepancies "
               "are in these units (x scale for the cloud's own units)",
               "scale": scale, "alpha": alpha, "alpha_orig_units": alpha / scale, "beta": beta,
               "dbeta": args.dbeta, "iso": args.iso, "start": args.start,
               "start_rule": "rays start `start` beyond the bbox grown by the inflation "
               "log(N)/alpha (the authors start 0.01 beyond the bbox itself)",
               "inflation": grow, "segment": args.segment, "samples": args.samples,
               "max_steps": args.max_steps, "trials": args.trials, "seed": args.seed,
               "seconds": round(info.seconds, 3), "scheduler": info.describe(),
               "threads": machine_info()["numba_threads"] if info.mode == "serial" else 1}
    summary = reduce(out, records, summary, scale)
    if not args.quiet:
        k = summary["kept"]
        T, hits, n = args.trials, summary["hits"], summary["switch_points"]
        if k["count"]:
            print(f"Barnes-Hut switches: {hits}/{T} rays reached d_hat <= {args.iso:g}; "
                  f"{n} switch points, {k['count']} where beta+{args.dbeta:g} visits "
                  f"fewer leaves: mean |d_hat diff| {k['mean_discrepancy']:.3g}, max "
                  f"{k['max_discrepancy']:.3g} (unit diagonal), min cosine "
                  f"{k['min_cosine']:.6f} (paper: {PAPER_BH['kept_points']} points, mean "
                  f"{PAPER_BH['mean_discrepancy']:.2g}, max {PAPER_BH['max_discrepancy']:.2g}, min "
                  f"cosine {PAPER_BH['min_cosine']}). Wrote {out} ({duration(info.seconds)}).")
        else:
            print(f"Barnes-Hut switches: {hits}/{T} rays reached d_hat <= {args.iso:g}; "
                  f"{n} switch points, none kept. Wrote {out}.")
    return 0
