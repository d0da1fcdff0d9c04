"""Inclusion-exclusion junction weights (smoothdist.junctions) against independent references.

The reference is ``tests/naive.py``'s ``junction_distance``: the sum over every cell of the mesh
(triangles, their shared edges and vertices; edges and their shared vertices) with
coefficients counted by dicts, in numpy. The kernels instead share each edge's and vertex's
term out among its primitives, so agreement checks that bookkeeping too. Tolerances: the two
sums add the same exponentials in different orders (a few ulps of the sum, relative 1e-12 of
d_hat after the log, and 1e-9 on gradients, which divide by the sum).
"""

import numpy as np
import pytest
import trimesh

import smoothdist
from smoothdist._kernels.spacing import area_weights
from smoothdist.junctions import junction_weights
from smoothdist.kernels import concatenate_trees
from tests import naive

RNG = np.random.default_rng(7)


def _square(k=4):
    """A flat square of 2 k^2 triangles in z = 0 (interior vertices of valence 6)."""
    x = np.linspace(0.0, 1.0, k + 1)
    X, Y = np.meshgrid(x, x)
    V = np.stack([X.ravel(), Y.ravel(), np.zeros(X.size)], 1)
    i = (np.arange(k)[:, None] * (k + 1) + np.arange(k)[None, :]).ravel()
    F = np.concatenate([np.stack([i, i + 1, i + k + 1], 1),
                        np.stack([i + 1, i + k + 2, i + k + 1], 1)])
    return V, F


def _meshes():
    ico = trimesh.creation.icosphere(1)
    noisy = trimesh.creation.icosphere(2)
    V = noisy.vertices * (1 + 0.15 * RNG.standard_normal(len(noisy.vertices)))[:, None]
    box = trimesh.creation.box()
    fin = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1.0]])
    t = np.linspace(0, 2 * np.pi, 30)
    poly = np.stack([np.cos(t), np.sin(2 * t), 0.3 * t], 1)
    star = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0], [-1, -1, 0]])
    return {
        "icosphere": smoothdist.DataMesh(ico.vertices, ico.faces),
        "noisy_sphere": smoothdist.DataMesh(V, noisy.faces),
        "box": smoothdist.DataMesh(box.vertices, box.faces),
        "flat_square": smoothdist.DataMesh(*_square()),
        # three triangles on the edge (0, 1): a non-manifold edge
        "fin": smoothdist.DataMesh(fin, triangles=[[0, 1, 2], [0, 1, 3], [0, 1, 4]]),
        "polyline": smoothdist.DataMesh(poly, edges=np.stack([np.arange(29), np.arange(1, 30)],
                                                             1)),
        # a vertex where four edges meet
        "star": smoothdist.DataMesh(star, edges=[[0, 1], [0, 2], [0, 3], [0, 4], [1, 2]]),
        "mixed": smoothdist.DataMesh(star, points=[3], edges=[[0, 4]], triangles=[[0, 1, 2]]),
    }


MESHES = _meshes()


def test_coefficients_count_the_junctions():
    """a_E = 1/2 on a closed surface's edges and b_v = 1/k_v at its vertices; a boundary edge
    and a boundary vertex subtract and add nothing; three triangles on an edge: 2/3 each;
    a polyline's inner vertices 1/2 and its ends 0; four edges at a vertex: 3/4."""
    ico = MESHES["icosphere"]
    jw = junction_weights(ico)
    k = np.bincount(ico.triangles.ravel())
    assert np.all(jw.tri[:, :3] == 0.5)
    np.testing.assert_array_equal(jw.tri[:, 3:], 1.0 / k[ico.triangles])
    sq = junction_weights(MESHES["flat_square"])
    V = MESHES["flat_square"].V
    on_rim = (np.min(np.c_[V[:, :2], 1 - V[:, :2]], axis=1) == 0)[MESHES["flat_square"].triangles]
    assert np.all(sq.tri[:, 3:][on_rim] == 0.0)
    assert np.all(sq.tri[:, 3:][~on_rim] == 1.0 / 6.0)
    assert set(np.unique(sq.tri[:, :3])) == {0.0, 0.5}
    fin = junction_weights(MESHES["fin"])
    np.testing.assert_allclose(fin.tri[:, 0], 2.0 / 3.0)          # the edge (0, 1) of each
    assert np.all(fin.tri[:, 1:3] == 0.0)
    poly = junction_weights(MESHES["polyline"]).edge
    assert poly[0, 0] == 0.0 and poly[-1, 1] == 0.0
    assert np.all(poly[1:, 0] == 0.5) and np.all(poly[:-1, 1] == 0.5)
    star = junction_weights(MESHES["star"]).edge
    np.testing.assert_allclose(star[:4, 0], 0.75)


@pytest.mark.parametrize("name", sorted(MESHES))
@pytest.mark.parametrize("alpha_l", [3.0, 30.0, 300.0])
def test_kernels_match_the_cell_sum(name, alpha_l):
    """Brute force, the tree with beta 0 and with tol: the naive cell sum, clamped to the
    nearest primitive where it falls below one term; gradients where it does not."""
    mesh = MESHES[name]
    field = smoothdist.SmoothDistanceField(mesh, weights="inclusion-exclusion")
    alpha = alpha_l / field.diagonal
    Q = np.concatenate([naive.near_queries(mesh, 150, RNG), naive.sample_on_primitives(mesh, 30,
                                                                                        RNG)])
    ref, g_ref, s = naive.junction_distance(Q, mesh, alpha)
    d_min = naive.exact_distance(Q, mesh)[0]
    clamped = s < 1.0
    ref = np.where(clamped, d_min, ref)
    free = s > 1.0 + 1e-9
    free[150:] = False      # on the data the direction of a zero distance is rounding noise
    for kw in (dict(method="brute"), dict(beta=0.0), dict(beta=0.0, tol=1e-12)):
        d, g = field.smooth_distance(Q, alpha=alpha, **kw)
        np.testing.assert_allclose(d, ref, rtol=1e-12, atol=1e-12 * field.diagonal,
                                   err_msg=str(kw))
        if "tol" not in kw:
            np.testing.assert_allclose(g[free], g_ref[free], rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("name", ["noisy_sphere", "box", "fin", "polyline", "star"])
def test_conservative_and_gradient_is_the_derivative(name):
    """d_hat <= d everywhere (the clamp where the cell sum undercounts, beta > 0 only lowers
    it), finite far away; the gradient matches central differences where unclamped."""
    mesh = MESHES[name]
    field = smoothdist.SmoothDistanceField(mesh, weights="inclusion-exclusion")
    Q = np.concatenate([naive.near_queries(mesh, 200, RNG), naive.far_queries(mesh, 20, RNG)])
    d_exact = field.exact_distance(Q)[0]
    for alpha_l in (2.0, 50.0, 2000.0):
        alpha = alpha_l / field.diagonal
        for beta in (0.0, 0.5):
            d, g = field.smooth_distance(Q, alpha=alpha, beta=beta)
            assert np.all(np.isfinite(d)) and np.all(np.isfinite(g))
            assert np.all(d <= d_exact * (1 + 1e-12) + 1e-12)
    alpha = 50.0 / field.diagonal
    Qn = Q[:200]
    s = naive.junction_distance(Qn, mesh, alpha)[2]
    h = 1e-6 * field.diagonal
    d, g = field.smooth_distance(Qn, alpha=alpha, beta=0.0)
    fd = np.stack([(field.smooth_distance(Qn + h * e, alpha=alpha, beta=0.0)[0]
                    - field.smooth_distance(Qn - h * e, alpha=alpha, beta=0.0)[0]) / (2 * h)
                   for e in np.eye(3)], 1)
    free = s > 1.0 + 1e-6
    assert free.sum() > 20
    np.testing.assert_allclose(g[free], fd[free], atol=2e-5)


def test_flat_faces_have_the_exact_distance_and_the_paper_weights_a_groove():
    """Above a flat square of 32 triangles (over its internal edges and interior vertices
    too) the smooth distance is the exact one, to rounding; the paper's weights leave a
    groove up to log(2) / alpha deep beside the internal edges (the control)."""
    V, F = _square(4)
    xy = RNG.uniform(0.05, 0.95, (400, 2))
    xy[:100, 1] = xy[:100, 0]                               # over the diagonals
    xy[100:150, 0] = 0.5                                    # over a row of edges
    h = 0.01
    Q = np.column_stack([xy, np.full(xy.shape[0], h)])
    alpha = 2000.0
    d_ie = smoothdist.SmoothDistanceField(V, F, weights="inclusion-exclusion").smooth_distance(
        Q, alpha=alpha, beta=0.0)
    np.testing.assert_allclose(d_ie.distance, h, rtol=0, atol=1e-14)
    np.testing.assert_allclose(d_ie.gradient, np.tile([0, 0, 1.0], (Q.shape[0], 1)), atol=1e-12)
    d_paper = smoothdist.SmoothDistanceField(V, F).smooth_distance(Q, alpha=alpha, beta=0.0)
    groove = d_paper.distance.max() - d_paper.distance.min()
    assert groove > 0.25 * np.log(2) / alpha


def test_straight_polyline_is_the_exact_tube_at_any_alpha():
    """On a straight chain the edge and vertex terms telescope to the nearest edge's: no
    ribs, whatever alpha (the paper's weights ripple at alpha h ~ 1)."""
    n = 20
    V = np.column_stack([np.linspace(0, 1, n + 1), np.zeros(n + 1), np.zeros(n + 1)])
    E = np.stack([np.arange(n), np.arange(1, n + 1)], 1)
    x = np.linspace(0.1, 0.9, 301)
    r = 0.03
    Q = np.column_stack([x, np.full_like(x, r), np.zeros_like(x)])
    for alpha_h in (0.5, 2.0, 20.0):
        alpha = alpha_h * n
        d = smoothdist.SmoothDistanceField(V, E, weights="inclusion-exclusion").smooth_distance(
            Q, alpha=alpha, beta=0.0).distance
        np.testing.assert_allclose(d, r, rtol=0, atol=1e-13)
    paper = smoothdist.SmoothDistanceField(V, E).smooth_distance(Q, alpha=1.0 * n, beta=0.0)
    assert np.ptp(paper.distance) > 1e-3 * r


def test_points_take_area_weights_and_switching_shares_the_geometry():
    """A point cloud's junction weights are its area weights (``tests/smoothdist/
    test_area_weights.py`` checks their sums; the paper's scheme keeps weight 1);
    with_weights shares the nodes and corners, and switching back gives the tree a fresh
    paper build has."""
    P = RNG.normal(size=(300, 3))
    a = smoothdist.SmoothDistanceField(P)
    b = a.with_weights("inclusion-exclusion")
    np.testing.assert_array_equal(a.tree.pwhi, 1.0)
    np.testing.assert_array_equal(b.tree.pwhi, area_weights(a.tree))
    assert b.tree.pts is a.tree.pts
    mesh = MESHES["box"]
    paper = smoothdist.SmoothDistanceField(mesh)
    ie = paper.with_weights("inclusion-exclusion")
    assert ie.weights == "inclusion-exclusion" and paper.weights == "paper"
    assert ie.tree.pts is paper.tree.pts and ie.tree.lo is paper.tree.lo
    back = ie.with_weights("paper")
    for name in ("wc", "wcls", "pwhi", "whi", "lwhi"):
        np.testing.assert_array_equal(getattr(back.tree, name), getattr(paper.tree, name))
    assert paper.with_weights("paper") is paper


@pytest.mark.parametrize("name", ["noisy_sphere", "fin", "polyline", "mixed"])
def test_a_field_built_with_the_junction_weights_is_the_switched_one(name):
    """Issue 60: ``SmoothDistanceField(weights="inclusion-exclusion")`` builds its tree with
    the junction weights directly (the paper's weight classes are not computed first: 0.37 s
    at 1M triangles); every array of the tree is the one a paper build switched with
    ``with_weights`` has, bit for bit."""
    mesh = MESHES[name]
    direct = smoothdist.SmoothDistanceField(mesh, weights="inclusion-exclusion")
    switched = smoothdist.SmoothDistanceField(mesh).with_weights("inclusion-exclusion")
    assert direct.weights == switched.weights == "inclusion-exclusion"
    for field in direct.tree._fields:
        a, b = getattr(direct.tree, field), getattr(switched.tree, field)
        np.testing.assert_array_equal(a, b, err_msg=field)
    assert direct.weight_bound == switched.weight_bound


def test_refusals():
    """Unknown schemes, whole-mesh distance (its kernels use the paper's weights) and a forest
    of both schemes are refused with a message, not computed wrongly."""
    with pytest.raises(ValueError, match="weights must be one of"):
        smoothdist.SmoothDistanceField(MESHES["box"], weights="exact")
    ie = smoothdist.SmoothDistanceField(MESHES["box"], weights="inclusion-exclusion")
    with pytest.raises(ValueError, match="paper's weights"):
        smoothdist.MeshDistance(ie, MESHES["box"], alpha=10.0, alpha_q=10.0)
    with pytest.raises(ValueError, match="one weight scheme"):
        concatenate_trees([ie.tree, ie.with_weights("paper").tree])
