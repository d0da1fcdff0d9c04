"""Guard against stale numba kernel caches after a source edit in another module.

numba's ``cache=True`` checks a cached kernel only against the file that defines it, but our kernels
compile in the njit functions they call from other modules (the tracer's march kernels contain
``smoothdist._kernels.query``'s), so an edit to ``smoothdist/_kernels/query.py`` alone could leave a
new process running the old render kernels. :func:`guard_once`, called when ``smoothdist`` is
imported (before any kernel is defined; every ``tracer`` module with kernels imports ``smoothdist``
first), hashes all ``.py`` files of ``smoothdist`` and ``tracer`` together with the numba version,
compares the digest with the one stored in each cache directory, and on a difference (or none
stored) deletes that directory's ``*.nbi`` / ``*.nbc`` files and stores the new digest. Unchanged
sources keep the cache. ``SMOOTHDIST_CACHE_GUARD=0`` switches it off.

Where numba caches the kernels of ``pkg/mod.py`` (``numba.core.caching``, numba >= 0.58): the
first of ``$NUMBA_CACHE_DIR/<subpath>`` (if the variable is set), ``pkg/__pycache__`` and
``<user cache dir>/numba/<subpath>`` that it can create and write to, where ``<subpath>`` is
``pkg_<sha1 of the absolute path of pkg>``. Only those directories are touched, only ``*.nbi``,
``*.nbc`` and the digest file in them. File-system errors (read-only installs, another process
clearing the same directory) are ignored: the guard never makes an import fail. Not covered: a
process started before the edit that is still compiling new signatures can save old code after
the clear; custom ``NUMBA_CACHE_LOCATOR_CLASSES`` locations.
"""

import hashlib
import os
import sys

import numba
from numba.core import config

ENV_VAR = "SMOOTHDIST_CACHE_GUARD"
#: the digest file written into each cache directory
STAMP_NAME = "smoothdist-sources.sha1"
#: numba's cache files: one index per kernel, one data file per compiled signature
CACHE_SUFFIXES = (".nbi", ".nbc")

_done = False


def default_package_dirs():
    """The ``smoothdist`` and ``tracer`` package directories (tracer may be absent)."""
    here = os.path.dirname(os.path.abspath(__file__))
    dirs = [here, os.path.join(os.path.dirname(here), "tracer")]
    return [d for d in dirs if os.path.isfile(os.path.join(d, "__init__.py"))]


def source_files(package_dirs):
    """Every ``.py`` file under ``package_dirs`` (recursively, ``__pycache__`` skipped), sorted."""
    files = []
    for top in package_dirs:
        for root, dirs, names in os.walk(top):
            dirs[:] = sorted(d for d in dirs if d != "__pycache__" and not d.startswith("."))
            files += [os.path.join(root, n) for n in sorted(names) if n.endswith(".py")]
    return files


def fingerprint(files):
    """Hex sha1 of the numba version and each file's path (its last two parts) and bytes."""
    h = hashlib.sha1(f"numba {numba.__version__}; guard 1\n".encode())
    for path in files:
        with open(path, "rb") as f:
            data = f.read()
        name = "/".join(os.path.normpath(path).split(os.sep)[-2:])
        h.update(f"{name} {len(data)}\n".encode())
        h.update(data)
    return h.hexdigest()


def _cache_subpath(source_dir):
    """numba's per-directory folder name under a cache root: ``<dir name>_<sha1 of the path>``."""
    try:
        # numba internals, absent in some versions: the fallback below
        from numba.core.caching import _CacheLocator

        return _CacheLocator.get_suitable_cache_subpath(os.path.join(source_dir, "x.py"))
    except (ImportError, AttributeError):  # pragma: no cover - replicates numba 0.58-0.68
        path = os.path.abspath(source_dir)
        return "_".join([os.path.basename(path), hashlib.sha1(path.encode()).hexdigest()])


def cache_dirs(source_dir):
    """numba's candidate cache directories for kernels defined in ``source_dir``, in the order
    numba tries them (it uses the first it can create and write to)."""
    subpath = _cache_subpath(source_dir)
    dirs = []
    if config.CACHE_DIR:
        dirs.append(os.path.join(config.CACHE_DIR, subpath))
    dirs.append(os.path.join(source_dir, "__pycache__"))
    try:
        # numba internals, absent in some versions: the fallback below
        from numba.misc.appdirs import AppDirs

        dirs.append(os.path.join(AppDirs(appname="numba", appauthor=False).user_cache_dir,
                                 subpath))
    except Exception:  # pragma: no cover - no user-wide cache known: nothing to clear there
        pass
    return dirs


def _read(path):
    try:
        with open(path, encoding="ascii") as f:
            return f.read().strip()
    except (OSError, ValueError):
        return None


def _clear(cache_dir):
    """Delete the numba cache files in ``cache_dir``; returns their paths."""
    removed = []
    try:
        names = os.listdir(cache_dir)
    except OSError:
        return removed
    for name in names:
        if name.endswith(CACHE_SUFFIXES):
            path = os.path.join(cache_dir, name)
            try:
                os.remove(path)
                removed.append(path)
            except OSError:  # gone already (another process), or read-only
                pass
    return removed


def _write_stamp(cache_dir, digest):
    """Store ``digest`` in ``cache_dir`` atomically; False if the directory is not writable."""
    path = os.path.join(cache_dir, STAMP_NAME)
    tmp = f"{path}.{os.getpid()}-{os.urandom(4).hex()}.tmp"
    try:
        with open(tmp, "w", encoding="ascii") as f:
            f.write(digest + "\n")
        os.replace(tmp, path)
        return True
    except OSError:
        try:
            os.remove(tmp)
        except OSError:
            pass
        return False


def guard(package_dirs):
    """Clear the numba caches of ``package_dirs`` if their sources changed since the caches were
    written; returns the deleted files (empty when nothing changed). Never raises ``OSError``."""
    try:
        files = source_files(package_dirs)
        digest = fingerprint(files)
    except OSError:
        return []
    removed = []
    for source_dir in sorted({os.path.dirname(p) for p in files}):
        in_use = False  # found the directory numba will write to
        for cache_dir in cache_dirs(source_dir):
            if not os.path.isdir(cache_dir):
                if in_use:
                    continue
                try:
                    os.makedirs(cache_dir, exist_ok=True)
                except OSError:
                    continue
            if _read(os.path.join(cache_dir, STAMP_NAME)) == digest:
                in_use = True
                continue
            removed += _clear(cache_dir)
            in_use = _write_stamp(cache_dir, digest) or in_use
    return removed


def guard_once():
    """:func:`guard` over ``smoothdist`` and ``tracer``, once per process, unless
    ``SMOOTHDIST_CACHE_GUARD=0``; never raises."""
    global _done
    if _done or os.environ.get(ENV_VAR, "1").strip() == "0":
        return
    _done = True
    try:
        guard(default_package_dirs())
    except Exception as exc:  # a broken guard must not break the import
        print(f"warning: numba cache guard skipped ({exc})", file=sys.stderr)
