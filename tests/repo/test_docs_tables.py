"""The performance guide's scaling and GPU tables, and the figures its prose takes from them,
are those of the committed results files (``benchmarks/tables.py`` makes the tables).

A rerun that writes new results files cannot leave the page behind: the test fails until the
tables are pasted again (``python benchmarks/tables.py scaling|gpu FILE``) and the sentences
below agree. Figures are compared as the page rounds them.
"""

import json
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
GUIDE = ROOT / "docs" / "guide" / "performance.md"
DATA = ROOT / "benchmarks" / "data"
sys.path.insert(0, str(ROOT))

from benchmarks.coldstart_words import (exact_cold_sentence,  # noqa: E402
                                         first_render_sentence, kinds_warm_sentence,
                                         levels_warm_sentence, library_warm_sentences,
                                         vertex_cold_sentence, warm_render_sentence,
                                         warm_sentences)
from benchmarks.tables import (build_scale_table, build_scale_words,  # noqa: E402
                               scale_points_words,
                               coldstart_ahead_table, coldstart_copies_table,
                               coldstart_kinds_table,
                               coldstart_steps_table,
                               coldstart_table, exact_mix_table,
                               exact_mix_words, gpu_table, mesh_distance_table,
                               mesh_distance_words, registers_table, scaling_table,
                               smooth_cost_table, TABLES)


def _guide():
    return GUIDE.read_text(encoding="utf-8")


def _flat(text):
    return " ".join(text.split())


def _load(name):
    return json.loads((DATA / name).read_text(encoding="utf-8"))


@pytest.mark.parametrize("kind, name", [("scaling", "scaling_xeon16.json"),
                                        ("scaling", "scaling_xeon16_before_png.json"),
                                        ("scaling", "scaling.json"),
                                        ("gpu", "gpu_h100.json"),
                                        ("gpu", "gpu_h200.json"),
                                        ("gpu", "gpu_h200_lit.json")])
def test_the_guide_holds_the_table_of_the_results_file(kind, name):
    table = {"scaling": scaling_table, "gpu": gpu_table}[kind](DATA / name)
    guide = _guide()
    # the GPU table sits in a list item, indented: compare line by line, stripped
    lines = [ln.strip() for ln in guide.splitlines()]
    want = [ln.strip() for ln in table.splitlines()]
    starts = [i for i, ln in enumerate(lines) if ln == want[0]]
    assert any(lines[i:i + len(want)] == want for i in starts), f"{name}: paste it again"


@pytest.mark.parametrize("name", ["build_scale.json", "build_scale_before.json"])
def test_the_guide_holds_the_build_scale_tables(name):
    """Issue 60's build-time and memory tables, this code's and the code before's, as
    ``benchmarks/tables.py build-scale`` makes them from the results files."""
    lines = [ln.strip() for ln in _guide().splitlines()]
    want = [ln.strip() for ln in build_scale_table(DATA / name).splitlines()]
    starts = [i for i, ln in enumerate(lines) if ln == want[0]]
    assert any(lines[i:i + len(want)] == want for i in starts), f"{name}: paste it again"


def test_the_build_scale_sentences_follow_the_files():
    """The largest mesh's build, memory and render, in the guide and in the README."""
    words = build_scale_words(DATA / "build_scale.json", DATA / "build_scale_before.json")
    for where in (_flat(_guide()), _flat((ROOT / "README.md").read_text(encoding="utf-8"))):
        for sentence in words:
            assert sentence in where, sentence


def test_the_ten_million_points_sentence_follows_its_file():
    """``bench_scale.py``'s 1e7-point cloud: the sentence is the results file's."""
    assert scale_points_words(DATA / "scale_points_1e7.json") in _flat(_guide())


def test_the_guide_holds_the_cold_start_table():
    """The first-call table of issue 51: this code (``coldstart.json``) and the code before
    (``coldstart_issue51_before.json``), made by ``benchmarks/tables.py coldstart``."""
    table = coldstart_table(DATA / "coldstart.json", DATA / "coldstart_issue51_before.json")
    lines = [ln.strip() for ln in _guide().splitlines()]
    want = [ln.strip() for ln in table.splitlines()]
    starts = [i for i, ln in enumerate(lines) if ln == want[0]]
    assert any(lines[i:i + len(want)] == want for i in starts), "paste it again"


def test_the_guide_holds_the_second_copy_and_warmup_table():
    """Issue 63's table (``coldstart_issue63.json``, ``tables.py coldstart-copies``) between
    its markers, and the file says what the page says of it: nothing compiled in a second copy
    or after the warm-up."""
    want = coldstart_copies_table(DATA / "coldstart_issue63.json").strip()
    text = _guide()
    start = text.index("<!-- coldstart-copies -->") + len("<!-- coldstart-copies -->")
    assert text[start:text.index("<!-- /coldstart-copies -->")].strip() == want, "paste it again"
    d = json.loads((DATA / "coldstart_issue63.json").read_text(encoding="utf-8"))
    assert all(r[m]["compiled"] == 0 for r in d["cases"].values()
               for m in ("second_copy", "after_warmup"))


def test_the_guide_holds_the_warmup_modes_table():
    """The exact offset surface's and the tolerance's first renders after the warm-up, before
    and after it compiled them (``coldstart_issue63_modes*.json``, ``tables.py
    coldstart-warmup``) between its markers; the files say what the page says: the warm-up
    before left them to compile, this one leaves nothing, and a second copy compiles nothing."""
    from benchmarks.tables import coldstart_warmup_table

    after = DATA / "coldstart_issue63_modes.json"
    before = DATA / "coldstart_issue63_modes_before.json"
    want = coldstart_warmup_table(after, before).strip()
    text, marker = _guide(), "<!-- coldstart-warmup-modes -->"
    start = text.index(marker) + len(marker)
    assert text[start:text.index("<!-- /coldstart-warmup-modes -->")].strip() == want, \
        "paste it again"
    d, b = _load(after.name)["cases"], _load(before.name)["cases"]
    assert set(d) == set(b) == {"mesh_exact", "mesh_tol"}
    assert all(r["after_warmup"]["compiled"] == 0 and r["second_copy"]["compiled"] == 0
               for r in d.values())
    assert all(r["after_warmup"]["compiled"] > 0 for r in b.values())


@pytest.mark.parametrize("marker, name", [("coldstart-ahead", "coldstart.json"),
                                          ("coldstart-ahead-sim",
                                           "coldstart_issue63_sim_ahead.json"),
                                          ("coldstart-ahead-unlit",
                                           "coldstart_issue63_unlit_ahead.json")])
def test_the_guide_holds_the_compile_ahead_tables(marker, name):
    """Issue 63's first renders with the light (or, unlit, the scene's distance) compiled in a
    second process and first simulation steps with the moments compiled in one (``cold_ahead``
    of the file, ``tables.py coldstart-ahead``) between their markers; every one of them took
    less wall time than the call alone."""
    want = coldstart_ahead_table(DATA / name).strip()
    text = _guide()
    start = text.index(f"<!-- {marker} -->") + len(f"<!-- {marker} -->")
    assert text[start:text.index(f"<!-- /{marker} -->")].strip() == want, "paste it again"
    cases = _load(name)["cases"]
    assert any("cold_ahead" in r for r in cases.values())
    assert all(r["cold_ahead"]["wall_s"] < r["cold"]["wall_s"] for r in cases.values()
               if "cold_ahead" in r)


@pytest.mark.parametrize("marker, name, make", [
    ("first-render-timeline", "first_render_timeline.json", "timeline"),
    ("coldstart-ab", "coldstart_issue63_renders_ab.json", "coldstart-ab"),
    ("coldstart-probe-one-kind", "coldstart_issue63_probe_one_kind.json", "coldstart-ab"),
    ("coldstart-probe-light-merged", "coldstart_issue63_probe_light_merged.json",
     "coldstart-ab"),
    ("coldstart-levels", "coldstart_issue63_levels_ab.json", "coldstart-ab"),
    ("coldstart-share", "coldstart_issue63_share_ab.json", "coldstart-ab"),
    ("coldstart-share-cloud", "coldstart_issue63_share_cloud_ab.json", "coldstart-ab")])
def test_the_guide_holds_the_first_render_tables(marker, name, make):
    """Issue 63's first-render timeline, the renders run in turn against the code before, and
    the probes (``benchmarks/tables.py timeline`` / ``coldstart-ab``), each between its
    markers."""
    want = TABLES[make](DATA / name).strip()
    text = _guide()
    start = text.index(f"<!-- {marker} -->") + len(f"<!-- {marker} -->")
    assert text[start:text.index(f"<!-- /{marker} -->")].strip() == want, "paste it again"
    # the sentence that reads the first two against the target
    assert first_render_sentence(DATA / "coldstart_issue63_renders_ab.json",
                                 DATA / "first_render_timeline.json") in _flat(text)
    assert warm_render_sentence(DATA / "coldstart_issue63_renders_warm.json") in _flat(text)
    # the warm renders around the merged levels (the last table)
    assert levels_warm_sentence(DATA / "coldstart_issue63_levels_warm.json") in _flat(text)
    # the vertex gradient's one traversal call, and the closing alpha's neighbours found once
    assert vertex_cold_sentence(DATA / "coldstart_issue63_vertex_loop_ab.json") in _flat(text)
    for words in library_warm_sentences(DATA / "library_issue63_ab.json"):
        assert words in _flat(text), words


def test_the_guide_holds_the_whole_mesh_kinds_table_and_warm_runs():
    """Issue 63's whole-mesh table (``coldstart.json`` against
    ``coldstart_issue63_kinds_before.json``, ``tables.py coldstart-kinds``) between its
    markers, and the warm side by side it quotes (``coldstart_issue63_kinds_warm.json``)."""
    want = coldstart_kinds_table(DATA / "coldstart.json",
                                 DATA / "coldstart_issue63_kinds_before.json").strip()
    text = _guide()
    start = text.index("<!-- coldstart-kinds -->") + len("<!-- coldstart-kinds -->")
    assert text[start:text.index("<!-- /coldstart-kinds -->")].strip() == want, "paste it again"
    head = _load("coldstart_issue63_tri_edges_head.json")["cases"]["md_tri_edges"]["cold"]
    same = _load("coldstart_issue63_amd_5797881.json")["cases"]["md_tri_edges"]["cold"]
    own = _load("coldstart.json")["cases"]["md_tri_edges"]["cold"]
    assert (f"Triangles on edges took {head['cpu_s']:.1f} s ({head['compiled']} specialisations)"
            in _flat(text))
    assert f"{same['cpu_s']:.1f} s ({same['compiled']}) with their own" in _flat(text)
    assert f"{own['cpu_s']:.1f} s ({own['compiled']}) in this table's later run" in _flat(text)
    # the exact distance's kernels of one kind: first call, warm runs, the rounds' ratios
    assert exact_cold_sentence(DATA / "coldstart_issue63_exact.json") in _flat(text)
    ex = _load("coldstart_issue63_exact.json")
    b, a = ([r["cpu_s"] for r in ex[side]] for side in ("before", "after"))
    ratios = [y / x for x, y in zip(b, a) if x < max(b) and y < max(a)]
    assert (f"the three rounds without them give ratios of {min(ratios):.2f}-{max(ratios):.2f}"
            in _flat(text)) and len(ratios) == 3
    assert f"({max(b):.1f} s before, {max(a):.1f} s after" in _flat(text)
    sl = _load("coldstart_issue63_exact_warm_amd.json")["mesh_distance_ms_best"]
    assert (f"best rounds {min(sl['after']['slide-sphere']):.2f} against "
            f"{min(sl['before']['slide-sphere']):.2f} ms") in _flat(text)
    warm = DATA / "coldstart_issue63_exact_warm_amd.json"
    assert kinds_warm_sentence(warm, "mesh_exact_ms_best", ".3f") in _flat(text)
    assert kinds_warm_sentence(warm) in _flat(text)
    for name in ("coldstart_issue63_kinds_warm.json", "coldstart_issue63_kinds_warm_amd.json",
                 "coldstart_issue63_kinds_warm_amd_600ff68.json"):
        assert kinds_warm_sentence(DATA / name) in _flat(text), name


def test_the_guide_holds_the_cold_start_steps_and_sentences():
    """Issue 51's steps table (``coldstart_issue51_steps.json``), its warm side-by-side
    sentences (``coldstart_issue51_warm.json``) and the first calls it quotes
    (``coldstart.json``, ``coldstart_issue51_before.json``)."""
    guide = _guide()
    lines = [ln.strip() for ln in guide.splitlines()]
    want = coldstart_steps_table(DATA / "coldstart_issue51_steps.json").splitlines()
    starts = [i for i, ln in enumerate(lines) if ln == want[0]]
    assert any(lines[i:i + len(want)] == want for i in starts), "paste the steps table again"
    text = _flat(guide)
    for sentence in warm_sentences(DATA / "coldstart_issue51_warm.json"):
        assert sentence in text, sentence
    cases = _load("coldstart.json")["cases"]
    before = _load("coldstart_issue51_before.json")["cases"]
    md, mdb = cases["md_triangles"]["cold"], before["md_triangles"]["cold"]
    assert f"the first exact query {cases['exact']['cold']['cpu_s']:.1f} s of CPU" in text
    assert f"the first smooth one {cases['smooth']['cold']['cpu_s']:.1f} s" in text
    # the run before this one, on a faster day: the same kernels of the point queries
    prev = _load("coldstart_issue63_round2.json")["cases"]
    assert (f"the same kernels took {prev['exact']['cold']['cpu_s']:.1f} s and "
            f"{prev['smooth']['cold']['cpu_s']:.1f} s") in text
    kinds = _load("coldstart_issue63_kinds_before.json")["cases"]["md_triangles"]["cold"]
    assert f"against the 15 s target: {md['cpu_s'] / kinds['cpu_s']:.2f} of what" in text
    assert (f"takes {md['cpu_s']:.1f} s against {mdb['cpu_s']:.1f} s before "
            f"({md['compiled']} specialisations against {mdb['compiled']})") in text
    renders = [cases[c]["cold"]["cpu_s"] for c in ("mesh", "edges", "cloud", "lit")]
    assert f"the renders {min(renders):.1f}-{max(renders):.1f} s against 10" in text
    # the same renders on the Intel machine, and in this machine's second-copy run
    for name, words in (("coldstart_issue63_intel.json", "(the Intel run: {} s, with the"),
                        ("coldstart_issue63.json", "{} s of CPU in the second-copy run")):
        was = [_load(name)["cases"][c]["cold"]["cpu_s"] for c in ("mesh", "edges", "cloud", "lit")]
        assert words.format(f"{min(was):.1f}-{max(was):.1f}") in text, name
    # the simulation step (kernels unchanged since) against the run of 11:24: the drift
    sim = _load("coldstart_issue63_amd_5797881.json")["cases"]["sim"]["cold"]["cpu_s"]
    assert (f"{cases['sim']['cold']['cpu_s']:.1f} s here, {sim:.1f} s at 11:24"
            f" (`coldstart_issue63_amd_5797881.json`)") in text


def test_the_whole_mesh_guide_quotes_the_measured_first_call():
    """The whole-mesh guide's compile figure is the measured first ``MeshDistance`` call."""
    text = _flat((ROOT / "docs" / "guide" / "whole-mesh.md").read_text(encoding="utf-8"))
    cold = _load("coldstart.json")["cases"]["md_triangles"]["cold"]
    before = _load("coldstart_issue51_before.json")["cases"]["md_triangles"]["cold"]
    assert (f"the first call compiles for {cold['cpu_s']:.0f} s of CPU "
            f"({before['cpu_s']:.0f} s before issue 51;") in text


def _range(values, fmt):
    lo, hi = format(min(values), fmt), format(max(values), fmt)
    return lo if lo == hi else f"{lo}-{hi}"


def test_the_scaling_sentences_follow_the_files():
    text = _flat(_guide())
    for name, sentence in (("scaling_xeon16.json", "the whole frame with its PNG reaches {}."),
                           ("scaling_xeon16_before_png.json", "the frame speedups were {}")):
        d = _load(name)
        top = str(d["threads"][-1])
        frame = [k["frame"]["speedup"][top] for k in d["kinds"].values()]
        assert sentence.format(_range(frame, ".1f")) in text, name
    d = _load("scaling_xeon16.json")
    top = str(d["threads"][-1])
    # "met for the --stats seconds of all three kinds"
    assert all(k["seconds"]["speedup"][top] >= 12 for k in d["kinds"].values())
    assert "is met for the `--stats` seconds of all three kinds" in text


def test_the_gpu_sentences_follow_the_file():
    text = _flat(_guide())
    rows = {r["what"]: r for r in _load("gpu_h100.json")["rows"]}
    bunnies = [rows[f"bunny {k}"] for k in ("points", "edges", "triangles")]
    above = [100 * (r["gpu_s"] / 0.040 - 1) for r in bunnies]
    assert (f"The points bunny is {above[0]:.0f} % above the first, the edges and triangles "
            f"{_range(above[1:], '.0f')} %") in text
    assert all(rows[f"grid {k}"]["gpu_kernel_s"] <= 0.010 for k in ("points", "edges", "triangles"))
    assert all(rows[f"grid {k}"]["gpu_s"] > 0.010 for k in ("points", "edges", "triangles"))
    speed = [r["speedup"] for r in bunnies]
    assert f"about {_range(speed, '.0f')}x over our own 16 CPU threads" in text
    assert f"compiles both kernels ({bunnies[0]['gpu_first_s']:.0f} s here)" in text
    spread = max(max(r["gpu_by_block"].values()) / r["gpu_reuse_s"] - 1 for r in bunnies)
    assert f"differ by at most {100 * spread:.0f} %" in text
    gains = [100 * (1 - r["gpu_by_block"]["8x8"] / r["gpu_reuse_s"]) for r in bunnies]
    assert all(r["gpu_by_block"]["8x8"] == min(r["gpu_by_block"].values()) for r in bunnies)
    assert f"by {_range(gains, '.1f')} %" in text
    before = _load("gpu_h100_before_gpu_cone.json")["rows"]
    differ = [r["hit_differs"] for r in before if r["hit_differs"] is not None]
    assert f"without it {_range(differ, 'd')} pixels of each bunny's hit mask differed" in text
    assert [r["hit_differs"] for r in bunnies] == [0, 1, 0]   # "one grazing pixel of the edges"
    warm = _load("gpu_h100_small_warm.json")["rows"][0]["gpu_first_s"]
    assert f"the first call took {warm:.2f} s" in text


def test_the_h200_sentences_follow_the_files():
    """The H200 paragraphs of issue 49 (``gpu_h200.json``, ``gpu_h200_lit.json``)."""
    text = _flat(_guide())
    rows = {r["what"]: r for r in _load("gpu_h200.json")["rows"]}
    kinds = ("points", "edges", "triangles")
    bunnies = [rows[f"bunny {k}"] for k in kinds]
    grids = [rows[f"grid {k}"] for k in kinds]
    ms = [1e3 * r["gpu_s"] for r in bunnies]
    assert (f"The 1080p frames take {_range(ms, '.0f')} ms, "
            f"{_range([r['speedup'] for r in bunnies], '.1f')}x the host's 16 threads") in text
    assert min(ms) > 25                                      # "25 ms is not met"
    assert [r["hit_differs"] for r in bunnies] == [0, 1, 0]  # "one grazing pixel of the edges"
    resident = " / ".join(f"{1e3 * r['gpu_resident_s']:.2f}" for r in grids)
    assert f"on the card, the launch, the outputs left there): {resident} ms" in text
    assert f"against {_range([1e3 * r['gpu_s'] for r in grids], '.1f')} ms with the copies" in text
    assert [r["gpu_resident_s"] <= 0.005 for r in grids] == [True, False, False]

    def change(v):
        return [100 * (r["gpu_variants"][v]["kernel_s"] / r["gpu_kernel_s"] - 1) for r in grids]

    for v in ("stack32", "box32"):
        c = change(v)
        assert f"by {min(c):.1f} to {max(c):+.1f} %" in text, v
        assert max(abs(x) for x in c) < 5                    # "noise", "neither is kept"
    assert all(r["gpu_variants"]["stack32"]["distance_max_diff"] == 0 for r in grids)
    box_render = [100 * (r["gpu_variants"]["box32"]["gpu_s"] / r["gpu_variants"]["box32"]["gpu_ref_s"]
                         - 1) for r in bunnies]
    assert f"the 1080p frames were {_range(box_render, '.1f')} % slower with them" in text
    moved = max(r["gpu_variants"]["box32"]["distance_max_diff"] for r in grids)
    assert f"moved by up to {moved:.1e} (edges)".replace("e-0", "e-") in text
    gains = [100 * (1 - r["gpu_by_block"]["8x8"] / r["gpu_reuse_s"]) for r in bunnies]
    assert f"8 x 8 was again the fastest ({_range(gains, '.1f')} % below 16 x 8)" in text
    assert all(r["gpu_by_block"]["32x4"] == max(r["gpu_by_block"].values()) for r in bunnies)
    lit = _load("gpu_h200_lit.json")["rows"]
    assert (f"{_range([r['gpu_s'] for r in lit], '.2f')} s on the card, "
            f"{_range([r['speedup'] for r in lit], '.1f')}x the host's 16 threads") in text
    assert all(r["hit_differs"] == 0 and r["rgb_max"] == 0 and r["whole_equal"] for r in lit)
    assert min(r["gpu_s"] for r in lit) > 1.0                # "1 s is not met"
    split = [r["gpu_whole_s"] / r["gpu_s"] for r in lit]
    assert (f"{_range(split, '.2f')}x faster (`gpu_whole_s`: "
            f"{_range([r['gpu_whole_s'] for r in lit], '.2f')} s)") in text
    parts = [r["gpu_parts"] for r in lit]
    samples = [sum(x[-1] for x in p["samples"]) for p in parts]
    light = [sum(x[-1] for x in p["light"]) for p in parts]
    rest = [100 * p["rest_s"] / p["total_s"] for p in parts]
    assert (f"the samples launches {_range(samples, '.2f')} s, the light launches "
            f"{_range(light, '.2f')} s, and {_range(rest, '.0f')} % in the rest") in text
    assert f"compiles the four render kernels: {lit[0]['gpu_first_s']:.0f} s" in text
    calls = [len(p["samples"]) + len(p["light"]) for p in parts]
    assert f"a lit frame above made {_range(calls, 'd')} samples and light calls" in text


def test_the_fill_rule_sentence_follows_its_file():
    """The tuning-constant entry of ``film.FILL_BETWEEN`` (``fill_between.json``)."""
    text = _flat(_guide())
    scenes = _load("fill_between.json")["scenes"]
    lion, trefoil = scenes["lion_points"], scenes["trefoil"]
    assert (f"{lion['off']['shadow_ground']} -> {lion['on']['shadow_ground']} under the scanned "
            f"lion and {trefoil['off']['shadow_ground']} -> {trefoil['on']['shadow_ground']} "
            "under the trefoil") in text
    assert (f"{lion['off']['colour']} -> {lion['on']['colour']} and {trefoil['off']['colour']} "
            f"-> {trefoil['on']['colour']}") in text
    rest = [scenes[n] for n in scenes if n not in ("lion_points", "trefoil")]
    assert (f"the other three scenes {_range([r['off']['colour'] for r in rest], 'd')} -> "
            f"{_range([r['on']['colour'] for r in rest], 'd')}") in text
    more = [100 * (r["on"]["light_queries"] / r["off"]["light_queries"] - 1)
            for r in scenes.values()]
    slower = [100 * (min(r["on"]["seconds"]) / min(r["off"]["seconds"]) - 1)
              for r in scenes.values()]
    assert f"light queries {_range(more, '.0f')} % more" in text
    assert f"the render's time {min(slower):.1f} to {max(slower):+.1f} %" in text
    assert all(r["on"]["shadow_ground"] == 0 for r in scenes.values())


def test_the_readme_quotes_the_files():
    """The README's 16-core and GPU sentence, figure by figure, from the same files."""
    text = _flat((ROOT / "README.md").read_text(encoding="utf-8"))
    d = _load("scaling_xeon16.json")
    top = str(d["threads"][-1])
    speed = [k["seconds"]["speedup"][top] for k in d["kinds"].values()]
    assert (f"on a {d['machine']['cores']}-core Intel Xeon the 1080p bunny traces "
            f"{_range(speed, '.1f')}x faster on {top} threads than on 1") in text
    rows = [r for r in _load("gpu_h100.json")["rows"] if r["what"].startswith("bunny")]
    ms = [1e3 * r["gpu_s"] for r in rows]
    assert (f"a 1080p frame takes {_range(ms, '.0f')} ms, "
            f"{_range([r['speedup'] for r in rows], '.0f')}x its 16 CPU threads") in text
    assert sum(r["hit_differs"] for r in rows) <= 1      # "with the same image"


def test_the_traversal_loop_cold_start_comparison_follows_its_file():
    """The performance guide's before/after first-render ranges of issue 33 (one traversal
    loop) are those of ``coldstart_traversal_ab.json``."""
    text = _flat(_guide())
    runs = _load("coldstart_traversal_ab.json")["runs"]
    for case, words in (("mesh", "the mesh file"), ("cloud", "the point cloud"),
                        ("lit", "the lit render")):
        before = [r["cases"][case]["cold_wall_s"] for r in runs if r["code"] == "before"]
        after = [r["cases"][case]["cold_wall_s"] for r in runs if r["code"] == "after"]
        assert f"{words} {_range(before, '.1f')} -> {_range(after, '.1f')}" in text, case


def test_the_cold_start_paragraph_follows_the_files():
    """The paragraph on the first renders after the one traversal loop (issue 33)."""
    text = _flat(_guide())
    cases = _load("coldstart_traversal.json")["cases"]
    for case in ("mesh", "cloud", "lit"):
        cold = cases[case]["cold"]
        assert f"{cold['wall_s']:.1f} ({cold['cpu_s']:.1f}, {cold['compiled']})" in text, case
    warm = " / ".join(f"{cases[c]['warm']['wall_s']:.1f}" for c in ("mesh", "cloud", "lit"))
    assert f"warm {warm} s" in text
    runs = {r["opt"]: r for r in _load("compile_profile.json")["runs"]}
    r3 = runs[3]
    own = list(r3["own_s"].items())
    assert (f"{r3['compilations']} compilations, {r3['compile_s']:.1f} s of a "
            f"{r3['wall_s']:.1f} s first render, none above {own[0][1]:.2f} s") in text
    assert (f"`NUMBA_OPT=2` and `1` (default 3) took {runs[2]['wall_s']:.1f} and "
            f"{runs[1]['wall_s']:.1f} s") in text
    # "not the cost": a lower optimisation level saves no more than a tenth
    assert min(runs[2]["wall_s"], runs[1]["wall_s"]) > 0.9 * r3["wall_s"]


def test_the_exact_mix_tables_and_sentences_follow_the_file():
    """Issue 47: the exact-query table against fcpw and libigl, the smooth distance's cost
    table, and the sentence that sums them up in the guide and the README."""
    path = DATA / "exact_mix.json"
    lines = [ln.strip() for ln in _guide().splitlines()]
    for table in (exact_mix_table(path), smooth_cost_table(path)):
        want = [ln.strip() for ln in table.splitlines()]
        starts = [i for i, ln in enumerate(lines) if ln == want[0]]
        assert any(lines[i:i + len(want)] == want for i in starts), "paste it again"
    words = exact_mix_words(path)
    assert words in _flat(_guide())
    assert words in _flat((ROOT / "README.md").read_text(encoding="utf-8"))
    d = _load("exact_mix.json")
    # the claim the sentence makes: on every mix the sides agree on the distances (fcpw
    # everywhere, open3d on triangles, libigl where it ran: not below 100 queries a call)
    for row in d["rows"]:
        sides = row["sides"]
        assert "fcpw" in sides and ("open3d" in sides or row["kind"] != "triangles"), row
        assert "libigl" in sides or "/" in row["mix"], row
        assert all(s["agrees"] for s in sides.values()), (row["data"], row["mix"])


def test_the_fidelity_table_follows_its_file():
    """Issues 46 and 62: the troubleshooting guide's fidelity table and its summary sentences
    are those of ``benchmarks/data/fidelity.json`` and the files it is compared with."""
    from benchmarks.bench_fidelity import markdown, summary

    d = _load("fidelity.json")
    page = (ROOT / "docs" / "guide" / "troubleshooting.md").read_text(encoding="utf-8")
    lines = [ln.strip() for ln in page.splitlines()]
    want = [ln.strip() for ln in markdown(d).splitlines()]
    starts = [i for i, ln in enumerate(lines) if ln == want[0]]
    assert any(lines[i:i + len(want)] == want for i in starts), "paste it again"
    assert summary(d) in _flat(page)
    assert summary(_load("fidelity_before_shell.json")) in _flat(page)
    # issue 62: the same corpus with the paper's weights, the comparison for the junctions
    assert summary(_load("fidelity_paper_weights.json")) in _flat(page)


def test_the_shell_time_sentence_follows_its_file():
    """Issue 46: the troubleshooting guide's render-time ratio of the thin shell against the
    rule before it is that of ``benchmarks/data/shell_time.json``."""
    d = _load("shell_time.json")
    page = (ROOT / "docs" / "guide" / "troubleshooting.md").read_text(encoding="utf-8")
    words = (f"at {d['size']}² the thin shell renders in {d['ratio_min']:.2f}-"
             f"{d['ratio_max']:.2f} (median {d['ratio_median']:.2f}) of the time of the rule "
             f"before it, on the {len(d['rows'])} shapes with triangles")
    assert words in _flat(page)
    r = [row["shell_s"] / row["before_s"] for row in d["rows"]]
    assert min(r) == pytest.approx(d["ratio_min"]) and max(r) == pytest.approx(d["ratio_max"])


def test_the_whole_mesh_side_by_side_follows_its_file():
    """Issue 48: the whole-mesh guide's side by side with the authors' ``meshDistance`` is the
    table of ``mesh_distance_authors.json`` (``benchmarks/tables.py mesh-distance``) and the
    README's sentence its words; without that file neither quotes a figure of it."""
    page = (ROOT / "docs" / "guide" / "whole-mesh.md").read_text(encoding="utf-8")
    section = page.split("### Side by side with the authors' `meshDistance`", 1)[1]
    section = section.split("\n## ", 1)[0]
    readme = _flat((ROOT / "README.md").read_text(encoding="utf-8"))
    path = DATA / "mesh_distance_authors.json"
    if path.is_file():
        lines = [ln.strip() for ln in section.splitlines()]
        want = [ln.strip() for ln in mesh_distance_table(path).splitlines()]
        starts = [i for i, ln in enumerate(lines) if ln == want[0]]
        assert any(lines[i:i + len(want)] == want for i in starts), "paste it again"
        assert mesh_distance_words(path) in readme
    else:
        assert not [ln for ln in section.splitlines() if ln.startswith("| ")]
        assert "their time" not in readme and "0.38x" not in readme


def test_the_cloud_1080_sentence_follows_its_file():
    """Issue 46 item 7: the troubleshooting guide's 1080p point-cloud times are those of
    ``benchmarks/data/cloud_1080.json``."""
    from benchmarks.bench_cloud_1080 import words

    d = _load("cloud_1080.json")
    page = (ROOT / "docs" / "guide" / "troubleshooting.md").read_text(encoding="utf-8")
    assert words(d) in _flat(page)
    assert [r["points"] for r in d["rows"]] == [50_000, 1_000_000]


def test_the_self_shadow_sentence_follows_its_files():
    """Issue 46 item 3: the troubleshooting guide's brute-force shadow figures are those of
    ``benchmarks/data/self_shadow.json`` (and ``self_shadow_before.json``)."""
    from benchmarks.bench_self_shadow import words

    d, before = _load("self_shadow.json"), _load("self_shadow_before.json")
    page = (ROOT / "docs" / "guide" / "troubleshooting.md").read_text(encoding="utf-8")
    assert words(d, before) in _flat(page)
    assert d["wrong"] == sum(r["wrong"] for r in d["rows"])


def test_the_film_host_sentence_follows_its_file():
    """The film's host work before and after (``film_host.json``, issue 49)."""
    text = _flat(_guide())
    data = _load("film_host.json")
    assert (f"{data['before_host_s_median']:.2f} -> {data['after_host_s_median']:.2f} s "
            "(medians), with the same image") in text
    assert data["same_image"] and data["size"] == [1920, 1080] and data["samples"] == 16
    assert len(data["before"]) == len(data["after"]) == 3 and data["threads"] == 2


def test_the_gpu_kernels_section_follows_its_files():
    """The registers table and the sentences of "What holds the GPU kernels back"
    (``cuda_registers.json``, ``film_batches.json``, ``gpu_h200_lit.json``,
    ``gpu_cone_end.json``; issue 49)."""
    from benchmarks.check_cuda_ptx import occupancy

    page = _guide()
    text = _flat(page)
    assert registers_table(DATA / "cuda_registers.json") in page
    kernels = {k["kernel"].split()[-1]: k for k in _load("cuda_registers.json")["kernels"]}
    render_path = [kernels[n]["assembled"][0] for n in ("render", "cone", "samples", "light")]
    regs = [a["registers"] for a in render_path]
    occ = {a["occupancy"] for a in render_path}
    assert len(occ) == 1
    occ = occ.pop()
    assert (f"uses {_range(regs, '.0f')} registers a thread. A multiprocessor then holds "
            f"{occ * 64:.0f} of its 64 warps ({occ:.1%} occupancy)".replace("%", " %")) in text
    smooth = kernels["smooth"]["assembled"][0]
    assert (f"smooth kernel uses {smooth['registers']} registers "
            f"({smooth['occupancy']:.0%})".replace("%", " %")) in text
    # the sample launches of several rays a pixel, counted on the CPU and timed on the H200
    batches = [b for b in _load("film_batches.json")["batches"] if b["samples"] > 1]
    assert f"carry {_range([b['rays'] for b in batches], ',')} rays each" in text
    samples = kernels["samples"]
    resident = 132 * 64 * occupancy(samples["assembled"][0]["registers"],
                                    samples["threads_per_block"]) * 32
    assert f"holds {resident:,.0f} of its threads at once" in text
    assert all(0.7 < b["rays"] / resident < 1.2 for b in batches)      # about one wave
    assert (f"slowest ray: {_range([b['evals_max'] for b in batches], 'd')} distance evaluations"
            in text)
    assert f"against a mean of {_range([b['evals_mean'] for b in batches], '.0f')}" in text
    lit = next(r for r in _load("gpu_h200_lit.json")["rows"] if "triangles" in r["what"])
    timed = [(n, k, s) for n, k, s in lit["gpu_parts"]["samples"] if k > 1]
    assert [(n, k) for n, k, _ in timed] == [(b["pixels"], b["samples"]) for b in batches]
    assert f"took {_range([s for _, _, s in timed], '.2f')} s for each" in text
    # the common end depth on the card
    rows = _load("gpu_cone_end.json")["rows"]
    assert all(r["eps"] == 1e-3 and r["size"] == "1920x1080" for r in rows)
    fall = [100 * (1 - r["render_ratio"]) for r in rows]
    assert f"warp-summed leaves fall by {_range(fall, '.0f')} %" in text
    assert min(r["cone_ratio"] for r in rows) > 2             # "more than double"
    assert f"do {_range([r['both_ratio'] for r in rows], '.2f')}x the work" in text
    assert sum(r["hit_differs"] for r in rows) == 1 and "One grazing pixel of the edges" in text
