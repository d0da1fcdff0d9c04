"""Tests for tracer.studies: the paper's parameter studies as sub-commands (tiny sizes).

Everything runs on the small meshes in ``tests/data`` or on meshes written to ``tmp_path``;
renders are 32 x 32 or smaller, grids 8^3, a few dozen rays.
"""

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from smoothdist import DataMesh, SmoothDistanceField
from tracer import runner
from tracer.studies import alpha, common, grid
from tracer.cli import main

TESTS = Path(__file__).resolve().parents[2]
OCTOPUS = TESTS / "data" / "octopus_low.obj"
BETA_ARGS = ["--size", "32", "--betas", "0,0.5,1", "--alpha", "40", "--alpha-u", "300", "-q"]
BETA_COLUMNS = ["type", "beta", "seconds", "hits", "mean_steps", "mean_leaves", "error_rel_diag",
                "error_std_rel_diag", "n_both"]


def _rows(path):
    with open(path, newline="", encoding="utf-8") as fh:
        return list(csv.DictReader(fh))


@pytest.fixture(scope="module")
def beta_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("beta") / "study"
    assert main(["ablate-beta", str(OCTOPUS), "-o", str(out), *BETA_ARGS]) == 0
    return out


# ----------------------------------------------------------------------------- ablate-beta
@pytest.mark.slow
def test_beta_outputs_exist(beta_run):
    for name in ("beta_ablation.csv", "beta_params.json", "beta_time.png", "beta_error.png",
                 "beta_grid.png", "beta_diff.png", "report.md", "cache/depth_points_beta0.npy",
                 "cache/depth_edges_beta0.npy", "cache/depth_triangles_beta0.npy",
                 "cache/render_edges_beta0.5.png"):
        assert (beta_run / name).is_file(), name
    assert not [p.name for p in beta_run.iterdir() if ".tmp-" in p.name]
    report = (beta_run / "report.md").read_text(encoding="utf-8")
    assert "beta_time.png" in report
    # the octopus is not the paper's bunny: no column of the authors' bunny numbers
    header = _table_header(report)
    assert "ref. error (% diag)" not in header and "ref. time (s)" not in header, header
    assert "No reference columns" in report and "not the bunny" in report
    assert json.loads((beta_run / "beta_params.json").read_text())["authors_reference"] is False


def _table_header(report):
    lines = [ln for ln in report.splitlines() if ln.startswith("| type")]
    return [c.strip() for c in lines[0].strip("|").split("|")]


def _column(report, name):
    lines = [ln for ln in report.splitlines() if ln.startswith("|")]
    col = _table_header(report).index(name)
    return [[c.strip() for c in ln.strip("|").split("|")][col] for ln in lines[2:]]


BUNNY = TESTS.parent / "scenes" / "data" / "bunny.off"


def test_beta_bunny_keeps_the_authors_reference(tmp_path):
    """The paper's bunny at the paper's alpha and camera: the authors' errors (2.5 % for points
    at beta 0.5, Sec. 4.3) are in the report; no reference times at 16² (they were measured at
    256² and 512² only). Read from the table's columns (a bare substring search also hit the
    load average printed in the report)."""
    out = tmp_path / "bunny"
    assert main(["ablate-beta", str(BUNNY), "-o", str(out), "--size", "16", "--betas", "0,0.5",
                 "--types", "points", "-q"]) == 0
    report = (out / "report.md").read_text(encoding="utf-8")
    from tracer.studies import plots  # the authors' errors come from their results file

    ref = plots.authors_errors({"authors_reference": True})
    assert _column(report, "ref. error (% diag)") == ["0", plots.fmt(ref[0.5][0], 3)]
    assert set(_column(report, "ref. time (s)")) == {"–"}
    assert "side by side" in report
    # the paper's own mesh keeps the paper's parameters, and says so (issue 46)
    params = json.loads((out / "beta_params.json").read_text())
    assert params["paper_parameters"] and (params["alpha"], params["alpha_u"]) == (200, 1200)
    assert params["parameters"] == "the paper's parameters: points alpha 200, alpha_U 1200"
    # the same bunny framed from a view is no longer the authors' protocol: no reference
    out2 = tmp_path / "bunny-view"
    assert main(["ablate-beta", str(BUNNY), "-o", str(out2), "--size", "16", "--betas", "0",
                 "--types", "points", "--view", "iso", "-q"]) == 0
    report = (out2 / "report.md").read_text(encoding="utf-8")
    assert "ref. error (% diag)" not in _table_header(report)
    assert "changes alpha, alpha_U or the camera" in report


def test_is_paper_bunny_by_content(tmp_path):
    """The bunny written to another format is still the bunny; another mesh is not."""
    mesh = DataMesh.load(BUNNY)
    with open(tmp_path / "b.obj", "w") as fh:
        fh.writelines(f"v {x:.6g} {y:.6g} {z:.6g}\n" for x, y, z in mesh.V)
        fh.writelines(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in mesh.triangles)
    assert common.is_paper_bunny(BUNNY) and common.is_paper_bunny(tmp_path / "b.obj")
    assert not common.is_paper_bunny(OCTOPUS)


@pytest.fixture(scope="module")
def tall_stl(tmp_path_factory):
    """A box three times taller along z than wide, made with trimesh and saved as STL (a z-up
    format: ``--up auto`` guesses z, as ``tracer render`` does)."""
    trimesh = pytest.importorskip("trimesh")
    path = tmp_path_factory.mktemp("tall") / "tall.stl"
    trimesh.creation.box(extents=(1.0, 1.0, 3.0)).export(path)
    return path


def _silhouette(mask):
    """``(height, width)`` in pixels of the hit pixels' bounding box, and whether the hits
    touch the image border."""
    rows, cols = np.nonzero(mask)
    border = (rows.min() == 0 or cols.min() == 0 or rows.max() == mask.shape[0] - 1
              or cols.max() == mask.shape[1] - 1)
    return rows.max() - rows.min() + 1, cols.max() - cols.min() + 1, border


def test_beta_frames_a_users_mesh_with_view_and_up(tall_stl, tmp_path):
    """--view front on a z-up STL: z is up in the image (the box stands three times taller
    than wide), the whole surface is in view (no hit on the border), and the report has no
    bunny reference column. The authors' camera (no --view) looks down -z at the box's
    square top instead."""
    out = tmp_path / "view"
    assert main(["ablate-beta", str(tall_stl), "-o", str(out), "--size", "48", "--betas", "0,1",
                 "--types", "triangles", "--alpha", "40", "--alpha-u", "300",
                 "--view", "front", "-q"]) == 0
    params = json.loads((out / "beta_params.json").read_text())
    assert params["view"] == "front" and params["up"] == "z"
    assert np.allclose(params["camera_vectors"][2], [0, 0, 1])
    depth = np.load(out / "cache" / "depth_triangles_beta0.npy")
    h, w, border = _silhouette(np.isfinite(depth))
    assert not border and 2.0 < h / w < 4.0, (h, w)
    assert np.isfinite(np.load(out / "cache" / "depth_triangles_beta1.npy")).any()
    header = _table_header((out / "report.md").read_text(encoding="utf-8"))
    assert "ref. error (% diag)" not in header and "error (% diag)" in header
    # --up alone implies --view front; --up y turns the same view to look along -z
    out2 = tmp_path / "up-y"
    assert main(["ablate-beta", str(tall_stl), "-o", str(out2), "--size", "48", "--betas", "0",
                 "--types", "triangles", "--alpha", "40", "--alpha-u", "300", "--up", "y",
                 "-q"]) == 0
    h, w, border = _silhouette(np.isfinite(np.load(out2 / "cache" /
                                                   "depth_triangles_beta0.npy")))
    assert not border and 0.7 < h / w < 1.4, (h, w)
    assert json.loads((out2 / "beta_params.json").read_text())["view"] == "front"


def test_beta_resume_refuses_another_view(tall_stl, tmp_path, capsys):
    out = tmp_path / "r"
    args = ["ablate-beta", str(tall_stl), "-o", str(out), "--size", "16", "--betas", "0",
            "--types", "points", "-q"]
    assert main(args + ["--view", "front"]) == 0
    assert main(args + ["--view", "iso", "--resume"]) == 2
    assert "another camera" in capsys.readouterr().err


def test_alpha_frames_a_users_mesh_with_view(tall_stl, tmp_path):
    """ablate-alpha --mesh --view front: the figure's camera has z up (guessed from the STL),
    and the panels show the standing box."""
    out = tmp_path / "a"
    assert main(["ablate-alpha", "metric", "-o", str(out), "--mesh", str(tall_stl), "--size",
                 "32", "--view", "front", "-q"]) == 0
    info = json.loads((out / "metric.json").read_text())
    origin, dest, up = (np.asarray(v) for v in info["camera"])
    assert np.allclose(up / np.linalg.norm(up), [0, 0, 1], atol=1e-6)
    assert abs((dest - origin)[2]) < 1e-9 and (dest - origin)[1] > 0  # looks along +y


def test_authors_reference_times_only_at_their_size_and_eps():
    from tracer.studies import plots
    def p(n, eps=1e-3, h=None, ref=True):
        return {"width": n, "height": h or n, "eps": eps, "authors_reference": ref}
    assert plots.authors_times(p(256))[0.5] == (1.48, 2.37, 2.63)
    assert plots.authors_times(p(256, ref=False)) == {}   # not their bunny and protocol
    assert plots.authors_errors(p(256, ref=False)) == {}
    # their errors from the results file their own program wrote, at every beta it ran
    res = json.loads(plots.AUTHORS_ERROR_FILE.read_text(encoding="utf-8"))
    errors = plots.authors_errors(p(32))
    assert sorted(errors) == sorted(res["betas"]) and errors[0.0] == (0.0, 0.0, 0.0)
    assert errors[0.5] == tuple(res["error_pct"]["0.5"][k] for k in plots.TYPES)
    assert all(0 < e < 10 for e in errors[1.0])  # % of the diagonal
    assert plots.authors_times(p(512))[0.5] == (6.33, 9.33, 10.46)
    assert plots.authors_times(p(32)) == {}
    assert plots.authors_times(p(512, eps=2.5e-5)) == {}   # our eps: not the same measurement
    assert plots.authors_times(p(512, h=256)) == {}


def test_beta_tol_series(tmp_path):
    """--tols adds a tolerance-pruned series (at beta 0): close to beta 0, with fewer
    leaves; the frontier plot and table set the beta renders against it."""
    out = tmp_path / "tol"
    assert main(["ablate-beta", str(OCTOPUS), "-o", str(out), "--size", "24", "--betas", "0,1",
                 "--tols", "0,0.01", "--types", "points", "--alpha", "40", "--alpha-u", "300",
                 "-q"]) == 0
    rows = {(float(r["beta"]), float(r["tol"])): r for r in _rows(out / "beta_ablation.csv")}
    assert set(rows) == {(0.0, 0.0), (1.0, 0.0), (0.0, 0.01)}
    assert float(rows[0.0, 0.01]["mean_leaves"]) < float(rows[0.0, 0.0]["mean_leaves"])
    # d_hat_tol >= d_hat_0 - log(1 + tol)/alpha: the depth moves by about that much at most
    diag = json.loads((out / "beta_params.json").read_text())["diag"]
    assert float(rows[0.0, 0.01]["error_rel_diag"]) * diag <= 3 * np.log1p(0.01) / 40.0
    report = (out / "report.md").read_text(encoding="utf-8")
    assert "| 0.01 |" in report and "beta_frontier.png" in report
    assert (out / "beta_frontier.png").is_file()
    table = report[report.index("## β against tol"):].splitlines()
    line = next(ln for ln in table if ln.startswith("| points | 1 |"))
    # the tol render is far more accurate than beta 1; dominated exactly when no slower
    faster = float(rows[0.0, 0.01]["seconds"]) <= float(rows[1.0, 0.0]["seconds"])
    assert ("| tol 0.01 |" in line) == faster
    assert ("no (as accurate: tol 0.01, slower)" in line) != faster


def test_beta_tol_renders_at_tol_betas():
    """Each tol > 0 is rendered at beta 0 only (the frontier's tol series) unless asked."""
    from tracer.studies import beta

    def keys(**kw):
        return [(t["beta"], t["tol"]) for t in beta.list_tasks(
            OCTOPUS, ["points"], [0.5, 1.0], [0.01, 0.1], size=8, alpha=1.0, alpha_u=1.0,
            eps=None, **kw)]

    assert keys() == [(0.0, 0.0), (0.5, 0.0), (1.0, 0.0), (0.0, 0.01), (0.0, 0.1)]
    assert keys(tol_betas=None) == [(b, t) for t in (0.0, 0.01, 0.1) for b in (0.0, 0.5, 1.0)]
    assert keys(tol_betas=[0.5]) == [(0.0, 0.0), (0.5, 0.0), (1.0, 0.0), (0.5, 0.01),
                                     (0.5, 0.1)]


def _row(kind, b, t, seconds, err):
    return {"type": kind, "beta": b, "tol": t, "seconds": seconds, "error_rel_diag": err}


def test_frontier_finds_the_fastest_dominating_tol():
    """frontier(): a tol render dominates a beta render when its error and its time are both
    no larger; the fastest such tol is named, else the fastest one as accurate (slower), else
    the most accurate one."""
    from tracer.studies.plots import frontier

    rows = [_row("points", 0.0, 0.0, 10.0, 0.0), _row("points", 0.1, 0.0, 2.0, 1e-3),
            _row("points", 0.5, 0.0, 0.5, 1e-2), _row("points", 1.0, 0.0, 0.2, 3e-2),
            _row("points", 0.0, 1e-2, 1.5, 2e-4), _row("points", 0.0, 1e-3, 1.9, 5e-5),
            _row("points", 0.0, 1.0, 0.4, 2e-2), _row("edges", 0.5, 0.0, 9.0, 1.0),
            _row("points", 0.0, 10.0, 0.3, float("nan"))]   # no reference: left out
    front = frontier(rows, "points")
    assert [f["row"]["beta"] for f in front] == [0.1, 0.5, 1.0]
    assert front[0]["by"]["tol"] == 1e-2          # 1e-3 dominates too, but is slower
    # beta 0.5 (0.5 s, 1e-2): tol 1 is faster but less accurate; 1e-2 is as accurate
    assert front[1]["by"] is None and front[1]["nearest"]["tol"] == 1e-2
    assert front[2]["by"] is None and front[2]["nearest"]["tol"] == 1.0   # 2e-2 <= 3e-2
    rows.append(_row("points", 0.05, 0.0, 5.0, 1e-6))  # more accurate than every tol
    assert frontier(rows, "points")[0]["nearest"]["tol"] == 1e-3
    rows.pop()
    # a beta render equal to a tol render in both counts as dominated (no larger, no longer)
    rows.append(_row("points", 0.0, 0.5, 0.5, 1e-2))
    assert frontier(rows, "points")[1]["by"]["tol"] == 0.5
    assert frontier(rows, "edges") == [{"row": rows[7], "by": None, "nearest": None}]


def test_beta_csv_columns_and_rows(beta_run):
    rows = _rows(beta_run / "beta_ablation.csv")
    assert set(BETA_COLUMNS) <= set(rows[0])
    assert [(r["type"], float(r["beta"])) for r in rows] == [
        (k, b) for k in ("points", "edges", "triangles") for b in (0.0, 0.5, 1.0)]
    depth = np.load(beta_run / "cache" / "depth_edges_beta0.npy")
    assert depth.shape == (32, 32) and depth.dtype == np.float32


@pytest.mark.parametrize("kind", ["points", "edges", "triangles"])
def test_beta_error_and_leaves(beta_run, kind):
    rows = [r for r in _rows(beta_run / "beta_ablation.csv") if r["type"] == kind]
    err = [float(r["error_rel_diag"]) for r in rows]
    leaves = [float(r["mean_leaves"]) for r in rows]
    assert err[0] == 0.0 and int(rows[0]["n_both"]) == int(rows[0]["hits"]) > 0
    assert err[-1] > err[1] >= 0.0           # grows with beta (up to noise in the middle)
    assert leaves[0] > leaves[1] > leaves[2]  # Barnes-Hut visits fewer leaves as beta grows
    assert all(int(r["n_both"]) > 0 for r in rows)


def test_beta_existing_folder_needs_overwrite(beta_run, capsys):
    assert main(["ablate-beta", str(OCTOPUS), "-o", str(beta_run), *BETA_ARGS]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error:") and "--overwrite" in err and len(err.strip().splitlines()) == 1


@pytest.mark.slow
def test_beta_resume_skips_rows(beta_run, tmp_path, monkeypatch):
    import shutil

    import tracer.rendering.renderer

    out = tmp_path / "copy"
    shutil.copytree(beta_run, out)
    csv_path = out / "beta_ablation.csv"
    rows = _rows(csv_path)
    # drop the last row: resume must render exactly that one, reusing the cached beta = 0 depth
    with open(csv_path, "w", newline="", encoding="utf-8") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows[:-1])
    calls = []
    real = tracer.rendering.renderer.render

    def counting(scene, **kw):
        if scene.width == 32:  # not the 8 x 8 warm-up render
            calls.append(scene.beta)
        return real(scene, **kw)

    monkeypatch.setattr(tracer.rendering.renderer, "render", counting)
    assert main(["ablate-beta", str(OCTOPUS), "-o", str(out), *BETA_ARGS, "--resume"]) == 0
    assert calls == [1.0]
    new = _rows(csv_path)
    assert len(new) == len(rows)
    for a, b in zip(rows[:-1], new[:-1]):
        assert a["seconds"] == b["seconds"]
    assert np.isclose(float(new[-1]["error_rel_diag"]), float(rows[-1]["error_rel_diag"]))
    calls.clear()
    assert main(["ablate-beta", str(OCTOPUS), "-o", str(out), *BETA_ARGS, "--resume"]) == 0
    assert calls == []
    # a resume with other parameters is refused
    args = [a if a != "40" else "41" for a in BETA_ARGS]
    assert main(["ablate-beta", str(OCTOPUS), "-o", str(out), *args, "--resume"]) == 2


def test_beta_interrupt_keeps_completed_rows(tmp_path, monkeypatch):
    import tracer.rendering.renderer

    real = tracer.rendering.renderer.render
    calls = []

    def interrupting(scene, **kw):
        if scene.width == 32:  # not the 8 x 8 warm-up render
            calls.append(scene.beta)
        if len(calls) == 3:
            raise KeyboardInterrupt
        return real(scene, **kw)

    monkeypatch.setattr(tracer.rendering.renderer, "render", interrupting)
    out = tmp_path / "cut"
    assert main(["ablate-beta", str(OCTOPUS), "-o", str(out), *BETA_ARGS,
                 "--types", "points"]) == 130
    rows = _rows(out / "beta_ablation.csv")
    assert [float(r["beta"]) for r in rows] == [0.0, 0.5]
    assert not [p.name for p in out.iterdir() if ".tmp-" in p.name]


def test_beta_bad_input(tmp_path, capsys):
    assert main(["ablate-beta", str(tmp_path / "missing.obj"), "-o", str(tmp_path / "o")]) == 2
    assert main(["ablate-beta", str(OCTOPUS), "-o", str(tmp_path / "o"), "--betas", "0,x"]) == 2
    assert main(["ablate-beta", str(OCTOPUS), "-o", str(tmp_path / "o"), "--types", "quads"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 3 and all(e.startswith("error:") for e in err)


# ----------------------------------------------------------------------------- ablate-alpha
def test_unweighted_field_is_naive_logsumexp(cube):
    field = SmoothDistanceField(cube)
    unw = common.unweighted_field(field)
    assert field.weight_bound > 1 and unw.weight_bound == 1.0
    assert field.tree.wc[:, 0].max() != 1.0 or field.tree.wc[:, 1:].any()  # untouched original
    Q = np.array([[0.9, 0.2, -0.1], [0.1, 0.7, 0.8], [0.0, 0.0, 1.3]])
    alpha = 7.0
    d, _ = unw.smooth_distance(Q, alpha=alpha, beta=0.0)
    # naive Eq. 2 over exact distances to every triangle, all weights 1
    V, T = cube.V, cube.triangles
    per = np.stack([SmoothDistanceField(V[t], [[0, 1, 2]]).exact_distance(Q)[0] for t in T])
    ref = -np.log(np.exp(-alpha * per).sum(axis=0)) / alpha
    np.testing.assert_allclose(d, ref, rtol=1e-10, atol=1e-12)


@pytest.mark.slow
def test_ablate_alpha_all_studies(tmp_path):
    out = tmp_path / "alpha"
    assert main(["ablate-alpha", "all", "-o", str(out), "--mesh", str(OCTOPUS), "--size", "24",
                 "-q"]) == 0
    report = (out / "report.md").read_text(encoding="utf-8")
    for s in alpha.STUDIES:
        slug = s.replace("-", "_")
        assert (out / f"{slug}.png").stat().st_size > 0
        info = json.loads((out / f"{slug}.json").read_text(encoding="utf-8"))
        assert info["study"] == s and info["size"] == 24
        assert f"## {s}" in report and f"({slug}.png)" in report
    nest = json.loads((out / "underestimate.json").read_text())["nesting"]
    assert nest["violations_beta_0"] == 0  # higher alpha nests inside lower alpha, exactly
    # a study's results are not replaced without --overwrite
    assert main(["ablate-alpha", "metric", "-o", str(out), "--mesh", str(OCTOPUS), "-q"]) == 2


def test_ablate_alpha_default_data(tmp_path):
    out = tmp_path / "alpha"
    assert main(["ablate-alpha", "metric", "-o", str(out), "--size", "16", "-q"]) == 0
    info = json.loads((out / "metric.json").read_text())
    assert info["data"].endswith("torus.obj") and len(info["renders"]) == 2


# ----------------------------------------------------------------------------- bench-grid
def _write_obj(path, V, F=None):
    lines = [f"v {x:.9g} {y:.9g} {z:.9g}" for x, y, z in V]
    lines += [f"f {' '.join(str(i + 1) for i in f)}" for f in (F if F is not None else [])]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


def test_bench_grid_two_meshes(tmp_path, cube, icosphere):
    src = tmp_path / "meshes"
    src.mkdir()
    _write_obj(src / "cube.obj", cube.V * 3.0 + 5.0, cube.triangles)
    _write_obj(src / "ico.obj", icosphere.V, icosphere.triangles)
    (src / "notes.txt").write_text("not a mesh")
    out = tmp_path / "bench"
    assert main(["bench-grid", str(src), "-o", str(out), "--grid", "8", "-q"]) == 0
    rows = _rows(out / "bench_grid.csv")
    assert list(rows[0]) == grid.BENCH_FIELDS + runner.META_FIELDS
    assert [r["name"] for r in rows] == ["cube", "ico"]
    cube_row = rows[0]
    assert int(cube_row["nV"]) == 8 and int(cube_row["nE"]) == 18 and int(cube_row["nF"]) == 12
    for r in rows:
        for L in "vef":
            assert 1.0 <= float(r[f"leaves_{L}"]) and float(r[f"seconds_{L}"]) >= 0.0
        assert float(r["leaves_v"]) <= int(r["nV"])
    for name in ("bench_time_vs_leaves.png", "bench_leaf_fraction.png", "bench_grid.json"):
        assert (out / name).is_file()
    assert main(["bench-grid", str(src), "-o", str(out), "--grid", "8", "-q"]) == 2
    assert main(["bench-grid", str(src), "-o", str(out), "--grid", "8", "-q", "--resume"]) == 0
    assert len(_rows(out / "bench_grid.csv")) == 2
    assert main(["bench-grid", str(tmp_path / "nowhere"), "-o", str(tmp_path / "b2")]) == 2


def test_bench_grid_without_a_folder_uses_the_shipped_meshes(tmp_path, monkeypatch, capsys):
    """No DIR: the three meshes in scenes/data/meshes (not a Thingi10K folder users lack),
    whatever the working directory; the help names that default."""
    shipped = common.REPO / "scenes" / "data" / "meshes"
    names = sorted(p.name for p in grid.mesh_files(shipped))
    assert len(names) == 3
    monkeypatch.chdir(tmp_path)
    assert main(["bench-grid", "-o", "out", "--grid", "4", "-q", "--scheduler", "serial"]) == 0
    rows = _rows(tmp_path / "out" / "bench_grid.csv")
    assert sorted(r["file"] for r in rows) == names
    assert all(r["status"] == "ok" for r in rows), rows
    params = json.loads((tmp_path / "out" / "bench_grid.json").read_text())
    assert Path(params["folder"]) == shipped.resolve()
    with pytest.raises(SystemExit):
        main(["bench-grid", "--help"])
    assert "scenes/data/meshes" in " ".join(capsys.readouterr().out.split())


def test_benchmark_normalisation_and_grid():
    V = np.array([[0.0, 0, 0], [4, 2, 0], [1, 1, 6]])
    W = grid.benchmark_normalise(V)
    lo, hi = W.min(0), W.max(0)
    np.testing.assert_allclose(0.5 * (lo + hi), 0.5)
    np.testing.assert_allclose(np.linalg.norm(hi - lo), 0.5)
    Q = grid.voxel_centres(4)
    assert Q.shape == (64, 3) and Q.min() == 0.125 and Q.max() == 0.875


# ----------------------------------------------------------------------------- bh-switch
def test_bh_switch_summary(tmp_path):
    rng = np.random.default_rng(3)
    xy = rng.random((1500, 2)) * [4.0, 2.0]
    z = 0.2 * np.sin(2 * xy[:, 0]) + 0.02 * rng.random(1500)
    cloud = tmp_path / "terrain.obj"
    _write_obj(cloud, np.column_stack([xy, z]))
    out = tmp_path / "bh"
    assert main(["bh-switch", str(cloud), "-o", str(out), "--trials", "40", "--seed", "1",
                 "-q"]) == 0
    summary = json.loads((out / "bh_switch.json").read_text())
    assert summary["hits"] > 0 and summary["switch_points"] > 0
    kept = summary["kept"]
    assert kept["count"] > 0
    for k in ("mean_discrepancy", "max_discrepancy", "mean_cosine", "min_cosine"):
        assert np.isfinite(kept[k]), k
    assert 0 <= kept["mean_discrepancy"] <= kept["max_discrepancy"]
    assert -1.0 <= kept["min_cosine"] <= kept["mean_cosine"] <= 1.0 + 1e-12
    rows = _rows(out / "bh_switch.csv")
    assert len(rows) == summary["switch_points"]
    assert sum(int(r["kept"]) for r in rows) == kept["count"]
    assert all(int(r["leaves_dbeta"]) < int(r["leaves"]) for r in rows if r["kept"] == "1")
    assert (out / "bh_switch.png").is_file()
    assert main(["bh-switch", str(cloud), "-o", str(out), "--trials", "4", "-q"]) == 2


# ----------------------------------------------------------------------------- defaults
@pytest.mark.slow
def test_default_output_folders(tmp_path, monkeypatch):
    """The README's commands need no -o: results go under renders/ablation/ (cwd-relative)."""
    monkeypatch.chdir(tmp_path)
    assert main(["ablate-beta", str(OCTOPUS), *BETA_ARGS, "--types", "points", "--size", "16"]) == 0
    assert (tmp_path / "renders" / "ablation" / "beta-16" / "beta_ablation.csv").is_file()
    src = tmp_path / "meshes"
    src.mkdir()
    (src / "tri.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    assert main(["bench-grid", str(src), "--grid", "4", "-q"]) == 0
    assert (tmp_path / "renders" / "ablation" / "grid-meshes" / "bench_grid.csv").is_file()


def test_beta_estimate_is_printed_before_the_renders(tmp_path, capsys, monkeypatch):
    import tracer.rendering.renderer

    real = tracer.rendering.renderer.render
    seen = []

    def spying(scene, **kw):
        if scene.width == 72:  # a full-size render: the estimate must be out already
            seen.append(capsys.readouterr().out)
        return real(scene, **kw)

    monkeypatch.setattr(tracer.rendering.renderer, "render", spying)
    assert main(["ablate-beta", str(OCTOPUS), "-o", str(tmp_path / "b"), "--size", "72",
                 "--betas", "1", "--types", "points", "--alpha", "40", "--alpha-u", "300",
                 "--scheduler", "serial"]) == 0
    assert len(seen) == 2  # beta 0 and beta 1
    # the parameters first (issue 46), then the estimate
    params, first = seen[0].strip().splitlines()[:2]
    assert params.startswith("parameters: the given parameters: points alpha 40, alpha_U 300")
    assert first.startswith("estimate (from 8x8 probe renders") and "beta = 0 renders" in first


def test_beta_estimate_is_printed_at_small_sizes(tmp_path, capsys):
    """--size 64 and below printed no estimate (and estimated 0 s): now every size does."""
    assert main(["ablate-beta", str(OCTOPUS), "-o", str(tmp_path / "b"), "--size", "64",
                 "--betas", "0.5,1", "--types", "points", "--alpha", "40", "--alpha-u", "300",
                 "--scheduler", "serial"]) == 0
    lines = capsys.readouterr().out.splitlines()
    est = [ln for ln in lines if ln.startswith("estimate (from 8x8 probe renders")]
    assert len(est) == 1, lines
    assert "beta = 0 renders" in est[0] and "all 3 renders" in est[0]
    assert "in-process with" in est[0]


def test_beta_study_estimated_above_the_threshold_is_not_run_in_process(tmp_path, capsys,
                                                                         monkeypatch):
    """A 64² study whose probes say 72 s (the bunny's beta = 0 renders are that slow) is not
    judged small enough for in-process: --scheduler local asks for its cluster (stubbed)."""
    from tracer.errors import CLIError
    from tracer.studies import beta

    def fake_probe(tasks, probe_size):
        assert probe_size == 8
        return [70.0 if t["beta"] == 0 else 1.0 for t in tasks]

    def no_cluster(mode, workers=None, **kw):
        raise CLIError(f"stub: a {mode} cluster was asked for")

    monkeypatch.setattr(beta, "probe", fake_probe)
    monkeypatch.setattr(runner, "connect", no_cluster)
    monkeypatch.setattr(runner, "cpu_count", lambda: 2)
    # the estimator on its own
    tasks = beta.list_tasks(str(OCTOPUS), ["points"], [0.5, 1.0], [0.0], size=64, alpha=40.0,
                            alpha_u=300.0, eps=None)
    said = []
    total = beta._estimate(tasks, 64, "local", None, said.append)
    assert total == 72.0 > runner.LOCAL_MIN_SECONDS
    assert [t["weight"] for t in tasks] == [70.0, 1.0, 1.0]
    assert runner.choose_mode("local", None, len(tasks), total) == "local"
    # one thread per worker: the 70 s render takes longer there than in-process
    assert len(said) == 1 and "all 3 renders 72.0s of work in-process" in said[0], said
    assert said[0].endswith("wall time on 2 worker(s)"), said
    # and the command: it goes for the local cluster instead of rendering in this process
    assert main(["ablate-beta", str(OCTOPUS), "-o", str(tmp_path / "b"), "--size", "64",
                 "--betas", "0.5,1", "--types", "points", "--alpha", "40", "--alpha-u",
                 "300"]) == 2
    assert "stub: a local cluster was asked for" in capsys.readouterr().err


def test_beta_difference_heat_map_has_a_colour_bar(beta_run):
    """beta_diff.png: the per-pixel |t_beta - t_0| maps, with a colour bar stating its units."""
    from tracer.studies import beta, plots

    rows = [beta.typed_row(r) for r in _rows(beta_run / "beta_ablation.csv")]
    params = json.loads((beta_run / "beta_params.json").read_text())
    fig = plots.beta_diff_figure(beta_run / "cache", rows, list(common.TYPES),
                                 [0.0, 0.2, 0.5, 1.0], params)
    try:
        bars = [ax for ax in fig.axes if ax.get_label() == "<colorbar>"]
        assert len(bars) == 1 and len(fig.axes) == 3 * 2 + 1  # 3 types x betas 0.5, 1; bar
        assert "% of bbox diagonal" in bars[0].get_ylabel()
        images = [im for ax in fig.axes for im in ax.get_images()]
        assert len(images) == 6
        lo, hi = images[0].norm.vmin, images[0].norm.vmax
        assert lo == 0.0 and hi > 0.0 and bars[0].get_ylim() == (lo, hi)
    finally:
        plots.pyplot().close(fig)
    assert (beta_run / "beta_diff.png").is_file()
    assert "beta_diff.png" in (beta_run / "report.md").read_text(encoding="utf-8")


def test_beta_error_over_a_tiny_hit_set_is_undefined(tmp_path):
    """An error over fewer pixels hit by both renders than MIN_ERROR_PIXELS and
    MIN_ERROR_SHARE of the image is NaN (shown as "undefined"), never 0 %; from that many
    pixels on it is the mean depth difference."""
    from tracer.studies import beta
    from tracer.studies.plots import percent

    def write(kind, b, depth):
        np.save(tmp_path / f"depth_{beta.file_stem(kind, b, 0.0)}.npy", depth)

    n = int(max(beta.MIN_ERROR_PIXELS, np.ceil(beta.MIN_ERROR_SHARE * 128 * 128)))
    ref = np.full((128, 128), np.nan)
    ref.flat[:4] = 1.0                          # 4 hit pixels: a user's mesh at the paper's alpha
    write("points", 0.0, ref)
    write("points", 0.5, ref + 0.25)
    big = np.full((128, 128), np.nan)
    big.flat[:n] = 2.0
    write("edges", 0.0, big)
    write("edges", 0.5, big + 0.5)
    rows = [{"type": k, "beta": 0.5, "tol": 0.0, "diag": 10.0} for k in ("points", "edges")]
    tiny, enough = beta.with_errors(rows, tmp_path)
    assert tiny["n_both"] == 4 and np.isnan(tiny["error_rel_diag"])
    assert percent(tiny["error_rel_diag"], 2) == "undefined"
    assert enough["n_both"] == n and enough["error_abs"] == pytest.approx(0.5)
    assert percent(enough["error_rel_diag"], 2) == "5.0%"


def test_small_errors_and_times_keep_their_digits():
    """A figure's numbers have significant digits: the beta grid's "mean 0.00%" for an error of
    0.003 % of the diagonal, and the alpha panels' "(0.0 s)" for 40 ms renders, were wrong."""
    from tracer.studies.plots import percent, significant

    assert percent(3.1e-5) == "0.0031%" and percent(0.05) == "5.0%" and percent(1.0) == "100%"
    assert percent(0.0) == "0.0%" and percent(float("nan")) == "undefined"
    assert significant(0.04312) == "0.043" and significant(12.34) == "12"
    assert significant(123.4, 3) == "123" and significant(0.1) == "0.10"
