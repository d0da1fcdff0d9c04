"""The kernel cache that outlives the copy: our numba kernels compiled once per machine.

numba's own cache locators keep a kernel's compiled code beside its source file
(``pkg/__pycache__``) or under a folder named after the source's absolute path, so a fresh
clone, a new virtual environment or a second install of the same version compiles everything
again (tens of CPU seconds). :class:`SourceKeyedLocator`, put first in numba's list of locators
when ``smoothdist`` is imported (:func:`install`), keeps the kernels of ``smoothdist`` and
``tracer`` in one folder per machine, keyed on content instead of place::

    <root>/<version>-<key>/<package>/        e.g. ~/.cache/smoothdist/kernels/0.1.0-3f2a.../
                                                  smoothdist._kernels/query.closest-412.py311.nbi

* ``key``: a hash of every ``.py`` file of both packages (relative name and bytes, the digest
  :mod:`smoothdist._cache_guard` computes: our kernels inline each other across modules, so any
  source edit starts a new folder), numba's, llvmlite's and Python's versions and the machine
  architecture. numba keys each entry inside on the CPU's name and features, the signature and
  the function's bytecode, and checks each index against the source file's sha256.
* The root keeps the :data:`KEEP` most recently used version folders; a process that creates
  a new one deletes the older ones beyond that (a source edit starts a new folder).
* ``root``: ``$SMOOTHDIST_CACHE_DIR`` if set (``off`` or ``0``: numba's own rules), else
  ``$NUMBA_CACHE_DIR/smoothdist`` if numba's variable is set, else the user's cache folder
  (``~/.cache/smoothdist/kernels`` on Linux, numba's ``appdirs``).
* Two processes may compile at once: numba writes each file under a temporary name and renames
  it into place, and in our folders :func:`install` makes a kernel's index-and-data update one
  step under a file lock (numba's own numbering of data files would otherwise let two processes
  saving two signatures of one kernel at the same moment pair an index entry with the other's
  data). A folder that cannot be created or written falls back to numba's locators
  (which the guard protects). Only functions defined in our two packages are placed here.

:func:`folders` lists what the root holds, :func:`clear` deletes it (all, or every version but
this one); ``python -m smoothdist cache`` is the command line.
"""

import hashlib
import os
import platform
import shutil
import sys

try:
    import fcntl
except ImportError:  # pragma: no cover - Windows: numba's saves as they are
    fcntl = None

import llvmlite
import numba
# numba internals (numba >= 0.58): the base classes of its own source-file locators, the locator
# list and the index-and-data file
from numba.core.caching import (CacheImpl, IndexDataCacheFile, _CacheLocator,
                                _SourceFileBackedLocatorMixin)

from smoothdist._cache_guard import default_package_dirs, fingerprint, source_files

ENV_VAR = "SMOOTHDIST_CACHE_DIR"
#: values of ``$SMOOTHDIST_CACHE_DIR`` that switch the locator off
OFF = ("off", "0", "no", "false")

#: version folders kept under the root (most recently used first)
KEEP = 4
#: the lock file beside each kernel's index, while a process updates it
LOCK_SUFFIX = ".lock"

_state = {"key": None, "installed": False, "ready": None, "version": "0"}


def package_dirs():
    """The ``smoothdist`` and ``tracer`` package directories (absolute; tracer may be absent)."""
    return [os.path.abspath(d) for d in default_package_dirs()]


def root():
    """The cache root (an absolute path), or None when ``$SMOOTHDIST_CACHE_DIR`` switches the
    locator off."""
    value = os.environ.get(ENV_VAR, "").strip()
    if value.lower() in OFF:
        return None
    if value:
        return os.path.abspath(os.path.expanduser(value))
    numba_dir = os.environ.get("NUMBA_CACHE_DIR", "").strip()
    if numba_dir:
        return os.path.join(os.path.abspath(os.path.expanduser(numba_dir)), "smoothdist")
    try:
        from numba.misc.appdirs import AppDirs  # numba internals, absent in some versions

        base = AppDirs(appname="smoothdist", appauthor=False).user_cache_dir
    except Exception:  # pragma: no cover - numba without appdirs
        base = os.path.join(os.path.expanduser("~"), ".cache", "smoothdist")
    return os.path.join(base, "kernels")


def key():
    """This copy's folder name, ``<smoothdist version>-<hash>`` (computed once per process, the
    version as :func:`install` was given it)."""
    if _state["key"] is None:
        h = hashlib.sha1(fingerprint(source_files(package_dirs())).encode())
        h.update(f"numba {numba.__version__}; llvmlite {llvmlite.__version__}; "
                 f"python {sys.version}; {platform.machine()}".encode())
        _state["key"] = f"{_state['version']}-{h.hexdigest()[:20]}"
    return _state["key"]


def folder():
    """This copy's cache folder (None when switched off)."""
    top = root()
    return None if top is None else os.path.join(top, key())


def _ready(path):
    """Create ``path`` (once per process), mark it used now and, if it is new, delete the
    version folders beyond the :data:`KEEP` most recently used; False if it cannot be made."""
    if _state["ready"] != path:
        try:
            new = not os.path.isdir(path)
            os.makedirs(path, exist_ok=True)
            os.utime(path)
        except OSError:
            return False
        _state["ready"] = path
        if new:
            _prune(os.path.dirname(path), keep=KEEP)
    return True


def _prune(top, keep):
    """Delete the version folders under ``top`` beyond the ``keep`` most recently used."""
    try:
        entries = [e for e in os.scandir(top) if e.is_dir()]
        entries.sort(key=lambda e: e.stat().st_mtime, reverse=True)
    except OSError:
        return
    for entry in entries[keep:]:
        shutil.rmtree(entry.path, ignore_errors=True)


def _package_name(py_file, dirs):
    """``smoothdist._kernels`` for a file in that package, None outside ``dirs``."""
    here = os.path.dirname(os.path.abspath(py_file))
    for top in dirs:
        if here == top or here.startswith(top + os.sep):
            rel = os.path.relpath(here, os.path.dirname(top))
            return rel.replace(os.sep, ".")
    return None


class SourceKeyedLocator(_SourceFileBackedLocatorMixin, _CacheLocator):
    """numba cache locator for the kernels of ``smoothdist`` and ``tracer``: the folder
    :func:`folder` ``/<package>``; the index stamp (the source file's sha256), the
    disambiguator (the line number) and the file names are numba's."""

    _dirs = None

    def __init__(self, py_func, py_file):
        self._py_file = py_file
        self._lineno = py_func.__code__.co_firstlineno
        self._cache_path = os.path.join(folder(), _package_name(py_file, self._dirs))

    def get_cache_path(self):
        return self._cache_path

    @classmethod
    def from_function(cls, py_func, py_file):
        if cls._dirs is None:
            cls._dirs = package_dirs()
        if root() is None or _package_name(py_file, cls._dirs) is None:
            return None
        if not _ready(folder()):
            return None
        return super().from_function(py_func, py_file)


def _put_first(impl_class):
    classes = impl_class._locator_classes
    if SourceKeyedLocator not in classes:
        impl_class._locator_classes = [SourceKeyedLocator, *classes]


def _locked_save(save):
    """numba's ``IndexDataCacheFile.save``, under an exclusive lock on ``<index>.lock`` for the
    files in our cache folders (elsewhere numba's as it is). In our folders a file-system error
    (the folder cleared by ``python -m smoothdist cache --clear`` or pruned by a process of
    another version meanwhile, a full disk) leaves the kernel uncached instead of failing the
    call that compiled it; a cleared folder is made again first."""

    def locked(self, key, data):
        here = folder()
        if here is None or not self._cache_path.startswith(here):
            return save(self, key, data)
        try:
            os.makedirs(self._cache_path, exist_ok=True)
            if fcntl is None:
                return save(self, key, data)
            with open(self._index_path + LOCK_SUFFIX, "a") as lock:
                fcntl.flock(lock, fcntl.LOCK_EX)
                try:
                    return save(self, key, data)
                finally:
                    fcntl.flock(lock, fcntl.LOCK_UN)
        except OSError:
            return None

    locked.__wrapped__ = save
    return locked


def install(version):
    """Put :class:`SourceKeyedLocator` first in numba's CPU locator list and lock its saves
    (once; idempotent); ``version`` (smoothdist's) starts the folder names. Must run before the
    kernels are defined. ``NUMBA_CACHE_LOCATOR_CLASSES``, when set, is numba's and wins."""
    _state["version"] = version
    if _state["installed"]:
        return
    _put_first(CacheImpl)
    if not hasattr(IndexDataCacheFile.save, "__wrapped__"):
        IndexDataCacheFile.save = _locked_save(IndexDataCacheFile.save)
    _state["installed"] = True


def install_cuda():
    """The same for numba-cuda's kernels (its own locator list); call after importing
    ``numba.cuda`` and before ``cuda.jit(cache=True)``. A numba-cuda without that list keeps
    its own rules."""
    try:
        # numba-cuda (gpu extra): loaded on use, by the caller's import of numba.cuda
        from numba.cuda.core import caching as cuda_caching
    except ImportError:
        return
    _put_first(cuda_caching.CacheImpl)
    saving = cuda_caching.IndexDataCacheFile
    if not hasattr(saving.save, "__wrapped__"):
        saving.save = _locked_save(saving.save)


def folders():
    """``[(name, bytes, is_current)]`` of the version folders under :func:`root`."""
    top = root()
    if top is None or not os.path.isdir(top):
        return []
    current = key()
    out = []
    for name in sorted(os.listdir(top)):
        path = os.path.join(top, name)
        if os.path.isdir(path):
            size = sum(os.path.getsize(os.path.join(d, f))
                       for d, _, names in os.walk(path) for f in names
                       if os.path.isfile(os.path.join(d, f)))
            out.append((name, size, name == current))
    return out


def clear(keep_current=False):
    """Delete the version folders under :func:`root` (all, or all but this copy's); returns
    their names. Errors on single files (another process writing) are ignored."""
    top = root()
    removed = []
    for name, _, current in folders():
        if keep_current and current:
            continue
        shutil.rmtree(os.path.join(top, name), ignore_errors=True)
        removed.append(name)
    return removed
