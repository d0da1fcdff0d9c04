"""Smooth distance between two meshes (Madan & Levin 2022, Sec. 3.6, Eq. 6-8), and its gradient.

A *data* mesh (points, edges, triangles or a mix; its BVH built once) against a *query* mesh of
the same kinds, which may move rigidly between calls:

    d_hat(M_d, M_q) = -(1/alpha_q) log sum_j exp(-alpha_q d_hat(M_d, g_j))          (Eq. 6)

over the query primitives ``g_j``, each ``d_hat(M_d, g_j)`` the smooth distance of one query
primitive (:mod:`smoothdist._kernels.mesh_query`). The gradient with respect to query vertex
``k`` is the paper's equal split (Eq. 7-8): primitive ``j``'s softmax weight times its translation
gradient, divided among its ``n_j + 1`` vertices,

    grad_k = sum_{j ∋ k} exp(-alpha_q d_hat_j) grad d_hat_j / (n_j + 1)
    / sum_j exp(-alpha_q d_hat_j).

So the vertex gradients sum to the gradient of a rigid translation of the whole query mesh.
Their torque ``sum_k (x_k - o) x grad_k`` applies each primitive's force at its centroid, which
is exact for point queries only: a pair distance changes under a rotation through the motion of
its closest point on ``g_j``. :meth:`MeshDistance.with_couple` adds the couple that makes the
torque the exact rotational derivative (:mod:`smoothdist._kernels.mesh_moment`), and
:meth:`MeshDistance.rigid_gradient` returns force and torque either way.

Conventions: distances are unsigned, in scene units (the data mesh's frame). ``R``, ``t`` map query
vertices ``x -> R x + t`` into that frame; gradients are with respect to the transformed vertex
positions. Bounds: ``d_hat <= min_j d_hat_j <= exact minimum pairwise distance``, and Barnes-Hut
only lowers it (``d_hat_beta <= d_hat_0``).
"""

import math
from typing import NamedTuple

import numba
import numpy as np

from smoothdist._kernels import mesh_moment as _mm
from smoothdist._kernels import mesh_query as _mq
from smoothdist._kernels import query as _q
from smoothdist._cast import COORD_LIMIT, as_indices, as_points, non_negative, positive
from smoothdist._config import NJIT
from smoothdist.convert import is_foreign_geometry
from smoothdist.error_budget import Within, mesh_alphas
from smoothdist.field import SmoothDistanceField
from smoothdist.mesh import DataMesh, as_data_mesh
from smoothdist._kernels.query import DEFAULT_TOL
from smoothdist.schedule import parallel_tasks, run_tasks


#: query meshes with fewer primitives than this run on the calling thread (a parallel launch
#: costs more than their work, and much more on a busy machine)
SERIAL_BELOW = {"smooth": 32, "exact": 1024}
#: how rigid-body torques are taken from the gradient: the exact derivative, or the paper's
#: equal split of each primitive's force over its vertices
TORQUES = ("exact", "split")


class QueryMesh(NamedTuple):
    """A validated query mesh: vertices and a primitive table (no repair: vertex numbering kept).

    ``V (n, 3) float64``; ``kind (m,) int64`` (0 point, 1 edge, 2 triangle); ``index (m, 3)``
    int64 vertex indices (unused slots repeat the last vertex).
    """

    V: np.ndarray
    kind: np.ndarray
    index: np.ndarray


def as_query_mesh(query, name="query"):
    """Build a :class:`QueryMesh` from a DataMesh, a ``(V, F)`` pair, or a ``(n, 3)`` point array.

    ``F`` is None (every vertex a point), ``(m, 1)`` points, ``(m, 2)`` edges or ``(m, 3)``
    triangles. Degenerate primitives are allowed (the closest-pair kernels handle them); NaN,
    bad shapes, out-of-range indices and empty meshes raise ``ValueError``.
    """
    if isinstance(query, QueryMesh):
        return query
    if isinstance(query, SmoothDistanceField):
        query = query.mesh
    if is_foreign_geometry(query):  # trimesh / pyvista: keep the object's own vertex order
        query = as_data_mesh(query, name=name, repair=False)
    if isinstance(query, DataMesh):
        V = query.V
        parts = [(0, query.points[:, None]), (1, query.edges), (2, query.triangles)]
    else:
        if isinstance(query, tuple) and len(query) == 2:
            V, F = query
        elif isinstance(query, (tuple, list)) and len(query) == 1:
            V, F = query[0], None
        else:
            V, F = query, None
        V = as_points(V, f"{name} vertices")
        if V.shape[0] == 0:
            raise ValueError(f"{name} mesh has no vertices")
        if F is None:
            parts = [(0, np.arange(V.shape[0])[:, None])]
        else:
            Fa = np.asarray(F)
            if Fa.ndim != 2 or Fa.shape[1] not in (1, 2, 3):
                raise ValueError(f"{name} faces must have shape (m, 1), (m, 2) or (m, 3), "
                                 f"got {Fa.shape}")
            k = Fa.shape[1]
            parts = [(k - 1, as_indices(Fa, V.shape[0], k, f"{name} faces"))]
    kinds, idx = [], []
    for k, I in parts:
        if I.shape[0]:
            kinds.append(np.full(I.shape[0], k, dtype=np.int64))
            idx.append(np.concatenate([I, np.repeat(I[:, -1:], 3 - I.shape[1], axis=1)], axis=1))
    if not kinds:
        raise ValueError(f"{name} mesh has no primitives")
    return QueryMesh(np.ascontiguousarray(V, dtype=np.float64),
                     np.ascontiguousarray(np.concatenate(kinds)),
                     np.ascontiguousarray(np.concatenate(idx), dtype=np.int64))


def _run_tasks(kernel, m, serial_below, *args):
    """Run the serial task kernel ``kernel(*args, ntasks, task0, task1)`` over ``m`` query
    primitives: on the calling thread below ``serial_below`` (one task), else one strided task
    per thread on the persistent worker threads (:func:`smoothdist.schedule.run_tasks`). The
    values do not depend on the split."""
    if m < serial_below:
        kernel(*args, 1, 0, 1)
        return
    ntasks = parallel_tasks(m)
    run_tasks(lambda a, b: kernel(*args, ntasks, a, b), ntasks, pool=True)


# (data kind, query kind) -> the distance's kernel that compiles that pair kernel only
# (1 edges, 2 triangles; point queries have kernels of their own)
_ONE_KIND_KERNELS = {(1, 1): _mq.segment_distance_tasks, (2, 2): _mq.triangle_distance_tasks,
                     (1, 2): _mq.triangles_on_segments_tasks,
                     (2, 1): _mq.segments_on_triangles_tasks}
#: (data kind, query kind) -> the exact distance's (serial, prange) kernels of that pair kernel
#: only (the query without points)
_ONE_KIND_EXACT = {(1, 1): (_mq.exact_segment_tasks, _mq.exact_segments),
                   (2, 2): (_mq.exact_triangle_tasks, _mq.exact_triangles)}


def _one_kind(kind):
    """The one primitive kind of ``kind (n,)`` int8/int64, or None for a mix (or none): a
    minimum and a maximum, no sort (a scan's tree may hold 10M primitives)."""
    if kind.size == 0 or kind.min() != kind.max():
        return None
    return int(kind[0])


def _as_field(data, leaf_size):
    if isinstance(data, SmoothDistanceField):
        return data
    if isinstance(data, DataMesh):
        return SmoothDistanceField(data, leaf_size=leaf_size)
    if isinstance(data, tuple) and len(data) == 2:
        return SmoothDistanceField(data[0], data[1], leaf_size=leaf_size)
    return SmoothDistanceField(data, leaf_size=leaf_size)


def as_rigid_transform(R=None, t=None):
    """Validate ``R (3, 3)`` (a rotation, None = identity) and ``t (3,)`` (None = 0)."""
    if np.iscomplexobj(R) or np.iscomplexobj(t):
        raise ValueError("R and t must be real, got a complex array")
    if R is None:
        Rm = np.eye(3)
    else:
        try:
            Rm = np.asarray(R, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"R must be a (3, 3) rotation matrix: {exc}") from None
        if Rm.shape != (3, 3):
            raise ValueError(f"R must have shape (3, 3), got {Rm.shape}")
        Rm = np.ascontiguousarray(Rm)
        bad = _rotation_defect(Rm)
        if bad == 1:
            raise ValueError("R contains NaN or infinite entries")
        if bad == 2:
            raise ValueError("R must be a rotation matrix (orthonormal, det +1)")
    if t is None:
        tv = np.zeros(3)
    else:
        try:
            tv = np.asarray(t, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"t must be a (3,) translation: {exc}") from None
        if tv.shape != (3,):
            raise ValueError(f"t must have shape (3,), got {tv.shape}")
        if not (math.isfinite(tv[0]) and math.isfinite(tv[1]) and math.isfinite(tv[2])):
            raise ValueError("t contains NaN or infinite entries")
    return Rm, tv


@numba.njit(**NJIT)
def _rotation_defect(R):
    """0 for a rotation ``R (3, 3)``; 1 for NaN or infinite entries; 2 when ``R^T R`` is more
    than 1e-6 from the identity in some entry, or ``det R < 0``."""
    for i in range(3):
        for j in range(3):
            if not math.isfinite(R[i, j]):
                return 1
    for i in range(3):
        for j in range(3):
            a = R[0, i] * R[0, j] + R[1, i] * R[1, j] + R[2, i] * R[2, j]
            if abs(a - (1.0 if i == j else 0.0)) > 1e-6:
                return 2
    det = (R[0, 0] * (R[1, 1] * R[2, 2] - R[1, 2] * R[2, 1])
           - R[0, 1] * (R[1, 0] * R[2, 2] - R[1, 2] * R[2, 0])
           + R[0, 2] * (R[1, 0] * R[2, 1] - R[1, 1] * R[2, 0]))
    return 2 if det < 0.0 else 0


@numba.njit(**NJIT)
def _check_gather(X, index, pts):
    """``pts[j]`` = the 9 coordinates of primitive ``j``'s vertices ``index[j]`` in ``X`` (for
    the rows of ``pts``). Returns False when a coordinate of ``X`` is NaN, infinite or beyond
    ``COORD_LIMIT`` (the checks of :func:`smoothdist._cast.as_points`)."""
    ok = True
    for i in range(X.shape[0]):
        for a in range(3):
            if not abs(X[i, a]) <= COORD_LIMIT:
                ok = False
    for j in range(pts.shape[0]):
        for c in range(3):
            v = index[j, c]
            for a in range(3):
                pts[j, 3 * c + a] = X[v, a]
    return ok


@numba.njit(**NJIT)
def _split(d, g, kind, index, alpha_q, G):
    """:func:`split_to_vertices` into ``G (n, 3)`` (zeroed here); returns ``d_hat``."""
    m = d.size
    dmin = np.inf
    for j in range(m):
        dmin = min(dmin, d[j])
    e = np.empty(m)
    s = 0.0
    for j in range(m):
        e[j] = math.exp(-alpha_q * (d[j] - dmin))
        s += e[j]
    G[:] = 0.0
    for j in range(m):
        nv = kind[j] + 1
        w = e[j] / s / nv
        for c in range(nv):
            v = index[j, c]
            G[v, 0] += w * g[j, 0]
            G[v, 1] += w * g[j, 1]
            G[v, 2] += w * g[j, 2]
    return dmin - math.log(s) / alpha_q


class MeshDistance:
    """Smooth (and exact) distance from a query mesh to a data mesh, for many rigid placements.

    Parameters
    ----------
    data : DataMesh, SmoothDistanceField, ``(V, F)`` tuple, or ``(n, 3)`` points
        The data mesh; its BVH is built once, here.
    query : DataMesh, ``(V, F)`` tuple, ``(n, 3)`` points, or a trimesh / pyvista object
        The query mesh. ``F`` None/(m, 2)/(m, 3); a DataMesh may mix kinds. Not repaired:
        gradients come back for every row of its ``V``.
    alpha : float or :func:`smoothdist.within`
        Inner sharpness (1 / scene units) of each query primitive's smooth distance.
        ``within(e)`` chooses ``alpha`` and ``alpha_q`` (half of ``e`` each) so that the smooth
        distance is at most ``e`` below the exact minimum pairwise distance wherever that is
        ``<= e`` (:mod:`smoothdist.error_budget`; edge and triangle queries need ``beta=0``
        or ``box_test=False``; kept in ``md.max_error``, the values in ``md.alpha`` and
        ``md.alpha_q``).
    alpha_q : float
        Outer sharpness over the query primitives (Eq. 6), > 0; required unless ``alpha`` is
        ``within(...)``.
    beta : float
        Barnes-Hut parameter (>= 0); 0 is exact.
    alpha_u : float, optional
        Weight attenuation threshold (None: no attenuation).
    gradient : {"exact", "metric"}
        Weight-gradient convention, as in :meth:`~smoothdist.SmoothDistanceField.smooth_distance`:
        ``"exact"`` (default) the derivative of the value, ``"metric"`` the paper's alpha-metric
        (its ``G.sum(axis=0)`` is a few % off the translation derivative at alpha 20).
    leaf_size : int
        BVH leaf size when the tree is built here.
    tol : float
        Optional pruning tolerance (>= 0, default 0 = the paper's algorithm): a BVH node whose
        far-field term is below ``tol`` times the running sum is replaced by that term. Still
        conservative (``d_hat`` only decreases, by at most ``-log(1 - k tol) / alpha`` per query
        primitive for ``k`` such nodes); applies to edge and triangle queries.
    box_test : bool
        The paper's cheap box test (Sec. 3.5; default True): a Barnes-Hut candidate's distance
        for an edge or triangle query is a lower bound from the box-box gap or the halfspace
        test. False computes the exact primitive-box distance instead (the quadratic program
        the paper avoids; only for measuring what the test saves: ``tracer reproduce``'s
        ``box_test`` experiment). Both are conservative; they accept slightly different far
        fields, so values differ within the Barnes-Hut error. Applies to ``md(...)`` and
        :meth:`primitive_distances`.

    Calling the object, ``d, G = md(R, t)``, returns the smooth distance (float) and the
    paper's vertex gradients ``G (n_query_vertices, 3)`` (Eq. 7-8): each query primitive's
    gradient for a rigid translation of it, weighted by its softmax and split equally among its
    vertices. So ``G.sum(axis=0)`` is the derivative for translating the whole query (with the
    default ``gradient="exact"``), and
    :meth:`rigid_gradient` gives force and torque; ``G[k]`` is not the derivative for moving
    vertex ``k`` alone, which :meth:`vertex_gradient` returns (deformable bodies).
    :meth:`exact` returns the exact minimum pairwise distance and its gradient.

    Examples
    --------
    >>> import numpy as np
    >>> md = MeshDistance(np.zeros((1, 3)), (np.array([[0., 0, 1], [1, 0, 1]]), [[0, 1]]),
    ...                   alpha=50.0, alpha_q=50.0)
    >>> d, G = md(t=[0.0, 0.0, 1.0])
    >>> round(d, 6), G.sum(axis=0).round(6).tolist()
    (2.0, [0.0, 0.0, 1.0])
    """

    def __init__(self, data, query, *, alpha, alpha_q=None, beta=0.5, alpha_u=None,
                 gradient="exact", leaf_size=1, tol=DEFAULT_TOL, box_test=True):
        self.field = _as_field(data, leaf_size)
        if self.field.weights != "paper":
            raise ValueError("whole-mesh distance uses the paper's weights: pass a field made "
                             "with weights='paper' (field.with_weights('paper'))")
        self.tol = non_negative(tol, "tol")
        if not isinstance(box_test, (bool, np.bool_)):
            raise ValueError(f"box_test must be True or False, got {box_test!r}")
        self.box_test = bool(box_test)
        self.query = as_query_mesh(query)
        self.max_error = None
        if isinstance(alpha, Within):
            if alpha_q is not None:
                raise ValueError("alpha=within(...) chooses alpha_q too: leave alpha_q out")
            if self.tol > 0.0:
                raise ValueError("alpha=within(...) needs tol=0: the error bound does not "
                                 "cover tolerance pruning")
            exact_far = not self.box_test or not np.any(self.query.kind)
            self.max_error = alpha.max_error
            alpha, alpha_q = mesh_alphas(self.field, alpha, non_negative(beta, "beta"), alpha_u,
                                         self.query.kind.size, exact_far)
        elif alpha_q is None:
            raise ValueError("alpha_q is required (or pass alpha=smoothdist.within(max_error))")
        self.alpha, self.beta, self.S, self.wgrad_scale = self.field.kernel_args(
            alpha, beta, alpha_u, gradient)
        self.alpha_q = positive(alpha_q, "alpha_q")
        self.alpha_u = alpha_u
        self.gradient = gradient
        self._used = np.unique(self.query.index)
        kind = self.query.kind
        # the point queries' rows and the others': each kind has kernels of its own, so that a
        # first call compiles only what its query mesh needs
        self._rows = np.flatnonzero(kind == 0), np.flatnonzero(kind != 0)
        # ... and where the data and the query's edges and triangles are of one kind, the
        # distance's traversal has a kernel that compiles that kind's pair kernel only
        data_kind = _one_kind(self.field.tree.kind)
        self._distance_kernel = _ONE_KIND_KERNELS.get(
            (data_kind, _one_kind(kind[kind != 0])), _mq.smooth_distance_primitive_tasks)
        self._exact_kernels = _ONE_KIND_EXACT.get(
            (data_kind, _one_kind(kind)),
            (_mq.exact_distance_primitive_tasks, _mq.exact_distance_primitives))
        self.last_stats = None

    @property
    def tree(self):
        """The data mesh's :class:`~smoothdist._kernels.bvh.TreeData`."""
        return self.field.tree

    @property
    def num_query_vertices(self):
        return int(self.query.V.shape[0])

    @property
    def num_query_primitives(self):
        return int(self.query.kind.size)

    def transformed_vertices(self, R=None, t=None):
        """Query vertices ``R x + t``, ``(n, 3)`` float64."""
        return self._place(R, t, False)[0]

    def _place(self, R, t, primitives=True):
        """``(X, pts)``: the transformed vertices and, if ``primitives``, every primitive's
        ``(m, 9)`` vertex coordinates (else ``(0, 9)``), in one pass."""
        Rm, tv = as_rigid_transform(R, t)
        q = self.query
        X = q.V @ Rm.T
        X += tv
        pts = np.empty((q.kind.size if primitives else 0, 9))
        if not _check_gather(X, q.index, pts):
            # the same finiteness and range checks (and messages) as any input: a huge t could
            # overflow a kernel
            as_points(X, "transformed query vertices")
        return X, pts

    def _primitive_coords(self, R, t):
        return self._place(R, t)[1]

    def _smooth_by_kind(self, pts, kernel, outs):
        """Run the task kernel ``kernel`` for the edge and triangle queries (its outputs
        ``outs``, each with a row per query primitive, filled in their rows) and the point
        kernel (:func:`smoothdist._kernels.query.smooth_distance_tasks`) for the point queries.
        Returns the point queries' rows and their ``(d, g, nodes, leaves)``, which the caller
        puts in its outputs (None without point queries)."""
        P, J = self._rows
        tree = self.field.tree
        args = (self.alpha, self.beta, self.S, self.wgrad_scale)
        m = self.query.kind.size
        if J.size == m:
            _run_tasks(kernel, m, SERIAL_BELOW["smooth"], tree, self.query.kind, pts, *args,
                       *outs, self.tol)
        elif J.size:
            part = [np.empty((J.size,) + o.shape[1:], o.dtype) for o in outs]
            _run_tasks(kernel, J.size, SERIAL_BELOW["smooth"], tree, self.query.kind[J], pts[J],
                       *args, *part, self.tol)
            for o, p in zip(outs, part):
                o[J] = p
        n = P.size
        if not n:
            return P, None
        point = (np.empty(n), np.empty((n, 3)), np.empty(n, dtype=np.int64),
                 np.empty(n, dtype=np.int64))
        _run_tasks(_q.smooth_distance_tasks, n, SERIAL_BELOW["smooth"], tree,
                   np.ascontiguousarray(pts[P, :3]), *args, *point, 0)
        return P, point

    def primitive_distances(self, R=None, t=None, *, method="bvh"):
        """Per query primitive: ``(d_hat (m,), translation gradient (m, 3))``.

        ``method="brute"`` sums every data primitive (slow reference, ignores beta).
        """
        if method not in ("bvh", "brute"):
            raise ValueError(f"method must be 'bvh' or 'brute', got {method!r}")
        pts = self._primitive_coords(R, t)
        m = self.query.kind.size
        d = np.empty(m)
        g = np.empty((m, 3))
        nodes = np.empty(m, dtype=np.int64)
        leaves = np.empty(m, dtype=np.int64)
        if method == "brute":
            _mq.smooth_distance_primitives_brute(self.field.tree, self.query.kind, pts,
                                                 self.alpha, self.S, self.wgrad_scale, d, g)
            nodes[:] = 0
            leaves[:] = self.field.tree.kind.size
        else:
            # box_test off: far fields at the exact primitive-box distance
            kernel = self._distance_kernel if self.box_test else _mq.exact_box_primitive_tasks
            P, point = self._smooth_by_kind(pts, kernel, (d, g, nodes, leaves))
            if point:
                d[P], g[P], nodes[P], leaves[P] = point
        self.last_stats = (nodes, leaves)
        return d, g

    def __call__(self, R=None, t=None, *, method="bvh"):
        """Smooth distance ``d_hat(M_d, M_q)`` (float) and the paper's vertex gradients
        ``(n, 3)``: each primitive's translation gradient split equally among its vertices
        (their sum is the translation gradient; see :meth:`vertex_gradient` for per-vertex
        derivatives)."""
        d, g = self.primitive_distances(R, t, method=method)
        return split_to_vertices(d, g, self.query, self.alpha_q)

    def _box_test_on(self, what):
        if not self.box_test:
            raise ValueError(f"{what} needs box_test=True (box_test=False measures the "
                             "distance and translation gradient only)")

    def vertex_gradient(self, R=None, t=None, *, method="bvh"):
        """``(d_hat, G (n, 3))``: the smooth distance and its derivative with respect to each
        transformed query vertex moved on its own, for deformable query meshes.

        Calling the object returns the paper's equal split instead (Eq. 7-8), which is right
        for rigid translations only. Here each pair term moves with its own closest point on the
        query primitive (its barycentrics) and its weight follows the data-side closest point
        (:mod:`smoothdist._kernels.mesh_moment`). With ``gradient="exact"``, ``beta=0`` and
        ``tol=0`` this is the derivative of ``d_hat`` (checked against finite differences);
        Barnes-Hut and tol far fields are split equally among a primitive's vertices, and
        ``gradient="metric"`` divides the weights' part by alpha as everywhere. Its rows sum
        to the translation gradient ``G.sum(axis=0)`` of the call. Costs one traversal per
        vertex beyond the first of each primitive (about 2x a call for edges, 3x for
        triangles).
        """
        if method not in ("bvh", "brute"):
            raise ValueError(f"method must be 'bvh' or 'brute', got {method!r}")
        self._box_test_on("vertex_gradient")
        pts = self._primitive_coords(R, t)
        q = self.query
        m = q.kind.size
        d = np.empty(m)
        g = np.empty((m, 3))
        Gp = np.empty((m, 3, 3))
        if method == "brute":
            _mm.smooth_vertex_primitives_brute(self.field.tree, q.kind, pts, self.alpha,
                                               self.beta, self.S, self.wgrad_scale, d, g, Gp)
        else:
            P, point = self._smooth_by_kind(pts, _mm.smooth_vertex_primitive_tasks, (d, g, Gp))
            if point:
                d[P], g[P] = point[:2]
                Gp[P] = 0.0
                Gp[P, 0] = point[1]
        dmin = d.min()
        e = np.exp(-self.alpha_q * (d - dmin))
        w = e / e.sum()
        G = np.zeros((q.V.shape[0], 3))
        for c in range(3):
            used = q.kind >= c
            np.add.at(G, q.index[used, c], w[used, None] * Gp[used, c])
        return float(dmin - math.log(e.sum()) / self.alpha_q), G

    def primitive_moments(self, R=None, t=None, *, method="bvh"):
        """Per query primitive: ``(d_hat (m,), translation gradient (m, 3), moment (m, 3))``.

        ``d_hat`` and the gradient equal :meth:`primitive_distances`' bit for bit; the moment
        is the gradient of ``d_hat_j`` for a rotation of the primitive about its centroid
        (:mod:`smoothdist._kernels.mesh_moment`; 0 for points). Scene units, data frame.
        """
        if method not in ("bvh", "brute"):
            raise ValueError(f"method must be 'bvh' or 'brute', got {method!r}")
        self._box_test_on("primitive_moments")
        pts = self._primitive_coords(R, t)
        m = self.query.kind.size
        d = np.empty(m)
        g = np.empty((m, 3))
        mo = np.empty((m, 3))
        nodes = np.empty(m, dtype=np.int64)
        leaves = np.empty(m, dtype=np.int64)
        if method == "brute":
            _mm.smooth_moment_primitives_brute(self.field.tree, self.query.kind, pts, self.alpha,
                                               self.S, self.wgrad_scale, d, g, mo)
            nodes[:] = 0
            leaves[:] = self.field.tree.kind.size
        else:
            P, point = self._smooth_by_kind(pts, _mm.smooth_moment_primitive_tasks,
                                            (d, g, mo, nodes, leaves))
            if point:
                d[P], g[P], nodes[P], leaves[P] = point
                mo[P] = 0.0
        self.last_stats = (nodes, leaves)
        return d, g, mo

    def with_couple(self, R=None, t=None, *, method="bvh"):
        """``(d_hat, G (n, 3), C (3,))``: what calling the object returns, and the couple ``C``
        that makes its torque exact.

        For any point ``o``, the gradient of ``d_hat`` for a rotation of the query about ``o``
        is ``sum_k (x_k - o) x G_k + C`` (``x_k`` the transformed query vertices): the equal
        split's torque plus ``C = sum_j softmax_j M_j``, the primitives' moments about their
        centroids (:meth:`primitive_moments`). ``C = 0`` for point queries. Data frame.
        """
        d, g, mo = self.primitive_moments(R, t, method=method)
        dist, G = split_to_vertices(d, g, self.query, self.alpha_q)
        return dist, G, _softmax_sum(d, mo, self.alpha_q)

    def rigid_gradient(self, R=None, t=None, *, torques="exact", method="bvh"):
        """``(d_hat, force (3,), torque (3,))``: the gradient of ``d_hat`` for a translation of
        the query and for a rotation of it about ``t`` (its frame's origin), data frame.

        ``torques="exact"`` is the derivative of ``d_hat`` (:meth:`with_couple`); ``"split"``
        the paper's equal split (Eq. 7-8: each primitive's force at its centroid).
        """
        if torques not in TORQUES:
            raise ValueError(f"torques must be one of {TORQUES}, got {torques!r}")
        Rm, tv = as_rigid_transform(R, t)
        if torques == "exact":
            dist, G, C = self.with_couple(Rm, tv, method=method)
        else:
            dist, G = self(Rm, tv, method=method)
            C = np.zeros(3)
        X = self.transformed_vertices(Rm, tv) - tv
        return dist, G.sum(axis=0), np.cross(X, G).sum(axis=0) + C

    def exact(self, R=None, t=None):
        """Exact minimum pairwise distance (float) and its gradient ``(n, 3)``.

        The gradient is the unit vector from the data's closest point to the query's, split
        equally among the minimising query primitive's vertices (zero elsewhere).
        """
        X, pts = self._place(R, t)
        m = self.query.kind.size
        d = np.empty(m)
        g = np.empty((m, 3))
        prim = np.empty(m, dtype=np.int64)
        bound2 = np.inf
        if np.any(self.query.kind > 0):
            # the query's vertices give an upper bound of the minimum: primitives prune with it
            X = np.ascontiguousarray(X[self._used])
            if X.shape[0] < SERIAL_BELOW["exact"]:
                dv = float(_mq.nearest_vertex_distance(self.field.tree, X))
            else:
                dv = float(self.field.exact_distance(X)[0].min())
            bound2 = (dv * (1 + 1e-9)) ** 2 + 1e-300
        one_task, prange_loop = self._exact_kernels
        if m < SERIAL_BELOW["exact"]:
            one_task(self.field.tree, self.query.kind, pts, bound2, d, g, prim, 1, 0, 1)
        else:
            prange_loop(self.field.tree, self.query.kind, pts, bound2, d, g, prim,
                        parallel_tasks(m))
        j = int(np.argmin(d))
        G = np.zeros((self.num_query_vertices, 3))
        k = int(self.query.kind[j]) + 1
        for v in self.query.index[j, :k]:
            G[v] += g[j] / k
        return float(d[j]), G

    def translation_at_gap(self, gap, direction, start=(0.0, 0.0, 0.0), R=None):
        """The translation ``t = start + s u`` (``u`` the unit ``direction``, largest ``s >= 0``
        before the exact gap first reaches ``gap``) at which the exact gap equals ``gap``.

        Walks in steps no longer than the current gap minus ``gap`` (so it never jumps through
        thin data), then bisects to about 1e-12 relative. Useful to place a query mesh just off
        contact. ``gap`` in scene units (> 0); ``R`` the query's rotation (default identity).
        Raises ``ValueError`` when the query starts closer than ``gap`` or never gets closer.
        """
        gap = positive(gap, "gap")
        u = np.asarray(direction, dtype=np.float64).reshape(3)
        if not np.all(np.isfinite(u)) or np.linalg.norm(u) == 0.0:
            raise ValueError("direction must be a finite, non-zero 3-vector")
        u = u / np.linalg.norm(u)
        start = np.asarray(start, dtype=np.float64).reshape(3)
        at = lambda s: self.exact(R, start + s * u)[0]  # noqa: E731
        if at(0.0) <= gap:
            raise ValueError(f"the query starts closer than the gap {gap:g}")
        lo, hi = 0.0, None
        for _ in range(100000):
            step = at(lo) - gap
            if step < 1e-12 * max(1.0, lo):
                hi = lo + 1e-12 * max(1.0, lo)
                break
            if at(lo + step) <= gap:
                hi = lo + step
                break
            lo += step
            if lo > 1e6 * self.field.diagonal:
                break
        if hi is None:
            raise ValueError("the query never comes within the gap along that direction")
        for _ in range(80):
            mid = 0.5 * (lo + hi)
            if at(mid) > gap:
                lo = mid
            else:
                hi = mid
        return start + lo * u

    def __repr__(self):
        return (f"MeshDistance(data={self.field.mesh!r}, query: {self.num_query_vertices} "
                f"vertices, {self.num_query_primitives} primitives, alpha={self.alpha:g}, "
                f"alpha_q={self.alpha_q:g}, beta={self.beta:g})")


@numba.njit(**NJIT)
def _softmax_sum(d, mo, alpha_q):
    """``sum_j softmax_j mo[j]`` with ``softmax = exp(-alpha_q d) / sum`` (the couple)."""
    dmin = np.inf
    for j in range(d.size):
        dmin = min(dmin, d[j])
    s = 0.0
    cx = cy = cz = 0.0
    for j in range(d.size):
        e = math.exp(-alpha_q * (d[j] - dmin))
        s += e
        cx += e * mo[j, 0]
        cy += e * mo[j, 1]
        cz += e * mo[j, 2]
    out = np.empty(3)
    out[0] = cx / s
    out[1] = cy / s
    out[2] = cz / s
    return out


def split_to_vertices(d, g, query, alpha_q):
    """Combine per-primitive distances by LogSumExp (Eq. 6) and split gradients (Eq. 7-8).

    ``d (m,)``, ``g (m, 3)`` per query primitive; returns ``(d_hat float, G (n, 3))``.
    """
    G = np.empty((query.V.shape[0], 3))
    dist = _split(np.ascontiguousarray(d, dtype=np.float64),
                  np.ascontiguousarray(g, dtype=np.float64), query.kind, query.index,
                  float(alpha_q), G)
    return float(dist), G


def mesh_distance(V_data, F_data, V_query, F_query, *, alpha, alpha_q=None, beta=0.5,
                  alpha_u=None, gradient="exact", tol=DEFAULT_TOL):
    """Smooth distance between a query mesh and a data mesh (Madan & Levin 2022, Eq. 6-8).

    Parameters
    ----------
    V_data : (n, 3) array_like;  F_data : None, (m, 2) or (m, 3) array_like of int
    V_query : (k, 3) array_like; F_query : None, (l, 2) or (l, 3) array_like of int
    alpha, alpha_q, beta, alpha_u, gradient, tol
        As in :class:`MeshDistance`.

    Returns
    -------
    d : float
        The smooth distance (scene units), at most the exact minimum pairwise distance.
    grad_vertices : (k, 3) float64
        Its gradient with respect to every query vertex (the paper's equal split).
    """
    md = MeshDistance((V_data, F_data), (V_query, F_query), alpha=alpha, alpha_q=alpha_q,
                      beta=beta, alpha_u=alpha_u, gradient=gradient, tol=tol)
    return md()


def combine_distances(distances, alphas):
    """LogSumExp of several bodies' distances with the largest alpha (paper Sec. 3.6, 5.5).

    Parameters
    ----------
    distances : (k,) array_like of float
        Pairwise (smooth) distances between bodies.
    alphas : float or (k,) array_like of float
        Their sharpnesses; the combination uses ``max(alphas)``.

    Returns
    -------
    (d, weights)
        ``d = -(1/a) log sum_i exp(-a d_i)`` (shifted, finite) and the softmax ``weights (k,)``:
        the combined gradient of any variable is ``sum_i weights[i] * grad d_i``.
    """
    if np.iscomplexobj(distances) or np.iscomplexobj(alphas):
        raise ValueError("distances and alphas must be real numbers")
    D = np.asarray(distances, dtype=np.float64).ravel()
    if D.size == 0:
        raise ValueError("distances is empty")
    if not np.all(np.isfinite(D)):
        raise ValueError("distances contain NaN or infinite values")
    A = np.atleast_1d(np.asarray(alphas, dtype=np.float64)).ravel()
    if A.size == 0 or not np.all(np.isfinite(A)) or np.any(A <= 0):
        raise ValueError("alphas must be finite numbers > 0")
    if A.size not in (1, D.size):
        raise ValueError(f"alphas must be one number or one per distance: got {A.size} alphas "
                         f"for {D.size} distances")
    a = float(A.max())
    m = float(D.min())
    e = np.exp(-a * (D - m))
    s = float(e.sum())
    return m - math.log(s) / a, e / s


__all__ = ["MeshDistance", "QueryMesh", "as_query_mesh", "as_rigid_transform", "combine_distances",
           "mesh_distance", "split_to_vertices"]
