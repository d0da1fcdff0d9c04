"""``tracer reproduce``: run every reproducible experiment of the paper and write a results
folder (``<experiment>.json`` each, with commit, date, machine, thread count and settings; the
studies' own CSVs and plots in ``<experiment>/``), ``claims.json`` and ``reproduction.md``.

``--quick`` runs everything at small sizes (at most :data:`QUICK_MINUTES` minutes on 2 cores
without ``--authors-bin``, which adds up to the quick timeout per Table 3 scene: the committed
quick run's ``run.json`` holds the measured figure, and
``tests/tracer/reproduce/test_reproduce.py`` checks it against the bound); the full run uses
the paper's sizes (hours on 2 cores: the Table 3 simulations dominate)
and runs the studies' and the simulations' tasks on the Dask runner (:mod:`tracer.runner`,
``--scheduler``). The folder is built next to ``--out``
under a temporary name and renamed when every experiment has finished, so an interrupted or
failed run leaves no half-written results.
"""

import json
import os
import shutil
import sys
import time
from pathlib import Path

from tracer import runner
from tracer.cli import main
from tracer.errors import CLIError
from tracer.outputs import write_json, write_text
from tracer.reproduce import docs, experiments
from tracer.reproduce.experiments import (EXPERIMENTS, NEEDS, SETTINGS, TABLE3_PAPER,
                                          load_average, merge_table3, provenance)
from tracer.reproduce.report import (claims_rows, dirty_results, load_run, render_page,
                                     report_state)
from tracer.studies.common import REPO

HELP = "run every reproducible experiment of the paper and write the results and the report"
#: the bound the help states for ``--quick`` on 2 cores (without ``--authors-bin``); the
#: committed quick run (renders/reproduction/quick/run.json) must keep it
QUICK_MINUTES = 15


def add_arguments(p):
    p.add_argument("--quick", action="store_true",
                   help=f"small sizes: at most {QUICK_MINUTES} minutes on 2 cores, measured "
                   "(renders/reproduction/quick/run.json); --authors-bin adds up to 10 minutes "
                   "per Table 3 scene (default: the paper's sizes, hours)")
    p.add_argument("--smoke", action="store_true",
                   help="smaller still than --quick (the test suite's run: every experiment "
                   "once, at its smallest)")
    p.add_argument("--out", metavar="DIR",
                   help="results folder (default renders/reproduction/quick or "
                   "renders/reproduction/full)")
    p.add_argument("--page", metavar="PATH",
                   help="also write the report page here (e.g. docs/reproduction.md)")
    p.add_argument("--only", metavar="LIST",
                   help="comma-separated experiments to run (default all: "
                   "underestimate, table3, grid, bh_switch, box_test, gpu, beta, alpha, "
                   "beta_alpha, attenuation, bh_centre, bulges, quadrature, vbowl); into an "
                   "existing results folder of the same mode it updates those experiments and "
                   "keeps the others (unless --overwrite)")
    p.add_argument("--authors-bin", metavar="PATH",
                   help="the authors' rigid_body_simulator (built as "
                   "benchmarks/authors/README.md says): Table 3 then also runs "
                   "their simulator on the same files and steps, on this machine, in the same "
                   "run (rows it cannot finish within the timeout say so)")
    p.add_argument("--table3-scenes", metavar="LIST",
                   help="comma-separated Table 3 scenes to run (default: the mode's; the full "
                   "run's are all eight, hours on 2 cores)")
    p.add_argument("--docs", action="store_true",
                   help="also rewrite the guides' figures that the report measures (their "
                   "reproduce: blocks) from the committed results (tracer/reproduce/docs.py)")
    p.add_argument("--report-only", action="store_true",
                   help="run nothing: regenerate claims.json and the page from --out")
    p.add_argument("--overwrite", action="store_true", help="replace an existing results folder")
    p.add_argument("--allow-dirty", action="store_true",
                   help="run, or write the report from results, on a work tree with "
                   "uncommitted changes (refused otherwise: such results name a commit that "
                   "is not the code they measured); the page then says which results are so")
    runner.add_arguments(p)
    p.add_argument("--threads", type=int, help="numba threads of in-process work")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress lines")


def _only(text, names, flag="--only", what="experiment(s)"):
    if not text:
        return list(names)
    pick = [s.strip() for s in text.split(",") if s.strip()]
    bad = [s for s in pick if s not in names]
    if bad or not pick:
        raise CLIError(f"{flag}: unknown {what} {', '.join(bad) or '(none given)'} "
                       f"(choose from {', '.join(names)})")
    return [n for n in names if n in pick]


def _shown(path):
    p = Path(path).resolve()
    try:
        return str(p.relative_to(REPO))
    except ValueError:
        return str(path)


def write_reproduction(out, page=None, shown_as=None, allow_dirty=False):
    """``claims.json`` and ``reproduction.md`` in ``out`` (and the page at ``page``); refused
    (:class:`CLIError`) when a result came from a tree with local changes, unless
    ``allow_dirty``. The report's own state (its commit, whether each experiment's measured
    code changed since its run) goes into ``run.json``'s ``report``."""
    dirty = dirty_results(out)
    if dirty and not allow_dirty:
        raise CLIError(f"results of a tree with local changes: {', '.join(dirty)} (rerun them "
                       "on a clean commit, or pass --allow-dirty and the page says so)")
    run = json.loads((Path(out) / "run.json").read_text(encoding="utf-8"))
    run["report"] = report_state(out, allow_dirty)
    write_json(Path(out) / "run.json", run)
    write_json(Path(out) / "claims.json", claims_rows(out))
    text = render_page(out, shown_as or _shown(out))
    write_text(Path(out) / "reproduction.md", text)
    if page:
        write_text(page, text)
    return text


def needs(args):
    """The optional packages of the experiments to run
    (:data:`tracer.reproduce.experiments.NEEDS`) and distributed for a cluster; none for
    ``--report-only``. :mod:`tracer.cli` checks them before anything runs."""
    if args.report_only:
        return []
    pick = {s.strip() for s in (args.only or "").split(",")}
    names = [n for n in EXPERIMENTS if not args.only or n in pick]
    serial = (args.quick or args.smoke) and args.scheduler == "local"  # as run() decides
    out = [p for n in names for p in NEEDS[n]] + ([] if serial else runner.needs(args))
    return list(dict.fromkeys(out))


def run(args):
    if args.quick and args.smoke:
        raise CLIError("--quick and --smoke exclude each other")
    mode = "smoke" if args.smoke else "quick" if args.quick else "full"
    names = _only(args.only, list(EXPERIMENTS))
    out = Path(args.out or os.path.join("renders", "reproduction", mode))
    if out.exists() and not out.is_dir():
        raise CLIError(f"--out exists and is not a folder: {out}")
    if args.page and Path(args.page).is_dir():
        raise CLIError(f"--page is a folder, not a file: {args.page}")
    if args.page and not Path(args.page).resolve().parent.is_dir():
        raise CLIError(f"--page: folder not found: {Path(args.page).parent}")
    if args.report_only:
        if not (out / "run.json").is_file():
            raise CLIError(f"{out} holds no results of tracer reproduce (no run.json)")
        write_reproduction(out, args.page, allow_dirty=args.allow_dirty)
        if not args.quiet:
            print(f"Wrote {out / 'claims.json'} and {out / 'reproduction.md'}"
                  + (f" and {args.page}" if args.page else ""))
        _docs(args)
        return 0
    sched, workers = runner.check_arguments(args)
    scenes = None
    if args.table3_scenes:
        scenes = _only(args.table3_scenes, list(TABLE3_PAPER), "--table3-scenes", "scene(s)")
    authors = None
    if args.authors_bin:
        authors = str(Path(args.authors_bin).resolve())
        if not (os.path.isfile(authors) and os.access(authors, os.X_OK)):
            raise CLIError(f"--authors-bin: not an executable file: {args.authors_bin}")
    if sched == "local" and mode != "full":
        sched, workers = "serial", None  # the quick run's tasks are too small for a cluster
    keep = []  # --only into an existing results folder: the experiments it keeps
    keep_rows = []
    if out.exists() and any(out.iterdir()) and not args.overwrite:
        if not (args.only and (out / "run.json").is_file()):
            raise CLIError(f"{out} exists (pass --overwrite to replace it)")
        old = load_run(out)
        if old["mode"] != mode:
            raise CLIError(f"{out} holds a {old['mode']} run, not a {mode} run; use another "
                           "--out or --overwrite")
        keep = [n for n in old["experiments"] if n not in names and n in EXPERIMENTS
                and (out / f"{n}.json").is_file()]
        # a run of some Table 3 scenes adds its rows to the earlier ones
        keep_rows = [n for n in old["experiments"] if n == "table3"
                     and (out / "table3.json").is_file()]
    if not args.allow_dirty:  # refuse now, not after an hour of experiments
        if experiments.tree_dirty():  # through the module: tests stand in for it
            raise CLIError("the work tree has uncommitted changes (git status): commit them, "
                           "or pass --allow-dirty and the page says so")
        old_dirty = [n for n in dirty_results(out) if n in keep + keep_rows]
        if old_dirty:
            raise CLIError(f"{out} keeps results of a tree with local changes: "
                           f"{', '.join(old_dirty)} (rerun them, or pass --allow-dirty)")
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.parent / f".{out.name}.partial-{os.getpid()}"
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir()
    say = (lambda s: None) if args.quiet else (lambda s: print(s, flush=True))
    t_all = time.perf_counter()
    try:
        for name in names:
            settings = SETTINGS[mode][name]
            if name == "table3" and scenes:
                settings = dict(settings, scenes=scenes)
            say(f"reproduce: {name} {settings}")
            load0 = load_average()
            t0 = time.perf_counter()
            res = EXPERIMENTS[name](tmp / name, settings,
                                    {"scheduler": sched, "workers": workers,
                                     "authors_bin": authors})
            sec = time.perf_counter() - t0
            if name == "table3" and scenes and name in keep_rows:
                res = merge_table3(json.loads((out / "table3.json").read_text()), res)
            write_json(tmp / f"{name}.json", dict(res, experiment=name, mode=mode,
                                                   settings=settings, seconds=round(sec, 2),
                                                   load_average_before=load0,
                                                   provenance=provenance()))
            say(f"reproduce: {name} done in {runner.duration(sec)}")
        for n in keep:  # the experiments --only left as they were
            shutil.copy2(out / f"{n}.json", tmp / f"{n}.json")
            if (out / n).is_dir():
                shutil.copytree(out / n, tmp / n)
        prov = provenance()
        ran = [n for n in EXPERIMENTS if n in names or n in keep]
        write_json(tmp / "run.json", dict(prov, mode=mode, experiments=ran,
                                          updated=names if keep else ran,
                                          scheduler=sched if sched in ("serial", "local")
                                          else "address", authors_bin=bool(authors),
                                          seconds=round(time.perf_counter() - t_all, 1)))
        write_reproduction(tmp, None, _shown(out), args.allow_dirty)
        if out.exists():
            old = out.parent / f".{out.name}.old-{os.getpid()}"
            out.rename(old)
            tmp.rename(out)
            shutil.rmtree(old, ignore_errors=True)
        else:
            tmp.rename(out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    if args.page:
        write_text(args.page, (out / "reproduction.md").read_text(encoding="utf-8"))
    say(f"Wrote {out} ({runner.duration(time.perf_counter() - t_all)})"
        + (f" and {args.page}" if args.page else ""))
    _docs(args)
    return 0


def _docs(args):
    """``--docs``: the guides' generated blocks rewritten from the committed results."""
    if not args.docs:
        return
    try:
        changed = docs.update()
    except (OSError, KeyError, ValueError, RuntimeError) as exc:
        raise CLIError(f"--docs: {exc}") from None
    if not args.quiet:
        print("Rewrote " + (", ".join(changed) if changed else "nothing (the guides agree)"))


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main(["reproduce", *sys.argv[1:]]))
