"""Closest pairs between simplices and the box-primitive lower bound, against independent references."""

import itertools

import numpy as np
import pytest

import naive_pairs
from smoothdist._kernels.box_distance import box_box_distance, box_lower_bound
from smoothdist._kernels.closest_pair import closest_pair

KINDS = (0, 1, 2)


def simplex_point(k, X, s, t):
    """The point with parameters ``(s, t)`` on simplex ``X (k+1, 3)`` (library convention)."""
    if k == 0:
        return X[0]
    if k == 1:
        return X[0] + s * (X[1] - X[0])
    return X[0] + s * (X[1] - X[0]) + t * (X[2] - X[0])


def pad(X):
    out = np.zeros(9)
    out[:X.size] = X.ravel()
    return out


def check_pair(kq, Q, kd, P, rtol=1e-9, sample=True):
    """Kernel pair == face-pair reference distance; the returned points and r are consistent;
    and (``sample``) no densely sampled pair of points is closer, the closest nearly as close."""
    c = closest_pair(kq, pad(Q), kd, pad(P))
    d = np.sqrt(c[0])
    if sample:
        A = naive_pairs.grid_simplex(Q, 40)
        B = naive_pairs.grid_simplex(P, 40)
        sampled = np.sqrt(((A[:, None, :] - B[None, :, :]) ** 2).sum(-1)).min()
        size = max(np.ptp(Q, axis=0).max(), np.ptp(P, axis=0).max(), 1e-3)
        assert d <= sampled + 1e-12 * max(1.0, sampled)
        assert sampled - d <= 0.05 * size
    ref, lam, mu = naive_pairs.closest_pairs(kq, Q[None], kd, P[None])
    scale = max(1.0, np.abs(Q).max(), np.abs(P).max())
    assert d == pytest.approx(ref[0], rel=rtol, abs=1e-12 * scale)
    # r is the difference of the two reported points, both on their simplices
    q = simplex_point(kq, Q, c[4], c[5])
    p = simplex_point(kd, P, c[7], c[8])
    np.testing.assert_allclose(np.array(c[1:4]), q - p, atol=1e-12 * scale)
    for k, (s, t) in ((kq, c[4:6]), (kd, c[7:9])):
        assert -1e-12 <= s <= 1 + 1e-12 and -1e-12 <= t <= 1 + 1e-12 and s + t <= 1 + 1e-12
        if k == 0:
            assert s == t == 0
        if k == 1:
            assert t == 0
    return c


def random_simplex(rng, k, center, size=1.0):
    return center + size * rng.normal(size=(k + 1, 3))


@pytest.mark.parametrize("kq, kd", list(itertools.product(KINDS, KINDS)))
def test_random_pairs_match_reference(kq, kd, rng):
    for trial in range(200):
        sep = [0.0, 0.5, 2.0, 1e3][trial % 4]
        Q = random_simplex(rng, kq, np.zeros(3))
        P = random_simplex(rng, kd, sep * rng.normal(size=3))
        check_pair(kq, Q, kd, P, sample=False)


@pytest.mark.parametrize("kq, kd", list(itertools.product(KINDS, KINDS)))
def test_pairs_against_dense_sampling(kq, kd, rng):
    """The kernel's distance is <= every sampled pair distance and close to the sampled minimum."""
    for trial in range(8):
        Q = random_simplex(rng, kq, np.zeros(3))
        P = random_simplex(rng, kd, rng.normal(size=3))
        c = closest_pair(kq, pad(Q), kd, pad(P))
        d = np.sqrt(c[0])
        A = naive_pairs.grid_simplex(Q, 60)
        B = naive_pairs.grid_simplex(P, 60)
        sampled = np.sqrt(((A[:, None, :] - B[None, :, :]) ** 2).sum(-1)).min()
        size = max(np.ptp(Q, axis=0).max(), np.ptp(P, axis=0).max(), 1e-3)
        assert d <= sampled + 1e-12
        assert sampled - d <= 0.05 * size


def test_parallel_segments():
    Q = np.array([[0, 0, 1.0], [2, 0, 1.0]])
    for shift in (-3.0, -1.0, 0.5, 1.5, 5.0):
        P = np.array([[shift, 0, 0.0], [shift + 1, 0, 0.0]])
        c = check_pair(1, Q, 1, P)
        gap = max(0.0, shift - 2.0, -(shift + 1))
        assert np.sqrt(c[0]) == pytest.approx(np.hypot(1.0, gap))
    # collinear, overlapping and touching
    c = check_pair(1, Q, 1, np.array([[1.0, 0, 1.0], [3.0, 0, 1.0]]))
    assert c[0] == 0.0
    c = check_pair(1, Q, 1, np.array([[2.0, 0, 1.0], [3.0, 0, 1.0]]))
    assert c[0] == 0.0


def test_segment_parallel_to_triangle():
    T = np.array([[0, 0, 0.0], [2, 0, 0], [0, 2, 0]])
    for seg in ([[0.2, 0.2, 0.5], [1.0, 0.5, 0.5]],      # above the interior
                [[1.5, 1.5, 0.5], [3.0, 1.5, 0.5]],      # above and beyond the hypotenuse
                [[-1, 0.5, 0.0], [3, 0.5, 0.0]]):        # in the plane, crossing
        check_pair(1, np.array(seg), 2, T)
        check_pair(2, T, 1, np.array(seg))


def test_touching_and_crossing():
    T = np.array([[0, 0, 0.0], [1, 0, 0], [0, 1, 0]])
    # a segment piercing the triangle
    c = check_pair(1, np.array([[0.2, 0.2, -1], [0.2, 0.2, 1.0]]), 2, T)
    assert c[0] == 0.0 and c[7] == pytest.approx(0.2) and c[8] == pytest.approx(0.2)
    # a triangle touching with a vertex, and two triangles crossing
    check_pair(2, np.array([[0.3, 0.3, 0], [1, 1, 1], [0, 1, 2.0]]), 2, T)
    c = check_pair(2, np.array([[0.3, 0.3, -1], [0.3, 0.3, 1], [2, 2, 0.5]]), 2, T)
    assert c[0] == 0.0
    # coplanar overlapping triangles
    c = check_pair(2, T + [0.2, 0.2, 0], 2, T)
    assert c[0] == 0.0


def test_degenerate_query_primitives(rng):
    """Zero-length segments and zero-area triangles behave as their points and segments."""
    P = np.array([[0, 0, 0.0], [1, 0, 0], [0, 1, 0]])
    pt = np.array([[0.3, 0.4, 2.0]])
    for kd, D in ((0, P[:1]), (1, P[:2]), (2, P)):
        ref = np.sqrt(closest_pair(0, pad(pt), kd, pad(D))[0])
        seg0 = np.repeat(pt, 2, axis=0)
        tri0 = np.repeat(pt, 3, axis=0)
        assert np.sqrt(check_pair(1, seg0, kd, D)[0]) == pytest.approx(ref)
        assert np.sqrt(check_pair(2, tri0, kd, D)[0]) == pytest.approx(ref)
        # a sliver triangle (collinear vertices) equals its longest edge
        sliver = np.array([[0.3, -1, 1.0], [0.3, 0.0, 1.0], [0.3, 2, 1.0]])
        ref = np.sqrt(check_pair(1, sliver[[0, 2]], kd, D)[0])
        assert np.sqrt(check_pair(2, sliver, kd, D)[0]) == pytest.approx(ref)
        # and as data
        assert np.sqrt(check_pair(kd, D, 2, sliver)[0]) == pytest.approx(ref)


def test_far_apart_pairs():
    Q = np.array([[0, 0, 0.0], [1, 0, 0], [0, 1, 0]])
    for kq, kd in itertools.product(KINDS, KINDS):
        c = check_pair(kq, Q[:kq + 1], kd, Q[:kd + 1] + [1e6, 2e6, -3e6])
        assert np.isfinite(c[0])


# ------------------------------------------------------------------------- box lower bound
def _node_box(lo, hi):
    return np.array([lo], dtype=float), np.array([hi], dtype=float)


def box_points(lo, hi, res=12):
    """Points on the box's surface (faces sampled on a grid)."""
    u = np.linspace(0, 1, res + 1)
    pts = []
    for a in range(3):
        b, c = [x for x in range(3) if x != a]
        U, W = np.meshgrid(u, u, indexing="ij")
        for side in (lo[a], hi[a]):
            P = np.zeros((U.size, 3))
            P[:, a] = side
            P[:, b] = lo[b] + U.ravel() * (hi[b] - lo[b])
            P[:, c] = lo[c] + W.ravel() * (hi[c] - lo[c])
            pts.append(P)
    return np.concatenate(pts)


@pytest.mark.parametrize("kq", KINDS)
@pytest.mark.slow
def test_box_lower_bound_never_overestimates(kq, rng):
    """delta <= dense-sampled primitive-box distance; exact where the paper's test is exact."""
    E = np.zeros(9)
    for trial in range(150):
        lo = rng.normal(size=3)
        hi = lo + rng.random(3) * 1.5
        LO, HI = _node_box(lo, hi)
        Q = random_simplex(rng, kq, lo + rng.normal(size=3) * 2.5, size=0.6)
        qlo, qhi = Q.min(axis=0), Q.max(axis=0)
        delta, ux, uy, uz = box_lower_bound(kq, pad(Q), qlo, qhi, LO, HI, 0, E)
        # reference: the primitive against the solid box (points inside the box count as 0)
        A = naive_pairs.grid_simplex(Q, 40)
        inside = np.all((A >= lo) & (A <= hi), axis=1)
        B = box_points(lo, hi)
        sampled = 0.0 if inside.any() else np.sqrt(((A[:, None] - B[None]) ** 2).sum(-1)).min()
        assert delta <= sampled + 1e-12
        assert box_box_distance(qlo, qhi, LO, HI, 0) <= delta + 1e-12
        if delta > 0:
            assert np.linalg.norm([ux, uy, uz]) == pytest.approx(1.0)
        sep = (qlo > hi) | (qhi < lo)
        nsep = int(sep.sum())
        # exact (up to the sampling) at a corner, for points, and across a box edge when the
        # query's extent along the edge lies within the box's
        j = int(np.flatnonzero(~sep)[0]) if nsep == 2 else 0
        if nsep == 3 or kq == 0 or (nsep == 2 and lo[j] <= qlo[j] and qhi[j] <= hi[j]):
            assert sampled - delta <= 0.02 * (1 + sampled)


def test_box_bound_authors_failure_cases():
    """The three overestimates of the authors' halfspace test (docs/authors-code.md §11,
    items 2-3)."""
    E = np.zeros(9)
    LO, HI = _node_box([0, 0, 0], [1, 1, 1])
    # a segment entirely above the box on x and y (k = 2): the authors use the lower x face
    Q = np.array([[2.0, 2.0, 0.2], [3.0, 2.5, 0.8]])
    d, *_ = box_lower_bound(1, pad(Q), Q.min(0), Q.max(0), LO, HI, 0, E)
    assert d == pytest.approx(np.hypot(1.0, 1.0))
    # k = 1: a long segment above the top face whose vertices project far from the face
    Q = np.array([[-3.0, 0.5, 1.5], [4.0, 0.5, 1.5]])
    d, *_ = box_lower_bound(1, pad(Q), Q.min(0), Q.max(0), LO, HI, 0, E)
    assert d == pytest.approx(0.5)
    # k = 1, a tilted triangle: the normal gap can beat the axis gap but stays below the truth
    Q = np.array([[-1.0, -1.0, 1.2], [3.0, -1.0, 5.2], [-1.0, 3.0, 5.2]])
    d, *_ = box_lower_bound(2, pad(Q), Q.min(0), Q.max(0), LO, HI, 0, E)
    ref, _, _ = naive_pairs.closest_pairs(2, Q[None], 0, np.array([[[1.0, 1.0, 1.0]]]))
    assert 0.2 < d <= ref[0] + 1e-12
