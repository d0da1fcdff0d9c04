"""Every test that compares with stored values is reviewed against the tolerance policy.

``docs/guide/test-tolerances.md`` says what differs between x86-64 CPUs and thread counts and
what tolerance each kind of stored value gets, and its table lists the test files that compare
with stored values. A test file compares with stored values (:func:`stored_value_uses`) when it

* names a stored result under ``tests/data`` (an ``.npz``, or an authors' ``*_state.txt``),
* takes the ``image_regression`` fixture (the golden images in ``tests/baseline``), or
* types a number with 10 or more significant digits (a value written down from a run).

Such a file without a row in the page fails here, so a new stored-value test is reviewed
against the policy before it lands. A stale row, or a stored result that no reviewed test
reads, fails too.
"""

import ast
import io
import re
import tokenize
from pathlib import Path

TESTS = Path(__file__).resolve().parents[1]
ROOT = TESTS.parent
PAGE = ROOT / "docs" / "guide" / "test-tolerances.md"
#: significant digits from which a typed number counts as a stored value
LONG_LITERAL_DIGITS = 10


def stored_results():
    """The stored results in ``tests/data``: ``.npz`` arrays and the authors' state files."""
    data = TESTS / "data"
    return sorted(p for p in data.rglob("*")
                  if p.suffix == ".npz" or p.name.endswith("_state.txt"))


def _significant_digits(literal):
    mantissa = re.split(r"[eE]", literal)[0].replace("_", "")
    return len(mantissa.replace(".", "").lstrip("0").rstrip("0"))


def stored_value_uses(source, results=()):
    """Why ``source`` (a test module's text) compares with stored values: a list of reasons,
    empty when it does not. ``results``: the stored result files it might name."""
    reasons = [f"reads {p.name}" for p in results if p.name in source]
    tree = ast.parse(source)
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and any(
                a.arg == "image_regression" for a in node.args.args):
            reasons.append(f"{node.name} takes image_regression")
    for tok in tokenize.generate_tokens(io.StringIO(source).readline):
        if (tok.type == tokenize.NUMBER and "." in tok.string
                and _significant_digits(tok.string) >= LONG_LITERAL_DIGITS):
            reasons.append(f"line {tok.start[0]} types {tok.string}")
    return reasons


def reviewed_files():
    """The test files in the page's review table (rows starting with a test file's path)."""
    text = PAGE.read_text(encoding="utf-8")
    return set(re.findall(r"^\| `(tests/(?:\w+/)*test_\w+\.py)` \|", text, flags=re.M))


def test_the_detector_finds_each_kind_of_stored_value():
    results = [Path("x/whole_mesh_before_issue17.npz")]
    assert stored_value_uses('DATA = "data/whole_mesh_before_issue17.npz"\n', results)
    assert stored_value_uses("def test_a(image_regression):\n    pass\n")
    assert stored_value_uses("D = -0.13169159458450502\n")
    assert stored_value_uses("x = 53.130102354\n")                  # 11 digits
    # ordinary tolerances, round numbers and short constants are not stored values
    plain = ("import numpy as np\n"
             "def test_b(tmp_path, rng):\n"
             "    assert abs(1.25 - 0.5 * 2.5) <= 1e-12 and 0.21404114 > 0.2\n"
             "    np.load(tmp_path / 'depth.npy')\n")
    assert stored_value_uses(plain, results) == []


def test_every_test_with_stored_values_is_reviewed():
    results = stored_results()
    reviewed = reviewed_files()
    missing = {}
    for path in sorted(TESTS.rglob("test_*.py")):
        if path.name == Path(__file__).name:    # its examples above are examples
            continue
        reasons = stored_value_uses(path.read_text(encoding="utf-8"), results)
        name = path.relative_to(ROOT).as_posix()
        if reasons and name not in reviewed:
            missing[name] = reasons[:3]
    assert not missing, (
        f"tests comparing with stored values without a row in {PAGE.relative_to(ROOT)}: "
        f"{missing}; review their tolerances against the policy and add the rows")


def test_every_row_names_a_test_file():
    reviewed = reviewed_files()
    assert len(reviewed) >= 5
    stale = sorted(f for f in reviewed if not (ROOT / f).is_file())
    assert not stale, f"rows of {PAGE.name} naming no test file: {stale}"


def test_every_stored_result_is_read_by_a_reviewed_test():
    sources = "\n".join((ROOT / f).read_text(encoding="utf-8") for f in reviewed_files())
    results = stored_results()
    assert any(p.suffix == ".npz" for p in results)
    unread = [str(p.relative_to(TESTS)) for p in results if p.name not in sources]
    assert not unread, f"stored results that no reviewed test reads: {unread}"
