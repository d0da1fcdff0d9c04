"""Exact unsigned distance: equals naive brute force, unit gradient, correct closest primitive,
pruning statistics, thread-count independence, validation."""

import numba
import numpy as np
import pytest

import naive
import smoothdist
from smoothdist import DataMesh, ExactDistanceResult, QueryStats, SmoothDistanceField

ZOO = ("point_cloud", "circle", "segment_star", "icosphere", "cube", "mixed_mesh",
       "nonmanifold_mesh")
SHARED = {
    "bunny": ("bunny.off", 60),
    "creeper": ("thingi10k/37825_minecraft_creeper.obj", 400),
    "cube_libre": ("thingi10k/65778_cube_libre_puzzle.obj", 300),
    "capillary": ("curves/capillary_networks.obj", 200),
    "freedman": ("curves/freedman_unknot.obj", 200),
}


def queries(mesh, rng, near=300, on=60, far=40):
    Q = np.concatenate([naive.near_queries(mesh, near, rng),
                        naive.sample_on_primitives(mesh, on, rng),
                        naive.far_queries(mesh, far, rng, 2.0, 1e6)])
    off = np.ones(Q.shape[0], dtype=bool)
    off[near:near + on] = False
    return Q, off


def check_against_naive(mesh, Q, off):
    field = SmoothDistanceField(mesh)
    res = field.exact_distance(Q, return_closest=True)
    assert isinstance(res, ExactDistanceResult)
    d, g, idx = res
    terms = naive.Terms(Q, mesh)
    dr, gr, _ = terms.exact()
    diag = mesh.diagonal
    # distance
    np.testing.assert_allclose(d, dr, rtol=1e-12, atol=1e-13 * diag)
    # on-geometry queries
    assert np.all(d[~off] <= 1e-12 * diag)
    # closest primitive: a valid index whose own distance is d (ties share the distance)
    assert idx.dtype == np.int64
    assert np.all((idx >= 0) & (idx < mesh.num_primitives))
    own = terms.D[np.arange(Q.shape[0]), idx]
    np.testing.assert_allclose(own, d, rtol=1e-12, atol=1e-13 * diag)
    # gradient: unit, and equal to (q - c) / d
    far = d > 1e-9 * diag
    np.testing.assert_allclose(np.linalg.norm(g[far], axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(g[far], gr[far], atol=1e-9)
    C = terms.C[np.arange(Q.shape[0]), idx]
    np.testing.assert_allclose(Q[far] - d[far, None] * g[far], C[far],
                               atol=1e-9 * diag, rtol=1e-12)
    return field


@pytest.mark.parametrize("name", ZOO)
def test_matches_naive_procedural(zoo, name, rng):
    mesh = zoo[name]
    Q, off = queries(mesh, rng)
    check_against_naive(mesh, Q, off)


@pytest.mark.parametrize("name", ["octopus", "trefoil"])
def test_matches_naive_real_local(request, name, rng):
    mesh = request.getfixturevalue(name)
    Q, off = queries(mesh, rng, near=200, on=40, far=30)
    check_against_naive(mesh, Q, off)


@pytest.mark.parametrize("key", sorted(SHARED))
def test_matches_naive_shared(shared_data, key, rng):
    path, n = SHARED[key]
    mesh = DataMesh.load(shared_data / path)
    Q, off = queries(mesh, rng, near=n, on=n // 5, far=n // 5)
    check_against_naive(mesh, Q, off)


def test_mixed_closest_kind(mixed_mesh):
    """Queries next to a free point, a spike edge and a sphere face report that primitive,
    numbered points, then edges, then triangles."""
    m = mixed_mesh
    field = SmoothDistanceField(m)
    p = m.points.size
    e = m.edges.shape[0]
    # just off a free point
    q_pt = m.V[m.points[0]] + np.array([1e-3, 0, 0])
    # middle of spike edge 0, pushed sideways
    a, b = m.V[m.edges[0]]
    side = np.cross(b - a, [0.3, 0.5, 0.7])
    q_edge = 0.5 * (a + b) + 1e-3 * side / np.linalg.norm(side)
    # just outside the centroid of triangle 5 (sphere: outward = centroid direction)
    cen = m.V[m.triangles[5]].mean(axis=0)
    q_tri = cen * 1.0001
    d, g, idx = field.exact_distance(np.array([q_pt, q_edge, q_tri]), return_closest=True)
    assert idx[0] == 0
    assert idx[1] == p + 0
    assert idx[2] == p + e + 5
    np.testing.assert_allclose(d[:2], 1e-3, rtol=1e-9)


def test_on_vertex_gives_zero_distance_and_zero_gradient(icosphere):
    field = SmoothDistanceField(icosphere)
    d, g = field.exact_distance(icosphere.V[:10])
    assert np.all(d == 0.0)
    assert np.all(g == 0.0)


def test_stats_and_pruning(octopus, rng):
    field = SmoothDistanceField(octopus)
    Q = np.concatenate([naive.near_queries(octopus, 300, rng),
                        naive.far_queries(octopus, 100, rng, 5.0, 100.0)])
    d, g, idx, st = field.exact_distance(Q, return_closest=True, return_stats=True)
    assert isinstance(st, QueryStats)
    N = field.num_primitives
    assert np.all(st.leaves_visited >= 1) and np.all(st.leaves_visited <= N)
    assert np.all(st.nodes_visited >= 1)
    assert np.all(st.nodes_visited <= field.tree.lo.shape[0])
    # branch and bound prunes: far fewer than N primitive tests on average
    assert st.leaves_visited.mean() < 0.2 * N
    d2, g2, st2 = field.exact_distance(Q, return_stats=True)
    np.testing.assert_array_equal(d, d2)
    np.testing.assert_array_equal(st.leaves_visited, st2.leaves_visited)


def test_module_function_equals_field(icosphere, circle, point_cloud, rng):
    for mesh, F in ((icosphere, icosphere.triangles), (circle, circle.edges), (point_cloud, None)):
        Q = naive.near_queries(mesh, 100, rng)
        a = smoothdist.exact_distance(Q, mesh.V, F)
        b = SmoothDistanceField(mesh).exact_distance(Q)
        np.testing.assert_array_equal(a[0], b[0])
        np.testing.assert_array_equal(a[1], b[1])


def test_exact_is_limit_of_smooth(octopus, rng):
    """d_hat -> d as alpha grows: the gap is at most log(A N)/alpha."""
    field = SmoothDistanceField(octopus)
    Q = naive.near_queries(octopus, 200, rng)
    d = field.exact_distance(Q).distance
    for alpha in (1e2, 1e4, 1e6):
        dh = field.smooth_distance(Q, alpha=alpha, beta=0.0).distance
        gap = d - dh
        assert np.all(gap >= -1e-12) and np.all(gap <= field.inflation(alpha) * (1 + 1e-9))


@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs >= 2 numba threads")
def test_parallel_equals_serial(octopus, rng):
    field = SmoothDistanceField(octopus)
    Q = naive.near_queries(octopus, 5000, rng)
    before = numba.get_num_threads()
    out = {}
    try:
        for n in (1, 2):
            numba.set_num_threads(n)
            out[n] = field.exact_distance(Q, return_closest=True, return_stats=True)
    finally:
        numba.set_num_threads(before)
    assert numba.get_num_threads() == before
    for x, y in zip(out[1][:3], out[2][:3]):
        np.testing.assert_array_equal(x, y)
    np.testing.assert_array_equal(np.stack(out[1][3]), np.stack(out[2][3]))


@pytest.mark.parametrize("Q", [[[0.0, float("nan"), 1.0]], np.zeros((3, 4)), [1.0, 2.0]])
def test_bad_queries_raise(icosphere, Q):
    with pytest.raises(ValueError, match="Q"):
        SmoothDistanceField(icosphere).exact_distance(Q)
