"""The exact-distance tree (``smoothdist._kernels.exact_query``): its build covers every primitive
with conservative boxes, and its seeded branch and bound equals numpy brute force and the plain
kernel on the smooth-distance tree (``smoothdist._kernels.query.exact_distance_batch``), on real
meshes, fuzzed mixed meshes, ties and queries on the geometry."""

from pathlib import Path

import numba
import numpy as np
import pytest

import naive
from smoothdist import DataMesh, SmoothDistanceField
from smoothdist import field as field_mod
from smoothdist._kernels import query
from smoothdist._kernels.exact_query import (GROUP, MAX_LEAF, build_exact_tree,
                                             exact_stack_size, exact_tree_batch,
                                             exact_tree_point, primitive_d2)

ROOT = Path(__file__).resolve().parents[3]
ZOO = ("point_cloud", "circle", "segment_star", "icosphere", "cube", "mixed_mesh",
       "nonmanifold_mesh")


#: no order: the queries in their own order (``smoothdist.field``'s ``_NO_ORDER``)
NO_ORDER = np.empty(0, dtype=np.int64)


def run_tree(et, Q, seeded=True):
    n = Q.shape[0]
    d, g = np.empty(n), np.empty((n, 3))
    p, no, le = (np.empty(n, dtype=np.int64) for _ in range(3))
    # every argument given, as SmoothDistanceField.exact_distance gives them: the kernel the
    # warm-up compiled (an omitted default is a specialisation of its own, compiled again)
    exact_tree_batch(et, np.ascontiguousarray(Q, dtype=np.float64), seeded, d, g, p, no, le, 1,
                     True, NO_ORDER, GROUP)
    return d, g, p, no, le


def run_plain(field, Q):
    n = Q.shape[0]
    d, g = np.empty(n), np.empty((n, 3))
    p, no, le = (np.empty(n, dtype=np.int64) for _ in range(3))
    query.exact_distance_batch(field.tree, np.ascontiguousarray(Q, dtype=np.float64), d, g, p,
                               no, le, 1)
    return d, g, p, no, le


def leaves_of(et):
    """``[(start, count)]`` of every leaf, walking the child table."""
    out = []
    todo = [et.root]
    while todo:
        c = todo.pop()
        if c < 0:
            code = -1 - c
            out.append((code >> 4, code & 15))
        else:
            todo += [int(et.child[c, 0]), int(et.child[c, 1])]
    return out


def prim_boxes(et):
    k = et.pts.shape[1] // 3
    P = et.pts.reshape(-1, k, 3)
    nv = et.kind.astype(np.int64) + 1
    lo = np.where((np.arange(k)[None, :] < nv[:, None])[..., None], P, np.inf).min(axis=1)
    hi = np.where((np.arange(k)[None, :] < nv[:, None])[..., None], P, -np.inf).max(axis=1)
    return lo, hi


def check_tree(field, leaf_size=4):
    et = build_exact_tree(field.tree, leaf_size=leaf_size)
    m = field.num_primitives
    # every primitive in exactly one leaf, leaves of 1..leaf_size primitives
    leaves = leaves_of(et)
    assert sorted(s for s, _ in leaves) == sorted(set(s for s, _ in leaves))
    assert all(1 <= c <= leaf_size for _, c in leaves)
    cover = np.zeros(m, dtype=int)
    for s, c in leaves:
        cover[s:s + c] += 1
    assert np.all(cover == 1)
    # the reordered table is a permutation of the mesh's primitives, same coordinates
    assert sorted(et.orig) == list(range(m))
    byorig = np.argsort(field.tree.orig)
    ref = field.tree.pts[byorig[et.orig]][:, :et.pts.shape[1]]
    np.testing.assert_array_equal(et.pts, ref)
    np.testing.assert_array_equal(et.kind, field.tree.kind[byorig[et.orig]])
    # every child box contains every vertex below it; left child numbered right after parent
    plo, phi = prim_boxes(et)

    def below(c):
        if c < 0:
            code = -1 - c
            return np.arange(code >> 4, (code >> 4) + (code & 15))
        return np.concatenate([below(int(et.child[c, 0])), below(int(et.child[c, 1]))])

    np.testing.assert_array_equal(et.root_box[:3], plo.min(axis=0))
    np.testing.assert_array_equal(et.root_box[3:], phi.max(axis=0))
    depth = 0
    for k in range(et.box.shape[0]):
        for j in range(2):
            idx = below(int(et.child[k, j]))
            b = et.box[k, 6 * j:6 * j + 6]
            np.testing.assert_array_equal(b[:3], plo[idx].min(axis=0))
            np.testing.assert_array_equal(b[3:], phi[idx].max(axis=0))
        if et.child[k, 0] >= 0:
            assert et.child[k, 0] == k + 1
    # depth: inner nodes on the longest path
    todo = [(et.root, 0)]
    while todo:
        c, dd = todo.pop()
        if c >= 0:
            todo += [(int(et.child[c, 0]), dd + 1), (int(et.child[c, 1]), dd + 1)]
        depth = max(depth, dd)
    assert depth == et.depth
    return et


def check_exact(field, et, Q, off=None, seeded=True):
    """The tree's answer against brute force (distance, closest primitive, gradient) and
    against the plain kernel."""
    mesh = field.mesh
    d, g, idx, nodes, leaves = run_tree(et, Q, seeded)
    terms = naive.Terms(Q, mesh)
    dr, gr, _ = terms.exact()
    diag = mesh.diagonal
    np.testing.assert_allclose(d, dr, rtol=1e-12, atol=1e-13 * diag)
    if off is not None:
        assert np.all(d[~off] <= 1e-12 * diag)
    assert np.all((idx >= 0) & (idx < mesh.num_primitives))
    own = terms.D[np.arange(Q.shape[0]), idx]
    np.testing.assert_allclose(own, d, rtol=1e-12, atol=1e-13 * diag)
    far = d > 1e-9 * diag
    np.testing.assert_allclose(np.linalg.norm(g[far], axis=1), 1.0, atol=1e-12)
    # (q - c) / d with c the reported primitive's closest point (at a tie between different
    # closest points, e.g. a cube's diagonal planes, the gradient is the reported one's)
    C = terms.C[np.arange(Q.shape[0]), idx]
    np.testing.assert_allclose(g[far], (Q[far] - C[far]) / d[far, None], atol=1e-9)
    unique = (terms.D <= dr[:, None] * (1 + 1e-9) + 1e-12 * diag).sum(axis=1) == 1
    np.testing.assert_allclose(g[far & unique], gr[far & unique], atol=1e-9)
    assert np.all(g[d == 0.0] == 0.0)
    assert np.all((leaves >= 1) & (leaves <= mesh.num_primitives + 1))
    assert np.all(nodes <= 2 * et.box.shape[0] + 1)
    # the plain kernel: same distances; where both pick the same primitive, the same bits
    d0, g0, idx0, _, _ = run_plain(field, Q)
    np.testing.assert_allclose(d, d0, rtol=1e-12, atol=1e-13 * diag)
    same = idx == idx0
    np.testing.assert_array_equal(d[same], d0[same])
    np.testing.assert_array_equal(g[same], g0[same])
    return d, idx


def queries(mesh, rng, near=300, on=60, far=40):
    Q = np.concatenate([naive.near_queries(mesh, near, rng),
                        naive.sample_on_primitives(mesh, on, rng),
                        naive.far_queries(mesh, far, rng, 2.0, 1e6)])
    off = np.ones(Q.shape[0], dtype=bool)
    off[near:near + on] = False
    return Q, off


def coherent(mesh, n=12):
    """An ``n^3`` grid over the mesh's box grown by a quarter diagonal, row after row (the
    order in which seeding pays)."""
    lo, hi = mesh.bounds
    pad = 0.25 * mesh.diagonal
    c = [np.linspace(lo[a] - pad, hi[a] + pad, n) for a in range(3)]
    X, Y, Z = np.meshgrid(*c, indexing="ij")
    return np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=1)


@pytest.mark.parametrize("name", ZOO)
def test_tree_and_queries_on_procedural_meshes(zoo, name, rng):
    field = SmoothDistanceField(zoo[name])
    et = check_tree(field)
    Q, off = queries(field.mesh, rng)
    for seeded in (True, False):
        check_exact(field, et, Q, off, seeded)
    check_exact(field, et, coherent(field.mesh))


@pytest.mark.parametrize("leaf_size", [1, 2, 8, MAX_LEAF])
def test_leaf_sizes(octopus, leaf_size, rng):
    field = SmoothDistanceField(octopus)
    et = check_tree(field, leaf_size)
    Q, off = queries(octopus, rng, near=200, on=40, far=20)
    check_exact(field, et, Q, off)


@pytest.mark.parametrize("name", ["octopus", "trefoil"])
@pytest.mark.slow
def test_real_local_meshes(request, name, rng):
    mesh = request.getfixturevalue(name)
    field = SmoothDistanceField(mesh)
    et = check_tree(field)
    Q, off = queries(mesh, rng, near=300, on=60, far=30)
    check_exact(field, et, Q, off)
    check_exact(field, et, coherent(mesh, 10))


@pytest.mark.parametrize("path", ["scenes/data/bunny.off",
                                  "scenes/data/curves/capillary_networks.obj"])
@pytest.mark.slow
def test_repository_meshes(path, rng):
    """The paper's bunny (6,966 triangles) and a curve network from ``scenes/data``."""
    mesh = DataMesh.load(ROOT / path)
    field = SmoothDistanceField(mesh)
    et = field.exact_tree
    Q, off = queries(mesh, rng, near=120, on=30, far=10)
    check_exact(field, et, Q, off)
    check_exact(field, et, coherent(mesh, 6))


def random_mixed(rng, npts, nedges, ntris, spread=1.0):
    """A random soup of points, edges and triangles over one vertex array (slivers, shared
    and duplicated vertices included)."""
    nv = 3 * (npts + nedges + ntris) // 2 + 3
    V = rng.normal(size=(nv, 3)) * spread
    # some vertices on a coarse lattice, so that coordinates and distances repeat exactly
    lat = rng.random(nv) < 0.3
    V[lat] = np.round(V[lat] * 2) / 2
    P = rng.choice(nv, size=npts, replace=False) if npts else None
    E = T = None
    if nedges:
        E = np.array([rng.choice(nv, 2, replace=False) for _ in range(nedges)])
    if ntris:
        T = np.array([rng.choice(nv, 3, replace=False) for _ in range(ntris)])
    return DataMesh(V, points=P, edges=E, triangles=T, name="fuzz")


@pytest.mark.filterwarnings("ignore::smoothdist.MeshRepairWarning")   # merged duplicates
@pytest.mark.parametrize("seed", range(8))
def test_fuzzed_mixed_meshes(seed):
    rng = np.random.default_rng(1000 + seed)
    npts, nedges, ntris = [(0, 0, 1), (1, 0, 0), (0, 1, 0), (30, 0, 0), (0, 40, 0),
                           (0, 0, 60), (20, 20, 20), (5, 50, 120)][seed]
    mesh = random_mixed(rng, npts, nedges, ntris)
    field = SmoothDistanceField(mesh)
    et = check_tree(field, leaf_size=int(rng.integers(1, 6)))
    Q, off = queries(mesh, rng, near=150, on=40, far=20)
    # queries at the vertices themselves
    Q = np.concatenate([Q, mesh.V[np.unique(np.concatenate(
        [mesh.points, mesh.edges.ravel(), mesh.triangles.ravel()]).astype(np.int64))]])
    off = np.concatenate([off, np.zeros(Q.shape[0] - off.size, dtype=bool)])
    check_exact(field, et, Q, off)
    check_exact(field, et, Q[rng.permutation(Q.shape[0])], None, True)


def test_ties_between_equidistant_primitives():
    """Lattice points queried at cell centres (8 points at one distance) and a triangulated
    grid queried above its vertices and edge midpoints (several triangles at one distance):
    the distance is the common one and the reported primitive is one of the tied ones."""
    c = np.arange(4.0)
    X, Y, Z = np.meshgrid(c, c, c, indexing="ij")
    lattice = DataMesh(np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=1), name="lattice")
    centres = np.stack(np.meshgrid(c[:-1] + 0.5, c[:-1] + 0.5, c[:-1] + 0.5,
                                   indexing="ij"), axis=-1).reshape(-1, 3)
    field = SmoothDistanceField(lattice)
    d, idx = check_exact(field, field.exact_tree, centres)
    np.testing.assert_allclose(d, np.sqrt(0.75), rtol=1e-15)
    own = naive.distances_to_primitives(centres, lattice)
    assert np.all((own <= d[:, None] * (1 + 1e-15)).sum(axis=1) == 8)

    n = 6
    g = np.arange(n + 1.0)
    GX, GY = np.meshgrid(g, g, indexing="ij")
    V = np.stack([GX.ravel(), GY.ravel(), np.zeros(GX.size)], axis=1)
    vid = np.arange(GX.size).reshape(n + 1, n + 1)
    T = []
    for i in range(n):
        for j in range(n):
            a, b, cc, dd = vid[i, j], vid[i + 1, j], vid[i + 1, j + 1], vid[i, j + 1]
            T += [(a, b, cc), (a, cc, dd)]
    sheet = DataMesh(V, np.array(T), name="sheet")
    field = SmoothDistanceField(sheet)
    mids = 0.5 * (V[np.array(T)[:, 0]] + V[np.array(T)[:, 1]])
    Q = np.concatenate([V + [0, 0, 0.5], mids + [0, 0, 0.25], V, mids,
                        V + [-0.3, 0.2, 0.1]])
    d, idx = check_exact(field, field.exact_tree, Q)
    nv, nm = V.shape[0], mids.shape[0]
    np.testing.assert_allclose(d[:nv], 0.5, rtol=1e-15)
    np.testing.assert_allclose(d[nv:nv + nm], 0.25, rtol=1e-15)
    assert np.all(d[nv + nm:2 * nv + 2 * nm] == 0.0)
    # most of these queries are tied between several triangles
    own = naive.distances_to_primitives(Q[:nv + nm], sheet)
    assert np.mean((own <= d[:nv + nm, None] * (1 + 1e-15)).sum(axis=1) >= 2) > 0.8


def test_single_primitive_and_tiny_tables():
    for mesh in (DataMesh(np.array([[1.0, 2.0, 3.0]])),
                 DataMesh(np.array([[0.0, 0, 0], [1, 0, 0]]), np.array([[0, 1]])),
                 DataMesh(np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]), np.array([[0, 1, 2]])),
                 DataMesh(np.random.default_rng(3).random((4, 3)))):
        field = SmoothDistanceField(mesh)
        et = check_tree(field)
        assert et.root < 0 and et.box.shape[0] == 0          # one leaf, no inner node
        Q = np.random.default_rng(4).normal(size=(50, 3)) * 3
        check_exact(field, et, Q)


def test_seeding_does_not_change_distances(octopus, rng):
    field = SmoothDistanceField(octopus)
    Q = coherent(octopus, 14)
    a = run_tree(field.exact_tree, Q, True)
    b = run_tree(field.exact_tree, Q, False)
    np.testing.assert_allclose(a[0], b[0], rtol=1e-12, atol=1e-13 * octopus.diagonal)
    same = a[2] == b[2]
    np.testing.assert_array_equal(a[0][same], b[0][same])
    np.testing.assert_array_equal(a[1][same], b[1][same])
    # on a coherent grid the seed prunes: fewer nodes in total
    assert a[3].sum() < b[3].sum()


def test_field_switches_to_the_tree(octopus, rng, monkeypatch):
    """exact_distance answers from the smooth-distance tree until its calls have asked for
    EXACT_TREE_AFTER queries per primitive, then builds the exact tree; both agree."""
    field = SmoothDistanceField(octopus)
    m = field.num_primitives
    Q = naive.near_queries(octopus, m // 2, rng)
    r1 = field.exact_distance(Q, return_closest=True)
    assert "_exact_tree" not in field.__dict__
    r2 = field.exact_distance(Q, return_closest=True)
    assert "_exact_tree" in field.__dict__
    np.testing.assert_allclose(r1.distance, r2.distance, rtol=1e-12,
                               atol=1e-13 * octopus.diagonal)
    same = r1.closest == r2.closest
    np.testing.assert_array_equal(r1.gradient[same], r2.gradient[same])
    ref = naive.exact_distance(Q, octopus)[0]
    np.testing.assert_allclose(r2.distance, ref, rtol=1e-12, atol=1e-13 * octopus.diagonal)
    # the module constant is what decides
    monkeypatch.setattr(field_mod, "EXACT_TREE_AFTER", 0.0)
    fresh = SmoothDistanceField(octopus)
    fresh.exact_distance(Q[:1])
    assert "_exact_tree" in fresh.__dict__


@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs >= 2 numba threads")
def test_parallel_equals_serial(octopus, rng):
    field = SmoothDistanceField(octopus)
    Q = np.concatenate([coherent(octopus, 12), naive.near_queries(octopus, 3000, rng)])
    before = numba.get_num_threads()
    out = {}
    try:
        for n in (1, 2):
            numba.set_num_threads(n)
            out[n] = run_tree(field.exact_tree, Q)
    finally:
        numba.set_num_threads(before)
    for x, y in zip(out[1], out[2]):
        np.testing.assert_array_equal(x, y)


def test_bad_leaf_size(octopus):
    field = SmoothDistanceField(octopus)
    for bad in (0, MAX_LEAF + 1):
        with pytest.raises(ValueError, match="leaf_size"):
            build_exact_tree(field.tree, leaf_size=bad)


@pytest.mark.filterwarnings("ignore::smoothdist.MeshRepairWarning")   # merged duplicates
def test_squared_distance_routines_match_brute_force():
    """primitive_d2 (two dot products per triangle, from the Gram matrix) against numpy's
    closest points, for every primitive of a fuzzed soup and queries near, on and far away."""
    rng = np.random.default_rng(7)
    mesh = random_mixed(rng, 10, 30, 60)
    field = SmoothDistanceField(mesh)
    et = field.exact_tree
    Q = np.concatenate([naive.near_queries(mesh, 60, rng),
                        naive.sample_on_primitives(mesh, 20, rng),
                        naive.far_queries(mesh, 10, rng, 2.0, 1e4), mesh.V[:20]])
    D = naive.distances_to_primitives(Q, mesh)[:, et.orig]         # tree order
    got = np.array([[primitive_d2(et.kind, et.pts, et.gram, i, *q) for i in range(et.kind.size)]
                    for q in Q])
    # rounding: relative to the distance, plus a few ulps of the coordinates' magnitude
    scale = np.abs(Q).max(axis=1)[:, None] + np.abs(mesh.V).max()
    err = np.abs(np.sqrt(got) - D)
    assert np.all(err <= 1e-12 * D + 1e-13 * scale), err.max()


def test_depth_stays_bounded_on_uneven_data(rng):
    """Points at x = 2^-k make every binned split cut off one point: past SAH_DEPTH the build
    splits at the median, so the depth stays small and the queries exact."""
    from smoothdist._kernels.exact_query import SAH_DEPTH
    k = np.arange(300)
    V = np.stack([2.0 ** -k, 0.5 * 2.0 ** -k, np.zeros(k.size)], axis=1)
    V = np.concatenate([V, rng.random((30, 3))])
    mesh = DataMesh(V, name="geometric")
    field = SmoothDistanceField(mesh)
    et = check_tree(field)
    assert SAH_DEPTH < et.depth <= SAH_DEPTH + 10
    Q = np.concatenate([naive.near_queries(mesh, 200, rng), V[:40] * 1.001])
    check_exact(field, et, Q)


@numba.njit
def _one_at_a_time(et, Q, k):
    """Every row of ``Q``'s distance by the single-query kernel, unseeded, with stacks of
    length ``k``."""
    n = Q.shape[0]
    d = np.empty(n)
    stack = np.empty(k, dtype=np.int64)
    dstack = np.empty(k)
    for i in range(n):
        r = exact_tree_point(et, Q[i, 0], Q[i, 1], Q[i, 2], stack, dstack, -1)
        d[i] = r[0]
    return d


@pytest.mark.parametrize("name", ["octopus", "mixed_mesh", "point_cloud", "segment_star"])
def test_groups_equal_one_query_at_a_time(request, name, rng):
    """The batch traces GROUP rows together; every row gets the distance the single-query
    kernel finds, for every length of a short last group, seeded or not, counting or not."""
    mesh = request.getfixturevalue(name) if name == "octopus" else \
        request.getfixturevalue("zoo")[name]
    field = SmoothDistanceField(mesh)
    et = field.exact_tree
    Q = np.concatenate([coherent(mesh, 9), naive.near_queries(mesh, 301, rng)])
    ref_d = _one_at_a_time(et, Q, exact_stack_size(et))
    atol = 1e-13 * mesh.diagonal
    for n in (1, 2, 3, 5, 7, Q.shape[0]):            # short last groups of every length
        for seeded in (True, False):
            d, g, p, no, le = run_tree(et, Q[:n], seeded)
            np.testing.assert_allclose(d, ref_d[:n], rtol=1e-12, atol=atol)
    # counting the nodes and leaves changes no result
    a = run_tree(et, Q)
    n = Q.shape[0]
    d, g = np.empty(n), np.empty((n, 3))
    p, no, le = (np.empty(n, dtype=np.int64) for _ in range(3))
    exact_tree_batch(et, Q, True, d, g, p, no, le, 1, False, NO_ORDER, GROUP)
    np.testing.assert_array_equal(d, a[0])
    np.testing.assert_array_equal(g, a[1])
    np.testing.assert_array_equal(p, a[2])
    assert a[3].min() >= 1 and a[4].min() >= 1
