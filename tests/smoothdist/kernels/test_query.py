"""Smooth distance ``d_hat`` (Madan & Levin 2022, Eq. 3-4, Sec. 3.3-3.4).

* values and gradients against the brute-force numpy reference in ``naive.py`` (beta = 0),
  for every primitive kind, mixed meshes and real meshes, for several alpha and alpha_u,
  including far queries (1e3-1e6 bounding-box diagonals) at alpha * diag = 1e4;
* the conservative bounds ``d - log(A^S N)/alpha <= d_hat <= d`` (docs/design-notes.md §2) on
  thousands of queries, and their Barnes-Hut variant;
* Barnes-Hut: below the exact sum, monotone in beta, fewer leaves for larger beta,
  ``beta = 0`` equal to ``method="brute"`` and to the reference;
* ``gradient="exact"`` against central finite differences, ``"metric"`` against ``"exact"``;
* thread-count independence, ``alpha="auto"``, argument validation.
"""

import math

import numba
import numpy as np
import pytest

import naive
import smoothdist
from smoothdist import DataMesh, QueryStats, SmoothDistanceField

ZOO = ("point_cloud", "circle", "segment_star", "icosphere", "cube", "mixed_mesh",
       "nonmanifold_mesh")
REAL_LOCAL = ("octopus", "trefoil")
#: (fixture-free) shared-data meshes: (relative path, number of queries for the naive check)
SHARED = {
    "bunny": ("bunny.off", 40),
    "creeper": ("thingi10k/37825_minecraft_creeper.obj", 150),
    "punch_card": ("thingi10k/97171_punch_card_reader.obj", 150),
    "capillary": ("curves/capillary_networks.obj", 80),
    "k5": ("curves/k5_graph.obj", 100),
}


# ----------------------------------------------------------------------------- helpers
def field_of(mesh, **kw):
    return SmoothDistanceField(mesh, **kw)


def typical_alpha(mesh):
    """The paper's heuristic 1/(min edge length); 50/diag for point clouds."""
    e = mesh.min_edge_length()
    return 1.0 / e if e is not None else 50.0 / mesh.diagonal


def mixed_queries(mesh, rng, near=150, on=40, far=30):
    """Near (bbox + 25%), on-primitive and far (1e3-1e6 diagonals) queries, and an ``off``
    mask for those that are not on the geometry (gradients are undefined on it)."""
    Q = np.concatenate([naive.near_queries(mesh, near, rng),
                        naive.sample_on_primitives(mesh, on, rng),
                        naive.far_queries(mesh, far, rng)])
    off = np.ones(Q.shape[0], dtype=bool)
    off[near:near + on] = False
    return Q, off


def assert_values_close(d, ref, scale, rtol=1e-9, what="d_hat"):
    """``|d - ref| <= rtol * (|ref| + scale)`` (scale: the inflation, for d_hat near 0)."""
    err = np.abs(d - ref)
    tol = rtol * (np.abs(ref) + scale)
    bad = np.nonzero(~(err <= tol))[0]
    assert bad.size == 0, (f"{what}: {bad.size} of {d.size} values differ, worst at {bad[0]}: "
                           f"got {d[bad[0]]!r}, reference {ref[bad[0]]!r}")


def assert_grads_close(g, ref, atol=1e-8, what="gradient"):
    err = np.abs(g - ref).max(axis=1) / np.maximum(1.0, np.abs(ref).max(axis=1))
    bad = np.nonzero(~(err <= atol))[0]
    assert bad.size == 0, (f"{what}: {bad.size} of {g.shape[0]} gradients differ, worst "
                           f"{err.max():.3e} at query {int(np.argmax(err))}: "
                           f"{g[bad[0]]} vs {ref[bad[0]]}")


def compare_with_naive(mesh, Q, off, alphas, alpha_us=(None,), gradients=("exact",)):
    field = field_of(mesh)
    terms = naive.Terms(Q, mesh)
    for alpha in alphas:
        for alpha_u in alpha_us:
            au = None if alpha_u is None else alpha_u * alpha
            scale = field.inflation(alpha, au)
            for gradient in gradients:
                d, g = field.smooth_distance(Q, alpha=alpha, beta=0.0, alpha_u=au,
                                             gradient=gradient)
                dr, gr = terms.smooth(alpha, au, gradient)
                label = f"{mesh.name} alpha={alpha:.4g} alpha_u={au} {gradient}"
                assert np.all(np.isfinite(d)) and np.all(np.isfinite(g)), label
                assert_values_close(d, dr, scale, what=f"d_hat ({label})")
                assert_grads_close(g[off], gr[off], what=f"gradient ({label})")


def load_shared(shared_data, key):
    return DataMesh.load(shared_data / SHARED[key][0])


# ----------------------------------------------------------------------------- vs naive
@pytest.mark.parametrize("name", ZOO)
def test_matches_naive_procedural(zoo, name, rng):
    mesh = zoo[name]
    Q, off = mixed_queries(mesh, rng)
    diag = mesh.diagonal
    alphas = (2.0 / diag, typical_alpha(mesh), 1e4 / diag)
    compare_with_naive(mesh, Q, off, alphas, alpha_us=(None, 3.0), gradients=("exact", "metric"))


@pytest.mark.parametrize("name", REAL_LOCAL)
def test_matches_naive_real_local(request, name, rng):
    mesh = request.getfixturevalue(name)
    Q, off = mixed_queries(mesh, rng, near=60, on=20, far=20)
    diag = mesh.diagonal
    compare_with_naive(mesh, Q, off, (1.0 / diag, typical_alpha(mesh), 1e4 / diag),
                       alpha_us=(None, 4.0))


@pytest.mark.parametrize("key", sorted(SHARED))
@pytest.mark.slow
def test_matches_naive_shared(shared_data, key, rng):
    mesh = load_shared(shared_data, key)
    n = SHARED[key][1]
    Q, off = mixed_queries(mesh, rng, near=n, on=n // 4, far=n // 4)
    diag = mesh.diagonal
    compare_with_naive(mesh, Q, off, (typical_alpha(mesh), 1e4 / diag), alpha_us=(None, 4.0))


@pytest.mark.parametrize("name", ZOO)
@pytest.mark.parametrize("alpha_diag", [1e4, 1e7])
def test_far_queries_huge_alpha_finite(zoo, name, alpha_diag, rng):
    """alpha * d up to ~1e13: the shifted LogSumExp stays finite (the authors' code gives inf)
    and equals the reference; far from the data d_hat ~ d and the gradient ~ the direction."""
    mesh = zoo[name]
    field = field_of(mesh)
    Q = naive.far_queries(mesh, 40, rng, 1e3, 1e6)
    alpha = alpha_diag / mesh.diagonal
    d_exact = field.exact_distance(Q).distance
    for beta in (0.0, 0.5):
        for gradient in ("exact", "metric"):
            d, g = field.smooth_distance(Q, alpha=alpha, beta=beta, gradient=gradient)
            assert np.all(np.isfinite(d)) and np.all(np.isfinite(g))
            assert np.all(d <= d_exact * (1 + 1e-12))
            assert np.all(d >= d_exact / (1 + beta) - field.inflation(alpha) - 1e-9 * d_exact)
            # unit-ish direction away from the data
            u = (Q - 0.5 * np.add(*mesh.bounds)) / np.linalg.norm(Q - 0.5 * np.add(*mesh.bounds),
                                                                 axis=1, keepdims=True)
            assert np.all(np.einsum("ij,ij->i", g, u) > 0.9)
    dr, gr = naive.smooth_distance(Q, mesh, alpha)
    d, g = field.smooth_distance(Q, alpha=alpha, beta=0.0, gradient="exact")
    assert_values_close(d, dr, field.inflation(alpha))
    assert_grads_close(g, gr)


def test_single_point_and_empty_queries(icosphere):
    field = field_of(icosphere)
    d1, g1 = field.smooth_distance([0.1, 0.2, 2.0], alpha=5.0)
    assert d1.shape == (1,) and g1.shape == (1, 3)
    d2, g2 = field.smooth_distance(np.array([[0.1, 0.2, 2.0]]), alpha=5.0)
    np.testing.assert_array_equal(d1, d2)
    np.testing.assert_array_equal(g1, g2)
    d0, g0, st = field.smooth_distance(np.zeros((0, 3)), alpha=5.0, return_stats=True)
    assert d0.shape == (0,) and g0.shape == (0, 3) and st.leaves_visited.shape == (0,)


def test_module_function_equals_field(mixed_mesh, rng):
    Q = naive.near_queries(mixed_mesh, 200, rng)
    V, P, E, T = mixed_mesh.V, mixed_mesh.points, mixed_mesh.edges, mixed_mesh.triangles
    field = SmoothDistanceField(V, points=P, edges=E, triangles=T)
    for kw in (dict(alpha=3.0), dict(alpha=3.0, beta=0.0, alpha_u=7.0, gradient="exact")):
        a = field.smooth_distance(Q, **kw)
        b = field_of(mixed_mesh).smooth_distance(Q, **kw)
        np.testing.assert_array_equal(a[0], b[0])
        np.testing.assert_array_equal(a[1], b[1])
    ico = mixed_mesh.as_kind("triangles")
    a = smoothdist.smooth_distance(Q, ico.V, ico.triangles, alpha=3.0, beta=0.25,
                                   return_stats=True)
    b = field_of(ico).smooth_distance(Q, alpha=3.0, beta=0.25, return_stats=True)
    assert len(a) == 3 and isinstance(a[2], QueryStats)
    for x, y in zip(a[:2], b[:2]):
        np.testing.assert_array_equal(x, y)
    np.testing.assert_array_equal(a[2].leaves_visited, b[2].leaves_visited)
    assert a[2].leaves_visited.dtype == np.int64 and a[2].nodes_visited.dtype == np.int64


def test_point_at_distance_matches_closed_form():
    """Two points, query on their bisector: d_hat = d - log(2)/alpha exactly, grad along the
    bisector; one point: d_hat = d."""
    V = np.array([[-1.0, 0, 0], [1.0, 0, 0]])
    for alpha in (0.5, 3.0, 300.0):
        d, g = smoothdist.smooth_distance([[0.0, 2.0, 0.0]], V, alpha=alpha, beta=0.0)
        assert d[0] == pytest.approx(math.sqrt(5.0) - math.log(2.0) / alpha, rel=1e-14)
        np.testing.assert_allclose(g[0], [0.0, 2.0 / math.sqrt(5.0), 0.0], atol=1e-15)
    d, g = smoothdist.smooth_distance([[0.0, 0.0, 2.0]], V[:1], alpha=5.0)
    assert d[0] == pytest.approx(math.sqrt(5.0), rel=1e-15)


# ----------------------------------------------------------------------------- bounds
BOUND_MESHES = ZOO + REAL_LOCAL


def bound_queries(mesh, rng, n=2000):
    """``n`` near, ``n/4`` on-geometry and ``n/4`` far (0.5-1e4 diagonals) queries."""
    return np.concatenate([naive.near_queries(mesh, n, rng, pad=0.1),
                           naive.sample_on_primitives(mesh, n // 4, rng),
                           naive.far_queries(mesh, n // 4, rng, 0.5, 1e4)])


def check_bounds(mesh, Q, alphas, alpha_us, betas):
    field = field_of(mesh)
    d = field.exact_distance(Q).distance
    for alpha in alphas:
        for alpha_u in alpha_us:
            au = None if alpha_u is None else alpha_u * alpha
            infl = field.inflation(alpha, au)
            S = 1.0 if au is None else min(alpha / au, 1.0)
            assert infl == pytest.approx(
                (S * math.log(field.weight_bound) + math.log(field.num_primitives)) / alpha)
            tiny = 1e-12 * (np.abs(d) + infl)
            d0 = None
            for beta in betas:
                dh, g = field.smooth_distance(Q, alpha=alpha, beta=beta, alpha_u=au)
                label = f"{mesh.name} alpha={alpha:.4g} alpha_u={au} beta={beta}"
                assert np.all(np.isfinite(dh)) and np.all(np.isfinite(g)), label
                up = dh - (d + tiny)
                assert up.max() <= 0, f"d_hat > d by {up.max():.3e} ({label})"
                # Barnes-Hut: far terms use the box distance delta > d / (1 + beta)
                lo = (d / (1.0 + beta) - infl - tiny) - dh
                assert lo.max() <= 0, f"d_hat below the lower bound by {lo.max():.3e} ({label})"
                if beta == 0.0:
                    d0 = dh
                else:
                    assert d0 is not None
                    assert np.all(dh <= d0 + tiny), f"d_hat_beta > d_hat_0 ({label})"


@pytest.mark.parametrize("name", BOUND_MESHES)
@pytest.mark.slow
def test_conservative_bounds(request, zoo, name, rng):
    mesh = zoo[name] if name in zoo else request.getfixturevalue(name)
    Q = bound_queries(mesh, rng, n=2000 if name in zoo else 1200)
    diag = mesh.diagonal
    check_bounds(mesh, Q, alphas=(1.0 / diag, typical_alpha(mesh), 1e3 / diag),
                 alpha_us=(None, 0.5, 4.0), betas=(0.0, 0.3, 1.0))


@pytest.mark.parametrize("key", ["bunny", "creeper", "capillary"])
@pytest.mark.slow
def test_conservative_bounds_shared(shared_data, key, rng):
    mesh = load_shared(shared_data, key)
    check_bounds(mesh, bound_queries(mesh, rng, n=1000 if key == "bunny" else 2000),
                 alphas=(typical_alpha(mesh),),
                 alpha_us=(None, 4.0), betas=(0.0, 0.5))


def test_clamp_is_needed_on_nonmanifold_mesh(nonmanifold_mesh, rng):
    """On a book of 4 triangles, isolated triangles and a bow-tie the unclamped weight A w~
    drops below 1, so an unclamped sum can exceed d; the library clamps and stays <= d and
    equal to the clamped reference."""
    mesh = nonmanifold_mesh
    Q = naive.sample_on_primitives(mesh, 800, rng)
    terms = naive.Terms(Q, mesh)
    assert terms.raw.min() < 0.5            # the clamp is active on this mesh
    field = field_of(mesh)
    for alpha in (typical_alpha(mesh), 1e3 / mesh.diagonal):
        # LogSumExp without the lower clamp (the upper one kept) at on-surface queries
        W = np.minimum(terms.raw, terms.whi[None])
        m = terms.D.min(axis=1)
        with np.errstate(invalid="ignore"):
            s = np.sum(W * np.exp(-alpha * (terms.D - m[:, None])), axis=1)
            unclamped = m - np.log(s) / alpha
        if alpha > typical_alpha(mesh):     # sharp: the own weight A w~ < 1 dominates
            assert np.any(~(unclamped <= m))    # NaN or above d somewhere
        d = field.smooth_distance(Q, alpha=alpha, beta=0.0).distance
        assert np.all(d <= m + 1e-12)
        assert_values_close(d, terms.smooth(alpha)[0], field.inflation(alpha))


# ----------------------------------------------------------------------------- Barnes-Hut
BETAS = (1.0, 0.5, 0.25, 0.1, 0.05, 0.0)


def check_barnes_hut(mesh, Q):
    field = field_of(mesh)
    alpha = typical_alpha(mesh)
    res = {b: field.smooth_distance(Q, alpha=alpha, beta=b, return_stats=True) for b in BETAS}
    d0 = res[0.0][0]
    tiny = 1e-12 * (np.abs(d0) + field.inflation(alpha))
    errors, leaves = [], []
    prev_d, prev_leaves = None, None
    for b in BETAS:                         # from large beta to 0
        d, g, st = res[b]
        assert np.all(d <= d0 + tiny), f"beta={b}: d_hat_beta > d_hat_0"
        if prev_d is not None:              # per query: d_hat only grows as beta shrinks
            assert np.all(d >= prev_d - tiny), f"beta={b}: d_hat decreased as beta shrank"
            # (leaves per query need not grow: a far field of the larger beta can lower the
            # running minimum and with it the reach of negligible-term pruning; the mean
            # does, below)
        prev_d, prev_leaves = d, st.leaves_visited
        errors.append(float(np.mean(d0 - d)))
        leaves.append(float(np.mean(st.leaves_visited)))
    assert all(e1 >= e2 for e1, e2 in zip(errors, errors[1:])), errors
    assert all(l1 <= l2 for l1, l2 in zip(leaves, leaves[1:])), leaves
    assert errors[0] > errors[-2] > 0.0 and errors[-1] == 0.0, errors
    assert leaves[0] < leaves[-1], leaves
    # beta = 0 evaluates every primitive exactly, except those whose terms are negligible
    # (below one unit in the last place of the sum together: test_negligible_pruning_*)
    assert np.all(res[0.0][2].leaves_visited <= field.num_primitives)
    return errors, leaves


@pytest.mark.parametrize("name", ["point_cloud", "circle", "icosphere", "mixed_mesh"])
def test_barnes_hut_monotone_procedural(zoo, name, rng):
    mesh = zoo[name]
    Q = np.concatenate([naive.near_queries(mesh, 400, rng, pad=1.0),
                        naive.far_queries(mesh, 100, rng, 1.0, 30.0)])
    check_barnes_hut(mesh, Q)


@pytest.mark.parametrize("name", REAL_LOCAL)
def test_barnes_hut_monotone_real(request, name, rng):
    mesh = request.getfixturevalue(name)
    check_barnes_hut(mesh, naive.near_queries(mesh, 1500, rng, pad=0.5))


def test_barnes_hut_monotone_bunny(bunny, rng):
    check_barnes_hut(bunny, naive.near_queries(bunny, 600, rng, pad=0.5))


@pytest.mark.parametrize("name", ZOO + REAL_LOCAL)
def test_beta0_bvh_equals_brute_and_naive(request, zoo, name, rng):
    mesh = zoo[name] if name in zoo else request.getfixturevalue(name)
    field = field_of(mesh)
    Q, off = mixed_queries(mesh, rng, near=80, on=20, far=20)
    alpha, au = typical_alpha(mesh), 2.5 * typical_alpha(mesh)
    for gradient in ("exact", "metric"):
        d, g = field.smooth_distance(Q, alpha=alpha, alpha_u=au, beta=0.0, gradient=gradient)
        db, gb, st = field.smooth_distance(Q, alpha=alpha, alpha_u=au, beta=0.7,
                                           gradient=gradient, method="brute",
                                           return_stats=True)   # brute ignores beta
        scale = field.inflation(alpha, au)
        assert_values_close(d, db, scale, rtol=1e-12, what="bvh vs brute")
        assert_grads_close(g[off], gb[off], atol=1e-11, what="bvh vs brute gradient")
        assert np.all(st.leaves_visited == field.num_primitives)
        dr, gr = naive.smooth_distance(Q, mesh, alpha, au, gradient)
        assert_values_close(db, dr, scale, what="brute vs naive")
        assert_grads_close(gb[off], gr[off], what="brute vs naive gradient")


@pytest.mark.parametrize("name", ZOO + REAL_LOCAL)
@pytest.mark.parametrize("sharp", [1.0, 20.0, 200.0])
def test_negligible_pruning_equals_brute_to_rounding(request, zoo, name, sharp, rng):
    """Negligible-term pruning (``smoothdist._kernels.query.negligible_reach``) at ``beta = 0``: the
    value equals brute force (every term) to rounding, at alphas where it prunes nearly
    everything (``sharp`` x the paper's alpha), and the pruned leaves are really skipped."""
    mesh = zoo[name] if name in zoo else request.getfixturevalue(name)
    field = field_of(mesh)
    Q, off = mixed_queries(mesh, rng, near=80, on=20, far=20)
    alpha = sharp * typical_alpha(mesh)
    d, g, st = field.smooth_distance(Q, alpha=alpha, beta=0.0, gradient="exact",
                                     return_stats=True)
    db, gb = field.smooth_distance(Q, alpha=alpha, gradient="exact", method="brute")
    scale = field.inflation(alpha)
    assert_values_close(d, db, scale, rtol=1e-12, what="pruned vs brute")
    assert_grads_close(g[off], gb[off], atol=1e-10, what="pruned vs brute gradient")
    if sharp == 200.0 and field.num_primitives > 40:
        # every query skips most of the data (terms below 2**-53 / N of the sum)
        assert np.median(st.leaves_visited) < 0.5 * field.num_primitives
    # ... and with Barnes-Hut on top it is never above the exact value (beyond rounding)
    d5 = field.smooth_distance(Q, alpha=alpha, beta=0.5).distance
    assert np.all(d5 <= db + 1e-12 * (np.abs(db) + scale))


def test_root_far_field_closed_form(icosphere):
    """Far enough for the root box to pass the test: the whole sum is N * whi^S e^{-alpha
    delta} with delta the distance to the root box, and the gradient its unit direction."""
    field = field_of(icosphere)
    lo, hi = field.bounds
    q = np.array([[0.0, 0.0, hi[2] + 50.0 * field.diagonal]])
    delta = q[0, 2] - hi[2]
    for au, S in ((None, 1.0), (20.0, 0.25)):
        d, g, st = field.smooth_distance(q, alpha=5.0, beta=1.0, alpha_u=au, return_stats=True)
        assert st.nodes_visited[0] == 1 and st.leaves_visited[0] == 1
        expect = delta - math.log(field.num_primitives * field.weight_bound ** S) / 5.0
        assert d[0] == pytest.approx(expect, rel=1e-13)
        np.testing.assert_allclose(g[0], [0.0, 0.0, 1.0], atol=1e-13)


# ----------------------------------------------------------------------------- gradients
def finite_difference(field, Q, h, **kw):
    out = np.empty_like(Q)
    for k in range(3):
        e = np.zeros(3)
        e[k] = h
        out[:, k] = (field.smooth_distance(Q + e, **kw).distance
                     - field.smooth_distance(Q - e, **kw).distance) / (2.0 * h)
    return out


FD_MESHES = ("point_cloud", "circle", "segment_star", "icosphere", "cube", "mixed_mesh",
             "nonmanifold_mesh", "octopus", "trefoil")


@pytest.mark.parametrize("name", FD_MESHES)
@pytest.mark.parametrize("alpha_u", [None, 3.0])
def test_exact_gradient_matches_finite_differences(request, zoo, name, alpha_u, rng):
    mesh = zoo[name] if name in zoo else request.getfixturevalue(name)
    field = field_of(mesh)
    Q = naive.near_queries(mesh, 150, rng, pad=0.1)
    for alpha in (0.5 * typical_alpha(mesh), 2.0 * typical_alpha(mesh)):
        kw = dict(alpha=alpha, beta=0.0, alpha_u=None if alpha_u is None else alpha_u * alpha)
        g = field.smooth_distance(Q, gradient="exact", **kw).gradient
        h = 1e-6 * mesh.diagonal
        f1 = finite_difference(field, Q, h, **kw)
        f2 = finite_difference(field, Q, 0.5 * h, **kw)
        # drop queries whose stencil straddles a kink (Voronoi-region or clamp boundary)
        smooth = np.abs(f1 - f2).max(axis=1) < 1e-6 * (1.0 + np.abs(f2).max(axis=1))
        assert smooth.mean() > 0.9, f"too many kinks ({smooth.mean():.2f} smooth)"
        err = np.abs(g - f2).max(axis=1)[smooth]
        assert np.median(err) < 1e-7, f"median FD error {np.median(err):.2e} (alpha={alpha})"
        assert np.quantile(err, 0.95) < 1e-6, f"95% FD error {np.quantile(err, 0.95):.2e}"


def test_metric_gradient_is_not_the_derivative_for_triangles(icosphere, rng):
    """The paper's metric gradient is not d(d_hat)/dq for alpha != 1; "exact" is (control)."""
    field = field_of(icosphere)
    Q = naive.near_queries(icosphere, 150, rng, pad=0.05)
    kw = dict(alpha=4.0, beta=0.0)
    fd = finite_difference(field, Q, 1e-6, **kw)
    ge = field.smooth_distance(Q, gradient="exact", **kw).gradient
    gm = field.smooth_distance(Q, gradient="metric", **kw).gradient
    assert np.median(np.abs(ge - fd).max(axis=1)) < 1e-7
    assert np.median(np.abs(gm - fd).max(axis=1)) > 1e-3


@pytest.mark.parametrize("name", ZOO)
def test_metric_equals_exact_at_alpha_one(zoo, name, rng):
    mesh = zoo[name]
    field = field_of(mesh)
    Q = naive.near_queries(mesh, 300, rng)
    for au in (None, 3.0):
        a = field.smooth_distance(Q, alpha=1.0, beta=0.0, alpha_u=au, gradient="exact")
        b = field.smooth_distance(Q, alpha=1.0, beta=0.0, alpha_u=au, gradient="metric")
        np.testing.assert_array_equal(a.distance, b.distance)
        np.testing.assert_array_equal(a.gradient, b.gradient)


@pytest.mark.parametrize("alpha", [0.3, 7.0, 250.0])
def test_metric_equals_exact_for_points(point_cloud, alpha, rng):
    field = field_of(point_cloud)
    Q = naive.near_queries(point_cloud, 300, rng)
    for beta in (0.0, 0.5):
        a = field.smooth_distance(Q, alpha=alpha, beta=beta, gradient="exact")
        b = field.smooth_distance(Q, alpha=alpha, beta=beta, gradient="metric")
        np.testing.assert_array_equal(a.gradient, b.gradient)
    # a point cloud's gradient is a convex combination of unit vectors: |grad| <= 1
    g = field.smooth_distance(Q, alpha=alpha, beta=0.0).gradient
    assert np.all(np.linalg.norm(g, axis=1) <= 1.0 + 1e-12)


@pytest.mark.parametrize("name", ["icosphere", "cube", "octopus", "mixed_mesh"])
def test_metric_differs_from_exact_for_triangles(request, zoo, name, rng):
    mesh = zoo[name] if name in zoo else request.getfixturevalue(name)
    field = field_of(mesh)
    Q = naive.near_queries(mesh, 300, rng, pad=0.05)
    alpha = 2.0 * typical_alpha(mesh)
    assert alpha != 1.0
    ge = field.smooth_distance(Q, alpha=alpha, beta=0.0, gradient="exact").gradient
    gm = field.smooth_distance(Q, alpha=alpha, beta=0.0, gradient="metric").gradient
    assert np.abs(ge - gm).max() > 1e-3
    # and "metric" is what the reference computes with the weight term divided by alpha^2
    assert_grads_close(gm, naive.smooth_distance(Q, mesh, alpha, gradient="metric")[1])


# ----------------------------------------------------------------------------- threads
@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs >= 2 numba threads")
@pytest.mark.parametrize("name", ["mixed_mesh", "octopus"])
def test_parallel_equals_serial(request, zoo, name, rng):
    mesh = zoo[name] if name in zoo else request.getfixturevalue(name)
    field = field_of(mesh)
    Q = naive.near_queries(mesh, 3000, rng)
    alpha = typical_alpha(mesh)
    before = numba.get_num_threads()
    out = {}
    try:
        for n in (1, 2):
            numba.set_num_threads(n)
            out[n] = (field.smooth_distance(Q, alpha=alpha, beta=0.5, alpha_u=3 * alpha,
                                            return_stats=True),
                      field.smooth_distance(Q, alpha=alpha, beta=0.0, gradient="exact"),
                      field.smooth_distance(Q, alpha=alpha, method="brute"))
    finally:
        numba.set_num_threads(before)
    assert numba.get_num_threads() == before
    for a, b in zip(out[1], out[2]):
        for x, y in zip(a, b):
            if isinstance(x, QueryStats):
                x, y = np.stack(x), np.stack(y)
            np.testing.assert_array_equal(x, y)


# ----------------------------------------------------------------------------- alpha="auto"
def independent_min_edge(mesh):
    V = mesh.V
    segs = [mesh.edges] + [mesh.triangles[:, [i, j]] for i, j in ((0, 1), (1, 2), (2, 0))]
    S = np.concatenate(segs)
    return float(np.min(np.linalg.norm(V[S[:, 0]] - V[S[:, 1]], axis=1)))


@pytest.mark.parametrize("name", ["circle", "segment_star", "icosphere", "cube", "mixed_mesh",
                                  "nonmanifold_mesh", "octopus", "trefoil"])
def test_paper_alpha_is_inverse_min_edge_and_auto_is_consistent(request, zoo, name, rng):
    mesh = zoo[name] if name in zoo else request.getfixturevalue(name)
    field = field_of(mesh)
    expect = 1.0 / independent_min_edge(mesh)
    assert field.paper_alpha() == pytest.approx(expect, rel=1e-12)
    # "auto" is scale-free: the data scaled by 10 gets alpha / 10
    big = SmoothDistanceField(DataMesh(mesh.V * 10.0, points=mesh.points, edges=mesh.edges,
                                       triangles=mesh.triangles))
    assert big.auto_alpha() == pytest.approx(field.auto_alpha() / 10.0, rel=1e-6)
    Q = naive.near_queries(mesh, 50, rng)
    a = field.smooth_distance(Q, alpha="auto", beta=0.0)
    b = field.smooth_distance(Q, alpha=field.auto_alpha(), beta=0.0)
    np.testing.assert_array_equal(a.distance, b.distance)
    if mesh.kind in ("edges", "triangles"):
        F = mesh.edges if mesh.kind == "edges" else mesh.triangles
        c = smoothdist.smooth_distance(Q, mesh.V, F, alpha="auto", beta=0.0)
        np.testing.assert_array_equal(c[0], a.distance)


def test_auto_alpha_points(point_cloud, rng):
    field = field_of(point_cloud)
    a = field.auto_alpha()
    assert math.isfinite(a) and a > 0
    # of the order of 1 / (typical spacing): spacing of 400 points in the unit cube ~ 0.08
    assert 1.0 < a < 1000.0
    Q = naive.near_queries(point_cloud, 50, rng)
    d, g = smoothdist.smooth_distance(Q, point_cloud.V, alpha="auto")
    assert np.all(np.isfinite(d)) and np.all(np.isfinite(g))
    # scale invariance: scaling the cloud by 10 divides alpha by 10
    big = SmoothDistanceField(point_cloud.V * 10.0)
    assert big.auto_alpha() == pytest.approx(a / 10.0, rel=1e-6)


# ----------------------------------------------------------------------------- validation
BAD_PARAMS = [
    (dict(alpha=0.0), "alpha"),
    (dict(alpha=-1.0), "alpha"),
    (dict(alpha=float("nan")), "alpha"),
    (dict(alpha=float("inf")), "alpha"),
    (dict(alpha="sharp"), "alpha"),
    (dict(alpha=None), "alpha"),
    (dict(alpha=True), "alpha"),
    (dict(alpha=2.0, beta=-0.1), "beta"),
    (dict(alpha=2.0, beta=float("nan")), "beta"),
    (dict(alpha=2.0, beta=float("inf")), "beta"),
    (dict(alpha=2.0, alpha_u=0.0), "alpha_u"),
    (dict(alpha=2.0, alpha_u=-3.0), "alpha_u"),
    (dict(alpha=2.0, alpha_u=float("nan")), "alpha_u"),
    (dict(alpha=2.0, gradient="approx"), "gradient"),
    (dict(alpha=2.0, gradient=None), "gradient"),
]


@pytest.mark.parametrize("kw,word", BAD_PARAMS)
def test_bad_parameters_raise(icosphere, kw, word):
    field = field_of(icosphere)
    with pytest.raises(ValueError, match=word):
        field.smooth_distance([[0.0, 0.0, 2.0]], **kw)
    with pytest.raises(ValueError, match=word):
        smoothdist.smooth_distance([[0.0, 0.0, 2.0]], icosphere.V, icosphere.triangles, **kw)


def test_bad_method_raises(icosphere):
    with pytest.raises(ValueError, match="method"):
        field_of(icosphere).smooth_distance([[0.0, 0.0, 2.0]], alpha=2.0, method="octree")


@pytest.mark.parametrize("Q", [
    [[0.0, float("nan"), 1.0]],
    [[0.0, float("inf"), 1.0]],
    np.zeros((4, 2)),
    np.zeros((2, 3, 1)),
    [[1.0, 2.0], [3.0, 4.0]],
    "abc",
])
def test_bad_queries_raise(icosphere, Q):
    with pytest.raises(ValueError, match="Q"):
        field_of(icosphere).smooth_distance(Q, alpha=2.0)
