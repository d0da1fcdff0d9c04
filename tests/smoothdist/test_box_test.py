"""The paper's box test on and off (Sec. 3.5; ``MeshDistance(box_test=...)``).

Off, a Barnes-Hut candidate's distance is the exact primitive-box distance
(:func:`smoothdist._kernels.box_distance.box_distance_exact`), checked here against a dense
sampling of the primitive (the point-box distance is a clamp, independent of the kernel). On and off
accept different far fields (the exact distance is at least the halfspace bound, so more nodes
qualify), so their values agree only within the Barnes-Hut error: the tolerance of these tests
and of ``tracer reproduce``'s ``box_test`` experiment is, per query primitive,
``|on - off| <= d_beta0 - min(on, off)``, both at most ``d_beta0`` (1e-12 relative for
rounding).
"""

import numpy as np
import pytest

from smoothdist import MeshDistance
from smoothdist._kernels.box_distance import box_distance_exact, box_lower_bound


def _sampled(kq, Q, lo, hi, n=120):
    """The smallest point-box distance over a barycentric grid of the primitive (an upper
    bound of the exact distance, within the grid's spacing of it)."""
    V = Q.reshape(3, 3)[:kq + 1]
    u = np.linspace(0.0, 1.0, n + 1)
    if kq == 1:
        P = V[0] + u[:, None] * (V[1] - V[0])
    else:
        a, b = np.meshgrid(u, u, indexing="ij")
        keep = a + b <= 1.0
        P = V[0] + a[keep, None] * (V[1] - V[0]) + b[keep, None] * (V[2] - V[0])
    gap = np.maximum(np.maximum(lo - P, P - hi), 0.0)
    return float(np.sqrt((gap ** 2).sum(1)).min())


@pytest.mark.parametrize("kq", [1, 2])
def test_exact_box_distance_against_sampling(kq):
    rng = np.random.default_rng(kq)
    E = np.empty(9)
    for _ in range(150):
        lo = rng.uniform(-1, 0, (1, 3))
        hi = lo + rng.uniform(0.05, 1.0, (1, 3))
        Q = np.zeros(9)
        Q[:3 * (kq + 1)] = rng.uniform(-2.5, 2.5, 3 * (kq + 1))
        d, ux, uy, uz = box_distance_exact(kq, Q, lo, hi, 0, E)
        s = _sampled(kq, Q, lo[0], hi[0])
        size = np.ptp(Q[:3 * (kq + 1)].reshape(-1, 3), axis=0).max()
        assert d <= s + 1e-12 and s - d <= 2.0 * size / 120, (d, s)
        qlo = Q[:3 * (kq + 1)].reshape(-1, 3).min(0)
        qhi = Q[:3 * (kq + 1)].reshape(-1, 3).max(0)
        assert box_lower_bound(kq, Q, qlo, qhi, lo, hi, 0, np.empty(9))[0] <= d + 1e-12
        if d > 0:
            assert abs(np.hypot(np.hypot(ux, uy), uz) - 1.0) < 1e-12
            # the gradient: moving the query along u by h adds h to the distance (to first order)
            h = 1e-6 * d
            Q2 = Q.copy()
            for v in range(kq + 1):
                Q2[3 * v:3 * v + 3] += h * np.array([ux, uy, uz])
            d2 = box_distance_exact(kq, Q2, lo, hi, 0, E)[0]
            assert abs((d2 - d) / h - 1.0) < 1e-4


def _pair(kind):
    from tracer.sim.primitives import bowl_edges, icosphere_edges, slide_edges, uv_sphere

    if kind == "edges":
        return bowl_edges(), icosphere_edges(), 50.0, [0.0, 0.5, 0.0]
    V, E = slide_edges()
    return (V, E), uv_sphere(), 100.0, V[24 * 7 + 3] + [0.0, 1.0, 0.0]


@pytest.mark.parametrize("kind", ["edges", "triangles"])
def test_box_test_on_and_off_agree_within_the_barnes_hut_error(kind):
    data, query, alpha, start = _pair(kind)
    on = MeshDistance(data, query, alpha=alpha, alpha_q=alpha, beta=0.5)
    off = MeshDistance(on.field, query, alpha=alpha, alpha_q=alpha, beta=0.5, box_test=False)
    ref = MeshDistance(on.field, query, alpha=alpha, alpha_q=alpha, beta=0.0)
    t = on.translation_at_gap(1.0 / alpha, [0.0, -1.0, 0.0], start)
    d_on, g_on = on.primitive_distances(t=t)
    d_off, g_off = off.primitive_distances(t=t)
    d0, _ = ref.primitive_distances(t=t)
    eps = 1e-12 * np.abs(d0).max()
    assert np.all(d_on <= d0 + eps) and np.all(d_off <= d0 + eps)
    assert np.all(np.abs(d_on - d_off) <= d0 - np.minimum(d_on, d_off) + eps)
    assert not np.array_equal(d_on, d_off)  # the switch reaches the kernels
    assert np.all(np.isfinite(g_off))
    # without far fields (beta 0) the box test is never called: identical results
    a = MeshDistance(on.field, query, alpha=alpha, alpha_q=alpha, beta=0.0, box_test=False)
    assert np.array_equal(a.primitive_distances(t=t)[0], d0)


def test_box_test_bad_input_and_unsupported_paths():
    data, query, alpha, start = _pair("edges")
    with pytest.raises(ValueError, match="box_test must be True or False"):
        MeshDistance(data, query, alpha=alpha, alpha_q=alpha, box_test="off")
    off = MeshDistance(data, query, alpha=alpha, alpha_q=alpha, box_test=False)
    with pytest.raises(ValueError, match="needs box_test=True"):
        off.vertex_gradient(t=[0.0, 1.0, 0.0])
    with pytest.raises(ValueError, match="needs box_test=True"):
        off.primitive_moments(t=[0.0, 1.0, 0.0])
