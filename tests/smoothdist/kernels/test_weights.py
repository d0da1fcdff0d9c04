"""Tests for smoothdist._kernels.weights (Madan & Levin 2022, Appendix C weight functions)."""

import numpy as np
import pytest

from smoothdist._kernels import weights as W
from smoothdist._kernels.weights import (
    edge_weight_coefficients,
    edge_weight_max,
    edge_weight_range,
    eval_edge_weight,
    eval_triangle_weight,
    triangle_weight_coefficients,
    triangle_weight_range,
)

EDGE_PAIRS = [(a, b) for a in range(1, 13) for b in range(1, 13)] + [(1, 50), (37, 2), (100, 100)]
TRI_PAIRS = [(2, 1), (3, 2), (4, 2), (5, 2), (6, 2), (7, 2), (8, 2), (12, 2), (3, 3), (4, 3), (6, 3)]
MANIFOLD_PAIRS = [(v, e) for (v, e) in TRI_PAIRS if v >= 3 and e == 2]

RNG = np.random.default_rng(12345)


# ----------------------------------------------------------------------------- helpers
def edge_np(c, t):
    """Independent numpy evaluation of the quartic and its derivative."""
    P = np.polynomial.polynomial
    c = np.asarray(c[:5], dtype=np.float64)
    return P.polyval(t, c), P.polyval(t, P.polyder(c))


EXPONENTS = [(k - j, j) for k in range(8) for j in range(k + 1)]  # s^a t^b, 36 monomials


def full_eval(x, s, t):
    """Value and gradient of a 36-coefficient monomial polynomial (numpy, independent)."""
    s = np.asarray(s, dtype=np.float64)
    t = np.asarray(t, dtype=np.float64)
    w = np.zeros(np.broadcast(s, t).shape)
    ws = np.zeros_like(w)
    wt = np.zeros_like(w)
    for xi, (a, b) in zip(x, EXPONENTS):
        w = w + xi * s**a * t**b
        if a:
            ws = ws + xi * a * s ** (a - 1) * t**b
        if b:
            wt = wt + xi * b * s**a * t ** (b - 1)
    return w, ws, wt


def thirteen_np(c, s, t):
    """Direct numpy evaluation of the 13-term symmetric form, term by term."""
    s = np.asarray(s, dtype=np.float64)
    t = np.asarray(t, dtype=np.float64)
    terms = [
        np.ones_like(s * t),
        s**2 + t**2,
        s**3 + t**3,
        s**4 + t**4,
        s**2 * t**2,
        s**5 + t**5,
        s**3 * t**2 + s**2 * t**3,
        s**6 + t**6,
        s**4 * t**2 + s**2 * t**4,
        s**3 * t**3,
        s**7 + t**7,
        s**5 * t**2 + s**2 * t**5,
        s**4 * t**3 + s**3 * t**4,
    ]
    return sum(ci * term for ci, term in zip(c[:13], terms))


def independent_full_solution(v, e):
    """Re-derive the minimum-norm 36-coefficient solution with a differently built system.

    The boundary normal-derivative conditions are imposed by collocation: each is a
    degree-6 polynomial in the boundary parameter, so vanishing at 7 distinct points is
    equivalent to vanishing identically. The solution set is the same affine space as the
    coefficient-matching system, so the minimum-norm solution must coincide.
    """
    rows, rhs = [], []

    def mono(s, t):
        return [s**a * t**b for (a, b) in EXPONENTS]

    def d_s(s, t):
        return [a * s ** (a - 1) * t**b if a else 0.0 for (a, b) in EXPONENTS]

    def d_t(s, t):
        return [b * s**a * t ** (b - 1) if b else 0.0 for (a, b) in EXPONENTS]

    for p in [(0, 0), (1, 0), (0, 1)]:
        rows.append(mono(*p))
        rhs.append(1.0 / v)
    for p in [(1 / 3, 0), (2 / 3, 0), (0, 1 / 3), (0, 2 / 3), (1 / 3, 2 / 3), (2 / 3, 1 / 3)]:
        rows.append(mono(*p))
        rhs.append(1.0 / e)
    rows.append(mono(1 / 3, 1 / 3))
    rhs.append((v - 1.0) / v)
    nodes = np.linspace(0.05, 0.95, 7)
    for u in nodes:
        rows.append(d_s(0.0, u))
        rhs.append(0.0)
        rows.append(d_t(u, 0.0))
        rhs.append(0.0)
        rows.append(np.add(d_s(1 - u, u), d_t(1 - u, u)))
        rhs.append(0.0)
    A = np.array(rows, dtype=np.float64)
    b = np.array(rhs)
    x = np.linalg.pinv(A, rcond=1e-11) @ b
    assert np.max(np.abs(A @ x - b)) < 1e-9
    return x


# ----------------------------------------------------------------------------- edges
@pytest.mark.parametrize("n0,n1", EDGE_PAIRS)
def test_edge_constraints(n0, n1):
    c = edge_weight_coefficients(n0, n1)
    assert c.shape == (5,) and c.dtype == np.float64
    w, dw = edge_np(c, np.array([0.0, 0.5, 1.0]))
    assert abs(w[0] - 1.0 / n0) < 1e-12
    assert abs(w[1] - 1.0) < 1e-12
    assert abs(w[2] - 1.0 / n1) < 1e-12
    assert abs(dw[0]) < 1e-12
    assert abs(dw[2]) < 1e-12


@pytest.mark.parametrize("n0,n1", [(1, 1), (1, 5), (3, 7), (12, 2)])
def test_edge_closed_form_matches_linear_solve(n0, n1):
    # rows: w(0), w(1), w(1/2), w'(0), w'(1)
    A = np.array(
        [
            [1, 0, 0, 0, 0],
            [1, 1, 1, 1, 1],
            [1, 0.5, 0.25, 0.125, 0.0625],
            [0, 1, 0, 0, 0],
            [0, 1, 2, 3, 4],
        ],
        dtype=np.float64,
    )
    rhs = np.array([1.0 / n0, 1.0 / n1, 1.0, 0.0, 0.0])
    np.testing.assert_allclose(edge_weight_coefficients(n0, n1), np.linalg.solve(A, rhs), atol=1e-12)


@pytest.mark.parametrize("n0,n1", [(a, b) for a in (1, 2, 3, 6, 12) for b in (1, 2, 5, 9)])
def test_edge_max_and_range_match_dense_sampling(n0, n1):
    c = edge_weight_coefficients(n0, n1)
    t = np.linspace(0.0, 1.0, 100_001)
    samples, _ = edge_np(c, t)
    wmax = edge_weight_max(c)
    assert abs(wmax - samples.max()) < 1e-9
    assert wmax >= samples.max() - 1e-15
    lo, hi = edge_weight_range(c)
    assert hi == wmax
    assert abs(lo - samples.min()) < 1e-9
    assert lo <= samples.min() + 1e-15
    assert abs(lo - min(1.0 / n0, 1.0 / n1)) < 1e-12


def test_edge_max_authors_example():
    """docs/authors-code.md §3: end valences 1 and 5 give a maximum of 1.11."""
    c = edge_weight_coefficients(1, 5)
    wmax = edge_weight_max(c)
    assert abs(wmax - 1.11) < 5e-3
    assert wmax > 1.0
    t = np.linspace(0, 1, 100_001)
    w, _ = edge_np(c, t)
    assert abs(t[np.argmax(w)] - 0.31) < 0.01
    # the closed-form critical point c2 / (2 c4) = 0.3125
    assert abs(edge_np(c, 0.3125)[0] - wmax) < 1e-14


def test_edge_equal_valences_max_is_one():
    for n in (1, 2, 4, 9):
        assert abs(edge_weight_max(edge_weight_coefficients(n, n)) - 1.0) < 1e-13


def test_edge_range_generic_coefficients():
    # coefficient vectors without the Hermite structure exercise the cubic-root fallback
    t = np.linspace(0.0, 1.0, 100_001)
    for _ in range(30):
        c = RNG.normal(size=5)
        samples, _ = edge_np(c, t)
        lo, hi = edge_weight_range(c)
        assert abs(hi - samples.max()) < 1e-9 and hi >= samples.max() - 1e-12
        assert abs(lo - samples.min()) < 1e-9 and lo <= samples.min() + 1e-12
    assert edge_weight_range(np.array([2.0, 0, 0, 0, 0])) == (2.0, 2.0)
    # linear: max at the endpoint
    assert edge_weight_range(np.array([1.0, -3.0, 0, 0, 0])) == (-2.0, 1.0)


@pytest.mark.parametrize("n0,n1", [(1, 5), (2, 3), (7, 7), (4, 1)])
def test_edge_kernel_derivative_finite_difference(n0, n1):
    c = edge_weight_coefficients(n0, n1)
    h = 1e-6
    for t in np.linspace(0.0, 1.0, 23):
        w, dw = eval_edge_weight(c, t)
        wp, _ = eval_edge_weight(c, t + h)
        wm, _ = eval_edge_weight(c, t - h)
        assert abs(dw - (wp - wm) / (2 * h)) < 1e-7


def test_edge_kernel_matches_numpy():
    for n0, n1 in [(1, 5), (3, 2), (10, 1)]:
        c = np.concatenate([edge_weight_coefficients(n0, n1), [99.0, -7.0]])  # length >= 5
        for t in RNG.uniform(-0.2, 1.2, size=50):
            w, dw = eval_edge_weight(c, t)
            wn, dwn = edge_np(c, t)
            assert abs(w - wn) < 1e-13
            assert abs(dw - dwn) < 1e-12


def test_edge_invalid_valence():
    with pytest.raises(ValueError):
        edge_weight_coefficients(0, 2)
    with pytest.raises(ValueError):
        edge_weight_coefficients(2, 1.5)


# ----------------------------------------------------------------------------- triangles
@pytest.fixture(scope="module")
def tri_coeffs():
    return {ve: triangle_weight_coefficients(*ve) for ve in TRI_PAIRS}


def test_triangle_shape_and_cache_copy():
    c = triangle_weight_coefficients(6, 2)
    assert c.shape == (13,) and c.dtype == np.float64
    c[:] = 123.0
    c2 = triangle_weight_coefficients(6, 2)
    assert not np.any(c2 == 123.0)
    assert c2.flags.writeable


@pytest.mark.parametrize("ve", TRI_PAIRS)
def test_triangle_point_constraints(ve, tri_coeffs):
    v, e = ve
    c = tri_coeffs[ve]
    for s, t in [(0, 0), (1, 0), (0, 1)]:
        assert abs(eval_triangle_weight(c, float(s), float(t))[0] - 1.0 / v) < 1e-9
    for s, t in [(1 / 3, 0), (2 / 3, 0), (0, 1 / 3), (0, 2 / 3), (1 / 3, 2 / 3), (2 / 3, 1 / 3)]:
        assert abs(eval_triangle_weight(c, s, t)[0] - 1.0 / e) < 1e-9
    assert abs(eval_triangle_weight(c, 1 / 3, 1 / 3)[0] - (v - 1.0) / v) < 1e-9


@pytest.mark.parametrize("ve", TRI_PAIRS)
def test_triangle_normal_derivatives_vanish(ve, tri_coeffs):
    c = tri_coeffs[ve]
    for u in np.linspace(0.0, 1.0, 41):
        assert abs(eval_triangle_weight(c, 0.0, u)[1]) < 1e-9  # d/ds on s = 0
        assert abs(eval_triangle_weight(c, u, 0.0)[2]) < 1e-9  # d/dt on t = 0
        _, ds, dt = eval_triangle_weight(c, 1.0 - u, u)  # (d/ds + d/dt) on s + t = 1
        assert abs(ds + dt) < 1e-9
    # same check with the independent term-by-term form and finite differences
    h = 1e-6
    u = np.linspace(0.0, 1.0, 41)
    z = np.zeros_like(u)
    d_s0 = (thirteen_np(c, z + h, u) - thirteen_np(c, z - h, u)) / (2 * h)
    d_hyp = (thirteen_np(c, 1 - u + h, u + h) - thirteen_np(c, 1 - u - h, u - h)) / (2 * h)
    assert np.max(np.abs(d_s0)) < 1e-7
    assert np.max(np.abs(d_hyp)) < 1e-7


@pytest.mark.parametrize("ve", TRI_PAIRS)
def test_triangle_symmetry(ve, tri_coeffs):
    c = tri_coeffs[ve]
    for s, t in RNG.uniform(0.0, 1.0, size=(40, 2)):
        w1, ds1, dt1 = eval_triangle_weight(c, s, t)
        w2, ds2, dt2 = eval_triangle_weight(c, t, s)
        assert abs(w1 - w2) < 1e-13
        assert abs(ds1 - dt2) < 1e-12 and abs(dt1 - ds2) < 1e-12


@pytest.mark.parametrize("ve", TRI_PAIRS)
def test_triangle_kernel_derivative_finite_difference(ve, tri_coeffs):
    c = tri_coeffs[ve]
    h = 1e-6
    for s, t in RNG.uniform(0.0, 1.0, size=(30, 2)):
        _, ds, dt = eval_triangle_weight(c, s, t)
        fd_s = (eval_triangle_weight(c, s + h, t)[0] - eval_triangle_weight(c, s - h, t)[0]) / (2 * h)
        fd_t = (eval_triangle_weight(c, s, t + h)[0] - eval_triangle_weight(c, s, t - h)[0]) / (2 * h)
        assert abs(ds - fd_s) < 1e-6
        assert abs(dt - fd_t) < 1e-6


@pytest.mark.parametrize("ve", TRI_PAIRS)
def test_triangle_matches_independent_full_solution(ve, tri_coeffs):
    c = tri_coeffs[ve]
    x = independent_full_solution(*ve)
    s, t = RNG.uniform(0.0, 1.0, size=(2, 200))
    inside = s + t <= 1.0
    s, t = s[inside], t[inside]
    wf, wfs, wft = full_eval(x, s, t)
    w13 = thirteen_np(c, s, t)
    np.testing.assert_allclose(w13, wf, atol=1e-9)
    for si, ti, a, b, cc in zip(s[:30], t[:30], wf, wfs, wft):
        w, ds, dt = eval_triangle_weight(c, si, ti)
        assert abs(w - a) < 1e-9 and abs(ds - b) < 1e-8 and abs(dt - cc) < 1e-8


@pytest.mark.parametrize("ve", MANIFOLD_PAIRS)
def test_triangle_manifold_range(ve, tri_coeffs):
    v, _ = ve
    lo, hi = triangle_weight_range(tri_coeffs[ve])
    assert abs(lo - 1.0 / v) < 1e-3
    assert lo > 0.0
    assert hi <= 1.0 + 1e-9
    assert hi >= (v - 1.0) / v - 1e-3  # the interior peak is at least the barycenter target


def test_triangle_nonmanifold_dips_below_one_over_v(tri_coeffs):
    # documented behaviour of the paper's construction (docs/authors-code.md §3 table)
    for ve, expected in [((2, 1), 0.443), ((3, 3), 0.186), ((4, 3), 0.123), ((6, 3), 0.055)]:
        lo, _ = triangle_weight_range(tri_coeffs[ve])
        assert abs(lo - expected) < 2e-3
        assert lo < 1.0 / ve[0]


def test_triangle_isolated_is_constant_one():
    c = triangle_weight_coefficients(1, 1)
    np.testing.assert_array_equal(c, np.r_[1.0, np.zeros(12)])
    for s, t in RNG.uniform(0, 0.5, size=(10, 2)):
        assert eval_triangle_weight(c, s, t) == (1.0, 0.0, 0.0)
    assert triangle_weight_range(c) == (1.0, 1.0)


def test_triangle_two_two_is_constant_half():
    lo, hi = triangle_weight_range(triangle_weight_coefficients(2, 2))
    assert abs(lo - 0.5) < 1e-9 and abs(hi - 0.5) < 1e-9


def test_triangle_invalid_inputs():
    with pytest.raises(ValueError):
        triangle_weight_coefficients(3, 4)
    with pytest.raises(ValueError):
        triangle_weight_coefficients(0, 0)


def test_triangle_range_samples_include_boundary():
    c = np.zeros(13)
    c[1] = 1.0  # w = s^2 + t^2: min 0 at (0,0), max 1 at (1,0) and (0,1)
    assert triangle_weight_range(c, n=7) == (0.0, 1.0)
    c = np.zeros(13)
    c[4] = 1.0  # w = s^2 t^2: max at (1/2, 1/2) on the hypotenuse = 1/16
    lo, hi = triangle_weight_range(c, n=10)
    assert lo == 0.0 and abs(hi - 1.0 / 16) < 1e-15
    # agrees with a brute-force sampling of the same grid
    c = triangle_weight_coefficients(4, 3)
    n = 37
    pts = [(i / n, j / n) for i in range(n + 1) for j in range(n + 1 - i)]
    vals = [thirteen_np(c, s, t) for s, t in pts]
    lo, hi = triangle_weight_range(c, n=n)
    assert abs(lo - min(vals)) < 1e-13 and abs(hi - max(vals)) < 1e-13


def test_triangle_kernel_matches_numpy():
    for ve in [(3, 2), (6, 3), (2, 1)]:
        c = np.concatenate([triangle_weight_coefficients(*ve), [5.0, -1.0]])  # length >= 13
        for s, t in RNG.uniform(-0.1, 1.1, size=(50, 2)):
            w, _, _ = eval_triangle_weight(c, s, t)
            assert abs(w - thirteen_np(c, s, t)) < 1e-12
            assert abs(w - W._triangle_poly(c, s, t)) < 1e-12
    # random (non-solution) coefficients: kernel value and derivatives vs 36-monomial form
    for _ in range(5):
        c = RNG.normal(size=13)
        x = np.zeros(36)
        for k, idx in enumerate(W._STORED):
            a, b = EXPONENTS[idx]
            x[idx] += c[k]
            if a != b:
                x[EXPONENTS.index((b, a))] += c[k]
        for s, t in RNG.uniform(0.0, 1.0, size=(20, 2)):
            w, ds, dt = eval_triangle_weight(c, s, t)
            a, b, cc = full_eval(x, s, t)
            assert abs(w - a) < 1e-12 and abs(ds - b) < 1e-11 and abs(dt - cc) < 1e-11


def test_stored_index_layout():
    # the 13 stored indices are the authors' full-basis positions of the listed monomials
    expected = [(0, 0), (2, 0), (3, 0), (4, 0), (2, 2), (5, 0), (3, 2), (6, 0), (4, 2), (3, 3),
                (7, 0), (5, 2), (4, 3)]
    assert [EXPONENTS[i] for i in W._STORED] == expected
