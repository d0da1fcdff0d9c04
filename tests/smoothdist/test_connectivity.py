"""smoothdist.connectivity against numpy's own row-wise ``np.unique`` and brute force: the
packed int64 keys must give the same rows, first occurrences, counts and order, also where the
keys do not fit (the lexsort fallback) and for equal floats (``-0.0 == 0.0``)."""

import numpy as np
import pytest

from smoothdist import connectivity as cn


def random_rows(rng, r, k, n):
    """``(r, k)`` rows of indices below ``n`` with many repeats (some rows twice or more)."""
    rows = rng.integers(0, n, (r, k))
    rows[r // 2:] = rows[rng.integers(0, r // 2, r - r // 2)]
    return rng.permutation(rows)


# n = 2**40: the keys of 2 or 3 columns do not fit in an int64 (the lexsort fallback)
@pytest.mark.parametrize("k,n", [(1, 7), (2, 50), (3, 30), (2, 2 ** 31), (2, 2 ** 40),
                                 (3, 2 ** 40)])
def test_the_keys_give_numpys_answers(rng, k, n):
    rows = random_rows(rng, 400, k, n)
    key = cn.row_keys(rows, n)
    if n ** k > 2 ** 63:
        assert key is None
    else:
        # the key order is the rows' lexicographic order
        np.testing.assert_array_equal(np.argsort(key, kind="stable"),
                                      np.lexsort(rows.T[::-1]))
    ref_rows, ref_first, ref_inv, ref_counts = np.unique(rows, axis=0, return_index=True,
                                                         return_inverse=True,
                                                         return_counts=True)
    np.testing.assert_array_equal(cn.unique_sorted_rows(rows, n), ref_rows)
    np.testing.assert_array_equal(cn.first_of_each(rows, n), np.sort(ref_first))
    np.testing.assert_array_equal(cn.row_counts(rows, n), ref_counts[ref_inv.ravel()])
    if key is not None:     # the counts of the keys themselves (the junction weights' edges)
        np.testing.assert_array_equal(cn.key_counts(key), ref_counts[ref_inv.ravel()])


def test_rows_without_repeats_and_tiny_inputs(rng):
    rows = np.unique(rng.integers(0, 100, (300, 2)), axis=0)
    np.testing.assert_array_equal(cn.first_of_each(rows, 100), np.arange(rows.shape[0]))
    np.testing.assert_array_equal(cn.row_counts(rows, 100), np.ones(rows.shape[0]))
    for r in (0, 1):
        rows = np.zeros((r, 3), dtype=np.int64)
        assert cn.first_of_each(rows, 5).size == r
        assert cn.unique_sorted_rows(rows, 5).shape == (r, 3)
        assert cn.row_counts(rows, 5).size == r
        assert cn.key_counts(np.zeros(r, dtype=np.int64)).size == r


def test_unique_edges_of_triangles(rng):
    T = rng.integers(0, 40, (200, 3))
    T = T[(T[:, 0] != T[:, 1]) & (T[:, 1] != T[:, 2]) & (T[:, 0] != T[:, 2])]
    brute = sorted({tuple(sorted((int(t[i]), int(t[(i + 1) % 3])))) for t in T
                    for i in range(3)})
    np.testing.assert_array_equal(cn.unique_edges(T), np.array(brute))
    np.testing.assert_array_equal(cn.unique_edges(T, 40), np.array(brute))
    np.testing.assert_array_equal(cn.unique_edges(T, 2 ** 40), np.array(brute))  # no keys
    assert cn.unique_edges(np.zeros((0, 3), dtype=np.int64)).shape == (0, 2)


def test_equal_rows_of_floats(rng):
    X = rng.normal(size=(500, 3))
    assert not cn.has_equal_rows(X)
    Y = X.copy()
    Y[17] = Y[400]
    assert cn.has_equal_rows(Y)
    # -0.0 equals 0.0, as numpy's comparisons (and np.unique) have it
    Z = np.array([[0.0, 1.0, 2.0], [-0.0, 1.0, 2.0], [3.0, 4.0, 5.0]])
    assert cn.has_equal_rows(Z)
    assert np.unique(Z, axis=0).shape[0] == 2
    assert not cn.has_equal_rows(X[:1])
    # rows that share two coordinates but not the third are not equal
    W = np.array([[1.0, 2.0, 3.0], [1.0, 2.0, 4.0], [1.0, 5.0, 3.0]])
    assert not cn.has_equal_rows(W)
