"""The order in which ``.ci/run`` hands the test files to its workers: the longest files
first (``tests/conftest.py``, ``LONG_FILES``), then the rest in their collection order."""

from pathlib import Path
from types import SimpleNamespace

import conftest

ROOT = Path(__file__).resolve().parents[2]


def test_every_long_file_is_a_test_file():
    # a renamed or removed file would silently drop out of the order
    for name in conftest.LONG_FILES:
        assert (ROOT / "tests" / name).is_file(), name
    assert len(set(conftest.LONG_FILES)) == len(conftest.LONG_FILES)


def test_long_files_go_first_and_the_rest_keep_their_order():
    ids = ["tests/a/test_x.py::t1", "tests/repo/test_docs.py::d1", "tests/a/test_x.py::t2",
           "tests/repo/test_readme.py::r1", "tests/b/test_y.py::y1",
           "tests/repo/test_docs.py::d2", "tests/repo/test_readme.py::r2"]
    items = [SimpleNamespace(nodeid=i) for i in ids]
    conftest.pytest_collection_modifyitems(None, items)
    assert [i.nodeid for i in items] == [
        "tests/repo/test_readme.py::r1", "tests/repo/test_readme.py::r2",
        "tests/repo/test_docs.py::d1", "tests/repo/test_docs.py::d2",
        "tests/a/test_x.py::t1", "tests/a/test_x.py::t2", "tests/b/test_y.py::y1"]


def test_ci_keeps_the_collection_order():
    # xdist's default would reorder the files by their number of tests
    text = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    assert "--dist loadfile --no-loadscope-reorder" in text
