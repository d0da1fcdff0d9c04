"""Code policy: numba compilation flags live in ``smoothdist/_config.py`` only.

* No file in ``smoothdist/`` or ``tracer/`` other than ``smoothdist/_config.py`` may pass
  ``fastmath=``, ``parallel=`` or ``error_model=`` (fastmath would break LogSumExp's reliance
  on IEEE ``inf`` and underflow; parallelism is switched centrally by ``SMOOTHDIST_PARALLEL``;
  every kernel divides under the same error model).
* Every numba decoration or call (``numba.njit``, ``njit``, ``numba.jit``, ...) takes its
  options from ``**NJIT``, ``**NJIT_PARALLEL`` or ``**NJIT_INLINE`` (``NJIT`` plus
  ``forceinline``) and nothing else, so that every kernel is cached (``cache=True``) and
  compiled with the same flags; ``**NJIT_GENERIC`` (``NJIT_INLINE`` without the cache) is for
  the generic traversal functions, which are inlined into cached kernels.
"""

import ast
import io
import tokenize
from pathlib import Path

import pytest

from smoothdist import _config

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("smoothdist", "tracer")
CONFIG = ROOT / "smoothdist" / "_config.py"
FORBIDDEN = ("fastmath", "parallel", "error_model")
NUMBA_DECORATORS = {"njit", "jit", "generated_jit", "vectorize", "guvectorize", "cfunc",
                    "stencil", "jit_module"}
#: NJIT_GENERIC: NJIT_INLINE without the cache, for the generic traversal loop (see _config)
ALLOWED_OPTIONS = {"NJIT", "NJIT_PARALLEL", "NJIT_INLINE", "NJIT_GENERIC", "NJIT_IR_INLINE"}


def sources():
    files = sorted(p for pkg in PACKAGES for p in (ROOT / pkg).rglob("*.py"))
    assert files, "no sources found"
    return files


def keyword_uses(text):
    """``(line, name)`` of every ``fastmath=`` / ``parallel=`` keyword argument or dict key in
    the code (comments and strings are skipped: the file is tokenised, not searched as text)."""
    hits = []
    toks = [t for t in tokenize.generate_tokens(io.StringIO(text).readline)
            if t.type not in (tokenize.COMMENT, tokenize.NL, tokenize.NEWLINE,
                              tokenize.INDENT, tokenize.DEDENT)]
    for i, t in enumerate(toks[:-1]):
        nxt = toks[i + 1]
        if t.type == tokenize.NAME and t.string in FORBIDDEN and nxt.string == "=":
            hits.append((t.start[0], t.string))
        if (t.type == tokenize.STRING and t.string.strip("'\"") in FORBIDDEN
                and nxt.string == ":"):
            hits.append((t.start[0], t.string))
    return hits


def test_config_is_the_cached_policy():
    assert _config.NJIT["cache"] is True and _config.NJIT_PARALLEL["cache"] is True
    assert _config.NJIT["fastmath"] is False and _config.NJIT_PARALLEL["fastmath"] is False
    # numpy's error model: no zero test and exception exit on every division in hot loops
    assert _config.NJIT["error_model"] == "numpy" == _config.NJIT_PARALLEL["error_model"]
    assert "parallel" not in _config.NJIT
    assert _config.NJIT_INLINE == dict(_config.NJIT, forceinline=True)
    assert keyword_uses(CONFIG.read_text()), "the scanner must see _config.py's own flags"


@pytest.mark.parametrize("path", sources(), ids=lambda p: str(p.relative_to(ROOT)))
def test_no_hard_coded_fastmath_or_parallel(path):
    if path == CONFIG:
        return
    hits = keyword_uses(path.read_text(encoding="utf-8"))
    assert not hits, (f"{path.relative_to(ROOT)} hard-codes "
                      + ", ".join(f"{n}= (line {ln})" for ln, n in hits)
                      + "; use **NJIT / **NJIT_PARALLEL from smoothdist._config")


def _numba_name(node):
    """``"njit"`` for ``numba.njit`` / ``njit`` / ``nb.njit`` ..., else None. ``cuda.jit`` is
    not a CPU kernel: numba-cuda compiles it for the device with options of its own (the
    CPU's ``NJIT`` options do not apply there), so it is not checked here."""
    if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) \
            and node.value.id == "cuda":
        return None
    if isinstance(node, ast.Attribute) and node.attr in NUMBA_DECORATORS:
        return node.attr
    if isinstance(node, ast.Name) and node.id in NUMBA_DECORATORS:
        return node.id
    return None


def _option_name(node):
    if isinstance(node, ast.Name):
        return node.id
    if isinstance(node, ast.Attribute):
        return node.attr
    return None


def numba_uses(tree):
    """``(line, problem)`` for every numba decorator / call not configured by **NJIT*."""
    problems = []
    seen_calls = set()
    for node in ast.walk(tree):
        decorators = getattr(node, "decorator_list", [])
        for dec in decorators:
            if _numba_name(dec):  # bare @numba.njit: no options at all, so no cache
                problems.append((dec.lineno, f"bare @{_numba_name(dec)} (no **NJIT)"))
        if isinstance(node, ast.Call) and _numba_name(node.func):
            seen_calls.add(id(node))
            name = _numba_name(node.func)
            stars = [k for k in node.keywords if k.arg is None]
            named = [k.arg for k in node.keywords if k.arg is not None]
            if len(stars) != 1 or _option_name(stars[0].value) not in ALLOWED_OPTIONS:
                problems.append((node.lineno, f"{name}(...) without exactly one **NJIT or "
                                              "**NJIT_PARALLEL"))
            if named:
                problems.append((node.lineno, f"{name}(...) with explicit options {named}"))
    return problems


@pytest.mark.parametrize("path", sources(), ids=lambda p: str(p.relative_to(ROOT)))
def test_every_kernel_uses_the_shared_options(path):
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    problems = numba_uses(tree)
    assert not problems, f"{path.relative_to(ROOT)}: " + "; ".join(
        f"line {ln}: {msg}" for ln, msg in problems)


def test_the_checks_catch_violations():
    bad = "import numba\n@numba.njit(cache=True, fastmath=True)\ndef f(x):\n    return x\n"
    assert keyword_uses(bad) == [(2, "fastmath")]
    assert numba_uses(ast.parse(bad))
    assert numba_uses(ast.parse("import numba\n@numba.njit\ndef f(x):\n    return x\n"))
    assert numba_uses(ast.parse("from numba import njit\ng = njit(lambda x: x)\n"))
    assert keyword_uses("OPTS = {'parallel': True}\n") == [(1, "'parallel'")]
    good = ("import numba\nfrom smoothdist._config import NJIT\n@numba.njit(**NJIT)\n"
            "def f(x):\n    return x  # parallel=True in a comment is fine\n")
    assert not keyword_uses(good) and not numba_uses(ast.parse(good))
    assert not numba_uses(ast.parse("import numba as nb\nfrom m import q\n"
                                    "@nb.njit(**q.NJIT_PARALLEL)\ndef f():\n    pass\n"))
    # a numba.prange loop or a "parallel" variable in a comparison is not an option
    assert not keyword_uses("if parallel == 1:\n    pass\n")


@pytest.mark.parametrize("package", ["smoothdist", "tracer", "tracer.rendering", "tracer.scenes",
                                     "tracer.checks", "tracer.sim", "tracer.studies"])
def test_no_public_name_shadows_a_submodule(package):
    """``tracer.mesh_scene`` was a function until its module was imported, then the module
    (issue 22); ``smoothdist.mesh_distance`` likewise. A name a package exports (``__all__``,
    lazily or not) must not also be one of its submodules, and stays the same object after
    every submodule is imported."""
    import importlib
    import pkgutil
    import warnings

    pkg = importlib.import_module(package)
    submodules = {m.name for m in pkgutil.iter_modules(pkg.__path__)}
    exported = set(getattr(pkg, "__all__", ()))
    assert not exported & submodules, sorted(exported & submodules)
    before = {name: getattr(pkg, name) for name in exported}
    with warnings.catch_warnings():  # smoothdist's moved kernel modules warn at their old paths
        warnings.simplefilter("ignore", DeprecationWarning)
        for name in submodules - {"__main__"}:
            importlib.import_module(f"{package}.{name}")
    for name, obj in before.items():
        assert getattr(pkg, name) is obj, name
        assert not isinstance(obj, type(pkg)), name
