"""Python threads for a render's per-pixel numpy loops that release the GIL
(:func:`~tracer.rendering.threads.in_bands`), with numba's thread count. The serial, GIL-free
task kernels run on :func:`smoothdist.schedule.run_tasks`, the one runner of thread tasks."""

import numba

from smoothdist.kernels import PARALLEL
from smoothdist.schedule import run_tasks

__all__ = ["render_threads", "in_bands"]


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

