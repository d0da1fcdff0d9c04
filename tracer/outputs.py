"""What every ``tracer`` command shares: its error class, option checks and output files.

* :class:`~tracer.errors.CLIError`: bad input, reported by :func:`tracer.cli.main` as one
  ``error: ...`` line with exit status 2;
* option checks with one-line errors naming the option: :func:`positive`,
  :func:`non_negative`, :func:`at_least`, :func:`float_list` and :func:`check_size` (one pixel
  limit, :data:`MAX_SIDE`, for every command that takes an image size in this form);
* output paths: :func:`check_outputs` (before any work), :func:`make_parents`,
  :func:`output_folder`;
* writing: :func:`atomic_write` (a temporary file renamed into place, so that an interrupted
  command never leaves a partial file) and the writers built on it, :func:`write_text`,
  :func:`write_bytes`, :func:`write_json` and :func:`write_csv`.

Only the standard library is imported here (numpy lazily, for its scalar types), so that
``tracer.cli`` stays light.
"""

import csv
import io
import json
import math
import os
import secrets
from contextlib import contextmanager
from pathlib import Path
from tracer.errors import CLIError

__all__ = [
    "MAX_SIDE",
    "positive",
    "non_negative",
    "at_least",
    "float_list",
    "check_size",
    "check_outputs",
    "make_parents",
    "output_folder",
    "atomic_write",
    "write_text",
    "write_bytes",
    "write_json",
    "write_csv",
    "csv_value",
]


# =============================================================================== options
#: largest image side, in pixels, of the commands' ``--size`` options checked here
MAX_SIDE = 8192


def positive(value, name):
    """``value`` if it is a finite number > 0; else a :class:`~tracer.errors.CLIError` naming
    ``name``."""
    if not (math.isfinite(value) and value > 0):
        raise CLIError(f"{name} must be a finite number > 0, got {value:g}")
    return value


def non_negative(value, name):
    """``value`` if it is a finite number >= 0; else a :class:`~tracer.errors.CLIError` naming
    ``name``."""
    if not (math.isfinite(value) and value >= 0):
        raise CLIError(f"{name} must be >= 0, got {value:g}")
    return value


def at_least(value, name, low=1):
    """An integer option that must be ``>= low`` (``None``, an option not given, passes)."""
    if value is not None and value < low:
        raise CLIError(f"{name} must be >= {low}, got {value}")
    return value


def float_list(text, name, *, non_negative=False, positive=False):
    """Parse ``"0,0.1,0.5"`` into a list of floats (one-line errors naming ``name``)."""
    vals = []
    for part in str(text).split(","):
        part = part.strip()
        if not part:
            continue
        try:
            v = float(part)
        except ValueError:
            raise CLIError(f"{name}: {part!r} is not a number") from None
        if not math.isfinite(v):
            raise CLIError(f"{name}: {part!r} is not finite")
        if non_negative and v < 0:
            raise CLIError(f"{name}: values must be >= 0, got {v:g}")
        if positive and v <= 0:
            raise CLIError(f"{name}: values must be > 0, got {v:g}")
        vals.append(v)
    if not vals:
        raise CLIError(f"{name}: give at least one value (comma separated)")
    return vals


def check_size(size, minimum=1, name="--size"):
    """An image size option: one integer (a square image) or ``(W, H)``, each side in
    ``minimum..MAX_SIDE`` pixels. Returns ``size``; ``None`` (not given) passes."""
    if size is None:
        return None
    if isinstance(size, int):
        if not minimum <= size <= MAX_SIDE:
            raise CLIError(f"{name} must be between {minimum} and {MAX_SIDE} pixels, "
                           f"got {size}")
        return size
    if min(size) < minimum or max(size) > MAX_SIDE:
        raise CLIError(f"{name} must be two integers in {minimum}..{MAX_SIDE}, got "
                       f"{' '.join(str(v) for v in size)}")
    return size


# =============================================================================== output paths
def check_outputs(paths, overwrite, create=True):
    """Check output paths before any work is done.

    Refuses (CLIError) an output that is a folder, that exists while ``overwrite`` is false,
    that is given twice, or whose folder cannot be created or written. With ``create`` the
    missing parent folders are made now; otherwise call :func:`make_parents` just before
    writing, so that a failed run leaves no empty folders behind.
    """
    seen = {}
    for p in paths:
        if p is None:
            continue
        key = os.path.realpath(p)
        if key in seen:
            raise CLIError(f"the same file is given for two outputs: {p}")
        seen[key] = p
        if os.path.isdir(p):
            raise CLIError(f"output path is a folder: {p}")
        if os.path.exists(p) and not overwrite:
            raise CLIError(f"output exists: {p} (pass --overwrite to replace it)")
        parent = os.path.dirname(os.path.abspath(p))
        probe = parent
        while not os.path.exists(probe):
            probe = os.path.dirname(probe)
        if not os.path.isdir(probe):
            raise CLIError(f"cannot write {p}: {probe} is a file, not a folder")
        if not os.access(probe, os.W_OK | os.X_OK):
            raise CLIError(f"cannot write {p}: folder {probe} is not writable")
    if create:
        make_parents(paths)


def make_parents(paths):
    """Create the parent folders of the given output paths (``None`` entries are skipped)."""
    for p in paths:
        if p is not None:
            os.makedirs(os.path.dirname(os.path.abspath(p)), exist_ok=True)


def output_folder(path):
    """``Path(path)``, refusing an existing file that is not a folder."""
    out = Path(path)
    if out.exists() and not out.is_dir():
        raise CLIError(f"output path exists and is not a folder: {out}")
    return out


# =============================================================================== atomic writes
def _exists_message(path):
    return f"{path} already exists; pass --overwrite to replace it"


def _create_temp(path):
    """Create an empty temporary file next to ``path``; return its Path.

    The name is ``.<stem>.tmp-<8 hex><suffix>``: hidden, in the same folder (so that
    ``os.replace`` is atomic) and with the same suffix (so format sniffing by extension works).
    The file is created with mode 0o666 minus the umask, like a plain ``open``.
    """
    folder = path.parent
    if not folder.is_dir():
        raise FileNotFoundError(f"cannot write {path}: folder {folder} does not exist")
    for _ in range(100):
        tmp = folder / f".{path.stem}.tmp-{secrets.token_hex(4)}{path.suffix}"
        try:
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
        except FileExistsError:
            continue
        except PermissionError:
            raise PermissionError(13, f"cannot write {path}: folder {folder} is not writable") \
                from None
        try:
            os.close(fd)
        except BaseException:  # e.g. Ctrl-C right here: do not leave the empty file behind
            _unlink_quietly(tmp)
            raise
        return tmp
    raise FileExistsError(f"cannot create a temporary file next to {path}")


def _unlink_quietly(p):
    try:
        os.unlink(p)
    except FileNotFoundError:
        pass


def _fsync(p):
    """Flush a written file to disk before it is renamed into place (best effort)."""
    try:
        fd = os.open(p, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


@contextmanager
def atomic_write(path, *, overwrite=True):
    """Write a file atomically through a temporary file in the same folder.

    Parameters
    ----------
    path : str or os.PathLike
        Final destination. Its folder must exist.
    overwrite : bool, default True
        If False, refuse to replace an existing ``path``.

    Yields
    ------
    pathlib.Path
        An empty temporary file ``.<stem>.tmp-XXXXXXXX<suffix>`` next to ``path``; the body
        writes to it. On normal exit it is moved onto ``path`` (``os.replace``, or an atomic
        no-clobber ``os.link`` when ``overwrite=False``). On any exception, including
        ``KeyboardInterrupt``, it is deleted and ``path`` is left untouched.

    Raises
    ------
    FileExistsError
        If ``overwrite=False`` and ``path`` exists (checked before the body runs and again,
        atomically where the file system allows, when the file is moved into place).
    FileNotFoundError
        If the folder of ``path`` does not exist.

    Examples
    --------
    >>> with atomic_write("out.txt") as tmp:  # doctest: +SKIP
    ...     tmp.write_text("done")
    """
    path = Path(path)
    if not overwrite and path.exists():
        raise FileExistsError(_exists_message(path))
    tmp = _create_temp(path)
    try:
        yield tmp
        _fsync(tmp)
        if overwrite:
            os.replace(tmp, path)
        else:
            try:
                os.link(tmp, path)  # fails if path appeared meanwhile
            except FileExistsError:
                raise FileExistsError(_exists_message(path)) from None
            except OSError:  # hard links unsupported: best effort
                if path.exists():
                    raise FileExistsError(_exists_message(path)) from None
                os.replace(tmp, path)
    finally:
        # After a successful os.replace the temporary name is gone; otherwise remove it.
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass


def write_text(path, text):
    """Atomically (re)write a UTF-8 text file."""
    with atomic_write(path) as tmp:
        Path(tmp).write_text(text, encoding="utf-8")


def write_bytes(path, data):
    """Atomically (re)write a binary file."""
    with atomic_write(path) as tmp:
        Path(tmp).write_bytes(data)


def write_json(path, data):
    """Atomically (re)write a JSON file (indented; numpy scalars and arrays, and paths, are
    converted)."""
    with atomic_write(path) as tmp:
        with open(tmp, "w", encoding="utf-8") as fh:
            json.dump(data, fh, indent=2, default=_json_default)
            fh.write("\n")


def _json_default(o):
    import numpy as np  # numpy: loaded on use, tracer.cli imports this module and starts without it

    if isinstance(o, np.integer):
        return int(o)
    if isinstance(o, np.floating):
        return float(o)
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, Path):
        return str(o)
    raise TypeError(type(o).__name__)


def csv_value(v):
    """A CSV cell: floats with 8 significant digits, NaN/None as empty."""
    import numpy as np  # numpy: loaded on use, tracer.cli imports this module and starts without it

    if isinstance(v, (float, np.floating)):
        v = float(v)
        return f"{v:.8g}" if math.isfinite(v) else ""
    if v is None:
        return ""
    return v


def write_csv(path, fields, rows):
    """Atomically (re)write a whole CSV file: a header of ``fields``, then one line per dict of
    ``rows`` (keys not in ``fields`` are ignored; cells as :func:`csv_value`)."""

    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=fields, extrasaction="ignore", lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({k: csv_value(v) for k, v in r.items()})
    with atomic_write(path) as tmp:
        with open(tmp, "w", encoding="utf-8", newline="") as fh:
            fh.write(buf.getvalue())
            fh.flush()
            os.fsync(fh.fileno())
