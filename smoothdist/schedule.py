"""How batch kernels share their work between threads: strided tasks.

A ``prange`` loop (numba's OpenMP and workqueue layers) hands each thread one run of
consecutive iterations. Queries and pixels usually come in spatial order (a grid, the rows of
an image, the silhouette pixels of a render, the primitives of a query mesh), and their cost
follows the geometry: the thread that got the part of the list near the surface does most of
the work while the other waits. So the batch kernels loop over ``ntasks`` tasks, one per
thread (:func:`parallel_tasks`), and task ``t`` takes items ``t, t + ntasks, ...``: every
thread gets a similar mix and still walks through space in order (neighbouring items, which
visit the same part of the tree, run at about the same time)::

    ntasks = max(1, min(n, ntasks))
    for task in prange(ntasks):
        ...                              # scratch stacks, once per task
        for i in range(task, n, ntasks):
            ...                          # item i

The task count comes from the Python caller: a kernel that calls ``numba.get_num_threads()``
itself cannot be cached on disk. It changes which thread computes an item, never its value:
results do not depend on it (nor on the number of threads). Measured (2 threads): the
anti-aliasing samples of the 512 x 512 lit bunny ran 1.49 x faster on 2 threads than on 1 in
list order (the rest of the render 1.8 x); see ``docs/guide/performance.md`` for the figures
after.

Kernels that need not be ``prange`` (a parallel loop costs numba about as much compile time
again as its body; the first call of a fresh install pays it) are serial *task kernels*:
``kernel(..., ntasks, task0, task1)`` runs tasks ``task0 <= t < task1`` of the same strided
scheme, releases the GIL (``nogil=True``), and :func:`run_tasks` calls it from Python threads,
one contiguous group of tasks each. The values are those of the ``prange`` kernel, whatever
the split.
"""

import os
import threading
from concurrent.futures import ThreadPoolExecutor

import numba

from smoothdist._config import PARALLEL

__all__ = ["TASKS", "parallel_tasks", "run_largest_first", "run_tasks"]

#: most parallel tasks
TASKS = 64


def parallel_tasks(m):
    """Number of strided tasks for ``m`` items: one per numba thread (at most :data:`TASKS`).

    With more tasks than threads the tasks that got one item more than the others (the first
    ``m % n``) would all land on the first thread (``prange`` hands each thread an equal run of
    consecutive tasks): 100 query primitives in 64 tasks gave one of two threads 64 of them.
    One task per thread gives every thread ``m / n`` items, rounded.
    """
    return max(1, min(int(m), numba.get_num_threads(), TASKS))


def run_tasks(fn, ntasks, threads=None, pool=False):
    """Call ``fn(task0, task1)`` over tasks ``0 <= task < ntasks``, split into contiguous
    groups, one per thread (``threads``, default numba's thread count, 1 under
    ``SMOOTHDIST_PARALLEL=0``; at most ``ntasks``), from Python threads: for serial GIL-free
    task kernels, whose tasks are independent, so the result does not depend on the split.
    The calling thread runs the first group; exceptions are re-raised here.

    ``pool``: run the other groups on this module's persistent worker threads (about 25 us a
    call instead of 200 us to start threads: for the library's small query batches) rather
    than on new threads. Only for ``fn`` that never waits on the pool itself (a kernel call):
    a worker that did could wait for a worker that never comes.
    """
    if ntasks <= 1:         # one task: this thread (no need to ask numba for its threads)
        fn(0, ntasks)
        return
    threads = threads or (numba.get_num_threads() if PARALLEL else 1)
    threads = max(1, min(threads, ntasks))
    if threads == 1:
        fn(0, ntasks)
        return
    edges = [ntasks * i // threads for i in range(threads + 1)]
    if pool:
        ex = _executor(threads - 1)
        futures = [ex.submit(fn, edges[i], edges[i + 1]) for i in range(1, threads)]
        try:
            fn(edges[0], edges[1])
        finally:
            errors = [f.exception() for f in futures]   # waits for every group
        errors = [e for e in errors if e is not None]
        if errors:
            raise errors[0]
        return
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


def run_largest_first(fn, items, threads):
    """Call ``fn(item, slot)`` for every entry of ``items`` (largest first, as the caller
    orders them) on ``threads`` Python threads, each taking the next item when it is done:
    for GIL-free kernels whose items differ in size (the subtrees of a tree build), where
    :func:`run_tasks`'s fixed groups would leave a thread idle. ``slot`` is ``1 +`` the
    thread's index (each thread's own progress counter); exceptions are re-raised here."""
    items = list(items)
    lock = threading.Lock()
    errors = []

    def work(slot):
        while not errors:
            with lock:
                if not items:
                    return
                i = items.pop(0)
            try:
                fn(i, slot)
            except BaseException as exc:  # handed to the calling thread
                errors.append(exc)

    workers = [threading.Thread(target=work, args=(k + 1,), daemon=True)
               for k in range(1, threads)]
    for t in workers:
        t.start()
    work(1)
    for t in workers:
        t.join()
    if errors:
        raise errors[0]


_POOL = {"executor": None, "workers": 0, "pid": None}
_POOL_LOCK = threading.Lock()


def _executor(workers):
    """The persistent worker threads of :func:`run_tasks` (``pool=True``), at least
    ``workers`` of them (a larger pool replaces a smaller one, which finishes its work). A
    forked child process makes its own (it has none of its parent's threads)."""
    with _POOL_LOCK:
        if _POOL["pid"] != os.getpid():
            _POOL.update(executor=None, workers=0, pid=os.getpid())
        if _POOL["workers"] < workers:
            old = _POOL["executor"]
            _POOL["executor"] = ThreadPoolExecutor(workers, thread_name_prefix="smoothdist")
            _POOL["workers"] = workers
            if old is not None:
                old.shutdown(wait=False)
        return _POOL["executor"]
