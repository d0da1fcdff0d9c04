"""The numba cache guard (``smoothdist._cache_guard``), checked as behaviour.

* The hazard it exists for, reproduced on a throwaway package: ``b.kernel`` (``cache=True``)
  calls ``a.constant`` (``cache=True``); after an edit of ``a.py`` alone a new process still gets
  the old constant from ``b``'s cached kernel. With the guard it gets the new one, and with
  unchanged sources the guard keeps the cache (the second start loads ``b.kernel`` from it).
* The cache directories the guard predicts are the ones numba writes to, in ``__pycache__``
  and under ``NUMBA_CACHE_DIR``; it clears those and nothing else.
* Missing, unwritable or concurrently cleared directories never raise;
  ``SMOOTHDIST_CACHE_GUARD=0`` switches the import-time check off.
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import numba.core.config
import pytest

from smoothdist import _cache_guard as cache_guard

ROOT = Path(__file__).resolve().parents[2]
GUARD = ROOT / "smoothdist" / "_cache_guard.py"

A_PY = "from numba import njit\n\n\n@njit(cache=True)\ndef constant():\n    return {value}\n"
B_PY = ("from numba import njit\n\nfrom toy.a import constant\n\n\n"
        "@njit(cache=True)\ndef kernel():\n    return constant() + 100\n")

# run in a fresh process: optionally the guard (loaded from its file, so that the real
# packages' import-time guard does not run), then toy.b.kernel; prints value and cache hits
RUN = r"""
import importlib.util, json, sys
parent, guard_path, use_guard = sys.argv[1], sys.argv[2], sys.argv[3] == "1"
if use_guard:
    spec = importlib.util.spec_from_file_location("cache_guard", guard_path)
    guard = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(guard)
    guard.guard([parent + "/toy"])
sys.path.insert(0, parent)
from toy import b
value = b.kernel()
print(json.dumps({"value": value, "hits": sum(b.kernel.stats.cache_hits.values())}))
"""


def make_toy(parent, value=1):
    pkg = parent / "toy"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text(A_PY.format(value=value))
    (pkg / "b.py").write_text(B_PY)
    return pkg


def edit_constant(pkg, value):
    """Rewrite ``a.py`` with another constant (other size, later mtime)."""
    path = pkg / "a.py"
    old = path.stat()
    path.write_text(A_PY.format(value=value))
    os.utime(path, (old.st_atime + 10, old.st_mtime + 10))


def run_toy(pkg, use_guard, cache_dir=None):
    env = dict(os.environ)
    env.pop("NUMBA_CACHE_DIR", None)
    if cache_dir is not None:
        env["NUMBA_CACHE_DIR"] = str(cache_dir)
    p = subprocess.run([sys.executable, "-c", RUN, str(pkg.parent), str(GUARD),
                        "1" if use_guard else "0"], env=env, capture_output=True, text=True,
                       timeout=120)
    assert p.returncode == 0, p.stderr
    return json.loads(p.stdout.strip().splitlines()[-1])


def cache_files(d):
    return sorted(p.name for p in Path(d).glob("*.nb[ic]")) if Path(d).is_dir() else []


@pytest.fixture(autouse=True)
def user_cache(tmp_path, monkeypatch):
    """numba's user-wide cache directory lies inside the test's temporary directory, and the
    children's kernel cache is the ``NUMBA_CACHE_DIR`` each test gives
    (``SMOOTHDIST_CACHE_DIR``, which would win over it, is not passed on)."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "user-cache"))
    monkeypatch.delenv("SMOOTHDIST_CACHE_DIR", raising=False)


@pytest.fixture
def no_cache_dir(monkeypatch):
    """The test process predicts numba's default (in-tree) locations."""
    monkeypatch.setattr(numba.core.config, "CACHE_DIR", "")


@pytest.mark.slow
def test_without_the_guard_an_edit_of_a_callee_is_missed(tmp_path):
    pkg = make_toy(tmp_path)
    assert run_toy(pkg, use_guard=False)["value"] == 101
    edit_constant(pkg, 22)
    stale = run_toy(pkg, use_guard=False)
    if stale["value"] == 122:
        pytest.skip(f"numba {numba.__version__} recompiles a caller when a callee's file "
                    "changes: the hazard the guard exists for does not occur")
    assert stale == {"value": 101, "hits": 1}


@pytest.mark.slow
def test_with_the_guard_an_edit_of_a_callee_is_picked_up(tmp_path, no_cache_dir):
    pkg = make_toy(tmp_path)
    first = run_toy(pkg, use_guard=True)
    assert first == {"value": 101, "hits": 0}
    # numba wrote where the guard looks
    where = cache_guard.cache_dirs(str(pkg))[0]
    assert Path(where) == pkg / "__pycache__"
    files = cache_files(where)
    assert any(f.startswith("b.kernel-") and f.endswith(".nbi") for f in files), files
    # unchanged sources: the cache is kept and used
    assert run_toy(pkg, use_guard=True) == {"value": 101, "hits": 1}
    assert cache_files(where) == files
    edit_constant(pkg, 22)
    assert run_toy(pkg, use_guard=True) == {"value": 122, "hits": 0}
    assert run_toy(pkg, use_guard=True) == {"value": 122, "hits": 1}


@pytest.mark.slow
def test_the_guard_clears_numba_cache_dir_when_it_is_set(tmp_path, monkeypatch):
    pkg = make_toy(tmp_path)
    root = tmp_path / "numba-cache"
    assert run_toy(pkg, use_guard=True, cache_dir=root)["value"] == 101
    monkeypatch.setattr(numba.core.config, "CACHE_DIR", str(root))
    where = Path(cache_guard.cache_dirs(str(pkg))[0])
    assert where.parent == root
    files = cache_files(where)
    assert any(f.startswith("b.kernel-") for f in files), files
    assert cache_files(pkg / "__pycache__") == []
    edit_constant(pkg, 22)
    removed = cache_guard.guard([str(pkg)])
    assert sorted(Path(p).name for p in removed) == files
    assert {Path(p).parent for p in removed} == {where}
    assert cache_files(where) == []
    assert run_toy(pkg, use_guard=True, cache_dir=root) == {"value": 122, "hits": 0}


def fake_cache(pkg):
    """Numba-like cache files in ``pkg/__pycache__``, plus files the guard must leave alone."""
    cache = pkg / "__pycache__"
    cache.mkdir(exist_ok=True)
    names = ["mod.f-3.py311.nbi", "mod.f-3.py311.1.nbc", "mod.cpython-311.pyc"]
    for name in names:
        (cache / name).write_bytes(b"x")
    (pkg / "stray.nbi").write_bytes(b"x")
    return cache


def test_unchanged_sources_keep_the_cache(tmp_path, no_cache_dir):
    pkg = tmp_path / "pkg"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "mod.py").write_text("X = 1\n")
    (pkg / "sub" / "deep.py").write_text("Y = 1\n")
    cache = fake_cache(pkg)
    sub_cache = fake_cache(pkg / "sub")
    # no digest yet: cleared, and the digest written
    assert len(cache_guard.guard([str(pkg)])) == 4
    assert (cache / cache_guard.STAMP_NAME).is_file()
    fake_cache(pkg)
    fake_cache(pkg / "sub")
    assert cache_guard.guard([str(pkg)]) == []
    assert len(cache_files(cache)) == 2 and len(cache_files(sub_cache)) == 2
    # an edit anywhere in the package tree clears every directory of it, numba's files only
    (pkg / "sub" / "deep.py").write_text("Y = 2\n")
    removed = cache_guard.guard([str(pkg)])
    assert sorted(removed) == sorted(str(d / n) for d in (cache, sub_cache)
                                     for n in ("mod.f-3.py311.nbi", "mod.f-3.py311.1.nbc"))
    assert (cache / "mod.cpython-311.pyc").is_file() and (pkg / "stray.nbi").is_file()


def test_the_fingerprint_covers_the_sources_and_numba(tmp_path, monkeypatch):
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "mod.py").write_text("X = 1\n")
    files = cache_guard.source_files([str(pkg)])
    before = cache_guard.fingerprint(files)
    assert cache_guard.fingerprint(files) == before
    (pkg / "mod.py").write_text("X = 2\n")
    assert cache_guard.fingerprint(files) != before
    (pkg / "mod.py").write_text("X = 1\n")
    monkeypatch.setattr(numba, "__version__", numba.__version__ + ".other")
    assert cache_guard.fingerprint(files) != before


def test_the_default_covers_smoothdist_and_tracer():
    dirs = cache_guard.default_package_dirs()
    assert dirs == [str(ROOT / "smoothdist"), str(ROOT / "tracer")]
    files = set(cache_guard.source_files(dirs))
    for rel in ("smoothdist/_kernels/query.py", "smoothdist/_kernels/weights.py",
                "tracer/rendering/march.py", "tracer/rendering/camera.py", "tracer/sim/ipm.py"):
        assert str(ROOT / rel) in files


def test_missing_and_unwritable_places_never_raise(tmp_path, monkeypatch, no_cache_dir):
    assert cache_guard.guard([str(tmp_path / "missing")]) == []
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "mod.py").write_text("X = 1\n")
    # no cache directory can be created: __pycache__, NUMBA_CACHE_DIR and the user-wide
    # cache all lie under a regular file
    blocker = tmp_path / "file"
    blocker.write_text("")
    (pkg / "__pycache__").write_text("")
    monkeypatch.setattr(numba.core.config, "CACHE_DIR", str(blocker / "numba"))
    monkeypatch.setenv("XDG_CACHE_HOME", str(blocker / "cache"))
    assert cache_guard.guard([str(pkg)]) == []
    # a read-only cache (or one another process is clearing): nothing deleted, nothing raised
    (pkg / "__pycache__").unlink()
    monkeypatch.setattr(numba.core.config, "CACHE_DIR", "")
    cache = fake_cache(pkg)

    def refuse(*args, **kwargs):
        raise PermissionError("read-only")

    def gone(*args, **kwargs):
        raise FileNotFoundError("deleted by another process")

    monkeypatch.setattr(cache_guard.os, "replace", refuse)
    for remove in (refuse, gone):
        monkeypatch.setattr(cache_guard.os, "remove", remove)
        assert cache_guard.guard([str(pkg)]) == []
        assert len(cache_files(cache)) == 2
        assert not (cache / cache_guard.STAMP_NAME).exists()
    # an unreadable source: no fingerprint, nothing touched
    monkeypatch.undo()
    (pkg / "broken.py").symlink_to(tmp_path / "nowhere.py")
    assert cache_guard.guard([str(pkg)]) == []
    assert len(cache_files(cache)) == 2


def test_guard_once_runs_once_and_can_be_switched_off(monkeypatch):
    calls = []
    monkeypatch.setattr(cache_guard, "guard", lambda dirs: calls.append(dirs) or [])
    monkeypatch.setattr(cache_guard, "_done", False)
    monkeypatch.setenv(cache_guard.ENV_VAR, "0")
    cache_guard.guard_once()
    assert calls == []
    monkeypatch.delenv(cache_guard.ENV_VAR)
    cache_guard.guard_once()
    cache_guard.guard_once()
    assert calls == [cache_guard.default_package_dirs()]

    def broken(dirs):
        raise RuntimeError("unexpected")

    monkeypatch.setattr(cache_guard, "guard", broken)
    monkeypatch.setattr(cache_guard, "_done", False)
    cache_guard.guard_once()  # warns, does not raise


@pytest.mark.slow
def test_serial_runs_do_not_load_the_parallel_kernels(tmp_path):
    """``SMOOTHDIST_PARALLEL=0`` after a parallel run compiles serial kernels: numba's cache
    index does not key on ``parallel=``, so a cached parallel kernel would be loaded."""
    # the exact point query's prange kernel, called directly: the smallest of the library's
    # parallel kernels to compile (the smooth one compiles its brute force and tol paths too)
    code = (
        "import numpy as np\n"
        "from smoothdist import DataMesh, SmoothDistanceField\n"
        "import smoothdist._kernels.query as q\n"
        "f = SmoothDistanceField(DataMesh(np.random.default_rng(0).random((50, 3))))\n"
        "n = 4\n"
        "k = q.exact_distance_batch\n"
        "k(f.tree, np.zeros((n, 3)), np.empty(n), np.empty((n, 3)), np.empty(n, np.int64),\n"
        "  np.empty(n, np.int64), np.empty(n, np.int64), 2)\n"
        "print(k.targetoptions['parallel'], sum(k.stats.cache_hits.values()))\n")
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"))
    # a moved per-machine cache would win over NUMBA_CACHE_DIR, and may hold the kernel already
    # (tests/smoothdist/kernels/test_exact_query.py calls it with the same types)
    env.pop("SMOOTHDIST_CACHE_DIR", None)
    env.pop("SMOOTHDIST_PARALLEL", None)
    runs = []
    for serial in (False, False, True):
        e = dict(env, SMOOTHDIST_PARALLEL="0") if serial else env
        out = subprocess.run([sys.executable, "-c", code], env=e, capture_output=True,
                             text=True, check=True).stdout.split()
        runs.append(out)
    assert runs[0] == ["True", "0"] and runs[1] == ["True", "1"]   # the parallel cache works
    assert runs[2] == ["False", "0"]                               # not loaded by a serial run
