"""The documentation site builds with warnings as errors, and the build catches what it should.

* :func:`test_docs_build`: ``python -m sphinx -W --keep-going docs OUT`` (the README's docs
  command) succeeds from this checkout: every page, every API docstring (``nitpicky``: a
  reference that resolves nowhere is an error), every gallery example (run; its figure becomes
  its picture) and the notebook (executed). Then the output is checked: a gallery page with an
  image per ``examples/plot_*.py``, the API pages, the notebook's embedded image and animation.
* The two guards the build relies on, each in a tiny throwaway project that uses our
  ``docs/conf.py``: a docstring with a broken cross-reference fails the build, and so does a
  gallery example that raises.
"""

import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"

pytest.importorskip("sphinx")
pytest.importorskip("sphinx_gallery")
pytest.importorskip("myst_nb")
pytest.importorskip("numpydoc")
pytest.importorskip("pydata_sphinx_theme")


def sphinx(src, out, *extra, cwd=ROOT):
    env = dict(os.environ, MPLBACKEND="Agg", PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-E", "-q",
                           "-d", str(out / ".doctrees"), *extra, str(src), str(out / "html")],
                          cwd=cwd, env=env, capture_output=True, text=True, timeout=900)


@pytest.mark.slow
def test_docs_build(tmp_path):
    proc = sphinx(DOCS, tmp_path)
    assert proc.returncode == 0, f"docs build failed:\n{proc.stdout[-3000:]}\n{proc.stderr[-6000:]}"
    html = tmp_path / "html"
    # the gallery: one page per example, each with its figure
    examples = sorted(p.stem for p in (ROOT / "examples").glob("plot_*.py"))
    assert len(examples) >= 6
    index = (html / "auto_examples" / "index.html").read_text(encoding="utf-8")
    for name in examples:
        page = (html / "auto_examples" / f"{name}.html").read_text(encoding="utf-8")
        assert f"sphx_glr_{name}_001.png" in page, f"{name}: no figure on its gallery page"
        assert (html / "_images" / f"sphx_glr_{name}_001.png").stat().st_size > 5000
        assert f"{name}.html" in index
    # the API reference: the public functions, with their numpydoc sections
    page = (html / "api" / "generated" / "smoothdist.smooth_distance.html").read_text("utf-8")
    assert "Parameters" in page and "alpha" in page
    for name in ("tracer.render_mesh", "tracer.RenderResult", "smoothdist.MeshDistance",
                 "tracer.show_animation"):
        assert (html / "api" / "generated" / f"{name}.html").is_file(), name
    # the guides and the generated scene-format reference are pages of the site
    for page in ("getting-started", "scene-format", "guide/image-regression",
                 "guide/performance", "guide/troubleshooting"):
        assert (html / f"{page}.html").is_file(), page
    # the notebook ran: the render shows as a PNG, the animation as an embedded GIF
    nb = (html / "notebooks" / "render-in-a-notebook.html").read_text(encoding="utf-8")
    assert re.search(r'<img[^>]+src="\.\./_images/[0-9a-f]+\.png"', nb), "no render image"
    assert "data:image/gif;base64," in nb, "no inline animation"


def _project(tmp_path, module_doc, example=None):
    """A throwaway Sphinx project with our conf.py, one autodoc'ed function and (optionally)
    one gallery example."""
    src, ex = tmp_path / "src", tmp_path / "ex"
    src.mkdir(parents=True)
    ex.mkdir()
    (ex / "GALLERY_HEADER.rst").write_text("Examples\n========\n")
    if example is not None:
        (ex / "plot_one.py").write_text(example)
    (tmp_path / "probe_mod.py").write_text(
        f'def probe():\n    """{module_doc}"""\n')
    (src / "conf.py").write_text(textwrap.dedent(f"""\
        import sys
        sys.path.insert(0, {str(tmp_path)!r})
        __file__ = {str(DOCS / 'conf.py')!r}
        exec(open(__file__).read())
        sphinx_gallery_conf = dict(sphinx_gallery_conf, examples_dirs={str(ex)!r},
                                   gallery_dirs="auto_examples")
        nb_execution_mode = "off"
        """))
    (src / "index.rst").write_text("Probe\n=====\n\n.. toctree::\n\n   auto_examples/index\n\n"
                                   ".. autofunction:: probe_mod.probe\n")
    return src


def test_a_broken_docstring_reference_fails_the_build(tmp_path):
    ok = _project(tmp_path / "ok", "Like :func:`probe_mod.probe`.\n\n    Returns\n"
                                   "    -------\n    None\n    ")
    proc = sphinx(ok, tmp_path / "ok", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr[-3000:]
    bad = _project(tmp_path / "bad", "Like :func:`smoothdist.no_such_function`.")
    proc = sphinx(bad, tmp_path / "bad", cwd=tmp_path)
    assert proc.returncode != 0
    assert "no_such_function" in proc.stderr


def test_a_failing_gallery_example_fails_the_build(tmp_path):
    src = _project(tmp_path, "A probe.",
                   example='"""\nFails\n=====\n\nRaises.\n"""\n\nraise RuntimeError("boom")\n')
    proc = sphinx(src, tmp_path, cwd=tmp_path)
    assert proc.returncode != 0
    assert "boom" in proc.stdout + proc.stderr
    (tmp_path / "ex" / "plot_one.py").write_text('"""\nWorks\n=====\n\nPrints.\n"""\n\nprint(1)\n')
    proc = sphinx(src, tmp_path, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr[-3000:]


# --------------------------------------------------------------------------- the public API
API_PAGES = [DOCS / "api" / "smoothdist.rst", DOCS / "api" / "tracer.rst"]


def _documented():
    """``module.name`` of every entry of the API pages' autosummary tables."""
    entries = []
    for page in API_PAGES:
        current = None
        for line in page.read_text(encoding="utf-8").splitlines():
            m = re.match(r"\.\. currentmodule:: (\S+)", line)
            if m:
                current = m.group(1)
            m = re.match(r" {3}([A-Za-z_][\w.]*)$", line)
            if m and current:
                entries.append(f"{current}.{m.group(1)}")
    return entries


def _split(dotted):
    """(module, name) for a documented ``pkg.mod.name``: the longest importable prefix."""
    import importlib

    parts = dotted.split(".")
    for i in range(len(parts) - 1, 0, -1):
        try:
            return importlib.import_module(".".join(parts[:i])), parts[i:]
        except ImportError:
            continue
    raise AssertionError(f"{dotted}: no importable module")


def test_the_documented_api_is_the_exported_api():
    """Every name on the API pages is exported (``__all__``) where it is documented, and every
    name the packages export is on the API pages."""
    import smoothdist
    import tracer
    import tracer.sim

    documented = _documented()
    assert len(documented) > 20
    for dotted in documented:
        module, attrs = _split(dotted)
        assert len(attrs) == 1, f"{dotted}: document a module's name, not an attribute's"
        assert hasattr(module, attrs[0]), f"{dotted} does not exist"
        assert attrs[0] in getattr(module, "__all__", ()), (
            f"{dotted} is documented but not in {module.__name__}.__all__")
    for pkg in (smoothdist, tracer, tracer.sim):
        for name in pkg.__all__:
            if name.startswith("__"):
                continue
            assert f"{pkg.__name__}.{name}" in documented, (
                f"{pkg.__name__}.{name} is exported but not on the API pages")
