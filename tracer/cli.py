"""Command line: ``python -m tracer <command> ...`` (also installed as ``tracer``).

Every command reports bad input as one line ``error: ...`` on stderr with exit status 2 (no
traceback; warnings, e.g. mesh repairs, are single ``warning: ...`` lines), an interruption
(Ctrl-C, SIGTERM) as ``interrupted: ...`` with status 130, and never leaves a partial output
file: outputs are written to a temporary file and renamed. Existing outputs are kept unless
``--overwrite`` is given.

This module only dispatches. Every sub-command is a module listed in :data:`COMMANDS` that
exposes

* ``HELP = "..."``: its one-line help, on one line at the module's top level (``tracer --help``
  reads it from the module's source, without importing the module);
* ``add_arguments(parser)``: its options;
* ``run(args) -> int``: the command itself (its exit status);
* optionally ``needs(args)``: the optional packages (top-level module names, the keys of
  :data:`EXTRA_OF`) the command will import with these arguments. :func:`main` looks for them
  right after parsing, before ``run`` does any work, so that a missing extra is reported at once
  (``error: this command needs pillow, ...``), not after a render of minutes.

A command's module is imported only when that command runs, so that ``tracer render`` does not
pay for importing pyvista or matplotlib. The error class, option checks and output helpers the
commands share are in :mod:`tracer.outputs`.
"""

import argparse
import atexit
import gc
import importlib
import importlib.util
import os
import re
import signal
import sys
import traceback
import warnings

from tracer.errors import CLIError

#: command name -> the module that implements it (see the module docstring)
COMMANDS = {
    "render": "tracer.cli_render",
    "compare": "tracer.checks.compare",
    "diff": "tracer.checks.imagediff",
    "ablate-beta": "tracer.studies.beta",
    "ablate-alpha": "tracer.studies.alpha",
    "bench-grid": "tracer.studies.grid",
    "bh-switch": "tracer.studies.bh_switch",
    "simulate": "tracer.sim.cli_simulate",
    "animate": "tracer.sim.cli_animate",
    "reproduce": "tracer.reproduce.cli",
    "warmup": "tracer.cli_warmup",
    "data": "tracer.cli_data",
}


class _Parser(argparse.ArgumentParser):
    """An argument parser whose usage errors are one ``error: ...`` line (exit status 2)."""

    def error(self, message):
        # an option's check that names its flag (tracer.cli_render: "argument --beta: --beta
        # must be >= 0, got -1.0") says it alone, as the command's own checks do
        checked = re.match(r"argument (\S+): (\1 .*)", message)
        if checked:
            raise CLIError(checked.group(2))
        raise CLIError(f"{self.prog}: {message} (see {self.prog} --help)")


def _available():
    """``{name: module spec}`` of the commands whose module exists."""
    out = {}
    for name, mod in COMMANDS.items():
        try:
            spec = importlib.util.find_spec(mod)
        except (ImportError, ValueError):
            spec = None
        if spec is not None:
            out[name] = spec
    return out


def _help(spec):
    """A command module's ``HELP``, read from its source without importing the module.

    The module is imported instead when its source cannot be read or its ``HELP`` is not one
    line ``HELP = "..."`` (a plain double-quoted string)."""
    try:
        with open(spec.origin, encoding="utf-8") as fh:
            for line in fh:
                if line.startswith("HELP = "):
                    text = line[len("HELP = "):].strip()
                    inner = text[1:-1]
                    if len(text) >= 2 and text[0] == text[-1] == '"' and not (
                            '"' in inner or "\\" in inner):
                        return inner
                    break
    except (OSError, TypeError, UnicodeDecodeError):  # TypeError: no source file (origin None)
        pass
    return importlib.import_module(spec.name).HELP


def build_parser(only=None):
    """The argument parser with every available sub-command.

    With ``only`` (a command name) just that command's module is imported and given its
    arguments; the others are listed by name and help text only. ``main`` uses this so that a
    broken or slow optional module cannot affect another command.
    """
    parser = _Parser(
        prog="tracer", description="Render and study smooth-distance isosurfaces "
        "(Madan & Levin 2022).")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    for name, spec in _available().items():
        if only is not None and name != only:
            helptext = _help(spec)
            sub.add_parser(name, help=helptext, description=helptext).set_defaults(
                _module=spec.name)
            continue
        module = importlib.import_module(spec.name)
        p = sub.add_parser(name, help=module.HELP, description=module.HELP)
        p.set_defaults(_module=spec.name)
        module.add_arguments(p)
    return parser


def _on_sigterm(signum, frame):
    raise KeyboardInterrupt


def _show_warning(message, category, filename, lineno, file=None, line=None):
    """Warnings (e.g. mesh repairs) as one ``warning: ...`` line on stderr, no source line."""
    text = str(message).strip().splitlines()
    print(f"warning: {text[0] if text else category.__name__}", file=sys.stderr)


def _one_line(exc):
    """The first line of an exception's message (OSErrors as ``strerror: filename``)."""
    if isinstance(exc, OSError) and exc.strerror and not isinstance(exc, FileExistsError):
        name = f": {exc.filename}" if exc.filename else ""
        return f"{exc.strerror}{name}"
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


#: optional packages and the extra of ``pyproject.toml`` that installs each
EXTRA_OF = {"PIL": ("pillow", "tracer"), "trimesh": ("trimesh", "tracer"),
            "scipy": ("scipy", "sim"), "imageio": ("imageio", "sim"),
            "imageio_ffmpeg": ("imageio-ffmpeg", "sim"), "matplotlib": ("matplotlib", "studies"),
            "distributed": ("distributed", "studies"), "dask": ("distributed", "studies"),
            "pyvista": ("pyvista", "studies"), "vtk": ("pyvista", "studies"),
            "vtkmodules": ("pyvista", "studies")}


def _missing_package(exc):
    """One line for an ImportError: which package this command needs and how to install it."""
    name = (getattr(exc, "name", None) or "").split(".")[0]
    if name in EXTRA_OF:
        package, extra = EXTRA_OF[name]
        return (f"this command needs {package}, which is not installed (pip install "
                f"'smoothdist[{extra}]', or 'smoothdist[all]' for every command)")
    return f"{_one_line(exc)} (pip install 'smoothdist[all]' installs every optional package)"


def installed(name):
    """Whether the top-level package ``name`` can be imported, without importing it."""
    try:
        return importlib.util.find_spec(name) is not None
    except ValueError:  # imported already, without a spec
        return True
    except ImportError:  # a finder refuses it
        return False


def check_needs(module, args):
    """Raise ``ModuleNotFoundError`` for the first package of the command module's
    ``needs(args)`` that is not installed; :func:`main` reports it as any failed import
    (``_missing_package``)."""
    needs = getattr(module, "needs", None)
    for name in needs(args) if needs is not None else ():
        if not installed(name):
            raise ModuleNotFoundError(f"No module named {name!r}", name=name)


def _install(signum, handler):
    try:
        return signal.signal(signum, handler)
    except (ValueError, OSError):  # not the main thread, or an unsupported signal
        return None


def main(argv=None):
    """Entry point; returns the exit status.

    Exit status: 0 success, 2 bad input (one ``error:`` line on stderr), 130 interrupted
    (SIGINT or SIGTERM), 3 an unexpected internal error (one line). ``TRACER_DEBUG=1`` shows
    the traceback behind an internal error, and behind an ``error:`` line that came from a
    ``ValueError`` or ``OSError``.
    """
    if argv is None:
        # the command is the process (``tracer ...``, ``python -m tracer ...``): at its end,
        # Python's last garbage collection walks every object numba made while compiling
        # (0.4-0.5 s after a first render here, more than the render's own light and PNG);
        # frozen, they are left to the process's end. Nothing of ours needs a collection
        # then: outputs are written and closed, children stopped, by then
        atexit.register(gc.freeze)
    old_int = _install(signal.SIGINT, signal.default_int_handler)
    old_term = _install(signal.SIGTERM, _on_sigterm)
    old_show = warnings.showwarning
    warnings.showwarning = _show_warning
    try:
        return _run(argv)
    except ImportError as exc:
        if os.environ.get("TRACER_DEBUG"):

            traceback.print_exc()
        print(f"error: {_missing_package(exc)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("\ninterrupted: stopped; no partial output file was left behind", file=sys.stderr)
        return 130
    except (CLIError, ValueError, OSError) as exc:
        if os.environ.get("TRACER_DEBUG") and not isinstance(exc, CLIError):

            traceback.print_exc()
        print(f"error: {_one_line(exc)}", file=sys.stderr)
        return 2
    except MemoryError:
        print("error: out of memory (try a smaller --size)", file=sys.stderr)
        return 2
    except RecursionError:
        print("error: input nested too deeply", file=sys.stderr)
        return 2
    except Exception as exc:
        if os.environ.get("TRACER_DEBUG"):
            raise
        print(f"error: internal error ({type(exc).__name__}: {_one_line(exc)}); please report "
              "it, with TRACER_DEBUG=1 set for the traceback", file=sys.stderr)
        return 3
    finally:
        warnings.showwarning = old_show
        if old_term is not None:
            _install(signal.SIGTERM, old_term)
        if old_int is not None:
            _install(signal.SIGINT, old_int)


def _run(argv):
    argv = list(sys.argv[1:] if argv is None else argv)
    command = next((a for a in argv if not a.startswith("-")), None)
    parser = build_parser(only=command if command in COMMANDS else "")
    args = parser.parse_args(argv)
    if not getattr(args, "command", None):
        parser.print_help()
        return 2
    if getattr(args, "threads", None) is not None:
        import numba  # numba: loaded on use, the command line starts without it

        if not 1 <= args.threads <= numba.config.NUMBA_NUM_THREADS:
            raise CLIError(f"--threads must be between 1 and {numba.config.NUMBA_NUM_THREADS}, "
                           f"got {args.threads}")
        numba.set_num_threads(args.threads)
    module = importlib.import_module(args._module)
    check_needs(module, args)
    return int(module.run(args) or 0)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
