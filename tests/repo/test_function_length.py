"""No function in smoothdist/ or tracer/ longer than 120 lines (docstring included), except
the listed ones, which may not grow."""

import ast

from import_graph import modules

LIMIT = 120
#: "module:function" -> its length, for a function allowed to stay long (none today)
ALLOWED = {}


def long_functions():
    """``{"module:function": lines}`` of every function over :data:`LIMIT` lines."""
    out = {}
    for name, path in modules().items():
        tree = ast.parse(open(path, encoding="utf-8").read(), path)
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                n = node.end_lineno - node.lineno + 1
                if n > LIMIT:
                    out[f"{name}:{node.name}"] = n
    return out


def test_no_new_long_function_and_none_grows():
    found = long_functions()
    new = {k: n for k, n in found.items() if k not in ALLOWED}
    grown = {k: n for k, n in found.items() if k in ALLOWED and n > ALLOWED[k]}
    assert not new, f"functions over {LIMIT} lines: {new}"
    assert not grown, f"listed long functions grew: {grown}"


def test_the_scan_measures_lines(tmp_path, monkeypatch):
    body = "\n".join(f"    x{i} = {i}" for i in range(LIMIT))
    path = tmp_path / "m.py"
    path.write_text(f"def f():\n{body}\n")
    monkeypatch.setattr("test_function_length.modules", lambda: {"m": str(path)})
    assert long_functions() == {"m:f": LIMIT + 1}
