"""Scattered query batches are answered along a Morton curve and returned in the caller's
order (smoothdist/query_order.py). The values must not depend on it: compared with the same
queries in chunks too small to be reordered (bitwise for the smooth distance, whose traversal
of one query does not depend on its neighbours; to 1 ulp for the exact distance, whose search
starts from the previous query's closest primitive, and on ties may end on another primitive
at the same distance) and with numpy brute force.
"""
import numpy as np
import pytest

import smoothdist as sd
from smoothdist import query_order as qo
from tests import naive


def _mesh():
    trimesh = pytest.importorskip("trimesh")
    m = trimesh.creation.icosphere(subdivisions=3)
    return sd.DataMesh(m.vertices * [1.0, 0.7, 0.4], np.asarray(m.faces))


def _chunked(fn, Q, size=qo.COHERENT_FROM - 1):
    parts = [fn(Q[i:i + size]) for i in range(0, Q.shape[0], size)]
    return [np.concatenate(p) for p in zip(*parts)]


def test_order_is_a_morton_permutation_only_for_scattered_batches():
    rng = np.random.default_rng(0)
    Q = rng.uniform(-1, 1, (20000, 3))
    order = qo.coherent_order(Q)
    assert order is not None
    np.testing.assert_array_equal(np.sort(order), np.arange(Q.shape[0]))
    lo, hi = qo.bounds(Q)
    np.testing.assert_array_equal(lo, Q.min(axis=0))
    np.testing.assert_array_equal(hi, Q.max(axis=0))
    k = np.clip((Q - lo) * (1023.0 / (hi - lo).max()), 0, 1023).astype(np.uint32)
    code = qo._spread(k[:, 0]) | (qo._spread(k[:, 1]) << 1) | (qo._spread(k[:, 2]) << 2)
    assert np.all(np.diff(code[order].astype(np.int64)) >= 0)
    # a grid in raster order, rows of an image, a polyline: kept as they are
    c = np.linspace(0, 1, 30)
    G = np.stack(np.meshgrid(c, c, c, indexing="ij"), -1).reshape(-1, 3)
    assert qo.coherent_order(G) is None
    s = np.linspace(0, 20, 50000)
    assert qo.coherent_order(np.stack([np.cos(s), np.sin(s), s], 1)) is None
    assert qo.coherent_order(Q[:qo.COHERENT_FROM - 1]) is None     # small batches
    assert qo.coherent_order(np.zeros((10000, 3))) is None         # one spot


def test_a_long_thin_batch_is_ordered_in_cubic_cells():
    """Issue 60: queries around a 1000:1 needle. Scaled axis by axis, the curve's cells were
    250x longer than wide and consecutive queries lay tens of radii apart along the needle
    (a bad first bound for each exact search: 2.5x the time in ``bench_exact_mix.py``'s
    needle row); in cubic cells the median step is about the queries' mean spacing along the
    needle."""
    rng = np.random.default_rng(4)
    n = 20000
    z = rng.uniform(0, 2000, n)
    a = rng.uniform(0, 2 * np.pi, n)
    r = rng.uniform(1, 4, n)
    Q = np.stack([r * np.cos(a), r * np.sin(a), z], 1)
    order = qo.coherent_order(Q)
    assert order is not None
    step = qo.median_step(Q, order)
    # 10 bits along z: cells of about 2 units (the needle's diameter); the mean spacing of
    # the queries is (8 * 8 * 2000 / n)^(1/3) = 1.9, so a step within 3 of them is local
    assert step < 3 * (8 * 8 * 2000 / n) ** (1 / 3), step
    per_axis = np.clip((Q - Q.min(0)) * (1023.0 / np.ptp(Q, 0)), 0, 1023).astype(np.uint32)
    code = (qo._spread(per_axis[:, 0]) | (qo._spread(per_axis[:, 1]) << 1)
            | (qo._spread(per_axis[:, 2]) << 2))
    assert qo.median_step(Q, np.argsort(code, kind="stable")) > 5 * step


def test_reordered_queries_give_the_values_in_the_callers_order():
    field = sd.SmoothDistanceField(_mesh())
    rng = np.random.default_rng(1)
    Q = rng.uniform(-1.3, 1.3, (12000, 3))
    assert qo.coherent_order(Q) is not None
    d, g, st = field.smooth_distance(Q, alpha=20.0, return_stats=True)
    d2, g2, n2, l2 = _chunked(lambda q: (lambda r: (r[0], r[1], r[2].nodes_visited,
                                                    r[2].leaves_visited))(
        field.smooth_distance(q, alpha=20.0, return_stats=True)), Q)
    np.testing.assert_array_equal(d, d2)
    np.testing.assert_array_equal(g, g2)
    np.testing.assert_array_equal(st.nodes_visited, n2)
    np.testing.assert_array_equal(st.leaves_visited, l2)
    for _ in range(2):      # the smooth-distance tree, then the exact tree (built on use)
        de, ge, prim = field.exact_distance(Q, return_closest=True)
        de2, = _chunked(lambda q: (field.exact_distance(q).distance,), Q)
        np.testing.assert_allclose(de, de2, rtol=4e-16, atol=0)
        ref, _, _ = naive.exact_distance(Q[::10], field.mesh)
        np.testing.assert_allclose(de[::10], ref, rtol=1e-12, atol=1e-15)
        # the closest primitive is in the caller's order: its distance is the query's
        D = naive.distances_to_primitives(Q[:200], field.mesh)
        np.testing.assert_allclose(D[np.arange(200), prim[:200]], de[:200], rtol=1e-12)
        field.exact_tree


def test_short_groups_and_single_queries_search_like_one_query():
    """Groups of 1-3 queries (a batch of 1-3 rows, or a batch's last rows) and the one-by-one
    traversal (group 1, for scattered batches) find what groups of 4 and brute force find.
    (A short group once searched the whole tree: its repeated rows kept an infinite bound and
    opened every node. Their work is not counted per query, so this shows in time only:
    ``benchmarks/bench_exact_mix.py``'s batches of 100.)"""
    from smoothdist._kernels.exact_query import GROUP, exact_tree_batch

    field = sd.SmoothDistanceField(_mesh())
    et = field.exact_tree
    rng = np.random.default_rng(3)
    Q = np.ascontiguousarray(rng.uniform(-1.3, 1.3, (203, 3)))   # 203 = 50 groups + 3
    order = np.empty(0, dtype=np.int64)

    def run(q, group):
        n = q.shape[0]
        out = (np.empty(n), np.empty((n, 3)), np.empty(n, np.int64), np.empty(n, np.int64),
               np.empty(n, np.int64))
        exact_tree_batch(et, q, True, *out, 1, True, order, group)
        return out

    for n in (1, 2, 3):
        d, g, p, nodes, leaves = run(Q[:n], GROUP)
        np.testing.assert_array_equal(d, field.exact_distance(Q[:n]).distance)
    d4, _, _, n4, _ = run(Q, GROUP)
    d1, _, _, n1, _ = run(Q, 1)
    np.testing.assert_allclose(d1, d4, rtol=4e-16, atol=0)
    ref, _, _ = naive.exact_distance(Q[::7], field.mesh)
    np.testing.assert_allclose(d1[::7], ref, rtol=1e-12, atol=1e-15)


def test_the_median_step_of_a_small_batch_is_the_median_of_its_steps():
    """Issue 60: batches of up to ``SAMPLE_STEPS + 1`` rows take every step in a few numpy
    calls (the general path cost a solver 60 us a call); the value is the median of the
    steps' lengths, as numpy's ``median`` gives it (to rounding of the norm)."""
    rng = np.random.default_rng(5)
    for n in (1, 2, 3, 4, 7, 10, 11, 100, qo.SAMPLE_STEPS, qo.SAMPLE_STEPS + 1,
              qo.SAMPLE_STEPS + 2):
        Q = rng.normal(size=(n, 3))
        ref = float(np.median(np.linalg.norm(np.diff(Q, axis=0), axis=1))) if n > 1 else 0.0
        if n > qo.SAMPLE_STEPS + 1:       # sampled: evenly spread steps
            i = np.unique(np.linspace(0, n - 2, qo.SAMPLE_STEPS).astype(np.int64))
            ref = float(np.median(np.linalg.norm(Q[i + 1] - Q[i], axis=1)))
        assert qo.median_step(Q) == pytest.approx(ref, rel=1e-14, abs=0), n
