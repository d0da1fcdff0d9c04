"""``tracer data``: the public data the benchmarks, studies and reproduction read
(:mod:`tracer.datasets`): where each file is, and fetching the missing ones, checked."""

from tracer import datasets
from tracer.errors import CLIError

HELP = "list or fetch the public data the benchmarks, studies and reproduction read (checked)"


def add_arguments(p):
    p.add_argument("action", choices=("list", "fetch"),
                   help="list: every registered file and where it is; fetch: download the "
                   "missing ones named (into the user cache, each checked by SHA-256)")
    p.add_argument("names", nargs="*", metavar="NAME",
                   help="files (thingi10k/72960_guardian_lion.obj) or groups ("
                   + ", ".join(sorted(datasets.GROUPS)) + "); default: every file")
    p.add_argument("--base", default=None, metavar="URL",
                   help="where the sources are downloaded from, {URL}/{repo}/{commit}/{path} "
                   "(a mirror of raw.githubusercontent.com; default $SMOOTHDIST_DATA_URL, "
                   f"else {datasets.RAW})")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress lines")


def needs(args):
    """Only the standard library and numpy."""
    return []


def _names(args):
    out = []
    for n in args.names or sorted(datasets.REGISTRY):
        if n in datasets.GROUPS:
            out += datasets.GROUPS[n]
        elif n in datasets.REGISTRY:
            out.append(n)
        else:
            raise CLIError(f"tracer data: no file or group {n!r} (see tracer data list)")
    return out


def run(args):
    names = _names(args)
    if args.action == "list":
        print(f"local copies: ${datasets.ENV_LOCAL}; cache: {datasets.cache_dir()}")
        for n in names:
            where, p = datasets.status(n)
            e = datasets.REGISTRY[n]
            print(f"{where:8s} {n}  ({e.size:,} bytes, {e.licence}; {e.source.repo})"
                  + (f"  {p}" if p else ""))
        return 0
    say = None if args.quiet else print
    for n in names:
        p = datasets.path(n, base=args.base, progress=say)
        if say:
            say(f"ok {n}: {p}")
    return 0
