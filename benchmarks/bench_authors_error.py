"""The authors' own beta study, run here: their isosurface error at each beta, as a results file.

Their ``beta_error_test`` (built as ``benchmarks/authors/README.md`` says) renders the bunny as
points, edges and triangles at each beta of ``SD_BETAS`` (alpha 200, alpha_U 1200, their eps
1e-3 absolute, 2 threads) and prints, per beta against its beta 0 render, the mean ``|t_beta
- t_0|`` over the pixels both hit, and the bbox diagonal. This script runs it once, reads those
lines, and writes the errors in % of the diagonal (and their render times) to a JSON file:
``tracer/studies/authors_beta_error.json``, which the beta study's error plot shows as the
authors' series, at exactly the betas measured.

Usage (from the repository root; at 256² it takes tens of minutes on 2 cores, their beta 0
renders dominating)::

    python benchmarks/bench_authors_error.py --authors-bin BUILD/beta_error_test --size 256 \\
        --json tracer/studies/authors_beta_error.json
"""

import argparse
import datetime
import json
import os
import platform
import re
import sys
import time
from pathlib import Path

from bench_authors import THEIR_NAMES, their_output  # the same run of their program

BETAS = (0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0)


def parse(text, betas):
    """``(diagonal, {beta: {type: error %}}, {beta: {type: seconds}}, {beta: {type: hits}})``
    from their output: a ``beta=B...`` block of render times per beta, then the bbox diagonal,
    then a ``beta=B`` block of mean errors per beta."""
    diag = float(re.search(r"bbox diagonal=([0-9.eE+-]+)", text).group(1))
    renders, stats = text.split("bbox diagonal=", 1)
    times, errors, hits = {}, {}, {}
    for block in re.split(r"\nbeta=", "\n" + renders)[1:]:
        b = float(block.split("...", 1)[0])
        times[b] = {THEIR_NAMES[m.group(1)]: float(m.group(2)) for m in
                    re.finditer(r"(point|edge|face) render took ([0-9.eE+-]+)s", block)}
    for block in re.split(r"\nbeta=", stats)[1:]:
        b = float(block.split("\n", 1)[0])
        errors[b] = {THEIR_NAMES[m.group(1)]: 100.0 * float(m.group(2)) / diag for m in
                     re.finditer(r"avg (point|edge|face) error: ([0-9.eE+-]+|nan)", block)}
        hits[b] = {THEIR_NAMES[m.group(1)]: int(m.group(2)) for m in
                   re.finditer(r"(point|edge|face) hits \(approx & exact\): (\d+)", block)}
    errors[0.0] = {k: 0.0 for k in THEIR_NAMES.values()}  # the reference: not printed
    hits.setdefault(0.0, {})
    missing = [b for b in betas if b not in errors or len(errors[b]) != 3]
    if missing:
        raise SystemExit(f"error: no errors for beta {missing} in their output (is it the "
                         f"patched beta_error_test?):\n{text[-500:]}")
    return diag, errors, times, hits


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--authors-bin", required=True, metavar="PATH",
                    help="their patched beta_error_test")
    ap.add_argument("--size", type=int, default=256, help="image width = height (default 256)")
    ap.add_argument("--betas", default=",".join(f"{b:g}" for b in BETAS),
                    help="comma-separated, the first 0 (the reference); default 0,0.1,...,1")
    ap.add_argument("--timeout", type=float, default=7200.0, help="seconds (default 7200)")
    ap.add_argument("--json", required=True, help="write the results here")
    a = ap.parse_args(argv)
    betas = [float(b) for b in a.betas.split(",")]
    if betas[0] != 0.0 or a.size < 1:
        ap.error("--betas must start with 0 (their errors are against beta 0); --size >= 1")
    if not os.access(a.authors_bin, os.X_OK):
        ap.error(f"--authors-bin {a.authors_bin}: not an executable file")
    load0 = os.getloadavg()
    t0 = time.perf_counter()
    try:
        text = their_output(a.authors_bin, a.size, betas, a.timeout)
    except RuntimeError as exc:
        raise SystemExit(f"error: {exc}") from None
    diag, errors, times, hits = parse(text, betas)
    res = {"what": "the authors' beta_error_test (abhimadan/smoothdists a2706a2, CPU build of "
                   "benchmarks/authors), bunny, alpha 200, alpha_U 1200, eps 1e-3 absolute, "
                   "2 threads; error = mean |t_beta - t_0| over pixels both hit, % of the "
                   "bbox diagonal",
           "size": a.size, "betas": betas, "bbox_diagonal": diag,
           "error_pct": {f"{b:g}": errors[b] for b in betas},
           "hits": {f"{b:g}": hits[b] for b in betas},
           "render_seconds": {f"{b:g}": times.get(b, {}) for b in betas},
           "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
           "machine": {"cpu": platform.processor() or platform.machine(),
                       "cores": os.cpu_count()},
           "load_average_before": list(load0), "load_average_after": list(os.getloadavg()),
           "seconds": round(time.perf_counter() - t0, 1)}
    Path(a.json).write_text(json.dumps(res, indent=1) + "\n", encoding="utf-8")
    for b in betas:
        print(f"beta {b:g}: " + ", ".join(f"{k} {v:.3g} %" for k, v in errors[b].items()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
