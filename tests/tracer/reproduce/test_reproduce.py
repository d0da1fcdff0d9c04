"""``tracer reproduce`` (tracer/reproduce/): the committed report page against its results
folder, numbers on it against independent recomputations from the raw CSVs, a page or result
edited by hand caught, the smallest run end to end, bad input refused without output."""

import json
import math
import re
import shutil
from pathlib import Path

import pytest

from tracer.cli import main
from tracer.reproduce import report
from tracer.reproduce.claims import CLAIMS, evaluate
from tracer.reproduce.experiments import SETTINGS, TABLE3_PAPER

REPO = Path(__file__).resolve().parents[3]
RESULTS = REPO / "renders" / "reproduction" / "full"
PAGE = REPO / "docs" / "reproduction.md"
SHOWN = "renders/reproduction/full"


# ------------------------------------------------------------------ independent checks
def _table(text, heading):
    """The rows (lists of cells) of the first Markdown table after ``## heading``."""
    part = text.split(f"## {heading}\n", 1)[1]
    rows = []
    for line in part.splitlines():
        if line.startswith("## "):
            break
        if line.startswith("|") and not line.startswith("|---"):
            rows.append([c.strip() for c in re.split(r"(?<!\\)\|", line)[1:-1]])
    return rows[1:]  # without the header


def _pearson(x, y):
    """Pearson's r in plain Python (not numpy's corrcoef, which the experiment uses)."""
    n = len(x)
    mx, my = sum(x) / n, sum(y) / n
    sxy = sum((a - mx) * (b - my) for a, b in zip(x, y))
    sxx = sum((a - mx) ** 2 for a in x)
    syy = sum((b - my) ** 2 for b in y)
    return sxy / math.sqrt(sxx * syy)


def _csv_rows(path):
    import csv

    with open(path, newline="", encoding="utf-8") as fh:
        return list(csv.DictReader(fh))


def _same3(cell, value):
    """A page cell (3 significant digits) shows ``value``."""
    return math.isclose(float(cell), float(f"{value:.3g}"), rel_tol=1e-9)


def disagreements(page_text, folder, shown=SHOWN):
    """What the page says that the results folder does not (empty when they agree)."""
    out = []
    if page_text != report.render_page(folder, shown):
        out.append("the page is not the one generated from the results folder")
    with open(Path(folder) / "claims.json", encoding="utf-8") as fh:
        if json.load(fh) != evaluate(report.load_results(folder)):
            out.append("claims.json is not the claims judged from the experiments' JSON")
    res = report.load_results(folder)
    # Table 3: the page's ms against table3.json, read here without the report's code
    if "table3" in res:
        # two rows share a query (the bunny), so a row is its data and query together
        by_pair = {(d, q): n for n, (_, d, q, _, _) in TABLE3_PAPER.items()}
        for cells in _table(page_text, "Table 3 as the paper states it"):
            name = by_pair.get((cells[0], cells[1]))
            r = res["table3"]["rows"].get(name) if name else None
            if r is None:
                continue
            run = next((x for x in r["runs"] if str(x["threads"]) == cells[5]), None)
            if run is None or not _same3(cells[4], run["ms_mean"]):
                out.append(f"Table 3 {name}: page {cells[4]} ms on {cells[5]} threads, "
                           f"results {r['runs']}")
    # the benchmark: Pearson r recomputed from the bench_grid.csv files
    if "grid" in res:
        g = res["grid"]
        rows = [r for p in g["csv"] for r in _csv_rows(Path(folder) / p)
                if r.get("status", "ok") == "ok"]
        N3 = float(g["grid"]) ** 3
        for cells in _table(page_text, "The benchmark figure"):
            L = {"points": "v", "edges": "e", "triangles": "f"}[cells[0]]
            pts = [(float(r[f"leaves_{L}"]), float(r[f"seconds_{L}"]) / N3) for r in rows
                   if r.get(f"seconds_{L}")]
            if len(pts) > 2 and not _same3(cells[2], _pearson(*zip(*pts))):
                out.append(f"benchmark {cells[0]}: page r {cells[2]}, CSVs give "
                           f"{_pearson(*zip(*pts))}")
            if int(cells[1]) != len(pts):
                out.append(f"benchmark {cells[0]}: page {cells[1]} meshes, CSVs {len(pts)}")
    # the beta study: time(beta 0) / time(beta 0.2) from the study's CSV
    if "beta" in res:
        rows = _csv_rows(Path(folder) / res["beta"]["csv"])
        claim = next(c for c in _table(page_text, "Claims") if "β=0.2" in c[1])
        for kind in ("points", "edges", "triangles"):
            t = {float(r["beta"]): float(r["seconds"]) for r in rows if r["type"] == kind
                 and float(r.get("tol") or 0) == 0}
            if f"{kind} {t[0.0] / t[0.2]:.3g}x" not in claim[4]:
                out.append(f"beta {kind}: page {claim[4]!r}, CSV {t[0.0] / t[0.2]:.3g}x")
    return out


# ------------------------------------------------------------------ the committed report
def test_committed_page_matches_results():
    assert disagreements(PAGE.read_text(encoding="utf-8"), RESULTS) == []


@pytest.mark.parametrize("folder", sorted(p.name for p in RESULTS.parent.iterdir()
                                          if (p / "run.json").is_file()))
def test_every_committed_results_folder_matches_its_page(folder):
    path = RESULTS.parent / folder
    text = (path / "reproduction.md").read_text(encoding="utf-8")
    assert disagreements(text, path, f"renders/reproduction/{folder}") == []


def test_committed_results_have_provenance_and_every_claim_a_row():
    run = report.load_run(RESULTS)
    for name, res in report.load_results(RESULTS).items():
        p = res["provenance"]
        assert re.fullmatch(r"[0-9a-f]{40}", p["commit"]), name
        assert re.fullmatch(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ", p["date"]), name
        assert p["machine"]["cpu"] and p["machine"]["cores"] >= 1 and p["numba_threads"] >= 1
        assert res["settings"] and res["mode"] == run["mode"]
    rows = evaluate(report.load_results(RESULTS))
    page = PAGE.read_text(encoding="utf-8")
    assert len(_table(page, "Claims")) == len(rows) >= 23
    for r in rows:  # every claim is judged, and a verdict other than a match says why
        assert r["verdict"] in ("match", "differs", "not comparable", "cannot be reproduced",
                                "inconclusive", "not run")
        assert r["verdict"] == "match" or r["reason"]
        if r["experiment"] is not None and r["verdict"] != "not run":
            assert r["last_run"] and r["last_run"][:10] in page


@pytest.mark.parametrize("where", ["page", "results"])
def test_an_edited_number_is_caught(tmp_path, where):
    folder = tmp_path / "quick"
    shutil.copytree(RESULTS, folder)
    page = PAGE.read_text(encoding="utf-8")
    res = json.loads((folder / "table3.json").read_text())
    name = next(iter(res["rows"]))
    ms = res["rows"][name]["runs"][0]["ms_mean"]
    if where == "page":
        cell = f"{ms:.3g}"
        row = next(line for line in page.splitlines()
                   if line.startswith("| ") and f"| {cell} |" in line)
        page = page.replace(row, row.replace(f"| {cell} |", f"| {float(cell) * 2:.3g} |"))
    else:
        res["rows"][name]["runs"][0]["ms_mean"] = ms * 2
        (folder / "table3.json").write_text(json.dumps(res))
    problems = disagreements(page, folder)
    assert problems and any("Table 3" in p or "not the one generated" in p for p in problems)


# ------------------------------------------------------------------ the guides
FULL = REPO / "renders" / "reproduction" / "full"


def _guide(name):
    return (REPO / "docs" / "guide" / name).read_text(encoding="utf-8")


def test_guides_show_the_committed_results():
    """The guides' figures that the report also measures are the generated blocks, and their
    numbers are those of the results files (read here without the generator's code)."""
    from tracer.reproduce import docs

    assert docs.disagreements() == []
    box = json.loads((FULL / "box_test.json").read_text())
    text = _guide("whole-mesh.md")
    for name, c in box["cases"].items():
        row = next(ln for ln in text.splitlines() if ln.startswith(f"| {name} ("))
        cells = [x.strip() for x in row.strip("|").split("|")]
        for cell, v in ((cells[5], c["ms_on"]), (cells[6], c["ms_off"])):
            shown = float(cell.split()[0].replace(",", ""))
            assert math.isclose(shown, v, rel_tol=5e-3 if v < 1000 else 5e-4), (cell, v)
    h = json.loads((FULL / "bh_switch.json").read_text())
    text = _guide("studies.md")
    for key in ("mean_discrepancy", "max_discrepancy"):
        assert f"{h[key]:.3g}" in text
    assert f"{h['kept_points']} switch points" in text and f"{h['min_cosine']:.4f}" in text
    # the 512² beta table against its CSV
    rows, path, _ = docs._beta_rows()
    r = next(r for r in rows if r["type"] == "edges" and float(r["beta"]) == 0.5)
    assert f" s ({100 * float(r['error_rel_diag']):.3g})" in text
    block = docs.current("docs/guide/studies.md", "beta-512")
    cell = next(ln for ln in block.splitlines() if ln.startswith("| edges |")).split("|")[3]
    assert math.isclose(float(cell.split()[0]), float(r["seconds"]), rel_tol=5e-3)


def test_an_edited_guide_figure_is_caught():
    from tracer.reproduce import docs

    box = json.loads((FULL / "box_test.json").read_text())
    ms = f"{box['cases']['bowl-ico']['ms_on']:.3g} ms"
    text = _guide("whole-mesh.md")
    assert ms in text
    edited = text.replace(ms, "0.001 ms", 1)
    problems = docs.disagreements(lambda g: edited if g.endswith("whole-mesh.md")
                                  else (REPO / g).read_text(encoding="utf-8"))
    assert problems == ["docs/guide/whole-mesh.md: block whole-mesh-speed is not the one "
                        "generated from the results"]


# ------------------------------------------------------------------ the command
@pytest.mark.slow
def test_quick_run_end_to_end(tmp_path, capsys):
    """``tracer reproduce --quick``, as a user runs it (issue 36 asks CI to: under a minute on
    2 cores once the kernels are compiled)."""
    out = tmp_path / "res"
    page = tmp_path / "page.md"
    # --allow-dirty: the tests run on work trees with local changes too (a developer's); the
    # refusal itself is tested on its own
    assert main(["reproduce", "--quick", "--out", str(out), "--page", str(page), "-q",
                 "--allow-dirty"]) == 0
    for name in ("underestimate", "table3", "grid", "bh_switch", "box_test", "gpu", "beta",
                 "alpha"):
        res = json.loads((out / f"{name}.json").read_text())
        assert {"commit", "date", "machine", "numba_threads"} <= set(res["provenance"])
        assert res["settings"] and res["mode"] == "quick"
    rows = json.loads((out / "claims.json").read_text())
    assert len(rows) == len(CLAIMS)
    # a verdict for every claim but the Table 3 rows that --quick leaves to the full run and
    # the claims no experiment measures (each says why)
    quick = {f"table3-{n}" for n in SETTINGS["quick"]["table3"]["scenes"]}
    unmeasured = {"gpu-leaves"} | {c[0] for c in CLAIMS if c[4] is None}
    assert all(r["verdict"] != "not run" for r in rows if r["id"] not in unmeasured
               and (not r["id"].startswith("table3-") or r["id"] in quick)), rows
    assert all(r["reason"] for r in rows if r["verdict"] == "not run")
    text = page.read_text(encoding="utf-8")
    assert text == (out / "reproduction.md").read_text(encoding="utf-8")
    assert report.render_page(out, str(out)) == text  # regenerated from the folder alone
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no partial folder
    # the underestimate experiment against the paper's bound, from its JSON
    u = json.loads((out / "underestimate.json").read_text())
    for kind, row in u["types"].items():
        assert row["beta_0"]["min_gap"] >= 0 and row["beta_0"]["max_gap"] <= row["bound"]
        assert row["beta_0.5"]["min_gap"] >= 0
    # regenerating from the folder gives the same page
    assert main(["reproduce", "--report-only", "--out", str(out), "-q", "--allow-dirty"]) == 0
    assert (out / "reproduction.md").read_text(encoding="utf-8") == text


def test_failed_experiment_leaves_nothing(tmp_path, monkeypatch, capsys):
    from tracer.reproduce import experiments

    def boom(out, s, where):
        out.mkdir(parents=True)
        (out / "half.csv").write_text("x\n")
        raise ValueError("broken on purpose")

    monkeypatch.setitem(experiments.EXPERIMENTS, "grid", boom)
    out = tmp_path / "res"
    assert main(["reproduce", "--smoke", "--only", "grid", "--out", str(out),
                 "--allow-dirty"]) == 2
    assert "broken on purpose" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("argv, text", [
    (["--only", "nope"], "--only: unknown experiment(s) nope"),
    (["--quick", "--smoke"], "exclude each other"),
    (["--report-only"], "holds no results"),
    (["--page", "."], "--page is a folder"),
    (["--page", "no/such/dir/page.md"], "folder not found"),
])
def test_bad_input(tmp_path, capsys, argv, text):
    out = tmp_path / "res"
    assert main(["reproduce", "--out", str(out), *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error:") and text in err[0]
    assert not out.exists()


def test_existing_results_kept_without_overwrite(tmp_path, capsys):
    out = tmp_path / "res"
    out.mkdir()
    (out / "keep.json").write_text("{}")
    assert main(["reproduce", "--smoke", "--out", str(out)]) == 2
    assert "--overwrite" in capsys.readouterr().err
    assert [p.name for p in out.iterdir()] == ["keep.json"]
    f = tmp_path / "file"
    f.write_text("x")
    assert main(["reproduce", "--smoke", "--out", str(f)]) == 2
    assert "not a folder" in capsys.readouterr().err


def test_table3_scenes_add_rows_to_the_earlier_ones(tmp_path, monkeypatch, capsys):
    """A run of some Table 3 scenes (``--table3-scenes``) into a results folder keeps the
    rows of the scenes it did not run, each with the date and commit of its own run."""
    from tracer.reproduce import experiments

    def fake(out, s, where):  # one row per scene, ms = the paper's row number
        rows = {n: {"scene": n, "steps": 3, "file_steps": 3, "dt": 0.01,
                    "runs": [{"threads": 1, "evaluations": 5, "ms_mean": float(row),
                              "ms_median": float(row), "load_average_before": 0.0}],
                    "run": {"date": f"2026-01-0{row}T12:00:00Z", "commit": "c" * 40}}
                for n, (row, *_rest) in experiments.TABLE3_PAPER.items() if n in s["scenes"]}
        return {"scenes": s["scenes"], "rows": rows, "authors_simulator": "not run",
                "not_run": [n for n in experiments.TABLE3_PAPER if n not in rows]}

    monkeypatch.setitem(experiments.EXPERIMENTS, "table3", fake)
    out = tmp_path / "res"
    base = ["reproduce", "--smoke", "--only", "table3", "--out", str(out), "-q",
            "--allow-dirty"]
    assert main(base + ["--table3-scenes", "ico_bowl,sphere_slide"]) == 0
    assert main(base + ["--table3-scenes", "sphere_slide,bunny_bunny"]) == 0
    res = json.loads((out / "table3.json").read_text())
    assert list(res["rows"]) == ["ico_bowl", "bunny_bunny", "sphere_slide"]  # the paper's order
    assert [res["rows"][n]["runs"][0]["ms_mean"] for n in res["rows"]] == [1.0, 5.0, 7.0]
    assert "ico_bowl" not in res["not_run"] and "bunny_lidar" in res["not_run"]
    page = (out / "reproduction.md").read_text(encoding="utf-8")
    assert "run 2026-01-01 at commit cccccccccccc" in page  # ico_bowl's, from the first run
    # without --table3-scenes the run is the whole table again: nothing old is kept
    assert main(base) == 0
    res = json.loads((out / "table3.json").read_text())
    assert list(res["rows"]) == ["trefoil_ringtoss"]


def test_beta_speedup_says_which_leaves_beta_prunes():
    """Claim 1 when it differs: the reason gives the leaves visited per evaluation at beta 0
    against beta 0.2 (from the study's rows), so a reader sees why the time ratio is what it
    is; without those rows the reason is the plain one."""
    from tracer.reproduce import claims

    secs = {"points": (8.0, 1.0), "edges": (30.0, 2.0), "triangles": (9.0, 1.0)}
    leaves = {"points": (3485.0, 500.0), "edges": (10449.0, 1000.0), "triangles": (6966.0, 1200.0)}
    b = {"size": 512, "threads": 2,
         "render_seconds": {k: {"0": t0, "0.2": t2} for k, (t0, t2) in secs.items()},
         "leaves_per_eval": {k: {"0": l0, "0.2": l2} for k, (l0, l2) in leaves.items()}}
    ours, _, verdict, why = claims._beta_speedup({"beta": b})
    assert verdict == claims.DIFFERS and "points 8x" in ours and "edges 15x" in ours
    assert "points 6.97x, edges 10.4x, triangles 5.8x" in why
    del b["leaves_per_eval"]
    assert claims._beta_speedup({"beta": b})[3] == \
        "time(beta 0) / time(beta 0.2) is below 10 for some type; " + claims.NO_SPREAD


def test_gpu_experiment_runs_the_benchmark_where_a_card_is(tmp_path, monkeypatch):
    """With a card, the gpu experiment runs benchmarks/bench_gpu.py at the mode's sizes and
    reads its JSON (the card here is a stand-in: the committed H100 results play the
    benchmark's output); without one it reads the committed measurement. Both give the same
    figures from the same file."""
    import subprocess

    from tracer.reproduce import experiments

    card = json.loads(experiments.GPU_CARD_RESULT.read_text(encoding="utf-8"))
    seen = []

    real_run = subprocess.run

    def fake_run(argv, **kw):
        if not any(str(a).endswith("bench_gpu.py") for a in argv):
            return real_run(argv, **kw)  # git and lscpu, for the provenance
        seen.append(argv)
        Path(argv[argv.index("--json") + 1]).write_text(json.dumps(card), encoding="utf-8")

    monkeypatch.setattr(experiments, "_card_available", lambda: True)
    monkeypatch.setattr(subprocess, "run", fake_run)
    s = SETTINGS["quick"]["gpu"]
    here = experiments.gpu(tmp_path / "gpu", s, {})
    argv = seen[0]
    assert argv[1].endswith("bench_gpu.py") and argv[argv.index("--grid") + 1] == str(s["grid"])
    assert argv[argv.index("--size") + 1:argv.index("--size") + 3] == [str(v) for v in s["size"]]
    assert here["source"] == "measured here" and (tmp_path / "gpu" / "bench_gpu.json").is_file()
    monkeypatch.setattr(experiments, "_card_available", lambda: False)
    stored = experiments.gpu(tmp_path / "gpu2", s, {})
    assert stored["source"] == "benchmarks/data/gpu_h100.json"
    assert here["grid"] == stored["grid"] and here["render"] == stored["render"]
    rows = {r["what"]: r for r in card["rows"]}
    assert stored["grid"]["points"]["kernel_speedup"] == pytest.approx(
        rows["grid points"]["cpu_s"] / rows["grid points"]["gpu_kernel_s"], rel=1e-12)


# ------------------------------------------------------------------ provenance (issue 48)
def _fake_gpu(out, s, where):
    return {"source": None, "why": "no card (a stand-in experiment)"}


def test_a_dirty_tree_is_refused_unless_allowed(tmp_path, monkeypatch, capsys):
    """A run on a tree with uncommitted changes is refused before any experiment runs; with
    --allow-dirty it runs and the page says which results are so."""
    from tracer.reproduce import experiments

    ran = []
    monkeypatch.setattr(experiments, "tree_dirty", lambda: True)
    monkeypatch.setitem(experiments.EXPERIMENTS, "gpu",
                        lambda o, s, w: ran.append(1) or _fake_gpu(o, s, w))
    out = tmp_path / "res"
    argv = ["reproduce", "--smoke", "--only", "gpu", "--out", str(out), "-q"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "uncommitted changes" in err and "--allow-dirty" in err
    assert ran == [] and not out.exists()
    assert main(argv + ["--allow-dirty"]) == 0
    page = (out / "reproduction.md").read_text(encoding="utf-8")
    assert "Written with `--allow-dirty`:** the results of gpu, run" in page


def test_report_only_refuses_dirty_results(tmp_path, capsys):
    """Results of a dirty tree: the report is refused without --allow-dirty (and nothing is
    rewritten), written with it and says so. The committed results come from a clean tree
    (issue 48's rerun); a copy with one of them marked dirty stands for the other case."""
    assert report.dirty_results(RESULTS) == []
    folder = tmp_path / "full"
    shutil.copytree(RESULTS, folder)
    grid = json.loads((folder / "grid.json").read_text(encoding="utf-8"))
    grid["provenance"]["dirty"] = True
    (folder / "grid.json").write_text(json.dumps(grid), encoding="utf-8")
    assert report.dirty_results(folder) == ["grid"]
    before = (folder / "reproduction.md").read_text(encoding="utf-8")
    assert main(["reproduce", "--report-only", "--out", str(folder), "-q"]) == 2
    assert "results of a tree with local changes" in capsys.readouterr().err
    assert (folder / "reproduction.md").read_text(encoding="utf-8") == before
    assert main(["reproduce", "--report-only", "--out", str(folder), "-q",
                 "--allow-dirty"]) == 0
    page = (folder / "reproduction.md").read_text(encoding="utf-8")
    assert "Written with `--allow-dirty`" in page


def test_code_changed_says_unknown_without_git(monkeypatch):
    from tracer.reproduce import experiments

    head = experiments.head_commit()
    assert experiments.code_changed(head, head) == "unchanged"
    assert experiments.code_changed("unknown", head) == "unknown"
    assert experiments.code_changed("f" * 40, head) == "unknown"  # no such commit
    monkeypatch.setattr(experiments, "_git_status", lambda *a: None)
    assert experiments.code_changed(head, head) == "unknown"
    assert experiments.tree_dirty() is None


def test_experiments_table_shows_tree_and_code_state():
    """Each experiment's row: its commit, clean or dirty, and whether the measured code
    changed since (as run.json's report state records it)."""
    run = report.load_run(RESULTS)
    rows = _table(PAGE.read_text(encoding="utf-8"), "Experiments")
    assert {r[0] for r in rows} == set(report.load_results(RESULTS))
    for r in rows:
        res = json.loads((RESULTS / f"{r[0]}.json").read_text())
        # the commit its figures measured (a card's committed file names its own)
        assert r[3].startswith(report.measured_commit(res)[:12])
        assert res["provenance"]["commit"][:12] in r[3]
        assert r[4] == {True: "dirty", False: "clean"}.get(res["provenance"]["dirty"],
                                                           "unknown")
        assert r[5].split()[0] == run["report"]["code"][r[0]]
        assert r[5].split()[0] in ("changed", "unchanged", "unknown")


def test_the_page_names_no_absolute_path():
    for text in (PAGE.read_text(encoding="utf-8"),
                 *(p.read_text(encoding="utf-8")
                   for p in RESULTS.parent.glob("*/reproduction.md"))):
        assert "/work/" not in text and "/home/" not in text


# ------------------------------------------------------------------ verdicts (issue 48)
def test_a_spread_that_straddles_the_threshold_is_inconclusive():
    from tracer.reproduce import claims

    assert claims.judge(5.5, 7.0, 5) == "match"
    assert claims.judge(3.0, 4.9, 5) == "differs"
    assert claims.judge(4.86, 7.44, 5) == "inconclusive"  # the issue's bowl-ico runs
    assert claims.judge(8.0, 9.0, 10, above=False) == "match"
    assert claims.combine(["match", "inconclusive"]) == "inconclusive"
    assert claims.combine(["match", "inconclusive", "differs"]) == "differs"


def _box(on, off):
    case = {"data_primitives": 736, "data_kind": "edges", "query_primitives": 120,
            "query_kind": "edges", "ms_on": sorted(on)[len(on) // 2],
            "ms_off": sorted(off)[len(off) // 2], "ms_on_all": on, "ms_off_all": off}
    case["speedup"] = case["ms_off"] / case["ms_on"]
    return {"box_test": {"beta": 0.5, "repeat": len(on), "threads": 2, "cases": {"c": case},
                         "load_average_before": [1.5, 1, 1],
                         "provenance": {"load_average": [2.5, 1, 1]}}}


def test_box_test_verdict_follows_the_rounds_spread():
    from tracer.reproduce import claims

    ours, setting, verdict, why = claims._box_test(_box([10, 10, 10], [60, 70, 80]))
    assert verdict == "match" and "rounds 6-8x" in ours and "load 1.5 before, 2.5 after" \
        in setting
    ours, _, verdict, why = claims._box_test(_box([10, 10, 10], [45, 60, 70]))
    assert verdict == "inconclusive" and "rounds 4.5-7x" in ours and "straddle" in why
    assert claims._box_test(_box([10, 10, 10], [30, 40, 45]))[2] == "differs"


def test_beta_verdicts_use_the_repeats():
    from tracer.reproduce import claims

    def beta(t0, t2, t5):
        return {"beta": {"size": 512, "threads": 2, "repeat": len(t0),
                         "render_seconds": {k: {"0": t0[0], "0.2": t2[0], "0.5": t5[0]}
                                            for k in claims.TYPES},
                         "render_seconds_repeats": {k: {"0": t0, "0.2": t2, "0.5": t5}
                                                    for k in claims.TYPES}}}

    assert claims._beta_speedup(beta([25, 24], [2, 2.1], [1, 1]))[2] == "match"
    r = claims._beta_speedup(beta([25, 21], [2, 2.2], [1, 1]))
    assert r[2] == "inconclusive" and "repeats 9.55-12.5x" in r[0]
    assert claims._beta_10s(beta([25, 24], [2, 2], [9, 11]))[2] == "inconclusive"
    assert claims._beta_10s(beta([25, 24], [2, 2], [1, 1.2]))[2] == "match"


def test_quick_runs_say_their_timing_verdicts_are_indicative():
    res = report.load_results(RESULTS)
    full = {r["id"]: r for r in evaluate(res)}
    assert not any(r.get("indicative") for r in full.values())
    for r in res.values():
        r["mode"] = "quick"
    quick = {r["id"]: r for r in evaluate(res)}
    assert quick["box-test"]["indicative"] == "a quick run: indicative only"
    assert not quick["underestimate"].get("indicative")  # not a timing


def test_bh_switch_rows_are_not_a_match_on_another_unit():
    """Rows 4-5: on the unit-diagonal cloud they are not comparable; measured the authors' way
    (raw coordinates) with switch points kept they are judged."""
    from tracer.reproduce import claims

    h = json.loads((RESULTS / "bh_switch.json").read_text())
    for fn in (claims._bh_disc, claims._bh_cos):
        assert fn({"bh_switch": h})[2] == "not comparable"
    raw = {"settings": {"alpha": 100.0, "iso": 0.1, "start": 0.01, "segment": 0.005,
                        "samples": 101, "max_steps": 20}, "hits": 400, "switch_points": 300,
           "kept_points": 200, "mean_discrepancy": 5e-5, "max_discrepancy": 1e-3,
           "mean_cosine": 1.0, "min_cosine": 0.999}
    ours, _, verdict, why = claims._bh_disc({"bh_switch": dict(h, raw=raw)})
    assert verdict == "match" and "raw units" in ours and "barnes_hut_smoothness_test" in why
    raw.update(kept_points=0, switch_points=0, hits=1)
    ours, _, verdict, why = claims._bh_disc({"bh_switch": dict(h, raw=raw)})
    assert verdict == "not comparable" and "1 of" in why


def test_no_intersection_row_reads_each_runs_minimum_distance():
    from tracer.reproduce import claims

    def t3(*d):
        return {"table3": {"rows": {f"s{i}": {"steps": 5, "runs": [{"min_exact_distance": x}]}
                                    for i, x in enumerate(d)}}}

    assert claims._no_intersection(t3(0.1, 0.02))[2] == "match"
    assert claims._no_intersection(t3(0.1, 0.0))[2] == "differs"
    assert claims._no_intersection({"table3": {"rows": {"a": {"runs": [{}]}}}})[2] == "not run"


def test_every_claim_of_issue_48_has_a_row():
    ids = {c[0] for c in CLAIMS}
    assert {"grid-variance", "gpu-above-one", "gpu-leaves", "no-intersection", "beta-alpha",
            "attenuation"} <= ids
