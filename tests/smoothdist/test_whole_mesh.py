"""Mesh-to-mesh smooth distance (Eq. 6-8): brute force, bounds, Barnes-Hut, gradients, bad input."""

import numpy as np
import pytest
from conftest import make_circle, make_cube, make_icosphere, make_mixed, make_nonmanifold

import naive_pairs
import smoothdist
from smoothdist import DataMesh, MeshDistance, combine_distances, mesh_distance
from smoothdist.whole_mesh import as_query_mesh


def _rotation(rng):
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def data_meshes():
    rng = np.random.default_rng(7)
    return {
        "points": DataMesh(rng.random((40, 3)) * 2 - 1, name="points"),
        "edges": make_circle(n=24),
        "triangles": make_icosphere(subdivisions=1),
        "mixed": make_mixed(),
        "nonmanifold": make_nonmanifold(),
    }


def query_meshes():
    rng = np.random.default_rng(11)
    oct_V = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1.]]) * 0.4
    oct_F = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5],
                      [3, 1, 5], [0, 3, 5]])
    t = np.linspace(0, 2 * np.pi, 9)[:-1]
    poly_V = np.stack([0.5 * np.cos(t), 0.3 * np.sin(2 * t), 0.2 * t], axis=1)
    poly_F = np.stack([np.arange(7), np.arange(1, 8)], axis=1)
    return {
        "points": (rng.random((7, 3)) * 0.6, None),
        "edges": (poly_V, poly_F),
        "triangles": (oct_V, oct_F),
    }


DATA = data_meshes()
QUERY = query_meshes()
#: apart, and overlapping (some primitive pairs intersect)
PLACEMENTS = [np.array([1.6, 0.2, -0.3]), np.array([0.3, 0.9, 0.1])]


def near_placement(md, R, direction, gap=0.05):
    """The translation along ``direction`` nearest the data with an exact gap of at least ``gap``.

    In penetration (pairs at distance 0) the data-side closest point of a pair is not unique, so
    the weights, hence ``d_hat``, are only piecewise smooth there: value and gradient tests use
    positive gaps, bound tests use both.
    """
    u = np.asarray(direction, dtype=float) / np.linalg.norm(direction)
    for s in np.linspace(4.0, 0.0, 161):
        if md.exact(R, s * u)[0] < gap:
            return (s + 0.025) * u
    return 0.0 * u


@pytest.mark.parametrize("dname", list(DATA))
@pytest.mark.parametrize("qname", list(QUERY))
@pytest.mark.slow
def test_brute_force_beta0(dname, qname):
    """beta = 0 BVH result == numpy face-pair brute force, to 1e-9 relative."""
    data = DATA[dname]
    Vq, Fq = QUERY[qname]
    rng = np.random.default_rng(3)
    R = _rotation(rng)
    probe = MeshDistance(data, (Vq, Fq), alpha=1.0, alpha_q=1.0)
    for t in (PLACEMENTS[0], near_placement(probe, R, [0.3, 0.9, 0.1])):
        for alpha, alpha_q, alpha_u in ((10.0, 8.0, None), (40.0, 25.0, 20.0)):
            md = MeshDistance(probe.field, (Vq, Fq), alpha=alpha, alpha_q=alpha_q, beta=0.0,
                              alpha_u=alpha_u)
            d, G = md(R, t)
            X = Vq @ R.T + t
            ref, dj_ref, D = naive_pairs.smooth_mesh_distance(X, Fq, data, alpha, alpha_q,
                                                              alpha_u)
            dj, _ = md.primitive_distances(R, t)
            np.testing.assert_allclose(dj, dj_ref, rtol=1e-9, atol=1e-12)
            assert d == pytest.approx(ref, rel=1e-9, abs=1e-12)
            db, _ = md(R, t, method="brute")
            assert db == pytest.approx(ref, rel=1e-9, abs=1e-12)
            # exact mode: the minimum pairwise distance
            de, Ge = md.exact(R, t)
            assert de == pytest.approx(D.min(), rel=1e-9, abs=1e-12)
            assert G.shape == (len(Vq), 3) and Ge.shape == (len(Vq), 3)


@pytest.mark.parametrize("dname", list(DATA))
@pytest.mark.parametrize("qname", list(QUERY))
def test_exact_distance_in_penetration(dname, qname):
    """Overlapping placements (intersections): exact mode == brute force minimum, incl. 0."""
    data = DATA[dname]
    Vq, Fq = QUERY[qname]
    R = _rotation(np.random.default_rng(3))
    md = MeshDistance(data, (Vq, Fq), alpha=10.0, alpha_q=10.0, beta=0.0)
    for t in PLACEMENTS:
        X = Vq @ R.T + t
        _, dj_ref, D = naive_pairs.smooth_mesh_distance(X, Fq, data, 10.0, 10.0)
        de, _ = md.exact(R, t)
        assert de == pytest.approx(D.min(), rel=1e-9, abs=1e-12)
        dj, _ = md.primitive_distances(R, t)
        assert np.all(dj <= D.min(axis=1) + 1e-12)


@pytest.mark.parametrize("dname", list(DATA))
@pytest.mark.parametrize("qname", list(QUERY))
def test_bounds_with_and_without_barnes_hut(dname, qname):
    """d_hat_beta <= d_hat_0 <= exact minimum pairwise distance, per primitive and for the mesh."""
    data = DATA[dname]
    Vq, Fq = QUERY[qname]
    rng = np.random.default_rng(5)
    for trial in range(6):
        R = _rotation(rng)
        t = rng.normal(size=3) * (0.5 + 2.0 * trial)
        md0 = MeshDistance(data, (Vq, Fq), alpha=30.0, alpha_q=20.0, beta=0.0)
        d0, _ = md0(R, t)
        dj0, _ = md0.primitive_distances(R, t)
        de, _ = md0.exact(R, t)
        assert d0 <= de + 1e-12
        for beta in (0.5, 2.0, 10.0):
            mdb = MeshDistance(md0.field, (Vq, Fq), alpha=30.0, alpha_q=20.0, beta=beta)
            db, _ = mdb(R, t)
            djb, _ = mdb.primitive_distances(R, t)
            assert np.all(djb <= dj0 + 1e-12 * (1 + np.abs(dj0)))
            assert db <= d0 + 1e-12 * (1 + abs(d0))


def test_barnes_hut_is_used_far_away():
    """Far from the data, Barnes-Hut evaluates far fewer leaves than the tree holds."""
    data = make_icosphere(subdivisions=3)
    Vq, Fq = QUERY["triangles"]
    md = MeshDistance(data, (Vq, Fq), alpha=5.0, alpha_q=5.0, beta=0.5)
    d, _ = md(t=[6.0, 0.0, 0.0])
    nodes, leaves = md.last_stats
    assert leaves.max() < data.num_primitives / 4
    md0 = MeshDistance(md.field, (Vq, Fq), alpha=5.0, alpha_q=5.0, beta=0.0)
    d0, _ = md0(t=[6.0, 0, 0])
    dj0, _ = md0.primitive_distances(t=[6.0, 0, 0])
    dj, _ = md.primitive_distances(t=[6.0, 0, 0])
    de, _ = md0.exact(t=[6.0, 0, 0])
    # far field at most a factor 1 + beta closer than what it replaces (field.py's bound)
    floor = de / 1.5 - np.log(md.field.weight_bound * data.num_primitives) / 5.0
    assert d <= d0 and np.all(dj <= dj0) and dj.min() >= floor


@pytest.mark.parametrize("dname", list(DATA))
@pytest.mark.parametrize("qname", ["edges", "triangles"])
def test_tolerance_pruning_stays_conservative(dname, qname):
    """tol > 0 only lowers d_hat, by at most -log(1 - k tol) / alpha per primitive."""
    data = DATA[dname]
    Vq, Fq = QUERY[qname]
    rng = np.random.default_rng(4)
    for trial in range(4):
        R = _rotation(rng)
        t = rng.normal(size=3) * (0.5 + trial)
        md = MeshDistance(data, (Vq, Fq), alpha=40.0, alpha_q=20.0, beta=0.5)
        dj, _ = md.primitive_distances(R, t)
        for tol in (1e-9, 1e-3):
            mt = MeshDistance(md.field, (Vq, Fq), alpha=40.0, alpha_q=20.0, beta=0.5, tol=tol)
            djt, _ = mt.primitive_distances(R, t)
            k = mt.last_stats[1]
            assert np.all(djt <= dj + 1e-12)
            small = k * tol < 0.5
            assert np.all((dj - djt <= -np.log1p(-k * tol) / 40.0 + 1e-12)[small])


@pytest.mark.parametrize("dname", ["points", "edges", "triangles", "mixed"])
@pytest.mark.parametrize("qname", list(QUERY))
def test_gradient_matches_finite_differences(dname, qname):
    """Exact-derivative option: summed vertex gradients == central FD of a rigid translation."""
    data = DATA[dname]
    Vq, Fq = QUERY[qname]
    rng = np.random.default_rng(9)
    R = _rotation(rng)
    md = MeshDistance(data, (Vq, Fq), alpha=12.0, alpha_q=9.0, beta=0.0, gradient="exact")
    t0 = near_placement(md, R, [0.9, 0.5, -0.2], gap=0.08)
    d, G = md(R, t0)
    g = G.sum(axis=0)
    h = 1e-6
    fd = np.array([(md(R, t0 + h * e)[0] - md(R, t0 - h * e)[0]) / (2 * h) for e in np.eye(3)])
    np.testing.assert_allclose(g, fd, atol=2e-5 * max(1.0, np.abs(fd).max()))
    # per query primitive: the translation gradient of that primitive alone
    dj, gj = md.primitive_distances(R, t0)
    qm = as_query_mesh((Vq @ R.T + t0, Fq))
    for j in range(0, qm.kind.size, 3):
        k = qm.kind[j]
        # primitive j alone, as a one-primitive query mesh over its own vertices
        Vj = qm.V[qm.index[j, :k + 1]]
        Fj = None if k == 0 else np.arange(k + 1)[None]
        single = MeshDistance(md.field, (Vj, Fj), alpha=12.0, alpha_q=9.0, beta=0.0,
                              gradient="exact")
        fdj = np.array([(single.primitive_distances(t=h * e)[0][0]
                         - single.primitive_distances(t=-h * e)[0][0]) / (2 * h)
                        for e in np.eye(3)])
        np.testing.assert_allclose(gj[j], fdj, atol=2e-5 * max(1.0, np.abs(fdj).max()))


def test_gradient_split_equally():
    """Eq. 8: each primitive's gradient is divided equally among its vertices."""
    data = DATA["triangles"]
    V = np.array([[0, 0, 2.0], [1, 0, 2.0], [0, 1, 2.0]])
    md = MeshDistance(data, (V, [[0, 1, 2]]), alpha=20.0, alpha_q=20.0, beta=0.0)
    d, G = md()
    dj, gj = md.primitive_distances()
    np.testing.assert_allclose(G, np.repeat(gj / 3, 3, axis=0), rtol=1e-12)
    assert d == pytest.approx(dj[0], rel=1e-12)


def test_unreferenced_query_vertices_get_zero_gradient():
    V = np.array([[0, 0, 3.0], [1, 0, 3.0], [5, 5, 5.0]])
    d, G = mesh_distance(np.zeros((1, 3)), None, V, [[0, 1]], alpha=10.0, alpha_q=10.0)
    assert np.all(G[2] == 0) and np.all(G[:2, 2] > 0)


def test_exact_mode_gradient():
    data = DATA["triangles"]
    V = np.array([[0, 0, 3.0], [1, 0, 3.0], [0, 1, 3.0], [4, 4, 4.0]])
    md = MeshDistance(data, (V, [[0, 1, 2], [1, 2, 3]]), alpha=10.0, alpha_q=10.0)
    d, G = md.exact()
    h = 1e-6
    fd = np.array([(md.exact(t=h * e)[0] - md.exact(t=-h * e)[0]) / (2 * h) for e in np.eye(3)])
    np.testing.assert_allclose(G.sum(axis=0), fd, atol=1e-6)
    nz = np.flatnonzero(np.abs(G).sum(axis=1))
    assert set(nz) <= {0, 1, 2} and len(nz) == 3


def test_rigid_transform_equals_moved_query():
    """md(R, t) equals a fresh evaluation on the moved vertices; no rebuild of the data tree."""
    data = DATA["mixed"]
    Vq, Fq = QUERY["triangles"]
    rng = np.random.default_rng(1)
    md = MeshDistance(data, (Vq, Fq), alpha=15.0, alpha_q=10.0)
    tree = md.tree
    for _ in range(3):
        R = _rotation(rng)
        t = rng.normal(size=3)
        d, G = md(R, t)
        d2, G2 = MeshDistance(md.field, (Vq @ R.T + t, Fq), alpha=15.0, alpha_q=10.0)()
        assert d == pytest.approx(d2, rel=1e-12)
        np.testing.assert_allclose(G, G2, rtol=1e-10, atol=1e-14)
    assert md.tree is tree


@pytest.mark.parametrize("qname", list(QUERY))
@pytest.mark.slow
def test_parallel_and_serial_kernels_agree(qname, monkeypatch):
    """Small query meshes run on the calling thread; the prange kernels give the same bits."""
    import importlib

    mdmod = importlib.import_module("smoothdist.whole_mesh")   # the module, not the function

    data = DATA["mixed"]
    Vq, Fq = QUERY[qname]
    R = _rotation(np.random.default_rng(8))
    t = np.array([0.4, 1.1, 0.2])
    out = {}
    for name, below in (("serial", {"smooth": 10**9, "exact": 10**9}),
                        ("parallel", {"smooth": 0, "exact": 0})):
        monkeypatch.setattr(mdmod, "SERIAL_BELOW", below)
        md = MeshDistance(data, (Vq, Fq), alpha=20.0, alpha_q=10.0, beta=0.5, tol=1e-9)
        out[name] = (md(R, t), md.exact(R, t), md.primitive_distances(R, t))
    (d1, G1), (e1, H1), (dj1, gj1) = out["serial"]
    (d2, G2), (e2, H2), (dj2, gj2) = out["parallel"]
    assert d1 == d2 and e1 == e2
    assert np.array_equal(G1, G2) and np.array_equal(H1, H2)
    assert np.array_equal(dj1, dj2) and np.array_equal(gj1, gj2)


def test_mesh_distance_function_matches_object():
    data = DATA["edges"]
    Vq, Fq = QUERY["edges"]
    d, G = mesh_distance(data.V, data.edges, Vq + [0.2, 0, 0.5], Fq, alpha=20.0, alpha_q=10.0)
    d2, G2 = MeshDistance((data.V, data.edges), (Vq + [0.2, 0, 0.5], Fq), alpha=20.0,
                          alpha_q=10.0)()
    assert d == d2 and np.array_equal(G, G2)


def test_mixed_query_mesh():
    """A mixed DataMesh as the query: its terms are the union of its kinds' terms."""
    data = DATA["triangles"]
    q = make_mixed()
    t = np.array([2.5, 0.0, 0.0])
    R = _rotation(np.random.default_rng(2))     # no parallel faces facing each other
    md = MeshDistance(data, q, alpha=10.0, alpha_q=6.0, beta=0.0)
    d, G = md(R, t)
    dj, _ = md.primitive_distances(R, t)
    parts = []
    for F in (None if q.points.size == 0 else q.points[:, None], q.edges, q.triangles):
        if F is not None and len(F):
            Vp = q.V @ R.T + t
            if F.shape[1] == 1:
                parts.append(naive_pairs.smooth_mesh_distance(Vp[F[:, 0]], None, data, 10.0, 6.0)[1])
            else:
                parts.append(naive_pairs.smooth_mesh_distance(Vp, F, data, 10.0, 6.0)[1])
    np.testing.assert_allclose(dj, np.concatenate(parts), rtol=1e-9)
    assert G.shape == (q.V.shape[0], 3)


@pytest.mark.parametrize("data_name", ["triangles", "mixed"])
def test_mixed_query_rows_equal_each_kind_alone(data_name):
    """A mixed query runs each kind through its own kernels (the point kernel for points, the
    primitive kernels for edges and triangles) and puts the rows back: every per-primitive
    output equals that of a query mesh of the one kind alone, and the paper's split and the
    per-vertex gradient equal the combination of the kinds' rows."""
    data = DATA[data_name]
    q = make_mixed()
    R = _rotation(np.random.default_rng(5))
    t = np.array([2.2, 0.3, -0.4])
    kw = dict(alpha=12.0, alpha_q=7.0, beta=0.5, tol=1e-4)
    md = MeshDistance(data, q, **kw)
    d, g = md.primitive_distances(R, t)
    stats = md.last_stats
    dm, gm, mo = md.primitive_moments(R, t)
    rows = {0: q.points[:, None], 1: q.edges, 2: q.triangles}
    start = 0
    for k, F in rows.items():
        alone = MeshDistance(data, DataMesh(q.V, **{("points", "edges", "triangles")[k]: F}),
                             **kw)
        sl = slice(start, start + len(F))
        start += len(F)
        dk, gk = alone.primitive_distances(R, t)
        assert np.array_equal(d[sl], dk) and np.array_equal(g[sl], gk)
        assert all(np.array_equal(a[sl], b) for a, b in zip(stats, alone.last_stats))
        dk, gk, mk = alone.primitive_moments(R, t)
        assert np.array_equal(dm[sl], dk) and np.array_equal(gm[sl], gk)
        assert np.array_equal(mo[sl], mk) and (k > 0 or not mk.any())
    assert start == md.num_query_primitives
    # the per-vertex gradient sums to the translation gradient of the paper's split
    dv, Gv = md.vertex_gradient(R, t)
    d0, G0 = md(R, t)
    assert dv == d0
    np.testing.assert_allclose(Gv.sum(axis=0), G0.sum(axis=0), rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("data_name, query_name, kernel", [
    ("triangles", "triangles", "triangle_distance_tasks"),
    ("edges", "edges", "segment_distance_tasks"),
    ("triangles", "edges", "segments_on_triangles_tasks"),
    ("edges", "triangles", "triangles_on_segments_tasks"),
    ("mixed", "triangles", "smooth_distance_primitive_tasks"),
    ("points", "triangles", "smooth_distance_primitive_tasks")])
def test_one_kind_kernels_equal_the_general_one(data_name, query_name, kernel):
    """Data and query of one kind take a kernel that compiles that pair kernel only; its
    values and stats are the general kernel's, bit for bit."""
    from smoothdist._kernels import mesh_query as mq
    md = MeshDistance(DATA[data_name], QUERY[query_name], alpha=15.0, alpha_q=9.0, beta=0.5)
    assert md._distance_kernel is getattr(mq, kernel)
    t = np.array([0.3, -0.2, 1.1])
    d, g = md.primitive_distances(t=t)
    stats = md.last_stats
    md._distance_kernel = mq.smooth_distance_primitive_tasks
    d0, g0 = md.primitive_distances(t=t)
    assert np.array_equal(d, d0) and np.array_equal(g, g0)
    assert all(np.array_equal(a, b) for a, b in zip(stats, md.last_stats))


@pytest.mark.parametrize("data_name, query_name, kernel", [
    ("triangles", "triangles", "exact_triangle_tasks"),
    ("edges", "edges", "exact_segment_tasks"),
    ("triangles", "edges", "exact_distance_primitive_tasks"),
    ("mixed", "triangles", "exact_distance_primitive_tasks")])
@pytest.mark.parametrize("t", PLACEMENTS)
def test_one_kind_exact_kernels_equal_the_general_one(data_name, query_name, kernel, t):
    """The exact distance of data and query of one kind takes kernels of that pair kernel only
    (serial and ``prange``); distance and gradient are the general kernels', bit for bit."""
    from smoothdist._kernels import mesh_query as mq
    md = MeshDistance(DATA[data_name], QUERY[query_name], alpha=15.0, alpha_q=9.0)
    assert md._exact_kernels[0] is getattr(mq, kernel)
    general = (mq.exact_distance_primitive_tasks, mq.exact_distance_primitives)
    for below in (10 ** 9, 0):     # the serial kernel, then the prange one
        with pytest.MonkeyPatch.context() as mp:
            mp.setitem(smoothdist.whole_mesh.SERIAL_BELOW, "exact", below)
            d, G = md.exact(t=t)
            own, md._exact_kernels = md._exact_kernels, general
            d0, G0 = md.exact(t=t)
            md._exact_kernels = own
        assert d == d0 and np.array_equal(G, G0)


def test_combine_distances():
    d, w = combine_distances([1.0, 2.0, 1.5], [10.0, 20.0, 5.0])
    ref = -np.log(np.exp(-20.0) + np.exp(-40.0) + np.exp(-30.0)) / 20.0
    assert d == pytest.approx(ref, rel=1e-12)
    assert w.sum() == pytest.approx(1.0) and w[0] > w[2] > w[1]
    d, w = combine_distances([1e4, 1e4 + 1], 50.0)        # finite far away
    assert np.isfinite(d) and d <= 1e4


@pytest.mark.parametrize("distances, alphas, match", [
    ([1.0, 2.0, 3.0], [1.0, 5.0], "one per distance"),
    ([1.0, 2.0], [1.0, 5.0, 2.0], "one per distance"),
    ([1.0 + 0j, 2.0], 5.0, "real"),
    ([1.0, 2.0], [5.0 + 1j], "real"),
])
def test_combine_distances_refuses_bad_input(distances, alphas, match):
    with pytest.raises(ValueError, match=match):
        combine_distances(distances, alphas)


def test_far_query_is_finite():
    md = MeshDistance(DATA["triangles"], QUERY["edges"], alpha=100.0, alpha_q=100.0)
    d, G = md(t=[1e5, 0, 0])
    assert np.isfinite(d) and np.all(np.isfinite(G))
    assert 1e5 - 2 < d <= 1e5


@pytest.mark.parametrize("kwargs, match", [
    (dict(alpha_q=0.0), "alpha_q"),
    (dict(alpha_q=-1.0), "alpha_q"),
    (dict(alpha_q=float("nan")), "alpha_q"),
    (dict(alpha=0.0), "alpha"),
    (dict(beta=-0.5), "beta"),
    (dict(gradient="nope"), "gradient"),
    (dict(tol=-1e-3), "tol"),
])
def test_bad_parameters(kwargs, match):
    args = dict(alpha=10.0, alpha_q=10.0)
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        MeshDistance(DATA["triangles"], QUERY["edges"], **args)


@pytest.mark.parametrize("query, match", [
    ((np.zeros((0, 3)), None), "no vertices"),
    ((np.array([[0, 0, np.nan], [1, 0, 0]]), [[0, 1]]), "NaN"),
    ((np.zeros((3, 2)), None), "shape"),
    ((np.eye(3), [[0, 5]]), "out of range"),
    ((np.eye(3), np.zeros((0, 2), dtype=int)), "no primitives"),
    ((np.eye(3), [[0, 1, 2, 0]]), "shape"),
    ((np.eye(3), [[0.5, 1]]), "integer"),
    ((np.eye(3) + 0j, [[0, 1]]), "real"),
    (np.zeros((2, 3), dtype=complex), "real"),
])
def test_bad_query_mesh(query, match):
    with pytest.raises(ValueError, match=match):
        MeshDistance(DATA["triangles"], query, alpha=10.0, alpha_q=10.0)


def test_bad_data_and_transform():
    with pytest.raises(ValueError):
        mesh_distance(np.zeros((0, 3)), None, np.eye(3), None, alpha=1.0, alpha_q=1.0)
    with pytest.raises(ValueError, match="NaN"):
        mesh_distance([[0, 0, np.nan]], None, np.eye(3), None, alpha=1.0, alpha_q=1.0)
    md = MeshDistance(DATA["points"], QUERY["points"], alpha=10.0, alpha_q=10.0)
    with pytest.raises(ValueError, match="rotation"):
        md(R=np.diag([1.0, 1.0, -1.0]))
    with pytest.raises(ValueError, match="shape"):
        md(R=np.eye(2))
    with pytest.raises(ValueError, match="shape"):
        md(t=[1.0, 2.0])
    with pytest.raises(ValueError, match="NaN"):
        md(t=[1.0, np.nan, 0.0])
    with pytest.raises(ValueError, match="real"):
        md(t=np.array([1.0, 0.0, 0.0], dtype=complex))
    with pytest.raises(ValueError, match="real"):
        md(R=np.eye(3, dtype=complex))
    with pytest.raises(ValueError, match="transformed query vertices"):
        md(t=[1e60, 0.0, 0.0])
    with pytest.raises(ValueError, match="transformed query vertices"):
        md.exact(t=[0.0, -1e300, 0.0])


def test_exported():
    assert smoothdist.MeshDistance is MeshDistance
    assert smoothdist.mesh_distance is mesh_distance


def test_trimesh_and_pyvista_query_meshes_match_arrays():
    """A trimesh or pyvista query mesh gives the arrays' value and per-vertex gradient."""
    trimesh = pytest.importorskip("trimesh")
    pv = pytest.importorskip("pyvista")
    ico = make_icosphere(1)
    V, T = ico.V, ico.triangles
    Vq = 0.4 * V + np.array([2.5, 0.1, -0.2])
    data = DataMesh(V, T)
    ref = MeshDistance(data, (Vq, T), alpha=20.0, alpha_q=20.0, beta=0.0)()
    tm = trimesh.Trimesh(Vq, T, process=False)
    faces = np.hstack([np.full((len(T), 1), 3), T]).ravel()
    pd = pv.PolyData(Vq, faces)
    for obj in (tm, pd):
        d, G = MeshDistance(data, obj, alpha=20.0, alpha_q=20.0, beta=0.0)()
        assert d == pytest.approx(ref[0], rel=1e-12)
        np.testing.assert_allclose(G, ref[1], rtol=1e-10, atol=1e-14)


def test_translation_at_gap_stops_before_thin_data():
    """Placing a query just off contact never jumps through thin data (a single triangle)."""
    V = np.array([[-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [0.0, 1.0, 0.0]])
    data = DataMesh(V, np.array([[0, 1, 2]]))
    q = (np.array([[0.0, 0.0, 0.0], [0.1, 0.0, 0.0]]), np.array([[0, 1]]))
    md = MeshDistance(data, q, alpha=50.0, alpha_q=50.0)
    t = md.translation_at_gap(1e-3, [0.0, 0.1, -1.0], start=[0.0, -0.2, 5.0])
    assert md.exact(t=t)[0] == pytest.approx(1e-3, rel=1e-9)
    assert t[2] > 0.0                       # still on the starting side of the triangle
    with pytest.raises(ValueError, match="starts closer"):
        md.translation_at_gap(10.0, [0.0, 0.0, -1.0], start=[0.0, 0.0, 5.0])
    with pytest.raises(ValueError, match="never comes within"):
        md.translation_at_gap(1e-3, [0.0, 0.0, 1.0], start=[0.0, 0.0, 5.0])
    with pytest.raises(ValueError, match="direction"):
        md.translation_at_gap(1e-3, [0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="gap"):
        md.translation_at_gap(-1.0, [0.0, 0.0, -1.0], start=[0.0, 0.0, 5.0])
