"""Polynomial weight functions for edges and triangles.

Implements the unscaled per-primitive weights :math:`\\tilde w_i` of Madan & Levin,
"Fast Evaluation of Smooth Distance Constraints on Co-Dimensional Geometry"
(SIGGRAPH 2022), Section 3.3 and Appendix C ("Weight Functions").

Everything here is dimensionless: weights are functions of the barycentric coordinates of
the closest-point projection onto the primitive, not of lengths.

* **Edges**: a quartic :math:`\\tilde w(t) = \\sum_{k=0}^4 c_k t^k` in the edge parameter
  ``t`` (``t = 0`` at endpoint 0, ``t = 1`` at endpoint 1). Coefficients: float64 array of
  shape ``(5,)``.
* **Triangles**: a symmetric degree-7 polynomial :math:`\\tilde w(s, t)`, where ``s`` and
  ``t`` are the barycentric coordinates of vertices 1 and 2, i.e. the point is
  ``v0 + s (v1 - v0) + t (v2 - v0)``. It is stored as 13 float64 coefficients multiplying,
  in order (the authors' layout)::

      1, (s²+t²), (s³+t³), (s⁴+t⁴), s²t², (s⁵+t⁵), (s³t²+s²t³), (s⁶+t⁶),
      (s⁴t²+s²t⁴), s³t³, (s⁷+t⁷), (s⁵t²+s²t⁵), (s⁴t³+s³t⁴)

The stored coefficients are for the *unscaled* weight; callers multiply by the mesh-wide
factor ``A`` (and apply the attenuation exponent) at evaluation time.

The numba kernels :func:`eval_edge_weight` and :func:`eval_triangle_weight` return the value
and its partial derivatives with respect to the barycentric coordinate(s).
"""

from __future__ import annotations

import functools
import operator

import numba
import numpy as np

from smoothdist._config import NJIT_INLINE

__all__ = [
    "edge_weight_coefficients",
    "edge_weight_max",
    "edge_weight_range",
    "eval_edge_weight",
    "triangle_weight_coefficients",
    "triangle_weight_range",
    "eval_triangle_weight",
    "N_EDGE_COEFFS",
    "N_TRIANGLE_COEFFS",
]

N_EDGE_COEFFS = 5
N_TRIANGLE_COEFFS = 13

# --------------------------------------------------------------------------------------
# Edges
# --------------------------------------------------------------------------------------


def _check_valence(name, n):
    try:
        n = operator.index(n)
    except TypeError:
        if float(n) != int(n):
            raise ValueError(f"{name} must be an integer valence, got {n!r}") from None
        n = int(n)
    if n < 1:
        raise ValueError(f"{name} must be >= 1, got {n}")
    return n


def edge_weight_coefficients(n0, n1):
    """Coefficients of the edge weight quartic.

    The quartic :math:`\\tilde w(t) = c_0 + c_1 t + c_2 t^2 + c_3 t^3 + c_4 t^4` satisfies
    :math:`\\tilde w(0) = 1/n_0`, :math:`\\tilde w(1) = 1/n_1`, :math:`\\tilde w(1/2) = 1`
    and :math:`\\tilde w'(0) = \\tilde w'(1) = 0` (Madan & Levin 2022, Appendix C.2).
    With ``a = 1/n0`` and ``b = 1/n1`` the closed form is
    ``c = [a, 0, 16 - 11a - 5b, 18a + 14b - 32, 16 - 8a - 8b]``.

    Parameters
    ----------
    n0, n1 : int
        Valences (number of incident edges) of endpoint 0 (``t = 0``) and endpoint 1
        (``t = 1``); both ``>= 1``.

    Returns
    -------
    numpy.ndarray
        Shape ``(5,)``, float64, coefficients in increasing powers of ``t``.

    Notes
    -----
    For ``n0 != n1`` the interior maximum is not at ``t = 1/2`` and exceeds 1 (e.g.
    ``n0 = 1, n1 = 5`` peaks at about 1.11 near ``t = 0.31``); see :func:`edge_weight_max`.
    """
    n0 = _check_valence("n0", n0)
    n1 = _check_valence("n1", n1)
    a = 1.0 / n0
    b = 1.0 / n1
    return np.array(
        [a, 0.0, 16.0 - 11.0 * a - 5.0 * b, 18.0 * a + 14.0 * b - 32.0, 16.0 - 8.0 * a - 8.0 * b],
        dtype=np.float64,
    )


def _edge_poly(c, t):
    """Pure-numpy quartic evaluation (value only); ``t`` may be an array."""
    c = np.asarray(c, dtype=np.float64)
    return c[0] + t * (c[1] + t * (c[2] + t * (c[3] + t * c[4])))


def _edge_critical_points(c):
    """Real critical points of the quartic inside [0, 1]."""
    c = np.asarray(c, dtype=np.float64)[:N_EDGE_COEFFS]
    # w'(t) = c1 + 2 c2 t + 3 c3 t^2 + 4 c4 t^3
    d = np.array([c[1], 2.0 * c[2], 3.0 * c[3], 4.0 * c[4]])
    scale = np.max(np.abs(d))
    if scale == 0.0:
        return np.empty(0)
    tol = 1e-14 * scale
    cands = []
    if abs(d[0]) <= tol and abs(d.sum()) <= tol:
        # Hermite structure w'(0) = w'(1) = 0:  w'(t) = t (1 - t) (2 c2 - 4 c4 t).
        if c[4] != 0.0:
            cands.append(c[2] / (2.0 * c[4]))
    else:
        # Generic coefficients: roots of the cubic derivative.
        # strip vanishing leading coefficients (numpy wants the highest power first)
        hi = np.trim_zeros(d[::-1], "f")
        if hi.size >= 2:
            r = np.roots(hi)
            cands.extend(float(x.real) for x in r if abs(x.imag) <= 1e-9 * max(1.0, abs(x)))
    return np.array([x for x in cands if 0.0 <= x <= 1.0], dtype=np.float64)


def edge_weight_range(c):
    """Exact minimum and maximum of the edge quartic over ``t`` in [0, 1].

    Parameters
    ----------
    c : array_like
        Quartic coefficients (first 5 entries used), increasing powers of ``t``.

    Returns
    -------
    (float, float)
        ``(min, max)`` over the endpoints and the interior critical points. For the
        weights built by :func:`edge_weight_coefficients` the derivative factors as
        ``t (1 - t) (2 c2 - 4 c4 t)``, so the only interior critical point is
        ``t* = c2 / (2 c4)``; other coefficient vectors fall back to the cubic's roots.
    """
    c = np.asarray(c, dtype=np.float64)
    if c.ndim != 1 or c.shape[0] < N_EDGE_COEFFS:
        raise ValueError("edge weight coefficients must be a 1-D array of length >= 5")
    ts = np.concatenate([[0.0, 1.0], _edge_critical_points(c)])
    vals = _edge_poly(c, ts)
    return float(vals.min()), float(vals.max())


def edge_weight_max(c):
    """Exact maximum of the edge quartic over ``t`` in [0, 1].

    Parameters
    ----------
    c : array_like
        Quartic coefficients (first 5 entries used), increasing powers of ``t``.

    Returns
    -------
    float
        ``max_{t in [0,1]} w(t)``, taken over the endpoints and the interior critical
        points (closed form, see :func:`edge_weight_range`).
    """
    return edge_weight_range(c)[1]


@numba.njit(**NJIT_INLINE)
def eval_edge_weight(c, t):
    """Edge weight quartic and its derivative (numba kernel).

    Parameters
    ----------
    c : numpy.ndarray
        float64, 1-D, length >= 5 (only ``c[0:5]`` used).
    t : float
        Edge parameter (barycentric coordinate of endpoint 1).

    Returns
    -------
    (float, float)
        ``(w, dw/dt)``.
    """
    c0 = c[0]
    c1 = c[1]
    c2 = c[2]
    c3 = c[3]
    c4 = c[4]
    w = c0 + t * (c1 + t * (c2 + t * (c3 + t * c4)))
    dw = c1 + t * (2.0 * c2 + t * (3.0 * c3 + t * (4.0 * c4)))
    return w, dw


# --------------------------------------------------------------------------------------
# Triangles
# --------------------------------------------------------------------------------------

_TRI_DEGREE = 7
_N_FULL = (_TRI_DEGREE + 1) * (_TRI_DEGREE + 2) // 2  # 36


def _mono_index(a, b):
    """Index of the monomial s^a t^b in the full basis (degree blocks, t-power inside)."""
    k = a + b
    return k * (k + 1) // 2 + b


#: exponents (a, b) of s^a t^b for every full-basis index
_EXPONENTS = tuple((k - j, j) for k in range(_TRI_DEGREE + 1) for j in range(k + 1))

#: full-basis indices of the 13 stored coefficients (the "s-major" representative of each
#: symmetric pair), in the authors' order
_STORED = (0, 3, 6, 10, 12, 15, 17, 21, 23, 24, 28, 30, 31)

#: monomials forced to zero by the axis normal-derivative constraints:
#: s t^j and s^j t for j = 0..6 (the st term is shared): 13 monomials
_AXIS_ZERO = tuple(sorted({_mono_index(1, j) for j in range(7)}
                          | {_mono_index(j, 1) for j in range(7)}))


def _hypotenuse_rows(swap):
    """Rows giving the t-power coefficients of (d/ds + d/dt) w along the hypotenuse.

    ``swap=False`` evaluates at (s, t) = (1 - t, t); ``swap=True`` at (t, 1 - t).
    Returns an array of shape (7, 36): row p is the coefficient of t^p (p = 0..6).
    """
    rows = np.zeros((_TRI_DEGREE, _N_FULL))
    P = np.polynomial.polynomial
    one_minus_t = np.array([1.0, -1.0])
    tpoly = np.array([0.0, 1.0])

    def power(p, n):
        return P.polypow(p, n) if n > 0 else np.array([1.0])

    for idx, (a, b) in enumerate(_EXPONENTS):
        # (d/ds + d/dt) s^a t^b = a s^(a-1) t^b + b s^a t^(b-1)
        S, T = (tpoly, one_minus_t) if swap else (one_minus_t, tpoly)
        poly = np.zeros(1)
        if a > 0:
            poly = P.polyadd(poly, a * P.polymul(power(S, a - 1), power(T, b)))
        if b > 0:
            poly = P.polyadd(poly, b * P.polymul(power(S, a), power(T, b - 1)))
        poly = np.trim_zeros(poly, "b") if np.any(poly) else np.zeros(1)
        rows[: poly.size, idx] = poly
    return rows


@functools.lru_cache(maxsize=1)
def _triangle_matrix():
    """The 36 x 36 constraint matrix of Appendix C.3 (rows as in the authors' code)."""
    rows = []
    # 10 point rows: 3 vertices, 6 edge points, barycenter
    pts = _TRI_POINTS
    for s, t in pts:
        rows.append([s**a * t**b for (a, b) in _EXPONENTS])
    # 13 single-coefficient rows: d/ds w(0, t) = 0 and d/dt w(t, 0) = 0
    for idx in _AXIS_ZERO:
        r = np.zeros(_N_FULL)
        r[idx] = 1.0
        rows.append(r)
    # 7 + 6 hypotenuse rows (the t^6 coefficient of the swapped expression duplicates)
    rows.extend(_hypotenuse_rows(swap=False))
    rows.extend(_hypotenuse_rows(swap=True)[:6])
    M = np.array(rows, dtype=np.float64)
    assert M.shape == (_N_FULL, _N_FULL)
    M.setflags(write=False)
    return M


_THIRD = 1.0 / 3.0
_TWO_THIRDS = 2.0 / 3.0
#: (s, t) of the 10 point constraints: vertices, edge points, barycenter
_TRI_POINTS = (
    (0.0, 0.0), (1.0, 0.0), (0.0, 1.0),
    (_THIRD, 0.0), (_TWO_THIRDS, 0.0), (0.0, _THIRD), (0.0, _TWO_THIRDS),
    (_THIRD, _TWO_THIRDS), (_TWO_THIRDS, _THIRD),
    (_THIRD, _THIRD),
)


def _triangle_rhs(v, e):
    rhs = np.zeros(_N_FULL)
    rhs[0:3] = 1.0 / v
    rhs[3:9] = 1.0 / e
    rhs[9] = (v - 1.0) / v
    return rhs


def _triangle_full_solution(v, e):
    """Minimum-norm least-squares solution (36 monomial coefficients), exactly symmetrised.

    Returns the symmetrised 36-vector; raises AssertionError if the system is not
    (numerically) consistent or the solution is not symmetric / not of the 13-term form.
    """
    M = _triangle_matrix()
    rhs = _triangle_rhs(v, e)
    x, _, rank, _ = np.linalg.lstsq(M, rhs, rcond=1e-12)
    resid = np.max(np.abs(M @ x - rhs))
    assert resid < 1e-10, f"triangle weight system inconsistent: residual {resid:.3e}"
    assert rank == 30, f"unexpected rank {rank} of the triangle weight system"
    # exact symmetrisation: average each coefficient with its s<->t mirror
    mirror = np.array([_mono_index(b, a) for (a, b) in _EXPONENTS])
    asym = np.max(np.abs(x - x[mirror]))
    scale = max(1.0, np.max(np.abs(x)))
    assert asym < 1e-9 * scale, f"triangle weight solution not symmetric: {asym:.3e}"
    x = 0.5 * (x + x[mirror])
    zero = np.max(np.abs(x[list(_AXIS_ZERO)]))
    assert zero < 1e-10 * scale, f"dropped triangle monomials not zero: {zero:.3e}"
    x[list(_AXIS_ZERO)] = 0.0
    return x


@functools.lru_cache(maxsize=None)
def _triangle_weight_coefficients_cached(v, e):
    if v == 1:
        c = np.zeros(N_TRIANGLE_COEFFS)
        c[0] = 1.0
    else:
        x = _triangle_full_solution(v, e)
        c = x[list(_STORED)].copy()
    c.setflags(write=False)
    return c


def triangle_weight_coefficients(v, e):
    """The 13 stored coefficients of the symmetric degree-7 triangle weight.

    Builds the 36-unknown monomial system of Madan & Levin 2022, Appendix C.3: 10 point
    constraints (``1/v`` at the three vertices, ``1/e`` at the two third-points of each
    edge, ``(v-1)/v`` at the barycenter) and zero normal derivative along ``s = 0``,
    ``t = 0`` and ``s + t = 1`` (26 coefficient equations). The system has rank 30; its
    minimum-norm least-squares solution (``numpy.linalg.lstsq``, float64) is taken, checked
    to be consistent, symmetrised exactly and compressed to the 13 unique coefficients.

    Parameters
    ----------
    v : int
        Maximum vertex valence (number of incident triangles) over the triangle's vertices.
    e : int
        Maximum edge valence (number of triangles sharing an edge) over its edges;
        ``1 <= e <= v``.

    Returns
    -------
    numpy.ndarray
        Shape ``(13,)``, float64 (a fresh copy; results are cached per ``(v, e)``).
        The coefficients multiply ``1, (s²+t²), (s³+t³), (s⁴+t⁴), s²t², (s⁵+t⁵),
        (s³t²+s²t³), (s⁶+t⁶), (s⁴t²+s²t⁴), s³t³, (s⁷+t⁷), (s⁵t²+s²t⁵), (s⁴t³+s³t⁴)``,
        with ``s``, ``t`` the barycentric coordinates of vertices 1 and 2.

    Notes
    -----
    Deviation from the paper: an isolated triangle (``v == 1``) gets the constant weight 1
    (coefficients ``[1, 0, ..., 0]``). The paper's barycenter target ``(v-1)/v`` is 0 there,
    which makes the polynomial negative in the interior (min about -0.0785) and the log of
    the weighted sum undefined; for an isolated triangle there is no concentration to
    correct, so the exact weight is 1 everywhere.

    The weight is not guaranteed to stay above ``1/v``: at non-manifold edges (``e >= 3``)
    and for ``(v, e) = (2, 1)`` it dips below ``1/v``; use :func:`triangle_weight_range`.
    """
    v = _check_valence("v", v)
    e = _check_valence("e", e)
    if e > v:
        raise ValueError(f"edge valence e={e} cannot exceed vertex valence v={v}")
    return _triangle_weight_coefficients_cached(v, e).copy()


def _triangle_poly(c, s, t):
    """Pure-numpy evaluation of the 13-term form (value only); ``s``, ``t`` may be arrays."""
    c = np.asarray(c, dtype=np.float64)
    s = np.asarray(s, dtype=np.float64)
    t = np.asarray(t, dtype=np.float64)

    def p(x):
        return x * x * (c[1] + x * (c[2] + x * (c[3] + x * (c[5] + x * (c[7] + x * c[10])))))

    st = s * t
    r = (
        c[4]
        + c[6] * (s + t)
        + c[8] * (s * s + t * t)
        + c[9] * st
        + c[11] * (s**3 + t**3)
        + c[12] * st * (s + t)
    )
    return c[0] + p(s) + p(t) + st * st * r


def triangle_weight_range(c, n=200):
    """Sampled minimum and maximum of the triangle weight over the reference triangle.

    Parameters
    ----------
    c : array_like
        13 stored coefficients (first 13 entries used).
    n : int, optional
        Grid resolution: samples ``(i/n, j/n)`` for all ``i, j >= 0`` with ``i + j <= n``
        (boundary included, ``(n+1)(n+2)/2`` points).

    Returns
    -------
    (float, float)
        ``(min, max)`` of the sampled values. Callers clamp the weight into this range, so
        a sampled (not exact) extremum is sufficient.
    """
    c = np.asarray(c, dtype=np.float64)
    if c.ndim != 1 or c.shape[0] < N_TRIANGLE_COEFFS:
        raise ValueError("triangle weight coefficients must be a 1-D array of length >= 13")
    n = operator.index(n)
    if n < 1:
        raise ValueError("n must be >= 1")
    i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
    mask = i + j <= n
    s = i[mask] / n
    t = j[mask] / n
    w = _triangle_poly(c, s, t)
    return float(w.min()), float(w.max())


@numba.njit(**NJIT_INLINE)
def eval_triangle_weight(c, s, t):
    """Triangle weight and its partial derivatives (numba kernel).

    Parameters
    ----------
    c : numpy.ndarray
        float64, 1-D, length >= 13 (only ``c[0:13]`` used), as returned by
        :func:`triangle_weight_coefficients`.
    s, t : float
        Barycentric coordinates of vertices 1 and 2.

    Returns
    -------
    (float, float, float)
        ``(w, dw/ds, dw/dt)``.

    Notes
    -----
    Uses ``w = c0 + P(s) + P(t) + s²t² R(s, t)`` with
    ``P(x) = x²(c1 + x(c2 + x(c3 + x(c5 + x(c7 + x c10)))))`` and
    ``R = c4 + c6(s+t) + c8(s²+t²) + c9 st + c11(s³+t³) + c12 st(s+t)``.
    """
    c0 = c[0]
    c1 = c[1]
    c2 = c[2]
    c3 = c[3]
    c4 = c[4]
    c5 = c[5]
    c6 = c[6]
    c7 = c[7]
    c8 = c[8]
    c9 = c[9]
    c10 = c[10]
    c11 = c[11]
    c12 = c[12]

    s2 = s * s
    t2 = t * t
    st = s * t
    spt = s + t

    # univariate part P(x) and P'(x)
    ps_in = c1 + s * (c2 + s * (c3 + s * (c5 + s * (c7 + s * c10))))
    pt_in = c1 + t * (c2 + t * (c3 + t * (c5 + t * (c7 + t * c10))))
    dps = s * (2.0 * c1 + s * (3.0 * c2 + s * (4.0 * c3
                                               + s * (5.0 * c5 + s * (6.0 * c7
                                                                      + s * (7.0 * c10))))))
    dpt = t * (2.0 * c1 + t * (3.0 * c2 + t * (4.0 * c3
                                               + t * (5.0 * c5 + t * (6.0 * c7
                                                                      + t * (7.0 * c10))))))

    # mixed part s²t² R(s, t)
    r = c4 + c6 * spt + c8 * (s2 + t2) + c9 * st + c11 * (s2 * s + t2 * t) + c12 * st * spt
    dr_ds = c6 + 2.0 * c8 * s + c9 * t + 3.0 * c11 * s2 + c12 * (2.0 * st + t2)
    dr_dt = c6 + 2.0 * c8 * t + c9 * s + 3.0 * c11 * t2 + c12 * (2.0 * st + s2)

    st2 = st * st
    w = c0 + s2 * ps_in + t2 * pt_in + st2 * r
    dw_ds = dps + 2.0 * s * t2 * r + st2 * dr_ds
    dw_dt = dpt + 2.0 * t * s2 * r + st2 * dr_dt
    return w, dw_ds, dw_dt
