"""Running independent tasks: in-process, on a local Dask cluster, or on an existing one.

The studies (:mod:`tracer.studies`) and the frames of ``tracer simulate`` / ``tracer animate``
(:mod:`tracer.sim.frames`) run through this module. A study is a list of tasks (small picklable
dicts, each with a unique ``"key"`` and an a-priori ``"weight"`` for the ETA) and a
module-level function ``fn(task) -> record`` (a small dict).
:func:`run_study` runs ``fn`` on every task and hands each record to the study's ``on_result``
callback in this process as soon as it arrives, in completion order; the study appends it to
its :class:`TaskLog` (one CSV row per task), so an interrupted study resumes without redoing the
tasks it finished.

Where the tasks run (``--scheduler``):

* ``serial``: in this process, one task after another (numba uses all cores, or ``--threads``);
* ``local`` (the default): a ``distributed.LocalCluster`` on 127.0.0.1 with one worker process per
  core (``--workers N`` to choose), one thread each and ``NUMBA_NUM_THREADS=1`` in the workers'
  environment. A run whose estimated cost is below :data:`LOCAL_MIN_SECONDS` (or that has a
  single task) runs in-process instead, since starting the cluster costs seconds;
* an address (``tcp://host:8786``): an existing Dask cluster. The workers must be able to import
  this project and read the mesh files by the same paths (a shared filesystem).

A task that raises is retried once; a task whose worker process dies is re-run elsewhere by
Dask's scheduler (up to ``distributed.scheduler.allowed-failures`` times). A task that still fails
is reported to ``on_failure`` with a one-line error and the others go on; a task that raises
:class:`tracer.errors.CLIError` (bad input) stops the study.

A worker loads what a task names by path (a mesh, a trajectory) and caches what it builds from
it (a field, a scene) under the file's :func:`file_stamp`, so that only the small task dict
travels through the scheduler.
"""

import asyncio
import csv
import inspect
import io
import logging
import math
import os
import socket
import sys
import time
import uuid

from tracer.compiling import COMPILING, Eta
from tracer.errors import CLIError
from tracer.outputs import csv_value, write_csv

#: below this estimated serial cost (seconds) ``--scheduler local`` runs in-process
LOCAL_MIN_SECONDS = 10.0
#: seconds to wait for an existing scheduler to answer
CONNECT_TIMEOUT = 3.0
#: retries of a task that raised (lost workers are handled by Dask separately)
RETRIES = 1
#: columns the runner adds to every record
META_FIELDS = ["status", "error", "task_seconds", "worker"]


def add_arguments(p):
    """``--scheduler`` and ``--workers``."""
    p.add_argument("--scheduler", default="local", metavar="local|serial|ADDRESS",
                   help="where the tasks run: 'local' (default: a Dask LocalCluster with one "
                   "worker process per core; tiny runs stay in-process), 'serial' (in this "
                   "process) or the address of a running Dask scheduler, e.g. tcp://host:8786")
    p.add_argument("--workers", type=int, metavar="N",
                   help="worker processes of the local cluster (default: one per core)")
    return p


def file_stamp(path):
    """``(absolute path, mtime_ns, size)``: a cache key that changes when the file does."""
    st = os.stat(path)
    return (os.path.abspath(path), st.st_mtime_ns, st.st_size)


def duration(s):
    """``12.3s``, ``4.5min`` or ``1.25h``."""
    if s < 90:
        return f"{s:.1f}s"
    if s < 5400:
        return f"{s / 60:.1f}min"
    return f"{s / 3600:.2f}h"


def cpu_count():
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def check_arguments(args):
    """Validate ``--scheduler``/``--workers`` before any work (one-line errors)."""
    sched = getattr(args, "scheduler", "local") or "local"
    workers = getattr(args, "workers", None)
    if workers is not None and not 1 <= workers <= 256:
        raise CLIError(f"--workers must be between 1 and 256, got {workers}")
    if workers is not None and sched != "local":
        raise CLIError("--workers applies to --scheduler local only")
    if sched not in ("local", "serial"):
        check_reachable(sched)
    return sched, workers


def needs(args):
    """``["distributed"]`` when ``--scheduler``/``--workers`` ask for a Dask cluster whatever
    the run's size (an address, or ``--workers``), else ``[]`` (``local`` alone may run
    in-process: :func:`choose_mode`). For a command's ``needs`` (:mod:`tracer.cli`)."""
    sched = getattr(args, "scheduler", "local") or "local"
    if sched == "serial" or (sched == "local" and getattr(args, "workers", None) is None):
        return []
    return ["distributed"]


def check_reachable(address, timeout=CONNECT_TIMEOUT):
    """Fail fast, before a study creates any output, when no Dask scheduler answers at
    ``address``: one-line :class:`~tracer.errors.CLIError` after at most about ``timeout``
    seconds."""
    scheme, host, port = _split_address(address)
    addr = f"{scheme}://{host}:{port}" if ":" not in host else f"{scheme}://[{host}]:{port}"

    async def identity():
        from distributed.comm import connect  # dask.distributed (studies extra): loaded on use

        comm = await connect(addr, timeout=timeout)
        try:
            await comm.write({"op": "identity", "reply": True})
            return await comm.read()
        finally:
            comm.abort()

    try:
        reply = asyncio.run(asyncio.wait_for(identity(), timeout + 1.0))
    except ImportError:
        raise CLIError("dask.distributed is not installed (pip install 'smoothdist[studies]'); use "
                       "--scheduler serial") from None
    except KeyboardInterrupt:
        raise
    except BaseException as exc:  # refused, timed out, or something else answering
        if isinstance(exc, (TimeoutError, asyncio.TimeoutError)):
            reason = "no answer"
        elif isinstance(exc, OSError):
            reason = _error_line(exc)
        else:  # e.g. an HTTP proxy answering: its reply is not Dask's protocol
            reason = "something that is not a Dask scheduler answers there"
        raise CLIError(f"cannot reach the Dask scheduler at {address}: {reason} (waited at "
                       f"most {timeout:g} s)") from None
    if not (isinstance(reply, dict) and reply.get("type") == "Scheduler"):
        raise CLIError(f"{address} did not answer as a Dask scheduler")


def _split_address(address):
    """``tcp://host:port`` (or ``host:port``) -> ``(scheme, host, port)``; one-line errors."""
    scheme, sep, rest = address.rpartition("://")
    scheme = scheme if sep else "tcp"
    host, sep, port = rest.rpartition(":")
    if not sep or not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise CLIError(f"--scheduler: {address!r} is not 'local', 'serial' or a scheduler "
                       "address like tcp://host:8786")
    return scheme, host.strip("[]"), int(port)


# =============================================================================== task log
class TaskLog:
    """One CSV row per finished task, appended (and flushed to disk) as results arrive.

    ``fields`` are the study's columns; :data:`META_FIELDS` are added. Rows are read back as
    strings; a truncated last line (an interrupted append) is dropped. ``done_keys`` are the
    keys of rows whose status is not ``failed`` (``skipped`` rows, e.g. a mesh that cannot be
    loaded, count as done: they would fail again).
    """

    def __init__(self, path, fields, key="key"):
        self.path = path
        self.key = key
        self.fields = list(fields) + [f for f in META_FIELDS if f not in fields]

    def read(self, required=()):
        if not os.path.exists(self.path):
            return []

        with open(self.path, "r", encoding="utf-8", newline="") as fh:
            reader = csv.DictReader(fh)
            missing = [c for c in (self.key, "status", *required)
                       if c not in (reader.fieldnames or [])]
            if missing:
                raise CLIError(f"{self.path}: not a results file of this command (missing "
                               f"column(s) {', '.join(missing)}); use another folder or "
                               "--overwrite")
            n = len(reader.fieldnames)
            rows = [r for r in reader if None not in r and len(r) == n and r.get(self.key)
                    and r.get("status")]
        latest = {}
        for r in rows:  # the last row of a key wins (a failed task that later succeeded)
            latest.pop(r[self.key], None)
            latest[r[self.key]] = r
        return list(latest.values())

    def done_keys(self, rows=None):
        rows = self.read() if rows is None else rows
        return {r[self.key] for r in rows if r.get("status") != "failed"}

    def start(self, rows=()):
        """(Re)write the file with ``rows`` (atomically); later rows are appended."""
        write_csv(self.path, self.fields, list(rows))

    def append(self, row):

        buf = io.StringIO()
        csv.DictWriter(buf, fieldnames=self.fields, extrasaction="ignore",
                       lineterminator="\n").writerow({k: csv_value(v) for k, v in row.items()})
        with open(self.path, "a", encoding="utf-8", newline="") as fh:
            fh.write(buf.getvalue())
            fh.flush()
            os.fsync(fh.fileno())


# =============================================================================== progress
class StudyProgress:
    """A progress bar over a study's weighted tasks: tasks done and failed, elapsed time, ETA.

    Each task has an a-priori weight (its expected cost). ``item(w)`` returns a callback that an
    in-process task reports its own progress to (``done, total, elapsed`` like
    :class:`tracer.rendering.frame.ProgressBar`); ``finish(w, line)`` marks a task done and logs a
    line, ``fail(w, line)`` marks it failed. On a terminal the bar redraws in place; in a log it
    prints one line per finished task. While numba compiles in this process (in-process tasks)
    the bar says so, and the ETA counts only the progress made after the compilation
    (:class:`tracer.compiling.Eta`).
    """

    def __init__(self, label, total_weight, n_tasks=None, stream=None, quiet=False):
        self.label = label
        self.total = max(float(total_weight), 1e-12)
        self.n_tasks = n_tasks
        self.done = 0.0
        self.n_done = 0
        self.n_failed = 0
        self.t0 = time.perf_counter()
        self.stream = stream or sys.stderr
        self.quiet = quiet
        self.tty = getattr(self.stream, "isatty", lambda: False)()
        self._last = 0.0
        self.eta = Eta()

    def _text(self, frac):
        elapsed = time.perf_counter() - self.t0
        eta = self.eta.left(min(frac, 1.0), elapsed)
        bar = "#" * int(30 * min(frac, 1.0))
        eta_s = "?" if eta is None or not math.isfinite(eta) else duration(eta)
        count = f"{self.n_done}/{self.n_tasks} done" if self.n_tasks else f"{self.n_done} done"
        if self.n_failed:
            count += f", {self.n_failed} failed"
        left = COMPILING if self.eta.compiling else f"~{eta_s} left"
        return (f"{self.label} [{bar:<30}] {100 * min(frac, 1.0):5.1f}% {count}, "
                f"{duration(elapsed)} elapsed, {left}")

    def _draw(self, frac, force=False):
        if self.quiet or not self.tty:
            return
        now = time.perf_counter()
        if not force and now - self._last < 0.2:
            return
        self._last = now
        self.stream.write("\r\033[K" + self._text(frac))
        self.stream.flush()

    def item(self, weight):
        def cb(done, total, elapsed):
            self._draw((self.done + weight * done / max(total, 1)) / self.total)

        def waiting(elapsed):  # nothing done yet (tracer.render): numba compiling?
            if self.eta.compiling:
                self._draw(self.done / self.total)
        cb.waiting = waiting
        return cb

    def finish(self, weight, line="", failed=False):
        self.done += weight
        if failed:
            self.n_failed += 1
        else:
            self.n_done += 1
        if self.quiet:
            return
        frac = self.done / self.total
        if self.tty:
            self.stream.write("\r\033[K")
            if line:
                self.stream.write(line + "\n")
            self._draw(frac, force=True)
            if frac >= 1 - 1e-9:
                self.stream.write("\n")
        else:
            self.stream.write((line + "  " if line else "") + "| " + self._text(frac) + "\n")
        self.stream.flush()

    def log(self, line):
        if self.quiet:
            return
        if self.tty:
            self.stream.write("\r\033[K" + line + "\n")
            self._draw(self.done / self.total, force=True)
        else:
            self.stream.write(line + "\n")
        self.stream.flush()


# =============================================================================== running
def call_task(fn, task, progress=None):
    """Run ``fn(task)`` (``fn(task, progress=cb)`` in-process when ``fn`` takes a progress
    callback) and add the runner's columns (status, worker id, task wall time) to its record.
    This is what executes on a Dask worker."""
    t0 = time.perf_counter()
    if progress is not None and "progress" in inspect.signature(fn).parameters:
        record = fn(task, progress=progress)
    else:
        record = fn(task)
    record = dict(record)
    record.setdefault("status", "ok")
    record.setdefault("error", "")
    record["task_seconds"] = time.perf_counter() - t0
    record["worker"] = f"{socket.gethostname()}:{os.getpid()}"
    return record


class RunInfo:
    """How a run went: ``mode`` (``serial``, ``local``, ``address``), ``workers``, ``dashboard``
    (URL or None), ``done``, ``failed`` (``[(key, error)]``) and ``seconds`` (wall time)."""

    def __init__(self, mode, workers=1, dashboard=None):
        self.mode = mode
        self.workers = workers
        self.dashboard = dashboard
        self.done = 0
        self.failed = []
        self.seconds = 0.0

    def describe(self):
        if self.mode == "serial":
            return "in-process"
        if self.mode == "local":
            return f"local Dask cluster, {self.workers} worker(s) x 1 thread"
        return f"Dask scheduler {self.mode} ({self.workers} worker(s))"


def choose_mode(scheduler, workers, n_tasks, estimate=None):
    """``"serial"``, ``"local"`` or the scheduler address, for ``n_tasks`` tasks with an
    estimated serial cost of ``estimate`` seconds (None: unknown)."""
    if scheduler == "serial":
        return "serial"
    if scheduler != "local":
        return scheduler
    if workers is None and (n_tasks <= 1 or cpu_count() == 1 or (
            estimate is not None and estimate < LOCAL_MIN_SECONDS)):
        return "serial"
    return "local"


def _error_line(exc):
    text = str(exc).strip()
    first = text.splitlines()[0] if text else ""
    return f"{type(exc).__name__}: {first}" if first else type(exc).__name__


def run_study(fn, tasks, *, on_result, on_failure=None, scheduler="local", workers=None,
              estimate=None, label="study", quiet=False, line=None, progress=None,
              retries=RETRIES):
    """Run ``fn`` on every task; returns a :class:`RunInfo`.

    ``on_result(task, record)`` and ``on_failure(task, error_line)`` are called in this process
    as results arrive. ``line(task, record)`` gives the log line of a finished task. ``progress``
    (a :class:`StudyProgress`) is created when not given.
    """
    tasks = list(tasks)
    mode = choose_mode(scheduler, workers, len(tasks), estimate) if tasks else "serial"
    total = sum(float(t.get("weight", 1.0)) for t in tasks)
    prog = progress or StudyProgress(label, total, n_tasks=len(tasks), quiet=quiet)
    t0 = time.perf_counter()

    def ok(task, record):
        on_result(task, record)
        info.done += 1
        prog.finish(float(task.get("weight", 1.0)), line(task, record) if line else "")

    def bad(task, err):
        info.failed.append((task["key"], err))
        if on_failure is not None:
            on_failure(task, err)
        prog.finish(float(task.get("weight", 1.0)), f"FAILED {task['key']}: {err}", failed=True)

    if mode == "serial":
        info = RunInfo("serial")
        for task in tasks:
            err = None
            for _ in range(retries + 1):
                try:
                    record = call_task(fn, task, prog.item(float(task.get("weight", 1.0))))
                    break
                except (KeyboardInterrupt, MemoryError, CLIError):
                    raise
                except Exception as exc:  # recorded, the study goes on
                    err = _error_line(exc)
            else:
                bad(task, err)
                continue
            ok(task, record)
        info.seconds = time.perf_counter() - t0
        return info

    client, cluster = connect(mode, workers)
    try:
        nworkers = len(client.scheduler_info().get("workers", {}))
        info = RunInfo(mode, nworkers, _dashboard(client, local=cluster is not None))
        if not quiet:
            dash = (f"; dashboard {info.dashboard}" if info.dashboard
                    else "; no dashboard (it needs bokeh: pip install bokeh)")
            prog.log(f"{label}: {len(tasks)} task(s) on {info.describe()} at "
                     f"{client.scheduler.address}{dash}"
                     + ("; waiting for workers to join" if not nworkers else ""))
        from distributed import as_completed  # dask.distributed (studies extra): loaded on use

        # Our client is not the process's default client (a user's own client stays the
        # default), and a separate process has none: whatever looks a client up
        # (as_completed, Future.result) must find ours, the current one in this block.
        with client.as_current():
            run = uuid.uuid4().hex[:8]
            futures, index = [], {}
            # heaviest first (Dask runs higher priority first), so that the long tasks overlap
            order = sorted(range(len(tasks)),
                           key=lambda i: -float(tasks[i].get("weight", 1.0)))
            for rank, i in enumerate(order):
                fut = client.submit(call_task, fn, tasks[i],
                                    key=f"{label.split()[0]}-{run}-{i}", pure=False,
                                    retries=retries, priority=len(tasks) - rank)
                futures.append(fut)
                index[fut.key] = i
            try:
                for fut in as_completed(futures, loop=client.loop):
                    task = tasks[index[fut.key]]
                    try:
                        record = fut.result()
                    except CLIError:  # bad input: stop the study
                        raise
                    except Exception as exc:  # the task raised (after its retries) or was lost
                        bad(task, _error_line(exc))
                        continue
                    ok(task, record)
            except BaseException:
                client.cancel(futures)
                raise
        info.seconds = time.perf_counter() - t0
        return info
    finally:
        _shutdown(client, cluster)


def connect(mode, workers=None, timeout=CONNECT_TIMEOUT):
    """``(client, cluster)``: a LocalCluster (``mode == "local"``) or a client of the scheduler
    at the address ``mode`` (cluster None). One-line :class:`~tracer.errors.CLIError` when it cannot
    be had."""
    try:
        # dask.distributed (studies extra): loaded on use
        from distributed import Client, LocalCluster
    except ImportError:
        raise CLIError("dask.distributed is not installed (pip install 'smoothdist[studies]'); use "
                       "--scheduler serial") from None
    if mode == "local":
        n = workers or cpu_count()
        # the scheduler's HTTP server (dashboard) on a free local port, never on 0.0.0.0
        kw = dict(n_workers=n, threads_per_worker=1, processes=True, host="127.0.0.1",
                  dashboard_address="127.0.0.1:0", silence_logs=logging.ERROR,
                  env={"NUMBA_NUM_THREADS": "1"})
        try:
            cluster = LocalCluster(**kw)
        except Exception as exc:
            raise CLIError(f"cannot start a local Dask cluster: {_error_line(exc)}") from None
        try:  # not the default client either: see run_study
            return Client(cluster, set_as_default=False), cluster
        except BaseException:
            cluster.close()
            raise
    scheme, host, port = _split_address(mode)
    address = f"{scheme}://{host}:{port}" if ":" not in host else f"{scheme}://[{host}]:{port}"
    try:
        client = Client(address, timeout=f"{timeout}s", set_as_default=False)
    except KeyboardInterrupt:
        raise
    except Exception as exc:
        raise CLIError(f"cannot reach the Dask scheduler at {mode} (no answer within "
                       f"{timeout:g} s): {_error_line(exc)}") from None
    return client, None


def _dashboard(client, local=True):
    """The dashboard's URL, or None when the scheduler has none (its pages need bokeh in the
    scheduler's environment: checked here for a local cluster)."""
    if local:
        try:
            # bokeh (with dask's dashboard): loaded on use
            import bokeh  # noqa: F401
        except ImportError:
            return None
    try:
        if client.scheduler_info().get("services", {}).get("dashboard"):
            return client.dashboard_link
    except Exception:
        pass
    return None


def _shutdown(client, cluster):
    for thing in (client, cluster):
        if thing is None:
            continue
        try:
            thing.close()
        except Exception:
            pass
