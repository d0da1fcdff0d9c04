"""Query order: batches of scattered queries are answered along a Morton (Z-order) curve.

A tree search is fastest when consecutive queries visit the same nodes: the nodes stay in
cache, and the exact search starts from the previous query's closest primitive
(:func:`smoothdist._kernels.exact_query.exact_tree_batch`), a good first bound only when that
query was nearby. Grids and image rows come in such an order; points drawn at random in a box
do not. :func:`coherent_order` detects the scattered case from a sample of consecutive steps and
returns a permutation along the Morton curve of the cube on the queries' bounding box
(cubic cells, 10 bits along its longest side);
the exact kernel takes the queries in that order itself and writes each result to its own row,
the others query ``Q[order]`` and put every result back (:func:`restore`), so values do not
depend on it. Batches too small to reorder whose consecutive queries lie far apart on the
data's scale (:func:`scattered`) are searched one query at a time instead of in packets.

What this gains is measured by ``benchmarks/bench_exact_mix.py`` (the performance guide,
"Exact queries on every mix").
"""

import numpy as np

__all__ = ["COHERENT_FROM", "coherent_order", "scattered", "restore"]

#: smallest batch that is reordered (below it the sort costs more than it saves)
COHERENT_FROM = 4096

#: consecutive steps sampled to judge the order
SAMPLE_STEPS = 1024

#: reorder when the median step exceeds this many mean query spacings
SCATTERED_STEPS = 4.0

#: queries whose median step exceeds this fraction of the data's diagonal are searched one
#: by one when they are not reordered (:func:`scattered`)
PACKET_STEP = 0.05


def _spread(x):
    """Insert two zero bits between the 10 low bits of ``x`` (uint32 array)."""
    x = (x | (x << 16)) & 0x030000FF
    x = (x | (x << 8)) & 0x0300F00F
    x = (x | (x << 4)) & 0x030C30C3
    return (x | (x << 2)) & 0x09249249


def bounds(Q):
    """``(lo, hi)`` of ``Q (n, 3)``, column by column (numpy's ``min(axis=0)`` on a C-order
    ``(n, 3)`` array is 25x slower)."""
    lo = np.array([Q[:, j].min() for j in range(3)])
    hi = np.array([Q[:, j].max() for j in range(3)])
    return lo, hi


def is_scattered(Q, lo, hi):
    """Whether consecutive rows of ``Q (n, 3) float64`` (bounding box ``lo``, ``hi``) jump far
    compared with their spacing.

    The median of up to :data:`SAMPLE_STEPS` consecutive steps, evenly spread over the batch,
    against the mean spacing ``(volume / n)^(1/3)`` of ``n`` points in the batch's bounding box
    (each side at least 1e-3 of the longest, so flat and linear batches count too).
    """
    n = Q.shape[0]
    ext = hi - lo
    longest = float(ext.max())
    if not longest > 0.0:
        return False
    ext = np.maximum(ext, 1e-3 * longest)
    spacing = float(np.prod(ext) / n) ** (1.0 / 3.0)
    return median_step(Q) > SCATTERED_STEPS * spacing


def median_step(Q, order=None):
    """Median length of up to :data:`SAMPLE_STEPS` consecutive steps of ``Q (n, 3)`` (taken
    in ``order`` when given), evenly spread over the batch (0 below two rows)."""
    n = Q.shape[0]
    if n < 2:
        return 0.0
    if order is None and n <= SAMPLE_STEPS + 1:
        # every step, in four numpy calls: a solver's batches of 2-1,000 queries paid 60 us a
        # call for the general path (linspace, unique, median), 3x the search of 10 queries
        d = Q[1:] - Q[:-1]
        s = np.einsum("ij,ij->i", d, d)
        m = n - 1
        k = m // 2
        if m % 2:
            return float(np.sqrt(np.partition(s, k)[k]))
        s = np.sqrt(np.partition(s, (k - 1, k))[k - 1:k + 1])
        return float(0.5 * (s[0] + s[1]))
    i = np.unique(np.linspace(0, n - 2, min(SAMPLE_STEPS, n - 1)).astype(np.int64))
    a, b = (i, i + 1) if order is None else (order[i], order[i + 1])
    return float(np.median(np.linalg.norm(Q[b] - Q[a], axis=1)))


def scattered(Q, scale, order=None):
    """Whether consecutive rows of ``Q`` (in ``order``) are far apart on the data's ``scale``
    (its bbox diagonal): median step above :data:`PACKET_STEP` of it. Such queries share no
    tree nodes, so a traversal of several at once opens the union of their searches."""
    return median_step(Q, order) > PACKET_STEP * scale


def coherent_order(Q):
    """A permutation ``(n,) int64`` of the rows of ``Q (n, 3) float64`` along the Morton curve
    of the cube on their bounding box's longest side (10 bits along it), or None when ``Q``
    is small (< :data:`COHERENT_FROM` rows) or already in a coherent order
    (:func:`is_scattered`). ``Q`` must be finite.

    The 30-bit codes are sorted in two stable passes over 16-bit halves (numpy sorts 16-bit
    keys by radix: 5x faster than its quicksort of the 32-bit codes).
    """
    n = Q.shape[0]
    if n < COHERENT_FROM:
        return None
    lo, hi = bounds(Q)
    if not is_scattered(Q, lo, hi):
        return None
    t = Q - lo
    # one scale for the three axes (cubic cells): per-axis scales stretch the curve's cells
    # along a long thin batch (a needle's queries: cells 250x longer than wide, consecutive
    # queries 30 radii apart, 2.5x the search time)
    t *= 1023.0 / max(float((hi - lo).max()), 1e-300)
    np.clip(t, 0.0, 1023.0, out=t)
    k = t.T.astype(np.uint32, order="C")          # (3, n): each axis contiguous
    code = _spread(k[0])
    code |= _spread(k[1]) << 1
    code |= _spread(k[2]) << 2
    first = np.argsort((code & 0xFFFF).astype(np.uint16), kind="stable")
    return first[np.argsort((code[first] >> 16).astype(np.uint16), kind="stable")]


def restore(order, *arrays):
    """Results computed for ``Q[order]``, in the order of ``Q``: new arrays (each array's
    first axis has ``order.size`` rows), returned as a tuple."""
    out = []
    for a in arrays:
        b = np.empty_like(a)
        b[order] = a
        out.append(b)
    return tuple(out)
