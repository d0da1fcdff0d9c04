"""The kernel modules moved into the private ``smoothdist._kernels``; their old paths
(``smoothdist.query``, ...) still import for one release (``smoothdist/_moved.py``).

* Each old path imports, warns ``DeprecationWarning`` once, at the importing line, naming the new
  place and ``smoothdist.kernels``, and hands out the new module's objects themselves (``_private``
  names included), for ``import old``, ``from old import name`` and ``from old import *``.
* Nothing uses the old paths: no import in smoothdist/ or tracer/ points at them (the import
  graph), none in tests/, benchmarks/ or examples/ names them, and importing ``smoothdist`` and
  ``tracer`` and rendering in a fresh process with ``-W error::DeprecationWarning`` succeeds.
"""

import importlib
import os
import re
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

import smoothdist
from import_graph import graph
from smoothdist._moved import MOVED

ROOT = Path(__file__).resolve().parents[2]


def _fresh_import(old):
    """Import ``old`` as if for the first time in this process (the doctest collection and
    the config policy test import every module); returns the module and the warnings."""
    sys.modules.pop(old, None)
    smoothdist.__dict__.pop(old.rpartition(".")[2], None)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        module = importlib.import_module(old)
    return module, [w for w in caught if issubclass(w.category, DeprecationWarning)]


def test_the_moved_list_is_the_shims():
    """Every name of :data:`MOVED` is a three-line shim at the old path and a module in
    ``smoothdist/_kernels/``, and no other module of smoothdist is a shim."""
    shims = sorted(p.stem for p in (ROOT / "smoothdist").glob("*.py")
                   if "forward(__name__" in p.read_text(encoding="utf-8"))
    assert shims == sorted(MOVED)
    for name in MOVED:
        assert (ROOT / "smoothdist" / "_kernels" / f"{name}.py").is_file(), name
        lines = (ROOT / "smoothdist" / f"{name}.py").read_text(encoding="utf-8").splitlines()
        assert len(lines) == 3 and f'"smoothdist._kernels.{name}"' in lines[2], lines


@pytest.mark.parametrize("name", MOVED)
def test_an_old_path_warns_once_and_forwards(name):
    old, new = f"smoothdist.{name}", importlib.import_module(f"smoothdist._kernels.{name}")
    module, caught = _fresh_import(old)
    assert len(caught) == 1, [str(w.message) for w in caught]
    message = str(caught[0].message)
    assert f"smoothdist._kernels.{name}" in message and "smoothdist.kernels" in message, message
    # stacklevel: the warning points at the caller of the import (importlib's import_module,
    # or an import hook such as pytest's assertion rewriter when one loads the module), not
    # at smoothdist/_moved.py or the shim
    import smoothdist

    assert not caught[0].filename.startswith(os.path.dirname(smoothdist.__file__)), \
        caught[0].filename
    names = [n for n in vars(new) if not n.startswith("__")]
    for n in names:  # every name, ``_private`` ones included, is the new module's object
        assert getattr(module, n) is getattr(new, n), n
    assert set(names) <= set(dir(module))
    with pytest.raises(AttributeError, match=f"smoothdist._kernels.{name}"):
        module.no_such_name
    # imported again: no second warning
    with warnings.catch_warnings(record=True) as again:
        warnings.simplefilter("always")
        importlib.import_module(old)
    assert not again


def test_the_import_forms_of_old_code():
    """``from smoothdist.query import name`` (a ``_private`` one too) and ``import *`` give
    the new objects; the warning names the importing file."""
    sys.modules.pop("smoothdist.query", None)
    sys.modules.pop("smoothdist.bvh", None)
    from smoothdist._kernels import bvh, query

    ns = {}
    with pytest.warns(DeprecationWarning, match="smoothdist._kernels.query") as caught:
        exec("from smoothdist.query import smooth_distance_point_tol, _attenuate", ns)
    # the importing code's frame ("<string>"; pytest's assertion rewriter where it loads the
    # package's modules, as for an installed plugin's distribution), never smoothdist's own
    assert not caught[0].filename.startswith(str(Path(sys.modules["smoothdist"].__file__).parent))
    assert ns["smooth_distance_point_tol"] is query.smooth_distance_point_tol
    assert ns["_attenuate"] is query._attenuate
    with pytest.warns(DeprecationWarning, match="smoothdist._kernels.bvh"):
        exec("from smoothdist.bvh import *", ns)
    assert ns["build_tree"] is bvh.build_tree and ns["TreeData"] is bvh.TreeData
    assert "forward" not in ns and "_sort_by_key" not in ns   # star: public names only


def test_the_packages_never_import_an_old_path():
    old = {f"smoothdist.{name}" for name in MOVED}
    users = sorted(f"{m} -> {t}" for m, targets in graph().items() for t in targets & old)
    assert not users, users


def test_no_script_names_an_old_path():
    """tests/, benchmarks/ and examples/ use the new paths (this file and the shims aside)."""
    pattern = re.compile(r"smoothdist[./](%s)\b|from smoothdist import [\w, ]*\b(%s)\b"
                         % ("|".join(MOVED), "|".join(MOVED)))
    found = []
    for folder in ("tests", "benchmarks", "examples"):
        for path in sorted((ROOT / folder).rglob("*.py")):
            if path.name == Path(__file__).name:
                continue
            for i, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
                if pattern.search(line):
                    found.append(f"{path.relative_to(ROOT)}:{i}: {line.strip()}")
    assert not found, "\n".join(found)


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
        "assert not [m for m in sys.modules if m.startswith('smoothdist.') and\n"
        "            m.split('.')[1] in %r], 'an old path was imported'\n" % (MOVED,))
    env = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg")
    proc = subprocess.run([sys.executable, "-W", "error::DeprecationWarning", "-c", code,
                           str(ROOT / "scenes" / "bunny_triangles.json"),
                           str(tmp_path / "x.png")],
                          env=env, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert (tmp_path / "x.png").is_file()
