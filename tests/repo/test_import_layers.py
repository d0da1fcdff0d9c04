"""No import circle between the modules of smoothdist and tracer (deferred imports inside
functions included), and no arrow from a lower room of docs/design-notes.md's map to a
higher one."""

import os
import re

import pytest

from import_graph import ROOT, cycles, graph, modules

DESIGN_NOTES = os.path.join(ROOT, "docs", "design-notes.md")


def test_the_graph_sees_deferred_and_relative_imports(tmp_path):
    pkg = tmp_path / "tracer"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("from tracer.a import thing\n")
    (pkg / "a.py").write_text("def f():\n    from tracer.sub import b\n")
    (pkg / "sub" / "__init__.py").write_text("")
    (pkg / "sub" / "b.py").write_text("from .. import thing\n")
    (tmp_path / "smoothdist").mkdir()
    edges = graph(str(tmp_path))
    assert edges["tracer.a"] == {"tracer.sub.b"}
    assert edges["tracer.sub.b"] == {"tracer.a"}  # via the package's re-export
    assert cycles(edges) == [["tracer.a", "tracer.sub.b"]]


def test_no_import_circle():
    found = cycles(graph())
    assert not found, "import circles: " + "; ".join(" <-> ".join(c) for c in found)


def test_smoothdist_never_imports_tracer():
    for m, targets in graph().items():
        if m.split(".")[0] == "smoothdist":
            assert not [t for t in targets if t.split(".")[0] == "tracer"], m


def test_tracer_uses_only_public_smoothdist_modules():
    """tracer reaches smoothdist through its public modules (``smoothdist``,
    ``smoothdist.kernels``, ``smoothdist.cuda``, ...), never a private one (a name that starts
    with ``_``, such as ``smoothdist._kernels`` or ``smoothdist._config``): the kernels tracer
    needs are exported by :mod:`smoothdist.kernels`."""
    bad = {m: sorted(t for t in targets if t.split(".")[0] == "smoothdist"
                     and any(part.startswith("_") for part in t.split(".")[1:]))
           for m, targets in graph().items() if m.split(".")[0] == "tracer"}
    bad = {m: t for m, t in bad.items() if t}
    assert not bad, bad


def rooms():
    """``[(room, [modules])]`` from the map's table in docs/design-notes.md, lowest first:
    rows ``| n | room | `module`, `module`, ... | ... |``."""
    text = open(DESIGN_NOTES, encoding="utf-8").read()
    start = text.index("<!-- rooms -->")
    end = text.index("<!-- /rooms -->")
    out = []
    for line in text[start:end].splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) >= 3 and cells[0].isdigit():
            out.append((cells[1], re.findall(r"`([\w.]+)`", cells[2])))
    return out


def test_the_map_lists_every_module_once():
    listed = [m for _, mods in rooms() for m in mods]
    dup = sorted({m for m in listed if listed.count(m) > 1})
    assert not dup, f"listed twice in the map: {dup}"
    actual = set(modules())
    assert sorted(actual - set(listed)) == [], "modules missing from the map"
    assert sorted(set(listed) - actual) == [], "the map names modules that do not exist"


def test_no_arrow_from_a_lower_room_up():
    floor = {m: i for i, (_, mods) in enumerate(rooms()) for m in mods}
    up = [f"{m} -> {t}" for m, targets in graph().items() for t in targets
          if floor.get(t, -1) > floor.get(m, len(floor))]
    assert not up, "imports that run back up: " + ", ".join(sorted(up))


@pytest.mark.parametrize("edge", ["smoothdist._kernels.query -> tracer.rendering.renderer",
                                  "tracer.rendering.camera -> tracer.scenes.scene",
                                  "tracer.runner -> tracer.rendering",
                                  "tracer.scenes.from_mesh -> tracer.checks.imagediff"])
def test_an_arrow_up_would_be_seen(edge):
    src, dst = edge.split(" -> ")
    floor = {m: i for i, (_, mods) in enumerate(rooms()) for m in mods}
    assert floor[dst] > floor[src]
