"""The performance guide's sentences on issue 51's warm side-by-side runs, made from
``benchmarks/data/coldstart_issue51_warm.json``, and on issue 63's
(``coldstart_issue63_kinds_warm.json``); ``tests/repo/test_docs_tables.py`` checks that the
guide holds them."""

import json
from pathlib import Path

DATA = Path(__file__).resolve().parent / "data" / "coldstart_issue51_warm.json"


def _range(values, fmt):
    lo, hi = format(min(values), fmt), format(max(values), fmt)
    return lo if lo == hi else f"{lo}-{hi}"


def _pairs(block, fmt, names=None):
    b, a = block["before"], block["after"]
    return ", ".join(f"{names.get(k, k) if names else k} {_range(b[k], fmt)} -> "
                     f"{_range(a[k], fmt)}" for k in b)


def warm_sentences(path=DATA):
    """``(mesh, exact, render, grid, generic)``: the sentences of the guide."""
    d = json.loads(Path(path).read_text(encoding="utf-8"))
    mesh = _pairs(d["mesh_distance_ms_best"], ".2f", {"ring-toss": "ring toss"})
    exact = _pairs(d["mesh_exact_ms_best"], ".2f")
    render = _pairs(d["render_s_best"], ".3f")
    g = d["grid_queries_per_s"]
    worst = max(abs(sum(g["after"][k]) / sum(g["before"][k]) - 1.0) for k in g["before"])
    grid = f"within {100 * worst:.0f} % for every kind and mode"
    c = d["render_s_best_cpu_name"]
    slow = [sum(c["generic"][k]) / sum(c["host"][k]) - 1.0 for k in c["host"]]
    generic = (f"{_range([100 * s for s in slow], '.0f')} % slower renders here "
               "(points / edges / triangles " + " / ".join(_range(c["host"][k], ".3f")
                                                          for k in c["host"])
               + " s for this CPU against " + " / ".join(_range(c["generic"][k], ".3f")
                                                          for k in c["generic"]) + " s generic)")
    return mesh, exact, render, grid, generic


def kinds_warm_sentence(path=DATA.parent / "coldstart_issue63_kinds_warm.json",
                        key="mesh_distance_ms_best", fmt=".2f"):
    """Issue 63's warm side by side (``bench_mesh_distance_ab.py``): the Table 3 cases' best
    milliseconds per round, before -> after (``key``: ``"mesh_exact_ms_best"`` for the exact
    distance's)."""
    d = json.loads(Path(path).read_text(encoding="utf-8"))
    return _pairs(d[key], fmt, {"ring-toss": "ring toss"}) + " ms"


def exact_cold_sentence(path=DATA.parent / "coldstart_issue63_exact.json"):
    """The first ``MeshDistance.exact`` call before -> after, CPU seconds (median and range of
    the alternating runs) and specialisations."""
    d = json.loads(Path(path).read_text(encoding="utf-8"))
    b, a = ([r["cpu_s"] for r in d[side]] for side in ("before", "after"))
    med = lambda v: sorted(v)[len(v) // 2]  # noqa: E731
    return (f"{med(b):.1f} s ({_range(b, '.1f')}, {d['before'][0]['compiled']} specialisations)"
            f" -> {med(a):.1f} s ({_range(a, '.1f')}, {d['after'][0]['compiled']})")


def levels_warm_sentence(path=DATA.parent / "coldstart_issue63_levels_warm.json"):
    """Warm renders around the render's merged levels (``coldstart_issue63_levels_warm.json``):
    the best wall seconds over the rounds of each side, before -> after, of the bunny at 256²
    as points, edges and triangles (``bench_render.py``) and of the clip frame's lit look and
    its normals (``bench_frame.py``)."""
    d = json.loads(Path(path).read_text(encoding="utf-8"))
    best = {side: {f"{part} {k}": min(r[part][k] for r in d[side]["rounds"])
                   for part in ("render_256", "frame_320x180") for k in d[side]["rounds"][0][part]}
            for side in ("before", "after")}
    names = {"render_256 points": "points", "render_256 edges": "edges",
             "render_256 triangles": "triangles", "frame_320x180 lit": "the lit frame",
             "frame_320x180 normals": "its normals"}
    return ", ".join(f"{names[k]} {best['before'][k]:.3f} -> {best['after'][k]:.3f} s"
                     for k in names)


def vertex_cold_sentence(path=DATA.parent / "coldstart_issue63_vertex_loop_ab.json"):
    """A first ``MeshDistance.vertex_gradient`` on an empty cache, the runs in turn of
    ``bench_coldstart.py --cases md_vertex`` (``{"runs": [report + side]}``): CPU seconds
    before -> after."""
    runs = json.loads(Path(path).read_text(encoding="utf-8"))["runs"]
    cpu = {side: [r["cases"]["md_vertex"]["cold"]["cpu_s"] for r in runs if r["side"] == side]
           for side in ("before", "after")}
    return (f"{_range(cpu['before'], '.1f')} CPU s before, {_range(cpu['after'], '.1f')} "
            "CPU s after")


def library_warm_sentences(path=DATA.parent / "library_issue63_ab.json"):
    """``(vertex gradient, closing alpha)``: ``bench_library_ab.py``'s best per run, before ->
    after, milliseconds and seconds."""
    d = json.loads(Path(path).read_text(encoding="utf-8"))
    vg = {s: [r["vertex_gradient_ms"] for r in d[s]["runs"]] for s in ("before", "after")}
    ca = {s: [r["closing_alpha_s"] for r in d[s]["runs"]] for s in ("before", "after")}
    return (f"{_range(vg['before'], '.2f')} ms before, {_range(vg['after'], '.2f')} ms after",
            f"{_range(ca['before'], '.2f')} s a call before, {_range(ca['after'], '.2f')} s "
            "after")


if __name__ == "__main__":
    print("\n".join(warm_sentences()))


def first_render_sentence(ab=DATA.parent / "coldstart_issue63_renders_ab.json",
                          timeline=DATA.parent / "first_render_timeline.json"):
    """Issue 63's first render of a mesh file with its light compiled alongside: its wall
    seconds, smallest over the rounds run in turn against the code before
    (``bench_coldstart_ab.py``), and in the timeline's run (``timeline_first_render.py``)."""
    d = json.loads(Path(ab).read_text(encoding="utf-8"))["cases"]["mesh"]
    b, a = (d[side]["summary"]["cold_ahead"]["min"] for side in ("before", "after"))
    wall = json.loads(Path(timeline).read_text(encoding="utf-8"))["wall_s"]
    return (f"the first render of the mesh file with its light alongside took {a:.1f} s of wall "
            f"time at best ({b:.1f} s before), and {wall:.1f} s in the timeline's run")


def warm_render_sentence(path=DATA.parent / "coldstart_issue63_renders_warm.json"):
    """Issue 63's warm lit render, the code before against this code: smallest and median wall
    seconds of each."""
    import statistics

    d = json.loads(Path(path).read_text(encoding="utf-8"))
    b, a = d["before"]["wall_s"], d["after"]["wall_s"]
    return (f"{min(b):.2f} s at best ({statistics.median(b):.2f} median) before, "
            f"{min(a):.2f} s ({statistics.median(a):.2f}) after")
