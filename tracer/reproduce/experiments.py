"""The experiments of ``tracer reproduce``: each reuses a study or benchmark that exists already
and returns a small dict of results, which :mod:`tracer.reproduce.cli` writes as
``<name>.json`` (with the provenance of :func:`provenance`) into the results folder.

Each experiment is ``fn(out, settings, where) -> dict``: ``out`` is the experiment's own
folder (the study's CSV, JSON and plots go there), ``settings`` the experiment's entry of
:data:`SETTINGS` (``smoke``, ``quick`` or ``full``), ``where`` the runner's ``{"scheduler": ...,
"workers": ...}`` (the studies and the simulations run their tasks through
:mod:`tracer.runner`).
"""

import csv
import datetime
import importlib
import importlib.util
import json
import math
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numba
import numpy as np

from smoothdist import DataMesh, MeshDistance, SmoothDistanceField
from smoothdist.cuda import CudaUnavailable, cuda_module, simulated
from tracer import datasets, runner
from tracer.cli import build_parser
from tracer.outputs import write_json
from tracer.runner import cpu_count
from tracer.sim.primitives import (bowl_edges, icosphere_edges, ring_toss_points, slide_edges,
                                   trefoil_100, uv_sphere)
from tracer.studies.bh_switch import DEFAULT_CLOUD, normalised_field
from tracer.studies.common import REPO, TYPE_LETTER, TYPES, unweighted_field
from tracer.studies.plots import beta_plots, bench_plots

#: the bunny of the paper's beta study
BUNNY = REPO / "scenes" / "data" / "bunny.off"
#: the scanned lion's points (the Barnes-Hut centre check)
DEFAULT_LION = REPO / "scenes" / "data" / "pointclouds" / "scan_guardian_lion_points.ply"
TABLE3 = REPO / "scenes" / "simulations" / "table3"

#: the paper's Table 3 (Sec. 5.5): scene file -> (row, data, query, paper ms at 28 threads, dt)
TABLE3_PAPER = {
    "ico_bowl": (1, "Bowl, 736 edges", "Icosphere, 120 edges", 2.72934, "1/200"),
    "spikeball_bowl": (2, "Bowl, 736 edges", "Spiky Sphere, 966 tris+edges", 34.7789, "1/1000"),
    "bunny_lidar": (3, "Terrain, 6,591,087 points", "Bunny, 3,485 points", 250.0031, "1/100"),
    "octopus_lidar": (4, "Terrain, 6,591,087 points", "Octopus, 4,432 tris", 189.5989, "1/100"),
    "bunny_bunny": (5, "Bunny, 6,966 tris", "Bunny, 6,966 tris", 92.5717, "1/400"),
    "bunny_bunny_plane": (6, "Bumpy Plane, 800 tris", "Bunny, 6,966 tris", 470.3857, "1/400"),
    "sphere_slide": (7, "Slide, 615 edges", "Sphere, 960 tris", 33.5601, "1/100"),
    "trefoil_ringtoss": (8, "Ring Toss, 12,400 points", "Trefoil, 100 edges", 1.4727, "1/200"),
}

#: settings per mode. ``steps`` None: the simulation file's own count (the paper's, except where
#: scenes/simulations/table3/README.md says why not); the terrain scenes build 6.6M points.
SETTINGS = {
    "quick": {
        "beta": {"size": 24, "betas": [0.0, 0.2, 0.5, 1.0], "repeat": 2},
        "alpha": {"study": "underestimate", "size": 24},
        "underestimate": {"queries": 1000, "seed": 0, "alpha": 200.0,
                          "alphas": [25.0, 50.0, 100.0, 200.0, 400.0, 800.0]},
        "bh_switch": {"trials": 40},
        "grid": {"grid": 24, "generated": [100, 1000, 10000], "thingi10k": True, "repeat": 3},
        "table3": {"scenes": ["ico_bowl", "trefoil_ringtoss", "sphere_slide"], "steps": 50,
                   "threads": [1, None], "authors_timeout": 600.0},
        "box_test": {"cases": ["bowl-ico", "slide-sphere"], "repeat": 5},
        "gpu": {"size": [640, 360], "grid": 50, "repeat": 3},
        "beta_alpha": {"size": 32, "alphas": [50.0, 200.0, 800.0], "betas": [0.0, 0.5, 1.0]},
        "bh_centre": {"seed": 0, "clusters": 40, "cluster": 64, "queries": 50,
                      "alphas": [1.0, 4.0, 16.0], "library_queries": 2000},
        "bulges": {"cells": 4, "alpha": 200.0, "height_x_alpha": 1.0},
        "quadrature": {"order": 5, "queries": 2000, "seed": 0, "alphas": [1.0, 10.0, 100.0]},
        "vbowl": {"steps": 400},
        "attenuation": {"R": 4.0, "r": 1.5, "alpha": 2.0, "alpha_us": [4, 8, 16, 64],
                        "grid": 201},
    },
    "smoke": {  # the test suite's: every experiment at its smallest (seconds, once compiled)
        "beta": {"size": 12, "betas": [0.0, 0.2, 0.5], "repeat": 2},
        "alpha": {"study": "underestimate", "size": 12},
        "underestimate": {"queries": 300, "seed": 0, "alpha": 200.0,
                          "alphas": [25.0, 50.0, 100.0, 200.0, 400.0, 800.0]},
        "bh_switch": {"trials": 20},
        "grid": {"grid": 8, "generated": [100], "thingi10k": False, "repeat": 2},
        "table3": {"scenes": ["trefoil_ringtoss"], "steps": 10, "threads": [1, None]},
        "box_test": {"cases": ["bowl-ico"], "repeat": 2},
        "gpu": {"size": [320, 180], "grid": 20, "repeat": 1},
        "beta_alpha": {"size": 12, "alphas": [100.0, 400.0], "betas": [0.0, 1.0]},
        "bh_centre": {"seed": 0, "clusters": 5, "cluster": 32, "queries": 20,
                      "alphas": [1.0, 16.0], "library_queries": 200},
        "bulges": {"cells": 4, "alpha": 200.0, "height_x_alpha": 1.0},
        "quadrature": {"order": 5, "queries": 200, "seed": 0, "alphas": [1.0, 100.0]},
        "vbowl": {"steps": 300},
        "attenuation": {"R": 4.0, "r": 1.5, "alpha": 2.0, "alpha_us": [16], "grid": 151},
    },
    "full": {
        "beta": {"size": 512, "betas": [0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0],
                 "repeat": 3},
        "alpha": {"study": "all", "size": 512},
        "underestimate": {"queries": 100000, "seed": 0, "alpha": 200.0,
                          "alphas": [25.0, 50.0, 100.0, 200.0, 400.0, 800.0]},
        "bh_switch": {"trials": 500},
        "grid": {"grid": 100, "generated": [100, 1000, 10000, 100000, 1000000],
                 "thingi10k": True, "repeat": 3},
        "table3": {"scenes": list(TABLE3_PAPER), "steps": None, "threads": [1, None],
                   "step_caps": {"octopus_lidar": 263}, "authors_timeout": 3600.0},
        "box_test": {"cases": ["bunny-bunny", "ring-toss", "bowl-ico", "slide-sphere"],
                     "repeat": 9},
        "gpu": {"size": [1920, 1080], "grid": 100, "repeat": 3},
        "beta_alpha": {"size": 128, "alphas": [50.0, 200.0, 800.0], "betas": [0.0, 0.5, 1.0]},
        "bh_centre": {"seed": 0, "clusters": 400, "cluster": 64, "queries": 100,
                      "alphas": [1.0, 4.0, 16.0, 64.0], "library_queries": 100000},
        "bulges": {"cells": 4, "alpha": 200.0, "height_x_alpha": 1.0},
        "quadrature": {"order": 5, "queries": 20000, "seed": 0,
                       "alphas": [1.0, 3.0, 10.0, 30.0, 100.0]},
        "vbowl": {"steps": 600},
        "attenuation": {"R": 4.0, "r": 1.5, "alpha": 2.0, "alpha_us": [4, 8, 16, 64],
                        "grid": 401},
    },
}


# ============================================================================ provenance
def git_output(*args):
    try:
        return subprocess.run(["git", *args], cwd=REPO, capture_output=True, text=True,
                              timeout=10).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return ""


def _git_status(*args):
    """The exit status of ``git *args`` in the repository (None when git cannot run)."""
    try:
        return subprocess.run(["git", *args], cwd=REPO, capture_output=True,
                              timeout=30).returncode
    except (OSError, subprocess.SubprocessError):
        return None


#: the code an experiment measures: a change here between an experiment's commit and the
#: report's makes its figures stale (table3 also times the simulator)
MEASURED_CODE = ("smoothdist", "tracer/rendering")
MEASURED_EXTRA = {"table3": ("tracer/sim",)}


def measured_code(name):
    return MEASURED_CODE + MEASURED_EXTRA.get(name, ())


def code_changed(commit, head, paths=MEASURED_CODE):
    """``"unchanged"`` or ``"changed"`` (the measured code between the two commits, by
    ``git diff --quiet``), ``"unknown"`` where git, or either commit, is not available."""
    if not commit or not head or "unknown" in (commit, head):
        return "unknown"
    rc = _git_status("diff", "--quiet", commit, head, "--", *paths)
    return {0: "unchanged", 1: "changed"}.get(rc, "unknown")


def tree_dirty():
    """True when the work tree has changes to tracked files, None where git cannot tell."""
    if _git_status("rev-parse", "--git-dir") != 0:
        return None
    return bool(git_output("status", "--porcelain", "--untracked-files=no"))


def head_commit():
    return git_output("rev-parse", "HEAD") or "unknown"


def load_average():
    """The 1, 5 and 15 minute load averages (None where the system has none)."""
    return [round(x, 2) for x in os.getloadavg()] if hasattr(os, "getloadavg") else None


def cpu_model():
    """The CPU's model name (lscpu, else /proc/cpuinfo, else platform.processor())."""
    try:
        out = subprocess.run(["lscpu"], capture_output=True, text=True, timeout=10).stdout
        for line in out.splitlines():
            if line.startswith("Model name:"):
                return line.split(":", 1)[1].strip()
    except (OSError, subprocess.SubprocessError):
        pass
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as fh:
            for line in fh:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def provenance():
    """Commit (and whether the tree had changes), UTC date, machine and thread count."""
    return {"commit": head_commit(), "dirty": tree_dirty(),
            "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
            "machine": {"cpu": cpu_model(), "cores": cpu_count(), "platform": platform.platform(),
                        "python": platform.python_version(), "numba": numba.__version__},
            "numba_threads": int(numba.get_num_threads()),
            "load_average": load_average()}


# ============================================================================ helpers
def run_command(argv):
    """Run a ``tracer`` sub-command in this process; its errors propagate (no ``error:``
    printing here: the caller reports)."""
    args = build_parser(only=argv[0]).parse_args(argv)
    status = int(importlib.import_module(args._module).run(args) or 0)
    if status:
        raise RuntimeError(f"tracer {argv[0]} exited with status {status}")


def runner_args(where):
    """``--scheduler`` (and ``--workers``) of a study's command line."""
    out = ["--scheduler", where["scheduler"]]
    if where.get("workers") is not None:
        out += ["--workers", str(where["workers"])]
    return out


def read_csv(path):
    def num(v):
        try:
            return float(v)
        except (TypeError, ValueError):
            return v

    with open(path, newline="", encoding="utf-8") as fh:
        return [{k: num(v) for k, v in r.items()} for r in csv.DictReader(fh)]


# ============================================================================ beta (Sec. 4.3)
#: the betas whose render times the paper's timing claims quote (0 / 0.2 and 0.5), rendered
#: ``repeat`` times for their spread
TIMED_BETAS = (0.0, 0.2, 0.5)


def beta(out, s, where):
    """The beta ablation on the bunny (``tracer ablate-beta``): seconds and isosurface error
    (fraction of the bbox diagonal) per type and beta."""
    run_command(["ablate-beta", str(BUNNY), "-o", str(out), "--size", str(s["size"]),
                 "--betas", ",".join(f"{b:g}" for b in s["betas"]), "--grid-betas",
                 ",".join(f"{b:g}" for b in s["betas"]), "--overwrite", "-q",
                 *runner_args(where)])
    shutil.rmtree(out / "cache", ignore_errors=True)  # depth buffers: large, not a result
    rows = [r for r in read_csv(out / "beta_ablation.csv") if float(r.get("tol") or 0) == 0]
    res = {"size": s["size"], "alpha": 200.0, "alpha_u": 1200.0, "betas": s["betas"],
           "render_seconds": {}, "error_rel_diag": {}, "csv": "beta/beta_ablation.csv"}
    for kind in TYPES:
        rs = sorted((r for r in rows if r["type"] == kind), key=lambda r: r["beta"])
        res["render_seconds"][kind] = {f"{r['beta']:g}": r["seconds"] for r in rs}
        res["error_rel_diag"][kind] = {f"{r['beta']:g}": r["error_rel_diag"] for r in rs}
        res.setdefault("leaves_per_eval", {})[kind] = {
            f"{r['beta']:g}": r["leaves_per_eval"] for r in rs if "leaves_per_eval" in r}
    res["threads"] = int(rows[0]["threads"]) if rows else None
    # the timing claims' betas rendered again (``repeat`` runs in all): their spread
    timed = [b for b in TIMED_BETAS if b in s["betas"]]
    reps = {kind: {f"{b:g}": [res["render_seconds"][kind][f"{b:g}"]] for b in timed}
            for kind in TYPES if res["render_seconds"].get(kind)}
    for i in range(1, int(s.get("repeat", 1))):
        sub = out / f"repeat{i}"
        run_command(["ablate-beta", str(BUNNY), "-o", str(sub), "--size", str(s["size"]),
                     "--betas", ",".join(f"{b:g}" for b in timed if b),
                     "--grid-betas", ",".join(f"{b:g}" for b in timed if b), "--overwrite",
                     "-q", *runner_args(where)])
        shutil.rmtree(sub / "cache", ignore_errors=True)
        for r in read_csv(sub / "beta_ablation.csv"):
            if float(r.get("tol") or 0) == 0 and r["type"] in reps \
                    and f"{r['beta']:g}" in reps[r["type"]]:
                reps[r["type"]][f"{r['beta']:g}"].append(r["seconds"])
    res["render_seconds_repeats"] = reps
    res["repeat"] = int(s.get("repeat", 1))
    if res["repeat"] > 1:
        beta_time_spread(out, reps)
    return res


def beta_time_spread(out, reps):
    """The beta study's time plot in ``out`` redrawn with the repeats' min-max bars
    (``reps``: ``{type: {beta: [seconds]}}``, the first run's included)."""
    with open(out / "beta_params.json", encoding="utf-8") as fh:
        params = json.load(fh)
    rows = [r for r in read_csv(out / "beta_ablation.csv") if r.get("status", "ok") == "ok"]
    beta_plots(out, rows, params, spread=reps)


# ============================================================================ alpha (Sec. 3)
def alpha(out, s, where):
    """The alpha studies (``tracer ablate-alpha``); the underestimate study's nesting and
    exact-distance checks are the numbers."""
    run_command(["ablate-alpha", s["study"], "-o", str(out), "--size", str(s["size"]),
                 "--overwrite", "-q", *runner_args(where)])
    with open(out / "underestimate.json", encoding="utf-8") as fh:
        u = json.load(fh)
    n = u["nesting"]
    return {"study": s["study"], "size": s["size"], "data": u["data"], "alphas": u["alphas"],
            "beta": u["beta"], "slice_samples": n["slice_samples"],
            "alpha_pairs": n["alpha_pairs"],
            "nesting_violations_beta_0.5": n["violations_beta_0.5"],
            "exact_check_samples": n["exact_check_samples"],
            "nesting_violations_beta_0": n["violations_beta_0"],
            "json": "alpha/underestimate.json"}


# ============================================================================ beta vs alpha
def beta_alpha(out, s, where):
    """Sec. 4.3, "beta can be increased with low error for higher values of alpha": the beta
    study (``tracer ablate-beta``) on the bunny at several alphas (alpha_U 1200, the paper's),
    the isosurface error (fraction of the bbox diagonal) per alpha, type and beta."""
    res = {"size": s["size"], "alphas": s["alphas"], "betas": s["betas"], "alpha_u": 1200.0,
           "error_rel_diag": {}, "csv": []}
    for a in s["alphas"]:
        sub = out / f"alpha{a:g}"
        run_command(["ablate-beta", str(BUNNY), "-o", str(sub), "--size", str(s["size"]),
                     "--alpha", f"{a:g}", "--alpha-u", "1200",
                     "--betas", ",".join(f"{b:g}" for b in s["betas"]),
                     "--grid-betas", ",".join(f"{b:g}" for b in s["betas"]), "--overwrite",
                     "-q", *runner_args(where)])
        shutil.rmtree(sub / "cache", ignore_errors=True)
        res["csv"].append(f"beta_alpha/alpha{a:g}/beta_ablation.csv")
        for r in read_csv(sub / "beta_ablation.csv"):
            if float(r.get("tol") or 0) == 0 and r.get("status", "ok") == "ok":
                res["error_rel_diag"].setdefault(r["type"], {}).setdefault(
                    f"{a:g}", {})[f"{r['beta']:g}"] = r["error_rel_diag"]
    return res


# ============================================================================ alpha_U (Sec. 3.3)
def hex_torus(R=4.0, r=1.5, n=6):
    """A hexagonal torus (``n`` segments around the ring and around the tube, ring radius
    ``R``, tube radius ``r``), triangles: the construction of the paper's Fig. "attenuate"
    (the authors' scenes/hex_torus.json: alpha 2, max_alpha 16)."""
    u = 2 * np.pi * np.arange(n) / n
    U, W = np.meshgrid(u, u, indexing="ij")
    V = np.stack([(R + r * np.cos(W)) * np.cos(U), (R + r * np.cos(W)) * np.sin(U),
                  r * np.sin(W)], -1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    a, b = i * n + j, (i + 1) % n * n + j
    c, d = (i + 1) % n * n + (j + 1) % n, i * n + (j + 1) % n
    F = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3),
                        np.stack([a, c, d], -1).reshape(-1, 3)])
    return V, F


def attenuation(out, s, where):
    """Sec. 3.3 (Fig. "attenuate"): at a low alpha the weights overcompensate and crease the
    surface of a blobby hexagonal torus; alpha_U blends between the weighted and the unweighted
    distance. On the slice y = 0 (both tube sections), beta 0: the smooth distance with full
    weights (S = 1), with each alpha_U of ``alpha_us`` (S = alpha / alpha_U) and unweighted;
    per field the largest curvature of the zero level curve (times the tube radius: 1 for a
    circle of the tube's size) over the samples within 1.5 grid steps of it, and whether every
    sample's value lies between the weighted and the unweighted one, growing with alpha_U."""
    R, r, alpha = s["R"], s["r"], s["alpha"]
    V, F = hex_torus(R, r)
    f = SmoothDistanceField(DataMesh(V, triangles=F, name="hex_torus"))
    m = 1.2 * f.inflation(alpha) + 0.5
    n = int(s["grid"])
    x = np.linspace(-(R + r + m), R + r + m, n)
    z = np.linspace(-(r + m), r + m, max(8, n // 2))
    X, Z = np.meshgrid(x, z, indexing="ij")
    Q = np.stack([X.ravel(), np.zeros(X.size), Z.ravel()], 1)
    hx, hz = x[1] - x[0], z[1] - z[0]
    fields = [("weighted", f, None)] + [(f"alpha_U {u:g}", f, float(u)) for u in s["alpha_us"]] \
        + [("unweighted", unweighted_field(f), None)]
    ds, rows = [], {}
    for name, field, au in fields:
        d, g = field.smooth_distance(Q, alpha=alpha, beta=0.0, alpha_u=au, gradient="exact")
        d = d.reshape(X.shape)
        g = g[:, [0, 2]].reshape(X.shape + (2,))
        nrm = g / np.maximum(np.linalg.norm(g, axis=-1, keepdims=True), 1e-300)
        kappa = np.gradient(nrm[..., 0], hx, axis=0) + np.gradient(nrm[..., 1], hz, axis=1)
        band = np.abs(d) < 1.5 * max(hx, hz)
        rows[name] = {"alpha_u": au, "S": 1.0 if name == "weighted" else
                      0.0 if name == "unweighted" else min(alpha / au, 1.0),
                      "max_curvature_x_r": float(np.abs(kappa[band]).max() * r)
                      if band.any() else None,
                      "p99_curvature_x_r": float(np.percentile(np.abs(kappa[band]), 99) * r)
                      if band.any() else None,
                      "band_samples": int(band.sum()), "min_distance": float(d.min())}
        ds.append(d)
    tol = 1e-9 * (1.0 + max(float(np.abs(d).max()) for d in ds))
    ordered = all(bool(np.all(b >= a - tol)) for a, b in zip(ds, ds[1:]))
    return {"shape": f"hexagonal torus, {len(F)} triangles, R {R:g}, r {r:g}",
            "alpha": alpha, "alpha_us": s["alpha_us"], "beta": 0.0, "inflation":
            f.inflation(alpha), "slice": "y = 0", "grid": [int(X.shape[0]), int(X.shape[1])],
            "fields": rows, "blend_ordered": ordered}


# ============================================================================ BH switch
#: the authors' ``barnes_hut_smoothness_test.cpp`` (abhimadan/smoothdists, app/): raw
#: coordinates of their scan, alpha 100 and beta 0.5 in those units, rays along z from 0.01
#: beyond the bbox, marched (at most 20 steps) until d_hat <= 0.1, then 101 samples over 0.005
AUTHORS_BH = {"alpha": 100.0, "iso": 0.1, "start": 0.01, "segment": 0.005, "samples": 101,
              "max_steps": 20}


def _point_spacing(V):
    """The median distance of a point to its nearest other point (None without scipy)."""
    try:
        from scipy.spatial import cKDTree  # scipy (sim extra): loaded on use
    except ImportError:
        return None
    d, _ = cKDTree(V).query(V, k=2)
    return float(np.median(d[:, 1]))


def bh_switch(out, s, where):
    """The Barnes-Hut switch study (``tracer bh-switch``) on the shipped Autzen cloud: on the
    cloud normalised to a unit diagonal (the study's default), and the authors' way
    (:data:`AUTHORS_BH`: their settings in the cloud's raw units, run as the study's
    normalised settings times the scale, which gives the same field; ``raw``)."""
    run_command(["bh-switch", "-o", str(out), "--trials", str(s["trials"]), "--overwrite", "-q",
                 *runner_args(where)])
    with open(out / "bh_switch.json", encoding="utf-8") as fh:
        j = json.load(fh)
    field, scale = normalised_field(str(DEFAULT_CLOUD))
    a = AUTHORS_BH
    run_command(["bh-switch", "-o", str(out / "raw"), "--trials", str(s["trials"]),
                 "--alpha", repr(a["alpha"] * scale), "--iso", repr(a["iso"] / scale),
                 "--start", repr(a["start"] / scale), "--segment", repr(a["segment"] / scale),
                 "--samples", str(a["samples"]), "--max-steps", str(a["max_steps"]),
                 "--overwrite", "-q", *runner_args(where)])
    with open(out / "raw" / "bh_switch.json", encoding="utf-8") as fh:
        r = json.load(fh)
    k, rk = j["kept"], r["kept"]
    spacing = _point_spacing(np.asarray(field.mesh.V) * scale)
    return {"cloud": os.path.relpath(j["cloud"], REPO) if os.path.isabs(j["cloud"])
            else j["cloud"], "points": j["points"], "trials": j["trials"], "hits": j["hits"],
            "alpha": j["alpha"], "beta": j["beta"], "dbeta": j["dbeta"], "iso": j.get("iso"),
            "kept_points": k["count"], "mean_discrepancy": k["mean_discrepancy"],
            "max_discrepancy": k["max_discrepancy"], "mean_cosine": k["mean_cosine"],
            "min_cosine": k["min_cosine"], "scale": scale,
            "mean_discrepancy_orig_units": k.get("mean_discrepancy_orig_units"),
            "max_discrepancy_orig_units": k.get("max_discrepancy_orig_units"),
            "median_spacing_orig_units": spacing,
            "raw": {"settings": dict(a), "hits": r["hits"], "switch_points": r["switch_points"],
                    "kept_points": rk["count"],
                    "mean_discrepancy": rk.get("mean_discrepancy_orig_units"),
                    "max_discrepancy": rk.get("max_discrepancy_orig_units"),
                    "mean_cosine": rk["mean_cosine"], "min_cosine": rk["min_cosine"],
                    "json": "bh_switch/raw/bh_switch.json"},
            "json": "bh_switch/bh_switch.json"}


# ============================================================================ grid (Sec. 4.4)
def heightfield_off(path, n_triangles):
    """A bumpy height-field grid with about ``n_triangles`` triangles, written as OFF."""
    n = max(2, int(round(math.sqrt(n_triangles / 2.0))))
    x = np.linspace(0.0, 1.0, n + 1)
    X, Y = np.meshgrid(x, x, indexing="ij")
    Z = 0.08 * np.sin(7.0 * X) * np.cos(5.0 * Y) + 0.03 * np.sin(23.0 * X + 11.0 * Y)
    V = np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=1)
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    a = (i * (n + 1) + j).ravel()
    b, c, d = a + (n + 1), a + 1, a + n + 2
    F = np.concatenate([np.stack([a, b, c], 1), np.stack([c, b, d], 1)])
    with open(path, "w", encoding="ascii") as fh:
        fh.write(f"OFF\n{len(V)} {len(F)} 0\n")
        np.savetxt(fh, V, fmt="%.9g")
        np.savetxt(fh, np.concatenate([np.full((len(F), 1), 3), F], 1), fmt="%d")
    return len(F)


def grid_fit(rows, grid):
    """Per type: Pearson r of seconds against mean leaves, ns per leaf per query (least squares
    through the origin of seconds per query against leaves), and the share of leaves visited
    (mean leaves / primitives) at the smallest and the largest mesh, the largest mean leaves."""
    Q = float(grid) ** 3
    out = {}
    for kind in TYPES:
        L = TYPE_LETTER[kind]
        cnt = {"points": "nV", "edges": "nE", "triangles": "nF"}[kind]
        rs = [r for r in rows if isinstance(r.get(f"seconds_{L}"), float)
              and isinstance(r.get(cnt), float) and r[cnt] > 0]
        if not rs:
            continue
        lv = np.array([r[f"leaves_{L}"] for r in rs])
        sq = np.array([r[f"seconds_{L}"] for r in rs]) / Q
        n = np.array([r[cnt] for r in rs])
        share = lv / n
        small, large = int(np.argmin(n)), int(np.argmax(n))
        per = sq / np.maximum(lv, 1e-300) * 1e9
        out[kind] = {
            "meshes": len(rs),
            "pearson_r": float(np.corrcoef(lv, sq)[0, 1]) if len(rs) > 2 else None,
            "ns_per_leaf_fit": float(1e9 * (lv @ sq) / (lv @ lv)),
            "ns_per_leaf_min": float(per.min()), "ns_per_leaf_max": float(per.max()),
            "us_per_query_mean": float(1e6 * sq.mean()),
            "leaves_max": float(lv.max()),
            "share_smallest": float(share[small]), "primitives_smallest": int(n[small]),
            "share_largest": float(share[large]), "primitives_largest": int(n[large]),
            "meshes_over_10pct_near_1000": int(np.sum((share > 0.10) & (n >= 500)
                                                      & (n <= 2000))),
            "share_mean_pct": float(100 * share.mean()),
            "share_sd_pct": float(100 * share.std(ddof=1)) if len(rs) > 1 else None,
        }
    return out


def fit_spread(fits):
    """Per type, the min and max over the repeats' fits (:func:`grid_fit`) of the figures the
    timing claims read: Pearson r, ns per leaf (fit) and the mean microseconds per query; and
    per repeat whether points were the fastest type."""
    out = {}
    for kind in TYPES:
        fs = [f[kind] for f in fits if kind in f]
        if not fs:
            continue
        out[kind] = {}
        for key in ("pearson_r", "ns_per_leaf_fit", "us_per_query_mean"):
            v = [f[key] for f in fs if f.get(key) is not None]
            out[kind][key] = [min(v), max(v)] if v else None
    out["points_fastest"] = [all(f["points"]["us_per_query_mean"] < f[k]["us_per_query_mean"]
                                 for k in ("edges", "triangles") if k in f)
                             for f in fits if "points" in f]
    return out


def thingi10k_folder(progress=None):
    """The folder of the 12 Thingi10K meshes (:mod:`tracer.datasets`: a local copy, the cache,
    or downloaded and checked), or the one-line reason why not."""
    try:
        return datasets.group_folder("thingi10k", progress=progress), None
    except datasets.DataUnavailable as exc:
        return None, str(exc)


def grid(out, s, where):
    """The grid benchmark (``tracer bench-grid``) over the shipped meshes, the 12 Thingi10K
    meshes (fetched on first use) and generated height fields of 1e2.. primitives; the fit.
    Where the settings ask for Thingi10K and it cannot be had, nothing is measured: the
    result says which data is missing, and the claims say "not run" rather than judging
    another mesh set."""
    sets = [("shipped", REPO / "scenes" / "data" / "meshes")]
    if s["thingi10k"]:
        thingi, why = thingi10k_folder(progress=print)
        if thingi is None:
            return {"grid": s["grid"], "alpha": 1.0, "beta": 0.5, "missing_data": ["thingi10k"],
                    "missing_why": why}
        sets.append(("thingi10k", thingi))
    tmp = tempfile.mkdtemp(prefix="reproduce-meshes-")
    try:
        gen = Path(tmp)
        made = {f"grid_{n:07d}.off": heightfield_off(gen / f"grid_{n:07d}.off", n)
                for n in s["generated"]}
        sets.append(("generated", gen))
        rows = []
        fits = []
        for i in range(int(s.get("repeat", 1))):  # repeat 0: the figures; the others: spread
            rep = []
            for name, folder in sets:
                dest = out / name if i == 0 else out / f"repeat{i}" / name
                run_command(["bench-grid", str(folder), "-o", str(dest), "--grid",
                             str(s["grid"]), "--overwrite", "-q", *runner_args(where)])
                for r in read_csv(dest / "bench_grid.csv"):
                    if r.get("status", "ok") == "ok":
                        rep.append(dict(r, set=name))
            if i == 0:
                rows = rep
            fits.append(grid_fit(rep, s["grid"]))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    threads = sorted({int(r["threads"]) for r in rows if isinstance(r.get("threads"), float)})
    bench_plots(out, rows, {"grid": s["grid"], "alpha": 1.0, "beta": 0.5,  # every set together
                            "threads": "/".join(map(str, threads)) or "?"})
    return {"grid": s["grid"], "alpha": 1.0, "beta": 0.5,
            "sets": [n for n, _ in sets], "generated_triangles": sorted(made.values()),
            "thingi10k_present": any(n == "thingi10k" for n, _ in sets), "meshes": len(rows),
            "fit": fits[0], "repeat": len(fits), "fit_spread": fit_spread(fits),
            "csv": [f"grid/{n}/bench_grid.csv" for n, _ in sets]}


# ============================================================================ Table 3
class _Timed:
    """A MeshDistance whose smooth evaluations (``__call__``, ``with_couple``) are timed."""

    def __init__(self, md, log):
        self._md, self._log = md, log

    def __getattr__(self, name):
        return getattr(self._md, name)

    def _timed(self, f, *a, **k):
        t0 = time.perf_counter()
        r = f(*a, **k)
        self._log.append(time.perf_counter() - t0)
        return r

    def __call__(self, *a, **k):
        return self._timed(self._md, *a, **k)

    def with_couple(self, *a, **k):
        return self._timed(self._md.with_couple, *a, **k)


def _timed_run(path, steps, cap, threads):
    """One simulation at ``threads`` numba threads (at most the process's); the mean and
    median milliseconds of its smooth distance evaluations."""
    # tracer.sim's run and files (scipy, sim extra): loaded on use
    from tracer.sim import run as simrun
    from tracer.sim.constraint import mesh_distance_factory
    from tracer.sim.simfile import load_simulation

    before = numba.get_num_threads()
    n = min(int(threads or numba.config.NUMBA_NUM_THREADS), numba.config.NUMBA_NUM_THREADS)
    t0 = time.perf_counter()
    sim = load_simulation(path)
    load_s = time.perf_counter() - t0
    log = []
    cls = mesh_distance_factory()

    def factory(*a, **k):
        return _Timed(cls(*a, **k), log)

    steps = sim.steps if steps is None else int(steps)
    steps = min(steps, cap or steps)
    numba.set_num_threads(n)
    try:
        con, integ = simrun.build(sim, factory)
        # warm-up: compile (or load) every kernel the run calls before timing anything
        X = np.array([b.x for b in sim.bodies])
        Rs = np.array([b.R for b in sim.bodies])
        for p in con.pairs:
            R, t = p.relative(X, Rs)
            p.md(R, t)
            if hasattr(p.md, "with_couple"):
                p.md.with_couple(R, t)
        con.evaluate(X, Rs, gradient=False)
        con.evaluate(X, Rs)
        del log[:]
        load0 = os.getloadavg()[0] if hasattr(os, "getloadavg") else None
        t0 = time.perf_counter()
        with tempfile.TemporaryDirectory() as tmp:
            frames = simrun.simulate(sim, os.path.join(tmp, "trajectory.npz"), steps=steps,
                                     built=(con, integ))
        wall = time.perf_counter() - t0
        # the exact distance between any two bodies at every step (the simulator computes it
        # for its trajectory anyway): positive throughout means no interpenetration
        dmin = np.asarray(frames["min_exact_distance"], dtype=float)
    finally:
        numba.set_num_threads(before)
    ev = np.array(log)
    return sim, steps, {
        "threads": n, "evaluations": int(ev.size),
        "ms_mean": float(1e3 * ev.mean()) if ev.size else None,
        "ms_median": float(1e3 * np.median(ev)) if ev.size else None,
        "ms_p10": float(1e3 * np.percentile(ev, 10)) if ev.size else None,
        "ms_p90": float(1e3 * np.percentile(ev, 90)) if ev.size else None,
        "ms_max": float(1e3 * ev.max()) if ev.size else None,
        "simulate_seconds": round(wall, 3), "load_seconds": round(load_s, 3),
        "load_average_before": None if load0 is None else round(load0, 2),
        "load_average_after": load_average(),
        "frames": int(dmin.size), "min_exact_distance": float(dmin.min()) if dmin.size else None,
        "bodies": [{"name": b.name, "kind": b.kind, "primitives": int(b.mesh.num_primitives),
                    "static": bool(b.static)} for b in sim.bodies]}


def _authors_bench():
    """``benchmarks/bench_authors_sim.py`` as a module (its ``prepared_copy`` and
    ``run_theirs``: the same file, meshes and step count for their simulator as for ours)."""
    spec = importlib.util.spec_from_file_location(
        "_bench_authors_sim", REPO / "benchmarks" / "bench_authors_sim.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


#: the authors' simulator runs on this many threads (the project machine's cores)
AUTHORS_THREADS = 2


def authors_run(path, steps, binary, timeout):
    """The authors' ``rigid_body_simulator`` on the simulation file ``path`` for ``steps``
    steps (``benchmarks/authors/README.md``), in a scratch
    folder: their mean milliseconds per distance evaluation (one ``meshDistance`` call: the
    lines of their ``__times.txt`` files, microseconds each), the count and the wall time; or
    why not."""
    bench = _authors_bench()
    load0 = round(os.getloadavg()[0], 2) if hasattr(os, "getloadavg") else None
    with tempfile.TemporaryDirectory() as tmp:
        sim_path, spec = bench.prepared_copy(path, tmp, steps)
        try:
            wall, _, n, us = bench.run_theirs(binary, sim_path, spec, AUTHORS_THREADS, timeout)
        except subprocess.TimeoutExpired:
            return {"status": f"did not finish within {timeout:.0f} s", "steps": steps,
                    "threads": AUTHORS_THREADS}
        except (OSError, subprocess.CalledProcessError, RuntimeError) as exc:
            return {"status": f"failed: {str(exc).splitlines()[0] if str(exc) else exc!r}",
                    "steps": steps, "threads": AUTHORS_THREADS}
    return {"status": "ok", "steps": steps, "threads": AUTHORS_THREADS, "evaluations": n,
            "ms_mean": us / 1e3 if n else None, "wall_seconds": round(wall, 2),
            "load_average_before": load0}


def table3_task(task):
    """One Table 3 simulation, run once per entry of ``threads`` (None: all of the process's
    numba threads): ``steps`` steps (the file's when None, at most ``cap``); per run the mean
    and median milliseconds of one smooth distance evaluation (distance and every query
    vertex's gradient) over the whole run. Every kernel is called once at the initial state
    before a run, so compilation is not timed."""
    most = numba.config.NUMBA_NUM_THREADS  # 1 in a Dask worker
    counts = list(dict.fromkeys(min(int(t or most), most) for t in task["threads"]))
    runs = []
    for threads in counts:
        sim, steps, r = _timed_run(task["path"], task["steps"], task.get("cap"), threads)
        runs.append(r)
    out = {"scene": task["key"], "steps": steps, "file_steps": int(sim.steps), "dt": sim.dt,
           "runs": runs}
    if task.get("authors_bin"):  # their simulator, same file and steps, after ours
        out["authors"] = authors_run(task["path"], steps, task["authors_bin"],
                                     task.get("authors_timeout", 3600.0))
    return out


def table3(out, s, where):
    """The paper's Table 3 simulations, each a task on the runner."""
    caps = s.get("step_caps", {})
    authors = where.get("authors_bin")
    skip = set(s.get("authors_skip", ()))
    tasks = [{"key": n, "path": str(TABLE3 / f"{n}.json"), "steps": s["steps"],
              "cap": caps.get(n), "threads": s["threads"], "weight": 1.0,
              "authors_bin": authors if authors and n not in skip else None,
              "authors_timeout": float(s.get("authors_timeout", 3600.0))}
             for n in s["scenes"]]
    rows = {}
    failed = []
    info = runner.run_study(table3_task, tasks,
                            on_result=lambda t, r: rows.__setitem__(t["key"], r),
                            on_failure=lambda t, e: failed.append((t["key"], e)),
                            scheduler=where["scheduler"], workers=where.get("workers"),
                            label="table3", quiet=True,
                            estimate=30.0 * len(tasks))
    if failed:
        raise RuntimeError(f"table3: {failed[0][0]} failed: {failed[0][1]}")
    out.mkdir(parents=True, exist_ok=True)
    for n, r in rows.items():
        row, data, query, paper_ms, dt = TABLE3_PAPER[n]
        r.update(paper_row=row, data=data, query=query, paper_ms_28_threads=paper_ms,
                 paper_dt=dt)
    stamp = provenance()
    for r in rows.values():  # each row says when and from which commit it ran
        r["run"] = {"date": stamp["date"], "commit": stamp["commit"]}
    write_json(out / "table3_rows.json", rows)
    return {"scenes": s["scenes"], "steps": s["steps"], "step_caps": caps,
            "scheduler": info.describe(), "rows": {n: rows[n] for n in s["scenes"]},
            "authors_simulator": ("their rigid_body_simulator (abhimadan/smoothdists a2706a2, "
                                  "CPU build of benchmarks/authors), the same "
                                  f"files and steps, {AUTHORS_THREADS} threads, after ours in "
                                  "the same task" if authors else "not run (no --authors-bin)"),
            "not_run": [n for n in TABLE3_PAPER if n not in s["scenes"]]}


def merge_table3(old, new):
    """``new`` Table 3 results with the rows of ``old`` (an earlier ``table3.json`` of the
    same results folder) for the scenes ``new`` did not run: a run of some scenes
    (``--table3-scenes``) adds to the table instead of replacing it. Kept rows keep their own
    ``run`` (date and commit; rows written before rows carried one get the old file's)."""
    prov = old.get("provenance", {})
    rows = {}
    for n in TABLE3_PAPER:
        if n in new["rows"]:
            rows[n] = new["rows"][n]
        elif n in old.get("rows", {}):
            rows[n] = dict(old["rows"][n])
            rows[n].setdefault("run", {"date": prov.get("date"), "commit": prov.get("commit")})
    merged = dict(new, rows=rows, scenes=list(rows),
                  not_run=[n for n in TABLE3_PAPER if n not in rows])
    if any(r.get("authors") for r in rows.values()) and "not run" in new["authors_simulator"]:
        merged["authors_simulator"] = old["authors_simulator"] + " (where a row has a figure)"
    return merged


# ============================================================================ box test
def box_cases():
    """The box test's cases: Table 3's whole-mesh pairs with edge and triangle queries, the
    query at an exact gap of 1 / alpha from the data (as ``benchmarks/bench_mesh_distance.py``
    places them). ``{name: (data (V, F), query (V, F), alpha, start, direction)}``."""
    bunny = DataMesh.load(BUNNY)
    sl_V, sl_E = slide_edges()
    tref_V, tref_E = trefoil_100(REPO / "scenes" / "data" / "curves" / "trefoil.obj")
    # thread the trefoil's central hole on the peg at the origin
    tref_V = tref_V - [tref_V[:, 0].mean(), 0.0, tref_V[:, 2].mean()]
    down = np.array([0.0, -1.0, 0.0])
    return {
        "ring-toss": ((ring_toss_points(), None), (tref_V, tref_E), 20.0,
                      np.array([0.0, 1.2, 0.0]), down),
        "bowl-ico": (bowl_edges(), icosphere_edges(), 50.0, np.array([0.0, 0.5, 0.0]), down),
        "slide-sphere": ((sl_V, sl_E), uv_sphere(), 100.0,
                         sl_V[24 * 7 + 3] + np.array([0.0, 1.0, 0.0]), down),
        "bunny-bunny": ((bunny.V, bunny.triangles), (bunny.V, bunny.triangles), 200.0,
                        np.array([0.0, 0.3, 0.0]), down),
    }


def box_test(out, s, where):
    """Sec. 3.5's box test on / off: the whole-mesh smooth distance (``MeshDistance``, beta 0.5)
    with the paper's cheap box test (``box_test=True``, the default) and with the exact
    primitive-box distance it avoids (``box_test=False``), timed back to back in one process
    (alternating, median of ``repeat``). Both must be conservative (at most the beta = 0 value
    per query primitive) and differ by no more than the Barnes-Hut error of the two (the
    tolerance ``tests/smoothdist/test_box_test.py`` documents); the run fails otherwise."""
    specs = box_cases()
    res = {"beta": 0.5, "repeat": s["repeat"], "cases": {}}
    for name in s["cases"]:
        data, query, alpha, start, direction = specs[name]
        on = MeshDistance(data, query, alpha=alpha, alpha_q=alpha, beta=0.5)
        off = MeshDistance(on.field, query, alpha=alpha, alpha_q=alpha, beta=0.5,
                           box_test=False)
        exact = MeshDistance(on.field, query, alpha=alpha, alpha_q=alpha, beta=0.0)
        t = on.translation_at_gap(1.0 / alpha, direction, start)
        d = {}
        for key, md in (("on", on), ("off", off), ("beta0", exact)):
            d[key] = md.primitive_distances(t=t)[0]  # also compiles the kernels, untimed
            d[key + "_leaves"] = float(md.last_stats[1].mean())
        scale = 1e-12 * max(1.0, float(np.abs(d["beta0"]).max()))
        conservative = bool(np.all(d["on"] <= d["beta0"] + scale)
                            and np.all(d["off"] <= d["beta0"] + scale))
        bh_err = d["beta0"] - np.minimum(d["on"], d["off"])
        within = bool(np.all(np.abs(d["on"] - d["off"]) <= bh_err + scale))
        if not (conservative and within):
            raise RuntimeError(f"box_test {name}: the box test on and off disagree beyond the "
                               "Barnes-Hut error (or one is not conservative)")
        times = {"on": [], "off": []}
        for _ in range(s["repeat"]):
            for key, md in (("on", on), ("off", off)):
                t0 = time.perf_counter()
                md(t=t)
                times[key].append(time.perf_counter() - t0)
        ms_on, ms_off = (1e3 * float(np.median(times[k])) for k in ("on", "off"))
        q = on.query
        res["cases"][name] = {
            "data_primitives": on.field.num_primitives, "data_kind": on.field.mesh.kind,
            "query_primitives": int(q.kind.size),
            "query_kind": ["points", "edges", "triangles"][int(q.kind.max())],
            "alpha": alpha, "ms_on": ms_on, "ms_off": ms_off, "speedup": ms_off / ms_on,
            "ms_on_all": [1e3 * x for x in times["on"]],
            "ms_off_all": [1e3 * x for x in times["off"]],
            "leaves_on": d["on_leaves"], "leaves_off": d["off_leaves"],
            "leaves_beta0": d["beta0_leaves"],
            "max_abs_diff_x_alpha": float(alpha * np.abs(d["on"] - d["off"]).max()),
            "max_bh_error_x_alpha": float(alpha * bh_err.max()),
            "conservative": conservative, "within_bh_error": within}
    res["threads"] = int(__import__("numba").get_num_threads())
    return res


# ============================================================================ underestimate
def underestimate(out, s, where):
    """Sec. 3 and App. A: ``0 <= d - d_hat <= log(A N) / alpha`` at random queries around the
    bunny, per type, at beta 0 and 0.5 (exact distance from the library's exact query); and
    the largest and mean gap at beta 0 for each of ``alphas`` (Sec. 3.1: more accurate as
    alpha grows)."""
    mesh = DataMesh.load(BUNNY)
    lo, hi = mesh.V.min(0), mesh.V.max(0)
    diag = float(np.linalg.norm(hi - lo))
    rng = np.random.default_rng(s["seed"])
    Q = rng.uniform(lo - 0.1 * diag, hi + 0.1 * diag, (s["queries"], 3))
    res = {"mesh": "scenes/data/bunny.off", "queries": s["queries"], "seed": s["seed"],
           "alpha": s["alpha"], "types": {}}
    for kind in TYPES:
        f = SmoothDistanceField(mesh.as_kind(kind))
        d, _ = f.exact_distance(Q)
        bound = f.inflation(s["alpha"])
        row = {"primitives": f.num_primitives, "bound": bound}
        for b in (0.0, 0.5):
            dh, _ = f.smooth_distance(Q, alpha=s["alpha"], beta=b)
            gap = d - dh
            row[f"beta_{b:g}"] = {"min_gap": float(gap.min()), "max_gap": float(gap.max()),
                                  "over_bound": int(np.sum(gap > bound * (1 + 1e-12))),
                                  "negative": int(np.sum(gap < -1e-12 * np.maximum(1, d)))}
        row["by_alpha"] = {}  # Sec. 3.1: more accurate as alpha grows (beta 0)
        for a in s.get("alphas", ()):
            gap = d - f.smooth_distance(Q, alpha=a, beta=0.0)[0]
            row["by_alpha"][f"{a:g}"] = {"max_gap": float(gap.max()),
                                         "mean_gap": float(gap.mean())}
        res["types"][kind] = row
    return res


# ============================================================================ Sec. 3 checks
def _lse_distance(d, w, alpha):
    """``-log(sum w exp(-alpha d)) / alpha`` per row of ``d (n, k)``, shifted (stable)."""
    m = d.min(axis=1, keepdims=True)
    return m[:, 0] - np.log(np.sum(w * np.exp(-alpha * (d - m)), axis=1)) / alpha


def bh_centre(out, s, where):
    """Sec. 3.5: the far field of a cluster placed at its box's closest point can only
    underestimate the cluster's smooth distance; placed at its centre of mass it can
    overestimate. Independent of the library: clusters of the lion scan's points (each the
    ``cluster`` nearest neighbours of a random point), queries 2-6 cluster radii away, the
    three LogSumExps in numpy; then the library's own Barnes-Hut (beta 0.5) against beta 0 at
    random queries around the scan."""
    import trimesh  # the PLY reader: an optional extra (NEEDS), loaded on use

    P = np.asarray(trimesh.load(DEFAULT_LION).vertices, float)
    P = (P - P.min(0)) / np.linalg.norm(np.ptp(P, 0))
    rng = np.random.default_rng(s["seed"])
    over_box = over_com = 0
    worst_com = 0.0
    n = 0
    for _ in range(s["clusters"]):
        c = P[rng.integers(len(P))]
        C = P[np.argsort(np.linalg.norm(P - c, axis=1))[:s["cluster"]]]
        lo, hi, com = C.min(0), C.max(0), C.mean(0)
        r = float(np.linalg.norm(hi - lo)) / 2 + 1e-12
        u = rng.normal(size=(s["queries"], 3))
        Q = com + u / np.linalg.norm(u, axis=1, keepdims=True) * r * rng.uniform(2, 6, (
            s["queries"], 1))
        for alpha in s["alphas"]:
            a = alpha / r  # alpha in units of the cluster's size
            exact = _lse_distance(np.linalg.norm(Q[:, None] - C[None], axis=2), 1.0, a)
            box = np.linalg.norm(Q - np.clip(Q, lo, hi), axis=1) - np.log(len(C)) / a
            com_d = np.linalg.norm(Q - com, axis=1) - np.log(len(C)) / a
            tol = 1e-12 * np.maximum(1.0, np.abs(exact))
            over_box += int(np.sum(box > exact + tol))
            over_com += int(np.sum(com_d > exact + tol))
            worst_com = max(worst_com, float(np.max((com_d - exact) * a)))
            n += len(Q)
    field, _ = normalised_field(DEFAULT_LION)
    lo, hi = field.bounds
    Q = rng.uniform(lo - 0.1 * (hi - lo), hi + 0.1 * (hi - lo), (s["library_queries"], 3))
    d0, _ = field.smooth_distance(Q, alpha=100.0, beta=0.0)
    d5, _ = field.smooth_distance(Q, alpha=100.0, beta=0.5)
    return {"cloud": "scenes/data/pointclouds/scan_guardian_lion_points.ply",
            "clusters": s["clusters"], "cluster": s["cluster"], "alphas": s["alphas"],
            "evaluations": n, "box_over": over_box, "com_over": over_com,
            "com_worst_over_x_alpha": worst_com, "library_queries": s["library_queries"],
            "library_over": int(np.sum(d5 > d0 + 1e-12 * np.maximum(1, np.abs(d0)))),
            "library_max_under": float(np.max(d0 - d5))}


def _flat_sheet(n):
    """A unit square of ``n x n`` cells, each split into two triangles: ``(V, F)``."""
    g = np.linspace(0.0, 1.0, n + 1)
    x, y = np.meshgrid(g, g, indexing="ij")
    V = np.stack([x.ravel(), y.ravel(), np.zeros(x.size)], 1)
    i = np.arange(n)[:, None] * (n + 1) + np.arange(n)[None, :]
    i = i.ravel()
    F = np.concatenate([np.stack([i, i + n + 1, i + 1], 1),
                        np.stack([i + 1, i + n + 1, i + n + 2], 1)])
    return V, F


def bulges(out, s, where):
    """Sec. 3.3: the weight functions remove the bulges of edge and triangle isosurfaces. On a
    flat sheet of triangles and a straight polyline of equal segments, at a fixed height above
    the data, the smooth distance above an interior vertex (a joint) against above the middle
    of a triangle (a segment): the bulge is how much closer the vertex looks (times alpha:
    ``log`` of the number of primitives counted there, unweighted), with the paper's weights
    and with all weights 1."""
    n, h = s["cells"], s["height_x_alpha"] / s["alpha"]
    V, F = _flat_sheet(n)
    inner = (V[:, 0] > 0) & (V[:, 0] < 1) & (V[:, 1] > 0) & (V[:, 1] < 1)
    line = np.stack([np.linspace(0, 1, n + 1), np.zeros(n + 1), np.zeros(n + 1)], 1)
    E = np.stack([np.arange(n), np.arange(1, n + 1)], 1)
    cases = {"triangles": (DataMesh(V, triangles=F), V[inner], V[F].mean(1)),
             "edges": (DataMesh(line, edges=E), line[1:-1], line[E].mean(1))}
    res = {"alpha": s["alpha"], "height_x_alpha": s["height_x_alpha"], "cells": n,
           "types": {}}
    for kind, (mesh, joints, middles) in cases.items():
        weighted = SmoothDistanceField(mesh, weights="paper")
        row = {"primitives": int(weighted.num_primitives)}
        for name, f in (("weights", weighted), ("weights_off", unweighted_field(weighted))):
            dj, _ = f.smooth_distance(joints + [0, 0, h], alpha=s["alpha"], beta=0.0)
            dm, _ = f.smooth_distance(middles + [0, 0, h], alpha=s["alpha"], beta=0.0)
            row[name] = {"bulge_x_alpha": float((dm.mean() - dj.mean()) * s["alpha"])}
        res["types"][kind] = row
    return res


def quadrature(out, s, where):
    """Sec. 3.2 (Fig. quadrature): LogSumExp over Gauss quadrature points of an edge, with the
    quadrature weights, overestimates the distance at low alpha (it is no longer
    conservative); over the exact distances to the primitives with weights >= 1 it never does.
    One unit edge, queries around it, numpy only."""
    x, w = np.polynomial.legendre.leggauss(s["order"])
    nodes = np.stack([(x + 1) / 2, np.zeros_like(x), np.zeros_like(x)], 1)
    rng = np.random.default_rng(s["seed"])
    Q = rng.uniform([-0.5, -1, -1], [1.5, 1, 1], (s["queries"], 3))
    exact = np.linalg.norm(Q - np.clip(Q, [0, 0, 0], [1, 0, 0]), axis=1)
    res = {"order": s["order"], "queries": s["queries"], "alphas": {}}
    for alpha in s["alphas"]:
        dq = _lse_distance(np.linalg.norm(Q[:, None] - nodes[None], axis=2), w / 2, alpha)
        ours = _lse_distance(exact[:, None], 1.0, alpha)
        res["alphas"][f"{alpha:g}"] = {
            "quadrature_over": int(np.sum(dq > exact + 1e-12)),
            "quadrature_max_over": float(np.max(dq - exact)),
            "lse_over": int(np.sum(ours > exact + 1e-12))}
    return res


def vbowl(out, s, where):
    """Sec. 5.5 (the V-shaped bowls): a point mass dropped into a V-shaped bowl with the
    exact-minimum and the smooth constraint (:mod:`tracer.sim.vbowl`, the same integrator and
    solver)."""
    from tracer.sim import vbowl as vb  # the simulator needs scipy (NEEDS), loaded on use

    runs = {f"{b}/{m}": vb.summary(vb.run(b, m, steps=s["steps"]))
            for b in vb.BOWLS for m in ("exact", "smooth")}
    return {"alpha": vb.ALPHA, "alpha_u": vb.ALPHA_U, "dt": vb.DT, "steps": s["steps"],
            "runs": runs}


# ============================================================================ GPU (App. E)
#: the last measurement on a CUDA card committed to the repository (``benchmarks/run_on_card.sh``)
GPU_CARD_RESULT = REPO / "benchmarks" / "data" / "gpu_h100.json"


def _card_available():
    try:
        return not simulated() and cuda_module() is not None
    except CudaUnavailable:
        return False


def _gpu_summary(bench, source, measured):
    """The claim's figures from a ``benchmarks/bench_gpu.py`` JSON: per type the grid's
    CPU, GPU (with copies) and GPU kernel times (ms) and the render's."""
    rows = {r["what"]: r for r in bench["rows"]}
    res = {"source": source, "measured": measured, "card": bench.get("card"),
           "cpu": bench.get("cpu"), "cpu_threads": bench.get("threads"), "grid": {},
           "render": {}}
    for kind in TYPES:
        g, r = rows[f"grid {kind}"], rows[f"bunny {kind}"]
        res["grid"][kind] = {
            "queries": g["size"], "primitives": g["primitives"], "cpu_ms": 1e3 * g["cpu_s"],
            "gpu_ms": 1e3 * g["gpu_s"], "gpu_kernel_ms": 1e3 * g["gpu_kernel_s"],
            "speedup": g["cpu_s"] / g["gpu_s"], "kernel_speedup": g["cpu_s"] / g["gpu_kernel_s"],
            "max_abs_diff": g.get("distance_max_diff")}
        res["render"][kind] = {"size": r["size"], "cpu_ms": 1e3 * r["cpu_s"],
                               "gpu_ms": 1e3 * r["gpu_s"], "speedup": r["cpu_s"] / r["gpu_s"],
                               "hit_differs": r.get("hit_differs")}
    return res


def gpu(out, s, where):
    """App. E: the smooth distance of the paper's benchmark grid (and the bunny's render) on a
    CUDA GPU against all the CPU's threads, on the same machine. With a card here,
    ``benchmarks/bench_gpu.py`` runs at the mode's sizes; without one, the last card
    measurement committed to the repository (:data:`GPU_CARD_RESULT`) is read, with the date
    and commit git gives it (``source`` says which)."""
    bench_py = REPO / "benchmarks" / "bench_gpu.py"
    if _card_available() and bench_py.is_file():
        path = Path(out) / "bench_gpu.json"
        path.parent.mkdir(parents=True, exist_ok=True)
        argv = [sys.executable, str(bench_py), "--size", *map(str, s["size"]),
                "--grid", str(s["grid"]), "--repeat", str(s["repeat"]), "--json", str(path)]
        subprocess.run(argv, cwd=REPO, check=True)
        bench = json.loads(path.read_text(encoding="utf-8"))
        prov = provenance()
        return _gpu_summary(bench, "measured here", {"date": prov["date"],
                                                     "commit": prov["commit"]})
    if not GPU_CARD_RESULT.is_file():
        return {"source": None, "why": "no CUDA GPU here and no committed card measurement"}
    bench = json.loads(GPU_CARD_RESULT.read_text(encoding="utf-8"))
    rel = str(GPU_CARD_RESULT.relative_to(REPO))
    when = git_output("log", "-1", "--format=%cI %H", "--", rel).split()
    measured = {"date": when[0] if when else None, "commit": when[1] if when else None}
    return _gpu_summary(bench, rel, measured)


#: name -> experiment, in the order they run (quick first where they are quick)
EXPERIMENTS = {"underestimate": underestimate, "table3": table3, "grid": grid,
               "bh_switch": bh_switch, "box_test": box_test, "gpu": gpu, "beta": beta,
               "alpha": alpha, "beta_alpha": beta_alpha, "attenuation": attenuation,
               "bh_centre": bh_centre, "bulges": bulges, "quadrature": quadrature,
               "vbowl": vbowl}
#: name -> the optional packages the experiment imports (``tracer reproduce`` checks them
#: before it runs anything): the studies' plots and images, the simulator's solver, trimesh
#: for the PLY scans (the lion, the Autzen tile), the generated icospheres and Thingi10K's STLs
NEEDS = {"underestimate": (), "table3": ("scipy", "trimesh"),
         "grid": ("matplotlib", "PIL", "trimesh"),
         "bh_switch": ("matplotlib", "PIL", "trimesh", "scipy"),
         "box_test": ("trimesh",), "gpu": (), "beta": ("matplotlib", "PIL"),
         "alpha": ("matplotlib", "PIL", "trimesh"), "beta_alpha": ("matplotlib", "PIL"),
         "attenuation": (), "bh_centre": ("trimesh",), "bulges": (), "quadrature": (),
         "vbowl": ("scipy",)}
