"""``python -m smoothdist COMMAND``: the library's kernel cache, from the command line.

* ``warmup``: compile the library's kernels into the per-machine cache, side by side on the
  machine's cores (:mod:`smoothdist.warmup`; ``tracer warmup`` adds the renderer's);
* ``cache``: where the cache is and what it holds; ``--prune`` deletes every version's folder
  but this one's, ``--clear`` all of them (:mod:`smoothdist._kernel_cache`).
"""

import argparse
import sys

from smoothdist import _kernel_cache as kc
from smoothdist import warmup


def _cache(args):
    top = kc.root()
    if top is None:
        print(f"the per-machine kernel cache is off ({kc.ENV_VAR}={kc.os.environ[kc.ENV_VAR]}): "
              "numba's own cache folders are used")
        return 0
    if args.clear or args.prune:
        removed = kc.clear(keep_current=args.prune)
        print(f"removed {len(removed)} folder(s) from {top}")
        return 0
    print(f"root:    {top}  (move it with {kc.ENV_VAR}=DIR; switch it off with "
          f"{kc.ENV_VAR}=off)")
    print(f"this copy: {kc.key()}")
    rows = kc.folders()
    if not rows:
        print("empty: nothing compiled yet (python -m smoothdist warmup compiles ahead)")
    for name, size, current in rows:
        print(f"  {name}  {size / 2**20:7.1f} MiB{'  (this copy)' if current else ''}")
    return 0


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python -m smoothdist",
                                     description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    w = sub.add_parser("warmup", help="compile the kernels ahead, on every core",
                       description=warmup.__doc__.split("\n\n")[0])
    warmup.add_arguments(w)
    c = sub.add_parser("cache", help="where the kernel cache is and what it holds")
    group = c.add_mutually_exclusive_group()
    group.add_argument("--prune", action="store_true",
                       help="delete every version's folder but this copy's")
    group.add_argument("--clear", action="store_true", help="delete every version's folder")
    args = parser.parse_args(argv)
    if args.command == "warmup":
        return warmup.warmup_command(args, ("smoothdist.warmup",))
    if args.command == "cache":
        return _cache(args)
    parser.print_help()
    return 2


if __name__ == "__main__":
    sys.exit(main())
