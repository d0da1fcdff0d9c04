"""The ripple figures of docs/guide/troubleshooting.md come from the results files in
renders/ripple/ (``benchmarks/bench_ripple.py``): each range the page quotes is recomputed
here from the CSVs (95th percentiles in degrees, one decimal as printed; time ratios two
decimals) and must appear in the paragraph, so the page cannot lag a rerun."""

import csv
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
RIPPLE = ROOT / "renders" / "ripple"
PAGE = ROOT / "docs" / "guide" / "troubleshooting.md"

#: the groups the paragraph names, by case
SMOOTH = ("ico2", "ico3", "uv_sphere", "pv_sphere", "capsule", "torus", "superellipsoid")
CURVES = ("circle64", "helix")
BOXES = ("box", "pv_box")
WIRES = ("ico1_wire", "cube_wire")


def rows(name):
    with open(RIPPLE / f"{name}.csv", newline="", encoding="utf-8") as fh:
        return list(csv.DictReader(fh))


def p95_range(rs, cases, setting):
    v = [float(r["smooth_p95"]) for r in rs if r["case"] in cases and r["setting"] == setting]
    assert len(v) == len(cases), (cases, setting)
    return f"{min(v):.1f}-{max(v):.1f}"


@pytest.fixture(scope="module")
def paragraph():
    text = PAGE.read_text(encoding="utf-8")
    start = text.index("<!-- ripple figures")
    return " ".join(text[start:text.index("- *When to change them.*")].split())


def test_the_quoted_ripple_figures_are_the_files(paragraph):
    auto = rows("auto")
    want = [p95_range(auto, SMOOTH, "today"), p95_range(auto, CURVES, "today"),
            p95_range(auto, BOXES, "today"), p95_range(auto, SMOOTH, "default"),
            p95_range(auto, CURVES, "default"), p95_range(auto, BOXES, "default")]
    facets, wire = rows("sharpness_facets"), rows("sharpness_wire")
    want += [p95_range(facets, ("box",), "sharp6").split("-")[0],
             p95_range(wire, WIRES, "sharp6"), p95_range(wire, WIRES, "default")]
    missing = [w for w in want if w not in paragraph]
    assert not missing, missing
    default = [r for r in auto if r["setting"] == "default"]
    assert all(r["meets_target"] == "True" for r in default)
    assert f"all {len(default)} shapes" in paragraph


def test_the_quoted_time_ratios_are_the_files(paragraph):
    rs = rows("auto_512")
    t = {(r["case"], r["setting"]): float(r["smooth_s"]) for r in rs}
    ratio = [t[c, "default"] / t[c, "today"] for c, s in t if s == "default"]
    assert f"{min(ratio):.2f}-{max(ratio):.2f} times" in paragraph
