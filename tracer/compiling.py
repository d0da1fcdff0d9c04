"""Numba compilations as they happen, for the progress displays.

The first run on a machine compiles the numba kernels (seconds; later runs load them from the
cache, which is no compilation: numba sends no event for it). A progress display that knew
nothing of it would divide the time left by a rate with the compile time in it and show an
ETA tens of times too long. :func:`compile_watch` registers one listener of numba's
``numba:compile`` events per process, on first use; :class:`Eta` says whether numba is
compiling now and computes the time left from the progress made since the last compilation
ended. :class:`tracer.rendering.frame.ProgressBar` and :class:`tracer.runner.StudyProgress` show
:data:`COMPILING` while numba compiles.

A first render can compile its kernels in a second process meanwhile
(:mod:`tracer.scenes.compile_ahead`): :func:`start_ahead` starts that child where it helps (within
:func:`ahead_allowed`), :func:`wait_ahead` waits for it before the film; the two share out the
trace and the film through files in a folder of their own (:func:`claim_job`). A first
simulation step does the same with its whole-mesh kernels (:mod:`tracer.sim.compile_ahead`).
"""

import atexit
import glob
import json
import os
import select
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from contextlib import contextmanager

from numba.core import event

from smoothdist.warmup import cache_folder, switched_off

__all__ = ["COMPILING", "CompileWatch", "compile_watch", "Eta", "ahead", "ahead_running",
           "wait_ahead",
           "AHEAD_WAIT", "AHEAD_ENV", "AHEAD_TAGS", "ahead_allowed", "ahead_config", "ahead_needed",
           "ahead_possible", "spawn_ahead", "start_ahead", "AHEAD_TRACE_ENV", "claim",
           "claim_job", "claim_trace", "tell_children", "wait_for"]

#: what the progress displays say while numba compiles
COMPILING = "compiling kernels (once per machine)"


class CompileWatch(event.Listener):
    """A listener of numba's ``numba:compile`` events: ``depth`` compilations open now (a
    kernel's callees compile inside it), ``ended`` the ``time.perf_counter()`` at which the
    last outermost one ended (None before any). Numba compiles under its global compiler
    lock, so one thread at a time changes them."""

    def __init__(self):
        self.depth = 0
        self.ended = None

    def on_start(self, ev):
        self.depth += 1

    def on_end(self, ev):
        self.depth = max(0, self.depth - 1)  # registered during a compilation: no start seen
        if self.depth == 0:
            self.ended = time.perf_counter()

    @property
    def compiling(self):
        return self.depth > 0


_WATCH = None
_LOCK = threading.Lock()


def compile_watch():
    """The process's :class:`CompileWatch`, registered with numba on the first call."""
    global _WATCH
    with _LOCK:
        if _WATCH is None:
            watch = CompileWatch()
            event.register("numba:compile", watch)
            _WATCH = watch
    return _WATCH


class Eta:
    """The time left of a run from the fraction done, counting only the progress made since
    numba last finished compiling (before that, the rate would include the compile time).

    Parameters
    ----------
    watch : CompileWatch, optional
        Default: the process's (:func:`compile_watch`).
    """

    def __init__(self, watch=None):
        self.watch = watch or compile_watch()
        self._base = (0.0, 0.0)  # (fraction, elapsed) the rate is measured from
        self._seen = (0.0, 0.0)  # the last (fraction, elapsed) given
        self._ended = None       # the compilation end the base was last set for

    @property
    def compiling(self):
        """Whether numba is compiling now."""
        return self.watch.compiling

    def left(self, frac, elapsed):
        """Seconds left at ``frac`` (0-1) done after ``elapsed`` seconds (the caller's clock);
        None while numba compiles, and until there is progress after the compilation.

        A compilation that ended during the run moves the start of the rate to its end, with
        the fraction seen last before it (progress while compiling is slight: the threads wait
        for the compiled kernel)."""
        if elapsed < self._seen[1]:  # the clock started again: a new run
            self._base = self._seen = (0.0, 0.0)
        ended = self.watch.ended
        if ended is not None and ended != self._ended:
            self._ended = ended
            end = elapsed - (time.perf_counter() - ended)  # on the caller's clock
            if end > self._base[1]:
                self._base = (min(self._seen[0], frac), end)
        self._seen = (frac, elapsed)
        f0, e0 = self._base
        if self.watch.compiling or frac <= f0 or elapsed <= e0:
            return None
        return (elapsed - e0) * (1.0 - frac) / (frac - f0)


# ------------------------------------------------------------- compiling in another process
#: the environment variable that turns compiling ahead off (``off``, ``0``, ``no``, ``false``)
AHEAD_ENV = "TRACER_COMPILE_AHEAD"
#: the environment variable naming a file that a child's error output is appended to (by
#: default it goes nowhere: a child that fails leaves the render to compile, as without it)
AHEAD_LOG_ENV = "TRACER_COMPILE_AHEAD_LOG"
#: the film's own kernel whose cache index says that a lit film's kernels are compiled
AHEAD_MARKER = os.path.join("tracer.rendering", "lighting.light_tasks-*.nbi")
#: the scene distance's kernel, whose cache index says the same of an unlit render's
AHEAD_DISTANCE_MARKER = os.path.join("tracer.rendering", "march.distance_at-*.nbi")
#: the child's code: :func:`tracer.scenes.compile_ahead.child_main` of its JSON argument
AHEAD_CHILD = ("import sys; from tracer.scenes import compile_ahead; "
               "compile_ahead.child_main(sys.argv[1])")
_AHEAD = []
_ALLOWED = []


@contextmanager
def ahead_allowed(on=True):
    """Within this block :func:`start_ahead` may start a child (``on`` False: may not): the
    entry points that own their process and render once on the CPU (``tracer render``,
    :func:`tracer.render_mesh`) allow it."""
    _ALLOWED.append(bool(on))
    try:
        yield
    finally:
        _ALLOWED.pop()
        _forget_ended()


def _forget_ended():
    """Forget the children of :func:`ahead` that have ended (their job folders removed); one
    still compiling is left to finish (it is stopped at this process's exit)."""
    with _LOCK:
        ended = [p for p in _AHEAD if p.poll() is not None]
        _AHEAD[:] = [p for p in _AHEAD if p not in ended]
    for p in ended:
        _stop(p)


def ahead_config(march, film, objects):
    """What the child's scene copies (a dict for JSON; :mod:`tracer.scenes.compile_ahead`): the
    number of ``objects``, the ``mode``, ``tol`` and ``beta`` of the scene's ``march`` settings
    and the settings of its ``film`` that choose the film's kernels."""
    return {"objects": int(objects), "mode": str(march.mode), "tol": float(march.tol),
            "beta": float(march.beta), "shading": str(film.shading),
            "samples": int(film.samples), "adaptive": bool(film.adaptive),
            "transparent": bool(film.transparent)}


def ahead_possible(marker):
    """Whether a child compiling ahead can help this process: compiling ahead allowed
    (:func:`ahead_allowed`) and not turned off (:data:`AHEAD_ENV`), POSIX, a second core, the
    per-machine kernel cache (``smoothdist.warmup.cache_folder``) active and without the index
    file that the glob ``marker`` (relative to the cache folder) names."""
    if not (_ALLOWED and _ALLOWED[-1]) or switched_off(os.environ.get(AHEAD_ENV, "")):
        return False
    if os.name != "posix":
        return False        # the child's progress is read with select(), which needs POSIX pipes
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    if (cores or 1) < 2:
        return False
    folder = cache_folder()
    return folder is not None and not glob.glob(os.path.join(folder, marker))


def ahead_needed(cfg):
    """Whether a render of ``cfg`` (:func:`ahead_config`) needs kernels that a child should
    compile now: :func:`ahead_possible` without the light's kernels in the cache (a lit
    render), or without the scene distance's (any other: the child compiles that distance
    while the render builds its tree)."""
    return ahead_possible(AHEAD_MARKER if cfg["shading"] == "lit" else AHEAD_DISTANCE_MARKER)


def start_ahead(march, film, objects):
    """Start a child that compiles the film kernels of a render with these settings (``march``,
    ``film``: the scene's groups, given before they are checked; ``objects``: how many) when
    :func:`ahead_needed`, registered with :func:`ahead`. Returns whether one started."""
    try:
        cfg = ahead_config(march, film, objects)
    except (TypeError, ValueError, AttributeError):
        return False        # a setting the scene's own checks will refuse, with a message
    if not ahead_needed(cfg):
        return False
    try:
        claims = tempfile.mkdtemp(prefix="tracer-ahead-")
    except OSError:         # no temporary folder to write: the child compiles the film
        return spawn_ahead(AHEAD_CHILD, json.dumps(cfg))
    if os.environ.get(AHEAD_TRACE_ENV, "").strip() == "render":
        claim(claims, "trace")     # taken before the child starts: the render traces
    if spawn_ahead(AHEAD_CHILD, json.dumps(dict(cfg, claims=claims)), claims):
        return True
    shutil.rmtree(claims, ignore_errors=True)
    return False


def claim(folder, name):
    """Take the job ``name`` in ``folder`` (shared by a render and its child): True for the
    one process whose file creation succeeds, False for the other."""
    try:
        os.close(os.open(os.path.join(folder, name), os.O_CREAT | os.O_EXCL | os.O_WRONLY))
    except OSError:         # taken already; or no folder (removed, unwritable)
        return False
    return True


def tell_children(name):
    """Leave the file ``name`` in the folder of every child of :func:`start_ahead` (the render
    says ``march`` when it has compiled its march, which the child's ground probe then loads:
    :func:`wait_for`)."""
    with _LOCK:
        folders = [p.claims for p in _AHEAD if getattr(p, "claims", None)]
    for folder in folders:
        claim(folder, name)


def wait_for(folder, name, timeout=None):
    """Wait (a child, :mod:`tracer.scenes.compile_ahead`) until the file ``name`` is in
    ``folder`` (:func:`tell_children`), the folder is gone (the render ended) or ``timeout``
    seconds (default :data:`AHEAD_WAIT`) have passed. Returns False for the last (timed out)."""
    deadline = time.perf_counter() + (AHEAD_WAIT if timeout is None else timeout)
    path = os.path.join(folder, name)
    while not os.path.exists(path) and os.path.isdir(folder):
        if time.perf_counter() >= deadline:
            return False
        time.sleep(0.02)
    return True


def claim_trace():
    """Whether this process compiles its trace kernel itself: True unless a child of
    :func:`start_ahead` has taken it (the child takes it when it has compiled the scene's
    distance before this process asks, :mod:`tracer.scenes.compile_ahead`; the process that
    does not compile the trace compiles the film's kernels). :data:`AHEAD_TRACE_ENV` set to
    ``child`` leaves it to the child."""
    forced = os.environ.get(AHEAD_TRACE_ENV, "").strip()
    if forced in ("child", "render"):
        return forced == "render" or not ahead_running()     # start_ahead took it for "render"
    return claim_job("trace")


def claim_job(name):
    """Whether this process compiles the kernels of job ``name`` itself: True unless a child of
    :func:`start_ahead` has taken it first (:func:`claim`)."""
    with _LOCK:
        children = [p for p in _AHEAD if getattr(p, "claims", None)]
    # a job taken before (a later frame of the same process) is still this process's
    if not all(name in p.mine or claim(p.claims, name) for p in children):
        return False
    for p in children:
        p.mine.add(name)        # not to be waited for (wait_ahead)
    return True


def spawn_ahead(code, arg, claims=None):
    """Start ``python -c code arg``, a child that compiles kernels ahead and prints its tags
    (:data:`AHEAD_TAGS`), its error output to :data:`AHEAD_LOG_ENV`'s file, registered with
    :func:`ahead` (``claims``: the folder of its jobs, :func:`claim_trace`, removed when it is
    waited for or stopped). Returns whether it started."""
    err = _ahead_log()
    try:
        # unbuffered: a line read leaves nothing behind in a buffer that select cannot see
        p = subprocess.Popen([sys.executable, "-c", code, arg], stdin=subprocess.DEVNULL,
                             stdout=subprocess.PIPE, stderr=err, bufsize=0)
    except OSError:         # no process to spare: this one compiles, as before
        return False
    finally:
        if err is not subprocess.DEVNULL:
            err.close()     # the child holds its own copy
    ahead(p, claims)
    return True


def _ahead_log():
    """Where a child's error output goes: the file :data:`AHEAD_LOG_ENV` names (appended to,
    after a line saying which process starts), or nowhere."""
    path = os.environ.get(AHEAD_LOG_ENV, "").strip()
    if not path:
        return subprocess.DEVNULL
    try:
        f = open(path, "ab")
        f.write(f"{time.strftime('%Y-%m-%d %H:%M:%S')} tracer: compile-ahead child of "
                f"process {os.getpid()}\n".encode())
        f.flush()
        return f
    except OSError:         # a log that cannot be written is no reason to stop a render
        return subprocess.DEVNULL
#: the longest a render waits for a child compiling its film's kernels (seconds): then it
#: compiles what is left itself
AHEAD_WAIT = 300.0


def ahead(process, claims=None):
    """Register ``process`` (a ``subprocess.Popen`` whose stdout is an unbuffered pipe), a child
    compiling kernels this process will need into the per-machine cache
    (:mod:`tracer.scenes.compile_ahead`); it prints a line with a tag as each group of them is
    done (:data:`AHEAD_TAGS`). ``claims``: the folder where it and this process share out
    their jobs (:func:`claim_trace`), or None."""
    process.tags = set()
    process.claims = claims
    process.mine = set()
    with _LOCK:
        _AHEAD.append(process)


#: what a child says when a group of kernels is in the cache (or is not its job: it says so
#: at once): ``"distance"`` the scene's distance (:func:`tracer.rendering.march.distance_at`
#: and its callees, which the trace shares), ``"march"`` the march
#: (:func:`tracer.rendering.march.march_ray`) and ``"trace"`` the trace kernel when it took the
#: trace (:func:`claim_trace`), ``"normals"`` the shading normals'
#: (:func:`tracer.rendering.march.gradient_tasks`), ``"light"`` the light's and the ground
#: probe's, ``"samples"`` the samples' kernel of a render of several samples per pixel (last),
#: ``"done"`` everything (a simulation's child, :mod:`tracer.sim.compile_ahead`, says only
#: this)
AHEAD_TAGS = ("distance", "march", "trace", "normals", "light", "samples", "done")
#: the environment variable that decides who compiles a first render's trace kernel, for the
#: tests and the benchmarks: ``render`` (the render), ``child`` (its child); unset, the child
#: when it has compiled the scene's distance before the render asks (:func:`claim_trace`)
AHEAD_TRACE_ENV = "TRACER_COMPILE_AHEAD_TRACE"


def ahead_running():
    """Whether a child of :func:`ahead` is compiling for this process now (not yet waited for
    to its end, and not ended)."""
    with _LOCK:
        return any(p.poll() is None for p in _AHEAD)


def wait_ahead(tag="done", timeout=AHEAD_WAIT):
    """Wait until every child of :func:`ahead` has said ``tag`` (:data:`AHEAD_TAGS`), or
    ended: this process then loads those kernels instead of compiling them again. At
    ``"done"`` the children are forgotten; one still running after ``timeout`` seconds is
    stopped. A job this process has taken (:func:`claim_job`) is not waited for. Returns the
    seconds waited."""
    t0 = time.perf_counter()
    with _LOCK:
        pending = [p for p in _AHEAD if tag not in getattr(p, "mine", ())]
        if tag == "done":
            _AHEAD[:] = []
    for p in pending:
        try:
            _read_until(p, tag, t0 + timeout)
            if tag == "done":
                p.wait(max(0.0, t0 + timeout - time.perf_counter()))
                _stop(p)
        except BaseException as exc:    # too long, or interrupted: the child stops too
            _stop(p)
            if not isinstance(exc, (subprocess.TimeoutExpired, TimeoutError)):
                raise
    return time.perf_counter() - t0


def _read_until(p, tag, deadline):
    """Read ``p``'s lines until it has said ``tag`` or closed its output; TimeoutError at
    ``deadline`` (``time.perf_counter()``)."""
    while tag not in p.tags and p.stdout is not None and not p.stdout.closed:
        left = deadline - time.perf_counter()
        if left <= 0 or not select.select([p.stdout], [], [], left)[0]:
            raise TimeoutError(tag)
        line = p.stdout.readline()
        if not line:        # the child ended (or failed): nothing more will come
            p.stdout.close()
            return
        p.tags.add(line.decode("ascii", "replace").strip())


def _stop(p):
    if p.poll() is None:
        p.kill()
    p.wait()
    if p.stdout is not None:
        p.stdout.close()
    if getattr(p, "claims", None):
        shutil.rmtree(p.claims, ignore_errors=True)


@atexit.register
def _stop_ahead():
    """A process that ends before its render's film stops its children (they would only
    finish compiling into the cache)."""
    with _LOCK:
        pending, _AHEAD[:] = list(_AHEAD), []
    for p in pending:
        _stop(p)
