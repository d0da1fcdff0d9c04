"""Side-by-side render benchmark: ours against the authors' C++ renderer, in the same run.

The setup is the authors' ``app/beta_error_test.cpp`` (Madan & Levin 2022, beta study): the
bunny (``scenes/data/bunny.off``) as points, edges and triangles, alpha 200, alpha_U 1200,
beta 0.5, hit threshold eps = 1e-3 (absolute, the authors' value), the camera at the bbox
centre + 2 x the largest extent along +z, 2 threads each. Their number is their own timer
(per-pixel sphere tracing only); ours is the wall time of one ``tracer.render`` call
(tracing, setup and shading: it can only flatter them). Each size is run ``--repeat`` times,
theirs and ours alternating, and the best of each is kept, so that a shared machine's load
hits both sides alike; the load average is printed before and after.

Optional extra columns (ours only, against the same authors' beta 0.5 time):

* ``--our-eps``: ours at our default eps (1e-4 of the bbox diagonal, 40x tighter);
* ``--tol T``: ours at beta 0 with tolerance-controlled pruning ``tol = T`` and our default
  eps (its accuracy against beta 0 is measured by ``benchmarks/bench_tol.py``);
* ``--authors-beta0`` (with ``--authors-bin`` and ``--tol``): the authors' beta 0 render as
  well, once per size (minutes at 512²), and the ratio of our ``tol`` render to it: the
  comparison at the same accuracy class (their beta 0 is exact up to their eps, 1e-3
  absolute; ours is within ``log(1 + T) / alpha`` of beta 0, at a 40x tighter eps).

The authors' renderer is not part of this project. Build it yourself from their public
repository (MIT) for this comparison only: ``benchmarks/authors/README.md``, or in short: their
sources at commit a2706a2 and libigl v2.4.0 headers, Eigen 3.4, a patch that makes
``beta_error_test`` read ``SD_RES`` / ``SD_BETAS`` from the environment and use 2 threads,
and a CPU-only Release build. Pass the binary with ``--authors-bin``. Without it, this
prints our column next to the side-by-side figures published in the issue (provenance
below).

Usage::

    python benchmarks/bench_authors.py --authors-bin ~/authors-bench/build/beta_error_test
    python benchmarks/bench_authors.py --sizes 256 --repeat 1          # ours + published
    python benchmarks/bench_authors.py --authors-bin BIN --our-eps --tol 3e-3
    python benchmarks/bench_authors.py --authors-bin BIN --sizes 256 --tol 3e-3 --authors-beta0
"""

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run from a checkout without installing
    sys.path.insert(0, str(ROOT))

import numba  # noqa: E402

import smoothdist  # noqa: E402
from smoothdist import SmoothDistanceField  # noqa: E402
from tracer.rendering.renderer import render  # noqa: E402
from tracer.scenes.scene import scene_from_field  # noqa: E402

TYPES = ("points", "edges", "triangles")
THEIR_NAMES = {"point": "points", "edge": "edges", "face": "triangles"}
ALPHA, ALPHA_U, BETA, EPS = 200.0, 1200.0, 0.5, 1e-3
MESH = ROOT / "scenes" / "data" / "bunny.off"
#: side-by-side figures published in the issue: size -> type -> (authors s, ours s)
PUBLISHED = {
    256: {"points": (1.48, 0.67), "edges": (2.37, 1.27), "triangles": (2.63, 1.61)},
    512: {"points": (6.33, 2.40), "edges": (9.33, 5.03), "triangles": (10.46, 6.72)},
}
PUBLISHED_NOTE = ("Published figures (issue 10): measured side by side on a quiet 2-core "
                  "machine, 2 threads each, bunny alpha 200, alpha_U 1200, beta 0.5, eps 1e-3 "
                  "(absolute); ours = render() seconds, theirs = their render timer.")


def paper_camera(V):
    """Bbox centre + 2 x largest extent along +z, looking at the centre, up +y."""
    import numpy as np

    lo, hi = V.min(axis=0), V.max(axis=0)
    c = 0.5 * (lo + hi)
    return c + np.array([0.0, 0.0, 2.0 * float((hi - lo).max())]), c, np.array([0.0, 1.0, 0.0])


def their_output(binary, size, betas, timeout=3600):
    """The standard output of one run of the authors' ``beta_error_test`` at ``size``² and
    ``betas``. It reads ``../data/bunny.off`` relative to its working folder, so it runs in a
    temporary folder with a copy of the bunny, and writes its ``t-*.dmat`` files there."""
    with tempfile.TemporaryDirectory(prefix="authors-bench-") as tmp:
        tmp = Path(tmp)
        (tmp / "data").mkdir()
        shutil.copyfile(MESH, tmp / "data" / "bunny.off")
        (tmp / "run").mkdir()
        env = dict(os.environ, SD_RES=str(size), SD_BETAS=",".join(f"{b:g}" for b in betas))
        p = subprocess.run([str(binary)], cwd=tmp / "run", env=env, capture_output=True,
                           text=True, timeout=timeout)
    if p.returncode != 0:
        raise RuntimeError(f"{binary} failed with status {p.returncode}: "
                           f"{(p.stderr or p.stdout).strip()[-300:]}")
    return p.stdout


def run_authors(binary, size, beta=BETA, workdir=None):
    """Run the authors' ``beta_error_test`` once at one beta; returns ``{type: seconds}``."""
    text = their_output(binary, size, [beta])
    out = {}
    for m in re.finditer(r"(point|edge|face) render took ([0-9.eE+-]+)s", text):
        out[THEIR_NAMES[m.group(1)]] = float(m.group(2))
    if f"res={size}x{size} threads=2" not in text or len(out) != 3:
        raise RuntimeError(f"{binary}: unexpected output (is it the patched beta_error_test "
                           f"with SD_RES / 2 threads?):\n{text[-500:]}")
    return out


def run_ours(fields, camera, size, beta, eps, tol=0.0):
    """One render per type; returns ``{type: (wall seconds, mean leaves per pixel)}``."""
    out = {}
    for kind, field in fields.items():
        scene = scene_from_field(field, alpha=ALPHA, alpha_u=ALPHA_U, beta=beta, tol=tol,
                                 camera=camera, width=size, height=size, eps=eps)
        t0 = time.perf_counter()
        res = render(scene)
        out[kind] = (time.perf_counter() - t0, float(res.leaves.mean()))
    return out


def best(runs, kind):
    vals = [r[kind] for r in runs]
    return min(vals, key=lambda v: v[0] if isinstance(v, tuple) else v)


def load():
    try:
        return "load average %.2f / %.2f / %.2f" % os.getloadavg()
    except OSError:
        return "load average unknown"


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--authors-bin", metavar="PATH",
                   help="the authors' patched beta_error_test binary (omit: published figures)")
    p.add_argument("--sizes", type=int, nargs="+", default=[256, 512], metavar="N")
    p.add_argument("--types", nargs="+", choices=TYPES, default=list(TYPES))
    p.add_argument("--repeat", type=int, default=3,
                   help="alternating runs per size, best kept (default 3)")
    p.add_argument("--threads", type=int, default=2, help="our numba threads (default 2, "
                   "as theirs)")
    p.add_argument("--our-eps", action="store_true",
                   help="also time ours at our default eps (1e-4 x bbox diagonal)")
    p.add_argument("--tol", type=float, default=None, metavar="T",
                   help="also time ours at beta 0 with tol T, at our default eps")
    p.add_argument("--authors-beta0", action="store_true",
                   help="with --authors-bin and --tol: also time the authors' beta 0 render "
                        "(once per size) and compare our tol render with it")
    args = p.parse_args(argv)
    if args.repeat < 1 or any(s < 1 for s in args.sizes):
        p.error("--repeat and --sizes must be >= 1")
    if args.authors_bin and not os.access(args.authors_bin, os.X_OK):
        p.error(f"--authors-bin {args.authors_bin} is not an executable file")
    if not 1 <= args.threads <= numba.config.NUMBA_NUM_THREADS:
        p.error(f"--threads must be between 1 and {numba.config.NUMBA_NUM_THREADS}")
    if args.tol is not None and args.tol <= 0:
        p.error("--tol must be > 0")
    if args.authors_beta0 and not (args.authors_bin and args.tol is not None):
        p.error("--authors-beta0 needs --authors-bin and --tol")
    numba.set_num_threads(args.threads)

    full = smoothdist.load_mesh(MESH)
    camera = paper_camera(full.V)
    fields = {k: SmoothDistanceField(full.as_kind(k)) for k in args.types}
    our_eps = 1e-4 * next(iter(fields.values())).diagonal
    print(f"# {load()} before; {os.cpu_count()} CPUs; ours: {args.threads} numba threads; "
          f"best of {args.repeat}, theirs and ours alternating", file=sys.stderr)
    # warm up: compile or load our kernels
    run_ours(fields, camera, 16, BETA, EPS)
    if args.tol is not None:
        run_ours(fields, camera, 16, 0.0, our_eps, args.tol)

    rows = []
    for size in args.sizes:
        theirs, ours, ours_eps, ours_tol = [], [], [], []
        for rep in range(args.repeat):
            if args.authors_bin:
                theirs.append(run_authors(args.authors_bin, size))
            ours.append(run_ours(fields, camera, size, BETA, EPS))
            if args.our_eps:
                ours_eps.append(run_ours(fields, camera, size, BETA, our_eps))
            if args.tol is not None:
                ours_tol.append(run_ours(fields, camera, size, 0.0, our_eps, args.tol))
            print(f"# {size}^2 run {rep + 1}/{args.repeat} done ({load()})", file=sys.stderr,
                  flush=True)
        for kind in args.types:
            row = {"type": kind, "size": size, "ours": best(ours, kind)[0]}
            row["authors"] = (best(theirs, kind) if theirs
                              else PUBLISHED.get(size, {}).get(kind, (None,))[0])
            if ours_eps:
                row["ours_eps"] = best(ours_eps, kind)[0]
            if ours_tol:
                row["ours_tol"] = best(ours_tol, kind)[0]
            rows.append(row)
        if args.authors_beta0:
            # once per size: their beta 0 render is O(N) per evaluation (minutes at 512²)
            zero = run_authors(args.authors_bin, size, beta=0.0)
            for row in rows[-len(args.types):]:
                row["authors0"] = zero[row["type"]]
            print(f"# {size}^2 authors' beta 0 done ({load()})", file=sys.stderr, flush=True)

    src = "measured now, same machine" if args.authors_bin else "published (see note)"
    head = ["type", "size", f"authors s ({src})", "ours s", "ratio"]
    if args.our_eps:
        head += ["ours s, eps 1e-4 diag", "ratio"]
    if args.tol is not None:
        head += [f"ours s, beta 0 tol {args.tol:g}, eps 1e-4 diag", "ratio"]
    if args.authors_beta0:
        head += ["authors s, beta 0 (one run)", "ours tol / authors beta 0"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * 2 + "---:|" * (len(head) - 2)]
    for r in rows:
        a = r["authors"]
        cell = lambda x: f"{x:.2f}"
        ratio = lambda x: "-" if a is None else f"{x / a:.3f}"
        vals = [r["type"], f"{r['size']}²", "-" if a is None else cell(a), cell(r["ours"]),
                ratio(r["ours"])]
        if args.our_eps:
            vals += [cell(r["ours_eps"]), ratio(r["ours_eps"])]
        if args.tol is not None:
            vals += [cell(r["ours_tol"]), ratio(r["ours_tol"])]
        if args.authors_beta0:
            vals += [cell(r["authors0"]), f"{r['ours_tol'] / r['authors0']:.3f}"]
        lines.append("| " + " | ".join(vals) + " |")
    print(f"Bunny, alpha {ALPHA:g}, alpha_U {ALPHA_U:g}, beta {BETA:g}, eps {EPS:g} (absolute) "
          f"unless stated; {args.threads} threads each; best of {args.repeat}; ratio = ours / "
          f"authors' (below 1 is faster). {load()} after the run.")
    print()
    print("\n".join(lines))
    if not args.authors_bin:
        print()
        print(PUBLISHED_NOTE)
        print()
        print("| type | size | authors s | ours s (then) | ratio |")
        print("|---|---|---:|---:|---:|")
        for size, by_type in PUBLISHED.items():
            for kind, (a, o) in by_type.items():
                print(f"| {kind} | {size}² | {a:.2f} | {o:.2f} | {o / a:.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
