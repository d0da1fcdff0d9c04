"""Modules that moved keep their old import paths for one release, the same way in both
packages (``smoothdist/_moved.py``, ``tracer/_moved.py``; the policy is
``docs/guide/deprecation.md``).

* Each old path imports, warns ``DeprecationWarning`` once, at the importing line, naming the new
  place, and is the new module itself (``_private`` names included), for ``import old``,
  ``from old import name`` and ``from old import *``.
* The tables are the whole story: no file sits at an old path, every new path is a module, the
  two import hooks are the same code, and ``CHANGELOG.md`` lists every move.
* Nothing uses the old paths: no import in the packages, tests/, benchmarks/ or examples/ names
  them, and importing ``smoothdist`` and ``tracer`` and rendering in a fresh process with
  ``-W error::DeprecationWarning`` succeeds.
"""

import importlib
import inspect
import os
import re
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

import smoothdist._moved
import tracer._moved

ROOT = Path(__file__).resolve().parents[2]
MOVED = {**smoothdist._moved.MOVED, **tracer._moved.MOVED}


def _path(dotted):
    return ROOT.joinpath(*dotted.split("."))


def _fresh_import(old):
    """Import ``old`` as if for the first time in this process (the doctest collection and
    other tests may have imported it); returns the module and the deprecation warnings."""
    sys.modules.pop(old, None)
    parent, _, child = old.rpartition(".")
    importlib.import_module(parent).__dict__.pop(child, None)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        module = importlib.import_module(old)
    return module, [w for w in caught if issubclass(w.category, DeprecationWarning)]


def test_the_tables_are_the_old_paths():
    assert len(smoothdist._moved.MOVED) == 11 and len(tracer._moved.MOVED) == 18
    for old, new in MOVED.items():
        assert not _path(old).with_suffix(".py").exists(), f"a file at the old path {old}"
        assert not _path(old).is_dir(), old
        assert _path(new).with_suffix(".py").is_file(), f"{old} -> {new}: no such module"
        assert old.split(".")[0] == new.split(".")[0], (old, new)
    # tracer's hook is a copy of smoothdist's (tracer uses only smoothdist's public modules)
    for name in ("MovedModules", "install"):
        assert (inspect.getsource(getattr(smoothdist._moved, name))
                == inspect.getsource(getattr(tracer._moved, name))), name


def test_the_changelog_lists_every_move():
    text = (ROOT / "CHANGELOG.md").read_text(encoding="utf-8")
    missing = [f"{old} -> {new}" for old, new in MOVED.items()
               if f"`{old}`" not in text or f"`{new}`" not in text]
    assert not missing, missing


@pytest.mark.parametrize("old", sorted(MOVED))
def test_an_old_path_warns_once_and_is_the_new_module(old):
    new = importlib.import_module(MOVED[old])
    module, caught = _fresh_import(old)
    assert module is new
    assert len(caught) == 1, [str(w.message) for w in caught]
    message = str(caught[0].message)
    assert f"{old} is deprecated: it moved to {MOVED[old]};" in message, message
    # stacklevel: the warning points at the caller of the import (here importlib's
    # import_module), never at the packages' own files
    for pkg in ("smoothdist", "tracer"):
        assert not caught[0].filename.startswith(str(ROOT / pkg)), caught[0].filename
    assert new.__spec__.name == MOVED[old]              # the new module is left as it was
    parent, _, child = old.rpartition(".")
    assert getattr(importlib.import_module(parent), child) is new
    with pytest.raises(AttributeError, match=MOVED[old]):
        module.no_such_name
    # imported again: no second warning
    with warnings.catch_warnings(record=True) as again:
        warnings.simplefilter("always")
        importlib.import_module(old)
    assert not again


def test_the_import_forms_of_old_code():
    """``from old import name`` (a ``_private`` one too) and ``import *`` give the new
    objects; the warning names the importing file and line."""
    from smoothdist._kernels import bvh, query
    from tracer.rendering import camera

    for old in ("smoothdist.query", "smoothdist.bvh", "tracer.camera"):
        sys.modules.pop(old, None)
    ns = {}
    with pytest.warns(DeprecationWarning, match="smoothdist._kernels.query") as caught:
        exec(compile("\nfrom smoothdist.query import smooth_distance_point_tol, _attenuate",
                     "old_code.py", "exec"), ns)
    assert (caught[0].filename, caught[0].lineno) == ("old_code.py", 2)
    assert ns["smooth_distance_point_tol"] is query.smooth_distance_point_tol
    assert ns["_attenuate"] is query._attenuate
    with pytest.warns(DeprecationWarning, match="smoothdist._kernels.bvh"):
        exec("from smoothdist.bvh import *", ns)
    assert ns["build_tree"] is bvh.build_tree and ns["TreeData"] is bvh.TreeData
    with pytest.warns(DeprecationWarning, match="tracer.rendering.camera"):
        exec("from tracer.camera import primary_rays", ns)
    assert ns["primary_rays"] is camera.primary_rays


def test_no_code_names_an_old_path():
    """The packages, tests/, benchmarks/ and examples/ import the new paths (this file aside)."""
    olds = "|".join(re.escape(o) for o in MOVED)
    parts = "|".join(re.escape(o.rpartition(".")[0]) + r" import [\w, ()]*\b"
                     + re.escape(o.rpartition(".")[2]) + r"\b" for o in MOVED)
    pattern = re.compile(rf"^\s*(?:import|from) (?:{olds})\b|^\s*from (?:{parts})", re.M)
    found = []
    for folder in ("smoothdist", "tracer", "tests", "benchmarks", "examples"):
        for path in sorted((ROOT / folder).rglob("*.py")):
            if path.name == Path(__file__).name:
                continue
            for m in pattern.finditer(path.read_text(encoding="utf-8")):
                found.append(f"{path.relative_to(ROOT)}: {m.group(0).strip()}")
    assert not found, "\n".join(found)


def test_the_scan_finds_old_imports():
    olds = "|".join(re.escape(o) for o in MOVED)
    pattern = re.compile(rf"^\s*(?:import|from) (?:{olds})\b", re.M)
    assert pattern.search("from tracer.camera import primary_rays\n")
    assert pattern.search("    import smoothdist.query as q\n")
    assert not pattern.search("from tracer.rendering.camera import primary_rays\n")


@pytest.mark.slow
def test_importing_and_rendering_does_not_warn(tmp_path):
    """A fresh process with DeprecationWarnings as errors imports both packages, the public
    kernels and every tracer room, and renders a small scene."""
    code = (
        "import smoothdist, smoothdist.kernels, tracer, tracer.sim, tracer.studies\n"
        "import tracer.cli\n"
        "import sys\n"
        "rc = tracer.cli.main(['render', sys.argv[1], '--size', '16', '12', '-q', '-o', "
        "sys.argv[2]])\n"
        "assert rc == 0, rc\n"
        "assert not set(sys.modules) & %r, 'an old path was imported'\n" % (set(MOVED),))
    env = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg")
    proc = subprocess.run([sys.executable, "-W", "error::DeprecationWarning", "-c", code,
                           str(ROOT / "scenes" / "bunny_triangles.json"),
                           str(tmp_path / "x.png")],
                          env=env, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert (tmp_path / "x.png").is_file()
