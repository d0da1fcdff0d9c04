"""Command line: ``python -m tracer <command> ...`` (also installed as ``tracer``).

Every command reports bad input as one line ``error: ...`` on stderr with exit status 2, an
interruption (Ctrl-C, SIGTERM) as ``interrupted: ...`` with status 130, and never leaves a
partial output file: outputs are written to a temporary file and renamed. Existing outputs
are kept unless ``--overwrite`` is given.

Sub-commands live in their own modules; each exposes ``add_arguments(parser)`` and
``run(args) -> int`` and is imported only when used, so that ``tracer render`` does not pay
for importing pyvista or matplotlib.
"""

import argparse
import importlib
import os
import signal
import sys

#: name -> (module, one-line help)
COMMANDS = {
    "render": ("tracer.cli_render", "sphere-trace a scene file to a PNG (and AOVs)"),
    "compare": ("tracer.compare", "compare a render with a pyvista isosurface of the same field"),
    "diff": ("tracer.imagediff", "compare two images; non-zero exit beyond a tolerance"),
    "ablate-beta": ("tracer.ablation", "the paper's beta ablation: time and error vs beta"),
    "ablate-alpha": ("tracer.ablation", "the paper's alpha studies as image grids"),
    "bench-grid": ("tracer.ablation", "the paper's Thingi10K grid benchmark over a folder"),
    "bh-switch": ("tracer.ablation", "Barnes-Hut near/far switch discontinuity study"),
}


class CLIError(Exception):
    """A user-facing error: printed as one line, exit status 2."""


def _available():
    out = {}
    for name, (mod, helptext) in COMMANDS.items():
        spec = importlib.util.find_spec(mod)
        if spec is not None:
            out[name] = (mod, helptext)
    return out


def build_parser():
    """The argument parser with every available sub-command."""
    parser = argparse.ArgumentParser(
        prog="tracer", description="Render and study smooth-distance isosurfaces "
        "(Madan & Levin 2022).")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, (mod, helptext) in _available().items():
        p = sub.add_parser(name, help=helptext, description=helptext)
        module = importlib.import_module(mod)
        adder = getattr(module, "add_arguments_" + name.replace("-", "_"), None) or module.add_arguments
        adder(p)
        p.set_defaults(_module=mod, _name=name)
    return parser


def _on_sigterm(signum, frame):
    raise KeyboardInterrupt


def main(argv=None):
    """Entry point; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "command", None):
        parser.print_help()
        return 2
    if getattr(args, "threads", None):
        import numba

        if not 1 <= args.threads <= numba.config.NUMBA_NUM_THREADS:
            print(f"error: --threads must be between 1 and {numba.config.NUMBA_NUM_THREADS}",
                  file=sys.stderr)
            return 2
        numba.set_num_threads(args.threads)
    old = signal.signal(signal.SIGTERM, _on_sigterm)
    module = importlib.import_module(args._module)
    runner = getattr(module, "run_" + args._name.replace("-", "_"), None) or module.run
    try:
        return int(runner(args) or 0)
    except KeyboardInterrupt:
        print("\ninterrupted: stopped; no partial output file was left behind", file=sys.stderr)
        return 130
    except (CLIError, ValueError, FileExistsError, FileNotFoundError, PermissionError,
            IsADirectoryError) as exc:
        msg = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        print(f"error: {msg}", file=sys.stderr)
        return 2
    except MemoryError:
        print("error: out of memory (try a smaller --size)", file=sys.stderr)
        return 2
    finally:
        signal.signal(signal.SIGTERM, old)


def check_outputs(paths, overwrite):
    """Refuse (CLIError) when an output exists and ``overwrite`` is false; make parent folders."""
    for p in paths:
        if p is None:
            continue
        if os.path.isdir(p):
            raise CLIError(f"output path is a folder: {p}")
        if os.path.exists(p) and not overwrite:
            raise CLIError(f"output exists: {p} (pass --overwrite to replace it)")
    for p in paths:
        if p is not None:
            parent = os.path.dirname(os.path.abspath(p))
            os.makedirs(parent, exist_ok=True)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
