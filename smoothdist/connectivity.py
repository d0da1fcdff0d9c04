"""Mesh connectivity in linear-ish time: rows of vertex indices as single int64 keys.

``np.unique(rows, axis=0)`` sorts a structured view of the rows and costs about a second per
million triangles; the functions here pack a row of ``k`` indices below ``n`` into one int64
``((i0 n + i1) n + i2)`` whenever ``n ** k`` fits (``n`` up to 3e9 for edges, 2e6 for
triangles), and sort those instead: the same answers (the key order is the rows' lexicographic
order), 5-20x faster on a 1.3M-triangle mesh. Wider rows fall back to ``np.lexsort``.

Every array is int64; rows are sorted within themselves by the callers where the row is a set
(an undirected edge, a triangle's vertex set).
"""

import numpy as np

#: largest key value (int64)
_KEY_MAX = np.iinfo(np.int64).max


def row_keys(rows, n):
    """``(r,)`` int64 keys of the rows of ``rows (r, k)`` (indices in ``[0, n)``), ordered as
    the rows are lexicographically, or ``None`` when ``n ** k`` does not fit in an int64."""
    rows = np.asarray(rows, dtype=np.int64)
    k = rows.shape[1]
    n = max(int(n), 1)
    if n ** k - 1 > _KEY_MAX:
        return None
    key = rows[:, 0].copy()
    for j in range(1, k):
        key *= n
        key += rows[:, j]
    return key


def _runs(rows, key, stable=False):
    """``(order, new)``: an order sorting ``rows (r, k)`` (r >= 1) lexicographically, by their
    ``key`` where given (stably with ``stable``; the lexsort fallback always is), and ``new
    (r,) bool``, True where a sorted row differs from the one before (the start of a run of
    equal rows)."""
    new = np.empty(rows.shape[0], dtype=bool)
    new[0] = True
    if key is None:
        order = np.lexsort(rows.T[::-1])
        sr = rows[order]
        np.any(sr[1:] != sr[:-1], axis=1, out=new[1:])
    else:
        order = np.argsort(key, kind="stable" if stable else None)
        sk = key[order]
        np.not_equal(sk[1:], sk[:-1], out=new[1:])
    return order, new


def first_of_each(rows, n):
    """Indices ``(u,)`` of the first occurrence of each distinct row of ``rows (r, k)``, in
    increasing order: ``rows[first_of_each(rows, n)]`` keeps every row once, in the input's
    order."""
    rows = np.asarray(rows, dtype=np.int64)
    if rows.shape[0] < 2:
        return np.arange(rows.shape[0])
    key = row_keys(rows, n)
    if key is not None:
        s = np.sort(key)
        if not np.any(s[1:] == s[:-1]):       # the common case: nothing repeats
            return np.arange(rows.shape[0])
    order, new = _runs(rows, key, stable=True)
    return np.sort(order[new])


def unique_sorted_rows(rows, n):
    """``(u, k)`` the distinct rows of ``rows (r, k)``, in lexicographic order (as
    ``np.unique(rows, axis=0)``)."""
    rows = np.asarray(rows, dtype=np.int64)
    if rows.shape[0] == 0:
        return rows.reshape(0, rows.shape[1])
    order, new = _runs(rows, row_keys(rows, n))
    return np.ascontiguousarray(rows[order[new]])


def row_counts(rows, n):
    """``(r,)`` how many times each row of ``rows (r, k)`` occurs in ``rows``."""
    rows = np.asarray(rows, dtype=np.int64)
    if rows.shape[0] == 0:
        return np.zeros(0, dtype=np.int64)
    return _run_lengths(*_runs(rows, row_keys(rows, n)))


def key_counts(key):
    """``(r,)`` how many times each entry of the int64 keys ``key (r,)`` occurs in ``key``
    (one sort and its runs: half the time of ``np.unique`` with ``return_inverse`` and
    ``return_counts``, 0.22 s against 0.44 for 3M keys)."""
    if key.size == 0:
        return np.zeros(0, dtype=np.int64)
    return _run_lengths(*_runs(key[:, None], key))


def _run_lengths(order, new):
    """Each sorted row's run length, in the rows' own order (:func:`_runs`' output)."""
    r = order.size
    starts = np.flatnonzero(new)
    lengths = np.diff(np.append(starts, r))
    out = np.empty(r, dtype=np.int64)
    out[order] = np.repeat(lengths, lengths)
    return out


def triangle_half_edges(T):
    """``(3 t, 2)`` the three edges of every triangle of ``T (t, 3)``, each row sorted: the
    edges ``(0 1)`` of every triangle, then ``(1 2)``, then ``(2 0)``."""
    T = np.asarray(T, dtype=np.int64)
    a = np.concatenate([T[:, 0], T[:, 1], T[:, 2]])
    b = np.concatenate([T[:, 1], T[:, 2], T[:, 0]])
    return np.stack([np.minimum(a, b), np.maximum(a, b)], axis=1)


def unique_edges(T, n=None):
    """Unique undirected edges ``(e, 2)`` int64 of triangles ``T (t, 3)``, sorted per row and
    in lexicographic order (``n``: the number of vertices, default ``T.max() + 1``)."""
    T = np.asarray(T, dtype=np.int64)
    if T.shape[0] == 0:
        return np.zeros((0, 2), dtype=np.int64)
    n = int(T.max()) + 1 if n is None else max(int(n), 1)
    if n * n - 1 > _KEY_MAX:
        return unique_sorted_rows(triangle_half_edges(T), n)
    # the keys straight from the corners, no (3 t, 2) rows in between
    keys = np.empty(3 * T.shape[0], dtype=np.int64)
    for j, (a, b) in enumerate(((0, 1), (1, 2), (2, 0))):
        out = keys[j * T.shape[0]:(j + 1) * T.shape[0]]
        np.minimum(T[:, a], T[:, b], out=out)
        out *= n
        out += np.maximum(T[:, a], T[:, b])
    keys.sort()
    keys = keys[np.concatenate([[True], keys[1:] != keys[:-1]])]
    return np.stack([keys // n, keys % n], axis=1)


def has_equal_rows(X):
    """Whether two rows of the float array ``X (r, 3)`` are equal (``-0.0 == 0.0``; finite
    values). A hash of each row's bits, sorted: equal rows have equal hashes, so distinct
    hashes prove there are none; only a hash collision costs the exact lexicographic check."""
    X = np.ascontiguousarray(X, dtype=np.float64)
    if X.shape[0] < 2:
        return False
    bits = (X + 0.0).view(np.uint64)             # + 0.0: -0.0 becomes 0.0
    h = bits[:, 0] * np.uint64(0x9E3779B97F4A7C15)
    h ^= bits[:, 1] * np.uint64(0xC2B2AE3D27D4EB4F)
    h ^= bits[:, 2] * np.uint64(0x165667B19E3779F9)
    h.sort()
    if not np.any(h[1:] == h[:-1]):
        return False
    order = np.lexsort((X[:, 2], X[:, 1], X[:, 0]))
    Xs = X[order]
    return bool(np.any(np.all(Xs[1:] == Xs[:-1], axis=1)))
