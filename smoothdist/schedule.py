"""How batch kernels share their work between threads: a scattered visiting order.

A ``prange`` loop (numba's OpenMP and workqueue layers) hands each thread one run of
consecutive iterations. Queries and pixels usually come in spatial order (a grid, the rows of
an image, the silhouette pixels of a render), and their cost follows the geometry: the thread
that got the half of the list near the surface does most of the work while the other waits.
Visiting iteration ``j`` as item ``(j * s) % n``, with a stride ``s`` coprime to ``n`` near
``n / phi`` (the golden ratio), gives every thread's run items from all over the list, so each
thread gets a similar mix. The order changes which thread computes an item, never its value:
results do not depend on it (nor on the number of threads).

Measured on the 512 x 512 lit bunny with adaptive anti-aliasing (2 threads): the extra
samples' kernel ran 1.49x faster on 2 threads than on 1 in list order, and took 23 % less
time in the scattered order.
"""

import math

import numba

from smoothdist._config import NJIT, NJIT_INLINE

__all__ = ["scatter_stride", "scattered"]

_INV_PHI = 0.6180339887498949


@numba.njit(**NJIT)
def scatter_stride(n):
    """A stride ``s`` (int) coprime to ``n >= 0`` near ``n / phi``: ``j -> (j * s) % n`` is a
    permutation of ``0 .. n - 1`` (``s`` = 1 for ``n < 3``)."""
    if n < 3:
        return 1
    s = int(_INV_PHI * n)
    while math.gcd(s, n) != 1:
        s += 1
    return s


@numba.njit(**NJIT_INLINE)
def scattered(j, n, s):
    """The item visited at iteration ``j`` of ``n`` with stride ``s`` (:func:`scatter_stride`)."""
    return (j * s) % n
