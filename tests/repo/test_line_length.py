"""No line of a .py file under smoothdist/ or tracer/ longer than 100 characters: the project's
width. The long lines were the residue of module moves (issue 33): module paths in docstrings
and comments grew when modules moved into tracer/rendering/, tracer/scenes/ and tracer/checks/,
and nothing caught it."""

from import_graph import modules

WIDTH = 100


def long_lines(paths):
    """``["path:line (n chars)"]`` of every line of ``paths`` over :data:`WIDTH` characters."""
    out = []
    for path in paths:
        with open(path, encoding="utf-8") as f:
            for i, line in enumerate(f, 1):
                n = len(line.rstrip("\r\n"))
                if n > WIDTH:
                    out.append(f"{path}:{i} ({n} chars)")
    return out


def test_no_line_over_the_width():
    found = long_lines(modules().values())
    assert not found, f"{len(found)} lines over {WIDTH} characters:\n" + "\n".join(found)


def test_the_scan_counts_characters(tmp_path):
    # characters, not bytes: a non-ASCII line of WIDTH characters is within the width
    path = tmp_path / "m.py"
    path.write_text("x" * WIDTH + "\n" + "∋" * WIDTH + "\n" + "y" * (WIDTH + 1) + "\n",
                    encoding="utf-8")
    assert long_lines([str(path)]) == [f"{path}:3 ({WIDTH + 1} chars)"]
