"""Large query batches run in passes of ``QUERY_CHUNK`` queries (a fixed working set beside
the outputs): the values, gradients, closest primitives and statistics are those of one pass,
bit for bit, on both exact trees and every smooth path (tasks, prange, tol, brute)."""

import numpy as np
import pytest

from smoothdist import SmoothDistanceField, field as field_module


@pytest.fixture(scope="module")
def queries():
    rng = np.random.default_rng(5)
    Q = rng.uniform(-1.3, 1.3, (900, 3))
    Q[::7] = Q[::7] * 0.01          # some near the centre, out of order
    return Q


def both(monkeypatch, call):
    whole = call()
    monkeypatch.setattr(field_module, "QUERY_CHUNK", 128)
    parts = call()
    monkeypatch.undo()
    return whole, parts


def same(a, b):
    for x, y in zip(a, b):
        if isinstance(x, tuple):
            same(x, y)
        else:
            np.testing.assert_array_equal(x, y)


@pytest.mark.parametrize("kw", [dict(beta=0.5), dict(beta=0.0, tol=0.01), dict(beta=0.2),
                                dict(beta=0.0, method="brute")])
def test_smooth_passes_equal_one_pass(icosphere, queries, monkeypatch, kw):
    field = SmoothDistanceField(icosphere)
    tol = kw.pop("tol", 0.0)
    whole, parts = both(monkeypatch, lambda: field.smooth_distance(
        queries, alpha=20.0, alpha_u="auto", return_stats=True, tol=tol, **kw))
    same(whole, parts)
    monkeypatch.setattr(field_module, "TASK_BATCH", 0)       # the prange kernel for every pass
    same(whole, field.smooth_distance(queries, alpha=20.0, alpha_u="auto", return_stats=True,
                                      tol=tol, **kw))


@pytest.mark.parametrize("exact_tree", [False, True])
def test_exact_passes_equal_one_pass(mixed_mesh, queries, monkeypatch, exact_tree):
    field = SmoothDistanceField(mixed_mesh)
    if exact_tree:
        field.exact_tree      # built: every call searches it
    whole, parts = both(monkeypatch, lambda: field.exact_distance(
        queries, return_closest=True, return_stats=True))
    same(whole, parts)
    d, g = field.exact_distance(queries[:0])
    assert d.shape == (0,) and g.shape == (0, 3)
