"""Slow numpy references for primitive-primitive distances and the mesh-to-mesh smooth distance.

Independent of the library's kernels: the closest pair of two simplices is found by enumerating
every pair of *faces* (vertices, edges, the triangle itself) of the two, solving the unconstrained
least-squares problem on their affine hulls with a pseudo-inverse, and keeping the best solution
whose barycentrics are all >= 0 (the minimum of a convex QP over a product of simplices lies in
the relative interior of some face pair, where it is that face pair's unconstrained minimum). The
library instead uses a vertex/edge decomposition with intersection tests.

Weights, clamps and LogSumExp come from :mod:`naive` (numpy, brute force).
"""

import itertools

import numpy as np

import naive

#: faces of a simplex with k + 1 vertices: tuples of vertex slots
FACES = {
    0: [(0,)],
    1: [(0,), (1,), (0, 1)],
    2: [(0,), (1,), (2,), (0, 1), (0, 2), (1, 2), (0, 1, 2)],
}


def _face_min(X, Y):
    """Unconstrained closest points of the affine hulls of ``X (n, a, 3)`` and ``Y (n, b, 3)``.

    Returns barycentrics ``lam (n, a)``, ``mu (n, b)`` (summing to 1) and squared distances.
    """
    n, a, _ = X.shape
    b = Y.shape[1]
    # point = X0 + sum_i x_i (X_i - X0), Y0 + sum_j y_j (Y_j - Y0); minimise |Xp - Yp|^2
    cols = [X[:, i] - X[:, 0] for i in range(1, a)] + [-(Y[:, j] - Y[:, 0]) for j in range(1, b)]
    r0 = X[:, 0] - Y[:, 0]
    if not cols:
        lam = np.ones((n, 1))
        mu = np.ones((n, 1))
        return lam, mu, np.einsum("nk,nk->n", r0, r0)
    M = np.stack(cols, axis=2)                          # (n, 3, a - 1 + b - 1)
    z = -np.einsum("nij,nj->ni", np.linalg.pinv(M), r0)
    x = z[:, :a - 1]
    y = z[:, a - 1:]
    lam = np.concatenate([1 - x.sum(axis=1, keepdims=True), x], axis=1)
    mu = np.concatenate([1 - y.sum(axis=1, keepdims=True), y], axis=1)
    r = r0 + np.einsum("nij,nj->ni", M, z)
    return lam, mu, np.einsum("nk,nk->n", r, r)


def closest_pairs(kq, Q, kd, P):
    """Closest pairs between query simplices ``Q (n, kq+1, 3)`` and data simplices ``P (n, kd+1, 3)``.

    Returns ``(dist (n,), lam (n, kq+1), mu (n, kd+1))``: distances and full barycentric
    coordinates on both sides (``lam @ Q`` and ``mu @ P`` are the closest points).
    """
    n = Q.shape[0]
    best = np.full(n, np.inf)
    lam_b = np.zeros((n, kq + 1))
    mu_b = np.zeros((n, kd + 1))
    for fq, fd in itertools.product(FACES[kq], FACES[kd]):
        lam, mu, d2 = _face_min(Q[:, list(fq)], P[:, list(fd)])
        ok = (lam >= -1e-12).all(axis=1) & (mu >= -1e-12).all(axis=1)
        # re-measure between the actual points, clipped into the faces
        lam = np.clip(lam, 0, None)
        lam /= lam.sum(axis=1, keepdims=True)
        mu = np.clip(mu, 0, None)
        mu /= mu.sum(axis=1, keepdims=True)
        r = np.einsum("na,nak->nk", lam, Q[:, list(fq)]) - np.einsum("nb,nbk->nk", mu, P[:, list(fd)])
        d2 = np.einsum("nk,nk->n", r, r)
        take = ok & (d2 < best * (1 - 1e-14))
        best = np.where(take, d2, best)
        L = np.zeros((n, kq + 1))
        L[:, list(fq)] = lam
        U = np.zeros((n, kd + 1))
        U[:, list(fd)] = mu
        lam_b = np.where(take[:, None], L, lam_b)
        mu_b = np.where(take[:, None], U, mu_b)
    return np.sqrt(best), lam_b, mu_b


def query_primitives(V, F):
    """``[(kind, (m, kind+1, 3) coords, (m, kind+1) indices)]`` of a query ``(V, F)``."""
    V = np.asarray(V, dtype=np.float64)
    if F is None:
        return [(0, V[:, None, :], np.arange(len(V))[:, None])]
    F = np.asarray(F)
    return [(F.shape[1] - 1, V[F], F)]


def data_primitives(mesh):
    """``[(kind, (m, kind+1, 3) coords, raw-weight function, whi (m,))]`` of a DataMesh.

    The raw-weight function maps data barycentrics ``mu (q, m, kind+1)`` to ``A w~`` (q, m).
    """
    V = mesh.V
    A, ecoef, ewhi, tcoef, twhi = mesh.weight_data()
    out = []
    if mesh.points.size:
        out.append((0, V[mesh.points][:, None, :], lambda mu: np.ones(mu.shape[:2]),
                    np.ones(mesh.points.size)))
    if mesh.edges.shape[0]:
        out.append((1, V[mesh.edges], lambda mu: A * naive.edge_poly(ecoef[None], mu[..., 1])[0],
                    ewhi))
    if mesh.triangles.shape[0]:
        out.append((2, V[mesh.triangles],
                    lambda mu: A * naive.triangle_poly(tcoef[None], mu[..., 1], mu[..., 2])[0],
                    twhi))
    return out


def pairwise(Vq, Fq, mesh):
    """All query-data pairs: ``(D (mq, md), raw weights (mq, md), whi (md,), kinds, idx)``."""
    (kq, Qc, Qi), = query_primitives(Vq, Fq)
    mq = Qc.shape[0]
    Ds, Rs, Ws = [], [], []
    for kd, Pc, rawf, whi in data_primitives(mesh):
        md = Pc.shape[0]
        Qr = np.repeat(Qc, md, axis=0)
        Pr = np.tile(Pc, (mq, 1, 1))
        d, lam, mu = closest_pairs(kq, Qr, kd, Pr)
        Ds.append(d.reshape(mq, md))
        Rs.append(rawf(mu.reshape(mq, md, kd + 1)))
        Ws.append(whi)
    return (np.concatenate(Ds, axis=1), np.concatenate(Rs, axis=1), np.concatenate(Ws), kq,
            Qi)


def smooth_mesh_distance(Vq, Fq, mesh, alpha, alpha_q, alpha_u=None):
    """Mesh-to-mesh smooth distance (Eq. 6) at beta = 0, and the per-query-primitive values."""
    D, raw, whi, kq, Qi = pairwise(Vq, Fq, mesh)
    S = 1.0 if alpha_u is None else min(alpha / alpha_u, 1.0)
    W = np.clip(raw, 1.0, whi[None]) ** S
    m = D.min(axis=1)
    dj = m - np.log(np.sum(W * np.exp(-alpha * (D - m[:, None])), axis=1)) / alpha
    mm = dj.min()
    d = mm - np.log(np.sum(np.exp(-alpha_q * (dj - mm)))) / alpha_q
    return d, dj, D


def sample_simplex(X, n, rng):
    """``n`` points (n, 3) on simplex ``X (k+1, 3)``: vertices, edge points and uniform samples."""
    k = X.shape[0] - 1
    if k == 0:
        return np.repeat(X, n, axis=0)
    B = rng.dirichlet(np.ones(k + 1), size=n)
    # add dense edge coverage: half of the samples on edges
    h = n // 2
    for i in range(h):
        a, b = rng.choice(k + 1, 2, replace=False)
        u = rng.random()
        B[i] = 0
        B[i, a] = u
        B[i, b] = 1 - u
    return B @ X


def grid_simplex(X, res):
    """Regular barycentric grid on a simplex ``X (k+1, 3)`` with ``res`` steps per edge."""
    k = X.shape[0] - 1
    if k == 0:
        return X.copy()
    u = np.linspace(0, 1, res + 1)
    if k == 1:
        return (1 - u)[:, None] * X[0] + u[:, None] * X[1]
    S, T = np.meshgrid(u, u, indexing="ij")
    keep = S + T <= 1 + 1e-12
    S, T = S[keep], T[keep]
    return X[0] + S[:, None] * (X[1] - X[0]) + T[:, None] * (X[2] - X[0])
