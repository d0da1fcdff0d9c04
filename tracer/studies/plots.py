"""Plots and reports of the studies (matplotlib, Agg; imported only when a study writes them).

* :func:`beta_outputs`: time and error vs beta (with the reference numbers), error against
  time with the tol series (:func:`beta_frontier`, :func:`frontier`), the image grid,
  the per-pixel depth-difference heat maps (:func:`beta_diff_figure`) and ``report.md`` of
  ``tracer ablate-beta``;
* :func:`panel_grid_png` and :func:`alpha_report`: the labelled image grids of ``tracer
  ablate-alpha`` and their report;
* :func:`bench_plots`: the two scatter plots of ``tracer bench-grid``;
* :func:`bh_plot`: the histograms of ``tracer bh-switch``.

Figures are saved through :func:`savefig` (atomic, palette PNG when large).
"""

import io
import json
import math
import os
import textwrap
from pathlib import Path

import numpy as np

from tracer.image import load_png
from tracer.outputs import atomic_write, write_text
from tracer.studies.common import (TYPE_COLORS, TYPE_LETTER, TYPES, beta_tag, close, fmt,
                                   machine_info)

#: the authors' isosurface error at each beta they were run at (bunny, alpha 200, alpha_U
#: 1200, their ``beta_error_test``), written by ``benchmarks/bench_authors_error.py``. Errors do
#: not depend on the machine.
AUTHORS_ERROR_FILE = Path(__file__).with_name("authors_beta_error.json")

#: the authors' render times in seconds (points / edges / triangles) by image size and beta,
#: measured side by side with ours in one run: see :data:`AUTHORS_TIMES_SETUP`. Only shown
#: next to a study of the same image size and the same eps; any other study shows none.
AUTHORS_TIMES = {256: {0.5: (1.48, 2.37, 2.63)}, 512: {0.5: (6.33, 9.33, 10.46)}}
#: the hit threshold of those measurements (absolute scene units, the authors' value)
AUTHORS_EPS = 1e-3
#: how and where :data:`AUTHORS_TIMES` were measured (printed in the reports)
AUTHORS_TIMES_SETUP = ("authors' C++ (beta_error_test) run side by side with ours: quiet 2-core "
                       "machine, 2 threads each, eps 1e-3 absolute, N x N px")


def significant(value, digits=2):
    """``value`` with ``digits`` significant digits, in positional notation (``0.0031``,
    ``5.0``, ``120``): a small value keeps its digits instead of rounding to ``0.00``."""
    text = np.format_float_positional(float(value), precision=digits, fractional=False,
                                      unique=False, trim="k")
    return text[:-1] if text.endswith(".") else text


def percent(fraction, digits=2):
    """``fraction`` (of the diagonal) as a percentage with ``digits`` significant digits
    (``0.0031%``, never ``0.00%``), or "undefined" where it is not finite (too few pixels to
    measure it)."""
    return f"{significant(100 * fraction, digits)}%" if math.isfinite(fraction) else "undefined"


def has_reference(params):
    """Whether the study is the authors' own (``params["authors_reference"]``: the paper's
    bunny at alpha 200, alpha_U 1200 with their camera; parameter files written before that
    key existed: the bunny's file name). Only then do their errors and times apply."""
    return bool(params.get("authors_reference", params.get("mesh_name") == "bunny.off"))


def authors_times(params):
    """``{beta: (points, edges, triangles) seconds}`` of the authors' renderer for a study with
    ``params`` (``width``, ``height``, ``eps``), or ``{}`` unless the study is theirs
    (:func:`has_reference`) and a side-by-side measurement exists at that square size *and*
    eps."""
    if (not has_reference(params) or params["width"] != params["height"]
            or not close(float(params["eps"]), AUTHORS_EPS)):
        return {}
    return AUTHORS_TIMES.get(int(params["width"]), {})


def surfaces_of(params):
    """Per type, the beta study's ``alpha``, ``alpha_u``, ``offset`` and ``parameters`` (where
    they came from) from its ``params`` (files written before per-type parameters: the one
    ``alpha`` and ``alpha_u`` of every type)."""
    if params.get("surfaces"):
        return params["surfaces"]
    return {k: {"alpha": params["alpha"], "alpha_u": params["alpha_u"], "offset": 0.0,
                "parameters": "given"} for k in TYPES}


def type_parameters(params, kind):
    """``α=3.86, α_U=77.3`` (and the offset when it is not 0) of ``kind`` in the beta study."""
    s = surfaces_of(params).get(kind)
    if s is None:
        return ""
    return (f"α={s['alpha']:.3g}, α_U={s['alpha_u']:.3g}"
            + (f", offset {s['offset']:.3g}" if s.get("offset") else ""))


def parameters_title(params):
    """The beta study's parameters for a title: ``the paper's α=200, α_U=1200``, ``the mesh's
    auto α, α_U per type``, ``given α=40, α_U=300`` (or per type when they differ)."""
    surf = surfaces_of(params)
    sources = {s.get("parameters", "given") for s in surf.values()}
    src = sources.pop() if len(sources) == 1 else "mixed"
    alphas = {(round(s["alpha"], 9), round(s["alpha_u"], 9), s.get("offset") or 0.0)
              for s in surf.values()}
    if len(alphas) == 1:
        a, u, off = alphas.pop()
        value = f"α={a:.4g}, α_U={u:.4g}" + (f", offset {off:.3g}" if off else "")
    else:
        value = "α, α_U per type"
    who = {"paper": "the paper's", "auto": "the mesh's auto", "given": "given"}.get(src, src)
    return f"{who} {value}"


def authors_errors(params, path=AUTHORS_ERROR_FILE):
    """``{beta: (points, edges, triangles)}``, the authors' errors in % of the diagonal at the
    betas of their run (:data:`AUTHORS_ERROR_FILE`), for the authors' own study
    (:func:`has_reference`), else ``{}``: their errors were measured on their bunny, not on a
    user's mesh. ``{}`` too where no results file exists."""
    if not has_reference(params) or not Path(path).is_file():
        return {}
    with open(path, encoding="utf-8") as fh:
        res = json.load(fh)
    return {float(b): tuple(e[k] for k in TYPES) for b, e in res["error_pct"].items()}


def _beta_span(betas):
    """``0-1 every 0.1`` for an evenly spaced list, else the values."""
    steps = {round(b - a, 9) for a, b in zip(betas, betas[1:])}
    if len(betas) > 3 and len(steps) == 1:
        return f"{betas[0]:g}-{betas[-1]:g} every {steps.pop():g}"
    return ", ".join(f"{x:g}" for x in betas)


def authors_error_size(path=AUTHORS_ERROR_FILE):
    """The image size the authors' errors were measured at (None without a results file)."""
    if not Path(path).is_file():
        return None
    with open(path, encoding="utf-8") as fh:
        return json.load(fh)["size"]


#: the paper's Barnes-Hut switch numbers on its city LiDAR scan (Sec. 4.3)
PAPER_BH = {"kept_points": 259, "mean_discrepancy": 7.6e-5, "max_discrepancy": 6.6e-3,
            "mean_cosine": 1.0, "min_cosine": 0.9974}


def pyplot():
    import matplotlib  # matplotlib (studies extra): loaded on use

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt  # matplotlib (studies extra): loaded on use

    return plt


def threads_note(rows):
    """``", 2 threads"`` from the rows' ``threads`` (the numba threads each render ran on;
    ``", 1-2 threads"`` when they differ, ``""`` when the rows do not say)."""
    n = sorted({int(float(r["threads"])) for r in rows if r.get("threads") not in (None, "")})
    if not n:
        return ""
    return f", {n[0]} thread{'s' if n[0] > 1 else ''}" if len(n) == 1 else \
        f", {n[0]}-{n[-1]} threads"


#: a marker per type, of different shapes and sizes (the larger hollow), so that series that
#: coincide (edges and triangles at the same error) both stay visible
SERIES_MARKERS = {"points": dict(marker="o", ms=6),
                  "edges": dict(marker="s", ms=9, mfc="none", mew=1.5),
                  "triangles": dict(marker="^", ms=5)}


def fit_title(ax, text, fontsize=10):
    """Set ``text`` as the title of ``ax``, broken into as many lines as it needs to stay
    inside the figure (measured with the figure's renderer, around the axes' centre, where
    matplotlib centres it: a mesh's long file name or parameter list stays inside the figure).
    Call it again after the layout moved the axes (:func:`legend_below` does)."""
    fig = ax.figure
    renderer = fig.canvas.get_renderer()
    box = ax.get_position()
    centre = (box.x0 + box.x1) / 2 * fig.get_size_inches()[0] * fig.dpi
    limit = 2 * min(centre, fig.get_size_inches()[0] * fig.dpi - centre) - 8
    width = max(len(line) for line in text.split("\n"))
    title = ax.set_title(text, fontsize=fontsize)
    while title.get_window_extent(renderer).width > limit and width > 20:
        width = int(width * 0.85)
        title.set_text("\n".join(textwrap.fill(part, width) for part in text.split("\n")))
    ax._fit_title = (text, fontsize)
    return title


def legend_below(fig, ax, fontsize=7, handles=None, top=0.0):
    """The legend of ``ax`` (or ``handles``: artists with labels, for a legend that several
    panels share) under the axes, in a band of its own that the figure grows by, so that it
    never covers the data, the title or the axis labels; in as many columns as fit the
    figure's width (one per six entries at most); then ``tight_layout`` for the rest, below a
    band of ``top`` inches kept for a suptitle."""
    if handles is None:
        handles, labels = ax.get_legend_handles_labels()
    else:
        labels = [h.get_label() for h in handles]
    w, h = fig.get_size_inches()
    if not handles:
        fig.tight_layout(rect=(0.0, 0.0, 1.0, 1.0 - top / h))
        return
    renderer = fig.canvas.get_renderer()
    width_px = w * fig.dpi
    for ncol in range(min(4, -(-len(handles) // 6)), 0, -1):
        leg = fig.legend(handles, labels, loc="lower center", bbox_to_anchor=(0.5, 0.0),
                         fontsize=fontsize, ncol=ncol, frameon=False)
        if ncol == 1 or leg.get_window_extent(renderer).width <= 0.98 * width_px:
            break
        leg.remove()
    band = leg.get_window_extent(renderer).height / fig.dpi + 0.1
    fig.set_size_inches(w, h + band)
    rect = (0.0, band / (h + band), 1.0, 1.0 - top / (h + band))
    fig.tight_layout(rect=rect)
    if hasattr(ax, "_fit_title"):       # the axes moved: wrap the title for where it is now
        fit_title(ax, *ax._fit_title)
        fig.tight_layout(rect=rect)


def fit_suptitle(fig, text, fontsize=9):
    """``fig``'s suptitle, wrapped to the figure's width (measured); returns the height in
    inches that it needs at the top (for ``tight_layout``'s ``rect``)."""
    title = fig.suptitle(text, fontsize=fontsize, y=0.995, va="top")
    wrap_to_figure(fig, title, text)
    return title.get_window_extent(fig.canvas.get_renderer()).height / fig.dpi + 0.1


def wrap_to_figure(fig, title, text):
    """Wrap the text artist ``title`` (holding ``text``) until it is no wider than the
    figure (measured with the figure's renderer)."""
    renderer = fig.canvas.get_renderer()
    limit = 0.96 * fig.get_size_inches()[0] * fig.dpi
    width = max(len(line) for line in text.split("\n"))
    while title.get_window_extent(renderer).width > limit and width > 20:
        width = int(width * 0.85)
        title.set_text("\n".join(textwrap.fill(part, width) for part in text.split("\n")))


def savefig(fig, path, dpi=100, max_bytes=195_000):
    """Save a matplotlib figure as PNG atomically (see :func:`png_bytes`)."""
    data = png_bytes(fig, dpi, max_bytes)
    with atomic_write(path) as tmp:
        Path(tmp).write_bytes(data)


def png_bytes(fig, dpi=100, max_bytes=195_000):
    """A matplotlib figure as PNG bytes; above ``max_bytes`` the image is stored with an
    adaptive 256-colour palette (committed result images stay small)."""
    from PIL import Image  # Pillow (tracer extra): loaded on use

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
    return data.getvalue()


def thumb(rgb, size):
    """Downsample an ``(H, W, 3)`` uint8 image so its longer side is at most ``size``."""
    from PIL import Image  # Pillow (tracer extra): loaded on use

    H, W = rgb.shape[:2]
    if max(H, W) <= size:
        return rgb
    s = size / max(H, W)
    img = Image.fromarray(rgb).resize((max(1, round(W * s)), max(1, round(H * s))),
                                      Image.LANCZOS)
    return np.asarray(img)


def beta_outputs(out, cache, rows, params, types, grid_betas):
    """Plots, image grid and report of the beta study from its rows (dicts with numbers).

    Rows with ``tol > 0`` (tolerance-controlled pruning) are drawn as extra dotted series in
    the time and error plots, set against the beta series in ``beta_frontier.png`` and the
    report's frontier table, and listed in the report; the image grid shows ``tol = 0``.
    """
    present = beta_plots(out, rows, params)
    front = beta_frontier(out, rows, params, present)
    plain = [r for r in rows if not r.get("tol", 0.0)]
    beta_grid(out, cache, plain, present, grid_betas, params)
    diff = beta_diff(out, cache, plain, present, grid_betas, params)
    write_text(out / "report.md", beta_report(rows, params, present, diff=diff, front=front))


def beta_plots(out, rows, params, spread=None):
    """``beta_time.png`` and ``beta_error.png`` from the study's rows; returns the types
    present. Needs only the rows (the CSV), not the renders. ``spread``: ``{type: {beta:
    [seconds of each run]}}`` of repeated renders, drawn as min-max bars on the time plot."""
    plt = pyplot()
    all_rows = rows
    extra = [r for r in rows if r.get("tol", 0.0)]
    rows = [r for r in rows if not r.get("tol", 0.0)]
    present = [k for k in TYPES if any(r["type"] == k for r in all_rows)]

    def tol_series(ax, k, column, scale=1.0):
        for t in sorted({r["tol"] for r in extra if r["type"] == k}):
            rs = sorted((r for r in extra if r["type"] == k and r["tol"] == t),
                        key=lambda r: r["beta"])
            ax.plot([r["beta"] for r in rs], [max(scale * r[column], 1e-4) for r in rs], "^:",
                    color=TYPE_COLORS[k], label=f"{k}, tol {t:g}")

    # ---- time vs beta (log y), like the paper's figure
    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    for k in present:
        rs = sorted((r for r in rows if r["type"] == k), key=lambda r: r["beta"])
        ax.plot([r["beta"] for r in rs], [max(r["seconds"], 1e-4) for r in rs], "-",
                color=TYPE_COLORS[k], **SERIES_MARKERS[k],
                label=f"{k} (ours, {params['width']}², {type_parameters(params, k)})")
        ref = authors_times(params)
        if ref:
            ref_b = sorted(ref)
            ax.plot(ref_b, [ref[b][TYPES.index(k)] for b in ref_b], "s", color=TYPE_COLORS[k],
                    mfc="none", ms=8, label=f"{k} (authors' C++, {params['width']}², "
                    "side by side)")
        tol_series(ax, k, "seconds")
        _spread_bars(ax, k, (spread or {}).get(k))
    ax.set_yscale("log")
    ax.set_xlabel("β")
    ax.set_ylabel("render time (s)")
    fit_title(ax, f"{params['mesh_name']}: time vs β{threads_note(all_rows)} "
              f"({parameters_title(params)})")
    ax.grid(True, which="both", alpha=0.3)
    legend_below(fig, ax)
    savefig(fig, out / "beta_time.png")
    plt.close(fig)
    # ---- error (% of diagonal) vs beta
    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    for k in present:
        rs = sorted((r for r in rows if r["type"] == k), key=lambda r: r["beta"])
        b = np.array([r["beta"] for r in rs])
        m = 100 * np.array([r["error_rel_diag"] for r in rs])
        sd = 100 * np.array([r["error_std_rel_diag"] for r in rs])
        ax.plot(b, m, "-", color=TYPE_COLORS[k], **SERIES_MARKERS[k],
                label=f"{k} (ours, {type_parameters(params, k)})")
        ax.fill_between(b, np.maximum(m - sd, 0), m + sd, color=TYPE_COLORS[k], alpha=0.12)
        ref_e = authors_errors(params)
        if ref_e:
            ref_b = sorted(ref_e)
            # measured at these betas only: markers, no line drawn as if measured between
            ax.plot(ref_b, [ref_e[x][TYPES.index(k)] for x in ref_b], "D", ls="none", ms=7,
                    color=TYPE_COLORS[k], mfc="none", alpha=0.8,
                    label=f"{k} (authors' C++ run here, {authors_error_size()}², "
                    f"β = {_beta_span(ref_b)})")
        tol_series(ax, k, "error_rel_diag", 100.0)
    ax.set_xlabel("β")
    ax.set_ylabel("mean |t_β − t_0| (% of bbox diagonal)")
    fit_title(ax, f"{params['mesh_name']}: isosurface error vs β (band: ±1 std)\n"
              f"{parameters_title(params)}")
    ax.grid(True, alpha=0.3)
    legend_below(fig, ax)
    savefig(fig, out / "beta_error.png")
    plt.close(fig)
    return present


#: betas labelled in ``beta_frontier.png`` when a series has more than six
FRONTIER_LABELS = (0.1, 0.2, 0.3, 0.5, 1.0)


def _spread_bars(ax, kind, runs):
    """Min-max bars over repeated renders (``{beta: [seconds]}``) of one type, labelled once
    with the number of runs."""
    runs = {float(b): v for b, v in (runs or {}).items() if len(v) > 1}
    if not runs:
        return
    b = sorted(runs)
    lo = np.array([min(runs[x]) for x in b])
    hi = np.array([max(runs[x]) for x in b])
    n = min(len(v) for v in runs.values())
    ax.vlines(b, lo, hi, color=TYPE_COLORS[kind], lw=1.2, zorder=3,
              label=f"{kind}: min-max of {n} runs at β {', '.join(f'{x:g}' for x in b)}")
    for y in (lo, hi):  # caps, so that a short bar behind a marker still shows
        ax.hlines(y, np.array(b) - 0.02, np.array(b) + 0.02, color=TYPE_COLORS[kind], lw=1.2,
                  zorder=3)


def frontier(rows, kind):
    """Each beta render of ``kind`` against the tol renders (rows with ``tol > 0``).

    Returns one dict per plain row with ``beta > 0`` (by beta): ``row``; ``by``, the fastest
    tol row whose error is no larger and whose time is no longer (None if there is none);
    ``nearest``, when there is none, the fastest tol row whose error is no larger (it is
    slower: how much says how far the tol series is from the beta render), or, when no tol
    row is that accurate, the most accurate one. Rows without an error (no reference) are
    left out."""
    def ok(r):
        return r["type"] == kind and math.isfinite(r["error_rel_diag"])

    tols = [r for r in rows if ok(r) and r.get("tol", 0.0)]
    out = []
    for r in sorted((r for r in rows if ok(r) and not r.get("tol", 0.0) and r["beta"] > 0),
                    key=lambda r: r["beta"]):
        dom = [t for t in tols if t["error_rel_diag"] <= r["error_rel_diag"]
               and t["seconds"] <= r["seconds"]]
        by = min(dom, key=lambda t: t["seconds"]) if dom else None
        nearest = None
        if by is None and tols:
            accurate = [t for t in tols if t["error_rel_diag"] <= r["error_rel_diag"]]
            nearest = (min(accurate, key=lambda t: t["seconds"]) if accurate
                       else min(tols, key=lambda t: t["error_rel_diag"]))
        out.append({"row": r, "by": by, "nearest": nearest})
    return out


def beta_frontier(out, rows, params, present):
    """``beta_frontier.png``: mean error against render time, one panel per type, the beta
    series (labelled by beta) and the tol series (labelled by tol; beta as in the CSV) on log
    axes; a beta render that some tol render dominates (error and time no larger) is drawn
    hollow. Returns False (and writes nothing) when no row has ``tol > 0``."""
    tol_rows = [r for r in rows if r.get("tol", 0.0) and math.isfinite(r["error_rel_diag"])]
    if not tol_rows:
        return False
    plt = pyplot()
    # matplotlib (studies extra): loaded on use
    from matplotlib.ticker import FuncFormatter, NullFormatter

    fig, axes = plt.subplots(1, len(present), squeeze=False,
                             figsize=(4.2 * len(present), 4.0))
    for ax, k in zip(axes[0], present):
        c = TYPE_COLORS[k]
        front = frontier(rows, k)
        bs = [f["row"] for f in front]
        floor = 1e-4    # % of the diagonal: errors of 0 drawn at the axis floor
        ax.plot([r["seconds"] for r in bs], [max(100 * r["error_rel_diag"], floor) for r in bs],
                "-", color=c, alpha=0.6, label="β series (tol 0)")
        for f in front:
            r = f["row"]
            ax.plot(r["seconds"], max(100 * r["error_rel_diag"], floor), "o", color=c,
                    mfc="white" if f["by"] else c, ms=6)
            if len(front) > 6 and not any(close(r["beta"], b) for b in FRONTIER_LABELS):
                continue    # a long series: label a few betas only
            ax.annotate(f"β {r['beta']:g}", (r["seconds"], max(100 * r["error_rel_diag"], floor)),
                        textcoords="offset points", xytext=(4, 3), fontsize=6, color=c)
        ts = sorted((r for r in tol_rows if r["type"] == k),
                    key=lambda r: (r["beta"], r["tol"]))
        for b in sorted({r["beta"] for r in ts}):
            tb = [r for r in ts if r["beta"] == b]
            ax.plot([r["seconds"] for r in tb],
                    [max(100 * r["error_rel_diag"], floor) for r in tb], "^:", color="0.25",
                    ms=5, label=f"tol series (β {b:g})")
            for r in tb:
                ax.annotate(f"{r['tol']:g}", (r["seconds"], max(100 * r["error_rel_diag"], floor)),
                            textcoords="offset points", xytext=(4, -8), fontsize=6, color="0.25")
        ref = next((r for r in rows if r["type"] == k and r["beta"] == 0.0
                    and not r.get("tol", 0.0)), None)
        if ref is not None:
            ax.axvline(ref["seconds"], color=c, ls="--", lw=0.8)
        ax.set_xscale("log")
        ax.set_yscale("log")
        for axis in (ax.xaxis, ax.yaxis):
            axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
            axis.set_minor_formatter(NullFormatter())
        ax.set_xlabel("render time (s)")
        ax.set_ylabel("mean |t − t_0| (% of bbox diagonal)")
        n_dom = sum(1 for f in front if f["by"])
        ref_s = f"; β 0 takes {ref['seconds']:.3g} s" if ref is not None else ""
        ax.set_title(f"{k}: {n_dom} of {len(front)} β dominated by a tol{ref_s}", fontsize=8)
        ax.grid(True, which="both", alpha=0.3)
    # matplotlib (studies extra): loaded on use
    from matplotlib.lines import Line2D

    shared = [Line2D([], [], color="0.4", marker="o", label="β series (tol 0), β beside each; "
                     "the type's colour, hollow: a tol render is as accurate and as fast"),
              Line2D([], [], color="0.25", ls=":", marker="^", ms=5,
                     label="tol series, tol beside each (at the β given)"),
              Line2D([], [], color="0.4", ls="--", lw=0.8, label="β 0 render's time (reference)")]
    top = fit_suptitle(fig, f"{params['mesh_name']}: error against time, β and tol "
                       f"({params['width']}², {parameters_title(params)})")
    legend_below(fig, axes[0][0], handles=shared, top=top)
    savefig(fig, out / "beta_frontier.png")
    plt.close(fig)
    return True


def frontier_lines(rows, present):
    """The report's frontier table (markdown lines; empty without tol rows)."""
    if not any(r.get("tol", 0.0) for r in rows):
        return []
    lines = ["## β against tol", "",
             "For each β, the fastest tol render with an error no larger and a time no longer "
             "(its β in brackets when not 0). Where there is none: the fastest tol render "
             "with an error no larger, and how many times the β render's time it takes; or, "
             "when no tol render is that accurate, the most accurate one.", "",
             "| type | β | time (s) | error (% diag) | dominated by | its time (s) | "
             "its error (% diag) | time / β's |", "|---|---|---|---|---|---|---|---|"]
    for k in present:
        for f in frontier(rows, k):
            r, t = f["row"], f["by"] or f["nearest"]
            if t is None:
                lines.append(f"| {k} | {r['beta']:g} | {r['seconds']:.3g} | "
                             f"{100 * r['error_rel_diag']:.4f} | – | – | – | – |")
                continue
            name = f"tol {t['tol']:g}" + (f" [β {t['beta']:g}]" if t["beta"] else "")
            if f["by"]:
                who = name
            elif t["error_rel_diag"] <= r["error_rel_diag"]:
                who = f"no (as accurate: {name}, slower)"
            else:
                who = f"no (no tol as accurate; best: {name})"
            lines.append(f"| {k} | {r['beta']:g} | {r['seconds']:.3g} | "
                         f"{100 * r['error_rel_diag']:.4f} | {who} | {t['seconds']:.3g} | "
                         f"{100 * t['error_rel_diag']:.4f} | "
                         f"{t['seconds'] / r['seconds']:.2f} |")
    return lines + [""]


def beta_grid(out, cache, rows, present, grid_betas, params=None):
    """``beta_grid.png``: the cached renders, types x selected betas (``tol = 0`` rows),
    each type labelled with its parameters (``params``: the study's, when given)."""
    plt = pyplot()
    measured = sorted({r["beta"] for r in rows})
    cols = [b for b in measured if any(close(b, g) for g in grid_betas)] or measured[:4]
    band = 0.25 if params else 0.0     # inches above the panels for the suptitle
    fig, axes = plt.subplots(len(present), len(cols), squeeze=False,
                             figsize=(1.9 * len(cols), 2.25 * len(present) + band))
    for i, k in enumerate(present):
        for j, b in enumerate(cols):
            ax = axes[i][j]
            ax.set_xticks([])
            ax.set_yticks([])
            r = next((r for r in rows if r["type"] == k and close(r["beta"], b)), None)
            img_path = cache / f"render_{k}_beta{beta_tag(b)}.png"
            if r is not None and img_path.exists():

                ax.imshow(thumb(load_png(img_path), 160), interpolation="lanczos")
                ax.set_title(f"β={b:g}: {r['seconds']:.3g} s\n"
                             f"err {percent(r['error_rel_diag'], 2)}", fontsize=7)
            else:
                ax.text(0.5, 0.5, "not available", ha="center", va="center", fontsize=7,
                        transform=ax.transAxes)
            if j == 0:
                ax.set_ylabel(f"{k}\n{type_parameters(params, k)}" if params else k,
                              fontsize=8 if params is None else 6)
    if params:
        fig.suptitle(f"{params['mesh_name']}: {parameters_title(params)}", fontsize=7)
    # tight_layout leaves the suptitle out: keep its band above the panels' titles
    fig.tight_layout(pad=0.4, rect=(0, 0, 1, 1 - band / fig.get_figheight()))
    savefig(fig, out / "beta_grid.png", dpi=100)
    plt.close(fig)


#: colour map of the depth-difference heat maps; pixels not hit by both renders are grey
DIFF_CMAP = "inferno"
DIFF_LABEL = "|t_β − t_0| per pixel (% of bbox diagonal)"


def beta_diff_figure(cache, rows, present, grid_betas, params):
    """The heat maps of ``beta_diff.png`` as a matplotlib figure, or None when no render with
    beta > 0 and its type's beta = 0 depth buffer are in ``cache``.

    One panel per type (rows) and selected beta > 0 (columns; the betas of the image grid): the
    per-pixel depth difference ``|t_beta - t_0|`` to the type's beta = 0 render over the bbox
    diagonal, in %, where both renders hit (grey elsewhere); the mean of a panel is the study's
    ``error_rel_diag``. All panels share one colour scale, shown by the colour bar (0 to the
    largest 99.5th percentile of the panels; larger values take the top colour).
    """
    plt = pyplot()
    import matplotlib  # matplotlib (studies extra): loaded on use

    measured = sorted({r["beta"] for r in rows if r["beta"] > 0})
    cols = [b for b in measured if any(close(b, g) for g in grid_betas)] or measured[:3]
    maps = {}
    for k in present:
        ref_path = cache / f"depth_{k}_beta{beta_tag(0.0)}.npy"
        if not ref_path.exists():
            continue
        ref = np.load(ref_path).astype(np.float64)
        for b in cols:
            r = next((r for r in rows if r["type"] == k and close(r["beta"], b)), None)
            path = cache / f"depth_{k}_beta{beta_tag(b)}.npy"
            if r is None or not path.exists():
                continue
            depth = np.load(path).astype(np.float64)
            if depth.shape != ref.shape:
                continue
            both = np.isfinite(depth) & np.isfinite(ref)
            err = np.full(depth.shape, np.nan)
            err[both] = 100.0 * np.abs(depth[both] - ref[both]) / float(r["diag"])
            maps[k, b] = (err, r)
    if not maps:
        return None
    values = [e[np.isfinite(e)] for e, _ in maps.values()]
    values = [v for v in values if v.size]
    vmax = max((float(np.percentile(v, 99.5)) for v in values), default=0.0)
    vmax = vmax if vmax > 0 else 1e-6
    over = any(float(v.max()) > vmax for v in values)
    types = [k for k in present if any(key[0] == k for key in maps)]
    cmap = matplotlib.colormaps[DIFF_CMAP].with_extremes(bad="#d9d9d9")
    norm = matplotlib.colors.Normalize(0.0, vmax)
    fig, axes = plt.subplots(len(types), len(cols), squeeze=False, layout="constrained",
                             figsize=(1.9 * len(cols) + 1.2, 2.25 * len(types) + 0.4))
    for i, k in enumerate(types):
        for j, b in enumerate(cols):
            ax = axes[i][j]
            ax.set_xticks([])
            ax.set_yticks([])
            if (k, b) in maps:
                err, r = maps[k, b]
                ax.imshow(err, cmap=cmap, norm=norm, interpolation="nearest")
                ax.set_title(f"β={b:g}: mean {percent(r['error_rel_diag'], 2)}", fontsize=7)
            else:
                ax.text(0.5, 0.5, "not available", ha="center", va="center", fontsize=7,
                        transform=ax.transAxes)
            if j == 0:
                ax.set_ylabel(f"{k}\n{type_parameters(params, k)}", fontsize=6)
    cb = fig.colorbar(matplotlib.cm.ScalarMappable(norm=norm, cmap=cmap), ax=axes,
                      extend="max" if over else "neither", shrink=0.9)
    cb.set_label(DIFF_LABEL, fontsize=8)
    cb.ax.tick_params(labelsize=7)
    text = (f"{params['mesh_name']}: depth difference to β = 0 (grey: not hit by both)\n"
            f"{parameters_title(params)}")
    # placed by the constrained layout (which keeps room for it), wrapped so a long name fits
    wrap_to_figure(fig, fig.suptitle(text, fontsize=8), text)
    return fig


def beta_diff(out, cache, rows, present, grid_betas, params):
    """Write ``beta_diff.png`` (:func:`beta_diff_figure`); returns whether it was written (a
    heat map of an earlier run is removed when there is nothing to show)."""
    fig = beta_diff_figure(cache, rows, present, grid_betas, params)
    if fig is None:
        (out / "beta_diff.png").unlink(missing_ok=True)
        return False
    savefig(fig, out / "beta_diff.png", dpi=100)
    pyplot().close(fig)
    return True


def beta_report(rows, params, present, diff=False, front=False):
    m = machine_info()
    lines = [f"# β ablation: {params['mesh_name']}", "",
             "Madan & Levin 2022, Sec. 4.3 (figure \"betatest\"); protocol of the authors' "
             "`app/beta_error_test`. Generated by `python -m tracer ablate-beta`.", "",
             f"- data: `{params['mesh_name']}` as vertices, edges and triangles; bbox diagonal "
             f"{params['diag']:.6g}",
             f"- parameters: {params.get('parameters') or parameters_title(params)}",
             f"- image {params['width']}×{params['height']} px; eps = {params['eps']:.3g} "
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
             *(["![error against time, beta and tol](beta_frontier.png)", ""] if front else []),
             "![renders](beta_grid.png)", "",
             *(["![depth difference to beta = 0](beta_diff.png)", ""] if diff else []),
             *_reference_lines(params)]
    ref = has_reference(params)
    head = ["type", "β", "tol", "time (s)", *(["ref. time (s)"] if ref else []),
            "speed-up vs β=0", "error (% diag)", *(["ref. error (% diag)"] if ref else []),
            "error std (% diag)", "hits", "mean leaves/px", "leaves/eval"]
    lines += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    times, errors = authors_times(params), authors_errors(params)
    for k in present:
        rs = sorted((r for r in rows if r["type"] == k),
                    key=lambda r: (r.get("tol", 0.0), r["beta"]))
        t0 = next((r["seconds"] for r in rs if r["beta"] == 0.0 and not r.get("tol", 0.0)),
                  float("nan"))
        ti = TYPES.index(k)
        for r in rs:
            plain = not r.get("tol", 0.0)
            ref_t = next((v[ti] for b, v in times.items() if close(b, r["beta"])), None) \
                if plain else None
            ref_e = next((v[ti] for b, v in errors.items() if close(b, r["beta"])),
                         None) if plain else None
            cells = [k, f"{r['beta']:g}", f"{r.get('tol', 0.0):g}", f"{r['seconds']:.3g}",
                     *([fmt(ref_t, 3) or "–"] if ref else []), f"{t0 / r['seconds']:.3g}×",
                     f"{100 * r['error_rel_diag']:.3f}", *([fmt(ref_e, 3) or "–"] if ref else []),
                     f"{100 * r['error_std_rel_diag']:.3f}", str(r["hits"]),
                     f"{r['mean_leaves']:.0f}", f"{r['leaves_per_eval']:.1f}"]
            lines.append("| " + " | ".join(cells) + " |")
    lines += ["", *frontier_lines(rows, present),
              "The raw numbers are in `beta_ablation.csv`; the parameters in "
              "`beta_params.json`.", ""]
    return "\n".join(lines)


def _reference_lines(params):
    """The heading and the sentence before the beta report's table."""
    if not has_reference(params):
        return ["## Measured", "",
                "No reference columns: the authors' errors and times were measured on the "
                "paper's bunny at α = 200, α_U = 1200 with their camera "
                f"({params.get('reference_rule', 'not this study')}).", ""]
    return ["## Measured vs reference", "",
            f"Reference times: {AUTHORS_TIMES_SETUP}; shown only for a study at the size "
            f"({', '.join(f'{n}²' for n in sorted(AUTHORS_TIMES))}) and eps "
            f"({AUTHORS_EPS:g}) they were measured at, and only for "
            "the betas measured. Reference errors: the authors' `beta_error_test`, run here at "
            f"{authors_error_size()}² (`tracer/studies/authors_beta_error.json`, written by "
            "`benchmarks/bench_authors_error.py`; errors do not depend on the machine).", ""]


def panel_grid_png(panels, title, cell=2.3):
    """Rows of ``(label, rgb)`` panels as one labelled PNG (bytes). Labels are wrapped to their
    panel's width and each row gets the height its longest label needs above its images (laid
    out by hand, in inches: no label runs into the panel above or out of the figure); the
    title is wrapped to the figure's width."""
    plt = pyplot()
    nr = len(panels)
    nc = max(len(r) for r in panels)
    pad = 0.06
    img = cell - 2 * pad
    per_line = max(16, int(cell * 72 / (0.6 * 7)))        # characters of a 7 pt label line
    labels = [[textwrap.fill(label, per_line) for label, _ in row] for row in panels]
    title = textwrap.fill(title, max(30, int(cell * nc * 72 / (0.6 * 8))))
    line = 7 * 1.3 / 72                                    # a label line's height, inches
    bands = [line * max(lab.count("\n") + 1 for lab in row) + 0.12 for row in labels]
    top = 8 * 1.3 / 72 * (title.count("\n") + 1) + 2 * pad
    W = cell * nc
    H = top + sum(b + img + pad for b in bands) + pad
    fig = plt.figure(figsize=(W, H))
    y = top                                                # inches from the top
    for i, row in enumerate(panels):
        y += bands[i]
        for j, (_, rgb) in enumerate(row):
            ax = fig.add_axes(((j * cell + pad) / W, (H - y - img) / H, img / W, img / H))
            ax.set_xticks([])
            ax.set_yticks([])
            ax.set_anchor("S")          # the image at the bottom of its box, the label above
            ax.imshow(thumb(rgb, 256), interpolation="lanczos")
            ax.set_title(labels[i][j], fontsize=7)
        y += img + pad
    fig.suptitle(title, fontsize=8, y=1 - pad / H, va="top")
    data = png_bytes(fig, dpi=100)
    plt.close(fig)
    return data


def alpha_report(out, studies):
    """report.md of the alpha studies: one section per <study>.json present in ``out``."""
    lines = ["# α studies", "",
             "Madan & Levin 2022, Sec. 3 figures, re-made with `python -m tracer ablate-alpha`. "
             "Each section lists the parameters; the JSON next to each image has them all "
             "(and per-render statistics).", ""]
    for s in studies:
        p = out / f"{s.replace('-', '_')}.json"
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


def _num(v):
    try:
        x = float(v)
    except (TypeError, ValueError):
        return float("nan")
    return x


def bench_plots(out, rows, params):
    """``bench_time_vs_leaves.png`` and ``bench_leaf_fraction.png`` in the folder ``out``
    (a Path) from the ``tracer bench-grid`` rows (dicts) and the study's ``params``."""
    plt = pyplot()
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
    legend_below(fig, ax, fontsize=8)
    legend_below(fig2, ax2, fontsize=8)
    savefig(fig, out / "bench_time_vs_leaves.png")
    savefig(fig2, out / "bench_leaf_fraction.png")
    plt.close(fig)
    plt.close(fig2)


def bh_plot(path, rows, summary):
    """The two histograms of ``tracer bh-switch`` (leaves visited and error, kept vs rejected
    switches) from its rows (dicts) and summary, written to ``path`` (PNG)."""
    plt = pyplot()
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
    handles, seen = [], set()
    for a in (a1, a2):
        for h, lab in zip(*a.get_legend_handles_labels()):
            if lab not in seen:
                seen.add(lab)
                handles.append(h)
    top = fit_suptitle(fig, f"Barnes-Hut switch study: {os.path.basename(summary['cloud'])}, "
                       f"α={summary['alpha']:g}, β={summary['beta']:g}")
    legend_below(fig, a1, fontsize=7, handles=handles, top=top)
    savefig(fig, path)
    plt.close(fig)
