"""The markdown tables that docs/guide/performance.md quotes, made from the results files.

``tests/repo/test_docs_tables.py`` checks that the guide holds each table exactly as this script
makes it from the committed results files, so a rerun that changes a figure cannot leave the
page behind.

Usage::

    python benchmarks/tables.py scaling benchmarks/data/scaling.json
    python benchmarks/tables.py gpu benchmarks/data/gpu_h100.json
    python benchmarks/tables.py coldstart benchmarks/data/coldstart.json \\
        benchmarks/data/coldstart_before.json
    python benchmarks/tables.py exact-mix benchmarks/data/exact_mix.json
    python benchmarks/tables.py smooth-cost benchmarks/data/exact_mix.json
    python benchmarks/tables.py mesh-distance benchmarks/data/mesh_distance_authors.json
    python benchmarks/tables.py registers benchmarks/data/cuda_registers.json
    python benchmarks/tables.py build-scale benchmarks/data/build_scale.json
    python benchmarks/tables.py coldstart-copies benchmarks/data/coldstart_issue63.json
    python benchmarks/tables.py coldstart-ahead benchmarks/data/coldstart.json
    python benchmarks/tables.py coldstart-kinds benchmarks/data/coldstart.json \\
        benchmarks/data/coldstart_issue63_kinds_before.json
    python benchmarks/tables.py coldstart-warmup benchmarks/data/coldstart_issue63_modes.json \\
        benchmarks/data/coldstart_issue63_modes_before.json
"""

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))


def _load(path):
    return json.loads(Path(path).read_text(encoding="utf-8"))


def scaling_table(path):
    """The thread-scaling table of a ``bench_scaling.py`` results file: per kind, the best
    ``--stats`` seconds at each thread count, the speedup at the most threads (``--stats``
    seconds and the whole frame with its PNG) and Amdahl's law fitted to all counts."""
    d = _load(path)
    m = d["machine"]
    counts = [str(n) for n in d["threads"]]
    top = counts[-1]
    lines = [f"{m['cpu']}, {m['cores']} cores, {d['size'][0]}x{d['size'][1]}, best of "
             f"{d['repeat']}, {d['date']} (Python {m['python']}, numpy {m['numpy']}, numba "
             f"{m['numba']})",
             "",
             "| kind | " + " | ".join(f"{n} thr. s" for n in counts)
             + f" | speedup at {top} | frame speedup at {top} | serial s (Amdahl) "
               f"| efficiency at {top} | load average |",
             "|---" * (len(counts) + 6) + "|"]
    for kind, k in d["kinds"].items():
        sec, frame = k["seconds"], k["frame"]
        eff = sec["best"]["1"] / (int(top) * sec["best"][top])
        serial = sec.get("serial_all", sec["serial_1_2"])
        lo, hi = k["load_average"]
        lines.append(f"| {kind} | " + " | ".join(f"{sec['best'][n]:.3f}" for n in counts)
                     + f" | {sec['speedup'][top]:.2f} | {frame['speedup'][top]:.2f} "
                       f"| {serial:.3f} | {eff:.2f} | {lo:.1f}-{hi:.1f} |")
    return "\n".join(lines)


def gpu_table(path):
    """The table of a ``bench_gpu.py`` results file (its own markdown, made again)."""
    from benchmarks.bench_gpu import markdown

    d = _load(path)
    return markdown(d["card"], d["rows"], d["threads"], d["cpu"])


#: the cold-start table's targets (issue 51): CPU seconds of a first call, fresh process, empty
#: kernel cache, our quiet 2-core machine
COLDSTART_TARGETS = {"exact": 4, "smooth": 5, "smooth_alpha_u": 5, "md_triangles": 15,
                     "md_edges": 15, "md_tri_edges": 15, "md_points": 15, "md_exact": 15,
                     "md_vertex": 15, "mesh": 10, "edges": 10, "cloud": 10, "lit": 10}


def _cpu(machine):
    """``"<CPU model>, "`` where the results file names it (files before 2026-12-07 do not)."""
    return f"{machine['cpu']}, " if machine.get("cpu") else ""


def _provenance(d, loads):
    """The closing line of a ``bench_coldstart.py`` table: when, which commit, the machine, and
    the range of the ``loads`` (load averages) seen."""
    m = d["machine"]
    return (f"{d['date']}, commit {(d.get('commit') or '?')[:10]}"
            f"{' (dirty)' if d.get('dirty') else ''}, {_cpu(m)}{m['cores']} cores, Python "
            f"{m['python']}, load average {min(loads):.1f}-{max(loads):.1f}")


def coldstart_table(path, before_path=None):
    """The first-call table of a ``bench_coldstart.py`` results file: per case its command, the
    cold CPU and wall seconds and compiled specialisations (and those of ``before_path``, the
    same script run on the code before), the warm wall seconds and the target."""
    d = _load(path)
    b = _load(before_path)["cases"] if before_path else {}
    cells = ["first call (empty cache)", "CPU s", "wall s", "compiled"]
    if b:
        cells += ["before: CPU s", "wall s", "compiled"]
    cells += ["warm wall s", "target CPU s"]
    lines = ["| " + " | ".join(cells) + " |", "|" + "---|" * len(cells)]
    for case, r in d["cases"].items():
        c = r["cold"]
        row = f"| `{r['command']}` | {c['cpu_s']:.1f} | {c['wall_s']:.1f} | {c['compiled']} | "
        if b:
            o = b.get(case)
            row += (f"{o['cold']['cpu_s']:.1f} | {o['cold']['wall_s']:.1f} | "
                    f"{o['cold']['compiled']} | " if o else "- | - | - | ")
        target = COLDSTART_TARGETS.get(case)
        row += f"{r['warm']['wall_s']:.1f} | {target if target else '-'} |"
        lines.append(row)
    loads = [x for r in d["cases"].values() for x in (r["cold"]["load_before"],
                                                       r["cold"]["load_after"])]
    lines += ["", _provenance(d, loads)]
    return "\n".join(lines)


#: issue 63's target: CPU seconds of any first call in a second copy of the same version (a
#: fresh clone or environment) after one compile on the machine
SECOND_COPY_TARGET = 3


def coldstart_copies_table(path):
    """Issue 63's first-call table of a ``bench_coldstart.py --copies`` results file: per case
    the CPU and wall seconds and compiled specialisations with an empty cache, in a second copy
    of the source after that, and with a new cache that ``tracer warmup`` filled, and the CPU
    seconds of a warm run in the first copy; then the warm-up's own cost."""
    d = _load(path)
    cells = ["first call", "empty cache: CPU s", "wall s", "compiled", "second copy: CPU s",
             "wall s", "compiled", "after warmup: CPU s", "wall s", "compiled", "warm: CPU s"]
    lines = ["| " + " | ".join(cells) + " |", "|" + "---|" * len(cells)]
    for r in d["cases"].values():
        row = f"| `{r['command']}` |"
        for mode in ("cold", "second_copy", "after_warmup"):
            m = r[mode]
            row += f" {m['cpu_s']:.1f} | {m['wall_s']:.1f} | {m['compiled']} |"
        lines.append(row + f" {r['warm']['cpu_s']:.1f} |")
    w = d["warmup"]
    loads = [x for r in d["cases"].values() for mode in ("cold", "second_copy", "after_warmup")
             for x in (r[mode]["load_before"], r[mode]["load_after"])]
    lines += ["", f"`python -m tracer warmup` into an empty cache: {w['wall_s']:.1f} s wall, "
              f"{w['cpu_s']:.1f} s CPU (its child processes), {w['compiled']} specialisations "
              f"compiled, on {w['cores']} cores.",
              "", _provenance(d, loads)]
    return "\n".join(lines)


def coldstart_warmup_table(path, before_path):
    """Issue 63's warm-up before and after a change: per case of two ``bench_coldstart.py
    --copies`` results files (``before_path`` on the code before, the same sitting) the first
    call with an empty cache and with a new cache that each code's ``tracer warmup`` filled;
    then each warm-up's own cost."""
    d, b = _load(path), _load(before_path)
    cells = ["first call", "empty cache: CPU s", "compiled", "after warmup, before: CPU s",
             "compiled", "after warmup: CPU s", "compiled"]
    lines = ["| " + " | ".join(cells) + " |", "|" + "---|" * len(cells)]
    loads = []
    for case, r in d["cases"].items():
        c, o, a = r["cold"], b["cases"][case]["after_warmup"], r["after_warmup"]
        lines.append(f"| `{r['command']}` | {c['cpu_s']:.1f} | {c['compiled']} | "
                     f"{o['cpu_s']:.1f} | {o['compiled']} | {a['cpu_s']:.1f} | {a['compiled']} |")
        loads += [x for m in (c, o, a) for x in (m["load_before"], m["load_after"])]
    wb, wa = b["warmup"], d["warmup"]
    lines += ["", f"`python -m tracer warmup` into an empty cache, before: {wb['wall_s']:.1f} s "
              f"wall, {wb['cpu_s']:.1f} s CPU, {wb['compiled']} specialisations; after: "
              f"{wa['wall_s']:.1f} s wall, {wa['cpu_s']:.1f} s CPU, {wa['compiled']} "
              f"specialisations (commit {(b.get('commit') or '?')[:10]} before).",
              "", _provenance(d, loads)]
    return "\n".join(lines)


def coldstart_ahead_table(path):
    """Issue 63's compile-ahead table of a ``bench_coldstart.py`` results file: per case that
    has one (the renders, the simulation) its first call with an empty cache in one process
    (``cold``) and with part of its kernels (a render's light, a simulation's moments) compiled
    in a second process beside it (``cold_ahead``: both processes' CPU), and the ratio of their
    wall seconds."""
    d = _load(path)
    cells = ["first call (empty cache)", "one process: CPU s", "wall s",
             "part compiled alongside: CPU s", "wall s", "wall ratio"]
    lines = ["| " + " | ".join(cells) + " |", "|" + "---|" * len(cells)]
    loads = []
    for r in d["cases"].values():
        if "cold_ahead" not in r:
            continue
        c, a = r["cold"], r["cold_ahead"]
        lines.append(f"| `{r['command']}` | {c['cpu_s']:.1f} | {c['wall_s']:.1f} | "
                     f"{a['cpu_s'] + a['cpu_children_s']:.1f} | {a['wall_s']:.1f} | "
                     f"{a['wall_s'] / c['wall_s']:.2f} |")
        loads += [c["load_before"], c["load_after"], a["load_before"], a["load_after"]]
    lines += ["", _provenance(d, loads)]
    return "\n".join(lines)


def coldstart_kinds_table(path, before_path):
    """Issue 63's whole-mesh table: per case of ``before_path`` (``bench_coldstart.py --source``
    on the code before) its first call there and in ``path`` (this code, the same sitting),
    CPU and wall seconds and compiled specialisations, and the ratio of the CPU seconds."""
    d, b = _load(path), _load(before_path)
    cells = ["first call (empty cache)", "before: CPU s", "wall s", "compiled", "after: CPU s",
             "wall s", "compiled", "CPU ratio"]
    lines = ["| " + " | ".join(cells) + " |", "|" + "---|" * len(cells)]
    loads = {"after": [], "before": []}
    for case, o in b["cases"].items():
        c, r = o["cold"], d["cases"][case]["cold"]
        lines.append(f"| `{o['command']}` | {c['cpu_s']:.1f} | {c['wall_s']:.1f} | "
                     f"{c['compiled']} | {r['cpu_s']:.1f} | {r['wall_s']:.1f} | "
                     f"{r['compiled']} | {r['cpu_s'] / c['cpu_s']:.2f} |")
        loads["before"] += [c["load_before"], c["load_after"]]
        loads["after"] += [r["load_before"], r["load_after"]]
    lines += ["", f"Before: {_provenance(b, loads['before'])}. After: "
              f"{_provenance(d, loads['after'])}."]
    return "\n".join(lines)


def coldstart_ab_table(path):
    """Issue 63's first renders, the code before against this code, from a
    ``bench_coldstart_ab.py`` results file: per render case and side the smallest and the median
    over the rounds of the render in one process (CPU seconds) and with the light compiled in a
    second process (wall seconds), and the ratio of the smallest (the modes the file holds)."""
    d = _load(path)
    modes = d.get("modes", ["cold", "cold_ahead"])     # older files ran both
    heads = {"cold": "one process, CPU s: before", "cold_ahead": "light alongside, wall s: before"}
    cells = ["first render (empty cache)"] + [c for m in modes for c in (heads[m], "after",
                                                                          "ratio")]
    lines = ["| " + " | ".join(cells) + " |", "|" + "---|" * len(cells)]
    loads = []
    for c in d["cases"].values():
        row = [f"`{c['command']}`"]
        for mode in modes:
            b, a = (c[side]["summary"][mode] for side in ("before", "after"))
            row += [f"{b['min']:.1f} ({b['median']:.1f})", f"{a['min']:.1f} ({a['median']:.1f})",
                    f"{a['min'] / b['min']:.2f}"]
            loads += [r[k] for side in ("before", "after") for r in c[side][mode]
                      for k in ("load_before", "load_after")]
        lines.append("| " + " | ".join(row) + " |")
    m = d["machine"]
    def name(side):
        probe = d[side].get("probe")
        if probe:           # a patch tried on a copy of the code before, not a commit
            return f"{side}: that with `{probe['patch']}`"
        dirty = " (dirty)" if d[side].get("dirty") else ""
        return f"{side}: commit {(d[side].get('commit') or '?')[:10]}{dirty}"
    sides = ", ".join(name(side) for side in ("before", "after"))
    lines += ["", f"Smallest (median) of {d['rounds']} rounds, each side run in turn; "
              f"{d['date']}, {sides}, {_cpu(m)}{m['cores']} cores, Python {m['python']}, load "
              f"average {min(loads):.1f}-{max(loads):.1f}"]
    return "\n".join(lines)


def timeline_table(path):
    """The events of a ``timeline_first_render.py`` results file, in time order: seconds since
    the render's process started, the process, what happened (a compilation with its length,
    callees included; a wait for the child with its length)."""
    d = _load(path)
    lines = ["| s | process | event |", "|---|---|---|"]
    for e in d["events"]:
        what = e["what"]
        if what == "compiled":
            what = f"compiled `{e['name']}` ({e['s']:.2f} s)"
        elif what == "waited":
            what = f"waits {e['s']:.2f} s for the child's `{e['tag']}`"
        lines.append(f"| {e['at']:.2f} | {e['who']} | {what} |")
    lines.append(f"| {d['wall_s']:.2f} | render | the process has ended |")
    m = d["machine"]
    dirty = " (dirty)" if d.get("dirty") else ""
    lines += ["", f"`{d['command']}`, an empty cache, its light compiled alongside; {d['date']}, "
              f"commit {(d.get('commit') or '?')[:10]}{dirty}, {_cpu(m)}{m['cores']} cores, "
              f"Python {m['python']}, load average {d['load_average'][0]:.1f}"]
    return "\n".join(lines)


def coldstart_steps_table(path):
    """The table of ``coldstart_issue51_steps.json``: the first ``MeshDistance`` call after
    each change of issue 51, in the order made."""
    d = _load(path)
    lines = ["| change (cumulative) | CPU s | wall s | compile events |", "|---|---|---|---|"]
    lines += [f"| {r['step']} | {r['cpu_s']:.1f} | {r['wall_s']:.1f} | {r['compile_events']} |"
              for r in d["steps"]]
    return "\n".join(lines)


def exact_mix_table(path):
    """The exact-query table of a ``bench_exact_mix.py`` results file."""
    from benchmarks.bench_exact_mix import markdown

    return markdown(_load(path))


def smooth_cost_table(path):
    """The smooth-vs-exact cost table of a ``bench_exact_mix.py --smooth`` results file."""
    from benchmarks.bench_exact_mix import smooth_markdown

    return smooth_markdown(_load(path))


def exact_mix_words(path):
    """The README's and the guide's sentence: the range of ours / theirs over the mixes asked
    in one call, and, per batch size, over those asked a few queries per call (fcpw and
    open3d only: libigl builds its tree at every call)."""
    d = _load(path)
    whole = [r for r in d["rows"] if "/" not in r["mix"]]
    batched = [r for r in d["rows"] if "/" in r["mix"]]

    def span(rows, name):
        r = [row["sides"][name]["ours_over_theirs"] for row in rows
             if name in row["sides"] and row["sides"][name]["agrees"]]
        if not r:
            return None
        lo, hi = f"{min(r):.2f}", f"{max(r):.2f}"
        return lo if lo == hi else f"{lo}-{hi}"

    names = ("fcpw", "open3d", "libigl")
    words = [f"{span(whole, n)} of {n}'s" for n in names if span(whole, n)]
    m = d["machine"]
    text = (f"Exact distance takes {', '.join(words[:-1])} and {words[-1]} wall time on each of "
            f"{len(whole)} query mixes ({m['date'][:10]}, {m['cores']} cores, "
            f"{m['threads']} threads each, same process, alternating)")
    sizes = sorted({int(r["mix"].split("/")[1]) for r in batched})
    parts = []
    for size in sizes:
        rows = [r for r in batched if int(r["mix"].split("/")[1]) == size]
        got = [f"{span(rows, n)} of {n}'s" for n in names[:2] if span(rows, n)]
        if got:
            parts.append(f"{size:,} per call, {' and '.join(got)}")
    if parts:
        text += "; asked " + "; ".join(parts)
    return text


def mesh_distance_table(path):
    """The whole-mesh side-by-side table of a ``bench_mesh_distance.py --authors-bin ...
    --json`` results file: per case their ``meshDistance`` and ours, best of each round's
    ``repeat`` calls (median over the rounds), the ratio of the bests and both values."""
    from tracer.reproduce.docs import POSES

    d = _load(path)
    rows = d["side_by_side"]
    lines = ["| case (pose: exact gap 1/alpha) | theirs, best (median of rounds) | ours, best "
             "(median) | ours / theirs | their value | ours |",
             "|---|---:|---:|---:|---:|---:|"]
    for r in rows:
        lines.append(f"| {r['case']} ({POSES.get(r['case'], '?')}) | "
                     f"{r['authors_ms_best']:.2f} ms ({r['authors_ms_median']:.2f}) | "
                     f"{r['ms_best']:.2f} ms ({r['ms_median']:.2f}) | **{r['ratio']:.2f}** | "
                     f"{r['authors_distance']:.6f} | {r['smooth_distance']:.6f} |")
    m = d["machine"]
    loads = [m["load_average"]] + [r["load_average"] for r in rows]
    lines += ["", f"{d.get('date', '?')}, commit {(d.get('commit') or '?')[:10]}, "
              f"{rows[0]['threads']} threads each, beta {rows[0]['beta']:g}, tol 0, "
              f"{d['rounds']} alternating rounds of theirs and ours, best of {d['repeat']} calls "
              f"each; load average {min(loads):.1f}-{max(loads):.1f} "
              f"(`{Path(path).as_posix()}`)"]
    return "\n".join(lines)


def mesh_distance_words(path):
    """The README's sentence: ours / theirs per case, from the same file."""
    d = _load(path)
    names = {"bunny-bunny": "bunny-bunny", "ring-toss": "ring toss",
             "bowl-ico": "bowl-icosphere", "slide-sphere": "slide-sphere"}
    return ("Whole-mesh distance (their `meshDistance`, beta 0.5, side by side, "
            f"{d.get('date', '?')[:10]}, best of each): "
            + ", ".join(f"{names.get(r['case'], r['case'])} {r['ratio']:.2f}x their time"
                        for r in d["side_by_side"]))


def registers_table(path):
    """The kernels' registers and occupancy of a ``check_cuda_ptx.py --ptxas`` report: per
    kernel of the GPU path its threads a block, then per register cap (none first) the
    registers a thread uses, the spill stores in its code (bytes) and the occupancy."""
    d = _load(path)
    caps = [a["max_registers"] for a in d["kernels"][0]["assembled"]]
    cells = ["kernel", "threads a block"]
    for cap in caps:
        name = "no cap" if cap is None else f"cap {cap}"
        cells += [f"{name}: registers", "spill stores, bytes", "occupancy"]
    lines = ["| " + " | ".join(cells) + " |", "|" + "---|" * len(cells)]
    for k in d["kernels"]:
        if k["kernel"].startswith("benchmarks."):
            continue                       # bench_gpu's own variants
        row = [f"`{k['kernel']}`", str(k["threads_per_block"])]
        for a in k["assembled"]:
            row += [str(a["registers"]), str(a["spill_stores"]), f"{a['occupancy']:.1%}"]
        lines.append("| " + " | ".join(row) + " |")
    return "\n".join(lines)


#: the peers of ``bench_build_scale.py``, in the table's order
BUILD_SCALE_PEERS = ("fcpw", "open3d", "warp", "libigl", "scipy")


def _mib(x, bound=False):
    """MiB to 2 significant figures at least; ``bound``: an upper bound (``<=``)."""
    return ("<=" if bound else "") + (f"{x:.0f}" if abs(x) >= 10 else f"{x:.2g}")


def _peer_cell(r):
    """A peer's build cell: ``seconds, extra MiB`` (a lazy build: ``add s + first query s*``),
    ``skipped`` or ``-`` (not run on this kind)."""
    if r is None:
        return "-"
    if "skipped" in r:
        return "skipped"
    secs = (f"{r['build_s']:.2g} + {r['first_query_s']:.2g}*" if r["lazy_build"]
            else f"{r['build_s']:.2g}")
    return (f"{secs} s, {_mib(r['build_extra_mib'], r['build_extra_bound'])} MiB"
            + (" (differs)" if r.get("agrees") is False else ""))


def build_scale_markdown(d):
    """The tables of a ``bench_build_scale.py`` results dict: the builds, then the renders'
    stages (where there are renders)."""
    return "\n\n".join(t for t in (_build_scale_builds(d), _build_scale_renders(d)) if t)


def _build_scale_builds(d):
    """Per kind and size ours' build seconds, extra memory and its ratio to the input arrays,
    the exact tree's seconds, each peer's build seconds and extra memory, ours' exact queries
    per second against the best peer's and ours' smooth queries per second."""
    rows = d["rows"]
    peers = [p for p in BUILD_SCALE_PEERS if any(p in r["libraries"] for r in rows)]
    head = (["kind", "primitives", "arrays MiB", "ours build s", "ours extra MiB (x arrays)",
             "ours exact tree s (peak +MiB)"] + [f"{p} build s, extra MiB" for p in peers]
            + ["ours exact q/s", "best peer q/s", "ours / best", "ours smooth q/s"])
    lines = ["| " + " | ".join(head) + " |", "|---|" + "---:|" * (len(head) - 1)]
    for r in rows:
        libs = r["libraries"]
        o = libs.get("ours", {})
        arrays = r["input_bytes"] / 2 ** 20
        cells = [r["kind"], f"{r['n']:,}", _mib(arrays)]
        if "build_s" in o:
            extra = o["build_extra_mib"]
            cells += [f"{o['build_s']:.2g}",
                      _mib(extra, True) if o["build_extra_bound"]
                      else f"{_mib(extra)} ({extra / arrays:.1f}x)",
                      f"{o['exact_tree_s']:.2g} "
                      f"(+{_mib(o['exact_tree_extra_mib'] - extra)})"]
        else:
            cells += [o.get("skipped", "-")[:40], "-", "-"]
        cells += [_peer_cell(libs.get(p)) for p in peers]
        rates = {p: libs[p]["queries_per_s"] for p in peers
                 if "queries_per_s" in libs.get(p, {}) and libs[p].get("agrees") is not False}
        best = max(rates, key=rates.get) if rates else None
        cells += [f"{o['queries_per_s']:.3g}" if "build_s" in o else "-",
                  f"{rates[best]:.3g} ({best})" if best else "-",
                  f"{o['queries_per_s'] / rates[best]:.2f}" if best and "build_s" in o else "-",
                  f"{o['smooth_queries_per_s']:.3g}" if "build_s" in o else "-"]
        lines.append("| " + " | ".join(cells) + " |")
    m = d["machine"]
    loads = [m["load_start"], m.get("load_end", m["load_start"])] + [
        x for r in rows for v in r["libraries"].values() for x in (v.get("load_before"),
                                                                     v.get("load_after"))
        if x is not None]
    lazy = sorted({lib for r in rows for lib, v in r["libraries"].items()
                   if v.get("lazy_build")})
    compiled = [r["libraries"]["ours"].get("compiled_in_timing") for r in rows
                if "build_s" in r["libraries"].get("ours", {})]
    lines += ["", f"{m['cpu']}, {m['cores']} cores, numba {m['threads']} threads, "
              f"{d['queries']:,} queries within 1-4 % of the diagonal, {m['date']}, commit "
              f"{(m.get('commit') or '?')[:10]}{' (dirty)' if m.get('dirty') else ''}, load "
              f"average {min(loads):.1f}-{max(loads):.1f}. Each library in a fresh process, "
              "compile excluded (numba compile events in ours' timed stages: "
              f"{max(compiled) if compiled else '-'}); extra MiB: peak RSS after the build "
              "minus RSS before (<=: the peak stayed at the warm-up's, an upper bound); "
              "queries/s from a second batch"
              + "".join(f"; * {lib} builds its tree in its first query (build s + first "
                        "query s)" for lib in lazy) + "."]
    return "\n".join(lines)


def _build_scale_renders(d):
    """Per kind and size the ``tracer render`` command's wall seconds, its ratio to the
    small reference's, its peak RSS and its stages' seconds."""
    renders = d.get("renders") or []
    if not renders:
        return ""
    names = list(dict.fromkeys(s["name"] for r in renders for s in (r["stages"] or [])))
    head = (["kind", "primitives", "whole command s", "x small", "peak RSS MiB"]
            + ([f"{n} s" for n in names] + ["startup s"] if names else ["stages"]))
    lines = ["| " + " | ".join(head) + " |", "|---|" + "---:|" * (len(head) - 1)]
    for r in renders:
        st = {s["name"]: s["seconds"] for s in (r["stages"] or [])}
        label = f"{r['n']:,}" + (f" ({r['label']})" if r["label"] else "")
        ratio = ("-" if r["rc"] else "1" if r["label"]
                 else f"{r['ratio_to_small']:.1f}" if r.get("ratio_to_small") else "-")
        cells = [r["kind"], label, f"{r['wall_s']:.2f}" + (" (failed)" if r["rc"] else ""),
                 ratio, f"{r['peak_rss_mib']:.0f}"]
        if names:
            cells += [f"{st[n]:.2f}" if n in st else "-" for n in names]
            cells.append(f"{r['wall_s'] - r['total_seconds']:.2f}"
                         if r["total_seconds"] is not None else "-")
        else:
            cells.append("- (no --stage-times)")
        lines.append("| " + " | ".join(cells) + " |")
    size = d["args"]["render_size"]
    lines += ["", f"`tracer render FILE --size {size} {size}` of the PLY, a fresh "
              "process, its kernels cached; x small: whole command / the small reference's; "
              "startup: whole command minus the stages' clock (imports)."]
    return "\n".join(lines)


def build_scale_words(path, before_path):
    """The sentences the README and the performance guide quote from a
    ``bench_build_scale.py`` results file (``path``) and the code before's (``before_path``):
    the largest triangle mesh's build, its memory and its render against the small one's."""
    d, b = _load(path), _load(before_path)

    def largest(res):
        rows = [r for r in res["rows"] if r["kind"] == "triangles"
                and "build_s" in r["libraries"].get("ours", {})]
        return max(rows, key=lambda r: r["n"])

    def render_ratio(res, n):
        return next(r["ratio_to_small"] for r in res["renders"]
                    if r["kind"] == "triangles" and r["n"] == n and not r["label"])

    r, rb = largest(d), largest(b)
    o, ob = r["libraries"]["ours"], rb["libraries"]["ours"]
    fcpw = r["libraries"].get("fcpw", {})
    arrays = r["input_bytes"] / 2 ** 20
    peer = (f" (fcpw {fcpw['build_s']:.2g} s)" if "build_s" in fcpw else "")
    return [f"a mesh of {r['n']:,} triangles builds in {o['build_s']:.2g} s{peer}, "
            f"{ob['build_s']:.2g} s before issue 60",
            f"with {o['build_extra_mib']:.0f} MiB of extra memory "
            f"({o['build_extra_mib'] / arrays:.0f}x its arrays; {ob['build_extra_mib']:.0f} MiB "
            f"before)",
            f"`tracer render` of it at {d['args']['render_size']}² takes "
            f"{render_ratio(d, r['n']):.1f}x the time of a 20k-triangle mesh "
            f"({render_ratio(b, rb['n']):.1f}x before)"]


def scale_points_words(path):
    """The performance guide's sentence on ``bench_scale.py``'s 1e7-point cloud, from its
    results file."""
    d = _load(path)
    return (f"building the `DataMesh` took {d['mesh_s']:.1f} s, the BVH ({d['nodes']:,} nodes, "
            f"leaf size {d['leaf_size']}, with a progress bar) {d['build_s']:.1f} s, a "
            f"{d['size']}² render (beta {d['beta']:g}) {d['render_s']:.1f} s with "
            f"{d['mean_leaves']:.0f} leaves per pixel, and the peak resident memory of the whole "
            f"process was {d['peak_rss_gb']:.2f} GB ({d['threads']} threads, load average "
            f"{d['load'][0]:.1f})")


def build_scale_table(path):
    """The build-time and memory tables of a ``bench_build_scale.py`` results file."""
    return build_scale_markdown(_load(path))


TABLES = {"scaling": scaling_table, "gpu": gpu_table, "coldstart": coldstart_table,
          "coldstart-steps": coldstart_steps_table, "exact-mix": exact_mix_table,
          "smooth-cost": smooth_cost_table, "mesh-distance": mesh_distance_table,
          "registers": registers_table, "build-scale": build_scale_table,
          "coldstart-copies": coldstart_copies_table, "coldstart-ahead": coldstart_ahead_table,
          "coldstart-kinds": coldstart_kinds_table, "coldstart-ab": coldstart_ab_table,
          "coldstart-warmup": coldstart_warmup_table,
          "timeline": timeline_table}


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("kind", choices=sorted(TABLES))
    p.add_argument("path")
    p.add_argument("before", nargs="?",
                   help="coldstart, coldstart-kinds, coldstart-warmup: the results of the "
                   "code before")
    # coldstart-steps: benchmarks/data/coldstart_issue51_steps.json
    args = p.parse_args(argv)
    print(TABLES[args.kind](args.path, *([args.before] if args.before else [])))
    return 0


if __name__ == "__main__":
    sys.exit(main())
