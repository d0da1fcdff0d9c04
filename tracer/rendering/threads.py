"""Python threads for a render's per-pixel numpy loops that release the GIL
(:func:`~tracer.rendering.threads.in_bands`), with numba's thread count. The serial, GIL-free
task kernels run on :func:`smoothdist.schedule.run_tasks`, the one runner of thread tasks."""

import numba

from smoothdist.kernels import PARALLEL
from smoothdist.schedule import run_tasks

__all__ = ["render_threads", "in_bands", "in_chunks", "CHUNK"]

#: items per chunk of :func:`in_chunks`: a chunk's (n, 3) float64 temporaries (1.5 MB) stay
#: in a core's cache from one numpy step to the next
CHUNK = 1 << 16


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



def in_chunks(fn, n, threads=None, chunk=CHUNK):
    """Call ``fn(i0, i1)`` for chunks of ``chunk`` items covering ``0 <= i < n``, the chunks
    shared out over the render's threads (:func:`in_bands`' threads): for per-item numpy
    steps, which then run from cache on every core; ``fn`` must touch items ``i0 <= i < i1``
    only. Exceptions are re-raised here."""
    count = -(-int(n) // chunk)
    if count <= 1:
        fn(0, int(n))
        return

    def chunks(c0, c1):
        for c in range(c0, c1):
            fn(c * chunk, min(int(n), (c + 1) * chunk))
    run_tasks(chunks, count, threads or render_threads())
