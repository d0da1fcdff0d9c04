"""Property tests (hypothesis) of the library on random small meshes and random queries.

* Random meshes (points, edges, triangles, mixed), degenerate ones included (coordinates on a
  coarse grid, so duplicates, zero-length edges and zero-area triangles are common; indices
  occasionally out of range): building one either raises ``ValueError`` or succeeds, maybe
  with a ``MeshRepairWarning``; nothing else is raised or warned.
* On every mesh that builds, for random queries near and up to 1e6 bounding-box diagonals
  away and random ``alpha`` (``alpha x diagonal`` from 1e-2 to 1e4), ``alpha_U`` and ``beta``:
  ``d_hat`` and its gradient are finite; ``d - log(A^S N) / alpha <= d_hat <= d`` (exact,
  ``beta = 0``) with ``A = field.weight_bound``; and Barnes-Hut only lowers the value,
  ``d_hat(beta) <= d_hat(0)``.

``max_examples`` is small and ``deadline=None`` so that the file runs in a few seconds.
"""

import math
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from smoothdist import DataMesh, MeshRepairWarning, SmoothDistanceField

FUZZ = settings(max_examples=40, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                       HealthCheck.filter_too_much])

# coordinates: a coarse grid (degeneracies) or arbitrary floats in a box, at some scale
grid = st.integers(-2, 2).map(float)
free = st.floats(-3.0, 3.0, allow_nan=False, allow_infinity=False)
coord = st.one_of(grid, free)


@st.composite
def meshes(draw, allow_bad_indices=True):
    """``(V, points, edges, triangles)`` index arrays for a random (possibly invalid) mesh."""
    n = draw(st.integers(1, 9))
    scale = draw(st.sampled_from([1e-3, 1.0, 1e3]))
    offset = draw(st.sampled_from([0.0, 0.0, 1e6]))
    V = np.array(draw(st.lists(st.tuples(coord, coord, coord), min_size=n, max_size=n)),
                 dtype=float) * scale + offset
    lo = -1 if allow_bad_indices and draw(st.integers(0, 9)) == 0 else 0
    hi = n if allow_bad_indices and draw(st.integers(0, 9)) == 0 else n - 1
    idx = st.integers(lo, hi)
    kind = draw(st.sampled_from(["points", "edges", "triangles", "mixed"]))
    P = E = T = None
    if kind in ("points", "mixed"):
        P = draw(st.lists(idx, min_size=1 if kind == "points" else 0, max_size=6))
    if kind in ("edges", "mixed"):
        E = draw(st.lists(st.tuples(idx, idx), min_size=1 if kind == "edges" else 0,
                          max_size=8))
    if kind in ("triangles", "mixed"):
        T = draw(st.lists(st.tuples(idx, idx, idx), min_size=1 if kind == "triangles" else 0,
                          max_size=8))
    arr = (lambda x, k: None if x is None else np.array(x, dtype=np.int64).reshape(-1, k))
    return V, (None if P is None else np.array(P, dtype=np.int64)), arr(E, 2), arr(T, 3)


def build(V, P, E, T):
    """Build a field: ``(field or None, repair warnings)``; only ValueError may be raised."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            if P is None and E is None and T is None:
                mesh = DataMesh(V)
            else:
                mesh = DataMesh(V, points=P, edges=E, triangles=T)
            field = SmoothDistanceField(mesh)
        except ValueError as exc:
            assert str(exc).strip() and "\n" not in str(exc).strip()
            field = None
    other = [str(w.message) for w in caught if not issubclass(w.category, MeshRepairWarning)]
    assert not other, other
    return field, [str(w.message) for w in caught if issubclass(w.category, MeshRepairWarning)]


def queries(field, draw):
    """Random queries: on the data, near it, and up to 1e6 diagonals away."""
    lo, hi = field.bounds
    c = 0.5 * (lo + hi)
    L = field.diagonal if field.diagonal > 0 else 1.0
    k = draw(st.integers(1, 6))
    exps = draw(st.lists(st.floats(-3.0, 6.0), min_size=k, max_size=k))
    dirs = draw(st.lists(st.tuples(free, free, free), min_size=k, max_size=k))
    dirs = np.array(dirs) + 1e-3
    dirs /= np.linalg.norm(dirs, axis=1)[:, None]
    Q = c + dirs * (L * 10.0 ** np.array(exps))[:, None]
    return np.concatenate([Q, field.mesh.V[:2]])


@FUZZ
@given(meshes())
def test_random_meshes_build_or_raise_value_error(mesh):
    field, repairs = build(*mesh)
    if field is not None:
        assert field.num_primitives >= 1
        assert math.isfinite(field.diagonal) and field.weight_bound >= 1.0
    for msg in repairs:
        assert any(w in msg for w in ("merged", "dropped")), msg


@FUZZ
@given(meshes(allow_bad_indices=False), st.data())
def test_smooth_distance_is_finite_and_conservative(mesh, data):
    field, _ = build(*mesh)
    assume(field is not None)
    L = field.diagonal if field.diagonal > 0 else 1.0
    alpha = 10.0 ** data.draw(st.floats(-2.0, 4.0), label="log10 alpha x L") / L
    alpha_u = data.draw(st.one_of(st.none(), st.floats(0.1, 10.0).map(lambda f: f * alpha)),
                        label="alpha_u")
    gradient = data.draw(st.sampled_from(["metric", "exact"]), label="gradient")
    Q = queries(field, data.draw)
    d, gd = field.exact_distance(Q)
    assert np.isfinite(d).all() and np.isfinite(gd).all()
    dh0, g0 = field.smooth_distance(Q, alpha=alpha, beta=0.0, alpha_u=alpha_u,
                                    gradient=gradient)
    assert np.isfinite(dh0).all() and np.isfinite(g0).all()
    tol = 1e-9 * (np.abs(d) + L + 1.0 / alpha) + 1e-9 * np.abs(Q).max(axis=1)
    A, N = field.weight_bound, field.num_primitives
    S = field.attenuation(alpha, alpha_u)
    assert np.all(dh0 <= d + tol), (dh0 - d).max()
    assert np.all(dh0 >= d - (S * math.log(A) + math.log(N)) / alpha - tol)
    beta = data.draw(st.floats(0.05, 5.0), label="beta")
    dh, g = field.smooth_distance(Q, alpha=alpha, beta=beta, alpha_u=alpha_u, gradient=gradient)
    assert np.isfinite(dh).all() and np.isfinite(g).all()
    assert np.all(dh <= dh0 + tol), (dh - dh0).max()


@FUZZ
@given(meshes(allow_bad_indices=False), st.floats(-2.0, 4.0))
def test_point_cloud_gradient_has_unit_length_far_away(mesh, log_alpha):
    """Far from any data the smooth distance grows like the distance: |grad| ~ 1."""
    V = mesh[0]
    field, _ = build(V, None, None, None)
    assume(field is not None)
    L = field.diagonal if field.diagonal > 0 else 1.0
    lo, hi = field.bounds
    Q = 0.5 * (lo + hi) + np.array([[1.0, 2.0, 2.0]]) / 3.0 * 1e3 * L
    dh, g = field.smooth_distance(Q, alpha=10.0 ** log_alpha / L, beta=0.0)
    assert np.isfinite(dh).all()
    assert abs(np.linalg.norm(g[0]) - 1.0) < 1e-3


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf, 1e60])
def test_non_finite_or_huge_vertices_raise_value_error(bad):
    V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    V[1, 2] = bad
    with pytest.raises(ValueError, match="V "):
        SmoothDistanceField(V, [[0, 1, 2]])
