"""Imports sit at the top of each module of smoothdist and tracer. An import inside a function
is allowed only where a dependency is loaded on use (an optional extra, numba or numpy kept out
of the command line's start), and it says so: a comment naming the dependency and the reason,
on its line or on the comment lines just above it (``# pyvista (studies extra): loaded on
use``).

Modules that other changes are editing still hold imports inside functions without a reason;
:data:`PENDING` counts them, and may only shrink.
"""

import ast
from pathlib import Path

from import_graph import ROOT, modules

#: unexplained imports inside functions, per module, left to the changes editing them
PENDING = {}
REASON_WORDS = ("loaded on use", "absent in some versions")


def deferred_imports(source):
    """``[(line, has_reason)]`` of the imports inside functions of ``source``."""
    lines = source.splitlines()
    out = {}
    for func in ast.walk(ast.parse(source)):
        if isinstance(func, (ast.FunctionDef, ast.AsyncFunctionDef)):
            for node in ast.walk(func):
                if isinstance(node, (ast.Import, ast.ImportFrom)):
                    out[node.lineno] = _has_reason(lines, node.lineno)
    return sorted(out.items())


def _has_reason(lines, lineno):
    """A reason on the import's line, on the comment lines above it, or on the line above a
    run of imports of the same block (one comment for ``import matplotlib`` and its parts)."""
    i = lineno - 1
    if any(w in lines[i] for w in REASON_WORDS):
        return True
    i -= 1
    while i >= 0 and lines[i].strip().startswith(("#", "import ", "from ", "matplotlib.use")):
        if any(w in lines[i] for w in REASON_WORDS):
            return True
        i -= 1
    return False


def test_every_import_inside_a_function_says_why():
    unexplained = {}
    for path in modules().values():
        rel = Path(path).relative_to(ROOT).as_posix()
        bad = [ln for ln, ok in deferred_imports(Path(path).read_text(encoding="utf-8"))
               if not ok]
        if len(bad) > PENDING.get(rel, 0):
            unexplained[rel] = bad
    assert not unexplained, ("imports inside functions without a reason (move them to the "
                             f"top, or say which dependency loads on use): {unexplained}")


def test_pending_counts_only_shrink():
    """A pending module that got better lowers its count here (the ratchet)."""
    for rel, allowed in PENDING.items():
        source = (Path(ROOT) / rel).read_text(encoding="utf-8")
        bad = sum(not ok for _, ok in deferred_imports(source))
        assert bad == allowed, f"{rel}: {bad} unexplained, PENDING says {allowed}: update it"


def test_the_scan_reads_reasons():
    source = ("import os\n"
              "def f():\n"
              "    import json\n"
              "    from PIL import Image  # Pillow (tracer extra): loaded on use\n"
              "    # matplotlib (studies extra): loaded on use\n"
              "    import matplotlib\n"
              "    from matplotlib.figure import Figure\n"
              "    x = 1\n"
              "    import numpy as np\n")
    assert deferred_imports(source) == [(3, False), (4, True), (6, True), (7, True), (9, False)]
