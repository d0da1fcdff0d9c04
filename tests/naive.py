"""Slow, readable, pure-numpy reference implementations for the smoothdist tests.

Nothing here uses the library's numba kernels (``smoothdist._kernels.query``,
``smoothdist._kernels.closest_point``, ``smoothdist._kernels.bvh``). The only things taken from
the library are the weight-polynomial *coefficients*, ``A`` and the clamp bounds ``whi``
(``DataMesh.weight_data()``; ``test_mesh.py`` checks those against an independent valence count
here, :func:`valences`); the polynomials themselves, their derivatives, the projection
Jacobians, the clamp into ``[1, whi]``, the attenuation power ``S`` and the LogSumExp are
evaluated here, in float64 numpy, brute force over every primitive.

Conventions follow the library: primitives are numbered points, then edges, then triangles;
an edge ``(a, b)`` is parametrised by ``t`` (``a + t (b - a)``); a triangle ``(a, b, c)`` by
barycentrics ``(s, t)`` of ``b`` and ``c`` (``a + s (b - a) + t (c - a)``).

Smooth distance (Madan & Levin 2022, Eq. 3):

    d_hat(q) = -(1/alpha) log sum_i W_i(q) exp(-alpha d_i(q)),
    W_i = clip(A w~_i(proj_i(q)), 1, whi_i) ** S,    S = min(alpha / alpha_u, 1)

computed with a max-shift (the smallest d_i). Its gradient is

    grad d_hat = sum_i e_i (W_i grad d_i - k grad W_i) / sum_i W_i e_i,  e_i = exp(-alpha (d_i - m))

with ``k = 1/alpha`` for the exact derivative and ``k = 1/alpha**2`` for the paper's metric.
"""

import numpy as np


# --------------------------------------------------------------------------- closest points


def closest_point_segment(P, A, B):
    """Closest points from every query to every segment.

    Parameters
    ----------
    P : (q, 3) queries;  A, B : (m, 3) segment end points.

    Returns
    -------
    C : (q, m, 3) closest points
    t : (q, m) parameters in [0, 1]
    dt : (q, m, 3) gradient of ``t`` with respect to the query (0 where clamped)
    """
    E = B - A                                      # (m, 3)
    L2 = np.einsum("mk,mk->m", E, E)               # (m,)
    AP = P[:, None, :] - A[None, :, :]             # (q, m, 3)
    raw = np.einsum("qmk,mk->qm", AP, E) / L2      # unconstrained parameter
    t = np.clip(raw, 0.0, 1.0)
    C = A[None] + t[..., None] * E[None]
    interior = (raw > 0.0) & (raw < 1.0)
    dt = np.where(interior[..., None], (E / L2[:, None])[None], 0.0)
    return C, t, dt


def closest_point_triangle(P, A, B, C):
    """Closest points from every query to every triangle, by the small QP.

    min_{s, t} |A + s (B - A) + t (C - A) - p|^2  subject to  s >= 0, t >= 0, s + t <= 1.

    The unconstrained minimiser is the projection onto the plane (2x2 normal equations); if it
    is feasible it is the answer, otherwise the minimum lies on the boundary, i.e. it is the
    best of the three edge segments.

    Returns
    -------
    X : (q, m, 3) closest points
    s, t : (q, m) barycentrics of B and C
    ds, dt : (q, m, 3) their gradients with respect to the query (the projection Jacobian:
        in-plane gradient in the interior, tangential along a clamped edge, 0 at a vertex)
    """
    AB = B - A
    AC = C - A
    g11 = np.einsum("mk,mk->m", AB, AB)
    g12 = np.einsum("mk,mk->m", AB, AC)
    g22 = np.einsum("mk,mk->m", AC, AC)
    det = g11 * g22 - g12 * g12
    # inverse Gram matrix
    i11, i12, i22 = g22 / det, -g12 / det, g11 / det
    AP = P[:, None, :] - A[None]
    r1 = np.einsum("qmk,mk->qm", AP, AB)
    r2 = np.einsum("qmk,mk->qm", AP, AC)
    s_in = i11 * r1 + i12 * r2
    t_in = i12 * r1 + i22 * r2
    grad_s_in = (i11[:, None] * AB + i12[:, None] * AC)[None]    # (1, m, 3)
    grad_t_in = (i12[:, None] * AB + i22[:, None] * AC)[None]
    inside = (s_in >= 0.0) & (t_in >= 0.0) & (s_in + t_in <= 1.0)

    # the three edges: (start, end, s(u), t(u))
    cands = []
    for (U, W, smap, tmap) in ((A, B, lambda u: u, lambda u: 0.0 * u),       # ab: s = u, t = 0
                               (A, C, lambda u: 0.0 * u, lambda u: u),       # ac: s = 0, t = u
                               (B, C, lambda u: 1.0 - u, lambda u: u)):      # bc: s = 1-u, t = u
        X, u, du = closest_point_segment(P, U, W)
        d2 = np.einsum("qmk,qmk->qm", P[:, None, :] - X, P[:, None, :] - X)
        cands.append((d2, X, u, du, smap, tmap))
    # pick the best edge (first wins ties)
    best = np.argmin(np.stack([c[0] for c in cands]), axis=0)          # (q, m)
    X = np.zeros(AP.shape)
    s = np.zeros(best.shape)
    t = np.zeros(best.shape)
    ds = np.zeros(AP.shape)
    dt = np.zeros(AP.shape)
    for j, (d2, Xj, u, du, smap, tmap) in enumerate(cands):
        sel = best == j
        X[sel] = Xj[sel]
        s[sel] = smap(u)[sel]
        t[sel] = tmap(u)[sel]
        # chain rule: d s / d q = (ds/du) du/dq
        dsdu = {0: 1.0, 1: 0.0, 2: -1.0}[j]
        dtdu = {0: 0.0, 1: 1.0, 2: 1.0}[j]
        ds[sel] = dsdu * du[sel]
        dt[sel] = dtdu * du[sel]
    # interior wins where feasible
    Xin = A[None] + s_in[..., None] * AB[None] + t_in[..., None] * AC[None]
    X = np.where(inside[..., None], Xin, X)
    s = np.where(inside, s_in, s)
    t = np.where(inside, t_in, t)
    ds = np.where(inside[..., None], np.broadcast_to(grad_s_in, ds.shape), ds)
    dt = np.where(inside[..., None], np.broadcast_to(grad_t_in, dt.shape), dt)
    return X, s, t, ds, dt


# --------------------------------------------------------------------------- weight polynomials

#: the 13 stored triangle coefficients multiply these sums of monomials s^a t^b
TRI_TERMS = (
    [(0, 0)],
    [(2, 0), (0, 2)],
    [(3, 0), (0, 3)],
    [(4, 0), (0, 4)],
    [(2, 2)],
    [(5, 0), (0, 5)],
    [(3, 2), (2, 3)],
    [(6, 0), (0, 6)],
    [(4, 2), (2, 4)],
    [(3, 3)],
    [(7, 0), (0, 7)],
    [(5, 2), (2, 5)],
    [(4, 3), (3, 4)],
)


def edge_poly(c, t):
    """Edge quartic ``w~(t)`` and ``dw~/dt``; ``c (..., 5)`` broadcast against ``t``."""
    c = np.asarray(c, dtype=np.float64)
    w = np.zeros(np.broadcast(c[..., 0], t).shape)
    dw = np.zeros_like(w)
    for k in range(5):
        w = w + c[..., k] * t ** k
        if k:
            dw = dw + k * c[..., k] * t ** (k - 1)
    return w, dw


def _pow(x, k):
    return np.ones_like(x) if k == 0 else x ** k


def triangle_poly(c, s, t):
    """Triangle polynomial ``w~(s, t)`` and its partials, from the 13 stored coefficients.

    ``c (..., 13)`` broadcast against ``s`` and ``t``. Evaluated monomial by monomial.
    """
    c = np.asarray(c, dtype=np.float64)
    shape = np.broadcast(c[..., 0], s, t).shape
    s = np.broadcast_to(s, shape)
    t = np.broadcast_to(t, shape)
    w = np.zeros(shape)
    ws = np.zeros(shape)
    wt = np.zeros(shape)
    for k, monos in enumerate(TRI_TERMS):
        ck = c[..., k]
        for a, b in monos:
            w = w + ck * _pow(s, a) * _pow(t, b)
            if a:
                ws = ws + ck * a * _pow(s, a - 1) * _pow(t, b)
            if b:
                wt = wt + ck * b * _pow(s, a) * _pow(t, b - 1)
    return w, ws, wt


def attenuate(raw, graw, whi, S):
    """Clamp the raw weight ``A w~`` into ``[1, whi]`` and raise it to ``S``.

    ``raw (...)``, ``graw (..., 3)`` its gradient, ``whi`` broadcastable upper clamp.
    Returns ``(W, grad W)``; the gradient is 0 where the clamp is active.
    """
    rc = np.clip(raw, 1.0, whi)
    W = rc ** S
    active = (raw > 1.0) & (raw < whi)
    gW = np.where(active[..., None], (S * rc ** (S - 1.0))[..., None] * graw, 0.0)
    return W, gW


# --------------------------------------------------------------------------- valences


def valences(mesh):
    """Independent weight inputs of a DataMesh (Madan & Levin 2022, Sec. 3.3).

    Returns ``(A, edge_valence (e, 2), tri_v (t,), tri_e (t,))``: ``A`` the largest vertex
    valence (edges counted in the edge set, triangles in the triangle set), the valences of
    each edge's two end points, and per triangle the largest vertex valence and the largest
    edge valence (number of triangles sharing an edge).
    """
    E, T = mesh.edges, mesh.triangles
    ev = {}
    for a, b in E:
        ev[int(a)] = ev.get(int(a), 0) + 1
        ev[int(b)] = ev.get(int(b), 0) + 1
    tv = {}
    te = {}
    for tri in T:
        for v in tri:
            tv[int(v)] = tv.get(int(v), 0) + 1
        for a, b in ((tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0])):
            key = (min(int(a), int(b)), max(int(a), int(b)))
            te[key] = te.get(key, 0) + 1
    A = max([1] + list(ev.values()) + list(tv.values()))
    edge_val = np.array([[ev[int(a)], ev[int(b)]] for a, b in E], dtype=np.int64).reshape(-1, 2)
    tri_v = np.array([max(tv[int(v)] for v in tri) for tri in T], dtype=np.int64)
    tri_e = np.array([max(te[(min(int(a), int(b)), max(int(a), int(b)))]
                          for a, b in ((tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0])))
                      for tri in T], dtype=np.int64)
    return A, edge_val, tri_v, tri_e


# --------------------------------------------------------------------------- per-primitive terms


class Terms:
    """Geometry of queries ``Q (q, 3)`` against every primitive of a DataMesh, computed once.

    Attributes (mesh numbering: points, edges, triangles):
    ``D (q, m)`` distances, ``gD (q, m, 3)`` their gradients (unit ``(q - c)/d``, 0 at d = 0),
    ``C (q, m, 3)`` closest points, ``raw (q, m)`` unclamped raw weights ``A w~`` (points: 1),
    ``graw (q, m, 3)`` their gradients through the projection, ``whi (m,)`` upper clamps.
    Evaluate the smooth distance for any ``alpha``/``alpha_u`` with :meth:`smooth`.
    """

    def __init__(self, Q, mesh):
        Q = np.atleast_2d(np.asarray(Q, dtype=np.float64))
        V = mesh.V
        A, ecoef, ewhi, tcoef, twhi = mesh.weight_data()
        q = Q.shape[0]
        Cs, raws, graws, whis = [], [], [], []
        if mesh.points.size:                                   # points: weight 1
            p = mesh.points.size
            Cs.append(np.broadcast_to(V[mesh.points][None], (q, p, 3)))
            raws.append(np.ones((q, p)))
            graws.append(np.zeros((q, p, 3)))
            whis.append(np.ones(p))
        if mesh.edges.shape[0]:
            E = mesh.edges
            Ce, t, dt = closest_point_segment(Q, V[E[:, 0]], V[E[:, 1]])
            w, dw = edge_poly(ecoef[None], t)
            Cs.append(Ce)
            raws.append(A * w)
            graws.append((A * dw)[..., None] * dt)
            whis.append(ewhi)
        if mesh.triangles.shape[0]:
            T = mesh.triangles
            Ct, s, t, ds, dt = closest_point_triangle(Q, V[T[:, 0]], V[T[:, 1]], V[T[:, 2]])
            w, ws, wt = triangle_poly(tcoef[None], s, t)
            Cs.append(Ct)
            raws.append(A * w)
            graws.append(A * (ws[..., None] * ds + wt[..., None] * dt))
            whis.append(twhi)
        self.C = np.concatenate(Cs, axis=1)
        R = Q[:, None, :] - self.C
        self.D = np.sqrt(np.einsum("qmk,qmk->qm", R, R))
        with np.errstate(invalid="ignore", divide="ignore"):
            self.gD = np.where(self.D[..., None] > 0, R / self.D[..., None], 0.0)
        self.raw = np.concatenate(raws, axis=1)
        self.graw = np.concatenate(graws, axis=1)
        self.whi = np.concatenate(whis)

    def weights(self, S):
        """Attenuated weights ``W (q, m)`` and gradients ``(q, m, 3)`` for exponent ``S``."""
        return attenuate(self.raw, self.graw, self.whi[None], S)

    def smooth(self, alpha, alpha_u=None, gradient="exact"):
        """``(d_hat (q,), grad (q, 3))`` by a max-shifted LogSumExp over every primitive."""
        alpha = float(alpha)
        S = 1.0 if alpha_u is None else min(alpha / float(alpha_u), 1.0)
        k = 1.0 / alpha if gradient == "exact" else 1.0 / alpha ** 2
        W, gW = self.weights(S)
        m = self.D.min(axis=1)
        e = np.exp(-alpha * (self.D - m[:, None]))     # every exponent <= 0, the largest is 1
        s = np.sum(W * e, axis=1)
        d = m - np.log(s) / alpha
        num = np.sum((W * e)[..., None] * self.gD - k * e[..., None] * gW, axis=1)
        return d, num / s[:, None]

    def exact(self):
        """``(d (q,), unit grad (q, 3), closest index (q,))``; ties go to the lowest index."""
        j = np.argmin(self.D, axis=1)
        rows = np.arange(self.D.shape[0])
        return self.D[rows, j], self.gD[rows, j], j


def _chunks(n, size):
    for i in range(0, n, size):
        yield slice(i, min(n, i + size))


def _chunk_size(mesh, budget=1_000_000):
    return max(1, budget // max(1, mesh.num_primitives))


def smooth_distance(Q, mesh, alpha, alpha_u=None, gradient="exact"):
    """Brute-force smooth distance ``d_hat (q,)`` and gradient ``(q, 3)`` (beta = 0).

    ``mesh`` is a :class:`smoothdist.DataMesh`. ``gradient`` is ``"exact"`` (true derivative)
    or ``"metric"`` (weight-gradient term divided by alpha once more).
    """
    Q = np.atleast_2d(np.asarray(Q, dtype=np.float64))
    d = np.empty(Q.shape[0])
    g = np.empty((Q.shape[0], 3))
    for sl in _chunks(Q.shape[0], _chunk_size(mesh)):
        d[sl], g[sl] = Terms(Q[sl], mesh).smooth(alpha, alpha_u, gradient)
    return d, g


def smooth_distance_value(Q, mesh, alpha, alpha_u=None):
    """Just ``d_hat`` (see :func:`smooth_distance`)."""
    return smooth_distance(Q, mesh, alpha, alpha_u)[0]


def exact_distance(Q, mesh):
    """Brute-force exact distance ``(d (q,), unit grad (q, 3), closest index (q,))``."""
    Q = np.atleast_2d(np.asarray(Q, dtype=np.float64))
    d = np.empty(Q.shape[0])
    g = np.empty((Q.shape[0], 3))
    idx = np.empty(Q.shape[0], dtype=np.int64)
    for sl in _chunks(Q.shape[0], _chunk_size(mesh)):
        d[sl], g[sl], idx[sl] = Terms(Q[sl], mesh).exact()
    return d, g, idx


def distances_to_primitives(Q, mesh):
    """Exact distances ``(q, m)`` from every query to every primitive (mesh numbering)."""
    return Terms(Q, mesh).D


def raw_weights(Q, mesh):
    """Unclamped raw weights ``A w~`` ``(q, m)`` at each query's projection (points: 1)."""
    return Terms(Q, mesh).raw


# --------------------------------------------------------------------------- sampling helpers


def sample_on_primitives(mesh, n, rng):
    """``n`` random points lying on random primitives of the mesh (distance 0)."""
    V = mesh.V
    P, E, T = mesh.points, mesh.edges, mesh.triangles
    m = mesh.num_primitives
    pick = rng.integers(0, m, n)
    out = np.empty((n, 3))
    for j, i in enumerate(pick):
        if i < P.size:
            out[j] = V[P[i]]
        elif i < P.size + E.shape[0]:
            a, b = V[E[i - P.size]]
            out[j] = a + rng.random() * (b - a)
        else:
            a, b, c = V[T[i - P.size - E.shape[0]]]
            u, v = rng.random(2)
            if u + v > 1:
                u, v = 1 - u, 1 - v
            out[j] = a + u * (b - a) + v * (c - a)
    return out


def near_queries(mesh, n, rng, pad=0.25):
    """``n`` uniform random queries in the mesh's bounding box grown by ``pad`` diagonals."""
    lo, hi = mesh.bounds
    diag = np.linalg.norm(hi - lo)
    lo = lo - pad * diag
    hi = hi + pad * diag
    return lo + rng.random((n, 3)) * (hi - lo)


def far_queries(mesh, n, rng, lo_diag=1e3, hi_diag=1e6):
    """``n`` queries at log-uniform distances ``[lo_diag, hi_diag]`` diagonals from the centre."""
    lo, hi = mesh.bounds
    diag = np.linalg.norm(hi - lo)
    centre = 0.5 * (lo + hi)
    u = rng.normal(size=(n, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    r = diag * np.exp(rng.uniform(np.log(lo_diag), np.log(hi_diag), n))
    return centre + u * r[:, None]


# --------------------------------------------------------------------------- junction weights
def junction_cells(mesh):
    """Independent cell counts for inclusion-exclusion (:mod:`smoothdist.junctions`), with
    dicts: ``(cells, signs)``, the list of cells ``("v", i)``, ``("e", a, b)``, ``("t", i)``
    of the edge mesh and of the triangle mesh, and the coefficient of each in the sum
    ``sum_cells coef exp(-alpha d_cell)``: triangles +1, each distinct triangle edge
    ``-(n_E - 1)``, each vertex ``1 - k_v + sum_{E at v} (n_E - 1)``; edge primitives +1, each
    vertex of the edge mesh ``-(n_v - 1)``; points +1."""
    cells, coef = [], []
    for p in mesh.points:
        cells.append(("v", int(p)))
        coef.append(1.0)
    nv = {}
    for i, (a, b) in enumerate(mesh.edges):
        cells.append(("e", int(a), int(b)))
        coef.append(1.0)
        for v in (int(a), int(b)):
            nv[v] = nv.get(v, 0) + 1
    for v, n in sorted(nv.items()):
        if n > 1:
            cells.append(("v", v))
            coef.append(-(n - 1.0))
    ne, kv = {}, {}
    for i, tri in enumerate(mesh.triangles):
        cells.append(("t", i))
        coef.append(1.0)
        for v in tri:
            kv[int(v)] = kv.get(int(v), 0) + 1
        for a, b in ((tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0])):
            key = (min(int(a), int(b)), max(int(a), int(b)))
            ne[key] = ne.get(key, 0) + 1
    c = {v: 1.0 - k for v, k in kv.items()}
    for (a, b), n in sorted(ne.items()):
        if n > 1:
            cells.append(("e", a, b))
            coef.append(-(n - 1.0))
        c[a] += n - 1.0
        c[b] += n - 1.0
    for v, cv in sorted(c.items()):
        if cv != 0.0:
            cells.append(("v", v))
            coef.append(cv)
    return cells, np.array(coef)


def junction_distance(Q, mesh, alpha):
    """Smooth distance with inclusion-exclusion junction weights, brute force over the cells
    of :func:`junction_cells`: ``(d_hat (q,), grad (q, 3), s (q,))`` with ``s`` the sum
    relative to the nearest triangle, edge or point (``d_hat`` is not clamped: where ``s < 1``
    the library returns the nearest distance instead)."""
    Q = np.atleast_2d(np.asarray(Q, dtype=np.float64))
    V = mesh.V
    cells, coef = junction_cells(mesh)
    D = np.empty((Q.shape[0], len(cells)))
    G = np.empty((Q.shape[0], len(cells), 3))
    for j, cell in enumerate(cells):
        if cell[0] == "v":
            X = np.broadcast_to(V[cell[1]], Q.shape)
        elif cell[0] == "e":
            X = closest_point_segment(Q, V[cell[1]][None], V[cell[2]][None])[0][:, 0]
        else:
            tri = mesh.triangles[cell[1]]
            X = closest_point_triangle(Q, V[tri[0]][None], V[tri[1]][None],
                                       V[tri[2]][None])[0][:, 0]
        R = Q - X
        D[:, j] = np.linalg.norm(R, axis=1)
        G[:, j] = R / np.where(D[:, j] > 0, D[:, j], 1.0)[:, None]
    m = D.min(axis=1)       # a cell's points all lie on a primitive: the nearest primitive's
    e = coef[None] * np.exp(-alpha * (D - m[:, None]))
    s = e.sum(axis=1)
    g = np.einsum("qm,qmk->qk", e, G) / s[:, None]
    return m - np.log(s) / alpha, g, s
