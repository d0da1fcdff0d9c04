"""Whole-mesh distance under fine lines of motion through parallel configurations (issue 37).

Where a query edge or face is parallel to a data edge or face, the closest pair of two primitives is
not unique; the weight depends on where it lies, so a choice left to rounding made ``d_hat`` jump
(9.2e-4 between shifts 5e-7 apart in the issue's smallest case) while the query moved by less than a
micron. ``smoothdist._kernels.closest_pair.tied_pair`` makes the choice continuous. Each scan below
translates a query mesh in steps of 1e-7 and 1e-4 along the axes and a diagonal and fails on any
step of ``d_hat`` larger than ``LIPSCHITZ`` times the step length; before the tie rule the icosphere
scans stepped by 2-3e3 times it. The gradients are checked there against one-sided differences
(aligned placements sit on kinks of the weight, where the two one-sided derivatives differ and the
gradient must lie between them) and, off the aligned placements, against central differences.
"""

import numpy as np
import pytest
import trimesh

from smoothdist import MeshDistance
from smoothdist._kernels.closest_pair import distinct_ties, tied_pair, triangle_triangle

#: ``|d_hat(x + h e) - d_hat(x)| <= LIPSCHITZ h``: d_hat's translation gradient has norm about 1
#: (unit distance gradients, averaged, plus a weight term of order 1 / alpha); a jump from a
#: closest-pair choice is 1e3-1e4 times the step at these step lengths
LIPSCHITZ = 3.0
KINDS = ("points", "edges", "triangles")


def _grid(n=8, half=0.4):
    xs = np.linspace(-half, half, n + 1)
    X, Y = np.meshgrid(xs, xs, indexing="ij")
    V = np.c_[X.ravel(), Y.ravel(), np.zeros(X.size)]
    F = []
    for i in range(n):
        for j in range(n):
            a = i * (n + 1) + j
            F += [[a, a + n + 1, a + n + 2], [a, a + n + 2, a + 1]]
    return V, np.array(F)


def _edges(F):
    E = np.sort(np.r_[F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]], axis=1)
    return np.unique(E, axis=0)


def _as(V, F, kind):
    if kind == "points":
        return V
    return (V, _edges(F)) if kind == "edges" else (V, F)


def _box():
    b = trimesh.creation.box(extents=[0.3, 0.2, 0.15])
    return np.asarray(b.vertices) + [0.013, -0.021, 0.175], np.asarray(b.faces)


def _ball():
    s = trimesh.creation.icosphere(subdivisions=2, radius=0.3)
    return np.asarray(s.vertices) + [0.0, 0.0, 0.42], np.asarray(s.faces)


GRID = _grid()
QUERIES = {"box": _box(), "ball": _ball()}
DIRECTIONS = (np.array([1.0, 0, 0]), np.array([0, 1.0, 0]), np.array([0, 0, 1.0]),
              np.array([1.0, 1.0, 0]) / np.sqrt(2))


def _largest_step(md, direction, h, n=20, start=np.zeros(3)):
    d = np.array([md(None, start + direction * (k * h))[0] for k in range(n + 1)])
    return np.abs(np.diff(d)).max() / h


def _check_gradient(md, t, tol):
    """The translation gradient against differences at ``t``: between the one-sided ones along
    each axis (kinks), and equal to the central one where the two agree."""
    d, G = md(None, t)
    g = G.sum(axis=0)
    h = 1e-6
    for a, e in enumerate(np.eye(3)):
        up = (md(None, t + h * e)[0] - d) / h
        down = (d - md(None, t - h * e)[0]) / h
        lo, hi = min(up, down), max(up, down)
        # the one-sided differences carry O(h) curvature (|d''| h ~ alpha h): the slack
        assert lo - tol <= g[a] <= hi + tol, (a, g[a], up, down)


@pytest.mark.parametrize("qname", list(QUERIES))
@pytest.mark.parametrize("qkind", KINDS)
@pytest.mark.parametrize("dkind", KINDS)
def test_no_jumps_along_lines_through_parallel_placements(dkind, qkind, qname):
    V, F = QUERIES[qname]
    md = MeshDistance(_as(*GRID, dkind), _as(V, F, qkind), alpha=50.0, alpha_q=50.0, beta=0.0,
                      gradient="exact")
    for direction in DIRECTIONS:
        for h in (1e-7, 1e-4):
            step = _largest_step(md, direction, h)
            assert step <= LIPSCHITZ, (direction, h, step)
    _check_gradient(md, np.zeros(3), tol=1e-3)


def test_the_issues_smallest_case_is_continuous():
    V = np.array([[-.2, -.2, 0], [0, -.2, 0], [.2, -.2, 0], [-.2, 0, 0], [0, 0, 0], [.2, 0, 0],
                  [-.2, .2, 0], [0, .2, 0], [.2, .2, 0]])
    F = [[0, 1, 4], [1, 2, 5], [3, 4, 7], [4, 5, 8], [0, 4, 3], [1, 5, 4], [3, 7, 6], [4, 8, 7]]
    T = np.array([[0.00556722, 0.15222992, 0.14447174], [0.137, 0.071, 0.12],
                  [0.00556722, -0.01022992, 0.14447174]])
    for method in ("bvh", "brute"):
        md = MeshDistance((V, F), (T, [[0, 1, 2]]), alpha=50.0, alpha_q=50.0, beta=0.0,
                          gradient="exact")
        x = np.linspace(-2e-6, 2e-6, 41)
        d = np.array([md(None, [s, 0, 0], method=method)[0] for s in x])
        # was: steps of 9.2e-4 between shifts 1e-7 apart
        assert np.abs(np.diff(d)).max() <= LIPSCHITZ * (x[1] - x[0])
    # the data edge under the query is parallel to the query face's level lines: a tie, and
    # the canonical pair is interior to the closest segment (not one of its ends)
    Q = T.ravel()
    P = V[[3, 4, 7]].ravel()
    assert distinct_ties(2, Q, 2, P) >= 2
    c = triangle_triangle(*Q, *P)
    assert c == tied_pair(2, Q, 2, P)
    assert 0.0 < c[7] < 1.0 and 0.0 < c[8] < 1.0


@pytest.mark.parametrize("h", [1e-7, 1e-4])
def test_collinear_and_coplanar_pairs(h):
    """A query edge above and parallel to a polyline of data edges (collinear directions), and a
    query triangle in the data triangles' plane beside them with an edge parallel to theirs."""
    xs = np.linspace(-0.5, 0.5, 11)
    poly = (np.c_[xs, np.zeros(11), np.zeros(11)], np.c_[np.arange(10), np.arange(1, 11)])
    seg = (np.array([[-0.123, 0.0, 0.1], [0.2345, 0.0, 0.1]]), [[0, 1]])
    md = MeshDistance(poly, seg, alpha=40.0, alpha_q=40.0, beta=0.0, gradient="exact")
    assert _largest_step(md, np.array([1.0, 0, 0]), h) <= LIPSCHITZ
    V, F = GRID
    tri = (np.array([[0.45, -0.1, 0.0], [0.45, 0.13, 0.0], [0.6, 0.0, 0.0]]), [[0, 1, 2]])
    md = MeshDistance((V, F), tri, alpha=40.0, alpha_q=40.0, beta=0.0, gradient="exact")
    for direction in (np.array([0, 1.0, 0]), np.array([1.0, 0, 0])):
        assert _largest_step(md, direction, h) <= LIPSCHITZ
    _check_gradient(md, np.zeros(3), tol=1e-3)


def test_gradient_matches_central_differences_off_the_aligned_placements():
    rng = np.random.default_rng(37)
    V, F = QUERIES["box"]
    for dkind in KINDS:
        for qkind in ("edges", "triangles"):
            md = MeshDistance(_as(*GRID, dkind), _as(V, F, qkind), alpha=50.0, alpha_q=50.0,
                              beta=0.0, gradient="exact")
            for _ in range(2):
                t = rng.uniform(-1, 1, 3) * [0.03, 0.03, 0.01]
                g = md(None, t)[1].sum(axis=0)
                h = 1e-6
                fd = [(md(None, t + h * e)[0] - md(None, t - h * e)[0]) / (2 * h)
                      for e in np.eye(3)]
                # central differences: O(h^2 alpha^2) truncation and 1e-16 / h rounding
                np.testing.assert_allclose(g, fd, atol=1e-6 * np.abs(fd).max())


def _point(kind, X, s, t):
    """The point at parameters ``(s, t)`` of a segment (kind 1) or triangle ``X (9,)``."""
    X = X.reshape(3, 3)
    p = X[0] + s * (X[1] - X[0])
    return p + t * (X[2] - X[0]) if kind == 2 else p


@pytest.mark.parametrize("qkind, dkind", [(1, 1), (1, 2), (2, 1), (2, 2)])
def test_tied_pairs_are_closest_pairs(qkind, dkind):
    """Every pair the tie rule reports lies on both primitives at the minimum distance, which
    :mod:`naive_pairs` (a face-by-face pseudo-inverse enumeration) finds independently."""
    import naive_pairs
    from smoothdist._kernels.closest_pair import closest_pair

    V, F = QUERIES["box"]
    GV, GF = GRID
    shift = np.array([1e-7, -3e-7, 0.0])
    Qs = V[F] + shift if qkind == 2 else V[_edges(F)] + shift
    Ps = GV[GF] if dkind == 2 else GV[_edges(GF)]
    n = 0
    for Qv in Qs:
        for Pv in Ps:
            Q = np.zeros(9)
            P = np.zeros(9)
            Q[:Qv.size] = Qv.ravel()
            P[:Pv.size] = Pv.ravel()
            if qkind == 1:
                Q[6:] = Q[3:6]
            if dkind == 1:
                P[6:] = P[3:6]
            if distinct_ties(qkind, Q, dkind, P) < 2:
                continue
            n += 1
            c = closest_pair(qkind, Q, dkind, P)
            ref = naive_pairs.closest_pairs(qkind, Qv[None], dkind, Pv[None])[0][0]
            # same minimum (the rule never changes the distance), and a real pair at it
            x = _point(qkind, Q, c[4], c[5])
            y = _point(dkind, P, c[7], c[8])
            assert np.sqrt(c[0]) == pytest.approx(ref, abs=1e-12)
            assert np.linalg.norm(x - y) == pytest.approx(ref, abs=1e-12)
            np.testing.assert_allclose(x - y, c[1:4], atol=1e-12)
            # two tied candidates take a short path (tie_of_two): the same pair as the general
            # rule's (rounding apart)
            ref_pair = tied_pair(qkind, Q, dkind, P)
            np.testing.assert_allclose(c[:6] + c[7:9], ref_pair[:6] + ref_pair[7:9], atol=1e-12)
            assert (c[6], c[9]) == (ref_pair[6], ref_pair[9])
    assert n > 10     # the box over the grid has many parallel pairs


def _vertex_differences(md, h=1e-6):
    """Central differences of ``d_hat`` for each query vertex coordinate moved alone."""
    q = md.query
    fd = np.zeros_like(q.V)
    for k in range(len(q.V)):
        for a in range(3):
            ds = []
            for sign in (1.0, -1.0):
                X = q.V.copy()
                X[k, a] += sign * h
                ds.append(MeshDistance(md.field, type(q)(X, q.kind, q.index), alpha=md.alpha,
                                       alpha_q=md.alpha_q, beta=md.beta, alpha_u=md.alpha_u,
                                       gradient=md.gradient)()[0])
            fd[k, a] = (ds[0] - ds[1]) / (2 * h)
    return fd


@pytest.mark.parametrize("qkind", ["edges", "triangles"])
@pytest.mark.parametrize("dkind", KINDS + ("mixed",))
def test_vertex_gradient_is_the_derivative_for_each_vertex(dkind, qkind):
    """``vertex_gradient`` against central differences over every query vertex coordinate (the
    equal split is 30-60 % off there), its rows summing to the translation gradient."""
    from conftest import make_mixed

    rng = np.random.default_rng(5)
    s = trimesh.creation.icosphere(subdivisions=1, radius=0.2)
    R = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    R *= np.sign(np.linalg.det(R))
    V = np.asarray(s.vertices) @ R.T + [0.01, 0.02, 0.28]
    if dkind == "mixed":
        data, alpha_u = make_mixed(), 60.0
        V = V * 2.0 + [0.0, 0.0, 1.2]
    else:
        data, alpha_u = _as(*GRID, dkind), None
    md = MeshDistance(data, _as(V, np.asarray(s.faces), qkind), alpha=30.0, alpha_q=30.0,
                      beta=0.0, alpha_u=alpha_u, gradient="exact")
    d, G = md.vertex_gradient()
    d_split, G_split = md()
    assert d == pytest.approx(d_split, abs=1e-14)
    np.testing.assert_allclose(G.sum(axis=0), G_split.sum(axis=0), atol=1e-13)
    fd = _vertex_differences(md)
    scale = np.abs(fd).max()
    # central differences: O(h^2 alpha^2) truncation, 1e-16 / h rounding: about 1e-8 of scale
    np.testing.assert_allclose(G, fd, atol=1e-6 * scale)
    assert np.abs(G_split - fd).max() > 0.1 * scale      # the split is not this derivative
    _, G_brute = md.vertex_gradient(method="brute")
    np.testing.assert_allclose(G, G_brute, atol=1e-12 * scale)


def test_vertex_gradient_with_barnes_hut_stays_close():
    """With Barnes-Hut the far fields are split equally: still the derivative near contact,
    where the terms that matter are evaluated exactly."""
    V, F = QUERIES["ball"]
    md0 = MeshDistance(GRID, (V, F), alpha=50.0, alpha_q=50.0, beta=0.0, gradient="exact")
    md5 = MeshDistance(GRID, (V, F), alpha=50.0, alpha_q=50.0, beta=0.5, gradient="exact")
    d0, G0 = md0.vertex_gradient()
    d5, G5 = md5.vertex_gradient()
    assert d5 < d0          # far fields were used (they only lower d_hat)
    assert 0.0 < np.abs(G5 - G0).max() <= 0.05 * np.abs(G0).max()
    with pytest.raises(ValueError, match="method"):
        md0.vertex_gradient(method="tree")


@pytest.mark.parametrize("qkind, dkind", [(1, 1), (1, 2), (2, 1), (2, 2)])
def test_random_parallel_pairs(qkind, dkind):
    """Random parallel configurations (a query simplex in a plane parallel to the data's, or an
    edge parallel to a data edge; some with duplicate vertices): the tie rule reports a real
    pair at the minimum distance that :mod:`naive_pairs` finds, and never a NaN."""
    import naive_pairs
    from smoothdist._kernels.closest_pair import closest_pair

    rng = np.random.default_rng(370 + 10 * qkind + dkind)
    n_tied = 0
    for case in range(150):
        P = rng.uniform(-1, 1, (3, 3))
        P[:, 2] = 0.0                                  # data in the plane z = 0
        if dkind == 1:
            P[2] = P[1]
        Q = rng.uniform(-1, 1, (3, 3))
        Q[:, 2] = rng.uniform(0.05, 0.5)               # query in a parallel plane
        if qkind == 1:
            Q[2] = Q[1]
            if dkind == 1 and case % 2:
                # parallel to the data edge too
                Q[1] = Q[0] + rng.uniform(-2, 2) * (P[1] - P[0])
        if case % 7 == 0:
            Q[1] = Q[0]                                # a degenerate query
        Qf, Pf = Q.ravel(), P.ravel()
        c = closest_pair(qkind, Qf, dkind, Pf)
        ref = naive_pairs.closest_pairs(qkind, Q[None, :qkind + 1], dkind,
                                        P[None, :dkind + 1])[0][0]
        assert np.all(np.isfinite(np.array(c, dtype=float)))
        x = _point(qkind, Qf, c[4], c[5])
        y = _point(dkind, Pf, c[7], c[8])
        assert np.sqrt(c[0]) == pytest.approx(ref, abs=1e-12)
        assert np.linalg.norm(x - y) == pytest.approx(ref, abs=1e-10)
        n_tied += distinct_ties(qkind, Qf, dkind, Pf) > 1
    assert n_tied > 20
