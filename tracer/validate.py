"""Checking parsed JSON input files (scene files, simulation files) with one-line errors.

Each check takes the file's ``path`` and ``where``, the place of the value in the file (a key
such as ``camera.origin`` or ``objects[0].alpha``, or a command-line flag that overrides it),
and raises :class:`~tracer.errors.SceneError` (a ``ValueError``) with the message
``<file name>: <where> <problem>`` (:func:`file_error`). :func:`read_json` reads a file into a
dict with one-line errors for a missing, unreadable, binary, empty, oversized or malformed file.

:mod:`tracer.scenes.scene` and :mod:`tracer.sim.simfile` (whose :class:`~tracer.errors.SimFileError`
is a :class:`~tracer.errors.SceneError`) validate their files with these.
"""

import json
import math
import numbers
import os

import numpy as np
from tracer.errors import SceneError

__all__ = ["MAX_JSON_BYTES", "file_error", "show", "json_type", "number", "vec3",
           "choice", "check_keys", "resolve_path", "read_json"]

#: largest JSON file we agree to parse (a scene or simulation file is a few kilobytes)
MAX_JSON_BYTES = 16 * 1024 * 1024


def file_error(path, where, msg):
    """The :class:`~tracer.errors.SceneError` ``<file name>: <where> <msg>`` (to raise)."""
    return SceneError(f"{os.path.basename(path)}: {where} {msg}")


def show(value, limit=60):
    """A short JSON rendering of a (possibly huge) value for messages."""
    try:
        text = json.dumps(value)
    except (TypeError, ValueError, RecursionError):
        text = repr(value)
    return text if len(text) <= limit else text[:limit - 3] + "..."


def json_type(value):
    """The JSON name of a parsed value's type (``object``, ``list``, ``number``, ...)."""
    names = {dict: "object", list: "list", str: "string", bool: "boolean", int: "number",
             float: "number", type(None): "null"}
    return names.get(type(value), type(value).__name__)


def number(value, path, where, *, positive=False, non_negative=False, integer=False):
    """A finite JSON number (not a boolean) as a float, or an int with ``integer``; optionally
    ``> 0`` (``positive``) or ``>= 0`` (``non_negative``)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise file_error(path, where, f"must be a number, got {show(value)}")
    try:
        fvalue = float(value)
    except OverflowError:
        raise file_error(path, where, f"is too large, got {show(value)}") from None
    if not math.isfinite(fvalue):
        raise file_error(path, where, f"must be finite, got {value}")
    if integer and (not fvalue.is_integer()):
        raise file_error(path, where, f"must be an integer, got {value}")
    if positive and fvalue <= 0:
        raise file_error(path, where, f"must be > 0, got {value}")
    if non_negative and fvalue < 0:
        raise file_error(path, where, f"must be >= 0, got {value}")
    return int(fvalue) if integer else fvalue


def vec3(value, path, where):
    """A list of three finite numbers as a float array of shape (3,)."""
    if not isinstance(value, list) or len(value) != 3:
        raise file_error(path, where, f"must be a list of 3 numbers, got {show(value)}")
    return np.array([number(v, path, f"{where}[{i}]") for i, v in enumerate(value)])


def choice(value, choices, path, where):
    """A string that is one of ``choices``."""
    if not isinstance(value, str) or value not in choices:
        raise file_error(path, where, f"must be one of {', '.join(choices)}; got {show(value)}")
    return value


def check_keys(d, allowed, path, where):
    """``d`` must be a JSON object whose keys are all in the set ``allowed``."""
    if not isinstance(d, dict):
        raise file_error(path, where, f"must be a JSON object, got {json_type(d)}")
    unknown = sorted(set(d) - allowed)
    if unknown:
        raise file_error(path, where, f"has unknown key(s) {', '.join(map(repr, unknown))} "
                                      f"(allowed: {', '.join(sorted(allowed))})")


def resolve_path(base, p, path, where):
    """The file named by ``p`` (``~`` expanded; relative to the folder ``base``), which must
    exist and not be a folder."""
    if not isinstance(p, str) or not p:
        raise file_error(path, where, f"must be a non-empty file path, got {show(p)}")
    full = os.path.normpath(os.path.join(base, os.path.expanduser(p)))
    if os.path.isdir(full):
        raise file_error(path, where, f"is a folder, not a file: {p} (looked for {full})")
    if not os.path.isfile(full):
        raise file_error(path, where, f"file not found: {p} (looked for {full})")
    return full


def read_json(path, what="scene"):
    """Parse a JSON file into Python values, with one-line :class:`~tracer.errors.SceneError`
    messages for a file that cannot be read or parsed; ``what`` names the kind of file in them
    (``"scene file not found: ..."``)."""
    path = os.fspath(path)
    name = os.path.basename(path)
    if not os.path.exists(path):
        raise SceneError(f"{what} file not found: {path}")
    if os.path.isdir(path):
        raise SceneError(f"{what} path is a folder, not a file: {path}")
    if not os.path.isfile(path):
        raise SceneError(f"{what} path is not a regular file: {path}")
    try:
        size = os.path.getsize(path)
        if size == 0:
            raise SceneError(f"{what} file is empty: {path}")
        if size > MAX_JSON_BYTES:
            raise SceneError(f"{name}: is {size} bytes, too large for a {what} file "
                             f"(limit {MAX_JSON_BYTES})")
        with open(path, "rb") as fh:
            raw = fh.read()
        if b"\0" in raw:
            raise SceneError(f"{name}: not a text JSON file (it holds binary data)")
        text = raw.decode("utf-8-sig")
        if not text.strip():
            raise SceneError(f"{what} file is empty (only white space): {path}")
        data = json.loads(text)
    except PermissionError:
        raise SceneError(f"{what} file is not readable (permission denied): {path}") from None
    except UnicodeDecodeError:
        raise SceneError(f"{name}: not a text (UTF-8) JSON file") from None
    except json.JSONDecodeError as exc:
        raise SceneError(f"{name}: malformed JSON at line {exc.lineno} "
                         f"column {exc.colno}: {exc.msg}") from None
    except RecursionError:
        raise SceneError(f"{name}: malformed JSON: nested too deeply") from None
    except OSError as exc:
        raise SceneError(f"{what} file could not be read: {path}: "
                         f"{exc.strerror or type(exc).__name__}") from None
    return data
