"""The one contact constraint of a scene: every pairwise smooth distance folded into ``c >= 0``.

For every pair of bodies that are not both static, one body is the **data** mesh and the other
the **query** mesh of a whole-mesh smooth distance ``d_hat(M_data, M_query)`` (paper Eq. 6-8,
:class:`smoothdist.MeshDistance`): the data body's ``alpha`` and ``alpha_U`` are the inner
parameters, the query body's ``alpha`` is ``alpha_q``. The data body is the static one, else the
one with more primitives (the cost grows with the number of query primitives). Each pair is
evaluated **once**, in that orientation, and both bodies' gradients come from that evaluation, so
the translation gradient is the derivative of the returned value (the authors evaluate each
orientation and mix them). The pair distances use the exact derivative of the weights
(``gradient="exact"``), not the paper's alpha-metric gradient, so that the solver's line search
sees a gradient consistent with the values. The rotation gradient is chosen by ``torques``:

* ``"exact"`` (default): the derivative of the pair distance for a rotation of the bodies.
  Each pair term acts at its own closest point on the query primitive (envelope theorem), so
  the equal-split torque gets the couple of :meth:`smoothdist.MeshDistance.with_couple`;
* ``"split"``: the paper's equal split of each query primitive's force over its vertices
  (Eq. 7-8; the authors' simulator), i.e. the force acts at the primitive's centroid: exact for
  point queries, off by the order of the primitive size times the force for edges and triangles
  (the rotation gradient then disagrees with the values the line search sees).

Both give the same translation gradient, and identical results for point-cloud query bodies.
A distance object without ``with_couple`` (e.g. a stand-in) gets split torques.

The scene constraint is the LogSumExp of the pair distances with the largest alpha of the scene
(paper Sec. 5.5)::

    c = -1/a log sum_p exp(-a d_p),   grad c = sum_p softmax_p grad d_p.

``mode="exact"`` replaces it by ``min_p (exact distance_p - 1/alpha_data_p)`` (the authors'
exact-distance constraint, C0 only; used by the V-bowl study).

Gradients are returned per body as a world-space force-like pair ``(gx, gw)``: ``gx`` the
derivative with respect to a translation of the body and ``gw`` with respect to a small world
rotation ``exp([w]x)`` applied about its centre of mass. From the query's vertex gradients
``g_i`` (world) at vertices ``p_i`` and the couple ``C`` (world; 0 with split torques):
``gx = sum g_i``, ``gw = sum (p_i - x) x g_i + C`` for the query body, and the negatives about
the data body's centre for the data body.

Broad phase (exact, not a heuristic): a pair whose lower bound ``(gap of bounding spheres) /
(1 + beta) - inflation`` exceeds the smallest pair distance by more than ``40 / a`` changes
``c`` by less than ``exp(-40)`` relative and is skipped.
"""

import math

import numpy as np

import smoothdist
from smoothdist import SmoothDistanceField

#: pairs whose lower bound exceeds the current minimum by this many 1/a are skipped
SKIP_EXPONENT = 40.0
#: the rotation gradient: exact derivative, or the paper's equal split (module notes)
TORQUES = ("exact", "split")
DEFAULT_TORQUES = "exact"


def mesh_distance_factory():
    """The whole-mesh distance class (issue 9's :class:`smoothdist.MeshDistance`)."""
    cls = getattr(smoothdist, "MeshDistance", None)
    if cls is None:
        raise RuntimeError("smoothdist.MeshDistance is not available in this build")
    return cls


def pair_order(bodies):
    """``[(data body index, query body index)]``: every pair of bodies of which one moves; the
    static body (or else the one of more primitives) is the pair's data, the other its query."""
    pairs = []
    for a in range(len(bodies)):
        for b in range(a + 1, len(bodies)):
            A, B = bodies[a], bodies[b]
            if A.static and B.static:
                continue
            if B.static or (not A.static and B.mesh.num_primitives > A.mesh.num_primitives):
                pairs.append((b, a))
            else:
                pairs.append((a, b))
    return pairs


class Pair:
    """One data/query body pair and its :class:`smoothdist.MeshDistance`."""

    def __init__(self, i_data, i_query, bodies, beta, factory, fields):
        self.i, self.j = i_data, i_query
        A, B = bodies[i_data], bodies[i_query]
        if i_data not in fields:
            fields[i_data] = SmoothDistanceField(A.mesh)
        fA = fields[i_data]
        self.md = factory(fA, B.mesh, alpha=A.alpha, alpha_q=B.alpha, beta=beta,
                          alpha_u=A.alpha_u, gradient="exact")
        self.offset = 1.0 / A.alpha
        self.inflation = (fA.inflation(A.alpha, A.alpha_u)
                          + math.log(max(B.mesh.num_primitives, 1)) / B.alpha)
        self.radius = A.radius + B.radius
        self.beta = beta

    def lower_bound(self, X):
        """A lower bound of the pair's smooth distance from the centres ``X (nb, 3)``."""
        gap = float(np.linalg.norm(X[self.i] - X[self.j])) - self.radius
        return max(gap, 0.0) / (1.0 + self.beta) - self.inflation

    def relative(self, X, Rs):
        """``(R_rel, t_rel)`` mapping query body coordinates into data body coordinates."""
        RA = Rs[self.i]
        return RA.T @ Rs[self.j], RA.T @ (X[self.j] - X[self.i])


class ContactConstraint:
    """``c(poses)`` and its per-body gradient for a list of :class:`~tracer.sim.bodies.Body`.

    Parameters
    ----------
    bodies : list of Body
    beta : float
        Barnes-Hut parameter of every pair distance.
    mode : {"smooth", "exact"}
    torques : {"exact", "split"}
        The rotation gradient of the smooth constraint (module notes). ``mode="exact"`` always
        splits the minimising primitive's gradient (the authors' exact constraint).
    factory : callable, optional
        ``factory(data_field, query_mesh, *, alpha, alpha_q, beta, alpha_u, gradient)`` returning
        an object
        with ``__call__(R, t)`` and ``exact(R, t)`` -> ``(d, G)`` (the
        :class:`~smoothdist.MeshDistance` contract). Default: :func:`mesh_distance_factory`.
    """

    def __init__(self, bodies, beta=0.5, mode="smooth", factory=None, torques=DEFAULT_TORQUES):
        if mode not in ("smooth", "exact"):
            raise ValueError(f"mode must be 'smooth' or 'exact', got {mode!r}")
        if torques not in TORQUES:
            raise ValueError(f"torques must be one of {TORQUES}, got {torques!r}")
        factory = factory or mesh_distance_factory()
        self.bodies = bodies
        self.mode = mode
        self.torques = torques
        fields = {}
        self.pairs = [Pair(i, j, bodies, beta, factory, fields) for i, j in pair_order(bodies)]
        if not self.pairs:
            raise ValueError("the scene needs at least one body that moves and two bodies")
        self.alpha = max(max(bodies[p.i].alpha, bodies[p.j].alpha) for p in self.pairs)
        self.alpha_min = min(min(bodies[p.i].alpha, bodies[p.j].alpha) for p in self.pairs)
        self.evaluations = 0

    def _pair(self, p, X, Rs, exact, gradient=True):
        """``(d, G (n, 3), C (3,) or None)`` of a pair in the data body's frame."""
        R, t = p.relative(X, Rs)
        C = None
        if exact:
            d, G = p.md.exact(R, t)
        elif gradient and self.torques == "exact" and hasattr(p.md, "with_couple"):
            d, G, C = p.md.with_couple(R, t)
        else:
            d, G = p.md(R, t)
        self.evaluations += 1
        return float(d), np.asarray(G, dtype=float), C

    def _pair_gradient(self, p, X, Rs, G, C=None):
        """World ``(gx, gw)`` of the data body and of the query body from vertex gradients
        and the couple ``C`` (data frame; None: split torques)."""
        RA, RB = Rs[p.i], Rs[p.j]
        g = G @ RA.T                                  # world vertex gradients
        P = self.bodies[p.j].mesh.V @ RB.T           # query vertices relative to its centre
        gsum = g.sum(axis=0)
        gw_q = np.cross(P, g).sum(axis=0)
        # data body: moving it by dx is moving the query by -dx; rotation about x_A
        rel = P + (X[p.j] - X[p.i])
        gw_d = -np.cross(rel, g).sum(axis=0)
        if C is not None:                             # a couple: the same about any point
            Cw = RA @ C
            gw_q = gw_q + Cw
            gw_d = gw_d - Cw
        return -gsum, gw_d, gsum, gw_q

    def evaluate(self, X, Rs, gradient=True):
        """``(c, gx (nb, 3), gw (nb, 3))`` at centres ``X (nb, 3)`` and rotations
        ``Rs (nb, 3, 3)``."""
        nb = len(self.bodies)
        gx = np.zeros((nb, 3))
        gw = np.zeros((nb, 3))
        order = sorted(self.pairs, key=lambda p: p.lower_bound(X))
        if self.mode == "exact":
            best, arg = np.inf, None
            for p in order:
                gap = float(np.linalg.norm(X[p.i] - X[p.j])) - p.radius
                if gap - p.offset > best:             # exact distances are >= sphere gaps
                    continue
                d, G, _ = self._pair(p, X, Rs, exact=True)
                if d - p.offset < best:
                    best, arg = d - p.offset, (p, G)
            if gradient:
                p, G = arg
                a, b, c_, e = self._pair_gradient(p, X, Rs, G)
                gx[p.i], gw[p.i], gx[p.j], gw[p.j] = a, b, c_, e
            return best, gx, gw
        a = self.alpha
        m, s = np.inf, 0.0
        terms = []
        for p in order:
            if terms and p.lower_bound(X) > m + SKIP_EXPONENT / a:
                break
            d, G, C = self._pair(p, X, Rs, exact=False, gradient=gradient)
            terms.append((p, d, G, C))
            m = min(m, d)
        for p, d, G, C in terms:
            w = math.exp(-a * (d - m))
            s += w
            if gradient:
                g_i, w_i, g_j, w_j = self._pair_gradient(p, X, Rs, G, C)
                gx[p.i] += w * g_i
                gw[p.i] += w * w_i
                gx[p.j] += w * g_j
                gw[p.j] += w * w_j
        return m - math.log(s) / a, gx / s, gw / s

    def min_exact_distance(self, X, Rs):
        """Exact minimum distance between the geometry of any two bodies (pairs not both static)."""
        best = np.inf
        for p in sorted(self.pairs, key=lambda p: p.lower_bound(X)):
            gap = float(np.linalg.norm(X[p.i] - X[p.j])) - p.radius
            if gap > best:
                continue
            R, t = p.relative(X, Rs)
            best = min(best, float(p.md.exact(R, t)[0]))
        return best
