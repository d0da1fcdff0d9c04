"""The beta study's plots on a user's mesh with a long name and per-type parameters (issue 61):
every text inside the figure, titles inside it too, the legend off the axes' data area, and
series that coincide both visible. Checked with matplotlib's own extents, on the figures as
``beta_plots`` saves them (``savefig`` intercepted before the PNG is written)."""

import numpy as np
import pytest

pytest.importorskip("matplotlib")

from matplotlib.backends.backend_agg import FigureCanvasAgg  # noqa: E402

from tracer.studies import plots  # noqa: E402

NAME = "mobius_strip_scanned_at_home_with_a_rather_long_file_name_v2.obj"
PARAMS = {
    "mesh": NAME, "mesh_name": NAME, "alpha": None, "alpha_u": None, "width": 128,
    "height": 128, "eps": 3.4e-4, "authors_reference": False,
    "surfaces": {"points": {"alpha": 12.729, "alpha_u": 254.58, "offset": 0.0,
                            "parameters": "auto"},
                 "edges": {"alpha": 2677.93, "alpha_u": 2677.93, "offset": 0.0112,
                           "parameters": "auto"},
                 "triangles": {"alpha": 1955.69, "alpha_u": 1955.69, "offset": 0.0102,
                               "parameters": "auto"}}}


def rows():
    """A study's rows: points' error grows with beta; edges' and triangles' coincide at 0."""
    out = []
    for k, scale in (("points", 1.0), ("edges", 0.0), ("triangles", 0.0)):
        for b in (0.0, 0.25, 0.5, 1.0):
            out.append({"type": k, "beta": b, "tol": 0.0, "seconds": 0.05 / (1 + 4 * b),
                        "error_rel_diag": scale * 0.03 * b, "error_std_rel_diag": 0.01 * b,
                        "threads": 16})
    return out


def _inside(inner, outer, slack=1.0):
    return (inner.x0 >= outer.x0 - slack and inner.y0 >= outer.y0 - slack
            and inner.x1 <= outer.x1 + slack and inner.y1 <= outer.y1 + slack)


def _overlap(a, b):
    return a.x0 < b.x1 and b.x0 < a.x1 and a.y0 < b.y1 and b.y0 < a.y1


def texts(fig):
    """The texts ``fig`` draws: titles, axis labels, the tick labels inside each axis' view
    (matplotlib keeps labels of ticks outside it, undrawn), legends', the figure's own."""
    out = list(fig.texts)
    for leg in [a.get_legend() for a in fig.axes if a.get_legend()] + list(fig.legends):
        out += leg.get_texts()
    for ax in fig.axes:
        out += [ax.title, ax._left_title, ax._right_title, ax.xaxis.label, ax.yaxis.label]
        for axis in (ax.xaxis, ax.yaxis):
            lo, hi = sorted(axis.get_view_interval())
            for tick in axis.get_major_ticks() + axis.get_minor_ticks():
                if lo - 1e-12 <= tick.get_loc() <= hi + 1e-12:
                    out.append(tick.label1)
    return [t for t in out if t.get_visible() and str(t.get_text()).strip()]


def check_layout(fig):
    """Problems of ``fig``: texts outside the figure, a legend over an axes' data area."""
    renderer = fig.canvas.get_renderer()
    problems = [f"text outside the figure: {t.get_text()[:60]!r}" for t in texts(fig)
                if not _inside(t.get_window_extent(renderer), fig.bbox)]
    legends = [a.get_legend() for a in fig.axes if a.get_legend()] + list(fig.legends)
    for leg in legends:
        box = leg.get_window_extent(renderer)
        for ax in fig.axes:
            if _overlap(box, ax.get_window_extent(renderer)):
                problems.append("legend over the data area")
    return problems


@pytest.fixture
def saved(monkeypatch):
    figs = {}

    def capture(fig, path, dpi=100, max_bytes=195_000):
        fig.canvas.draw()
        figs[path.name] = (check_layout(fig), fig)

    monkeypatch.setattr(plots, "savefig", capture)
    return figs


def test_beta_plots_keep_their_texts_in_the_figure_and_off_the_data(tmp_path, saved):
    present = plots.beta_plots(tmp_path, rows(), PARAMS)
    assert present == ["points", "edges", "triangles"]
    assert set(saved) == {"beta_time.png", "beta_error.png"}
    for name, (problems, _) in saved.items():
        assert not problems, (name, problems)
    # the time plot says how many threads each render had
    assert "16 threads" in saved["beta_time.png"][1].axes[0].get_title().replace("\n", " ")


def test_repeated_renders_show_their_spread_on_the_time_plot(tmp_path, saved):
    """Three runs at beta 0 and 0.5: one min-max bar per type and beta, spanning the runs'
    fastest and slowest, named in the legend; the layout still holds."""
    spread = {k: {"0": [0.05, 0.06, 0.045], "0.5": [0.017, 0.02, 0.016]}
              for k in ("points", "edges", "triangles")}
    plots.beta_plots(tmp_path, rows(), PARAMS, spread=spread)
    problems, fig = saved["beta_time.png"]
    assert not problems, problems
    bars = [c for c in fig.axes[0].collections if "min-max of 3 runs" in c.get_label()]
    assert len(bars) == 3
    segs = bars[0].get_segments()
    assert sorted((s[0][0], s[0][1], s[1][1]) for s in segs) == [(0.0, 0.045, 0.06),
                                                                  (0.5, 0.016, 0.02)]


def test_the_old_layout_fails_the_check(tmp_path, saved, monkeypatch):
    """The check can fail: the legend inside the axes and the title on one line, as before."""
    def inside(fig, ax, fontsize=7):
        ax.legend(fontsize=fontsize, ncol=2)
        ax.set_title(ax.get_title().replace("\n", " "))
        fig.tight_layout()

    monkeypatch.setattr(plots, "legend_below", inside)
    plots.beta_plots(tmp_path, rows(), PARAMS)
    assert all(problems for problems, _ in saved.values())


def test_coinciding_series_stay_visible(tmp_path, saved):
    """Edges and triangles at the same errors: different marker shapes and sizes, the larger
    one hollow, so that neither hides the other."""
    plots.beta_plots(tmp_path, rows(), PARAMS)
    _, fig = saved["beta_error.png"]
    lines = {ln.get_label().split(" ")[0]: ln for ln in fig.axes[0].get_lines()}
    e, t = lines["edges"], lines["triangles"]
    assert np.allclose(e.get_ydata(), t.get_ydata())
    assert e.get_marker() != t.get_marker() and e.get_markersize() > t.get_markersize()
    assert e.get_markerfacecolor() == "none"


def test_panel_grids_keep_labels_off_the_panels_above(monkeypatch):
    """The alpha study's panel grids (metric.png, weights.png, ...): long labels and a long
    title stay inside the figure and off the other panels."""
    found = []

    def capture(fig, dpi=100, max_bytes=195_000):
        fig.canvas.draw()
        renderer = fig.canvas.get_renderer()
        problems = check_layout(fig)
        for ax in fig.axes:
            title = ax.title.get_window_extent(renderer)
            problems += [f"label over another panel: {ax.get_title()[:40]!r}"
                         for other in fig.axes if other is not ax
                         and _overlap(title, other.get_window_extent(renderer))]
        found.append(problems)
        return b""

    monkeypatch.setattr(plots, "png_bytes", capture)
    img = np.full((64, 64, 3), 200, np.uint8)
    label = "metric on: α-metric weight gradient of the gear_with_long_name.stl (α=30, α_U=30)"
    plots.panel_grid_png([[(label, img), ("off", img)], [(label, img), (label, img)]],
                         "α-metric weight gradient off (left) / on (right): " + NAME
                         + ", α_U = α, β=0.5, the mesh's own orientation")
    assert found == [[]]


def tol_rows():
    """rows() with a tol series at beta 0 for every type."""
    out = rows()
    for k in ("points", "edges", "triangles"):
        for tol in (0.001, 0.01, 0.1, 1.0):
            out.append({"type": k, "beta": 0.0, "tol": tol, "seconds": 0.02 / (1 + tol),
                        "error_rel_diag": 0.01 * tol, "error_std_rel_diag": 0.0, "threads": 16})
    return out


def test_the_frontier_shares_one_legend_below_its_panels(tmp_path, saved):
    assert plots.beta_frontier(tmp_path, tol_rows(), PARAMS, ["points", "edges", "triangles"])
    problems, fig = saved["beta_frontier.png"]
    assert not problems, problems
    assert len(fig.legends) == 1 and not any(a.get_legend() for a in fig.axes)


def test_bench_grid_and_bh_switch_plots(tmp_path, saved):
    from tracer.studies.common import TYPE_LETTER

    grid_rows = []
    for i, n in enumerate((1_000, 10_000, 100_000)):
        row = {"nV": n, "nE": 3 * n, "nF": 2 * n}
        for k in ("points", "edges", "triangles"):
            L = TYPE_LETTER[k]
            row[f"leaves_{L}"] = 20.0 * (i + 1)
            row[f"seconds_{L}"] = 0.1 * (i + 1)
        grid_rows.append(row)
    plots.bench_plots(tmp_path, grid_rows, {"grid": 32, "alpha": 200.0, "beta": 0.5,
                                            "threads": 16})
    rng = np.random.default_rng(0)
    bh_rows = [{"kept": bool(i % 3), "discrepancy": float(10 ** rng.uniform(-8, -2)),
                "cosine": float(1 - 10 ** rng.uniform(-12, -2))} for i in range(200)]
    plots.bh_plot(tmp_path / "bh_switch.png", bh_rows,
                  {"cloud": "/data/" + NAME.replace(".obj", ".ply"), "alpha": 1000.0,
                   "beta": 0.5})
    assert set(saved) == {"bench_time_vs_leaves.png", "bench_leaf_fraction.png",
                          "bh_switch.png"}
    for name, (problems, _) in saved.items():
        assert not problems, (name, problems)


def fake_cache(folder, params, betas=(0.0, 0.25, 0.5, 1.0), n=24):
    """A beta study's depth cache of ``n x n`` renders (a gradient) and depth buffers (a
    sphere's, moved by beta), as the study writes them."""
    from tracer.image import save_png  # the test's own cache of renders
    from tracer.studies.common import beta_tag

    folder.mkdir()
    y, x = np.mgrid[0:n, 0:n] / (n - 1)
    r2 = (x - 0.5) ** 2 + (y - 0.5) ** 2
    for k in ("points", "edges", "triangles"):
        for b in betas:
            rgb = (np.stack([x, y, np.full_like(x, b)], -1) * 255).astype(np.uint8)
            save_png(folder / f"render_{k}_beta{beta_tag(b)}.png", rgb)
            depth = np.where(r2 < 0.2, 1.0 - np.sqrt(np.maximum(0.2 - r2, 0)) + 0.01 * b,
                             np.nan)
            np.save(folder / f"depth_{k}_beta{beta_tag(b)}.npy", depth.astype(np.float32))
    return folder


def test_the_image_grid_and_the_heat_maps_keep_their_texts_in_the_figure(tmp_path, saved):
    """``beta_grid.png`` and ``beta_diff.png`` from a depth cache, with the long per-type
    labels of a user's mesh: no text leaves the figure, no legend over a panel."""
    cache = fake_cache(tmp_path / "cache", PARAMS)
    rs = [dict(r, diag=1.0) for r in rows()]
    present = ["points", "edges", "triangles"]
    plots.beta_grid(tmp_path, cache, rs, present, (0.0, 0.5, 1.0), PARAMS)
    assert plots.beta_diff(tmp_path, cache, rs, present, (0.5, 1.0), PARAMS)
    assert set(saved) == {"beta_grid.png", "beta_diff.png"}
    for name, (problems, fig) in saved.items():
        assert not problems, (name, problems)
        assert len(fig.axes) >= 6
        FigureCanvasAgg(fig).draw()  # closed after saving: draw it again to measure
        top = fig._suptitle.get_window_extent(fig.canvas.get_renderer())
        for ax in fig.axes:  # the wrapped suptitle stays above every panel and its title
            for box in (ax.get_window_extent(), ax.title.get_window_extent()):
                assert not _overlap(top, box), name
