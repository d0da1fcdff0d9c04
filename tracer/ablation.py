"""The paper's parameter studies as sub-commands (Madan & Levin 2022, Sec. 3.3-3.4, 4.3, 4.4).

* ``tracer ablate-beta MESH -o DIR``: the beta ablation of Sec. 4.3 (figure "betatest"): render
  the mesh's vertices, edges and triangles with the authors' camera at every beta, and record
  the wall time and the isosurface error along each ray against the exact (beta = 0) render,
  relative to the bounding-box diagonal. Protocol of the authors' ``app/beta_error_test``:
  alpha = 200, alpha_U = 1200, beta in {0, 0.1, ..., 1}, camera at the bbox centre + 2 x the
  largest extent along +z looking at the centre (up +y); the error over the pixels that both
  renders hit is ``mean |t_beta - t_0|`` with its population standard deviation.
* ``tracer ablate-alpha STUDY -o DIR``: the alpha figures of Sec. 3 as labelled image grids:
  ``underestimate`` (nested isosurfaces at increasing alpha), ``exact-smooth`` (smooth vs exact
  offset surfaces), ``weights`` (weight functions on/off), ``metric`` (alpha-metric weight
  gradient on/off) and ``attenuate`` (alpha_U attenuation on/off); ``all`` runs them all.
* ``tracer bench-grid [DIR] -o OUT``: the Thingi10K benchmark of Sec. 4.4 (authors'
  ``app/benchmark_cpu``): V, E and F of every mesh normalised to a bbox centred at
  (0.5, 0.5, 0.5) with diagonal 0.5, queried at the ``N^3`` voxel centres of the unit cube with
  alpha = alpha_U = 1 and beta = 0.5 (the authors' code uses alpha = 1; the paper gives none).
* ``tracer bh-switch CLOUD -o OUT``: the Barnes-Hut near/far switch study of Sec. 4.3
  (authors' ``app/barnes_hut_smoothness_test``).

"Weights off" (figure ``weights``, and the unweighted column of ``attenuate``) is realised by
:func:`unweighted_field`: a copy of a field whose primitive table has the raw weight polynomial
``A w~`` replaced by the constant 1 (``wc[:, 0] = 1``, other coefficients 0, per-primitive clamp
``pwhi = 1``) and whose node weight bounds ``whi`` are 1, so that the Barnes-Hut far field and
the tracer's inflation margin use the unweighted bound as well. Every term then has ``W = 1``,
exactly the naive LogSumExp of Eq. 2 applied to exact primitive distances.

Every command writes through temporary files (``tracer.image.atomic_write``), refuses to
replace earlier results without ``--overwrite``, and, where a study is long, records each row as
soon as it is measured so that an interruption (Ctrl-C) keeps the completed rows and
``--resume`` carries on from them. matplotlib (Agg) is imported only inside the functions that
plot.
"""

import copy
import csv
import io
import json
import math
import os
import platform
import sys
import time
import warnings
from pathlib import Path

import numpy as np

from tracer.cli import CLIError

#: repository root (``tracer/..``)
REPO = Path(__file__).resolve().parents[1]
#: the paper's three data-mesh types, in its order
TYPES = ("points", "edges", "triangles")
#: colours of the paper's beta figure: vertices green, edges orange, triangles purple
TYPE_COLORS = {"points": "#2ca02c", "edges": "#ff7f0e", "triangles": "#8e44ad"}
TYPE_LETTER = {"points": "v", "edges": "e", "triangles": "f"}

#: reference numbers of the beta study (bunny, alpha 200, alpha_U 1200), measured with the
#: authors' code at 256 x 256 on 2 cores: seconds and error in % of the bbox diagonal for
#: points / edges / triangles
PAPER_BETA = {
    0.0: {"seconds": (150.0, 670.0, 699.0), "error_pct": (0.0, 0.0, 0.0)},
    0.5: {"seconds": (3.8, 6.6, 7.6), "error_pct": (2.5, 3.7, 3.4)},
    1.0: {"seconds": (0.84, 1.14, 1.25), "error_pct": (4.9, 6.5, 6.0)},
}
PAPER_BETA_SETUP = "authors' code, 256 x 256 px, 2 cores"

#: the paper's Barnes-Hut switch numbers on its city LiDAR scan (Sec. 4.3)
PAPER_BH = {"kept_points": 259, "mean_discrepancy": 7.6e-5, "max_discrepancy": 6.6e-3,
            "mean_cosine": 1.0, "min_cosine": 0.9974}

BETA_CSV = "beta_ablation.csv"
BETA_PARAMS = "beta_params.json"
BETA_FIELDS = ["type", "beta", "seconds", "hits", "mean_steps", "mean_leaves",
               "error_rel_diag", "error_std_rel_diag", "n_both", "error_abs", "error_std_abs",
               "leaves_per_eval", "hit_fraction", "alpha", "alpha_u", "width", "height", "eps",
               "diag", "n_primitives", "threads"]
BENCH_FIELDS = ["name", "nV", "leaves_v", "seconds_v", "nE", "leaves_e", "seconds_e", "nF",
                "leaves_f", "seconds_f"]
BH_FIELDS = ["trial", "sample", "x", "y", "z", "leaves", "d_hat", "dz_d_hat", "leaves_dbeta",
             "d_hat_dbeta", "discrepancy", "discrepancy_orig_units", "cosine", "kept"]


# =============================================================================== helpers
def _float_list(text, name, *, non_negative=False, positive=False):
    """Parse ``"0,0.1,0.5"`` into a list of floats (one-line errors)."""
    vals = []
    for part in str(text).split(","):
        part = part.strip()
        if not part:
            continue
        try:
            v = float(part)
        except ValueError:
            raise CLIError(f"{name}: {part!r} is not a number") from None
        if not math.isfinite(v):
            raise CLIError(f"{name}: {part!r} is not finite")
        if non_negative and v < 0:
            raise CLIError(f"{name}: values must be >= 0, got {v:g}")
        if positive and v <= 0:
            raise CLIError(f"{name}: values must be > 0, got {v:g}")
        vals.append(v)
    if not vals:
        raise CLIError(f"{name}: give at least one value (comma separated)")
    return vals


def _types(text):
    out = []
    for part in str(text).split(","):
        part = part.strip()
        if not part:
            continue
        part = {"faces": "triangles", "vertices": "points", "v": "points", "e": "edges",
                "f": "triangles"}.get(part, part)
        if part not in TYPES:
            raise CLIError(f"--types: unknown type {part!r} (choose from {', '.join(TYPES)})")
        if part not in out:
            out.append(part)
    if not out:
        raise CLIError("--types: give at least one of points, edges, triangles")
    return out


def _positive(value, name):
    if not (math.isfinite(value) and value > 0):
        raise CLIError(f"{name} must be a finite number > 0, got {value:g}")
    return value


def _check_size(size):
    if not 8 <= size <= 8192:
        raise CLIError(f"--size must be between 8 and 8192 pixels, got {size}")
    return size


def _load(path, kind=None):
    """Load a mesh file as a DataMesh (``kind`` as in ``DataMesh.as_kind``), one-line errors."""
    from smoothdist import DataMesh, MeshRepairWarning

    path = os.fspath(path)
    if not os.path.exists(path):
        raise CLIError(f"mesh file not found: {path}")
    if os.path.isdir(path):
        raise CLIError(f"mesh path is a folder, not a file: {path}")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", MeshRepairWarning)
            mesh = DataMesh.load(path)
            return mesh.as_kind(kind) if kind is not None else mesh
    except (ValueError, OSError) as exc:
        msg = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise CLIError(f"cannot use {path}: {msg}") from None


def _field(mesh):
    from smoothdist import SmoothDistanceField

    return SmoothDistanceField(mesh)


def unweighted_field(field):
    """A shallow copy of ``field`` whose every primitive has weight 1 ("weights off").

    The raw weight polynomial ``A w~`` of edges and triangles becomes the constant 1
    (``wc[:, 0] = 1``, all other coefficients 0; see ``smoothdist.bvh.TreeData`` and
    ``smoothdist.query.primitive_term``), the per-primitive clamp ``pwhi`` and the node bounds
    ``whi`` become 1 (so that the Barnes-Hut far field ``count * whi**S`` and the tracer's
    inflation margin ``log(A**S N) / alpha`` use the unweighted bound), and ``A`` becomes 1.
    Point clouds are unchanged (their weight is already 1).
    """
    t = field.tree
    wc = np.zeros_like(t.wc)
    wc[:, 0] = 1.0
    out = copy.copy(field)
    out.tree = t._replace(wc=wc, pwhi=np.ones_like(t.pwhi), whi=np.ones_like(t.whi), A=1.0)
    return out


def _fmt(v, digits=4):
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return ""
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    return f"{float(v):.{digits}g}"


def _write_csv(path, fields, rows):
    """Atomically (re)write a whole CSV file."""
    from tracer.image import atomic_write

    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=fields, extrasaction="ignore", lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({k: (_fmt(v, 8) if isinstance(v, float) else v) for k, v in r.items()})
    with atomic_write(path) as tmp:
        with open(tmp, "w", encoding="utf-8", newline="") as fh:
            fh.write(buf.getvalue())
            fh.flush()
            os.fsync(fh.fileno())


def _read_csv(path, required):
    with open(path, "r", encoding="utf-8", newline="") as fh:
        reader = csv.DictReader(fh)
        missing = [c for c in required if c not in (reader.fieldnames or [])]
        if missing:
            raise CLIError(f"{path}: not a results file of this command (missing column(s) "
                           f"{', '.join(missing)}); use another folder or --overwrite")
        return list(reader)


def _write_json(path, data):
    from tracer.image import atomic_write

    with atomic_write(path) as tmp:
        with open(tmp, "w", encoding="utf-8") as fh:
            json.dump(data, fh, indent=2, default=_json_default)
            fh.write("\n")


def _json_default(o):
    if isinstance(o, np.integer):
        return int(o)
    if isinstance(o, np.floating):
        return float(o)
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, Path):
        return str(o)
    raise TypeError(type(o).__name__)


def _write_text(path, text):
    from tracer.image import atomic_write

    with atomic_write(path) as tmp:
        Path(tmp).write_text(text, encoding="utf-8")


def _pyplot():
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    return plt


def _savefig(fig, path, dpi=100, max_bytes=195_000):
    """Save a matplotlib figure as PNG atomically; above ``max_bytes`` the image is stored with
    an adaptive 256-colour palette (committed result images stay small)."""
    from PIL import Image

    from tracer.image import atomic_write

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    buf.seek(0)
    img = Image.open(buf).convert("RGB")
    data = io.BytesIO()
    img.save(data, format="PNG", optimize=True)
    if data.tell() > max_bytes:
        data = io.BytesIO()
        img.quantize(colors=256, method=Image.Quantize.MEDIANCUT,
                     dither=Image.Dither.FLOYDSTEINBERG).save(data, format="PNG", optimize=True)
    with atomic_write(path) as tmp:
        Path(tmp).write_bytes(data.getvalue())


def _thumb(rgb, size):
    """Downsample an ``(H, W, 3)`` uint8 image so its longer side is at most ``size``."""
    from PIL import Image

    H, W = rgb.shape[:2]
    if max(H, W) <= size:
        return rgb
    s = size / max(H, W)
    img = Image.fromarray(rgb).resize((max(1, round(W * s)), max(1, round(H * s))),
                                      Image.LANCZOS)
    return np.asarray(img)


def _machine():
    import numba

    return {"platform": platform.platform(), "processor": platform.processor() or "",
            "cpu_count": os.cpu_count(), "numba_threads": int(numba.get_num_threads()),
            "python": platform.python_version(), "numba": numba.__version__,
            "load_average": [round(x, 2) for x in os.getloadavg()]
            if hasattr(os, "getloadavg") else None}


def _beta_tag(beta):
    return f"{beta:g}".replace("-", "m")


def _close(a, b, rel=1e-9):
    return abs(float(a) - float(b)) <= rel * max(1.0, abs(float(a)), abs(float(b)))


class StudyProgress:
    """A progress bar with an ETA over a whole study of weighted work items.

    Each item (a render, a mesh) has an a-priori weight; ``item(w)`` returns a callback that
    the item reports its own progress to (``done, total, elapsed`` like
    :class:`tracer.render.ProgressBar`), and ``finish(w, line)`` marks it done and logs a line.
    On a terminal the bar redraws in place; in a log it prints one line per finished item.
    """

    def __init__(self, label, total_weight, stream=None, quiet=False):
        self.label = label
        self.total = max(float(total_weight), 1e-12)
        self.done = 0.0
        self.t0 = time.perf_counter()
        self.stream = stream or sys.stderr
        self.quiet = quiet
        self.tty = getattr(self.stream, "isatty", lambda: False)()
        self._last = 0.0

    def _text(self, frac):
        elapsed = time.perf_counter() - self.t0
        eta = elapsed * (1 - frac) / frac if frac > 1e-9 else float("nan")
        bar = "#" * int(30 * min(frac, 1.0))
        eta_s = "?" if not math.isfinite(eta) else _duration(eta)
        return (f"{self.label} [{bar:<30}] {100 * min(frac, 1.0):5.1f}% "
                f"{_duration(elapsed)} elapsed, ~{eta_s} left")

    def _draw(self, frac, force=False):
        if self.quiet or not self.tty:
            return
        now = time.perf_counter()
        if not force and now - self._last < 0.2:
            return
        self._last = now
        self.stream.write("\r\033[K" + self._text(frac))
        self.stream.flush()

    def item(self, weight):
        def cb(done, total, elapsed):
            self._draw((self.done + weight * done / max(total, 1)) / self.total)
        return cb

    def finish(self, weight, line=""):
        self.done += weight
        if self.quiet:
            return
        frac = self.done / self.total
        if self.tty:
            self.stream.write("\r\033[K")
            if line:
                self.stream.write(line + "\n")
            self._draw(frac, force=True)
            if frac >= 1 - 1e-9:
                self.stream.write("\n")
        else:
            self.stream.write((line + "  " if line else "") + "| " + self._text(frac) + "\n")
        self.stream.flush()

    def log(self, line):
        if self.quiet:
            return
        if self.tty:
            self.stream.write("\r\033[K" + line + "\n")
            self._draw(self.done / self.total, force=True)
        else:
            self.stream.write(line + "\n")
        self.stream.flush()


def _duration(s):
    if s < 90:
        return f"{s:.1f}s"
    if s < 5400:
        return f"{s / 60:.1f}min"
    return f"{s / 3600:.2f}h"


def _add_common(p):
    p.add_argument("--threads", type=int, help="number of threads (default: all cores)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar or log lines")
    return p


# =============================================================================== ablate-beta
def add_arguments_ablate_beta(p):
    """Arguments of ``tracer ablate-beta``."""
    p.add_argument("mesh", help="data mesh file (the paper uses the Stanford bunny, "
                   "scenes/data/bunny.off)")
    p.add_argument("-o", "--output", required=True, metavar="DIR",
                   help="result folder (created; holds beta_ablation.csv, plots, report.md)")
    p.add_argument("--alpha", type=float, default=200.0, help="alpha (default 200, the paper's)")
    p.add_argument("--alpha-u", type=float, default=1200.0,
                   help="alpha_U for weight attenuation (default 1200, the paper's)")
    p.add_argument("--betas", default="0,0.1,0.2,0.3,0.4,0.5,0.6,0.7,0.8,0.9,1.0",
                   help="comma-separated betas (default 0,0.1,...,1.0); 0, the reference, "
                   "is always rendered")
    p.add_argument("--size", type=int, default=512,
                   help="image width = height in pixels (default 512, the paper's)")
    p.add_argument("--types", default="points,edges,triangles",
                   help="data types to study (default points,edges,triangles)")
    p.add_argument("--eps", type=float, help="hit threshold in scene units (default 1e-4 x "
                   "the bbox diagonal; the authors' code uses 1e-3)")
    p.add_argument("--grid-betas", default="0,0.2,0.5,1.0",
                   help="betas shown in the image grid (default 0,0.2,0.5,1.0; those not "
                   "measured are skipped)")
    p.add_argument("--depth-cache", metavar="DIR",
                   help="where the beta = 0 depth buffers (depth_<type>_beta0.npy) and the "
                   "full-size renders are kept for --resume (default: the result folder)")
    p.add_argument("--note", help="a line of text for report.md (e.g. the machine's load)")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--overwrite", action="store_true",
                   help="start afresh, replacing the folder's earlier results")
    g.add_argument("--resume", action="store_true",
                   help="keep the (type, beta) rows already in the CSV and render the rest; "
                   "plots and report are then rebuilt")
    _add_common(p)


def _beta_weight(beta, kind):
    """A-priori relative cost of one render (for the ETA): beta = 0 dominates."""
    return (0.4 if kind == "points" else 1.0) / (beta + 0.05) ** 1.5


def run_ablate_beta(args):
    """Run the beta ablation; returns the exit status."""
    from tracer.image import save_npy, save_png
    from tracer.render import render
    from tracer.scene import scene_from_field

    import numba

    alpha = _positive(args.alpha, "--alpha")
    alpha_u = _positive(args.alpha_u, "--alpha-u")
    betas = sorted(set(_float_list(args.betas, "--betas", non_negative=True)) | {0.0})
    grid_betas = _float_list(args.grid_betas, "--grid-betas", non_negative=True)
    types = _types(args.types)
    size = _check_size(args.size)
    if args.eps is not None:
        _positive(args.eps, "--eps")
    out = Path(args.output)
    if out.exists() and not out.is_dir():
        raise CLIError(f"output path exists and is not a folder: {out}")
    cache = Path(args.depth_cache) if args.depth_cache else out
    csv_path = out / BETA_CSV
    products = [csv_path, out / BETA_PARAMS, out / "beta_time.png", out / "beta_error.png",
                out / "beta_grid.png", out / "report.md"]
    existing = [p for p in products if p.exists()]
    if existing and not (args.overwrite or args.resume):
        raise CLIError(f"{out} already holds beta-ablation results ({existing[0].name}); pass "
                       "--resume to continue them or --overwrite to replace them")
    mesh_all = _load(args.mesh)
    fields = {}
    for kind in types:
        mesh = _load(args.mesh, kind) if kind != "points" else mesh_all.as_kind("points")
        fields[kind] = _field(mesh)
    diag = float(np.linalg.norm(np.subtract(*mesh_all.bounds[::-1])))
    params = {"mesh": str(args.mesh), "mesh_name": os.path.basename(args.mesh),
              "alpha": alpha, "alpha_u": alpha_u, "width": size, "height": size,
              "eps": args.eps if args.eps is not None else 1e-4 * diag,
              "eps_rule": "given" if args.eps is not None else "1e-4 x bbox diagonal",
              "diag": diag, "camera": "bbox centre + 2 x largest extent along +z, looking at "
              "the centre, up +y (authors' beta_error_test)", "depth_cache": str(cache),
              "note": args.note or ""}
    rows = []
    if args.resume and csv_path.exists():
        rows = _read_csv(csv_path, ["type", "beta", "alpha", "alpha_u", "width"])
        for r in rows:
            if not (_close(r["alpha"], alpha) and _close(r["alpha_u"], alpha_u)
                    and int(r["width"]) == size):
                raise CLIError(f"{csv_path} was measured with alpha {r['alpha']}, alpha_u "
                               f"{r['alpha_u']}, size {r['width']}; rerun with those values or "
                               "use --overwrite")
        old = out / BETA_PARAMS
        if old.exists():
            try:
                prev = json.loads(old.read_text(encoding="utf-8"))
            except ValueError:
                prev = {}
            if prev.get("mesh_name") not in (None, params["mesh_name"]):
                raise CLIError(f"{out} holds results for {prev.get('mesh_name')}, not "
                               f"{params['mesh_name']}; use another folder or --overwrite")
            if not args.note and prev.get("note"):
                params["note"] = prev["note"]
        rows = [_typed_beta_row(r) for r in rows]
    out.mkdir(parents=True, exist_ok=True)
    cache.mkdir(parents=True, exist_ok=True)
    _write_json(out / BETA_PARAMS, params)
    done = {(r["type"], round(r["beta"], 9)) for r in rows}
    todo = [(k, b) for k in types for b in betas if (k, round(b, 9)) not in done]
    # a type with anything left needs its beta = 0 depth buffer: from the cache, or rendered
    need_ref = {}
    for k in sorted({k for k, _ in todo}, key=types.index):
        dpath = cache / f"depth_{k}_beta0.npy"
        ref = None
        if (k, 0.0) in done and dpath.exists():
            try:
                ref = np.load(dpath, allow_pickle=False)
            except (OSError, ValueError):
                ref = None
            if ref is not None and ref.shape != (size, size):
                ref = None
        need_ref[k] = ref
        if ref is None and (k, 0.0) not in todo:
            todo.append((k, 0.0))  # the reference is re-rendered (its row is replaced)
    todo.sort(key=lambda kb: (types.index(kb[0]), kb[1]))
    weights = {kb: _beta_weight(kb[1], kb[0]) for kb in todo}
    prog = StudyProgress(f"ablate-beta {params['mesh_name']}", sum(weights.values()),
                         quiet=args.quiet)
    if done and not args.quiet:
        prog.log(f"resuming: {len(done)} row(s) already in {csv_path}, {len(todo)} render(s) "
                 "to go")
    threads = int(numba.get_num_threads())
    if todo:  # load (or compile) the kernels outside the timed renders
        render(scene_from_field(fields[todo[0][0]], alpha=alpha, alpha_u=alpha_u, beta=1.0,
                                width=8, height=8, eps=args.eps))
    for kind, beta in todo:
        field = fields[kind]
        scene = scene_from_field(field, alpha=alpha, alpha_u=alpha_u, beta=beta, width=size,
                                 height=size, eps=args.eps, name=f"{kind}-beta{beta:g}")
        res = render(scene, progress=prog.item(weights[(kind, beta)]))
        depth = res.depth.astype(np.float64)
        if beta == 0.0:
            save_npy(cache / f"depth_{kind}_beta0.npy", res.depth)
            need_ref[kind] = res.depth
        ref = np.asarray(need_ref[kind], dtype=np.float64)
        both = np.isfinite(depth) & np.isfinite(ref) & res.hit
        n_both = int(both.sum())
        if n_both:
            e = np.abs(depth[both] - ref[both])
            err, std = float(e.mean()), float(e.std())
        else:
            err = std = float("nan")
        save_png(cache / f"render_{kind}_beta{_beta_tag(beta)}.png", res.rgb)
        s = res.summary()
        row = {"type": kind, "beta": float(beta), "seconds": float(res.seconds),
               "hits": s["hits"], "mean_steps": s["mean_steps"], "mean_leaves": s["mean_leaves"],
               "error_rel_diag": err / diag, "error_std_rel_diag": std / diag,
               "n_both": n_both, "error_abs": err, "error_std_abs": std,
               "leaves_per_eval": float(res.leaves.sum() / max(res.steps.sum(), 1)),
               "hit_fraction": s["hit_fraction"], "alpha": alpha, "alpha_u": alpha_u,
               "width": size, "height": size, "eps": float(scene.eps), "diag": diag,
               "n_primitives": field.num_primitives, "threads": threads}
        rows = [r for r in rows if not (r["type"] == kind and _close(r["beta"], beta))] + [row]
        rows.sort(key=lambda r: (TYPES.index(r["type"]), r["beta"]))
        _write_csv(csv_path, BETA_FIELDS, rows)
        prog.finish(weights[(kind, beta)],
                    f"{kind:9s} beta {beta:<4g} {res.seconds:8.2f} s  {s['hits']:7d} hits  "
                    f"{s['mean_leaves']:10.0f} leaves/px  error {100 * err / diag:.3f}% of diag")
    _beta_outputs(out, cache, rows, params, types, grid_betas)
    if not args.quiet:
        print(f"Beta ablation of {params['mesh_name']}: {len(rows)} rows in {csv_path}; wrote "
              f"beta_time.png, beta_error.png, beta_grid.png and report.md in {out}.")
    return 0


def _typed_beta_row(r):
    out = dict(r)
    for k in ("beta", "seconds", "mean_steps", "mean_leaves", "error_rel_diag",
              "error_std_rel_diag", "error_abs", "error_std_abs", "leaves_per_eval",
              "hit_fraction", "alpha", "alpha_u", "eps", "diag"):
        try:
            out[k] = float(r.get(k, "nan") or "nan")
        except ValueError:
            out[k] = float("nan")
    for k in ("hits", "n_both", "width", "height", "n_primitives", "threads"):
        try:
            out[k] = int(float(r.get(k, 0) or 0))
        except ValueError:
            out[k] = 0
    return out


def _beta_outputs(out, cache, rows, params, types, grid_betas):
    """Plots, image grid and report of the beta study from its rows."""
    plt = _pyplot()
    present = [k for k in TYPES if any(r["type"] == k for r in rows)]
    # ---- time vs beta (log y), like the paper's figure
    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    for k in present:
        rs = sorted((r for r in rows if r["type"] == k), key=lambda r: r["beta"])
        ax.plot([r["beta"] for r in rs], [max(r["seconds"], 1e-4) for r in rs], "o-",
                color=TYPE_COLORS[k], label=f"{k} (ours, {params['width']}²)")
        ref_b = sorted(PAPER_BETA)
        ax.plot(ref_b, [PAPER_BETA[b]["seconds"][TYPES.index(k)] for b in ref_b], "s--",
                color=TYPE_COLORS[k], mfc="none", alpha=0.7, label=f"{k} (reference)")
    ax.set_yscale("log")
    ax.set_xlabel("β")
    ax.set_ylabel("render time (s)")
    ax.set_title(f"{params['mesh_name']}: time vs β (α={params['alpha']:g}, "
                 f"α_U={params['alpha_u']:g})", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    _savefig(fig, out / "beta_time.png")
    plt.close(fig)
    # ---- error (% of diagonal) vs beta
    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    for k in present:
        rs = sorted((r for r in rows if r["type"] == k), key=lambda r: r["beta"])
        b = np.array([r["beta"] for r in rs])
        m = 100 * np.array([r["error_rel_diag"] for r in rs])
        sd = 100 * np.array([r["error_std_rel_diag"] for r in rs])
        ax.plot(b, m, "o-", color=TYPE_COLORS[k], label=f"{k} (ours)")
        ax.fill_between(b, np.maximum(m - sd, 0), m + sd, color=TYPE_COLORS[k], alpha=0.12)
        ref_b = sorted(PAPER_BETA)
        ax.plot(ref_b, [PAPER_BETA[x]["error_pct"][TYPES.index(k)] for x in ref_b], "s--",
                color=TYPE_COLORS[k], mfc="none", alpha=0.7, label=f"{k} (reference)")
    ax.set_xlabel("β")
    ax.set_ylabel("mean |t_β − t_0| (% of bbox diagonal)")
    ax.set_title(f"{params['mesh_name']}: isosurface error vs β (band: ±1 std)", fontsize=10)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    _savefig(fig, out / "beta_error.png")
    plt.close(fig)
    # ---- image grid: types x selected betas
    measured = sorted({r["beta"] for r in rows})
    cols = [b for b in measured if any(_close(b, g) for g in grid_betas)] or measured[:4]
    fig, axes = plt.subplots(len(present), len(cols), squeeze=False,
                             figsize=(1.9 * len(cols), 2.25 * len(present)))
    for i, k in enumerate(present):
        for j, b in enumerate(cols):
            ax = axes[i][j]
            ax.set_xticks([])
            ax.set_yticks([])
            r = next((r for r in rows if r["type"] == k and _close(r["beta"], b)), None)
            img_path = cache / f"render_{k}_beta{_beta_tag(b)}.png"
            if r is not None and img_path.exists():
                from tracer.image import load_png

                ax.imshow(_thumb(load_png(img_path), 160), interpolation="lanczos")
                ax.set_title(f"β={b:g}: {r['seconds']:.3g} s\n"
                             f"err {100 * r['error_rel_diag']:.2f}%", fontsize=7)
            else:
                ax.text(0.5, 0.5, "not available", ha="center", va="center", fontsize=7,
                        transform=ax.transAxes)
            if j == 0:
                ax.set_ylabel(k, fontsize=8)
    fig.tight_layout(pad=0.4)
    _savefig(fig, out / "beta_grid.png", dpi=100)
    plt.close(fig)
    _write_text(out / "report.md", _beta_report(rows, params, present))


def _beta_report(rows, params, present):
    m = _machine()
    lines = [f"# β ablation: {params['mesh_name']}", "",
             "Madan & Levin 2022, Sec. 4.3 (figure \"betatest\"); protocol of the authors' "
             "`app/beta_error_test`. Generated by `python -m tracer ablate-beta`.", "",
             f"- data: `{params['mesh_name']}` as vertices, edges and triangles; bbox diagonal "
             f"{params['diag']:.6g}",
             f"- α = {params['alpha']:g}, α_U = {params['alpha_u']:g}; image "
             f"{params['width']}×{params['height']} px; eps = {params['eps']:.3g} "
             f"({params['eps_rule']}; the authors' code uses 1e-3)",
             f"- camera: {params['camera']}",
             "- error: mean |t_β − t_0| over the pixels that both the β render and the β = 0 "
             "render hit, over the bbox diagonal (std: population standard deviation)",
             f"- machine: {m['platform']}, {m['cpu_count']} CPU(s), numba threads "
             f"{m['numba_threads']}; load average when this report was (re)generated "
             f"{m['load_average']}. Times are wall-clock seconds of the tracing only and "
             "depend on other load on the machine.",
             *([f"- note: {params['note']}"] if params.get("note") else []), "",
             "![time vs beta](beta_time.png)", "", "![error vs beta](beta_error.png)", "",
             "![renders](beta_grid.png)", "",
             f"## Measured vs reference ({PAPER_BETA_SETUP})", "",
             "| type | β | time (s) | ref. time (s) | speed-up vs β=0 | ref. speed-up | "
             "error (% diag) | ref. error (% diag) | error std (% diag) | hits | mean leaves/px "
             "| leaves/eval |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for k in present:
        rs = sorted((r for r in rows if r["type"] == k), key=lambda r: r["beta"])
        t0 = next((r["seconds"] for r in rs if r["beta"] == 0.0), float("nan"))
        ti = TYPES.index(k)
        for r in rs:
            ref = next((v for b, v in PAPER_BETA.items() if _close(b, r["beta"])), None)
            ref_t = ref["seconds"][ti] if ref else None
            ref_e = ref["error_pct"][ti] if ref else None
            ref_sp = PAPER_BETA[0.0]["seconds"][ti] / ref_t if ref_t else None
            lines.append(
                f"| {k} | {r['beta']:g} | {r['seconds']:.3g} | {_fmt(ref_t, 3) or '–'} | "
                f"{t0 / r['seconds']:.3g}× | {(f'{ref_sp:.3g}×' if ref_sp else '–')} | "
                f"{100 * r['error_rel_diag']:.3f} | {_fmt(ref_e, 3) or '–'} | "
                f"{100 * r['error_std_rel_diag']:.3f} | {r['hits']} | {r['mean_leaves']:.0f} | "
                f"{r['leaves_per_eval']:.1f} |")
    lines += ["", "The raw numbers are in `beta_ablation.csv`; the parameters in "
              "`beta_params.json`.", ""]
    return "\n".join(lines)


# =============================================================================== ablate-alpha
STUDIES = ("underestimate", "exact-smooth", "weights", "metric", "attenuate")

#: default data and cameras (the cameras of the matching scenes/*.json)
_LION = ("scenes/data/pointclouds/scan_guardian_lion_points.ply",
         ((0.035, -2.6, 0.07), (0.035, 0.0, 0.07), (0.0, 0.0, 1.0)))
_CAPILLARY = ("scenes/data/curves/capillary_networks.obj",
              ((0.0, 0.15, 4.2), (-0.03, 0.15, 0.0), (0.0, 1.0, 0.0)))
_OCTOPUS = ("scenes/data/meshes/octopus_low.obj",
            ((0.034, 0.049, 2.0), (0.034, 0.049, 0.082), (0.0, 1.0, 0.0)))
_TORUS = ("scenes/data/meshes/torus.obj",
          ((0.0, -3.6, 2.6), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0)))

#: per study: default alphas, and the factors of the mesh's auto alpha used with --mesh
STUDY_DEFAULTS = {
    "underestimate": {"alphas": [25.0, 50.0, 100.0, 200.0], "factors": [0.15, 0.3, 0.6, 1.2]},
    "exact-smooth": {"alphas": [25.0, 50.0, 100.0, 200.0], "factors": [0.15, 0.3, 0.6, 1.2]},
    "weights": {"alphas": [40.0, 120.0], "factors": [1.0]},
    "metric": {"alphas": [15.0, 30.0], "factors": [0.5, 1.0]},
    "attenuate": {"alphas": [20.0, 40.0], "alpha_u": 300.0, "factors": [0.15, 0.3],
                  "u_factor": 2.4},
}


def add_arguments_ablate_alpha(p):
    """Arguments of ``tracer ablate-alpha``."""
    p.add_argument("study", choices=STUDIES + ("all",),
                   help="which figure: underestimate (nested isosurfaces at increasing alpha), "
                   "exact-smooth (smooth vs exact offset), weights (on/off), metric (alpha-metric "
                   "gradient on/off), attenuate (alpha_U on/off), or all")
    p.add_argument("-o", "--output", required=True, metavar="DIR",
                   help="result folder: <study>.png, <study>.json and report.md")
    p.add_argument("--size", type=int, default=256, help="render size per panel (default 256)")
    p.add_argument("--mesh", help="use this mesh instead of the study's default data (camera: "
                   "the paper's beta-study camera, framed; alphas scaled from the mesh's auto "
                   "alpha)")
    p.add_argument("--kind", choices=TYPES,
                   help="with --mesh: primitive type to use (default: points for underestimate "
                   "and exact-smooth, triangles (else edges) for metric and attenuate)")
    p.add_argument("--alphas", help="comma-separated alphas (overrides the study's defaults; "
                   "weights: the alpha of each row)")
    p.add_argument("--alpha-u", type=float, help="attenuate: the alpha_U of the attenuated "
                   "column (default 300, the octopus scene's max_alpha)")
    p.add_argument("--beta", type=float, default=0.5, help="Barnes-Hut beta (default 0.5)")
    p.add_argument("--shading", choices=("normals", "headlight"), default="normals",
                   help="panel shading (default: normals, i.e. gradient as colour)")
    p.add_argument("--no-frame", action="store_true",
                   help="keep the study's camera as is (default: move it so that the union of "
                   "the panels' silhouettes fills the frame)")
    p.add_argument("--overwrite", action="store_true", help="replace earlier results of a study")
    _add_common(p)


def run_ablate_alpha(args):
    """Run one alpha study (or all); returns the exit status."""
    size = _check_size(args.size)
    if not (math.isfinite(args.beta) and args.beta >= 0):
        raise CLIError(f"--beta must be >= 0, got {args.beta:g}")
    if args.alpha_u is not None:
        _positive(args.alpha_u, "--alpha-u")
    alphas = _float_list(args.alphas, "--alphas", positive=True) if args.alphas else None
    studies = list(STUDIES) if args.study == "all" else [args.study]
    out = Path(args.output)
    if out.exists() and not out.is_dir():
        raise CLIError(f"output path exists and is not a folder: {out}")
    for s in studies:
        for ext in (".png", ".json"):
            p = out / f"{_slug(s)}{ext}"
            if p.exists() and not args.overwrite:
                raise CLIError(f"{p} exists (pass --overwrite to replace it)")
    if args.mesh:
        _load(args.mesh)  # validate early
    out.mkdir(parents=True, exist_ok=True)
    prog = StudyProgress(f"ablate-alpha {args.study}", len(studies), quiet=args.quiet)
    for s in studies:
        t0 = time.perf_counter()
        panels, info = _STUDY_FUNCS[s](args, size, alphas, prog)
        info.update(study=s, size=size, beta=args.beta, seconds=round(time.perf_counter() - t0, 2),
                    image=f"{_slug(s)}.png")
        _panel_grid(out / f"{_slug(s)}.png", panels, info["title"])
        _write_json(out / f"{_slug(s)}.json", info)
        _write_text(out / "report.md", _alpha_report(out))
        prog.finish(1, f"{s}: {len(panels)}x{max(len(r) for r in panels)} panels in "
                    f"{info['seconds']:.1f} s -> {out / (_slug(s) + '.png')}")
    if not args.quiet:
        print(f"Wrote {', '.join(_slug(s) + '.png' for s in studies)}, their JSON and "
              f"report.md in {out}.")
    return 0


def _slug(study):
    return study.replace("-", "_")


def _study_data(args, default, kind_default):
    """``(source, DataMesh of the kind, camera or None, from_override)``.

    With ``--mesh``, ``kind_default == "triangles"`` falls back to edges, then points, when the
    mesh has no triangles.
    """
    if args.mesh:
        kind = args.kind or kind_default
        if kind_default == "triangles" and not args.kind:
            m = _load(args.mesh)
            kind = "triangles" if len(m.triangles) else ("edges" if len(m.edges) else "points")
        return args.mesh, _load(args.mesh, kind), None, True
    return default[0], _load(REPO / default[0], kind_default), default[1], False


def _alphas_for(study, alphas, field, override):
    if alphas:
        return sorted(alphas)
    d = STUDY_DEFAULTS[study]
    if override:
        a0 = field.auto_alpha()
        return [float(f"{a0 * f:.4g}") for f in d["factors"]]
    return list(d["alphas"])


def _default_camera(field):
    """The paper's beta-study camera for ``field`` (as ``scene_from_field`` builds it)."""
    lo, hi = field.bounds
    c = 0.5 * (lo + hi)
    return (c + np.array([0.0, 0.0, 2.0 * float((hi - lo).max())]), c, np.array([0.0, 1, 0]))


def _scene(field, *, camera, size, alpha, alpha_u=None, beta, mode="smooth", shading="normals",
           gradient="metric", offset=None):
    from tracer.scene import scene_from_field

    return scene_from_field(field, alpha=alpha, alpha_u=alpha_u, beta=beta, camera=camera,
                            width=size, height=size, mode=mode, shading=shading,
                            gradient=gradient, offset=offset)


def _frame_camera(specs, camera, fill=0.86, probe=48):
    """Move ``camera`` (pan and dolly, same orientation) so that the union of the silhouettes
    of ``specs`` (``(field, scene kwargs)``, probed at ``probe`` px) fills ``fill`` of the
    frame. Never moves it back; returns the original camera when nothing is hit."""
    from tracer.render import RenderError, render

    union = np.zeros((probe, probe), bool)
    for field, kw in specs:
        try:
            union |= render(_scene(field, camera=camera, size=probe, **kw)).hit
        except RenderError:
            return camera
    if not union.any():
        return camera
    rows, cols = np.nonzero(union)
    # the authors' image-plane coordinates (see tracer.camera): dx = col/W - 1/2,
    # dy = (H - 1 - row)/H - 1/2, at unit distance along `forward`
    dx0, dx1 = cols.min() / probe - 0.5, (cols.max() + 1) / probe - 0.5
    dy0, dy1 = (probe - 1 - rows.max()) / probe - 0.5, (probe - rows.min()) / probe - 0.5
    half = 0.5 * max(dx1 - dx0, dy1 - dy0) + 1.0 / probe
    k = half / (0.5 * fill)
    if k >= 1.0:
        return camera
    o, d, up = (np.asarray(v, float) for v in camera)
    f = d - o
    dist = float(np.linalg.norm(f))
    f /= dist
    h = np.cross(f, up)
    h /= np.linalg.norm(h)
    v = np.cross(h, f)
    shift = (0.5 * (dx0 + dx1) * h + 0.5 * (dy0 + dy1) * v) * dist
    d2 = d + shift
    return (d2 - f * dist * k, d2, up)


def _render_group(specs, camera, size, prog, frame=True):
    """Render ``specs`` (``(field, scene kwargs)``) with one shared, optionally framed camera."""
    from tracer.render import RenderError, render

    cam = _frame_camera(specs, camera, probe=min(48, size)) if frame else camera
    out = []
    for field, kw in specs:
        try:
            out.append(render(_scene(field, camera=cam, size=size, **kw),
                              progress=prog.item(0.0)))
        except RenderError as exc:
            if cam is camera:
                raise CLIError(f"alpha {kw.get('alpha'):g}: {exc}") from None
            return _render_group(specs, camera, size, prog, frame=False)
    return out, [np.asarray(c, float).round(6).tolist() for c in cam]


def _study_underestimate(args, size, alphas, prog):
    src, mesh, camera, override = _study_data(args, _LION, args.kind or "points")
    field = _field(mesh)
    camera = camera or _default_camera(field)
    alphas = _alphas_for("underestimate", alphas, field, override)
    specs = [(field, dict(alpha=a, beta=args.beta, shading=args.shading)) for a in alphas]
    res, cam = _render_group(specs, camera, size, prog, frame=not args.no_frame)
    row = [(f"α = {a:g}  ({r.seconds:.1f} s)", r.rgb) for a, r in zip(alphas, res)]
    # nesting on a slice through the data, perpendicular to the view direction
    slice_img, nest = _nesting_slice(field, alphas, args.beta, camera, size,
                                     n=min(160, max(32, size)))
    row.append(("zero sets on a slice (α ↑ = darker → lighter)", slice_img))
    info = {"title": f"Underestimate / nesting: {os.path.basename(src)} ({field.num_primitives} "
            f"{mesh.kind}), β={args.beta:g}", "data": src, "kind": mesh.kind, "alphas": alphas,
            "camera": cam, "shading": args.shading,
            "renders": [{"alpha": a, **r.summary()} for a, r in zip(alphas, res)],
            "nesting": nest, "paper_figure": "underestimate",
            "note": "higher-alpha isosurfaces lie inside lower-alpha ones (LogSumExp with unit "
            "weights is non-decreasing in alpha); 'nesting.violations' counts slice samples "
            "where a higher alpha is inside (d_hat <= 0) but a lower alpha is not"}
    return [row], info


def _view_frame(field, camera):
    lo, hi = field.bounds
    c = 0.5 * (lo + hi)
    o, d, up = (np.asarray(v, float) for v in camera)
    f = d - o
    f /= np.linalg.norm(f)
    h = np.cross(f, up)
    h /= np.linalg.norm(h)
    v = np.cross(h, f)
    return c, f, h, v


def _nesting_slice(field, alphas, beta, camera, size, n=160, exact_n=32):
    """Zero sets of ``d_hat`` for each alpha on the plane through the bbox centre facing the
    camera, as an RGB image, and the nesting check over the ``n x n`` plane samples (at
    ``beta``, and exactly, at beta = 0, on an ``exact_n x exact_n`` subset)."""
    plt = _pyplot()
    c, f, h, v = _view_frame(field, camera)
    lo, hi = field.bounds
    diag = float(np.linalg.norm(hi - lo))
    pts = field.mesh.used_vertices()
    half = 0.5 * diag * 0.8
    u = np.linspace(-half, half, n)
    U, Vv = np.meshgrid(u, u)
    Q = c + U.reshape(-1, 1) * h + Vv.reshape(-1, 1) * v
    def violations(Db):
        bad = 0
        for i in range(len(alphas)):
            for j in range(i + 1, len(alphas)):
                bad += int(np.sum((Db[j] <= 0) & (Db[i] > 0)))
        return bad

    D = [field.smooth_distance(Q, alpha=a, beta=beta)[0].reshape(n, n) for a in alphas]
    check = {f"violations_beta_{beta:g}": violations(D)}
    if beta > 0:
        # the exact sum costs N terms per sample: check it on every `step`-th sample only
        step = max(1, n // exact_n)
        Qs = Q.reshape(n, n, 3)[::step, ::step].reshape(-1, 3)
        check["exact_check_samples"] = int(Qs.shape[0])
        check["violations_beta_0"] = violations(
            [field.smooth_distance(Qs, alpha=a, beta=0.0)[0] for a in alphas])
    fig, ax = plt.subplots(figsize=(size / 100, size / 100), dpi=100)
    slab = np.abs((pts - c) @ f) < 0.01 * diag
    P = pts[slab] - c
    ax.plot(P @ h, P @ v, ",", color="0.35")
    cmap = plt.get_cmap("viridis")
    for i, a in enumerate(alphas):
        ax.contour(U, Vv, D[i], levels=[0.0], colors=[cmap(i / max(len(alphas) - 1, 1))],
                   linewidths=1.0)
    ax.set_xlim(-half, half)
    ax.set_ylim(-half, half)
    ax.set_aspect("equal")
    ax.axis("off")
    fig.subplots_adjust(0, 0, 1, 1)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    plt.close(fig)
    from PIL import Image

    buf.seek(0)
    img = np.asarray(Image.open(buf).convert("RGB"))
    return img, {"slice_samples": n * n, "alpha_pairs": len(alphas) * (len(alphas) - 1) // 2,
                 **check, "plane": "through the bbox centre, perpendicular to the view "
                 "direction; points within 1% of the diagonal of it are drawn grey"}


def _study_exact_smooth(args, size, alphas, prog):
    src, mesh, camera, override = _study_data(args, _LION, args.kind or "points")
    field = _field(mesh)
    camera = camera or _default_camera(field)
    alphas = _alphas_for("exact-smooth", alphas, field, override)
    specs = []
    for a in alphas:
        specs.append((field, dict(alpha=a, beta=args.beta, mode="exact", offset=1.0 / a,
                                  shading=args.shading)))
    for a in alphas:
        specs.append((field, dict(alpha=a, beta=args.beta, shading=args.shading)))
    res, cam = _render_group(specs, camera, size, prog, frame=not args.no_frame)
    n = len(alphas)
    exact_row = [(f"exact, offset 1/α = {1 / a:.3g}", r.rgb) for a, r in zip(alphas, res[:n])]
    smooth_row = [(f"smooth, α = {a:g}", r.rgb) for a, r in zip(alphas, res[n:])]
    stats = [{"alpha": a, "exact": re.summary(), "smooth": rs.summary()}
             for a, re, rs in zip(alphas, res[:n], res[n:])]
    info = {"title": f"Exact offset (top) vs smooth distance (bottom): {os.path.basename(src)}, "
            f"β={args.beta:g}", "data": src, "kind": mesh.kind, "alphas": alphas,
            "camera": cam, "shading": args.shading, "renders": stats,
            "paper_figure": "exact_smooth"}
    return [exact_row, smooth_row], info


def _study_weights(args, size, alphas, prog):
    if args.mesh:
        m = _load(args.mesh)
        cases = []
        if len(m.edges) or len(m.triangles):
            cases.append(("edges", args.mesh, m.as_kind("edges"), None))
        if len(m.triangles):
            cases.append(("triangles", args.mesh, m.as_kind("triangles"), None))
        if not cases:
            raise CLIError(f"weights: {args.mesh} has no edges or triangles (weights only "
                           "exist for edges and triangles)")
    else:
        cases = [("edges", _CAPILLARY[0], _load(REPO / _CAPILLARY[0], "edges"), _CAPILLARY[1]),
                 ("triangles", _OCTOPUS[0], _load(REPO / _OCTOPUS[0], "triangles"),
                  _OCTOPUS[1])]
    default = STUDY_DEFAULTS["weights"]["alphas"]
    rows, stats = [], []
    for i, (kind, src, mesh, camera) in enumerate(cases):
        field = _field(mesh)
        camera = camera or _default_camera(field)
        if alphas:
            a = alphas[min(i, len(alphas) - 1)]
        elif args.mesh:
            a = float(f"{field.auto_alpha() * STUDY_DEFAULTS['weights']['factors'][0]:.4g}")
        else:
            a = default[i]
        kw = dict(alpha=a, beta=args.beta, shading=args.shading)
        (off, on), cam = _render_group([(unweighted_field(field), kw), (field, kw)], camera,
                                       size, prog, frame=not args.no_frame)
        rows.append([(f"{kind}, weights off (α={a:g})", off.rgb),
                     (f"{kind}, weights on (A={field.weight_bound:.3g})", on.rgb)])
        stats.append({"kind": kind, "data": src, "alpha": a, "alpha_u": a, "S": 1.0,
                      "A": field.weight_bound, "camera": cam, "off": off.summary(),
                      "on": on.summary()})
    info = {"title": f"Weight functions off (left) / on (right), α_U = α (S = 1), "
            f"β={args.beta:g}", "cases": stats, "shading": args.shading,
            "paper_figure": "weights",
            "weights_off": "unweighted_field(): raw weight A w~ forced to the constant 1 "
            "(wc[:,0]=1, other coefficients 0, pwhi=1, node whi=1, A=1)"}
    return rows, info


def _study_metric(args, size, alphas, prog):
    src, mesh, camera, override = _study_data(args, _TORUS, "triangles")
    field = _field(mesh)
    camera = camera or _default_camera(field)
    alphas = _alphas_for("metric", alphas, field, override)
    specs = []
    for a in alphas:
        for g in ("exact", "metric"):
            specs.append((field, dict(alpha=a, alpha_u=a, beta=args.beta, shading=args.shading,
                                      gradient=g)))
    res, cam = _render_group(specs, camera, size, prog, frame=not args.no_frame)
    rows, stats = [], []
    for i, a in enumerate(alphas):
        ex, me = res[2 * i], res[2 * i + 1]
        rows.append([(f"metric off: exact ∇d̂ (α={a:g})", ex.rgb),
                     (f"metric on: α-metric gradient (α={a:g})", me.rgb)])
        stats.append({"alpha": a, "exact": ex.summary(), "metric": me.summary()})
    info = {"title": f"α-metric weight gradient off (left) / on (right): "
            f"{os.path.basename(src)}, α_U = α, β={args.beta:g}", "data": src, "kind": mesh.kind,
            "alphas": alphas, "camera": cam, "shading": args.shading, "renders": stats,
            "paper_figure": "metric",
            "note": "same isosurface; only the gradient used for shading differs: the weight "
            "gradient is scaled by 1/alpha (exact derivative of d_hat) or 1/alpha^2 (the "
            "paper's alpha-metric)"}
    return rows, info


def _study_attenuate(args, size, alphas, prog):
    src, mesh, camera, override = _study_data(args, _OCTOPUS, "triangles")
    field = _field(mesh)
    camera = camera or _default_camera(field)
    alphas = _alphas_for("attenuate", alphas, field, override)
    if args.alpha_u is not None:
        alpha_u = args.alpha_u
    elif override:
        alpha_u = float(f"{field.auto_alpha() * STUDY_DEFAULTS['attenuate']['u_factor']:.4g}")
    else:
        alpha_u = STUDY_DEFAULTS["attenuate"]["alpha_u"]
    unw = unweighted_field(field)
    specs = []
    for a in alphas:
        specs += [(field, dict(alpha=a, alpha_u=a, beta=args.beta, shading=args.shading)),
                  (field, dict(alpha=a, alpha_u=alpha_u, beta=args.beta, shading=args.shading)),
                  (unw, dict(alpha=a, beta=args.beta, shading=args.shading))]
    res, cam = _render_group(specs, camera, size, prog, frame=not args.no_frame)
    rows, stats = [], []
    for i, a in enumerate(alphas):
        full, att, non = res[3 * i:3 * i + 3]
        S = field.attenuation(a, alpha_u)
        rows.append([(f"attenuation off: α_U = α = {a:g} (S=1)", full.rgb),
                     (f"on: α_U = {alpha_u:g} (S={S:.3g})", att.rgb),
                     (f"unweighted (α={a:g})", non.rgb)])
        stats.append({"alpha": a, "alpha_u": alpha_u, "S": S, "full": full.summary(),
                      "attenuated": att.summary(), "unweighted": non.summary()})
    info = {"title": f"Weight attenuation at low α: {os.path.basename(src)}, β={args.beta:g}",
            "data": src, "kind": mesh.kind, "alphas": alphas, "alpha_u": alpha_u,
            "A": field.weight_bound, "camera": cam, "shading": args.shading, "renders": stats,
            "paper_figure": "attenuate"}
    return rows, info


_STUDY_FUNCS = {"underestimate": _study_underestimate, "exact-smooth": _study_exact_smooth,
                "weights": _study_weights, "metric": _study_metric,
                "attenuate": _study_attenuate}


def _panel_grid(path, panels, title, cell=2.3):
    """Save rows of ``(label, rgb)`` panels as one labelled PNG."""
    plt = _pyplot()
    nr = len(panels)
    nc = max(len(r) for r in panels)
    fig, axes = plt.subplots(nr, nc, squeeze=False,
                             figsize=(cell * nc, 1.07 * cell * nr + 0.35))
    for i, row in enumerate(panels):
        for j in range(nc):
            ax = axes[i][j]
            ax.set_xticks([])
            ax.set_yticks([])
            if j < len(row):
                label, img = row[j]
                ax.imshow(_thumb(img, 256), interpolation="lanczos")
                ax.set_title(label, fontsize=7)
            else:
                ax.axis("off")
    fig.suptitle(title, fontsize=8)
    fig.tight_layout(pad=0.4, rect=(0, 0, 1, 1 - 0.3 / (1.07 * cell * nr + 0.35)))
    _savefig(fig, path, dpi=100)
    plt.close(fig)


def _alpha_report(out):
    """report.md of the alpha studies: one section per <study>.json present in ``out``."""
    lines = ["# α studies", "",
             "Madan & Levin 2022, Sec. 3 figures, re-made with `python -m tracer ablate-alpha`. "
             "Each section lists the parameters; the JSON next to each image has them all "
             "(and per-render statistics).", ""]
    for s in STUDIES:
        p = out / f"{_slug(s)}.json"
        if not p.exists():
            continue
        try:
            info = json.loads(p.read_text(encoding="utf-8"))
        except ValueError:
            continue
        lines += [f"## {s} (paper figure \"{info.get('paper_figure', s)}\")", "",
                  f"{info.get('title', '')}", "", f"![{s}]({info.get('image')})", ""]
        keep = {k: v for k, v in info.items()
                if k not in ("renders", "cases", "title", "image", "study")}
        for k, v in keep.items():
            lines.append(f"- {k}: {json.dumps(v) if not isinstance(v, str) else v}")
        if "cases" in info:
            for c in info["cases"]:
                lines.append(f"- {c['kind']}: `{c['data']}`, α = {c['alpha']:g}, A = {c['A']:g}")
        lines.append("")
    return "\n".join(lines)


# =============================================================================== bench-grid
def add_arguments_bench_grid(p):
    """Arguments of ``tracer bench-grid``."""
    p.add_argument("folder", nargs="?", metavar="DIR",
                   help="folder of meshes (default ../shared/data/thingi10k next to the repo)")
    p.add_argument("-o", "--output", required=True, metavar="OUT",
                   help="result folder: bench_grid.csv, bench_grid.json and the two plots")
    p.add_argument("--grid", type=int, default=100, help="N for the N^3 voxel grid (default 100)")
    p.add_argument("--alpha", type=float, default=1.0, help="alpha (default 1, the authors' code)")
    p.add_argument("--alpha-u", type=float, help="alpha_U (default: alpha, i.e. S = 1)")
    p.add_argument("--beta", type=float, default=0.5, help="Barnes-Hut beta (default 0.5)")
    p.add_argument("--types", default="points,edges,triangles",
                   help="data types (default points,edges,triangles)")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--overwrite", action="store_true", help="replace earlier results")
    g.add_argument("--resume", action="store_true", help="skip meshes already in the CSV")
    _add_common(p)


MESH_EXTS = (".obj", ".off", ".stl", ".ply")


def benchmark_normalise(V):
    """The authors' benchmark normalisation: the vertex bbox centred at (0.5, 0.5, 0.5) with
    diagonal 0.5 (translate the centre to 0, divide by 2 x diagonal, add 0.5)."""
    V = np.asarray(V, dtype=np.float64)
    lo, hi = V.min(axis=0), V.max(axis=0)
    diag = float(np.linalg.norm(hi - lo))
    if diag == 0:
        raise ValueError("all vertices coincide")
    return (V - 0.5 * (lo + hi)) / (2.0 * diag) + 0.5


def voxel_centres(n):
    """``(n**3, 3)`` centres ``(i + 0.5) / n`` of an ``n^3`` grid over the unit cube."""
    c = (np.arange(n) + 0.5) / n
    X, Y, Z = np.meshgrid(c, c, c, indexing="ij")
    return np.ascontiguousarray(np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=1))


def run_bench_grid(args):
    """Run the grid benchmark over a folder; returns the exit status."""
    from smoothdist import DataMesh, MeshRepairWarning, SmoothDistanceField

    folder = Path(args.folder) if args.folder else (REPO / ".." / "shared" / "data" / "thingi10k")
    if not folder.is_dir():
        raise CLIError(f"mesh folder not found: {folder.resolve() if not args.folder else folder}"
                       " (give the Thingi10K folder as DIR)")
    files = sorted(p for p in folder.iterdir() if p.suffix.lower() in MESH_EXTS and p.is_file())
    if not files:
        raise CLIError(f"no mesh files ({', '.join(MESH_EXTS)}) in {folder}")
    if args.grid < 1 or args.grid > 400:
        raise CLIError(f"--grid must be between 1 and 400, got {args.grid}")
    alpha = _positive(args.alpha, "--alpha")
    alpha_u = _positive(args.alpha_u, "--alpha-u") if args.alpha_u is not None else alpha
    if not (math.isfinite(args.beta) and args.beta >= 0):
        raise CLIError(f"--beta must be >= 0, got {args.beta:g}")
    types = _types(args.types)
    out = Path(args.output)
    if out.exists() and not out.is_dir():
        raise CLIError(f"output path exists and is not a folder: {out}")
    csv_path = out / "bench_grid.csv"
    products = [csv_path, out / "bench_grid.json", out / "bench_time_vs_leaves.png",
                out / "bench_leaf_fraction.png"]
    existing = [p for p in products if p.exists()]
    if existing and not (args.overwrite or args.resume):
        raise CLIError(f"{out} already holds benchmark results ({existing[0].name}); pass "
                       "--resume to continue them or --overwrite to replace them")
    rows = []
    if args.resume and csv_path.exists():
        rows = _read_csv(csv_path, BENCH_FIELDS)
    out.mkdir(parents=True, exist_ok=True)
    import numba

    params = {"folder": str(folder.resolve()), "grid": args.grid, "alpha": alpha,
              "alpha_u": alpha_u, "beta": args.beta, "types": types,
              "normalisation": "vertex bbox centred at (0.5,0.5,0.5), diagonal 0.5",
              "queries": f"{args.grid}^3 voxel centres (i+0.5)/N of [0,1]^3",
              "threads": int(numba.get_num_threads()), "machine": _machine()}
    _write_json(out / "bench_grid.json", params)
    done = {r["name"] for r in rows}
    todo = [f for f in files if f.stem not in done]
    Q = voxel_centres(args.grid)
    prog = StudyProgress("bench-grid", max(len(todo) * len(types), 1), quiet=args.quiet)
    warm = SmoothDistanceField(np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]), [[0, 1, 2]])
    warm.smooth_distance(Q[:8], alpha=alpha, beta=args.beta, alpha_u=alpha_u, return_stats=True)
    for f in todo:
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", MeshRepairWarning)
                m = DataMesh.load(f)
                Vn = benchmark_normalise(m.V)
                meshes = {"points": DataMesh(Vn, name=f.name)}
                if len(m.edges) or len(m.triangles):
                    e = m.as_kind("edges")
                    meshes["edges"] = DataMesh(Vn, edges=e.edges, name=f.name)
                if len(m.triangles):
                    meshes["triangles"] = DataMesh(Vn, triangles=m.triangles, name=f.name)
        except (ValueError, OSError) as exc:
            prog.log(f"skipping {f.name}: {str(exc).strip().splitlines()[0]}")
            prog.finish(len(types))
            continue
        row = {"name": f.stem}
        for kind in TYPES:
            L = TYPE_LETTER[kind]
            key_n = {"points": "nV", "edges": "nE", "triangles": "nF"}[kind]
            if kind not in types or kind not in meshes:
                row.update({key_n: "", f"leaves_{L}": "", f"seconds_{L}": ""})
                if kind in types:
                    prog.finish(1)
                continue
            field = SmoothDistanceField(meshes[kind])
            t0 = time.perf_counter()
            _, _, st = field.smooth_distance(Q, alpha=alpha, beta=args.beta, alpha_u=alpha_u,
                                             return_stats=True)
            sec = time.perf_counter() - t0
            row.update({key_n: field.num_primitives,
                        f"leaves_{L}": float(st.leaves_visited.mean()), f"seconds_{L}": sec})
            prog.finish(1, f"{f.stem}: {kind} N={field.num_primitives} "
                        f"{st.leaves_visited.mean():.1f} leaves/query, {sec:.2f} s")
        rows.append(row)
        _write_csv(csv_path, BENCH_FIELDS, rows)
    _bench_plots(out, rows, params)
    if not args.quiet:
        print(f"Benchmark of {len(rows)} mesh(es) at {args.grid}^3 queries: {csv_path}, "
              f"bench_time_vs_leaves.png, bench_leaf_fraction.png.")
    return 0


def _num(v):
    try:
        x = float(v)
    except (TypeError, ValueError):
        return float("nan")
    return x


def _bench_plots(out, rows, params):
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6.0, 4.2))
    fig2, ax2 = plt.subplots(figsize=(6.0, 4.2))
    for kind in TYPES:
        L = TYPE_LETTER[kind]
        n = np.array([_num(r.get({"points": "nV", "edges": "nE", "triangles": "nF"}[kind]))
                      for r in rows])
        lv = np.array([_num(r.get(f"leaves_{L}")) for r in rows])
        sec = np.array([_num(r.get(f"seconds_{L}")) for r in rows])
        ok = np.isfinite(n) & np.isfinite(lv) & np.isfinite(sec) & (n > 0)
        if not ok.any():
            continue
        ax.scatter(lv[ok], sec[ok], s=16, color=TYPE_COLORS[kind], label=kind)
        ax2.scatter(n[ok], 100 * lv[ok] / n[ok], s=16, color=TYPE_COLORS[kind], label=kind)
    q = params["grid"] ** 3
    ax.set_xlabel("mean leaves visited per query")
    ax.set_ylabel(f"seconds for {q:,} queries")
    ax.set_title(f"time vs leaves visited (α={params['alpha']:g}, β={params['beta']:g}, "
                 f"{params['threads']} threads)", fontsize=9)
    ax2.set_xlabel("mesh size (primitives)")
    ax2.set_ylabel("leaves visited (% of primitives)")
    ax2.set_title("fraction of leaves visited vs mesh size", fontsize=9)
    for a in (ax, ax2):
        a.set_xscale("log")
        a.set_yscale("log")
        a.grid(True, which="both", alpha=0.3)
        if a.get_legend_handles_labels()[0]:
            a.legend(fontsize=8)
    fig.tight_layout()
    fig2.tight_layout()
    _savefig(fig, out / "bench_time_vs_leaves.png")
    _savefig(fig2, out / "bench_leaf_fraction.png")
    plt.close(fig)
    plt.close(fig2)


# =============================================================================== bh-switch
def add_arguments_bh_switch(p):
    """Arguments of ``tracer bh-switch``."""
    p.add_argument("cloud", nargs="?", default=None,
                   help="point cloud (or mesh: its vertices are used); default "
                   "scenes/data/pointclouds/lidar_autzen_trim.ply")
    p.add_argument("-o", "--output", required=True, metavar="OUT",
                   help="result folder: bh_switch.csv, bh_switch.json, bh_switch.png")
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
    _add_common(p)


def run_bh_switch(args):
    """Run the Barnes-Hut switch study; returns the exit status."""
    from smoothdist import DataMesh, SmoothDistanceField

    src = args.cloud or str(REPO / "scenes" / "data" / "pointclouds" / "lidar_autzen_trim.ply")
    alpha = _positive(args.alpha, "--alpha")
    for name in ("iso", "start", "segment", "dbeta"):
        _positive(getattr(args, name), f"--{name}")
    if not (math.isfinite(args.beta) and args.beta >= 0):
        raise CLIError(f"--beta must be >= 0, got {args.beta:g}")
    if args.trials < 1:
        raise CLIError(f"--trials must be >= 1, got {args.trials}")
    if args.samples < 2:
        raise CLIError(f"--samples must be >= 2, got {args.samples}")
    if args.max_steps < 1:
        raise CLIError(f"--max-steps must be >= 1, got {args.max_steps}")
    out = Path(args.output)
    if out.exists() and not out.is_dir():
        raise CLIError(f"output path exists and is not a folder: {out}")
    products = [out / "bh_switch.csv", out / "bh_switch.json", out / "bh_switch.png"]
    for p in products:
        if p.exists() and not args.overwrite:
            raise CLIError(f"{p} exists (pass --overwrite to replace it)")
    mesh = _load(src, "points")
    V = mesh.V[mesh.points]
    lo0, hi0 = V.min(axis=0), V.max(axis=0)
    scale = float(np.linalg.norm(hi0 - lo0))
    if scale == 0:
        raise CLIError(f"{src}: all points coincide")
    Vn = (V - lo0) / scale  # unit bbox diagonal, min corner at the origin
    field = SmoothDistanceField(DataMesh(Vn, name=os.path.basename(src)))
    lo, hi = field.bounds
    rng = np.random.default_rng(args.seed)
    T = args.trials
    x = rng.uniform(lo[0], hi[0], T)
    y = rng.uniform(lo[1], hi[1], T)
    top = rng.random(T) < 0.5
    # the zero set can lie up to log(N)/alpha outside the data (inflation): start beyond it
    grow = field.inflation(alpha)
    z = np.where(top, hi[2] + grow + args.start, lo[2] - grow - args.start)
    dz = np.where(top, -1.0, 1.0)
    beta = args.beta
    t0 = time.perf_counter()
    # 1. march each ray along z with steps d_hat until d_hat <= iso (hit), d_hat grows (miss)
    #    or max_steps steps were taken
    active = np.ones(T, bool)
    hit = np.zeros(T, bool)
    prev = np.full(T, np.inf)
    steps = np.zeros(T, np.int64)
    for _ in range(args.max_steps + 1):
        idx = np.flatnonzero(active)
        if idx.size == 0:
            break
        d, _ = field.smooth_distance(np.stack([x[idx], y[idx], z[idx]], axis=1), alpha=alpha,
                                     beta=beta)
        reached = d <= args.iso
        hit[idx[reached]] = True
        grew = ~reached & (d > prev[idx])
        stop = reached | grew | (steps[idx] >= args.max_steps)
        go = idx[~stop]
        z[go] += dz[go] * d[~stop]
        prev[go] = d[~stop]
        steps[go] += 1
        active[idx[stop]] = False
    # 2. sample the further segment; 3. compare at every change of leaves visited
    hits = np.flatnonzero(hit)
    K = args.samples
    frac = np.arange(K) / (K - 1)
    rows = []
    n_samples = hits.size * K
    if hits.size:
        Z = z[hits, None] + dz[hits, None] * args.segment * frac[None, :]
        Q = np.stack([np.repeat(x[hits], K), np.repeat(y[hits], K), Z.ravel()], axis=1)
        d, g, st = field.smooth_distance(Q, alpha=alpha, beta=beta, return_stats=True)
        lv = st.leaves_visited.reshape(hits.size, K)
        sw = np.zeros((hits.size, K), bool)
        sw[:, 1:] = lv[:, 1:] != lv[:, :-1]
        flat = np.flatnonzero(sw.ravel())
        if flat.size:
            d2, g2, st2 = field.smooth_distance(Q[flat], alpha=alpha, beta=beta + args.dbeta,
                                                return_stats=True)
            g1 = g[flat]
            n1 = np.linalg.norm(g1, axis=1)
            n2 = np.linalg.norm(g2, axis=1)
            cos = np.einsum("ij,ij->i", g1, g2) / np.maximum(n1 * n2, 1e-300)
            for j, fi in enumerate(flat):
                ti, k = divmod(int(fi), K)
                disc = abs(float(d[fi] - d2[j]))
                rows.append({"trial": int(hits[ti]), "sample": k, "x": float(Q[fi, 0]),
                             "y": float(Q[fi, 1]), "z": float(Q[fi, 2]),
                             "leaves": int(st.leaves_visited[fi]), "d_hat": float(d[fi]),
                             "dz_d_hat": float(g[fi, 2]),
                             "leaves_dbeta": int(st2.leaves_visited[j]),
                             "d_hat_dbeta": float(d2[j]), "discrepancy": disc,
                             "discrepancy_orig_units": disc * scale, "cosine": float(cos[j]),
                             "kept": int(st2.leaves_visited[j] < st.leaves_visited[fi])})
    seconds = time.perf_counter() - t0
    kept = [r for r in rows if r["kept"]]

    def stats(rs):
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

    summary = {"cloud": src, "points": int(V.shape[0]), "normalisation":
               "translated to the bbox min corner and divided by the bbox diagonal (unit "
               "diagonal), so that alpha = 100 means 1/alpha = 1% of the diagonal; discrepancies "
               "are in these units (x scale for the cloud's own units)",
               "scale": scale, "alpha": alpha, "alpha_orig_units": alpha / scale, "beta": beta,
               "dbeta": args.dbeta, "iso": args.iso, "start": args.start,
               "start_rule": "rays start `start` beyond the bbox grown by the inflation "
               "log(N)/alpha (the authors start 0.01 beyond the bbox itself)",
               "inflation": grow,
               "segment": args.segment, "samples": K, "max_steps": args.max_steps,
               "trials": T, "seed": args.seed, "hits": int(hits.size), "samples_total": n_samples,
               "march_steps_mean": float(steps.mean()), "switch_points": len(rows),
               "kept": stats(kept), "all_switches": stats(rows), "paper": PAPER_BH,
               "paper_note": "paper: city LiDAR scan, 259 kept points (beta + 1e-4 visits fewer "
               "leaves), in that scan's units", "seconds": round(seconds, 3),
               "threads": _machine()["numba_threads"]}
    out.mkdir(parents=True, exist_ok=True)
    _write_csv(out / "bh_switch.csv", BH_FIELDS, rows)
    _write_json(out / "bh_switch.json", summary)
    _bh_plot(out / "bh_switch.png", rows, summary)
    if not args.quiet:
        k = summary["kept"]
        if k["count"]:
            print(f"Barnes-Hut switches: {hits.size}/{T} rays reached d_hat <= {args.iso:g}; "
                  f"{len(rows)} switch points, {k['count']} where beta+{args.dbeta:g} visits "
                  f"fewer leaves: mean |d_hat diff| {k['mean_discrepancy']:.3g}, max "
                  f"{k['max_discrepancy']:.3g} (unit diagonal), min cosine "
                  f"{k['min_cosine']:.6f} (paper: {PAPER_BH['kept_points']} points, mean "
                  f"{PAPER_BH['mean_discrepancy']:.2g}, max {PAPER_BH['max_discrepancy']:.2g}, min "
                  f"cosine {PAPER_BH['min_cosine']}). Wrote {out}.")
        else:
            print(f"Barnes-Hut switches: {hits.size}/{T} rays reached d_hat <= {args.iso:g}; "
                  f"{len(rows)} switch points, none kept. Wrote {out}.")
    return 0


def _bh_plot(path, rows, summary):
    plt = _pyplot()
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(8.0, 3.2))
    kept = [r for r in rows if r["kept"]]
    other = [r for r in rows if not r["kept"]]
    for rs, lab, col in ((kept, "kept (β+Δβ visits fewer leaves)", "#1f77b4"),
                         (other, "other switches", "#bbbbbb")):
        dd = np.array([r["discrepancy"] for r in rs])
        cc = np.array([r["cosine"] for r in rs])
        dd = dd[dd > 0]
        if dd.size:
            a1.hist(np.log10(dd), bins=30, color=col, alpha=0.8, label=lab)
        if cc.size:
            a2.hist(np.clip(1 - cc, 1e-16, None), bins=np.logspace(-16, 0, 33), color=col,
                    alpha=0.8, label=lab)
    a1.axvline(math.log10(PAPER_BH["mean_discrepancy"]), color="k", ls="--", lw=0.8,
               label="paper mean")
    a1.set_xlabel("log10 |d̂_β − d̂_{β+Δβ}| (unit diagonal)")
    a1.set_ylabel("switch points")
    a2.set_xscale("log")
    a2.axvline(1 - PAPER_BH["min_cosine"], color="k", ls="--", lw=0.8, label="paper 1 − min cos")
    a2.set_xlabel("1 − cos(∇d̂_β, ∇d̂_{β+Δβ})")
    for a in (a1, a2):
        if a.get_legend_handles_labels()[0]:
            a.legend(fontsize=6)
    fig.suptitle(f"Barnes-Hut switch study: {os.path.basename(summary['cloud'])}, "
                 f"α={summary['alpha']:g}, β={summary['beta']:g}", fontsize=9)
    fig.tight_layout()
    _savefig(fig, path)
    plt.close(fig)
