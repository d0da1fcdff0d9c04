"""``alpha=within(e)``: the smooth distance at most ``e`` below the exact one near contact
(issue 47, item 3). Checked on both sides: the bound holds against numpy brute force on shapes
made here (a bumpy sphere, a helix polyline, random samples, whole query meshes), and it is
attained (data points at one spot), so an alpha chosen larger than needed fails too.
"""
import math

import numpy as np
import pytest

import smoothdist as sd
from tests import naive

# the gap checks compare d - d_hat with e: both are O(1e-2) sums of float64 terms; 1e-12
# relative covers any summation order, FMA and vector width
ROUND = 1e-12


def _bumpy_sphere():
    trimesh = pytest.importorskip("trimesh")
    m = trimesh.creation.icosphere(subdivisions=2)
    rng = np.random.default_rng(5)
    V = m.vertices * (1.0 + 0.05 * rng.standard_normal(len(m.vertices)))[:, None]
    return sd.DataMesh(V, np.asarray(m.faces))


def _helix():
    s = np.linspace(0.0, 4 * np.pi, 120)
    V = np.stack([np.cos(s), np.sin(s), 0.1 * s], axis=1)
    return sd.DataMesh(V, np.stack([np.arange(119), np.arange(1, 120)], axis=1))


def _samples():
    rng = np.random.default_rng(8)
    P = rng.normal(size=(400, 3))
    return sd.DataMesh(P / np.linalg.norm(P, axis=1, keepdims=True))


def _near(mesh, e, rng, n=300):
    """Query points at exact distance in (0, e] from random spots of the data."""
    spots = naive.sample_on_primitives(mesh, n, rng)
    dirs = rng.normal(size=(n, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    return spots + rng.uniform(0.0, e, n)[:, None] * dirs


@pytest.mark.parametrize("alpha_u", [None, "auto", 400.0])
@pytest.mark.parametrize("beta", [0.0, 0.5])
@pytest.mark.parametrize("shape", ["triangles", "edges", "points"])
def test_within_holds_near_contact(shape, beta, alpha_u):
    mesh = {"triangles": _bumpy_sphere, "edges": _helix, "points": _samples}[shape]()
    e = 0.01
    rng = np.random.default_rng(2)
    Q = _near(mesh, e, rng)
    d = naive.exact_distance(Q, mesh)[0]
    Q, d = Q[d <= e], d[d <= e]
    assert len(d) > 100
    field = sd.SmoothDistanceField(mesh)
    dh = field.smooth_distance(Q, alpha=sd.within(e), beta=beta, alpha_u=alpha_u).distance
    gap = d - dh
    assert gap.min() >= -ROUND * e
    assert gap.max() <= e * (1 + ROUND)
    # the same alpha through the field's method and the top-level function
    alpha = field.alpha_within(e, beta, alpha_u)
    np.testing.assert_array_equal(
        dh, sd.smooth_distance(Q, mesh, alpha=alpha, beta=beta, alpha_u=alpha_u).distance)
    if beta == 0.0:   # the brute force's value at that alpha agrees (independent sum)
        S = field.attenuation(alpha, alpha_u)
        ref = naive.smooth_distance_value(Q, mesh, alpha,
                                          None if S == 1.0 else alpha / S)
        np.testing.assert_allclose(dh, ref, rtol=0, atol=1e-9)


def _cluster(n, spot=(0.0, 0.0, 0.0), far=(5.0, 0.0, 0.0)):
    """``n`` points within 1e-9 of ``spot`` and one far point (so the data has a size)."""
    rng = np.random.default_rng(n)
    P = np.asarray(spot) + 1e-9 * rng.uniform(-1, 1, (n, 3))
    return np.vstack([P, far])


@pytest.mark.parametrize("beta", [0.0, 0.5])
def test_within_is_attained_by_points_at_one_spot(beta):
    """``n`` coincident points read ``d - log n / alpha`` at beta 0: the gap reaches the bound
    (to the far point's share log(n) / log(n + 1)); at beta 0.5 the bound allows ``e / 1.5``
    for the sum and ``beta e / (1 + beta)`` for a far field that cannot occur here (the
    cluster is one node much smaller than its distance, the same value either way)."""
    e = 0.02
    n = 2000
    field = sd.SmoothDistanceField(_cluster(n))
    Q = np.array([[0.0, 0.0, e], [0.0, e / 2, 0.0], [0.0, 0.0, e / 10]])
    dh = field.smooth_distance(Q, alpha=sd.within(e), beta=beta).distance
    d = np.linalg.norm(Q, axis=1)
    share = math.log(n) / math.log(n + 1)
    np.testing.assert_allclose(d - dh, e * share / (1 + beta), rtol=1e-6)
    assert np.all(d - dh <= e)


def test_alpha_u_number_is_solved_for_alpha():
    """With a number alpha_u the exponent S = min(alpha / alpha_u, 1) depends on alpha; the
    alpha returned is the smallest that meets (1 + beta)(S log A + log N) / e."""
    field = sd.SmoothDistanceField(_bumpy_sphere())
    logA, logN = math.log(field.weight_bound), math.log(field.num_primitives)
    assert logA > 0.5
    e, beta = 0.01, 0.5
    none = field.alpha_within(e, beta)
    assert none == pytest.approx((1 + beta) * (logA + logN) / e, rel=1e-14)
    for alpha_u in (0.5 * none, 3.0 * none, 50.0 * none):
        a = field.alpha_within(e, beta, alpha_u)
        S = min(a / alpha_u, 1.0)
        need = (1 + beta) * (S * logA + logN) / e
        assert a >= need * (1 - 1e-14)
        if a < alpha_u:    # interior solution: the inequality is tight, so none smaller fits
            assert a == pytest.approx(need, rel=1e-12)
        assert a <= none * (1 + 1e-14)


def _query_points(n, spot):
    rng = np.random.default_rng(n + 1)
    return np.asarray(spot) + 1e-9 * rng.uniform(-1, 1, (n, 3))


def test_mesh_within_is_attained_and_holds():
    """Query of m points at one spot over data of n points at one spot: the whole-mesh gap
    is log n / alpha + log m / alpha_q, half of e each (to the far point's share)."""
    e, n, m = 0.02, 500, 300
    data = _cluster(n)
    md = sd.MeshDistance(data, _query_points(m, (0.0, 0.0, 0.0)), alpha=sd.within(e))
    assert md.max_error == e
    for t in ([0.0, 0.0, e], [0.0, 0.3 * e, 0.0]):
        D, G = md(t=t)
        d = float(np.linalg.norm(t))
        # beta 0.5 on point queries: the bound is (e/2 + e/2) / 1.5 at the sum's worst
        expect = (e / 2 * math.log(n) / math.log(n + 1) + e / 2) / 1.5
        assert d - D == pytest.approx(expect, rel=1e-5)
        assert d - D <= e


@pytest.mark.parametrize("query", ["triangles", "edges", "points"])
def test_mesh_within_holds_near_contact(query):
    trimesh = pytest.importorskip("trimesh")
    data = _bumpy_sphere()
    small = trimesh.creation.icosphere(subdivisions=1)
    Vq = 0.25 * small.vertices
    q = {"triangles": (Vq, small.faces), "edges": (Vq, small.edges_unique), "points": Vq}[query]
    e = 0.02
    md = sd.MeshDistance(data, q, alpha=sd.within(e), beta=0.0)
    rng = np.random.default_rng(4)
    checked = 0
    for k in range(12):
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        # place the query so that its exact gap is about uniform in (0, e)
        target = rng.uniform(0.05, 1.0) * e
        t = md.translation_at_gap(target, -u, start=2.5 * u)
        d_exact = md.exact(t=t)[0]
        if not 0 < d_exact <= e:
            continue
        D = md(t=t)[0]
        assert -ROUND <= d_exact - D <= e * (1 + ROUND)
        checked += 1
    assert checked >= 8


def test_within_errors():
    V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    for bad in (0, -1.0, float("nan"), float("inf"), "small", True):
        with pytest.raises(ValueError, match="max_error"):
            sd.within(bad)
    with pytest.raises(ValueError, match="tol=0"):
        sd.smooth_distance([[0, 0, 1.0]], V, [[0, 1, 2]], alpha=sd.within(0.01), tol=0.1)
    tri = (V, [[0, 1, 2]])
    with pytest.raises(ValueError, match="beta=0 or box_test=False"):
        sd.MeshDistance(tri, tri, alpha=sd.within(0.01))
    sd.MeshDistance(tri, tri, alpha=sd.within(0.01), beta=0.0)
    sd.MeshDistance(tri, tri, alpha=sd.within(0.01), box_test=False)
    sd.MeshDistance(tri, V, alpha=sd.within(0.01))       # point queries: any beta
    with pytest.raises(ValueError, match="alpha_q"):
        sd.MeshDistance(tri, V, alpha=sd.within(0.01), alpha_q=20.0)
    with pytest.raises(ValueError, match="alpha_q is required"):
        sd.MeshDistance(tri, V, alpha=20.0)
    with pytest.raises(ValueError, match="tol=0"):
        sd.MeshDistance(tri, V, alpha=sd.within(0.01), tol=0.1)
