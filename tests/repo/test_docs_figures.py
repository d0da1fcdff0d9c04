"""Every figure of the README and the guides (a number with a unit of time, a ratio or a
percentage) has a results file behind it (issue 48).

A line that shows such a figure passes when it lies

- in a generated block (``<!-- reproduce:NAME ... -->`` ... ``<!-- /reproduce:NAME -->``),
  which ``tests/tracer/reproduce/test_reproduce.py`` compares with the results files it is
  written from;
- in a table that ``benchmarks/tables.py`` makes from a results file (the line as the table
  function prints it; ``tests/repo/test_docs_tables.py`` checks that the page holds the table);
- in a fenced code block (commands and their printouts, not claims);
- or on the ledger, ``tests/repo/docs_figures_ledger.tsv`` (``file<TAB>reason<TAB>line``), which
  says why the line has no results file: a line checked sentence by sentence by a named test,
  or one that predates the rule and is still to be tied.

So a figure typed into a new or an edited line fails here until it is generated from a results
file, or ledgered with a reason; a ledger line whose text has left its page fails too, so the
ledger only shrinks. ``python tests/repo/test_docs_figures.py`` prints the lines that are neither
(paste them into the ledger only with a true reason).
"""

import json
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
LEDGER = ROOT / "tests" / "repo" / "docs_figures_ledger.tsv"
DATA = ROOT / "benchmarks" / "data"
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

#: a number followed by a unit of time, a ratio or a percentage
FIGURE = re.compile(r"(?<![\w.])\d[\d,]*(?:\.\d+)?\s?(?:(?:ms|µs|us|ns|s|min|minutes|"
                    r"seconds|hours|h|%)(?![\w])|[x×](?![\w])(?!\s?\d))")
_BLOCK = re.compile(r"<!-- reproduce:(\S+)[^>]*-->.*?<!-- /reproduce:\1 -->", re.S)
_FENCE = re.compile(r"^```.*?^```", re.S | re.M)


def pages():
    """The README and every guide, relative to the repository."""
    return ["README.md"] + sorted(p.relative_to(ROOT).as_posix()
                                  for p in (ROOT / "docs" / "guide").glob("*.md"))


def generated_lines():
    """The lines of the tables ``benchmarks/tables.py`` (and ``bench_fidelity.markdown``) make
    from the committed results files, stripped."""
    from benchmarks import tables as T
    from benchmarks.bench_fidelity import markdown

    made = [T.scaling_table(DATA / "scaling_xeon16.json"),
            T.scaling_table(DATA / "scaling_xeon16_before_png.json"),
            T.scaling_table(DATA / "scaling.json"), T.gpu_table(DATA / "gpu_h100.json"),
            T.gpu_table(DATA / "gpu_h200.json"), T.gpu_table(DATA / "gpu_h200_lit.json"),
            T.coldstart_table(DATA / "coldstart.json", DATA / "coldstart_issue51_before.json"),
            T.coldstart_steps_table(DATA / "coldstart_issue51_steps.json"),
            T.coldstart_copies_table(DATA / "coldstart_issue63.json"),
            T.coldstart_kinds_table(DATA / "coldstart.json",
                                    DATA / "coldstart_issue63_kinds_before.json"),
            T.coldstart_warmup_table(DATA / "coldstart_issue63_modes.json",
                                     DATA / "coldstart_issue63_modes_before.json"),
            T.coldstart_ab_table(DATA / "coldstart_issue63_renders_ab.json"),
            T.coldstart_ab_table(DATA / "coldstart_issue63_probe_one_kind.json"),
            T.coldstart_ab_table(DATA / "coldstart_issue63_probe_light_merged.json"),
            T.timeline_table(DATA / "first_render_timeline.json"),
            T.exact_mix_table(DATA / "exact_mix.json"),
            T.smooth_cost_table(DATA / "exact_mix.json"),
            T.registers_table(DATA / "cuda_registers.json"),
            T.build_scale_table(DATA / "build_scale.json"),
            T.build_scale_table(DATA / "build_scale_before.json"),
            markdown(json.loads((DATA / "fidelity.json").read_text(encoding="utf-8")))]
    if (DATA / "mesh_distance_authors.json").is_file():
        made.append(T.mesh_distance_table(DATA / "mesh_distance_authors.json"))
    return {ln.strip() for t in made for ln in t.splitlines() if ln.strip()}


def figure_lines(text):
    """The lines of ``text`` that show a figure, outside generated blocks and code fences."""
    text = _FENCE.sub("", _BLOCK.sub("", text))
    return [ln.strip() for ln in text.splitlines() if FIGURE.search(ln)]


def ledger():
    """``{(file, line): reason}`` of the ledger."""
    out = {}
    for n, row in enumerate(LEDGER.read_text(encoding="utf-8").splitlines(), 1):
        if not row.strip() or row.startswith("#"):
            continue
        parts = row.split("\t")
        assert len(parts) == 3 and parts[1].strip(), f"ledger line {n}: file, reason, line"
        out[(parts[0], parts[2])] = parts[1]
    return out


def untied(read=lambda f: (ROOT / f).read_text(encoding="utf-8")):
    """``[(file, line)]``: figure lines neither generated nor ledgered."""
    tied = generated_lines()
    known = ledger()
    return [(f, ln) for f in pages() for ln in figure_lines(read(f))
            if ln not in tied and (f, ln) not in known]


def test_every_figure_has_a_results_file_or_a_reason():
    missing = untied()
    assert not missing, ("figures without a results file (generate them from one, or ledger "
                         "them with a reason in tests/repo/docs_figures_ledger.tsv):\n"
                         + "\n".join(f"{f}: {ln}" for f, ln in missing))


def test_the_ledger_holds_only_lines_still_on_their_pages():
    """A line fixed or removed leaves the ledger with it: the ledger only shrinks."""
    have = {(f, ln) for f in pages()
            for ln in figure_lines((ROOT / f).read_text(encoding="utf-8"))}
    stale = [k for k in ledger() if k not in have]
    assert not stale, "ledger lines no longer on their page (remove them):\n" + "\n".join(
        f"{f}: {ln}" for f, ln in stale)


def test_a_typed_figure_is_caught():
    """The check itself: a new sentence with a typed figure in a guide fails, the same figure
    inside a generated block does not."""
    page = "docs/guide/whole-mesh.md"
    text = (ROOT / page).read_text(encoding="utf-8")
    typed = text + "\nOurs takes 0.42 ms on the ring toss.\n"
    assert (page, "Ours takes 0.42 ms on the ring toss.") in untied(
        lambda f: typed if f == page else (ROOT / f).read_text(encoding="utf-8"))
    block = text + ("\n<!-- reproduce:x (generated) -->\nOurs takes 0.42 ms on the ring toss."
                    "\n<!-- /reproduce:x -->\n")
    assert (page, "Ours takes 0.42 ms on the ring toss.") not in untied(
        lambda f: block if f == page else (ROOT / f).read_text(encoding="utf-8"))
    assert figure_lines("a 3.5x speed-up\n12 % of\n1,200 s\nversion 0.68\na 20 x 20 grid\n") \
        == ["a 3.5x speed-up", "12 % of", "1,200 s"]


if __name__ == "__main__":  # pragma: no cover
    for f, ln in untied():
        print(f"{f}\t?\t{ln}")
