"""``tracer ablate-beta``: the beta ablation of Sec. 4.3 (figure "betatest").

Render the mesh's vertices, edges and triangles at every beta, and record the wall time and
the isosurface error along each ray against the exact (beta = 0) render, relative to the
bounding-box diagonal. The parameters (:func:`surface_parameters`): the paper's bunny, or any
mesh with ``--paper-parameters``, is rendered with the paper's alpha 200, alpha_U 1200 and the
authors' camera; any other mesh with its own automatic parameters per type, as ``tracer
render`` picks them (``SmoothDistanceField.auto_surface``: alpha, alpha_U and the level
offset), and a camera framing the whole surface from the front (the paper's values would leave
a few pixels of a small mesh hit). ``--alpha`` / ``--alpha-u`` replace either; ``--view`` /
``--up`` frame a mesh as ``tracer render`` does. Every output names the parameters and where
they came from; the report shows the authors' errors and times only for their data and
protocol (the paper's bunny, alpha 200, alpha_U 1200, their camera).
Protocol of the authors' ``app/beta_error_test``: alpha = 200, alpha_U = 1200, beta in
{0, 0.1, ..., 1}, camera at the bbox centre + 2 x the largest extent along +z looking at the centre
(up +y); the error over the pixels that both renders hit is ``mean |t_beta - t_0|`` with its
population standard deviation.

The study as independent tasks:

* :func:`list_tasks`: one task per (type, beta, tol), a small dict of render parameters (mesh
  path, type, beta, tol, size, alpha, alpha_u, offset, eps);
* :func:`render_task`: renders one task (the field is built once per process,
  :func:`tracer.studies.common.cached_field`) and returns its statistics with the depth buffer
  and a PNG of the render;
* :func:`reduce`: the error of every row against its type's beta = 0 depth buffer, then
  ``beta_ablation.csv``, the plots, the image grid, the heat maps of the per-pixel depth
  difference to beta = 0 (``beta_diff.png``, with its colour bar) and ``report.md``.

``tol`` is the renderer's tolerance-controlled pruning (the scene key ``tol``; 0 = off); tasks
with ``tol > 0`` are listed when ``--tols`` asks for them, at beta 0 unless ``--tol-betas``
says otherwise. ``beta_frontier.png`` and the report's frontier table set each beta's render
against the tol renders: the fastest one with an error no larger and a time no longer, if
any (:func:`tracer.studies.plots.frontier`).
"""

import io
import json
import os
import time
from pathlib import Path
from types import SimpleNamespace

import numba
import numpy as np

from tracer import runner
from tracer.errors import CLIError
from tracer.outputs import check_size, float_list, output_folder, positive, write_bytes, write_json
from tracer.rendering import renderer
from tracer.runner import duration
from tracer.scenes.scene import scene_from_field
from tracer.studies.common import (TYPES, add_common, add_view_arguments, beta_tag,
                                   cached_field, close, is_paper_bunny, load_mesh_checked,
                                   parse_types, render_orientation, resolve_view, study_needs,
                                   view_camera, view_name)
from tracer.studies.plots import beta_outputs

HELP = "the paper's beta ablation: time and error vs beta"

BETA_CSV = "beta_ablation.csv"
BETA_PARAMS = "beta_params.json"
BETA_FIELDS = ["type", "beta", "tol", "seconds", "hits", "mean_steps", "mean_leaves",
               "error_rel_diag", "error_std_rel_diag", "n_both", "error_abs", "error_std_abs",
               "leaves_per_eval", "hit_fraction", "alpha", "alpha_u", "offset", "parameters",
               "width", "height", "eps", "diag", "n_primitives", "threads", "key"]
#: the paper's parameters of the study (Sec. 4.3, the authors' ``beta_error_test``): alpha and
#: alpha_U in 1 / scene units, chosen for the bunny's scale
PAPER_ALPHA = 200.0
PAPER_ALPHA_U = 1200.0
#: columns that depend on the machine, its load or the scheduler, not on the study's results
TIMING_FIELDS = ("seconds", "threads", "task_seconds", "worker")
#: fewest pixels hit by both a render and its beta = 0 reference for an error to be reported,
#: in number and as a share of the image: below either the error is undefined (NaN,
#: "undefined" in the plots), not a figure (a user's mesh at the paper's alpha left 4 of 16,384
#: pixels hit, shown as "err 0.00 %")
MIN_ERROR_PIXELS = 10
#: the share of the image's pixels below which the error is undefined (see above)
MIN_ERROR_SHARE = 0.005
#: the probe renders at size // PROBE_DIV (at least 8 px) to estimate the study's cost
PROBE_DIV = 16
#: a coarse probe spends more time per pixel than the full-size render (more sphere-tracing
#: steps per pixel, a fixed cost per render, few tiles to share between threads): its
#: per-pixel time is divided by (size / probe size) ** PROBE_BIAS_EXP. Calibrated on the bunny
#: (alpha 200, alpha_U 1200, 2 threads): at 64² the 8x8 probes of the beta = 0 renders took
#: 1.7-1.9 x the full renders' time per pixel, about 8 ** 0.25; the beta = 0 renders' steps per
#: pixel fall from 5.4 at 8² to 4.3 at 32², 3.5 at 64² and 2.8 at 128².
PROBE_BIAS_EXP = 0.25


def default_output(size):
    return os.path.join("renders", "ablation", f"beta-{size}")


def add_arguments(p):
    """Arguments of ``tracer ablate-beta``."""
    p.add_argument("mesh", help="data mesh file (the paper uses the Stanford bunny, "
                   "scenes/data/bunny.off)")
    p.add_argument("-o", "--output", metavar="DIR",
                   help="result folder (created; holds beta_ablation.csv, plots, report.md); "
                   "default renders/ablation/beta-<size>")
    p.add_argument("--alpha", type=float,
                   help="alpha of every type (default: the mesh's own automatic alpha per type, "
                   "as tracer render picks it; the paper's 200 for the paper's bunny or with "
                   "--paper-parameters)")
    p.add_argument("--alpha-u", type=float,
                   help="alpha_U for weight attenuation (default: the mesh's automatic alpha_U "
                   "per type; the paper's 1200 for the paper's bunny or with "
                   "--paper-parameters)")
    p.add_argument("--paper-parameters", action="store_true",
                   help="render any mesh with the paper's alpha 200, alpha_U 1200 and the "
                   "authors' camera (the default for the paper's bunny only; on a small mesh "
                   "few pixels may be hit, and their errors are then undefined)")
    p.add_argument("--betas", default="0,0.1,0.2,0.3,0.4,0.5,0.6,0.7,0.8,0.9,1.0",
                   help="comma-separated betas (default 0,0.1,...,1.0); 0, the reference, "
                   "is always rendered")
    p.add_argument("--tols", default="0",
                   help="comma-separated tolerances for tolerance-controlled pruning (default "
                   "0: off; e.g. 1e-3,1e-2,0.1,1); each tol > 0 is rendered at the betas of "
                   "--tol-betas, and beta_frontier.png sets the tol series against the beta "
                   "series (error against time)")
    p.add_argument("--tol-betas", default="0",
                   help="betas at which each tol > 0 is rendered (default 0: the tol series "
                   "of the frontier; 'all': every beta of --betas)")
    p.add_argument("--size", type=int, default=256,
                   help="image width = height in pixels (default 256, the size of the "
                   "reference timings; the paper's figure uses 512)")
    p.add_argument("--types", default="points,edges,triangles",
                   help="data types to study (default points,edges,triangles)")
    p.add_argument("--eps", type=float, help="hit threshold in scene units (default 1e-4 x "
                   "the bbox diagonal; the authors' code uses 1e-3)")
    p.add_argument("--grid-betas", default="0,0.2,0.5,1.0",
                   help="betas shown in the image grid (default 0,0.2,0.5,1.0; those not "
                   "measured are skipped)")
    p.add_argument("--depth-cache", metavar="DIR",
                   help="where the depth buffers (depth_<type>_beta<b>.npy) and the full-size "
                   "renders are kept (default: DIR/cache)")
    add_view_arguments(p, "front, framing the whole surface, for a mesh of your own; the "
                       "authors' camera (bbox centre + 2 x the largest extent along +z, looking "
                       "at the centre, up +y) for the paper's bunny or with --paper-parameters")
    p.add_argument("--note", help="a line of text for report.md (e.g. the machine's load)")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--overwrite", action="store_true",
                   help="start afresh, replacing the folder's earlier results")
    g.add_argument("--resume", action="store_true",
                   help="keep the rows already in the CSV and render the rest; plots and "
                   "report are then rebuilt")
    runner.add_arguments(p)
    add_common(p)


# =============================================================================== tasks
def task_key(kind, beta, tol):
    return f"{kind}|beta={beta:g}|tol={tol:g}"


def file_stem(kind, beta, tol):
    """``edges_beta0.5`` (``_tol<t>`` appended when tol > 0)."""
    return f"{kind}_beta{beta_tag(beta)}" + (f"_tol{beta_tag(tol)}" if tol else "")


def list_tasks(mesh, types, betas, tols, *, size, alpha=None, alpha_u=None, eps,
               tol_betas=(0.0,), camera=None, surfaces=None):
    """One task per (type, beta, tol): a dict of render parameters and its ``key``. ``tol``
    0 is rendered at every beta, each ``tol > 0`` at the betas ``tol_betas`` (None: every
    beta). The reference (beta 0, tol 0) of every type is always included. ``camera``:
    ``(origin, dest, up)`` shared by every render, or None for the authors' camera.
    ``surfaces``: per type, ``alpha``, ``alpha_u`` (1 / scene units), ``offset`` (scene units)
    and ``parameters`` (where they came from), as :func:`surface_parameters` returns them;
    without it every type has ``alpha``, ``alpha_u``, offset 0 and "given"."""
    betas = sorted(set(betas) | {0.0})
    tols = sorted(set(tols) | {0.0})
    tol_betas = betas if tol_betas is None else sorted(set(tol_betas))
    mesh = os.path.abspath(mesh)
    if surfaces is None:
        surfaces = {k: {"alpha": alpha, "alpha_u": alpha_u, "offset": 0.0,
                        "parameters": "given"} for k in types}
    return [{"key": task_key(k, b, t), "mesh": mesh, "type": k, "beta": float(b),
             "tol": float(t), "size": int(size), "alpha": float(surfaces[k]["alpha"]),
             "alpha_u": float(surfaces[k]["alpha_u"]),
             "offset": float(surfaces[k].get("offset", 0.0)),
             "parameters": surfaces[k].get("parameters", "given"),
             "eps": None if eps is None else float(eps), "camera": camera}
            for k in types for t in tols for b in (tol_betas if t else betas)]


def surface_parameters(mesh, types, alpha=None, alpha_u=None, paper=False):
    """Per type, the study's ``{"alpha", "alpha_u"}`` (1 / scene units), ``"offset"`` (the
    level ``d_hat = offset``, scene units) and ``"parameters"``, where they came from:

    * ``paper``: the paper's ``PAPER_ALPHA`` and ``PAPER_ALPHA_U``, offset 0 ("paper");
    * else the mesh's own automatic ones, as ``tracer render`` picks them ("auto"): with
      neither ``alpha`` nor ``alpha_u`` given, ``SmoothDistanceField.auto_surface`` (points:
      ``auto_alpha``, ``auto_alpha_u``, offset 0; edges and triangles: the level about one
      edge length out); else ``auto_alpha`` / ``auto_alpha_u(alpha)`` for the one not given,
      offset 0.

    A given ``alpha`` or ``alpha_u`` is used as given ("given"); a mix reads e.g. "alpha
    given, alpha_U auto"."""
    out = {}
    src = "paper" if paper else "auto"
    for kind in types:
        if paper:
            a = PAPER_ALPHA if alpha is None else alpha
            u = PAPER_ALPHA_U if alpha_u is None else alpha_u
            off = 0.0
        else:
            field = cached_field(os.path.abspath(mesh), kind)
            if alpha is None and alpha_u is None:
                a, u, off = field.auto_surface()
            else:
                a = field.auto_alpha() if alpha is None else alpha
                u = field.auto_alpha_u(a) if alpha_u is None else alpha_u
                off = 0.0
        a_from = "given" if alpha is not None else src
        u_from = "given" if alpha_u is not None else src
        out[kind] = {"alpha": float(a), "alpha_u": float(u), "offset": float(off),
                     "parameters": a_from if a_from == u_from
                     else f"alpha {a_from}, alpha_U {u_from}"}
    return out


def describe_surfaces(surfaces, paper_bunny=False):
    """One line naming the parameters of every type and where they came from (1 / scene units;
    the offset in scene units), e.g. ``the mesh's auto parameters: points alpha 3.86, alpha_U
    77.3; triangles alpha 26.4, alpha_U 26.4, offset 0.227``."""
    src = "; ".join(sorted({s["parameters"] for s in surfaces.values()}))
    head = {"auto": "the mesh's auto parameters (as tracer render picks them)",
            "paper": "the paper's parameters" + ("" if paper_bunny else
                                                 " (--paper-parameters: chosen for the "
                                                 "bunny's scale, not this mesh's)"),
            "given": "the given parameters"}.get(src, src)
    parts = [f"{k} alpha {s['alpha']:.4g}, alpha_U {s['alpha_u']:.4g}"
             + (f", offset {s['offset']:.3g}" if s.get("offset") else "")
             for k, s in surfaces.items()]
    return f"{head}: " + "; ".join(parts)


_WARM = set()


def _scene(field, task, size=None):
    size = size or task["size"]
    return scene_from_field(field, alpha=task["alpha"], alpha_u=task["alpha_u"],
                            beta=task["beta"], camera=task.get("camera"), width=size,
                            height=size, eps=task["eps"], offset=task.get("offset") or None,
                            tol=task.get("tol", 0.0), name=f"{task['type']}-beta{task['beta']:g}")


def _render(scene, task, progress=None):
    return renderer.render(scene, progress=progress)


def render_task(task, progress=None):
    """Render one task; returns its record: the render's statistics, ``depth`` (float32
    ``(size, size)``, NaN on misses) and ``png`` (the shaded render, PNG bytes)."""
    from PIL import Image  # Pillow (tracer extra): loaded on use

    field = cached_field(task["mesh"], task["type"])
    if (task["mesh"], task["type"]) not in _WARM:  # load or compile the kernels, untimed
        _render(_scene(field, dict(task, beta=1.0), 8), task)
        _WARM.add((task["mesh"], task["type"]))
    scene = _scene(field, task)
    res = _render(scene, task, progress)
    s = res.summary()
    lo, hi = field.bounds
    buf = io.BytesIO()
    Image.fromarray(res.rgb).save(buf, format="PNG")
    return {"type": task["type"], "beta": task["beta"], "tol": task["tol"],
            "seconds": float(res.seconds), "hits": s["hits"], "mean_steps": s["mean_steps"],
            "mean_leaves": s["mean_leaves"],
            "leaves_per_eval": float(res.leaves.sum() / max(res.steps.sum(), 1)),
            "hit_fraction": s["hit_fraction"], "alpha": task["alpha"],
            "alpha_u": task["alpha_u"], "offset": task.get("offset", 0.0),
            "parameters": task.get("parameters", "given"), "width": task["size"],
            "height": task["size"],
            "eps": float(scene.eps), "diag": float(np.linalg.norm(hi - lo)),
            "n_primitives": field.num_primitives, "threads": int(numba.get_num_threads()),
            "depth": res.depth.astype(np.float32), "png": buf.getvalue()}


def probe(tasks, probe_size):
    """Estimated seconds of each task in this process: the task rendered at ``probe_size``
    pixels, timed, and scaled by the pixel count and the probe's bias
    (:data:`PROBE_BIAS_EXP`; the kernels are warmed up first)."""
    est = []
    for task in tasks:
        field = cached_field(task["mesh"], task["type"])
        if (task["mesh"], task["type"]) not in _WARM:
            _render(_scene(field, dict(task, beta=1.0), 8), task)
            _WARM.add((task["mesh"], task["type"]))
        t0 = time.perf_counter()
        _render(_scene(field, task, probe_size), task)
        ratio = task["size"] / probe_size
        est.append((time.perf_counter() - t0) * ratio ** (2 - PROBE_BIAS_EXP))
    return est


# =============================================================================== reducer
def typed_row(r):
    """A CSV row (strings) with its numbers parsed."""
    out = dict(r)
    for k in ("beta", "tol", "seconds", "mean_steps", "mean_leaves", "error_rel_diag",
              "error_std_rel_diag", "error_abs", "error_std_abs", "leaves_per_eval",
              "hit_fraction", "alpha", "alpha_u", "offset", "eps", "diag", "task_seconds"):
        try:
            out[k] = float(r.get(k) or "nan")
        except (TypeError, ValueError):
            out[k] = float("nan")
    for k in ("tol", "offset"):  # absent from files written before these columns
        if not out[k] == out[k]:
            out[k] = 0.0
    for k in ("hits", "n_both", "width", "height", "n_primitives", "threads"):
        try:
            out[k] = int(float(r.get(k) or 0))
        except (TypeError, ValueError):
            out[k] = 0
    return out


def with_errors(rows, cache):
    """``rows`` with the error columns computed from the depth buffers in ``cache``: each row
    against the beta = 0, tol = 0 render of its type, over the pixels both hit (NaN, i.e.
    undefined, over fewer than :data:`MIN_ERROR_PIXELS` or :data:`MIN_ERROR_SHARE` of the
    image)."""
    refs = {}
    out = []
    for r in rows:
        r = dict(r)
        k = r["type"]
        if k not in refs:
            p = cache / f"depth_{file_stem(k, 0.0, 0.0)}.npy"
            refs[k] = np.load(p).astype(np.float64) if p.exists() else None
        p = cache / f"depth_{file_stem(k, r['beta'], r['tol'])}.npy"
        ref = refs[k]
        err = std = float("nan")
        n_both = 0
        if ref is not None and p.exists():
            depth = np.load(p).astype(np.float64)
            if depth.shape == ref.shape:
                both = np.isfinite(depth) & np.isfinite(ref)
                n_both = int(both.sum())
                if n_both >= max(MIN_ERROR_PIXELS, MIN_ERROR_SHARE * depth.size):
                    e = np.abs(depth[both] - ref[both])
                    err, std = float(e.mean()), float(e.std())
        diag = r["diag"]
        r.update(error_abs=err, error_std_abs=std, error_rel_diag=err / diag,
                 error_std_rel_diag=std / diag, n_both=n_both)
        out.append(r)
    return out


def reduce(out, cache, log, params, types, grid_betas):
    """Rewrite the CSV (sorted, errors filled in) and write the plots and report; returns the
    finished rows (dicts with numbers)."""
    rows = log.read()
    ok = [typed_row(r) for r in rows if r["status"] == "ok"]
    ok = with_errors(ok, cache)
    ok.sort(key=lambda r: (TYPES.index(r["type"]), r["tol"], r["beta"]))
    failed = [r for r in rows if r["status"] != "ok"]
    log.start(ok + failed)
    if ok:
        beta_outputs(out, cache, ok, params, types, grid_betas)
    return ok


# =============================================================================== command
def needs(args):
    """The optional packages of the study (:func:`tracer.studies.common.study_needs`)."""
    return study_needs(args, [args.mesh])


def run(args):
    """Run the beta ablation; returns the exit status (1 when a task failed)."""
    sched, workers = runner.check_arguments(args)
    alpha = None if args.alpha is None else positive(args.alpha, "--alpha")
    alpha_u = None if args.alpha_u is None else positive(args.alpha_u, "--alpha-u")
    betas = float_list(args.betas, "--betas", non_negative=True)
    tols = float_list(args.tols, "--tols", non_negative=True)
    tol_betas = (None if args.tol_betas.strip().lower() == "all"
                 else float_list(args.tol_betas, "--tol-betas", non_negative=True))
    grid_betas = float_list(args.grid_betas, "--grid-betas", non_negative=True)
    types = parse_types(args.types)
    size = check_size(args.size, minimum=8)
    if args.eps is not None:
        positive(args.eps, "--eps")
    out = output_folder(args.output or default_output(size))
    cache = Path(args.depth_cache) if args.depth_cache else out / "cache"
    csv_path = out / BETA_CSV
    products = [csv_path, out / BETA_PARAMS, out / "beta_time.png", out / "beta_error.png",
                out / "beta_frontier.png", out / "beta_grid.png", out / "beta_diff.png",
                out / "report.md"]
    existing = [p for p in products if p.exists()]
    if existing and not (args.overwrite or args.resume):
        raise CLIError(f"{out} already holds beta-ablation results ({existing[0].name}); pass "
                       "--resume to continue them or --overwrite to replace them")
    params, surfaces, camera = _study_params(args, types, size, alpha, alpha_u, cache)
    log = runner.TaskLog(csv_path, BETA_FIELDS)
    rows = _resumed_rows(args, log, out, csv_path, params, camera, surfaces, size)
    out.mkdir(parents=True, exist_ok=True)
    cache.mkdir(parents=True, exist_ok=True)
    write_json(out / BETA_PARAMS, params)
    # a finished task counts only while its depth buffer is still in the cache
    done = {r["key"] for r in rows if r["status"] == "ok" and (
        cache / f"depth_{file_stem(r['type'], float(r['beta']), float(r.get('tol') or 0))}.npy"
    ).exists()}
    rows = [r for r in rows if r["key"] in done]
    log.start(rows)
    tasks = list_tasks(args.mesh, types, betas, tols, size=size, eps=args.eps,
                       tol_betas=tol_betas, camera=camera, surfaces=surfaces)
    todo = [t for t in tasks if t["key"] not in done]
    label = f"ablate-beta {params['mesh_name']}"
    say = (lambda s: None) if args.quiet else (lambda s: print(s, flush=True))
    say(f"parameters: {params['parameters']}; betas "
        f"{', '.join(f'{b:g}' for b in sorted(set(betas) | {0.0}))}; camera: "
        f"{params['camera'].split(' (origin')[0]}")
    if done:
        say(f"resuming: {len(done)} row(s) already in {csv_path}, {len(todo)} render(s) to go")
    estimate = _estimate(todo, size, sched, workers, say)

    def on_result(task, record):
        stem = file_stem(task["type"], task["beta"], task["tol"])
        np.save(cache / f".depth_{stem}.tmp.npy", record.pop("depth"), allow_pickle=False)
        os.replace(cache / f".depth_{stem}.tmp.npy", cache / f"depth_{stem}.npy")
        write_bytes(cache / f"render_{stem}.png", record.pop("png"))
        log.append(dict(record, key=task["key"]))

    def on_failure(task, err):
        log.append({"key": task["key"], "type": task["type"], "beta": task["beta"],
                    "tol": task["tol"], "status": "failed", "error": err})

    def line(task, r):
        return (f"{r['type']:9s} beta {r['beta']:<4g}"
                + (f" tol {r['tol']:g}" if r["tol"] else "")
                + f" {r['seconds']:8.2f} s  {r['hits']:7d} hits  {r['mean_leaves']:10.0f} "
                f"leaves/px")

    info = runner.run_study(render_task, todo, on_result=on_result, on_failure=on_failure,
                            scheduler=sched, workers=workers, estimate=estimate, label=label,
                            quiet=args.quiet, line=line)
    ok = reduce(out, cache, log, params, types, grid_betas)
    say(f"Beta ablation of {params['mesh_name']} at {params['parameters']}: {len(ok)} rows "
        f"in {csv_path} ({len(todo)} render(s) {info.describe()}, {duration(info.seconds)}); "
        f"wrote beta_time.png, beta_error.png, beta_frontier.png, beta_grid.png"
        + (", beta_diff.png" if (out / "beta_diff.png").exists() else "")
        + f" and report.md in {out}.")
    for line_ in few_hits_warnings(ok):
        print(f"warning: {line_}", flush=True)
    if info.failed:
        print(f"warning: {len(info.failed)} render(s) failed (see the 'error' column of "
              f"{csv_path}); rerun with --resume to retry them", flush=True)
        return 1
    return 0


def _study_params(args, types, size, alpha, alpha_u, cache):
    """``(params, surfaces, camera)`` of the study: its description for ``beta_params.json``
    and the reports, the parameters of every type (:func:`surface_parameters`: the paper's for
    its bunny or with ``--paper-parameters``, else the mesh's auto ones, ``--alpha`` and
    ``--alpha-u`` as given) and the shared camera (None: the authors'; a mesh of the user's own
    is framed from the front unless ``--view`` says otherwise)."""
    mesh_all = load_mesh_checked(args.mesh)
    for kind in types:  # fail early on a type the mesh cannot provide
        if kind != "points":
            load_mesh_checked(args.mesh, kind)
    diag = float(np.linalg.norm(np.subtract(*mesh_all.bounds[::-1])))
    eps_abs = args.eps if args.eps is not None else 1e-4 * diag
    bunny = is_paper_bunny(args.mesh)
    # the paper's alpha, alpha_U and camera for its bunny (or when asked); any other mesh
    # gets its own automatic parameters and a camera framing it
    paper = bunny or args.paper_parameters
    surfaces = surface_parameters(args.mesh, types, alpha, alpha_u, paper=paper)
    view, up = resolve_view(args, args.mesh)
    framed = "--view" if view else None
    if not view and not paper:
        view, up, why = render_orientation(args.mesh, mesh_all)
        framed = f"as tracer render orients a mesh of your own: {why}"
    camera = None
    if view:  # one camera for every type: the largest surface of them all in view
        fields = [cached_field(os.path.abspath(args.mesh), k) for k in types]
        grow = max(f.inflation(surfaces[k]["alpha"], surfaces[k]["alpha_u"])
                   + surfaces[k]["offset"] for f, k in zip(fields, types)) + 2.0 * eps_abs
        camera = view_camera(fields, view, up, grow, size)
    # the authors' beta_error_test numbers hold for their bunny, alpha, alpha_U and camera
    reference = bunny and camera is None and all(
        close(v["alpha"], PAPER_ALPHA) and close(v["alpha_u"], PAPER_ALPHA_U)
        and not v["offset"] for v in surfaces.values())
    params = {"mesh": str(args.mesh), "mesh_name": os.path.basename(args.mesh),
              "alpha": _common(surfaces, "alpha"), "alpha_u": _common(surfaces, "alpha_u"),
              "surfaces": surfaces, "parameters": describe_surfaces(surfaces, bunny),
              "paper_parameters": bool(paper),
              "width": size, "height": size, "eps": eps_abs,
              "eps_rule": "given" if args.eps is not None else "1e-4 x bbox diagonal",
              "diag": diag, "camera": "bbox centre + 2 x largest extent along +z, looking at "
              "the centre, up +y (authors' beta_error_test)" if camera is None else
              f"{view_name(view)} view, up {up} ({framed}): the whole surface in view, as tracer "
              f"render frames it (origin {_vec(camera[0])}, looking at {_vec(camera[1])}, up "
              f"{_vec(camera[2])})",
              "view": view_name(view), "up": up, "camera_vectors": camera,
              "authors_reference": reference,
              "reference_rule": "the authors' errors and times are shown for the paper's bunny "
              "at alpha 200, alpha_U 1200 and their camera only" + (
                  "" if reference else (" (this mesh is not the bunny)" if not bunny else
                                        " (this study changes alpha, alpha_U or the camera)")),
              "depth_cache": str(cache), "note": args.note or ""}
    return params, surfaces, camera


def _resumed_rows(args, log, out, csv_path, params, camera, surfaces, size):
    """The rows of an earlier run to resume (``--resume``), checked against this run's
    settings: the same alpha, alpha_U and offset per type (``surfaces``), size, camera and
    mesh (a one-line error otherwise); the earlier note is kept unless a new one is given."""
    if not (args.resume and csv_path.exists()):
        return []
    rows = log.read(["type", "beta", "alpha", "alpha_u", "width"])
    for r in rows:
        s = surfaces.get(r["type"])
        if r["status"] == "ok" and s is not None and not (
                close(r["alpha"], s["alpha"]) and close(r["alpha_u"], s["alpha_u"])
                and close(r.get("offset") or 0.0, s["offset"]) and int(r["width"]) == size):
            raise CLIError(f"{csv_path} was measured with alpha {r['alpha']}, alpha_u "
                           f"{r['alpha_u']}, offset {r.get('offset') or 0}, size {r['width']} "
                           f"for {r['type']}, not {params['parameters']}; rerun with those "
                           "values or use --overwrite")
    old = out / BETA_PARAMS
    if old.exists():
        try:
            prev = json.loads(old.read_text(encoding="utf-8"))
        except ValueError:
            prev = {}
        if prev.get("camera_vectors", camera) != camera:
            raise CLIError(f"{out} was rendered with another camera ({prev.get('camera')}); "
                           "rerun with the same --view / --up or use --overwrite")
        if prev.get("mesh_name") not in (None, params["mesh_name"]):
            raise CLIError(f"{out} holds results for {prev.get('mesh_name')}, not "
                           f"{params['mesh_name']}; use another folder or --overwrite")
        if not args.note and prev.get("note"):
            params["note"] = prev["note"]
    return rows


def _vec(v):
    return "(" + ", ".join(f"{x:.4g}" for x in v) + ")"


def _common(surfaces, key):
    """``surfaces``' value of ``key`` when every type has the same one, else None."""
    values = [s[key] for s in surfaces.values()]
    return values[0] if all(close(v, values[0]) for v in values) else None


def few_hits_warnings(rows):
    """A line per type whose beta = 0 render hit too few pixels to measure an error
    (:data:`MIN_ERROR_PIXELS`, :data:`MIN_ERROR_SHARE`): its errors are undefined."""
    out = []
    for r in rows:
        if r["beta"] == 0.0 and not r.get("tol", 0.0):
            n = r["width"] * r["height"]
            if r["hits"] < max(MIN_ERROR_PIXELS, MIN_ERROR_SHARE * n):
                out.append(f"{r['type']} at beta 0 hit {r['hits']} of {n} pixels (alpha "
                           f"{r['alpha']:.4g}, {r.get('parameters') or 'given'}): its errors are "
                           "undefined; the mesh's auto parameters (no --alpha, no "
                           "--paper-parameters) or --view frame a surface that fills the image")
    return out


def _estimate(todo, size, sched, workers, say):
    """Probe the tasks at a coarse size (:func:`probe`: ``size // PROBE_DIV``, at least 8 px),
    set their weights, print the estimate (at every size); returns the estimated serial
    seconds, from which ``--scheduler local`` decides whether to start a cluster."""
    if not todo:
        return 0.0

    p = max(8, size // PROBE_DIV)
    t0 = time.perf_counter()
    est = probe(todo, p)
    for t, e in zip(todo, est):
        t["weight"] = e
    total = sum(est)
    mode = runner.choose_mode(sched, workers, len(todo), total)
    threads = int(numba.get_num_threads())
    if mode == "serial":
        wall, where = total, f"in-process with {threads} thread(s)"
    else:
        w = workers or (runner.cpu_count() if mode == "local" else None)
        # one thread per worker: a task takes ~threads x its in-process time
        wall = max(max(est) * threads, total * threads / w) if w else None
        where = f"on {w} worker(s)" if w else f"on the cluster at {mode}"
    slow = [(t, e) for t, e in zip(todo, est) if t["beta"] == 0.0]
    parts = ", ".join(f"{t['type']} {duration(e)}" for t, e in slow)
    say(f"estimate (from {p}x{p} probe renders, {time.perf_counter() - t0:.1f} s): "
        + (f"beta = 0 renders {duration(sum(e for _, e in slow))} ({parts}); " if slow else "")
        + f"all {len(todo)} renders {duration(total)} of work in-process"
        + (f", about {duration(wall)} wall time {where}" if wall is not None else f" ({where})"))
    return total
