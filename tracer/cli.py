"""Command line: ``python -m tracer <command> ...`` (also installed as ``tracer``).

Every command reports bad input as one line ``error: ...`` on stderr with exit status 2 (no
traceback; warnings, e.g. mesh repairs, are single ``warning: ...`` lines), an interruption
(Ctrl-C, SIGTERM) as ``interrupted: ...`` with status 130, and never leaves a partial output
file: outputs are written to a temporary file and renamed. Existing outputs are kept unless
``--overwrite`` is given.

Sub-commands live in their own modules; each exposes ``add_arguments(parser)`` and
``run(args) -> int`` and is imported only when used, so that ``tracer render`` does not pay
for importing pyvista or matplotlib.
"""

import argparse
import importlib
import os
import signal
import sys
import warnings

#: name -> (module, one-line help)
COMMANDS = {
    "render": ("tracer.cli_render", "sphere-trace a scene file to a PNG (and AOVs)"),
    "compare": ("tracer.compare", "compare a render with a pyvista isosurface of the same field"),
    "diff": ("tracer.imagediff", "compare two images; non-zero exit beyond a tolerance"),
    "ablate-beta": ("tracer.studies.beta", "the paper's beta ablation: time and error vs beta"),
    "ablate-alpha": ("tracer.studies.alpha", "the paper's alpha studies as image grids"),
    "bench-grid": ("tracer.studies.grid", "the paper's Thingi10K grid benchmark over a folder"),
    "bh-switch": ("tracer.studies.bh_switch", "Barnes-Hut near/far switch discontinuity study"),
    "simulate": ("tracer.sim.cli_sim", "simulate rigid bodies with one smooth-distance constraint"),
    "animate": ("tracer.sim.cli_sim", "render a simulated trajectory to PNG frames, MP4 and GIF"),
}


class CLIError(Exception):
    """A user-facing error: printed as one line, exit status 2."""


class _Parser(argparse.ArgumentParser):
    """An argument parser whose usage errors are one ``error: ...`` line (exit status 2)."""

    def error(self, message):
        raise CLIError(f"{self.prog}: {message} (see {self.prog} --help)")


def _available():
    out = {}
    for name, (mod, helptext) in COMMANDS.items():
        try:
            spec = importlib.util.find_spec(mod)
        except (ImportError, ValueError):
            spec = None
        if spec is not None:
            out[name] = (mod, helptext)
    return out


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
    for name, (mod, helptext) in _available().items():
        p = sub.add_parser(name, help=helptext, description=helptext)
        p.set_defaults(_module=mod, _name=name)
        if only is not None and name != only:
            continue
        module = importlib.import_module(mod)
        adder = getattr(module, "add_arguments_" + name.replace("-", "_"), None) or module.add_arguments
        adder(p)
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
    old_int = _install(signal.SIGINT, signal.default_int_handler)
    old_term = _install(signal.SIGTERM, _on_sigterm)
    old_show = warnings.showwarning
    warnings.showwarning = _show_warning
    try:
        return _run(argv)
    except KeyboardInterrupt:
        print("\ninterrupted: stopped; no partial output file was left behind", file=sys.stderr)
        return 130
    except (CLIError, ValueError, OSError) as exc:
        if os.environ.get("TRACER_DEBUG") and not isinstance(exc, CLIError):
            import traceback  # where a ValueError or OSError came from (a library, a bug)

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
        import numba

        if not 1 <= args.threads <= numba.config.NUMBA_NUM_THREADS:
            raise CLIError(f"--threads must be between 1 and {numba.config.NUMBA_NUM_THREADS}, "
                           f"got {args.threads}")
        numba.set_num_threads(args.threads)
    module = importlib.import_module(args._module)
    runner = getattr(module, "run_" + args._name.replace("-", "_"), None) or module.run
    return int(runner(args) or 0)


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


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
