"""The per-machine kernel cache (``smoothdist._kernel_cache``), checked as behaviour.

* A second copy of the same source (another folder, as a fresh clone or a new virtual
  environment would be) loads the kernels the first copy compiled; a copy whose sources differ
  in any file compiles them again, into a folder of its own; nothing is written beside the
  sources.
* The root: ``$SMOOTHDIST_CACHE_DIR``, else ``$NUMBA_CACHE_DIR/smoothdist``, else the user's
  cache folder; ``off`` gives numba's own locators back; only our packages' functions are
  placed there.
* Version folders beyond the most recently used few are pruned; ``python -m smoothdist cache``
  lists and clears them; the save lock applies to our folders only.
"""

import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numba
import pytest

import smoothdist
from smoothdist import _kernel_cache as kc

ROOT = Path(__file__).resolve().parents[2]

# run in a fresh process with a copy of smoothdist first on the path: one small cached kernel,
# then where it came from
RUN = r"""
import json, sys
import smoothdist
from smoothdist import _kernel_cache
from smoothdist._kernels.closest_point import closest_point_segment as f
value = f(0.0, 1.0, 0.0, -1.0, 0.0, 0.0, 1.0, 0.0, 0.0)
print(json.dumps({"file": smoothdist.__file__, "value": list(value)[:3],
                  "hits": sum(f.stats.cache_hits.values()),
                  "misses": sum(f.stats.cache_misses.values()),
                  "folder": _kernel_cache.folder(), "path": f._cache.cache_path}))
"""


def copy_package(dest):
    """``smoothdist`` alone (no ``tracer`` beside it) copied to ``dest``, no caches."""
    shutil.copytree(ROOT / "smoothdist", dest / "smoothdist",
                    ignore=shutil.ignore_patterns("__pycache__"))
    return dest


def run_copy(copy, env_extra):
    env = {k: v for k, v in os.environ.items()
           if k not in ("SMOOTHDIST_CACHE_DIR", "NUMBA_CACHE_DIR")}
    env.update(env_extra, PYTHONPATH=str(copy))
    p = subprocess.run([sys.executable, "-c", RUN], env=env, capture_output=True, text=True,
                       timeout=300, cwd=copy)
    assert p.returncode == 0, p.stderr
    out = json.loads(p.stdout.strip().splitlines()[-1])
    assert out["file"] == str(copy / "smoothdist" / "__init__.py")
    return out


@pytest.mark.slow
def test_a_second_copy_loads_the_kernels_and_a_changed_copy_compiles_its_own(tmp_path):
    cache = tmp_path / "cache"
    env = {"SMOOTHDIST_CACHE_DIR": str(cache)}
    a = copy_package(tmp_path / "a")
    first = run_copy(a, env)
    assert (first["hits"], first["misses"]) == (0, 1)
    assert first["value"] == [0.0, 0.0, 0.0]
    # compiled into the root, not beside the sources
    assert Path(first["path"]).parent == Path(first["folder"])
    assert Path(first["folder"]).parent == cache
    assert not list((a / "smoothdist").rglob("*.nbi"))
    # another folder, same sources: loaded, not compiled
    b = copy_package(tmp_path / "b")
    second = run_copy(b, env)
    assert (second["hits"], second["misses"]) == (1, 0)
    assert second["folder"] == first["folder"]
    # one byte more in a kernel module: its own folder, compiled again; the first one kept
    path = b / "smoothdist" / "_kernels" / "closest_point.py"
    path.write_text(path.read_text() + "\n# edited\n")
    edited = run_copy(b, env)
    assert (edited["hits"], edited["misses"]) == (0, 1)
    assert edited["folder"] != first["folder"]
    assert sorted(p.name for p in cache.iterdir()) == sorted(
        Path(f).name for f in (first["folder"], edited["folder"]))
    # and the first copy still loads its own
    assert run_copy(a, env)["hits"] == 1


@pytest.mark.slow
def test_numba_cache_dir_moves_the_root_and_off_gives_numba_its_own_rules(tmp_path):
    a = copy_package(tmp_path / "a")
    moved = run_copy(a, {"NUMBA_CACHE_DIR": str(tmp_path / "numba")})
    assert Path(moved["folder"]).parent == tmp_path / "numba" / "smoothdist"
    off = run_copy(a, {"SMOOTHDIST_CACHE_DIR": "off"})
    assert off["folder"] is None
    # numba's in-tree locator, beside the source
    assert Path(off["path"]) == a / "smoothdist" / "_kernels" / "__pycache__"


def test_the_root_follows_the_environment(monkeypatch, tmp_path):
    monkeypatch.setenv(kc.ENV_VAR, str(tmp_path / "mine"))
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "numba"))
    assert kc.root() == str(tmp_path / "mine")
    monkeypatch.delenv(kc.ENV_VAR)
    assert kc.root() == str(tmp_path / "numba" / "smoothdist")
    monkeypatch.delenv("NUMBA_CACHE_DIR")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert kc.root().startswith(str(tmp_path / "xdg"))
    for value in ("off", "0", "OFF"):
        monkeypatch.setenv(kc.ENV_VAR, value)
        assert kc.root() is None and kc.folder() is None


def test_the_key_covers_every_source_file_and_the_versions():
    k = kc.key()
    assert k.startswith(smoothdist.__version__ + "-") and len(k.split("-")[-1]) == 20
    # this process's kernels are placed under it
    from smoothdist._kernels.closest_point import closest_point_segment

    if kc.root() is not None:
        assert closest_point_segment._cache.cache_path == os.path.join(
            kc.folder(), "smoothdist._kernels")


def test_only_our_packages_are_placed(tmp_path, monkeypatch):
    monkeypatch.setenv(kc.ENV_VAR, str(tmp_path / "cache"))
    other = tmp_path / "theirs.py"
    other.write_text("def f():\n    return 1\n")

    def f():
        return 1

    assert kc.SourceKeyedLocator.from_function(f, str(other)) is None
    ours = ROOT / "smoothdist" / "_kernels" / "closest_point.py"
    loc = kc.SourceKeyedLocator.from_function(f, str(ours))
    assert loc is not None
    assert loc.get_cache_path() == os.path.join(kc.folder(), "smoothdist._kernels")
    assert numba.core.caching.CacheImpl._locator_classes[0] is kc.SourceKeyedLocator


def test_prune_keeps_the_most_recently_used(tmp_path):
    now = time.time()
    for i in range(7):
        d = tmp_path / f"v{i}"
        d.mkdir()
        (d / "x.nbi").write_bytes(b"x")
        os.utime(d, (now - 100 * i, now - 100 * i))
    kc._prune(str(tmp_path), keep=4)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["v0", "v1", "v2", "v3"]


def test_the_save_lock_applies_to_our_folders_only(tmp_path, monkeypatch):
    monkeypatch.setenv(kc.ENV_VAR, str(tmp_path / "cache"))
    calls = []

    def save(self, key, data):
        calls.append((self._cache_path, os.path.exists(self._index_path + kc.LOCK_SUFFIX)))

    locked = kc._locked_save(save)

    class File:
        def __init__(self, path):
            self._cache_path = path
            self._index_path = os.path.join(path, "f.nbi")

    ours = os.path.join(kc.folder(), "smoothdist._kernels")
    os.makedirs(ours)
    locked(File(ours), "k", "d")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    locked(File(str(elsewhere)), "k", "d")
    assert calls == [(ours, True), (str(elsewhere), False)]


def test_a_save_into_a_cleared_folder_makes_it_again_and_never_fails(tmp_path, monkeypatch):
    monkeypatch.setenv(kc.ENV_VAR, str(tmp_path / "cache"))
    ours = os.path.join(kc.folder(), "smoothdist._kernels")

    def save(self, key, data):
        with open(self._index_path, "w") as f:
            f.write(data)

    class File:
        _cache_path = ours
        _index_path = os.path.join(ours, "f.nbi")

    kc._locked_save(save)(File(), "k", "d")    # the folder was never made (or was cleared)
    assert Path(File._index_path).read_text() == "d"

    def broken(self, key, data):
        raise OSError(28, "No space left on device")

    assert kc._locked_save(broken)(File(), "k", "d") is None


def test_the_cache_command_lists_and_clears(tmp_path):
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["SMOOTHDIST_CACHE_DIR"] = str(tmp_path)
    for name in ("0.0.1-old", "0.0.2-older"):
        (tmp_path / name).mkdir()
        (tmp_path / name / "a.nbc").write_bytes(b"x" * 2048)

    def cache(*args):
        p = subprocess.run([sys.executable, "-m", "smoothdist", "cache", *args], env=env,
                           capture_output=True, text=True, timeout=120)
        assert p.returncode == 0, p.stderr
        return p.stdout

    listing = cache()
    assert str(tmp_path) in listing and "0.0.1-old" in listing and "0.0.2-older" in listing
    # importing smoothdist made this copy's folder (its kernels are placed there)
    current = tmp_path / kc.key()
    assert current.is_dir() and f"{current.name}" in listing and "(this copy)" in listing
    assert "removed 2 folder(s)" in cache("--prune")
    assert [p.name for p in tmp_path.iterdir()] == [current.name]
    assert "removed 1 folder(s)" in cache("--clear")
    assert not list(tmp_path.iterdir())


CUDA_RUN = r"""
import json
import smoothdist
from smoothdist import _kernel_cache as kc
try:
    from numba.cuda.core import caching
    from numba.cuda.dispatcher import CUDACacheImpl
except ImportError as exc:
    print(json.dumps({"skip": str(exc)}))
    raise SystemExit(0)
kc.install_cuda()
from smoothdist import cuda as sdcuda
impl = CUDACacheImpl(sdcuda._exact_kernel)
print(json.dumps({"first": caching.CacheImpl._locator_classes[0].__name__,
                  "locked": hasattr(caching.IndexDataCacheFile.save, "__wrapped__"),
                  "path": impl.locator.get_cache_path(), "folder": kc.folder()}))
"""


@pytest.mark.slow
def test_the_cuda_kernels_use_the_same_cache(tmp_path):
    """numba-cuda's own locator list gets the locator too (in a child: importing numba.cuda
    fixes the simulator choice for the process). No card here: where the CUDA kernels' cache
    would go, not that a card's second process loads them."""
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["SMOOTHDIST_CACHE_DIR"] = str(tmp_path)
    p = subprocess.run([sys.executable, "-c", CUDA_RUN], env=env, capture_output=True,
                       text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    out = json.loads(p.stdout.strip().splitlines()[-1])
    if "skip" in out:
        pytest.skip(f"numba-cuda's caching module is not importable: {out['skip']}")
    assert out["first"] == "SourceKeyedLocator" and out["locked"]
    assert out["path"] == os.path.join(out["folder"], "smoothdist")


# one signature of a small kernel per process: float64 (argv[1] == "f") or int64 arguments
TWO = r"""
import json, sys, time
import smoothdist
from numba.core import caching
# numba's index update made slow (read, then 1 s, then write): two processes that save at about
# the same moment overlap for sure, as they may by chance when compiling for minutes
write_index = caching.IndexDataCacheFile._save_index
caching.IndexDataCacheFile._save_index = lambda self, o: (time.sleep(1.0), write_index(self, o))
from smoothdist._kernels.closest_point import closest_point_segment as f
args = (0.0, 1.0, 0.0, -1.0, 0.0, 0.0, 1.0, 0.0, 0.0) if sys.argv[1] == "f" else (0, 1, 0, -1, 0,
                                                                                0, 1, 0, 0)
f(*args)
if len(sys.argv) > 2:
    f(0, 1, 0, -1, 0, 0, 1, 0, 0)
print(json.dumps({"hits": sum(f.stats.cache_hits.values()),
                  "misses": sum(f.stats.cache_misses.values())}))
"""


@pytest.mark.slow
def test_two_processes_saving_two_signatures_at_once_keep_both(tmp_path):
    """Two processes compile one kernel for two signatures at the same moment into an empty
    cache, each taking a second between reading numba's index and writing it back; a third
    loads both (without the lock the later write drops the other's entry: checked by hand with
    the lock switched off, 2026-12-06)."""
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["SMOOTHDIST_CACHE_DIR"] = str(tmp_path / "cache")
    procs = [subprocess.Popen([sys.executable, "-c", TWO, kind], env=env, text=True,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE)
             for kind in ("f", "i")]
    for p in procs:
        out, err = p.communicate(timeout=300)
        assert p.returncode == 0, err
        assert json.loads(out.strip().splitlines()[-1]) == {"hits": 0, "misses": 1}
    third = subprocess.run([sys.executable, "-c", TWO, "f", "both"], env=env,
                           capture_output=True, text=True, timeout=300)
    assert third.returncode == 0, third.stderr
    assert json.loads(third.stdout.strip().splitlines()[-1]) == {"hits": 2, "misses": 0}
