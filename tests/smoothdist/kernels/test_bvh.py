"""BVH invariants (boxes nest and are tight, every primitive in exactly one leaf, per-node
weight maxima, balanced depth), the primitive table, leaf_size independence of the results,
traversal statistics, and tiny meshes (1-2 primitives)."""

import math

import numpy as np
import pytest

import naive
from smoothdist import DataMesh, SmoothDistanceField
from smoothdist._kernels.bvh import SAH_MIN, build_tree

MESHES = ("point_cloud", "circle", "segment_star", "icosphere", "cube", "mixed_mesh",
          "nonmanifold_mesh", "octopus", "trefoil")


def get(request, zoo, name):
    return zoo[name] if name in zoo else request.getfixturevalue(name)


def primitive_vertices(mesh):
    """List (mesh numbering) of (k, 3) vertex arrays of every primitive."""
    V = mesh.V
    out = [V[[p]] for p in mesh.points]
    out += [V[e] for e in mesh.edges]
    out += [V[t] for t in mesh.triangles]
    return out


def check_tree(mesh, leaf_size):
    tree = build_tree(mesh, leaf_size=leaf_size)
    m = mesh.num_primitives
    n = tree.lo.shape[0]
    prims = primitive_vertices(mesh)
    A, ec, ewhi, tc, twhi = mesh.weight_data()
    whi_mesh = np.concatenate([np.ones(mesh.points.size), ewhi, twhi])
    kind_mesh = np.concatenate([np.zeros(mesh.points.size), np.ones(mesh.edges.shape[0]),
                                np.full(mesh.triangles.shape[0], 2)])
    for arr in (tree.lo, tree.hi, tree.left, tree.right, tree.start, tree.count, tree.diag,
                tree.whi, tree.kind, tree.pts, tree.wc, tree.wcls, tree.pwhi, tree.orig):
        assert arr.flags.c_contiguous
    # primitive table: a permutation of the mesh's primitives, with their data
    np.testing.assert_array_equal(np.sort(tree.orig), np.arange(m))
    np.testing.assert_array_equal(tree.kind, kind_mesh[tree.orig])
    np.testing.assert_array_equal(tree.pwhi, whi_mesh[tree.orig])
    assert tree.A == A
    for i in range(m):
        P = prims[tree.orig[i]]
        k = P.shape[0]
        np.testing.assert_array_equal(tree.pts[i, :3 * k], P.ravel())
        assert np.all(tree.pts[i, 3 * k:] == 0)
        # wc: coefficients of the raw weight A w~ (A folded in)
        if k == 2:
            np.testing.assert_allclose(tree.wc[tree.wcls[i], :5],
                                       A * ec[tree.orig[i] - mesh.points.size],
                                       rtol=1e-15, atol=0)
        if k == 3:
            j = tree.orig[i] - mesh.points.size - mesh.edges.shape[0]
            np.testing.assert_allclose(tree.wc[tree.wcls[i]], A * tc[j], rtol=1e-15, atol=0)
    # root covers everything
    assert tree.start[0] == 0 and tree.count[0] == m
    seen = np.zeros(m, dtype=int)
    depth = np.zeros(n, dtype=int)
    reached = np.zeros(n, dtype=bool)
    reached[0] = True
    stack = [0]
    while stack:
        node = stack.pop()
        s, c = tree.start[node], tree.count[node]
        assert c >= 1
        # box: tight around the node's primitives' vertices
        X = np.concatenate([prims[tree.orig[i]] for i in range(s, s + c)])
        np.testing.assert_array_equal(tree.lo[node], X.min(axis=0))
        np.testing.assert_array_equal(tree.hi[node], X.max(axis=0))
        assert tree.diag[node] == pytest.approx(np.linalg.norm(tree.hi[node] - tree.lo[node]),
                                                rel=1e-15, abs=0)
        # weight bound of the node: the max of its primitives' clamps
        assert tree.whi[node] == tree.pwhi[s:s + c].max()
        assert tree.whi[node] >= 1.0
        L, R = tree.left[node], tree.right[node]
        if L < 0:
            assert R < 0
            assert c <= leaf_size
            seen[s:s + c] += 1
            continue
        assert c > leaf_size
        # children partition the parent's range, boxes nest
        assert tree.start[L] == s and tree.start[R] == s + tree.count[L]
        assert tree.count[L] + tree.count[R] == c
        _check_split(tree, prims, s, c, tree.count[L])
        for ch in (L, R):
            assert not reached[ch], "node reached twice"
            reached[ch] = True
            assert np.all(tree.lo[ch] >= tree.lo[node]) and np.all(tree.hi[ch] <= tree.hi[node])
            depth[ch] = depth[node] + 1
            stack.append(ch)
    assert reached.all(), "unreachable nodes"
    assert np.all(seen == 1), "every primitive must lie in exactly one leaf"
    assert tree.depth == depth.max()
    # every split keeps SAH_MIN of the primitives on each side
    assert tree.depth <= max(0, math.ceil(math.log(m) / -math.log1p(-SAH_MIN)))
    assert SmoothDistanceField(mesh, leaf_size=leaf_size).weight_bound == tree.whi[0]
    return tree


def _area(e):
    """Half the surface area of boxes with extents ``e (k, 3)``."""
    return e[:, 0] * e[:, 1] + e[:, 1] * e[:, 2] + e[:, 2] * e[:, 0]


def _check_split(tree, prims, s, c, cl):
    """The node ``[s, s + c)`` split after ``cl`` primitives: those with the smallest centroids
    along the longest axis of the centroids' box go left, each side keeps at least ``SAH_MIN``
    of them, and (where the centroids along the axis are distinct, so the order is unique) the
    split has the smallest surface-area cost ``A_L n_L + A_R n_R`` of those allowed."""
    P = [prims[tree.orig[i]] for i in range(s, s + c)]
    cent = np.array([p.mean(axis=0) for p in P])
    ext = cent.max(axis=0) - cent.min(axis=0)
    axis = 1 if (ext[1] > ext[0] and ext[1] >= ext[2]) else 2 if (ext[2] > ext[0]
                                                                   and ext[2] > ext[1]) else 0
    x = cent[:, axis]
    assert x[:cl].max() <= x[cl:].min()
    lo_count = max(1, int(SAH_MIN * c))
    assert lo_count <= cl <= c - lo_count
    if np.unique(x).size == c and c > 3:
        rank = np.argsort(x)
        plo = np.array([P[i].min(axis=0) for i in rank])
        phi = np.array([P[i].max(axis=0) for i in rank])
        # boxes of the first k and of the last c - k primitives, k = 1 .. c - 1
        e_l = np.maximum.accumulate(phi)[:-1] - np.minimum.accumulate(plo)[:-1]
        e_r = (np.maximum.accumulate(phi[::-1]) - np.minimum.accumulate(plo[::-1]))[::-1][1:]
        k = np.arange(1, c)
        cost = (_area(e_l) * k + _area(e_r) * (c - k))
        ok = (k >= lo_count) & (k <= c - lo_count)
        assert cost[cl - 1] <= cost[ok].min() * (1 + 1e-9) + 1e-300


@pytest.mark.parametrize("name", MESHES)
@pytest.mark.parametrize("leaf_size", [1, 3, 8])
def test_tree_invariants(request, zoo, name, leaf_size):
    check_tree(get(request, zoo, name), leaf_size)


def test_tree_invariants_bunny(bunny):
    check_tree(bunny.as_kind("points"), 4)


@pytest.mark.parametrize("name", MESHES)
def test_leaf_size_gives_same_results(request, zoo, name, rng):
    mesh = get(request, zoo, name)
    Q = np.concatenate([naive.near_queries(mesh, 300, rng),
                        naive.far_queries(mesh, 30, rng, 2.0, 1e4)])
    e = mesh.min_edge_length()
    alpha = 1.0 / e if e else 50.0 / mesh.diagonal
    base = SmoothDistanceField(mesh, leaf_size=1)
    d1, g1 = base.smooth_distance(Q, alpha=alpha, beta=0.0, alpha_u=3 * alpha, gradient="exact")
    x1 = base.exact_distance(Q, return_closest=True)
    scale = base.inflation(alpha, 3 * alpha)
    D = naive.distances_to_primitives(Q, mesh)
    for leaf_size in (2, 5, 16):
        f = SmoothDistanceField(mesh, leaf_size=leaf_size)
        d, g = f.smooth_distance(Q, alpha=alpha, beta=0.0, alpha_u=3 * alpha, gradient="exact")
        np.testing.assert_allclose(d, d1, rtol=1e-12, atol=1e-12 * scale)
        np.testing.assert_allclose(g, g1, rtol=1e-12, atol=1e-12)
        x = f.exact_distance(Q, return_closest=True)
        np.testing.assert_allclose(x.distance, x1.distance, rtol=1e-12, atol=0)
        np.testing.assert_allclose(x.gradient, x1.gradient, atol=1e-12)
        # the closest primitive may differ only in a tie
        np.testing.assert_allclose(D[np.arange(Q.shape[0]), x.closest], x1.distance,
                                   rtol=1e-12, atol=1e-13 * mesh.diagonal)
        # Barnes-Hut with big leaves keeps the bound below the exact sum
        db = f.smooth_distance(Q, alpha=alpha, beta=0.5, alpha_u=3 * alpha).distance
        assert np.all(db <= d1 + 1e-12 * (np.abs(d1) + scale))


@pytest.mark.parametrize("leaf_size", [0, -1, 1.5, True, "2"])
def test_bad_leaf_size(icosphere, leaf_size):
    with pytest.raises(ValueError, match="leaf_size"):
        SmoothDistanceField(icosphere, leaf_size=leaf_size)


def _reach(field, alpha):
    """The negligible-term reach, written out: terms beyond the nearest distance plus this
    are below ``2**-53 / N`` of the sum (docs/design-notes.md, "Negligible terms")."""
    S = field.kernel_args(alpha, 0.0, None, "exact")[2]
    n = field.num_primitives
    return (math.log(n * 2.0 ** 53) + S * max(math.log(field.tree.whi[0]), 0.0)) / alpha


@pytest.mark.parametrize("name", ["icosphere", "mixed_mesh", "octopus"])
def test_stats_beta_zero_visit_everything(request, zoo, name, rng):
    mesh = get(request, zoo, name)
    for leaf_size in (1, 4):
        f = SmoothDistanceField(mesh, leaf_size=leaf_size)
        Q = naive.near_queries(mesh, 100, rng)
        _, _, st = f.smooth_distance(Q, alpha=10.0, beta=0.0, return_stats=True)
        # every primitive, except those skipped as negligible (smoothdist._kernels.query.
        # negligible_reach): all within ``reach`` of the nearest one are visited
        D = naive.distances_to_primitives(Q, mesh)
        reach = _reach(f, 10.0)
        must = (D < D.min(axis=1, keepdims=True) + reach).sum(axis=1)
        assert np.all(st.leaves_visited <= f.num_primitives)
        assert np.all(st.leaves_visited >= must)
        assert np.all(st.nodes_visited <= f.tree.lo.shape[0])
        _, _, st = f.smooth_distance(Q, alpha=100.0, beta=0.0, return_stats=True)
        assert np.all(st.leaves_visited >= (D < D.min(axis=1, keepdims=True)
                                            + _reach(f, 100.0)).sum(1))
        _, _, st = f.smooth_distance(Q, alpha=10.0, method="brute", return_stats=True)
        assert np.all(st.leaves_visited == f.num_primitives)


TINY = {
    "one_point": (np.array([[0.3, -0.2, 0.5]]), None),
    "two_points": (np.array([[0.0, 0, 0], [1.0, 0.5, 0]]), None),
    "one_edge": (np.array([[0.0, 0, 0], [1.0, 0.5, 0.2]]), np.array([[0, 1]])),
    "one_triangle": (np.array([[0.0, 0, 0], [1.0, 0, 0], [0.2, 0.9, 0.1]]), np.array([[0, 1, 2]])),
}


@pytest.mark.parametrize("name", sorted(TINY))
def test_tiny_meshes(name, rng):
    V, F = TINY[name]
    mesh = DataMesh(V, F)
    field = SmoothDistanceField(mesh)
    tree = check_tree(mesh, 1)
    assert tree.depth == (0 if mesh.num_primitives == 1 else 1)
    Q = np.concatenate([rng.normal(size=(100, 3)), naive.far_queries(mesh, 10, rng, 10.0, 1e5)
                        if mesh.diagonal > 0 else rng.normal(size=(10, 3)) * 1e5])
    for alpha, au in ((0.7, None), (30.0, 90.0)):
        for beta in (0.0, 0.8):
            d, g = field.smooth_distance(Q, alpha=alpha, beta=beta, alpha_u=au,
                                         gradient="exact")
            dr, gr = naive.smooth_distance(Q, mesh, alpha, au)
            if beta == 0.0 or mesh.num_primitives == 1:
                np.testing.assert_allclose(d, dr, rtol=1e-9, atol=1e-12)
                np.testing.assert_allclose(g, gr, atol=1e-8)
            else:
                assert np.all(d <= dr + 1e-12 * np.abs(dr))
    de, ge, _ = naive.exact_distance(Q, mesh)
    x = field.exact_distance(Q)
    np.testing.assert_allclose(x.distance, de, rtol=1e-13)
    np.testing.assert_allclose(x.gradient, ge, atol=1e-12)
    if mesh.num_primitives == 1:     # one primitive: a weight-1 term, d_hat = d exactly
        assert field.weight_bound == 1.0
        d = field.smooth_distance(Q, alpha=5.0, beta=0.5).distance
        np.testing.assert_allclose(d, de, rtol=1e-13)


@pytest.mark.parametrize("leaf_size", [1, 2])
def test_barnes_hut_acceptance_rule(leaf_size):
    """A node (> 1 primitive) is replaced by its far field iff diag(box) < beta * dist(q, box)
    (the authors' rule, paper Alg. 1): two points, so the root is the only such node."""
    V = np.array([[0.0, 0.0, 0.0], [0.3, 0.4, 0.0]])          # root box diagonal 0.5
    field = SmoothDistanceField(V, leaf_size=leaf_size)
    q = np.array([[0.3, 0.4, 2.0]])                              # box distance 2.0
    ratio = 0.5 / 2.0
    for beta, accepted in ((ratio * 1.001, True), (ratio * 0.999, False)):
        d, g, st = field.smooth_distance(q, alpha=3.0, beta=beta, return_stats=True)
        if accepted:
            assert st.nodes_visited[0] == 1 and st.leaves_visited[0] == 1
            assert d[0] == pytest.approx(2.0 - math.log(2.0) / 3.0, rel=1e-14)
        else:
            assert st.leaves_visited[0] == 2
            assert st.nodes_visited[0] == (3 if leaf_size == 1 else 1)
            dr = naive.smooth_distance(q, field.mesh, 3.0)[0]
            assert d[0] == pytest.approx(dr[0], rel=1e-14)


def _barnes_hut_numpy(tree, terms, q, alpha, beta, S):
    """Value of the Barnes-Hut smooth distance at one query by a plain Python traversal of the
    tree's arrays: far field ``count * whi**S * exp(-alpha * box distance)`` (written with
    ``whi ** S``, independently of the kernel's ``lwhi``), every other primitive by its naive
    term (``terms``: :class:`naive.Terms` of this query)."""
    W = terms.weights(S)[0][0]
    D = terms.D[0]
    parts = []
    stack = [0]
    while stack:
        n = stack.pop()
        bd = np.linalg.norm(q - np.clip(q, tree.lo[n], tree.hi[n]))
        if tree.count[n] > 1 and tree.diag[n] < beta * bd:
            parts.append((bd, tree.count[n] * tree.whi[n] ** S))
        elif tree.left[n] < 0:
            for i in range(tree.start[n], tree.start[n] + tree.count[n]):
                j = tree.orig[i]
                parts.append((D[j], W[j]))
        else:
            stack += [tree.left[n], tree.right[n]]
    d, w = np.array(parts).T
    m = d.min()
    return m - math.log(np.sum(w * np.exp(-alpha * (d - m)))) / alpha


@pytest.mark.parametrize("name", ["icosphere", "mixed_mesh", "segment_star"])
def test_barnes_hut_far_field_against_numpy(request, zoo, name, rng):
    """The kernel folds ``whi**S`` into the exponent (``TreeData.lwhi = log(whi)``); values
    equal a numpy traversal that multiplies ``count * whi**S`` in, for weighted primitives,
    with attenuation (S < 1), to 1e-12; ``lwhi`` is ``log(whi)`` also in a forest."""
    mesh = zoo[name]
    field = SmoothDistanceField(mesh)
    tree = field.tree
    np.testing.assert_array_equal(tree.lwhi, np.log(tree.whi))
    assert tree.whi.max() > 1.0                      # weighted: the fold matters
    from smoothdist.kernels import concatenate_trees
    forest, roots = concatenate_trees([tree, tree])
    np.testing.assert_array_equal(forest.lwhi, np.log(forest.whi))
    lo, hi = field.bounds
    Q = lo + (hi - lo) * rng.uniform(-0.5, 1.5, size=(12, 3))
    alpha, alpha_u, beta = 40.0 / field.diagonal, 200.0 / field.diagonal, 0.5
    S = alpha / alpha_u
    d, g = field.smooth_distance(Q, alpha=alpha, alpha_u=alpha_u, beta=beta)
    for k, q in enumerate(Q):
        ref = _barnes_hut_numpy(tree, naive.Terms(q[None], mesh), q, alpha, beta, S)
        assert d[k] == pytest.approx(ref, rel=1e-12, abs=1e-12 * field.diagonal)
