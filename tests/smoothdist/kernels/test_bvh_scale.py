"""The lean BVH build used for very large point clouds (``benchmarks/bench_scale.py``).

* a point cloud's tree built with a progress callback (the kernel runs in a thread) equals the
  one built without, and the callback ends at ``done == total``;
* point clouds skip the per-primitive boxes and the weight-coefficient reordering: the tree is
  the same as a mixed-code build would give (checked against the distance kernels and the
  node invariants), for several leaf sizes (the node capacity ``4 m / leaf_size``).
"""

import numpy as np
import pytest

from smoothdist import DataMesh, SmoothDistanceField
from smoothdist._kernels.bvh import build_tree


@pytest.mark.parametrize("leaf_size", [1, 2, 3, 8, 33])
def test_point_cloud_tree_invariants(leaf_size, rng):
    V = rng.random((1000, 3))
    tree = build_tree(DataMesh(V), leaf_size=leaf_size)
    n = tree.lo.shape[0]
    leaves = tree.left < 0
    assert tree.count[0] == 1000 and tree.count[leaves].sum() == 1000
    assert np.all(tree.count[leaves] <= leaf_size)
    assert n <= min(2 * 1000, 4 * (1000 // leaf_size) + 4)
    # every primitive lies in the box of its leaf
    for node in np.nonzero(leaves)[0]:
        P = tree.pts[tree.start[node]:tree.start[node] + tree.count[node], :3]
        assert np.all(P >= tree.lo[node]) and np.all(P <= tree.hi[node])
    assert np.array_equal(np.sort(tree.orig), np.arange(1000))
    np.testing.assert_array_equal(tree.pts[:, :3], V[tree.orig])
    assert not tree.wc.any()


def test_progress_callback_and_same_tree(rng):
    V = rng.random((5000, 3))
    calls = []
    a = build_tree(DataMesh(V), leaf_size=4,
                   progress=lambda done, total, t: calls.append((done, total)))
    b = build_tree(DataMesh(V), leaf_size=4)
    assert calls and calls[-1] == (5000, 5000)
    assert all(0 <= d <= t == 5000 for d, t in calls)
    for x, y in zip(a, b):
        if isinstance(x, np.ndarray):
            np.testing.assert_array_equal(x, y)
        else:
            assert x == y


def test_field_progress_and_queries(rng):
    V = rng.random((3000, 3))
    Q = rng.random((50, 3)) * 1.4 - 0.2
    seen = []
    f = SmoothDistanceField(V, leaf_size=8, progress=lambda *a: seen.append(a))
    ref = SmoothDistanceField(V)
    assert seen
    np.testing.assert_allclose(f.exact_distance(Q)[0], ref.exact_distance(Q)[0], rtol=0,
                               atol=1e-15)
    np.testing.assert_allclose(f.smooth_distance(Q, alpha=50.0, beta=0.0)[0],
                               ref.smooth_distance(Q, alpha=50.0, beta=0.0)[0], rtol=1e-12)
