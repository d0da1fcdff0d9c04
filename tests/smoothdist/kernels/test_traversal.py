"""The one traversal loop (smoothdist._kernels.traversal.nearest_first): a new query kind is
written as its functions only, and gets what brute force gets."""

from typing import NamedTuple

import numba
import numpy as np
import pytest

from smoothdist import SmoothDistanceField
from smoothdist._kernels.closest_point import box_distance2
from smoothdist._kernels.traversal import (always, beyond_best, nearest_first, never,
                                           no_far_field, within_best)


class _Ball(NamedTuple):
    px: float
    py: float
    pz: float
    r2: float


@numba.njit(inline="always")
def _children(tree, q, node):
    l = tree.left[node]
    r = tree.right[node]
    return (l, box_distance2(q.px, q.py, q.pz, tree.lo, tree.hi, l)[0],
            r, box_distance2(q.px, q.py, q.pz, tree.lo, tree.hi, r)[0])


@numba.njit(inline="always")
def _d2(tree, i, q):
    P = tree.pts
    return (P[i, 0] - q.px) ** 2 + (P[i, 1] - q.py) ** 2 + (P[i, 2] - q.pz) ** 2


@numba.njit(inline="always")
def _nearest_leaf(tree, q, node, st):
    """Branch and bound for the nearest point primitive; ``st = (best d2, index, leaves)``."""
    if tree.left[node] >= 0:
        return False, st
    best, bi, leaves = st
    for i in range(tree.start[node], tree.start[node] + tree.count[node]):
        d2 = _d2(tree, i, q)
        leaves += 1
        if d2 < best:
            best = d2
            bi = i
    return True, (best, bi, leaves)


@numba.njit(inline="always")
def _outside(tree, q, node, key, st):
    return key > q.r2


@numba.njit(inline="always")
def _count_leaf(tree, q, node, n):
    if tree.left[node] >= 0:
        return False, n
    for i in range(tree.start[node], tree.start[node] + tree.count[node]):
        if _d2(tree, i, q) <= q.r2:
            n += 1
    return True, n


@numba.njit(inline="always")
def _whole_inside(tree, q, node, key, n):
    """A far field of the counting kind: a box inside the ball counts all its points at once
    (its farthest corner within the radius)."""
    far2 = 0.0
    for a in range(3):
        c = q.px if a == 0 else (q.py if a == 1 else q.pz)
        far2 += max(c - tree.lo[node, a], tree.hi[node, a] - c) ** 2
    if far2 <= q.r2:
        return True, n + tree.count[node]
    return False, n


@numba.njit
def _nearest(tree, Q, out, stack, dstack):
    for j in range(Q.shape[0]):
        q = _Ball(Q[j, 0], Q[j, 1], Q[j, 2], 0.0)
        (best, bi, leaves), nodes = nearest_first(
            tree, q, (np.inf, -1, 0), stack, dstack, 0,
            box_distance2(q.px, q.py, q.pz, tree.lo, tree.hi, 0)[0], beyond_best,
            no_far_field, _nearest_leaf, _children, within_best)
        out[j, 0] = best
        out[j, 1] = tree.orig[bi]
        out[j, 2] = nodes


@numba.njit
def _count(tree, Q, r2, far, out, stack, dstack):
    for j in range(Q.shape[0]):
        q = _Ball(Q[j, 0], Q[j, 1], Q[j, 2], r2)
        key0 = box_distance2(q.px, q.py, q.pz, tree.lo, tree.hi, 0)[0]
        if far:
            n, nodes = nearest_first(tree, q, 0, stack, dstack, 0, key0, _outside,
                                     _whole_inside, _count_leaf, _children, always)
        else:
            n, nodes = nearest_first(tree, q, 0, stack, dstack, 0, key0, never, no_far_field,
                                     _count_leaf, _children, always)
        out[j, 0] = n
        out[j, 1] = nodes


@pytest.fixture(scope="module")
def cloud():
    rng = np.random.default_rng(7)
    P = rng.normal(size=(1500, 3)) * [1.0, 0.5, 0.2]
    field = SmoothDistanceField(P)
    Q = rng.uniform(-2.0, 2.0, size=(200, 3))
    k = field.tree.depth + 4
    return P, field.tree, Q, np.empty(k, np.int64), np.empty(k)


def test_branch_and_bound_kind_finds_the_nearest_point(cloud):
    P, tree, Q, stack, dstack = cloud
    out = np.empty((len(Q), 3))
    _nearest(tree, Q, out, stack, dstack)
    D2 = ((Q[:, None, :] - P[None, :, :]) ** 2).sum(axis=2)
    # the same sums as numpy's up to rounding (vector width may reorder the three terms)
    np.testing.assert_allclose(out[:, 0], D2.min(axis=1), rtol=1e-13)
    np.testing.assert_array_equal(out[:, 1], D2.argmin(axis=1))
    # pruning works: far fewer nodes than the tree has (2 * 1500 - 1)
    assert out[:, 2].mean() < 0.1 * (2 * len(P) - 1)


def test_every_node_is_visited_without_pruning_and_far_fields_count_whole_boxes(cloud):
    P, tree, Q, stack, dstack = cloud
    r2 = 0.6 ** 2
    full = np.empty((len(Q), 2), np.int64)
    pruned = np.empty((len(Q), 2), np.int64)
    _count(tree, Q, r2, False, full, stack, dstack)
    _count(tree, Q, r2, True, pruned, stack, dstack)
    truth = (((Q[:, None, :] - P[None, :, :]) ** 2).sum(axis=2) <= r2).sum(axis=1)
    np.testing.assert_array_equal(full[:, 0], truth)
    np.testing.assert_array_equal(pruned[:, 0], truth)
    assert (full[:, 1] == 2 * len(P) - 1).all()     # never skips, opens every inner node
    assert (pruned[:, 1] < full[:, 1]).all()
    assert truth.max() > 50                          # the far field was exercised


KIND = '''
from typing import NamedTuple

import numba, numpy as np
from smoothdist import SmoothDistanceField
from smoothdist._kernels.closest_point import box_distance2
from smoothdist._kernels.traversal import always, nearest_first, never, no_far_field


class Query{tag}(NamedTuple):
    x: float
    y: float
    z: float


@numba.njit(inline="always")
def children(tree, q, node):
    l = tree.left[node]
    r = tree.right[node]
    return (l, box_distance2(q.x, q.y, q.z, tree.lo, tree.hi, l)[0],
            r, box_distance2(q.x, q.y, q.z, tree.lo, tree.hi, r)[0])


@numba.njit(inline="always")
def count_leaf(tree, q, node, n):
    if tree.left[node] >= 0:
        return False, n
    return True, n + tree.count[node]


@numba.njit
def count(tree, stack, dstack):
    q = Query{tag}(0.0, 0.0, 0.0)
    return nearest_first(tree, q, 0, stack, dstack, 0, 0.0, never, no_far_field, count_leaf,
                         children, always)[0]


tree = SmoothDistanceField(np.random.default_rng(0).random((50, 3))).tree
k = tree.depth + 4
assert count(tree, np.empty(k, np.int64), np.empty(k)) == 50
'''


def test_a_kind_in_another_module_leaves_no_cache_entry_behind(tmp_path):
    """A query kind written in a module of its own (a script, a notebook, a test) compiles the
    loop for its types; the loop is not cached, so another process that cannot import that
    module still compiles its own kinds (a cached loop's index named the first module's
    types, and reading it failed with ModuleNotFoundError)."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    root = str(Path(__file__).resolve().parents[3])
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "user_kind.py").write_text(KIND.format(tag="A"))
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"),
               PYTHONPATH=os.pathsep.join([str(tmp_path / "mine"), root]))
    env.pop("SMOOTHDIST_CACHE_DIR", None)  # it would win over NUMBA_CACHE_DIR
    first = subprocess.run([sys.executable, "-c", "import user_kind"], env=env,
                           capture_output=True, text=True, cwd=root)
    assert first.returncode == 0, first.stderr[-2000:]
    env["PYTHONPATH"] = root                       # user_kind is not importable here
    second = subprocess.run([sys.executable, "-c", KIND.format(tag="B")], env=env,
                            capture_output=True, text=True, cwd=root)
    assert second.returncode == 0, second.stderr[-2000:]
