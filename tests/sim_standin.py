"""A slow stand-in for ``smoothdist.MeshDistance`` when the query mesh is a point cloud.

For a point-cloud query mesh the whole-mesh smooth distance (paper Eq. 6-8, each point its own
primitive, ``n(g) + 1 = 1``) is the LogSumExp with ``alpha_q`` of the point-query smooth
distances, and its vertex gradient is the softmax-weighted point gradient. Used by the tests as
an independent second computation (and to develop the simulator before MeshDistance existed).
"""

import numpy as np

from smoothdist import DataMesh, SmoothDistanceField


class PointQueryDistance:
    """``md(R, t) -> (d, G)`` and ``md.exact(R, t)`` for a point-cloud query mesh."""

    def __init__(self, data, query, *, alpha, alpha_q, beta=0.5, alpha_u=None, gradient="exact"):
        if isinstance(data, SmoothDistanceField):
            data = data.mesh
        if not isinstance(data, DataMesh):
            data = DataMesh(*data)
        if not isinstance(query, DataMesh):
            query = DataMesh(*query)
        if len(query.edges) or len(query.triangles):
            raise ValueError("the stand-in handles point-cloud query meshes only")
        self.field = SmoothDistanceField(data)
        self.V = query.V
        self.idx = query.points
        self.alpha, self.alpha_q, self.beta, self.alpha_u = alpha, alpha_q, beta, alpha_u
        self.gradient = gradient

    def _points(self, R, t):
        R = np.eye(3) if R is None else np.asarray(R, float)
        t = np.zeros(3) if t is None else np.asarray(t, float)
        return self.V[self.idx] @ R.T + t

    def __call__(self, R=None, t=None):
        d, g = self.field.smooth_distance(self._points(R, t), alpha=self.alpha, beta=self.beta,
                                          alpha_u=self.alpha_u, gradient=self.gradient)
        m = d.min()
        e = np.exp(-self.alpha_q * (d - m))
        s = e.sum()
        G = np.zeros_like(self.V)
        np.add.at(G, self.idx, (e / s)[:, None] * g)
        return float(m - np.log(s) / self.alpha_q), G

    def exact(self, R=None, t=None):
        d, g = self.field.exact_distance(self._points(R, t))
        k = int(np.argmin(d))
        G = np.zeros_like(self.V)
        G[self.idx[k]] = g[k]
        return float(d[k]), G
