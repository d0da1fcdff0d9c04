"""Python threads for a render's per-pixel work: the serial, GIL-free task kernels and numpy
loops that release the GIL (:func:`~tracer.rendering.threads.run_tasks`,
:func:`~tracer.rendering.threads.in_bands`), with numba's thread count."""

import numba

from smoothdist.kernels import PARALLEL
from smoothdist.schedule import run_tasks as _run_tasks

__all__ = ["render_threads", "in_bands", "run_tasks"]


def render_threads():
    """Threads that trace a render: numba's thread count (``numba.set_num_threads``,
    ``tracer render --threads``), 1 with ``SMOOTHDIST_PARALLEL=0``."""
    return numba.get_num_threads() if PARALLEL else 1


def in_bands(fn, rows, threads=None):
    """Call ``fn(r0, r1)`` for bands of rows covering ``0 <= r < rows``, one band per thread
    (default :func:`render_threads`), from Python threads: for per-pixel numpy work, whose
    array loops release the GIL. Bands of at least 16 rows; exceptions are re-raised here."""
    bands = max(1, min(threads or render_threads(), rows // 16))
    run_tasks(lambda a, b: fn(rows * a // bands, rows * b // bands), bands, bands)


def run_tasks(fn, ntasks, threads=None):
    """Call ``fn(task0, task1)`` over tasks ``0 <= task < ntasks``, split into contiguous
    groups, one per thread (at most :func:`render_threads`), from Python threads: for the
    serial, GIL-free task kernels (``tracer.rendering.march.sample_tasks``,
    ``tracer.rendering.lighting.light_tasks``), whose tasks are independent, so the result does not
    depend on the split (:func:`smoothdist.schedule.run_tasks`). Exceptions are re-raised
    here."""
    _run_tasks(fn, ntasks, threads or render_threads())
