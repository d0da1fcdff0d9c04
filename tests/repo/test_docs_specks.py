"""The speck figures that docs/guide/troubleshooting.md quotes are the ones in the results files.

``benchmarks/bench_specks.py`` writes ``renders/ripple/specks.csv`` (and ``specks_before.csv``
was the same script on the lighting code before the shadow-ray fix). The guide quotes the
before / after counts of the issue's two random clouds and the lit scan bunny; this test reads
both CSVs and fails when the guide and the files disagree, so a rerun that changes a count
cannot leave the page behind. Counts are integers: compared exactly.
"""

import csv
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
GUIDE = ROOT / "docs" / "guide" / "troubleshooting.md"


def _counts(name):
    with open(ROOT / "renders" / "ripple" / name, encoding="utf-8") as fh:
        rows = csv.DictReader(line for line in fh if not line.startswith("#"))
        return {r["case"]: r for r in rows}


def _paragraph():
    text = GUIDE.read_text(encoding="utf-8")
    start = text.index("*Dark specks or scratches")
    return " ".join(text[start:text.index("\n- *", start)].split())


def test_cloud_and_bunny_counts_match_the_results_files():
    before, now = _counts("specks_before.csv"), _counts("specks.csv")
    para = _paragraph()
    m = re.search(r"at 512², (\d+) and (\d+) pixels .*? before, (\d+) now; on the lit scan "
                  r"bunny at 256², (\d+) before, (\d+) now", para)
    assert m, "the guide's speck sentence changed shape: update this test with it"
    quoted = [int(g) for g in m.groups()]
    files = [int(before["normal3000"]["specks"]), int(before["cube2000"]["specks"]),
             max(int(now["normal3000"]["specks"]), int(now["cube2000"]["specks"])),
             int(before["bunny_points"]["specks"]), int(now["bunny_points"]["specks"])]
    assert quoted == files


def test_the_guide_reads_the_gallery_columns_as_the_file_has_them():
    """The guide says what remains on the shipped scenes is mostly there without the light's
    rays (``unlit``); check that it is so in the file, scene by scene."""
    now = _counts("specks.csv")
    assert {"specks", "unlit", "added_by_light"} <= set(next(iter(now.values())))
    for case in ("octopus_lit", "trefoil", "mixed"):
        row = now[case]
        assert int(row["unlit"]) >= int(row["added_by_light"]), case
    for case in ("normal3000", "cube2000", "bunny_points", "bunny_triangles"):
        assert int(now[case]["specks"]) == 0, case
