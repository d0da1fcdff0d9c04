"""Numba compilations as they happen, for the progress displays.

The first run on a machine compiles the numba kernels (seconds; later runs load them from the
cache, which is no compilation: numba sends no event for it). A progress display that knew
nothing of it would divide the time left by a rate with the compile time in it and show an
ETA tens of times too long. :func:`compile_watch` registers one listener of numba's
``numba:compile`` events per process, on first use; :class:`Eta` says whether numba is
compiling now and computes the time left from the progress made since the last compilation
ended. :class:`tracer.rendering.frame.ProgressBar` and :class:`tracer.runner.StudyProgress` show
:data:`COMPILING` while numba compiles.
"""

import threading
import time

from numba.core import event

__all__ = ["COMPILING", "CompileWatch", "compile_watch", "Eta"]

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
