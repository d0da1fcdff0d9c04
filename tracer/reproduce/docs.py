"""Figures of the guides that ``tracer reproduce`` also measures, written from its results.

A guide holds each such figure between two markers::

    <!-- reproduce:NAME ... -->
    (generated text)
    <!-- /reproduce:NAME -->

:func:`blocks` builds every block's text from the committed results (:data:`BLOCKS`: the guide,
the block's name and the function that writes it), :func:`update` rewrites the guides
(``tracer reproduce --report-only --docs``) and :func:`disagreements` lists the blocks whose
text is not the one generated (``tests/tracer/reproduce/test_reproduce.py``), so that the
guides cannot lag the results again.
"""

import csv
import json
import re
from pathlib import Path

from tracer.outputs import write_text
from tracer.reproduce.claims import g3
from tracer.reproduce.experiments import TABLE3_PAPER, git_output
from tracer.studies.common import REPO

FULL = REPO / "renders" / "reproduction" / "full"
#: the beta study at the paper's 512² (``tracer ablate-beta scenes/data/bunny.off --size 512``)
#: while the full reproduction has not run its beta experiment
BETA512 = REPO / "renders" / "ablation" / "beta512"
#: box_test's cases -> the paper's Table 3 row
CASE_ROW = {"bunny-bunny": "bunny_bunny", "ring-toss": "trefoil_ringtoss",
            "bowl-ico": "ico_bowl", "slide-sphere": "sphere_slide"}


#: the cases' poses (``box_cases`` places them as ``benchmarks/bench_mesh_distance.py`` does)
POSES = {"bunny-bunny": "the copy above the bunny",
         "ring-toss": "the trefoil threaded on a peg just above the board",
         "bowl-ico": "the icosphere resting in the bowl",
         "slide-sphere": "the sphere lying in the chute"}


def num(x):
    """3 significant digits, without an exponent (``2,400``, ``8.04``, ``0.00122``)."""
    x = float(x)
    return f"{x:,.0f}" if abs(x) >= 1000 else g3(x)


def _json(path):
    with open(path, encoding="utf-8") as fh:
        return json.load(fh)


def _rel(path):
    return Path(path).resolve().relative_to(REPO).as_posix()


def _when(res):
    p = res["provenance"]
    load = p.get("load_average")
    return (f"{p['date'][:10]}, commit `{p['commit'][:12]}`, {p['numba_threads']} numba "
            f"threads, load average {', '.join(g3(x) for x in load) if load else '-'}")


def whole_mesh_speed_text():
    """The speed table of docs/guide/whole-mesh.md: one near-contact evaluation per Table 3
    case, from the full run's ``box_test.json``."""
    res = _json(FULL / "box_test.json")
    L = ["| case (pose: exact gap 1/alpha) | data | query | alpha / alpha_q | paper, 28 threads "
         "| ours (median) | ours, box test off |", "|---|---|---|---|---:|---:|---:|"]
    for name, c in res["cases"].items():
        paper = TABLE3_PAPER[CASE_ROW[name]][3]
        L.append(f"| {name} ({POSES[name]}) | {c['data_primitives']:,} {c['data_kind']} | "
                 f"{c['query_primitives']:,} {c['query_kind']} | {c['alpha']:g} / "
                 f"{c['alpha']:g} | {num(paper)} ms | {num(c['ms_on'])} ms | "
                 f"{num(c['ms_off'])} ms |")
    ratio = {n: c["ms_on"] / TABLE3_PAPER[CASE_ROW[n]][3] for n, c in res["cases"].items()}
    faster = [f"{n} ({g3(1 / r)}x)" for n, r in ratio.items() if r < 1]
    slower = [f"{n} ({g3(r)}x slower)" for n, r in ratio.items() if r >= 1]
    L += ["", "Against the paper's 28 threads on our cores: faster on "
          + (", ".join(faster) or "none") + "; " + (", ".join(slower) or "none slower") + "."]
    L += ["", f"Ours: `tracer reproduce`'s box_test experiment (`{_rel(FULL)}/box_test.json`; "
          f"{_when(res)}): the median of {res['repeat']} wall-clock evaluations (value + every "
          f"vertex gradient, beta {res['beta']:g}, tol 0), alternated with the same evaluation "
          "with the box test off (the exact primitive-box distance; see "
          "[the reproduction report](../reproduction.md))."]
    return "\n".join(L)


def bh_switch_text():
    """The Barnes-Hut switch sentence of docs/guide/studies.md, from the full run."""
    h = _json(FULL / "bh_switch.json")
    return (f"On the Autzen cloud normalised to a unit diagonal ({h['points']:,} points, "
            f"{h['trials']} rays, alpha {h['alpha']:g}, beta {h['beta']:g}) it keeps "
            f"{h['kept_points']} switch points with a mean discrepancy of "
            f"{g3(h['mean_discrepancy'])}, a maximum of {g3(h['max_discrepancy'])} and a "
            f"minimum gradient cosine of {h['min_cosine']:.4f} (`{_rel(FULL)}/bh_switch.json`, "
            f"{_when(h)}).")


def _beta_rows():
    """``(rows, source, when)`` of the 512² beta study: the full reproduction's when it ran
    its beta experiment, else :data:`BETA512`."""
    if (FULL / "beta.json").is_file():
        res = _json(FULL / "beta.json")
        path = FULL / res["csv"]
        when = _when(res)
    else:
        path = BETA512 / "beta_ablation.csv"
        p = _json(BETA512 / "beta_params.json")
        date = git_output("log", "-1", "--format=%cs", "--", _rel(path))
        when = (p.get("note") or "the study's own run") + (f"; committed {date}" if date else "")
    with open(path, newline="", encoding="utf-8") as fh:
        rows = [r for r in csv.DictReader(fh) if float(r.get("tol") or 0) == 0
                and r.get("status", "ok") == "ok"]
    return rows, path, when


def beta_512_text():
    """The 512² beta table of docs/guide/studies.md."""
    rows, path, when = _beta_rows()
    t = {(r["type"], float(r["beta"])): r for r in rows}
    L = ["| type (512²) | beta 0 | beta 0.5 (error %) | beta 1.0 (error %) |",
         "|---|---:|---:|---:|"]
    for kind in ("points", "edges", "triangles"):
        cells = []
        for b in (0.0, 0.5, 1.0):
            r = t.get((kind, b))
            if r is None:
                cells.append("-")
                continue
            s = f"{num(r['seconds'])} s"
            cells.append(s if b == 0 else f"{s} ({100 * float(r['error_rel_diag']):.3g})")
        L.append(f"| {kind} | " + " | ".join(cells) + " |")
    total = sum(float(r["seconds"]) for r in rows)
    L += ["", f"From `{_rel(path)}` ({when}); its {len(rows)} renders took "
          f"{total / 60:.0f} min in all."]
    return "\n".join(L)


#: (guide, block name, writer)
BLOCKS = [("docs/guide/whole-mesh.md", "whole-mesh-speed", whole_mesh_speed_text),
          ("docs/guide/studies.md", "beta-512", beta_512_text),
          ("docs/guide/studies.md", "bh-switch", bh_switch_text)]

_OPEN = "<!-- reproduce:{name} (generated by `python -m tracer reproduce --report-only --docs` " \
        "from the results files; do not edit) -->"


def _pattern(name):
    return re.compile(r"<!-- reproduce:" + re.escape(name) + r"\b[^>]*-->\n(.*?)<!-- /reproduce:"
                      + re.escape(name) + r" -->", re.S)


def blocks():
    """``{(guide, name): generated text}``."""
    return {(g, n): f() for g, n, f in BLOCKS}


def _read(guide):
    return (REPO / guide).read_text(encoding="utf-8")


def current(guide, name, read=_read):
    """The text between the block's markers in the guide (None when the markers are missing);
    ``read(guide)`` gives the guide's text."""
    m = _pattern(name).search(read(guide))
    return m.group(1).rstrip("\n") if m else None


def disagreements(read=_read):
    """The blocks whose guide text (``read(guide)``) is not the generated one."""
    out = []
    for (guide, name), text in blocks().items():
        have = current(guide, name, read)
        if have is None:
            out.append(f"{guide}: no reproduce:{name} block")
        elif have != text:
            out.append(f"{guide}: block {name} is not the one generated from the results")
    return out


def update():
    """Rewrite every block in its guide; returns the guides changed."""
    changed = []
    for (guide, name), text in blocks().items():
        path = REPO / guide
        old = path.read_text(encoding="utf-8")
        pat = _pattern(name)
        if not pat.search(old):
            raise RuntimeError(f"{guide} has no reproduce:{name} block")
        new = pat.sub(lambda m: _OPEN.format(name=name) + "\n" + text + "\n<!-- /reproduce:"
                      + name + " -->", old, count=1)
        if new != old:
            write_text(path, new)
            changed.append(guide)
    return sorted(set(changed))
