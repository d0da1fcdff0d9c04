"""Python threads for a render's per-pixel work: the serial, GIL-free task kernels and numpy
loops that release the GIL (:func:`~tracer.threads.run_tasks`, :func:`~tracer.threads.in_bands`), with numba's thread count."""

import threading

from smoothdist.kernels import PARALLEL

__all__ = ["render_threads", "in_bands", "run_tasks"]


def render_threads():
    """Threads that trace a render: numba's thread count (``numba.set_num_threads``,
    ``tracer render --threads``), 1 with ``SMOOTHDIST_PARALLEL=0``."""
    import numba

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
    serial, GIL-free task kernels (``tracer.march.sample_tasks``,
    ``tracer.lighting.light_tasks``), whose tasks are independent, so the result does not
    depend on the split. Exceptions are re-raised here."""
    threads = max(1, min(threads or render_threads(), ntasks))
    if threads == 1:
        fn(0, ntasks)
        return
    edges = [ntasks * i // threads for i in range(threads + 1)]
    errors = []

    def work(a, b):
        try:
            fn(a, b)
        except BaseException as exc:  # handed to the calling thread
            errors.append(exc)

    workers = [threading.Thread(target=work, args=(edges[i], edges[i + 1]), daemon=True)
               for i in range(1, threads)]
    for t in workers:
        t.start()
    work(edges[0], edges[1])
    for t in workers:
        t.join()
    if errors:
        raise errors[0]
