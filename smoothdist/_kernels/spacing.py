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

from typing import NamedTuple

import numba
import numpy as np

from smoothdist._config import NJIT, NJIT_IR_INLINE
from smoothdist._kernels.closest_point import box_distance2
from smoothdist._kernels.traversal import ZERO, always, nearest_first, no_far_field
from smoothdist.schedule import parallel_tasks, run_tasks

__all__ = ["points_within", "gap_probes", "local_smooth_distance"]


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
    within ``radius`` only (weights 1).

    Leaving terms out of the LogSumExp sum can only raise ``d_hat``, so this bounds the
    full ``beta = 0`` value from above, and every Barnes-Hut value (which lies below it).
    Queries with no point within ``radius`` get ``+inf``. Returns ``(q,) float64``.
    """
    nb, count = points_within(tree, Q, radius, max_count)
    d = np.linalg.norm(nb - Q[:, None, :], axis=2)
    d = np.where(np.arange(max_count)[None, :] < np.minimum(count, max_count)[:, None], d,
                 np.inf)
    m = d.min(axis=1)
    with np.errstate(invalid="ignore"):
        s = np.exp(-alpha * (d - m[:, None])).sum(axis=1)
        return np.where(np.isfinite(m), m - np.log(s) / alpha, np.inf)
