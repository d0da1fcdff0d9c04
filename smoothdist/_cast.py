"""Boundary coercion and validation: everything a kernel trusts is checked here first.

Every public entry point runs its arrays and parameters through these helpers, which raise a
``ValueError`` whose message names the offending argument, before any numba kernel runs.
"""

import math
import numbers

import numpy as np

#: Largest accepted absolute coordinate. The closest-point kernels multiply dot products of
#: coordinate differences (fourth powers of lengths), which stay finite in float64 only up to
#: about 1e75; 1e50 leaves room for queries far outside the data.
COORD_LIMIT = 1e50


def non_finite_rows(A, noun="row", plural=None):
    """Describe the rows of ``A (n, 3)`` with a NaN or infinite value: their count and the
    first one, e.g. ``"2 of 10 rows (first: row 3, [nan, 0.0, 1.0])"`` (0-based index)."""
    bad = ~np.all(np.isfinite(A), axis=1)
    first = int(np.argmax(bad))
    return (f"{int(bad.sum())} of {A.shape[0]} {plural or noun + 's'} (first: {noun} {first}, "
            f"{A[first].tolist()})")


def as_points(X, name="Q"):
    """Return ``X`` as a C-contiguous ``(n, 3)`` float64 array of finite values.

    A single point of shape ``(3,)`` is accepted and returned as ``(1, 3)``. Coordinates must
    be finite and at most :data:`COORD_LIMIT` in absolute value.
    """
    if np.iscomplexobj(X):
        raise ValueError(f"{name} must hold real coordinates, got a complex array")
    try:
        A = np.asarray(X, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be a numeric array of shape (n, 3): {exc}") from None
    if A.ndim == 1 and A.shape[0] == 3:
        A = A[None, :]
    if A.ndim != 2 or A.shape[1] != 3:
        raise ValueError(f"{name} must have shape (n, 3), got {A.shape}")
    # one reduction checks all three: the largest |x| is NaN with a NaN, inf with an inf
    if A.size and not np.abs(A).max() <= COORD_LIMIT:
        if not np.all(np.isfinite(A)):
            raise ValueError(f"{name} contains NaN or infinite coordinates: "
                             f"{non_finite_rows(A)}")
        bad = int(np.argmax(np.abs(A).max(axis=1) > COORD_LIMIT))
        raise ValueError(f"{name} has coordinates beyond +-{COORD_LIMIT:.0e} (first at row {bad}): "
                         "rescale or recentre the data")
    return np.ascontiguousarray(A)


def as_indices(F, n_vertices, k, name="F"):
    """Return ``F`` as a C-contiguous ``(m, k)`` int64 array of valid vertex indices."""
    try:
        A = np.asarray(F)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be an integer array of shape (m, {k}): {exc}") from None
    if A.size == 0:
        return np.zeros((0, k), dtype=np.int64)
    if A.ndim == 1 and k == 1:
        A = A[:, None]
    if A.ndim != 2 or A.shape[1] != k:
        raise ValueError(f"{name} must have shape (m, {k}), got {A.shape}")
    if not np.issubdtype(A.dtype, np.integer):
        if (np.issubdtype(A.dtype, np.floating) and np.all(np.isfinite(A))
                and np.all(A == np.round(A))):
            A = A.astype(np.int64)
        else:
            raise ValueError(f"{name} must hold integer vertex indices, got dtype {A.dtype}")
    A = A.astype(np.int64, copy=False)
    if A.min() < 0:
        raise ValueError(f"{name} has negative vertex indices (min {A.min()})")
    if A.max() >= n_vertices:
        raise ValueError(
            f"{name} has vertex index {A.max()} out of range for {n_vertices} vertices")
    return np.ascontiguousarray(A)


def positive(value, name, allow_inf=False):
    """Return ``value`` as a float after checking it is a finite number > 0."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f"{name} must be a positive number, got {value!r}")
    value = float(value)
    if math.isnan(value) or value <= 0 or (math.isinf(value) and not allow_inf):
        raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
    return value


def non_negative(value, name):
    """Return ``value`` as a float after checking it is a finite number >= 0."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f"{name} must be a number >= 0, got {value!r}")
    value = float(value)
    if not math.isfinite(value) or value < 0:
        raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
    return value
