"""The reproduction report: ``claims.json`` and the Markdown page from a results folder.

:func:`load_results` reads ``<experiment>.json`` of a results folder, :func:`claims_rows`
judges every claim (:mod:`tracer.reproduce.claims`), :func:`render_page` writes the page from
the rows and the results alone, so that the page can be regenerated, and checked, from the
folder (``tests/tracer/reproduce/test_reproduce.py``).
"""

import json
import re
from pathlib import Path

from tracer.reproduce.claims import evaluate, g3
from tracer.reproduce.experiments import (EXPERIMENTS, MEASURED_CODE, TABLE3_PAPER, code_changed,
                                          grid_fit, head_commit, measured_code, read_csv)

#: the files of a results folder that are not an experiment's
NOT_EXPERIMENTS = {"claims.json", "run.json"}


def load_results(folder):
    """``{experiment: results}`` of every ``<experiment>.json`` in ``folder``. A grid result
    written before the fit held the spread of the share of leaves visited gets it from its
    own CSVs (the same fit, :func:`tracer.reproduce.experiments.grid_fit`)."""
    folder = Path(folder)
    out = {}
    for p in sorted(folder.glob("*.json")):
        if p.name in NOT_EXPERIMENTS:
            continue
        with open(p, encoding="utf-8") as fh:
            out[p.stem] = json.load(fh)
    g = out.get("grid")
    if g and "fit" in g and any("share_sd_pct" not in f for f in g["fit"].values()):
        rows = [r for c in g["csv"] for r in read_csv(folder / c)
                if r.get("status", "ok") == "ok"]
        fit = grid_fit(rows, g["grid"])
        for kind, f in g["fit"].items():
            for key in ("share_mean_pct", "share_sd_pct"):
                f.setdefault(key, fit[kind][key])
    return out


def load_run(folder):
    with open(Path(folder) / "run.json", encoding="utf-8") as fh:
        return json.load(fh)


def claims_rows(folder):
    return evaluate(load_results(folder))


def _dirty_word(flag):
    return {True: "dirty", False: "clean"}.get(flag, "unknown")


def dirty_results(folder):
    """The experiments of ``folder`` (and ``run`` for its run.json) that ran on a tree with
    local changes; ``[]`` for a folder that is not there."""
    folder = Path(folder)
    if not folder.is_dir():
        return []
    out = [n for n, r in load_results(folder).items() if r.get("provenance", {}).get("dirty")]
    if (folder / "run.json").is_file() and load_run(folder).get("dirty"):
        out.append("run")
    return out


def measured_commit(res):
    """The commit an experiment's figures measured: its run's, except for figures read from a
    committed measurement (the GPU card's file), which name their own."""
    m = res.get("measured") or {}
    if res.get("source") not in (None, "measured here") and m.get("commit"):
        return m["commit"]
    return res["provenance"].get("commit")


def report_state(folder, allow_dirty):
    """The report's commit (HEAD now) and, per experiment (and per commit of a Table 3 row),
    whether its measured code (:func:`tracer.reproduce.experiments.measured_code`) changed
    between that experiment's commit and the report's: ``run.json``'s ``report``, from which
    the page is written."""
    head = head_commit()
    res = load_results(folder)
    code = {n: code_changed(measured_commit(r), head, measured_code(n)) for n, r in res.items()}
    rows = {}
    for r in res.get("table3", {}).get("rows", {}).values():
        c = (r.get("run") or {}).get("commit")
        if c and c not in rows:
            rows[c] = code_changed(c, head, measured_code("table3"))
    return {"commit": head, "allow_dirty": bool(allow_dirty), "code": code,
            "table3_row_commits": rows}


def _cell(text):
    return str(text).replace("|", "\\|").replace("\n", " ")


def _relative(text):
    """Results written before the authors' build recipe moved into ``benchmarks/authors`` name
    its older folder outside the repository: named as the repository's folder here."""
    return re.sub(r"\S*/tools/authors-bench", "benchmarks/authors", str(text))


def _loads(before, after):
    """The 1-minute load average before and after a run (``-`` where not recorded)."""
    def one(x):
        return g3(x[0]) if x else "-"
    return f"{one(before)} → {one(after)}"


def _date(d):
    return d[:10] if d else "-"


def _last_run(row, results, code):
    """A claim's last-run cell: the date and commit its figures measured, and whether the code
    they measure changed between that commit and the report's."""
    exp = row.get("experiment")
    if not row.get("last_run") or exp not in results:
        return _date(row.get("last_run"))
    since = {"changed": "measured code changed since", "unchanged": "measured code unchanged "
             "since"}.get(code.get(exp), "measured code since: not recorded")
    return f"{_date(row['last_run'])} at {measured_commit(results[exp])[:12]} ({since})"


def _experiment_lines(results, code, state):
    """The page's Experiments table."""
    L = []
    L += ["", "## Experiments", "",
          "| experiment | last run | seconds | commit | tree | measured code since | threads "
          "| load average before → after | settings |",
          "|---|---|---:|---|---|---|---:|---|---|"]
    for name, res in results.items():
        p = res["provenance"]
        commit = measured_commit(res)[:12]
        if measured_commit(res) != p["commit"]:
            commit += f" (read at {p['commit'][:12]} from {res.get('source')})"
        since = code.get(name, "not recorded")
        if name == "table3":  # rows kept from earlier runs carry their own commit
            rc = state.get("table3_row_commits", {})
            others = [c for c in rc if c != p["commit"]]
            if others:
                commit += " (rows also from " + ", ".join(c[:12] for c in others) + ")"
                since += " (" + ", ".join(f"{c[:12]}: {rc[c]}" for c in others) + ")"
        L.append("| " + " | ".join(_cell(x) for x in (
            name, p["date"], f"{res['seconds']:.1f}", commit, _dirty_word(p.get("dirty")),
            since, p["numba_threads"], _loads(res.get("load_average_before"),
                                              p.get("load_average")),
            json.dumps(res["settings"], sort_keys=True))) + " |")
    return L


def _table3_lines(t):
    """The page's Table 3 section from the table3 results ``t``."""
    L = []
    L += ["", "## Table 3 as the paper states it", "",
          "Average time of one smooth distance evaluation (distance and every query "
          "vertex's gradient) over the whole simulation; every kernel is called once "
          "before the run, so compilation is not timed. The paper's on 28 threads, ours on "
          "this machine at each thread count (a machine shared with other work makes "
          "several threads wait on each other: compare the load averages).", "",
          f"The last column: {_relative(t.get('authors_simulator', 'not run'))}. Their "
          "evaluations "
          "are their `meshDistance` calls (one per mesh pair and orientation, every "
          "line-search trial of their interior-point solver included), ours the "
          "`MeshDistance` calls of our simulator: the same simulation and steps, not the "
          "same number of calls.", "",
          "| data | query | dt | paper (ms, 28 threads) | ours (ms) | threads | load "
          "average | steps | evaluations | authors' simulator here (ms) |",
          "|---|---|---|---:|---:|---:|---:|---:|---:|---|"]
    for name, (row, data, query, paper_ms, dt) in TABLE3_PAPER.items():
        r = t["rows"].get(name)
        if r is None:
            L.append("| " + " | ".join(_cell(x) for x in (
                data, query, dt, paper_ms, "not run", "-", "-", "-", "-", "-")) + " |")
            continue
        a = r.get("authors")
        theirs = "-" if not a else (
            f"{g3(a['ms_mean'])} on {a['threads']} threads ({a['evaluations']} "
            f"evaluations, load {g3(a['load_average_before'])})"
            if a["status"] == "ok" else a["status"])
        for x in r["runs"]:
            L.append("| " + " | ".join(_cell(v) for v in (
                data, query, dt, paper_ms, g3(x["ms_mean"]), x["threads"],
                g3(x["load_average_before"]), r["steps"], x["evaluations"], theirs)) + " |")
    L.append("| City Street, 6,747,648 points | Motorcycle, 8,800 tris | 1/100 | 581.2362 "
             "| data not available | - | - | - | - | - |")
    return L


def _box_test_lines(b):
    """The page's box-test section from the box_test results ``b``."""
    L = []
    L += ["", "## The box test on and off", "",
          "Sec. 3.5: the whole-mesh smooth distance (`MeshDistance`, beta "
          f"{b['beta']:g}) with the paper's cheap box test (on, the default) and with the "
          "exact primitive-box distance it avoids (`box_test=False`), timed alternately in "
          f"one process (median of {b['repeat']}, {b['threads']} threads), the query at an "
          "exact gap of 1/alpha. Both are conservative; per query primitive they differ by "
          "no more than the Barnes-Hut error (the largest of each, times alpha, below).", "",
          "| case | query | data | alpha | on (ms) | off (ms) | speed-up | leaves on / off "
          "| max \\|on − off\\| × alpha | max BH error × alpha |",
          "|---|---|---|---:|---:|---:|---:|---|---:|---:|"]
    for name, c in b["cases"].items():
        L.append("| " + " | ".join(_cell(x) for x in (
            name, f"{c['query_primitives']} {c['query_kind']}",
            f"{c['data_primitives']} {c['data_kind']}", f"{c['alpha']:g}", g3(c["ms_on"]),
            g3(c["ms_off"]), f"{g3(c['speedup'])}x",
            f"{g3(c['leaves_on'])} / {g3(c['leaves_off'])}",
            g3(c["max_abs_diff_x_alpha"]), g3(c["max_bh_error_x_alpha"]))) + " |")
    return L


def _grid_lines(g, shown_as):
    """The page's benchmark-figure section from the grid results ``g``."""
    L = []
    L += ["", "## The benchmark figure", "",
          f"`tracer bench-grid` over {g['meshes']} meshes ({', '.join(g['sets'])}; "
          f"generated height fields of {', '.join(str(n) for n in g['generated_triangles'])} "
          f"triangles), {g['grid']}³ queries. The paper's two plots over every mesh: "
          f"`{shown_as}/grid/bench_time_vs_leaves.png` and `bench_leaf_fraction.png` (and "
          "per set in `grid/<set>/`).", "",
          "| type | meshes | Pearson r (time, leaves) | ns per leaf (fit) | ns per leaf "
          "(range) | leaves at most | share of leaves, smallest mesh | largest mesh |",
          "|---|---:|---:|---:|---|---:|---|---|"]
    for kind, f in g["fit"].items():
        L.append("| " + " | ".join(_cell(x) for x in (
            kind, f["meshes"], g3(f["pearson_r"]), g3(f["ns_per_leaf_fit"]),
            f"{g3(f['ns_per_leaf_min'])}-{g3(f['ns_per_leaf_max'])}", g3(f["leaves_max"]),
            f"{100 * f['share_smallest']:.3g} % ({f['primitives_smallest']})",
            f"{100 * f['share_largest']:.3g} % ({f['primitives_largest']})")) + " |")
    return L


def render_page(folder, shown_as):
    """The Markdown page of the results folder ``folder`` (named ``shown_as`` on the page)."""
    results = load_results(folder)
    run = load_run(folder)
    rows = evaluate(results)
    counts = {}
    for r in rows:
        counts[r["verdict"]] = counts.get(r["verdict"], 0) + 1
    L = ["# Reproduction of the paper's claims", "",
         "<!-- generated by `python -m tracer reproduce`; do not edit: "
         "tests/tracer/reproduce/test_reproduce.py checks it against the results folder -->", "",
         f"Generated from `{shown_as}` ({run['mode']} run, {run['date']}, commit "
         f"`{run['commit'][:12]}`{' with local changes' if run.get('dirty') else ''}, "
         f"{run['machine']['cpu']}, {run['machine']['cores']} cores, "
         f"{run['numba_threads']} numba threads, scheduler {run['scheduler']}; "
         f"{run['seconds']:.0f} s in all"
         + (f"; it updated {', '.join(run['updated'])} and kept the others' earlier results"
            if run.get("updated", run["experiments"]) != run["experiments"] else "")
         + "). Every number below is read from the JSON files "
         "there; the paper's values are quoted from it. Rerun with "
         f"`python -m tracer reproduce{'' if run['mode'] == 'full' else ' --' + run['mode']} "
         + ("--scheduler serial " if run.get("scheduler") == "serial" else "")
         + "--out DIR --page docs/reproduction.md` on a clean commit (`--scheduler serial`: "
         "every experiment in this process on all its threads; Table 3 then times 1 and all "
         "threads). The data column says what each row reads: files shipped in `scenes/`, "
         "or fetched with a checksum on first use (`python -m tracer data fetch`); a run "
         "that cannot get a row's data says so in the row.", ""]
    state = run.get("report") or {}
    code = state.get("code", {})
    if state.get("commit"):
        L += [f"The report was written at commit `{state['commit'][:12]}`; the Experiments "
              "table says for each experiment whether the code it measures (`"
              + "/`, `".join(MEASURED_CODE) + "/`, and `tracer/sim/` for table3) changed "
              "between its commit and this one.", ""]
    dirty = dirty_results(folder)
    if dirty:
        L += ["**Written with `--allow-dirty`:** the results of " + ", ".join(dirty)
              + " come from a work tree with uncommitted changes, so their commit is not "
              "exactly the code they measured.", ""]
    stale = [n for n, v in code.items() if v == "changed"]
    if stale:
        L += ["**Stale:** the measured code changed since the run of " + ", ".join(stale)
              + "; their rows describe older code.", ""]
    missing = [n for n in EXPERIMENTS if n not in run["experiments"]]
    if missing:
        L += [f"This run did not run {', '.join(missing)} (`--only`): their claims say "
              "\"not run\".", ""]
    if run["mode"] != "full":
        L += [f"**This is the {run['mode']} run** (small renders, a small query grid, a few "
              "simulation "
              "steps): it shows that every experiment runs and how each claim is judged; its "
              "sizes are not the paper's, and the verdicts say where that matters. The full run "
              "(`tracer reproduce`, an hour or more on 2 cores) uses the paper's sizes.", ""]
    L += ["Verdicts: " + ", ".join(f"{v}: {n}" for v, n in sorted(counts.items())) + ". "
          "*match* and *differs*: the paper's quantity, measured here; *not comparable*: "
          "another quantity, unit, mesh set or hardware than the paper's (the reason says "
          "which); *cannot be reproduced*: the data or the hardware is not available at all; "
          "*inconclusive*: a timing "
          "whose spread over the repeats (min-max, shown) straddles the paper's threshold; "
          "*not run*: not part of this run. Timing rows give the load average before and "
          "after their experiment"
          + ("; in this run they are indicative only" if run["mode"] != "full" else "")
          + ".", "",
          "## Claims", "",
          "| # | claim (quoted) | section | paper | ours | setting | data | verdict | last run |",
          "|---:|---|---|---|---|---|---|---|---|"]
    for i, r in enumerate(rows, 1):
        verdict = r["verdict"] + (f" ({r['indicative']})" if r.get("indicative") else "") \
            + (f": {r['reason'].strip()}" if r["reason"].strip() else "")
        L.append("| " + " | ".join(_cell(x) for x in (
            i, f"“{r['quote']}”", r["section"], r["paper"], r["ours"], r["setting"],
            r.get("data", "-"), verdict, _last_run(r, results, code))) + " |")
    L += _experiment_lines(results, code, state)
    if "table3" in results:
        L += _table3_lines(results["table3"])
    if "box_test" in results:
        L += _box_test_lines(results["box_test"])
    if "grid" in results and "fit" in results["grid"]:  # not when its data was missing
        L += _grid_lines(results["grid"], shown_as)
    L.append("")
    return "\n".join(L)
