"""Area weights of point clouds under junction weights (issue 62, item 3): a point stands for
the share of the sampled shape around it, so a random clump of samples does not raise a bump.

Each kernel result is compared with an independent numpy computation (brute-force
neighbours, the weighted LogSumExp summed over every point, central differences)."""

import numpy as np
import pytest

import smoothdist
from smoothdist._kernels.spacing import (AREA_WEIGHT_CAP, area_weights, local_smooth_distance,
                                         nearest_k)

RNG = np.random.default_rng(62)


def _weights_in_mesh_order(field):
    """The points' weights (``tree.pwhi``) in the mesh's numbering."""
    w = np.empty(field.tree.pwhi.size)
    w[field.tree.orig] = field.tree.pwhi
    return w


def test_nearest_k_is_the_brute_force_distances():
    """k-nearest distances against every pair in numpy, in tree order; fewer points than k
    leave ``inf``."""
    P = RNG.normal(size=(400, 3))
    field = smoothdist.SmoothDistanceField(P)
    got = nearest_k(field.tree, np.arange(P.shape[0]), 5)
    D = np.linalg.norm(P[:, None] - P[None], axis=2)
    np.fill_diagonal(D, np.inf)
    want = np.sort(D, axis=1)[:, :5][field.tree.orig]    # tree order
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=0)
    few = smoothdist.SmoothDistanceField(P[:3])
    assert np.isinf(nearest_k(few.tree, np.arange(3), 4)[:, 2:]).all()


def test_a_regular_grid_weighs_its_points_alike_and_a_clump_as_its_site():
    """Inside a regular grid every point stands for the same area (weight about 1); a clump of 30
    samples at one site of the grid weighs about what one site does, not 30 sites (unit
    weights: 30)."""
    g = np.arange(40.0)
    X, Y = np.meshgrid(g, g)
    grid = np.c_[X.ravel(), Y.ravel(), np.zeros(X.size)]
    site = np.array([20.0, 20.0, 0.0])
    clump = site + np.c_[RNG.uniform(-0.15, 0.15, (30, 2)), np.zeros(30)]
    keep = np.linalg.norm(grid - site, axis=1) > 0      # the clump replaces its site
    P = np.concatenate([grid[keep], clump])
    field = smoothdist.SmoothDistanceField(P, weights="inclusion-exclusion")
    w = _weights_in_mesh_order(field)
    inner = np.all((grid[keep][:, :2] >= 5) & (grid[keep][:, :2] <= 34), axis=1) \
        & (np.linalg.norm(grid[keep] - site, axis=1) > 4)
    site_w = w[:keep.sum()][inner]
    np.testing.assert_allclose(site_w, site_w[0], rtol=1e-9)   # one area for every site
    assert 0.8 < site_w[0] <= 1.0       # a random spot of the grid sees the sites' area
    total = w[keep.sum():].sum() / site_w[0]
    assert 0.3 < total < 3.0, total
    assert np.all(w >= 1.0 / AREA_WEIGHT_CAP) and np.all(w <= AREA_WEIGHT_CAP)


def test_the_weights_follow_the_clouds_dimension():
    """On a curve, a point's share grows like its spacing (dimension 1), on a surface like
    its spacing squared: a curve sampled at spacings 1 and 2 in halves weighs the sparse
    half's points 2x, a plane sampled likewise 4x."""
    x = np.r_[np.arange(0.0, 200.0, 1.0), np.arange(200.0, 600.0, 2.0)]
    line = np.c_[x, np.zeros_like(x), np.zeros_like(x)]
    f = smoothdist.SmoothDistanceField(line, weights="inclusion-exclusion")
    w = _weights_in_mesh_order(f)
    ratio = np.median(w[(x > 300) & (x < 500)]) / np.median(w[(x > 30) & (x < 170)])
    assert ratio == pytest.approx(2.0, rel=0.05)
    a, b = np.meshgrid(np.arange(0.0, 30.0, 1.0), np.arange(0.0, 30.0, 1.0))
    c, d = np.meshgrid(np.arange(40.0, 100.0, 2.0), np.arange(0.0, 60.0, 2.0))
    plane = np.r_[np.c_[a.ravel(), b.ravel()], np.c_[c.ravel(), d.ravel()]]
    plane = np.c_[plane, np.zeros(plane.shape[0])]
    f = smoothdist.SmoothDistanceField(plane, weights="inclusion-exclusion")
    w = _weights_in_mesh_order(f)
    dense = np.all((plane[:, :2] > 5) & (plane[:, :2] < 25), axis=1)
    sparse = (plane[:, 0] > 50) & (plane[:, 0] < 90) & (plane[:, 1] > 10) & (plane[:, 1] < 50)
    assert np.median(w[sparse]) / np.median(w[dense]) == pytest.approx(4.0, rel=0.05)


def _sheet(n, clump=0):
    """``n`` random points of a unit square (z = 0), and ``clump`` more within 0.01 of its
    centre."""
    P = np.c_[RNG.uniform(0, 1, (n, 2)), np.zeros(n)]
    C = np.c_[0.5 + RNG.uniform(-0.01, 0.01, (clump, 2)), np.zeros(clump)]
    return np.r_[P, C]


def test_paper_weights_and_volume_samples_keep_weight_one():
    """The paper's scheme (the library's default) sums unit weights, as before; so does a
    random sample of a volume under junction weights (its surface is its hull, which a
    point's share of the volume does not measure)."""
    field = smoothdist.SmoothDistanceField(_sheet(300))
    np.testing.assert_array_equal(field.tree.pwhi, 1.0)
    assert np.ptp(area_weights(field.tree)) > 0          # while the cloud's areas differ
    cube = smoothdist.SmoothDistanceField(RNG.uniform(-1, 1, (800, 3)),
                                          weights="inclusion-exclusion")
    np.testing.assert_array_equal(cube.tree.pwhi, 1.0)


@pytest.mark.parametrize("alpha", [3.0, 30.0])
def test_the_weighted_sum_is_the_numpy_one_and_stays_below_the_distance(alpha):
    """The smooth distance of a cloud with area weights is ``m - log(max(sum w e^(-alpha
    (d - m)), 1)) / alpha`` summed in numpy over every point; its gradient matches central
    differences where the sum is not clamped (``s > 1``: everywhere the renderer's surfaces
    lie, ``d_hat >= 0``); ``d_hat <= d`` with Barnes-Hut too (weights below 1 included)."""
    P = _sheet(250, clump=50)
    field = smoothdist.SmoothDistanceField(P, weights="inclusion-exclusion")
    w = _weights_in_mesh_order(field)
    assert w.min() < 1.0 < w.max()
    Q = RNG.uniform(-0.2, 1.2, (60, 3)) * [1, 1, 0.3]
    res = field.smooth_distance(Q, alpha=alpha, alpha_u=alpha, beta=0.0)
    d = np.linalg.norm(Q[:, None] - P[None], axis=2)
    m = d.min(axis=1)
    raw = (w * np.exp(-alpha * (d - m[:, None]))).sum(axis=1)
    s = np.maximum(raw, 1.0)
    np.testing.assert_allclose(res.distance, m - np.log(s) / alpha, rtol=0, atol=1e-12)
    free = raw > 1.0 + 1e-6
    assert free.mean() > 0.5                             # enough left to compare
    h = 1e-6
    for axis in range(3):
        e = np.zeros(3)
        e[axis] = h
        fd = (field.smooth_distance(Q + e, alpha=alpha, alpha_u=alpha, beta=0.0).distance
              - field.smooth_distance(Q - e, alpha=alpha, alpha_u=alpha, beta=0.0).distance)
        np.testing.assert_allclose(res.gradient[free, axis], fd[free] / (2 * h), atol=2e-5)
    for beta in (0.0, 0.5, 1.0):
        dh = field.smooth_distance(Q, alpha=alpha, alpha_u=alpha, beta=beta).distance
        assert np.all(dh <= m + 1e-12)


def test_the_local_bound_of_the_closing_alpha_sums_unit_weights():
    """``local_smooth_distance`` (the closing alpha's probe) sums the unit-weight terms of the
    points within its radius, as numpy does, under either scheme: a cloud's gaps are judged
    as closed where the unit sum closes them."""
    P = RNG.uniform(0, 1, (500, 3)) * [1, 1, 0]
    field = smoothdist.SmoothDistanceField(P, weights="inclusion-exclusion")
    assert np.ptp(field.tree.pwhi) > 0
    Q = RNG.uniform(0.2, 0.8, (40, 3)) * [1, 1, 0] + [0, 0, 0.01]
    alpha, radius = 60.0, 0.15
    got = local_smooth_distance(field.tree, Q, alpha, radius)
    d = np.linalg.norm(Q[:, None] - P[None], axis=2)
    near = d <= radius
    m = np.where(near, d, np.inf).min(axis=1)
    s = np.where(near, np.exp(-alpha * (d - m[:, None])), 0).sum(axis=1)
    np.testing.assert_allclose(got, m - np.log(s) / alpha, rtol=0, atol=1e-12)
    paper = smoothdist.SmoothDistanceField(P)
    np.testing.assert_array_equal(got, local_smooth_distance(paper.tree, Q, alpha, radius))


def test_the_automatic_surface_follows_the_weights():
    """A field switched to junction weights does not keep the paper field's automatic
    parameters (area weights move them), and a dense random sample takes 0.8 of its
    ``auto_alpha`` with them (the offset target, not its gaps, set that); an even sample (a
    grid) keeps ``auto_alpha``."""
    from smoothdist.field import AUTO_CLOUD_MARGIN

    P = _sheet(20_000)
    paper = smoothdist.SmoothDistanceField(P)
    a_paper = paper.auto_surface()[0]
    switched = paper.with_weights("inclusion-exclusion")
    fresh = smoothdist.SmoothDistanceField(P, weights="inclusion-exclusion")
    assert switched.auto_surface() == fresh.auto_surface()
    assert fresh.auto_surface()[0] != a_paper
    assert fresh.spacing_spread() > 0.4
    assert fresh.auto_surface()[0] == pytest.approx(AUTO_CLOUD_MARGIN * fresh.auto_alpha())
    g = np.arange(0.0, 1.0, 0.02)
    X, Y = np.meshgrid(g, g)
    grid = smoothdist.SmoothDistanceField(np.c_[X.ravel(), Y.ravel(), np.zeros(X.size)],
                                          weights="inclusion-exclusion")
    assert grid.spacing_spread() < 0.01
    assert grid.auto_surface()[0] == grid.auto_alpha()
