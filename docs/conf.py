"""Sphinx configuration of the smoothdist + tracer documentation.

Build (from the repository root, with the ``docs`` extra installed)::

    python -m sphinx -W --keep-going docs docs/_build/html

``-W`` turns every warning into an error: a broken cross-reference in a docstring or page
(``nitpicky``), a docstring numpydoc cannot parse, or a gallery example that raises fails the
build (``tests/repo/test_docs.py`` runs it in the suite).
"""

import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
os.environ.setdefault("MPLBACKEND", "Agg")

import smoothdist  # noqa: E402

project = "smoothdist + tracer"
author = "the smoothdist developers"
copyright = "2026, the smoothdist developers"
version = release = smoothdist.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "numpydoc",
    "sphinx_gallery.gen_gallery",
    "myst_nb",                       # Markdown pages (MyST) and executed notebooks
]

source_suffix = {".rst": "restructuredtext", ".md": "myst-nb", ".ipynb": "myst-nb"}
exclude_patterns = ["_build", "**.ipynb_checkpoints", "auto_examples/*.ipynb",
                    "auto_examples/*.py", "auto_examples/*.zip", "auto_examples/*.json",
                    "auto_examples/*.md5", "auto_examples/*.codeobj.json"]
root_doc = "index"

# ---------------------------------------------------------------------------- references
nitpicky = True                      # a reference that resolves nowhere is a warning (an error)
# types of other packages (no intersphinx: the build runs offline) and numpydoc's shape words
nitpick_ignore_regex = [
    (r"py:class", r"(numpy|np|numba|trimesh|pyvista|pv|PIL|dask|distributed|matplotlib|scipy)\..*"),
    (r"py:class", r"(optional|array_like|array-like|callable|path-like|file-like)"),
    (r"py:class", r"(pathlib\.)?Path|os\.PathLike|typing\..*|collections\..*"),
]

# ---------------------------------------------------------------------------- API reference
autosummary_generate = True
# The stubs are written anew on every build: a stub left from an earlier build names a module
# that may have moved since (tracer's modules moved into rooms), and Sphinx reads every stub.
import shutil  # noqa: E402

shutil.rmtree(Path(__file__).resolve().parent / "api" / "generated", ignore_errors=True)
templates_path = ["_templates"]
autosummary_imported_members = False
autodoc_default_options = {"members": True, "inherited-members": False}
autodoc_typehints = "none"
autodoc_member_order = "bysource"
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False
numpydoc_validation_checks = set()

# ---------------------------------------------------------------------------- Markdown, notebooks
myst_enable_extensions = ["colon_fence", "dollarmath", "deflist"]
myst_heading_anchors = 3
nb_execution_mode = "force"          # the notebooks run at every build
nb_execution_raise_on_error = True   # a failing cell fails the build
nb_execution_timeout = 600
nb_execution_excludepatterns = ["auto_examples/*"]

# ---------------------------------------------------------------------------- gallery
sphinx_gallery_conf = {
    "examples_dirs": str(ROOT / "examples"),
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"/plot_",   # every plot_*.py runs; its figures become the thumbnails
    "ignore_pattern": r"(__init__|mesh_distance_demo|make_gallery)\.py",
    "abort_on_example_error": True,
    "image_scrapers": ("matplotlib",),
    "download_all_examples": False,
    "remove_config_comments": True,
    "show_memory": False,
    "min_reported_time": 2,
    "thumbnail_size": (320, 240),
}

# ---------------------------------------------------------------------------- HTML
html_theme = "pydata_sphinx_theme"
html_title = "smoothdist + tracer"
html_static_path = []
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "secondary_sidebar_items": ["page-toc"],
    "footer_start": ["copyright"],
    "footer_end": [],
}
html_show_sourcelink = False


def _skip_member(app, what, name, obj, skip, options):
    """Leave out NamedTuple field accessors ("Alias for field number N"): the class docstring
    lists the fields."""
    doc = getattr(obj, "__doc__", None) or ""
    if doc.startswith("Alias for field number"):
        return True
    return None


def _numpydoc_template_once():
    """numpydoc (1.11) makes a Jinja environment and compiles its docstring template anew for
    every docstring and signature it formats: 3,168 compiles, 9 s of a 60 s profiled build on
    our 2-core machine. Replace the module-level ``get_doc_object`` that its ``setup``
    installs with one that compiles the template once per builder and hands numpydoc the same
    template every time. Left as it is where numpydoc's names differ."""
    from numpydoc import docscrape_sphinx as ds
    from numpydoc import numpydoc as nd

    names = ("get_doc_object", "get_doc_object_orig", "SphinxClassDoc", "SphinxFunctionDoc",
             "SphinxObjDoc")
    if not all(hasattr(ds, n) for n in names) or not hasattr(nd, "get_doc_object"):
        return
    templates = {}

    def get_doc_object(obj, what=None, doc=None, config=None, builder=None):
        config = {} if config is None else config
        key = id(builder)
        if key not in templates:
            probe = {}      # numpydoc's own function puts the compiled template here
            ds.get_doc_object(_skip_member, config=probe, builder=builder)
            templates[key] = probe["template"]
        config["template"] = templates[key]
        return ds.get_doc_object_orig(obj, what=what, doc=doc, config=config,
                                      class_doc=ds.SphinxClassDoc,
                                      func_doc=ds.SphinxFunctionDoc, obj_doc=ds.SphinxObjDoc)

    nd.get_doc_object = get_doc_object


def setup(app):
    app.connect("autodoc-skip-member", _skip_member)
    _numpydoc_template_once()
