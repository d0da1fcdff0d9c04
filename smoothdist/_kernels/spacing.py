"""Point-cloud spacing: neighbours within a radius and the gaps a smooth surface must close.

``alpha="auto"`` for point clouds needs more than the median nearest-neighbour spacing: a
random sample of a surface (``trimesh.sample.sample_surface``) has gaps several median
spacings wide, and an alpha that merges neighbouring blobs at the median spacing leaves
those gaps open (holes). :func:`gap_probes` finds, around sampled points, the points of the
sampled surface farthest from the samples (centres of the local gaps); the surface is closed
where ``d_hat <= 0`` at every gap centre.

Kernels take the flat :class:`smoothdist._kernels.bvh.TreeData` arrays; the Python function builds
the probes in numpy.
"""

import math
from typing import NamedTuple

import numba
import numpy as np

from smoothdist._config import NJIT, NJIT_IR_INLINE
from smoothdist._kernels.closest_point import box_children, box_distance2
from smoothdist._kernels.traversal import ZERO, always, nearest_first, no_far_field
from smoothdist.schedule import parallel_tasks, run_tasks

__all__ = ["points_within", "gap_probes", "local_smooth_distance", "local_distances",
           "smooth_of_local", "nearest_k", "area_weights",
           "AREA_NEIGHBOURS", "AREA_WEIGHT_CAP"]


class _RadiusQuery(NamedTuple):
    """A radius search: the centre, the squared radius, the output indices."""
    px: float
    py: float
    pz: float
    r2: float
    out: np.ndarray


@numba.njit(**NJIT_IR_INLINE)
def _outside_radius(tree, q, node, key, st):
    """``skip``: the node's box is farther than the radius (the march's box kernel)."""
    return box_distance2(q.px, q.py, q.pz, tree.lo, tree.hi, node)[0] > q.r2


@numba.njit(**NJIT_IR_INLINE)
def _right_first(tree, q, node):
    """``children`` without keys: the right child is popped first (the order in which the
    stored neighbours of a crowded query have always been taken)."""
    return tree.right[node], 0.0, tree.left[node], 0.0


@numba.njit(**NJIT_IR_INLINE)
def _collect_points(tree, q, node, n):
    """A leaf's point primitives at squared distance ``0 < d2 <= r2``, stored into ``q.out``;
    the state is how many were found."""
    if tree.left[node] >= 0:
        return False, n
    px, py, pz, r2, out = q
    for i in range(tree.start[node], tree.start[node] + tree.count[node]):
        if tree.kind[i] != 0:
            continue
        dd = (tree.pts[i, 0] - px) ** 2 + (tree.pts[i, 1] - py) ** 2 + (tree.pts[i, 2] - pz) ** 2
        if 0.0 < dd <= r2:
            if n < out.size:
                out[n] = i
            n += 1
    return True, n


@numba.njit(**NJIT)
def _points_within_one(tree, px, py, pz, r2, out, stack, dstack):
    """Tree-order indices of point primitives at squared distance ``0 < d2 <= r2`` from
    ``(px, py, pz)`` into ``out`` (at most ``out.size``, nearest not guaranteed first);
    returns how many were found (may exceed ``out.size``: the rest are not stored)."""
    n, _ = nearest_first(tree, _RadiusQuery(px, py, pz, r2, out), ZERO, stack, dstack, ZERO, 0.0,
                         _outside_radius, no_far_field, _collect_points, _right_first, always)
    return n


@numba.njit(**NJIT)
def _points_within_tasks(tree, P, r2, out, counts, stack_len, ntasks, task0, task1):
    """:func:`_points_within_one` for rows ``q = t, t + ntasks, ...`` of ``P`` for the tasks
    ``task0 <= t < task1`` (a serial task kernel, :func:`smoothdist.schedule.run_tasks`)."""
    stack = np.empty(stack_len, dtype=np.int64)
    dstack = np.empty(stack_len)
    for task in range(task0, task1):
        for q in range(task, P.shape[0], ntasks):
            counts[q] = _points_within_one(tree, P[q, 0], P[q, 1], P[q, 2], r2, out[q], stack,
                                           dstack)


def points_within(tree, P, radius, max_count):
    """Point primitives within ``radius`` (> 0, excluding distance 0) of each row of ``P``.

    Returns ``(coords (q, max_count, 3) float64, count (q,) int64)``: the first
    ``min(count, max_count)`` rows of ``coords[i]`` are neighbours of ``P[i]`` (in no
    particular order); ``count`` is how many there are in all.
    """
    P = np.ascontiguousarray(P, dtype=np.float64).reshape(-1, 3)
    out = np.full((P.shape[0], max_count), -1, dtype=np.int64)
    counts = np.zeros(P.shape[0], dtype=np.int64)
    if P.shape[0]:
        ntasks = parallel_tasks(P.shape[0])
        r2, k = float(radius) ** 2, 2 * tree.depth + 4
        run_tasks(lambda a, b: _points_within_tasks(tree, P, r2, out, counts, k, ntasks, a, b),
                  ntasks, pool=True)
    coords = tree.pts[np.maximum(out, 0), :3]
    return coords, counts


def gap_probes(tree, P, radius, neighbours=24, max_count=96):
    """Candidate centres of the gaps around sampled points of a cloud.

    In a plane, the distance to the nearest sample has its local maxima at the
    circumcentres of the (Delaunay) triangles of samples that contain their circumcentre
    (non-obtuse). For each row ``p`` of ``P (q, 3)``, every triangle of ``p`` and two of its
    ``neighbours`` nearest neighbours within ``radius`` that contains its circumcentre gives
    a candidate; it is a gap centre when no sample is closer to it than the triangle's
    corners (the caller checks that with an exact distance query). Points with fewer than
    two neighbours (isolated returns) give none.

    Returns ``(centres (k, 3) float64, circumradii (k,) float64)``.
    """
    nb, count = points_within(tree, P, radius, max_count)
    count = np.minimum(count, max_count)
    rel = nb - P[:, None, :]
    dist = np.where(np.arange(max_count)[None, :] < count[:, None],
                    np.einsum("qki,qki->qk", rel, rel), np.inf)
    order = np.argsort(dist, axis=1)[:, :neighbours]
    rel = np.take_along_axis(rel, order[..., None], axis=1)
    k = np.minimum(count, neighbours)
    centres, radii = [], []
    for i in range(neighbours):
        for j in range(i + 1, neighbours):
            use = j < k
            if not use.any():
                continue
            c, inside = _circumcentre(rel[use, i], rel[use, j])
            centres.append((P[use] + c)[inside])
            radii.append(np.linalg.norm(c[inside], axis=1))
    if not centres:
        return np.zeros((0, 3)), np.zeros(0)
    return np.concatenate(centres), np.concatenate(radii)


def _circumcentre(a, b):
    """Circumcentres of triangles ``0, a, b`` (rows), relative to the corner at 0, and
    whether each lies inside its triangle (not obtuse, not degenerate)."""
    aa = np.einsum("ij,ij->i", a, a)
    bb = np.einsum("ij,ij->i", b, b)
    ab = np.einsum("ij,ij->i", a, b)
    det = 2.0 * (aa * bb - ab * ab)
    ok = det > 1e-12 * (aa * bb)
    safe = np.where(ok, det, 1.0)
    s = bb * (aa - ab) / safe
    t = aa * (bb - ab) / safe
    inside = ok & (s >= 0) & (t >= 0) & (s + t <= 1)
    return s[:, None] * a + t[:, None] * b, inside


def local_smooth_distance(tree, Q, alpha, radius, max_count=256):
    """An upper bound of a point cloud's smooth distance at ``Q (q, 3)``, from its points
    within ``radius`` only, with weight 1 (also under junction weights: the closing alpha
    stays where the unit sum puts it, and the area weights, heavier at a gap's edges, close
    the gaps as well; judged with them, the gaps of a sparse random sample closed at a
    higher alpha, which showed more of its relief: p95 11.6 against 6.5 degrees from the
    sphere's normals for 2,000 random samples of a sphere).

    Leaving terms out of the LogSumExp sum can only raise ``d_hat``, so this bounds the
    full ``beta = 0`` value from above, and every Barnes-Hut value (which lies below it).
    Queries with no point within ``radius`` get ``+inf``. Returns ``(q,) float64``.
    """
    return smooth_of_local(local_distances(tree, Q, radius, max_count), alpha)


def local_distances(tree, Q, radius, max_count=256):
    """``(d, m)``: the distances ``d (q, max_count)`` from ``Q (q, 3)`` to the cloud's points
    within ``radius`` (``inf`` in the unused slots) and their minimum ``m (q,)`` (``inf``:
    none), which :func:`smooth_of_local` sums at any alpha: a search over alpha
    (``SmoothDistanceField.closing_alpha``) finds the neighbours once."""
    nb, count = points_within(tree, Q, radius, max_count)
    d = np.linalg.norm(nb - Q[:, None, :], axis=2)
    d = np.where(np.arange(max_count)[None, :] < np.minimum(count, max_count)[:, None], d,
                 np.inf)
    return d, d.min(axis=1)


def smooth_of_local(local, alpha):
    """:func:`local_smooth_distance` at ``alpha`` from ``local = (d, m)``
    (:func:`local_distances`). Returns ``(q,) float64``."""
    d, m = local
    with np.errstate(invalid="ignore"):
        s = np.exp(-alpha * (d - m[:, None])).sum(axis=1)
        return np.where(np.isfinite(m), m - np.log(s) / alpha, np.inf)


#: neighbours of a point whose distances measure the area it stands for (:func:`area_weights`)
AREA_NEIGHBOURS = 12
#: clouds of a higher dimension (samples of a volume: their surface is their hull, which a
#: point's share of the volume does not measure) keep weight 1
AREA_MAX_DIMENSION = 2.5
#: an area weight lies in ``[1 / AREA_WEIGHT_CAP, AREA_WEIGHT_CAP]``: an isolated return's
#: blob grows by at most ``log(cap) / alpha``, a clump's points keep a share
AREA_WEIGHT_CAP = 16.0


class _NearestQuery(NamedTuple):
    """A k-nearest search from point primitive ``own`` (tree order; skipped): squared
    distances of the best so far, ascending, in ``best (k,)``."""
    px: float
    py: float
    pz: float
    own: int
    best: np.ndarray


@numba.njit(**NJIT_IR_INLINE)
def _beyond_kth(tree, q, node, key, st):
    """``skip``: the node is no nearer than the k-th best so far."""
    return key >= st


@numba.njit(**NJIT_IR_INLINE)
def _within_kth(key, st):
    """``keep``: a child nearer than the k-th best so far."""
    return key < st


@numba.njit(**NJIT_IR_INLINE)
def _insert_points(tree, q, node, st):
    """A leaf's point primitives (other than ``q.own``) into ``q.best`` by insertion; the
    state is the k-th best squared distance."""
    if tree.left[node] >= 0:
        return False, st
    best = q.best
    k = best.size
    for i in range(tree.start[node], tree.start[node] + tree.count[node]):
        if tree.kind[i] != 0 or i == q.own:
            continue
        dd = (tree.pts[i, 0] - q.px) ** 2 + (tree.pts[i, 1] - q.py) ** 2 \
            + (tree.pts[i, 2] - q.pz) ** 2
        if dd < best[k - 1]:
            j = k - 1
            while j > 0 and best[j - 1] > dd:
                best[j] = best[j - 1]
                j -= 1
            best[j] = dd
    return True, best[k - 1]


@numba.njit(**NJIT)
def _nearest_k_tasks(tree, idx, k, dim, out_d, out_area, stack_len, ntasks, task0, task1):
    """For point primitive ``idx[q]`` (tree order), the squared distances to its ``k`` nearest
    other point primitives (ascending, ``inf`` where there are fewer): into ``out_d[q]`` when
    ``out_d`` has rows, and ``mean_j r_j ** dim / j`` into ``out_area[q]`` when ``dim > 0``;
    rows ``q = t, t + ntasks, ...`` of the tasks ``task0 <= t < task1``."""
    stack = np.empty(stack_len, dtype=np.int64)
    dstack = np.empty(stack_len)
    best = np.empty(k)
    for task in range(task0, task1):
        for q in range(task, idx.size, ntasks):
            i = idx[q]
            for j in range(k):
                best[j] = np.inf
            nearest_first(tree, _NearestQuery(tree.pts[i, 0], tree.pts[i, 1], tree.pts[i, 2], i,
                                              best), np.inf, stack, dstack, ZERO, 0.0,
                          _beyond_kth, no_far_field, _insert_points, box_children, _within_kth)
            if out_d.shape[0]:
                for j in range(k):
                    out_d[q, j] = best[j]
            if dim > 0.0:
                a = 0.0
                for j in range(k):
                    a += math.exp(0.5 * dim * math.log(best[j])) / (j + 1) if best[j] > 0.0 \
                        else 0.0
                out_area[q] = a / k


def _nearest_k_run(tree, idx, k, dim, out_d, out_area):
    """:func:`_nearest_k_tasks` over ``idx`` on the worker threads."""
    idx = np.ascontiguousarray(idx, dtype=np.int64)
    if idx.size:
        ntasks = parallel_tasks(idx.size)
        depth = 2 * tree.depth + 4
        run_tasks(lambda a, b: _nearest_k_tasks(tree, idx, int(k), float(dim), out_d, out_area,
                                                depth, ntasks, a, b), ntasks, pool=True)


def nearest_k(tree, idx, k):
    """Distances from the point primitives ``idx (q,)`` (tree order) to their ``k`` nearest
    other point primitives: ``(q, k) float64``, ascending, ``inf`` where the tree has fewer
    points."""
    out = np.empty((len(idx), int(k)))
    _nearest_k_run(tree, idx, k, 0.0, out, np.empty(0))
    return np.sqrt(out)


def area_weights(tree, k=AREA_NEIGHBOURS, cap=AREA_WEIGHT_CAP, samples=2000):
    """The share of the sampled shape each point primitive of ``tree`` stands for, relative
    to what a random spot of the shape sees: ``a / (sum a^2 / sum a)`` clipped to
    ``[1 / cap, cap]``, with ``a = mean_j r_j ** dim / j`` over its ``k`` nearest other
    points (``r_j`` the distance to the ``j``-th) and ``dim`` the cloud's dimension (1 for
    samples of a curve, 2 of a surface, 3 of a volume), estimated from how the neighbour
    distances grow, ``r_k / r_(k/2) = 2 ** (1 / dim)`` (median over up to ``samples``
    points). ``(m,) float64`` in tree order, 1 for edges and triangles, and 1 everywhere for
    a cloud of dimension above :data:`AREA_MAX_DIMENSION`.

    Why: a random sample clumps, and each clump of ``n`` points adds ``log(n) / alpha`` to
    the LogSumExp surface (bumps: "stucco" on a scanned wall). Weighted by area, the sum over
    a patch counts its area, not its points.
    """
    w = np.ones(tree.kind.size)
    idx = np.flatnonzero(tree.kind == 0)
    if idx.size <= k:
        return w
    # the dimension from a sample of the points; then each point's area in one pass, in
    # (m,) memory (a 10M-point scan needs no (m, k) table)
    rng = np.random.default_rng(0)
    sample = idx if idx.size <= samples else np.sort(rng.choice(idx, samples, replace=False))
    r = nearest_k(tree, sample, k)
    rk, rh = r[:, k - 1], r[:, k // 2 - 1]
    ok = np.isfinite(rk) & (rh > 0)
    if not ok.any():
        return w
    grow = float(np.median(rk[ok] / rh[ok]))
    dim = float(np.clip(math.log(k / (k // 2)) / math.log(grow), 1.0, 3.0)) if grow > 1 else 3.0
    if dim > AREA_MAX_DIMENSION:
        return w
    # the area is estimated from each of the k neighbours (the j-th nearest spans about j
    # points' areas) and averaged: less noisy than the k-th alone (the faces of 100k random
    # points on a box turned 6.1 degrees at p95 with the 8th alone, 5.3 with the mean of 12)
    area = np.empty(idx.size)
    _nearest_k_run(tree, idx, k, dim, np.empty((0, k)), area)
    fin = np.isfinite(area)
    # relative to the area a random spot of the shape sees (the points' mean area weighted by
    # area): where the sample is sparsest the weights are about 1, as unit weights were, and
    # denser patches weigh less (a scan's detailed parts no longer bulge)
    scale = float(np.sum(area[fin] ** 2) / np.sum(area[fin])) if fin.any() else 0.0
    if not scale > 0:
        return w
    w[idx] = np.clip(np.where(fin, area / scale, cap), 1.0 / cap, cap)
    return w
