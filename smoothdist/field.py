"""The build-once object: a data mesh, its BVH, and batch queries against it."""

import copy
import hashlib
import math
from typing import NamedTuple

import numpy as np

from smoothdist import cuda
from smoothdist._cast import as_points, non_negative, positive
from smoothdist._kernels import query as _q
from smoothdist._kernels.bvh import build_tree, tree_with_weights
from smoothdist._kernels.exact_query import CHUNK as EXACT_CHUNK
from smoothdist._kernels.exact_query import GROUP, build_exact_tree, exact_tree_batch
from smoothdist._kernels.spacing import gap_probes, local_distances, smooth_of_local
from smoothdist.error_budget import Within, point_alpha, within
from smoothdist.junctions import check_weights
from smoothdist.connectivity import unique_sorted_rows
from smoothdist.mesh import as_data_mesh, triangle_normals
from smoothdist.query_order import coherent_order, scattered
from smoothdist.schedule import parallel_tasks, run_tasks

GRADIENTS = ("exact", "metric")
METHODS = ("bvh", "brute")

#: Smallest accepted ``alpha x L`` (``L`` the bounding-box diagonal, 1 for a single point).
#: Below it the blur ``1 / alpha`` is 1e12 times the data's size, and ``log(N) / alpha`` and
#: the metric gradient's ``1 / alpha**2`` would overflow float64 for tiny alpha.
MIN_ALPHA_SCALE = 1e-12

#: ``alpha="auto"`` aims at a mean surface offset of this fraction of the bbox diagonal (the
#: promise is 2 %; see :meth:`SmoothDistanceField.auto_alpha`)
AUTO_OFFSET = 0.01
#: probe points used to estimate the offset for ``alpha="auto"``
AUTO_PROBES = 256
#: point clouds, ``alpha="auto"``: gaps are probed around this many sampled points, between
#: neighbours within this many median spacings, and the closing alpha is bisected in this
#: many steps (to within 2 ** (1 / 2 ** steps), 4 % for 4); see
#: :meth:`SmoothDistanceField.closing_alpha`
AUTO_GAP_SAMPLES = 2000
AUTO_GAP_RADIUS = 8.0
AUTO_GAP_STEPS = 4
#: ... and this fraction of the gaps probed may stay open (a scan's widest few: real holes)
AUTO_GAP_OPEN = 5e-4
#: the renderer's automatic surface of a random sample (a point cloud whose nearest-neighbour
#: distances spread more than ``AUTO_RANDOM_SPREAD``, their standard deviation over their
#: mean: about 0.5 for uniform random samples of a surface, 0.9 of a curve, 0.3 for a scan,
#: at most 0.16 for even samples and mesh vertices) with junction (area) weights takes
#: ``AUTO_CLOUD_MARGIN`` of :meth:`SmoothDistanceField.auto_alpha` where that smooths over less
#: than ``AUTO_OFFSET`` of the diagonal (``1 / alpha``: a cloud dense for its size; a sparse
#: one, 200 points on a torus, would close its hole): the relief the random spacing leaves,
#: once the weights have evened the clumps, is smoothed over a longer scale
#: (``box_points_100k`` in ``benchmarks/data/fidelity.json``: its normals against its faces)
AUTO_CLOUD_MARGIN = 0.8
AUTO_RANDOM_SPREAD = 0.4
#: ``alpha_u="auto"`` is this times alpha (see :meth:`SmoothDistanceField.auto_alpha_u`)
AUTO_ALPHA_U_FACTOR = 20.0
#: the renderer's automatic surface of edges and triangles (issue 35,
#: :meth:`SmoothDistanceField.auto_surface`): the level ``d_hat = C`` with ``C`` this many mean
#: edge lengths ...
AUTO_SURFACE_SPACINGS = 0.75
#: ... but at most this fraction of the bbox diagonal (a box of 12 triangles) ...
AUTO_SURFACE_MAX = 0.08
#: ... and, when there are edges, at least this fraction of it (a tube of a finely sampled
#: curve stays as thick as ``alpha="auto"``'s zero set made it) ...
AUTO_SURFACE_MIN_TUBE = 0.01
#: ... at ``alpha = AUTO_SURFACE_SHARPNESS / C``, without attenuation ...
AUTO_SURFACE_SHARPNESS = 6.0
#: ... or ``AUTO_FLAT_SHARPNESS / C`` where ``alpha`` would exceed ``AUTO_ISOLATED_EDGES``
#: over the mean edge length (``C`` capped: a few large facets, a box of 12 triangles). The
#: terms of neighbouring facets then no longer overlap into a smooth sum: each edge between
#: coplanar facets raises a ridge whose slope falls like ``1 / sqrt(alpha C)``
AUTO_ISOLATED_EDGES = 16.0
AUTO_FLAT_SHARPNESS = 14.0
#: surfaces (the data has triangles; issue 46): the level ``d_hat = C`` hugs the mesh, with
#: ``C`` at most this fraction of the bbox diagonal (a silhouette grows by ``2 C``: a sphere's
#: IoU against the mesh itself stays above 0.95) ...
AUTO_SHELL_MAX = 0.003
#: ... and at most this fraction of the data's local feature size
#: (:meth:`SmoothDistanceField.feature_sizes`:
#: half the thickness of a plate, half the width of a gap between parts), taken at this
#: percentile of the surface (thin parts of a shape keep their thickness within 10 %) ...
AUTO_SHELL_FEATURE = 0.1
AUTO_SHELL_PERCENTILE = 25.0
#: ... but not below this fraction of the diagonal (5 hit tolerances) ...
AUTO_SHELL_MIN = 0.0005
#: ... at ``alpha = AUTO_SHELL_SHARPNESS / C`` without attenuation: the smooth surface then
#: lies within ``log(m) / alpha`` of the exact one (``m`` facets meeting: ridges along the
#: mesh's edges about 3 % of ``C`` high, the facets' own shading), ``C`` from the data
AUTO_SHELL_SHARPNESS = 20.0
#: surface points sampled by :meth:`SmoothDistanceField.feature_sizes`, and the steps of its
#: shrinking balls
AUTO_FEATURE_SAMPLES = 400
AUTO_FEATURE_STEPS = 16
#: a net of edges (the wireframe of a surface: vertices of more than ``AUTO_WIRE_DEGREE``
#: edges on average) is drawn as wires of radius ``AUTO_WIRE_RADIUS`` mean edge lengths, so
#: that it stays a net (0.75 closed it into a ribbed surface), at ``alpha =
#: AUTO_WIRE_SHARPNESS / C``: the joints of straight wires bulge by about ``log(degree) /
#: alpha``, 5 % of the radius at this sharpness (``renders/ripple/sharpness_wire.csv``)
AUTO_WIRE_DEGREE = 2.5
AUTO_WIRE_RADIUS = 0.1
AUTO_WIRE_SHARPNESS = 30.0
#: how many data sets' ``auto_alpha`` values are remembered by content (a key and a float each;
#: the search costs seconds on a 100k-point cloud, a key a hash of the arrays, ~1 ms per MB)
AUTO_CACHE_SIZE = 64
_AUTO_ALPHA_CACHE = {}


def _data_key(field):
    """A key for what ``auto_alpha`` depends on: the vertex and primitive arrays (a BLAKE2
    digest of their bytes, shapes and dtypes), the tree's leaf size and the weight scheme."""
    m = field.mesh
    h = hashlib.blake2b(digest_size=20)
    for a in (m.V, m.points, m.edges, m.triangles):
        a = np.ascontiguousarray(a)
        h.update(str((a.shape, a.dtype.str)).encode())
        h.update(a.data)
    return h.hexdigest(), field.leaf_size, field.weights
#: :meth:`SmoothDistanceField.exact_distance` switches to :attr:`SmoothDistanceField.exact_tree`
#: once it has answered this many queries per primitive (its build costs about as much as
#: one or two exact queries per primitive save)
EXACT_TREE_AFTER = 1.0
#: batches of at most this many queries (``smooth_distance`` without ``tol``, ``exact_distance``
#: on the BVH) run as serial task kernels from Python threads
#: (``smoothdist._kernels.query.*_tasks``: about half the compile time of a ``prange`` kernel, which
#: a fresh install's first call pays); larger batches use the ``prange`` kernels (``*_batch``). The
#: same values either way.
TASK_BATCH = 1 << 14

#: ``order`` argument of :func:`~smoothdist._kernels.exact_query.exact_tree_batch`: the
#: queries' own order
_NO_ORDER = np.empty(0, dtype=np.int64)


class SmoothDistanceResult(NamedTuple):
    """``distance (q,) float64`` and ``gradient (q, 3) float64``."""

    distance: np.ndarray
    gradient: np.ndarray


class QueryStats(NamedTuple):
    """Per-query traversal statistics, ``(q,)`` int64 each.

    ``leaves_visited`` counts exact primitive evaluations plus Barnes-Hut far-field nodes.
    """

    nodes_visited: np.ndarray
    leaves_visited: np.ndarray


class ExactDistanceResult(NamedTuple):
    """``distance (q,)``, unit ``gradient (q, 3)`` and ``closest`` primitive index ``(q,)``."""

    distance: np.ndarray
    gradient: np.ndarray
    closest: np.ndarray


class SmoothDistanceField:
    """A data mesh with its BVH, answering smooth and exact distance queries.

    Parameters
    ----------
    mesh : DataMesh, (n, 3) array_like, or a trimesh / pyvista object
        The data mesh, or vertex positions (then ``F`` as in :class:`~smoothdist.DataMesh`), or a
        ``trimesh.Trimesh`` / ``PointCloud`` / ``path.Path3D`` or ``pyvista.PolyData``
        (converted by :func:`smoothdist.mesh.as_data_mesh`).
    F : (m, k) array_like of int, optional
        Primitives when ``mesh`` is a vertex array.
    leaf_size : int
        Primitives per BVH leaf.
    progress : callable(done, total, elapsed_s), optional
        Reports the BVH build (see :func:`smoothdist._kernels.bvh.build_tree`), for very large data.
    weights : {"paper", "inclusion-exclusion"}
        The weights of edges and triangles: the paper's polynomials (Sec. 3.3, App. C; the
        default), or inclusion-exclusion over the junctions (:mod:`smoothdist.junctions`):
        the exact distance's sum above flat faces and outside convex edges and corners (no
        groove along the internal edges of a flat face), for ``alpha`` large against the
        edges. :meth:`with_weights` switches an existing field. Point clouds: no difference.

    Notes
    -----
    Distances are unsigned and in scene units. The smooth distance ``d_hat`` (Madan & Levin
    2022, Eq. 3) with ``beta = 0`` satisfies ``d - log(A**S * N) / alpha <= d_hat <= d`` with
    ``d`` the exact distance, ``N`` the number of primitives and ``A`` :attr:`weight_bound`.
    Barnes-Hut (``beta > 0``) only lowers it: ``d_hat_beta <= d_hat_0``, and since a far-field
    term sits at most a factor ``1 + beta`` closer than the primitives it replaces,
    ``d / (1 + beta) - log(A**S * N) / alpha <= d_hat_beta``.

    Examples
    --------
    >>> import numpy as np
    >>> field = SmoothDistanceField(np.array([[0., 0, 0], [1, 0, 0]]))
    >>> d, g = field.smooth_distance([[0.5, 1, 0]], alpha=10.0, beta=0.0)
    >>> bool(d[0] < 1.118)
    True
    """

    def __init__(self, mesh, F=None, *, leaf_size=1, progress=None, weights="paper",
                 **mesh_kwargs):
        check_weights(weights)
        mesh = as_data_mesh(mesh, F, **mesh_kwargs)
        if (isinstance(leaf_size, bool) or not isinstance(leaf_size, (int, np.integer))
                or leaf_size < 1):
            raise ValueError(f"leaf_size must be an integer >= 1, got {leaf_size!r}")
        self.mesh = mesh
        self.leaf_size = int(leaf_size)
        self.weights = weights
        self.tree = build_tree(mesh, leaf_size=self.leaf_size, progress=progress,
                               weights=weights)

    def with_weights(self, weights):
        """This field with the weight scheme ``weights`` (``"paper"`` or
        ``"inclusion-exclusion"``, see the class notes): ``self`` when it already has it,
        otherwise a new field that shares the mesh, the tree's nodes and corners and the
        exact-distance tree (cheap: the weight arrays only)."""
        if check_weights(weights) == self.weights:
            return self
        out = copy.copy(self)
        # not the GPU's copy of the tree, nor the automatic parameters (the weights move them)
        out.__dict__ = {k: v for k, v in self.__dict__.items()
                        if k != "_cuda_tree" and not k.startswith("_auto_")}
        out.tree = tree_with_weights(self.tree, self.mesh, weights)
        out.weights = weights
        return out

    # ------------------------------------------------------------------ properties
    @property
    def num_primitives(self):
        """Number of primitives ``N``."""
        return int(self.tree.kind.size)

    @property
    def exact_tree(self):
        """The :class:`~smoothdist._kernels.exact_query.ExactTree` that answers exact distance
        queries.

        Built on first access and kept (binned SAH, leaves of up to 4 primitives; about
        1.5 us and 170 bytes per triangle, 70 per point, see
        :mod:`smoothdist._kernels.exact_query`). :meth:`exact_distance` builds it once its calls
        have asked for ``EXACT_TREE_AFTER`` queries per primitive (the build then pays for
        itself) and searches the smooth-distance tree with
        :func:`smoothdist._kernels.query.exact_distance_point` until then. The smooth kernels never
        use it.
        """
        et = self.__dict__.get("_exact_tree")
        if et is None:
            et = self._exact_tree = build_exact_tree(self.tree)
        return et

    @property
    def bounds(self):
        """``(lo, hi)``: bounding box of the data, two (3,) float64 arrays."""
        return self.tree.lo[0].copy(), self.tree.hi[0].copy()

    @property
    def diagonal(self):
        """Bounding-box diagonal length (scene units)."""
        return float(self.tree.diag[0])

    @property
    def weight_bound(self):
        """``A``: the largest raw weight of any primitive (>= 1; 1 for point clouds)."""
        return float(self.tree.whi[0])

    def check_alpha(self, alpha, name="alpha"):
        """Return ``alpha`` as a float after validating it for this data.

        It must be a finite number > 0 with ``alpha x diagonal >= MIN_ALPHA_SCALE`` (the
        diagonal counts as 1 for a single point); raises ``ValueError`` otherwise. Any larger
        alpha is accepted (the smooth distance then tends to the exact distance).
        """
        alpha = positive(alpha, name)
        L = self.diagonal if self.diagonal > 0 else 1.0
        if alpha * L < MIN_ALPHA_SCALE:
            raise ValueError(f"{name}={alpha:g} is too small for data of size {L:.4g}: "
                             f"{name} x bbox diagonal must be >= {MIN_ALPHA_SCALE:g}")
        return alpha

    def attenuation(self, alpha, alpha_u=None):
        """``S = min(alpha / alpha_u, 1)`` (1 when ``alpha_u`` is None)."""
        alpha = self.check_alpha(alpha)
        if alpha_u is None:
            return 1.0
        if isinstance(alpha_u, str) and alpha_u == "auto":
            alpha_u = self.auto_alpha_u(alpha)
        return min(alpha / positive(alpha_u, "alpha_u"), 1.0)

    def inflation(self, alpha, alpha_u=None):
        """Largest possible gap ``d - d_hat = log(A**S * N) / alpha`` (scene units)."""
        S = self.attenuation(alpha, alpha_u)
        return (S * math.log(self.weight_bound) + math.log(self.num_primitives)) / float(alpha)

    def auto_alpha(self):
        """``alpha="auto"``: the smallest alpha whose surface lies close to the data.

        Promise (tested on every shipped mesh, curve and point cloud, and on a unit
        icosphere): the isosurface ``d_hat = 0`` at this alpha, with ``alpha_u="auto"`` and
        ``beta <= 0.5``, lies on average at most 2 % of the bounding-box diagonal from the
        data, and point clouds still close into one surface. For point clouds closure comes
        first: the offset is about 3-4 median spacings, so the 2 % holds for clouds whose
        spacing is at most 0.5 % of the diagonal (scans; not the vertices of a coarse mesh).

        How: the smooth surface sits where the exact distance ``d`` equals the gap
        ``d - d_hat``, which varies slowly near the data. We place ``AUTO_PROBES`` probe
        points at exact distance ``AUTO_OFFSET x diagonal`` from random spots on random
        primitives and take the smallest alpha at which their mean gap is at most that
        distance (:meth:`offset_estimate`; a few secant steps in ``log alpha``, since the
        gap scales like ``1 / alpha``). Smaller alphas give smoother surfaces, so the
        smallest one that meets the target is chosen. Point clouds are capped at
        :meth:`paper_alpha` ``= 1 / median spacing``, beyond which neighbouring blobs stop
        merging into one surface, and then lowered until the widest gaps between sampled
        points are closed too (:meth:`closing_alpha`: random samples of a surface have gaps
        several median spacings wide). The result is cached, on the field and by the data's
        content (``_data_key``), so a second field of the same data (a second
        ``render_mesh`` of the same file, another view) does not search again.
        """
        cached = getattr(self, "_auto_alpha_value", None)
        if cached is not None:
            return cached
        key = _data_key(self)
        if key in _AUTO_ALPHA_CACHE:
            self._auto_alpha_value = _AUTO_ALPHA_CACHE[key]
            return self._auto_alpha_value
        L = self.diagonal
        if not L > 0:
            value = self.paper_alpha()
        else:
            target = AUTO_OFFSET * L
            probes, dist = self._offset_probes(target)
            alpha = 2.0 / target
            for _ in range(12):
                ratio = self.offset_estimate(alpha, probes=(probes, dist)) / target
                if 0.9 <= ratio <= 1.0:
                    break
                alpha *= ratio if ratio > 1.0 else max(ratio, 0.25) * 1.05
            for _ in range(100):  # the gap falls like 1 / alpha: a few steps at most
                if self.offset_estimate(alpha, probes=(probes, dist)) <= target:
                    break
                alpha *= 1.1
            value = float(alpha)
            if self.mesh.points.size >= 2:
                value = self.closing_alpha(min(value, 1.0 / self.point_spacing()))
        self._auto_alpha_value = value
        while len(_AUTO_ALPHA_CACHE) >= AUTO_CACHE_SIZE:
            _AUTO_ALPHA_CACHE.pop(next(iter(_AUTO_ALPHA_CACHE)))   # the oldest
        _AUTO_ALPHA_CACHE[key] = value
        return value

    def closing_alpha(self, alpha, samples=AUTO_GAP_SAMPLES, seed=0):
        """The largest alpha ``<= alpha`` at which a point cloud's gaps are closed.

        Probes are the centres of the gaps (local maxima of the distance to the cloud, the
        circumcentres of empty non-obtuse triangles) between up to ``samples`` sampled points
        and their neighbours within ``AUTO_GAP_RADIUS`` median spacings
        (:func:`smoothdist._kernels.spacing.gap_probes`); the cloud is closed at an alpha where
        ``d_hat <= 0`` (beta 0.5, ``alpha_u="auto"``) at every probe. ``alpha`` itself when
        it closes them, else a bisection in ``log alpha`` (``d_hat`` falls with alpha, so
        the closed alphas are an interval). A random sample of a surface needs about 0.6-0.8
        of ``1 / median spacing``: its widest gaps are 2-3 median spacings across, where an
        even sample's are 1.5-2. Meshes without points: ``alpha``.
        """
        pts = self.mesh.V[self.mesh.points]
        if pts.shape[0] < 3:
            return float(alpha)
        rng = np.random.default_rng(seed)
        pick = pts if pts.shape[0] <= samples else pts[rng.choice(pts.shape[0], samples,
                                                                   replace=False)]
        probes, radii = gap_probes(self.tree, np.ascontiguousarray(pick),
                                   AUTO_GAP_RADIUS * self.point_spacing())
        if probes.shape[0]:  # gap centres: no sample closer than the triangle's corners
            probes = probes[_exact_bvh(self.tree, probes)[0] >= (1.0 - 1e-9) * radii]

        # the probes' neighbours once; each alpha of the search sums their terms again
        local = local_distances(self.tree, probes, AUTO_GAP_RADIUS * self.point_spacing())

        def closed(a):
            return bool(np.mean(smooth_of_local(local, a) > 0.0) <= AUTO_GAP_OPEN)

        hi = float(alpha)
        if probes.shape[0] == 0 or closed(hi):
            return hi
        lo = hi
        for _ in range(20):
            lo *= 0.5
            if closed(lo):
                break
        else:
            return lo
        for _ in range(AUTO_GAP_STEPS):  # keep lo closed, hi open
            mid = math.sqrt(lo * hi)
            lo, hi = (mid, hi) if closed(mid) else (lo, mid)
        return lo

    def mean_edge_length(self):
        """Mean length of the distinct edges of the edges and triangles (None for a point
        cloud)."""
        m = self.mesh
        E = m.distinct_edges()
        if E.shape[0] == 0:
            return None
        return float(np.mean(np.linalg.norm(m.V[E[:, 1]] - m.V[E[:, 0]], axis=1)))

    def is_wire_net(self):
        """Edges only, and their vertices join more than ``AUTO_WIRE_DEGREE`` edges on
        average: the wireframe of a surface rather than curves (polylines, trees and
        networks join 2, a few 3)."""
        m = self.mesh
        if not m.edges.size or m.triangles.size or m.points.size:
            return False
        E = unique_sorted_rows(np.sort(m.edges, axis=1), m.V.shape[0])
        deg = np.bincount(E.ravel())
        return float(deg[deg > 0].mean()) > AUTO_WIRE_DEGREE

    def auto_surface(self):
        """The renderer's automatic ``(alpha, alpha_u, offset)``: what ``alpha``,
        ``alpha_u`` and the smooth offset left to ``"auto"`` render (issues 35 and 46).

        Meshes with triangles (and no points): a thin shell around the mesh itself, the level
        set ``d_hat = C`` with ``C = min(AUTO_SHELL_MAX x diagonal, AUTO_SHELL_FEATURE x f)``
        (0.3 % of the diagonal, or a tenth of ``f``, the 25th percentile of the local feature
        size of :meth:`feature_sizes`: half a thin plate's thickness, half a narrow gap's
        width), at least ``AUTO_SHELL_MIN x diagonal``, with edges too at least
        ``AUTO_SURFACE_MIN_TUBE x diagonal``; ``alpha = AUTO_SHELL_SHARPNESS / C`` (20) and
        no attenuation (``alpha_u = alpha``). Thin parts stay thin, holes open, and the
        surface follows the exact offset surface of the data closely (no ribs or scallops
        between facets: a coarse mesh shows its facets, as the mesh itself does);
        ``benchmarks/bench_fidelity.py`` measures it on a corpus of shapes.

        Edges alone (curves): a tube, the level set ``d_hat = C`` with
        ``C = min(AUTO_SURFACE_SPACINGS x mean edge length, AUTO_SURFACE_MAX x diagonal)``
        (0.75 edge lengths, at most 8 % of the diagonal) and at least
        ``AUTO_SURFACE_MIN_TUBE x diagonal`` (1 %: the tube's radius); the wireframe of a
        surface, :meth:`is_wire_net`, ``AUTO_WIRE_RADIUS`` = 0.1 edge lengths: wires;
        ``alpha = AUTO_SURFACE_SHARPNESS / C`` (6; 14 where that would exceed 16 over the
        mean edge length; 30 for wires), no attenuation. The zero set of ``d_hat`` runs in a
        groove along every edge (rings on a tube); the level set about one edge length out is
        as smooth as the exact tube (``renders/ripple/auto.csv``).

        Point clouds and meshes with points: :meth:`auto_alpha` (times
        ``AUTO_CLOUD_MARGIN`` for a random sample, :meth:`spacing_spread`, dense for its size,
        ``1 / alpha`` below ``AUTO_OFFSET`` of the diagonal, with junction weights, whose
        points carry area weights),
        :meth:`auto_alpha_u` and offset 0 (a cloud's surface is the smooth one that closes
        it). The result is cached.
        """
        cached = getattr(self, "_auto_surface_value", None)
        if cached is not None:
            return cached
        m = self.mesh
        # the shell of a mesh of triangles does not use the mean edge length (and its edges,
        # repaired, have positive lengths): not measured (0.35 s at 1M triangles)
        shell = bool(m.triangles.size) and not m.points.size
        h = None if shell else self.mean_edge_length()
        L = self.diagonal
        value = None
        if m.points.size or not (shell or (h is not None and h > 0)) or not L > 0:
            alpha = self.auto_alpha()
            if (self.weights != "paper" and alpha * L * AUTO_OFFSET > 1.0
                    and self.spacing_spread() > AUTO_RANDOM_SPREAD):
                alpha *= AUTO_CLOUD_MARGIN
            value = (alpha, self.auto_alpha_u(alpha), 0.0)
        elif self.is_wire_net():
            C = AUTO_WIRE_RADIUS * h
            alpha = AUTO_WIRE_SHARPNESS / C
        elif self.mesh.triangles.size:
            f = np.percentile(self.feature_sizes(), AUTO_SHELL_PERCENTILE)
            C = max(min(AUTO_SHELL_MAX * L, AUTO_SHELL_FEATURE * f), AUTO_SHELL_MIN * L)
            if self.mesh.edges.size:
                C = max(C, AUTO_SURFACE_MIN_TUBE * L)
            alpha = AUTO_SHELL_SHARPNESS / C
        else:
            C = max(min(AUTO_SURFACE_SPACINGS * h, AUTO_SURFACE_MAX * L),
                    AUTO_SURFACE_MIN_TUBE * L)
            alpha = AUTO_SURFACE_SHARPNESS / C
            if alpha * h > AUTO_ISOLATED_EDGES:
                alpha = AUTO_FLAT_SHARPNESS / C
        if value is None:
            value = (float(alpha), float(alpha), float(C))
        self._auto_surface_value = value
        return value

    def feature_sizes(self, count=AUTO_FEATURE_SAMPLES, seed=0):
        """Local feature size at ``count`` random points of the triangles (area-weighted):
        for each, the radius of the largest empty ball touching the surface there, on the
        smaller of its two sides (scene units, ``(count,)`` float64, at most the diagonal).

        Half the thickness of a plate or a thin part, half the width of a gap or a hole
        between parts, the radius of curvature of a curved surface; near a sharp edge, the
        distance to it. Shrinking balls: a ball of radius ``r`` tangent at ``p`` whose
        nearest surface point ``q`` (exact distance on this field's tree) lies inside is
        replaced by the ball through ``p`` and ``q``, ``r = |p - q|^2 / (2 (p - q) . n)``,
        ``AUTO_FEATURE_STEPS`` times at most. Triangles only (0 data: ``(0,)``).
        """
        m = self.mesh
        if m.triangles.shape[0] == 0:
            return np.empty(0)
        cr = triangle_normals(m.V, m.triangles)
        area = np.linalg.norm(cr, axis=1)
        ok = area > 0
        if not ok.any():
            return np.empty(0)
        rng = np.random.default_rng(seed)
        pick = rng.choice(np.flatnonzero(ok), count, p=area[ok] / area[ok].sum())
        u, v = rng.random((2, count))
        flip = u + v > 1.0
        u[flip], v[flip] = 1.0 - u[flip], 1.0 - v[flip]
        t = m.V[m.triangles[pick]]
        P = t[:, 0] + u[:, None] * (t[:, 1] - t[:, 0]) + v[:, None] * (t[:, 2] - t[:, 0])
        n = cr[pick] / area[pick, None]
        P, n = np.concatenate([P, P]), np.concatenate([n, -n])    # both sides
        L = max(self.diagonal, 1e-300)
        r = np.full(P.shape[0], L)
        live = np.ones(P.shape[0], dtype=bool)
        for _ in range(AUTO_FEATURE_STEPS):
            c = np.ascontiguousarray(P[live] - r[live, None] * n[live])
            d, g = _exact_bvh(self.tree, c)
            w = P[live] - (c - d[:, None] * g)                     # p - q
            wn = np.einsum("ij,ij->i", w, n[live])
            inside = (d < (1.0 - 1e-6) * r[live]) & (wn > 0.0)
            new = np.where(inside, np.einsum("ij,ij->i", w, w) / (2.0 * np.where(
                inside, wn, 1.0)), r[live])
            idx = np.flatnonzero(live)
            r[idx] = np.minimum(r[idx], new)
            live[idx[~inside]] = False
            if not live.any():
                break
        r = np.minimum(r[:count], r[count:])
        return np.maximum(r, 0.0)

    def auto_alpha_u(self, alpha):
        """``alpha_u="auto"``: ``AUTO_ALPHA_U_FACTOR x alpha`` (attenuation ``S = 1/20``).

        Tested promise: on a straight polyline of edge length ``h`` the tube's radius ripples
        by at most 1 % of its mean for ``alpha h <= 1.5`` (without attenuation, 13 % at
        ``alpha h = 1`` and 22 % at 1.5: the "ribbing" at the edge spacing). A point cloud
        (points only): ``alpha`` itself, no attenuation; its points have no weight function to
        attenuate, and with junction weights their area weights
        (:func:`smoothdist._kernels.spacing.area_weights`) act at full strength.
        """
        m = self.mesh
        if m.points.size and not (m.edges.size or m.triangles.size):
            return float(alpha)
        return AUTO_ALPHA_U_FACTOR * float(alpha)

    def paper_alpha(self):
        """The paper's alpha heuristic (Sec. 4.3), made scale-aware for point clouds.

        Edges and triangles: ``1 / (shortest edge length)``, as the paper suggests. Points: the
        paper's "100 x bbox diagonal" is not scale invariant, so we use
        ``1 / (median nearest-neighbour spacing)`` of up to 2000 sampled points: two points
        ``h`` apart give ``d_hat <= 0`` half-way between them while ``alpha <= 2 log 2 / h``,
        so at this alpha neighbouring blobs merge into a closed surface; it gives 352 for the
        bunny's vertices, close to the paper's 200. (This was ``"auto"`` before; on small
        meshes it inflates the surface by a large fraction of their size.)
        """
        e = self.mesh.min_edge_length()
        if e is not None:
            return 1.0 / e
        return 1.0 / self.point_spacing()

    def _offset_probes(self, target, count=None, seed=0):
        """Probe points at exact distance about ``target`` from random spots of the data.

        The exact distances search the smooth-distance tree (these few hundred probes are not
        the caller's queries: they neither count towards :attr:`exact_tree`'s build nor
        compile its kernels). Returns ``(probes (k, 3), exact distance (k,))``.
        """
        count = count or AUTO_PROBES
        rng = np.random.default_rng(seed)
        m = self.mesh
        n_p, n_e = m.points.size, m.edges.shape[0]
        pick = rng.integers(0, m.num_primitives, count)
        spots = np.empty((count, 3))
        for k, i in enumerate(pick):
            if i < n_p:
                spots[k] = m.V[m.points[i]]
            elif i < n_p + n_e:
                a, b = m.V[m.edges[i - n_p]]
                spots[k] = a + rng.random() * (b - a)
            else:
                a, b, c = m.V[m.triangles[i - n_p - n_e]]
                u, v = rng.random(2)
                if u + v > 1.0:
                    u, v = 1.0 - u, 1.0 - v
                spots[k] = a + u * (b - a) + v * (c - a)
        dirs = rng.normal(size=(count, 3))
        dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
        q = spots + target * dirs
        d, g = _exact_bvh(self.tree, q)
        ok = d > 1e-9 * target
        q = np.ascontiguousarray((q - d[:, None] * g)[ok] + target * g[ok])  # closest + outward
        return q, _exact_bvh(self.tree, q)[0]

    def offset_estimate(self, alpha, alpha_u="auto", beta=0.5, probes=None):
        """Estimated mean offset of the surface ``d_hat = 0`` from the data (scene units).

        The mean gap ``d - d_hat`` over probe points at exact distance about
        ``AUTO_OFFSET x diagonal`` from the data (see :meth:`auto_alpha`).
        """
        if probes is None:
            probes = self._offset_probes(AUTO_OFFSET * max(self.diagonal, 1e-300))
        q, d = probes
        dh = self.smooth_distance(q, alpha=alpha, beta=beta, alpha_u=alpha_u).distance
        return float(np.mean(d - dh))

    def point_spacing(self, samples=2000, seed=0):
        """Median distance from a point primitive to its nearest other point (scene units)."""
        d = self._nearest_distances(samples, seed)
        return float(np.median(d)) if d.size else max(self.diagonal, 1.0)

    def spacing_spread(self, samples=2000, seed=0):
        """How uneven a point cloud's spacing is: the standard deviation of the distances from
        its points to their nearest other points over their mean (0 for a grid, about 0.5 for
        a uniform random sample of a surface; 0 with fewer than two points)."""
        d = self._nearest_distances(samples, seed)
        return float(np.std(d) / np.mean(d)) if d.size else 0.0

    def _nearest_distances(self, samples, seed):
        """Nearest-other-point distances (> 0) of up to ``samples`` sampled point primitives."""
        pts = self.mesh.V[self.mesh.points]
        if pts.shape[0] < 2:
            return np.empty(0)
        rng = np.random.default_rng(seed)
        pick = pts if pts.shape[0] <= samples else pts[rng.choice(pts.shape[0], samples,
                                                                   replace=False)]
        d = _nearest_other(self.tree, np.ascontiguousarray(pick))
        return d[np.isfinite(d) & (d > 0)]

    # ------------------------------------------------------------------ queries
    def smooth_distance(self, Q, *, alpha, beta=0.5, alpha_u=None, gradient="exact",
                        method="bvh", return_stats=False, tol=_q.DEFAULT_TOL, device=None):
        """Smooth distance ``d_hat`` (Eq. 3) and its gradient at query points.

        Parameters
        ----------
        Q : (q, 3) array_like of float, or a (q, 3) float64 array on the GPU
            Query points (a single (3,) point is accepted). An array on the GPU (any object
            with ``__cuda_array_interface__``: CuPy, PyTorch, numba) is read there, and the
            results are numba device arrays (:mod:`smoothdist.cuda`): no host copies.
        alpha : float, "auto" or :func:`smoothdist.within`
            LogSumExp sharpness in 1 / scene units (> 0). ``"auto"``: :meth:`auto_alpha`.
            ``within(e)``: :meth:`alpha_within` for this beta and alpha_u (the smooth distance
            at most ``e`` below the exact one wherever that is ``<= e``; needs ``tol=0``).
        beta : float
            Barnes-Hut parameter (>= 0); 0 evaluates every term exactly.
        alpha_u : float or "auto", optional
            ``alpha_U`` for weight attenuation ``S = min(alpha / alpha_U, 1)``; None: S = 1;
            ``"auto"``: :meth:`auto_alpha_u` (20 x alpha, no ribbing on tubes).
        gradient : {"exact", "metric"}
            ``"exact"`` (default) is the derivative of ``d_hat`` (what a solver's line search
            needs). ``"metric"`` is the paper's alpha-metric weight gradient (Sec. 3.3): the
            weights' term divided by alpha once more, smoother for shading but not the
            derivative for edges and triangles (at alpha 20 about 10 % off central
            differences); the two agree for point clouds and at alpha = 1.
        method : {"bvh", "brute"}
            ``"brute"`` sums every primitive without the tree (slow reference; ignores beta).
        return_stats : bool
            Also return :class:`QueryStats`.
        tol : float
            Tolerance-controlled pruning (>= 0; 0 = off): visit nodes nearest-first and
            replace a subtree by its conservative far field only while the far fields accepted
            so far stay below ``tol`` times the exact part of the sum. With ``beta=0``,
            ``d_hat_0 - log(1 + tol) / alpha <= d_hat <= d_hat_0`` (error at most
            ``tol / alpha``; proof in :func:`smoothdist._kernels.query.smooth_distance_point_tol`).
        device : {"cpu", "cuda"}, optional
            ``"cuda"``: evaluate on the GPU (:mod:`smoothdist.cuda`; needs the ``gpu`` extra
            and a GPU, or numba's simulator), the same kernel code; ``method="bvh"`` only.
            Default: ``"cuda"`` for queries on the GPU, ``"cpu"`` otherwise.

        Returns
        -------
        SmoothDistanceResult ``(distance (q,), gradient (q, 3))``, plus :class:`QueryStats`
        when ``return_stats``.
        """
        beta = non_negative(beta, "beta")
        tol = non_negative(tol, "tol")
        alpha = self.check_alpha(self._resolve_alpha(alpha, beta, alpha_u, tol))
        S = self.attenuation(alpha, alpha_u)
        if gradient not in GRADIENTS:
            raise ValueError(f"gradient must be one of {GRADIENTS}, got {gradient!r}")
        if method not in METHODS:
            raise ValueError(f"method must be one of {METHODS}, got {method!r}")
        device, Q = _device_and_points(device, Q, method)
        wgrad_scale = 1.0 / alpha if gradient == "exact" else 1.0 / (alpha * alpha)
        if device == "cuda":
            d, g, nodes, leaves = cuda.smooth_distance(self.tree, Q, alpha, beta, S, wgrad_scale,
                                                       tol, self.device_tree())
            res = SmoothDistanceResult(d, g)
            return (d, g, QueryStats(nodes, leaves)) if return_stats else res
        out = _outputs(Q.shape[0], return_stats)
        for part, rows in _passes(Q, out):
            self._smooth_chunk(part, (alpha, beta, S, wgrad_scale, tol), method, rows)
        d, g, nodes, leaves = out
        return (d, g, QueryStats(nodes, leaves)) if return_stats else SmoothDistanceResult(d, g)

    def _smooth_chunk(self, Q, params, method, out):
        """:meth:`smooth_distance` of the queries ``Q (k, 3)`` (at most :data:`QUERY_CHUNK`)
        into ``out = [d (k,), g (k, 3), nodes, leaves]`` (views of the whole batch's arrays;
        the stats None when not asked for), in the queries' coherent order."""
        alpha, beta, S, wgrad_scale, tol = params
        n = Q.shape[0]
        order = coherent_order(Q) if method == "bvh" else None
        res = _scratch(n, out, reuse=order is None)
        d, g, nodes, leaves = res
        if order is not None:
            Q = Q[order]
        if 0 < n <= TASK_BATCH and method == "bvh" and tol == 0.0:
            _tasks(_q.smooth_distance_tasks, n, self.tree, Q, alpha, beta, S, wgrad_scale, d, g,
                   nodes, leaves, 0)
        elif n:
            brute = method == "brute"     # every primitive summed, no tree
            _q.smooth_distance_batch(self.tree, Q, alpha, beta, S, wgrad_scale, brute, d, g, nodes,
                                     leaves, tol, parallel_tasks(n))
        _scatter(order, res, out)

    def exact_distance(self, Q, *, return_closest=False, return_stats=False, device=None):
        """Exact unsigned distance, unit gradient, and (optionally) the closest primitive.

        Returns ``(distance (q,), gradient (q, 3))``; with ``return_closest`` an
        :class:`ExactDistanceResult` whose ``closest`` is the primitive index in the mesh
        numbering (points, then edges, then triangles); with ``return_stats`` a trailing
        :class:`QueryStats` (counted on the tree searched, see :attr:`exact_tree`).

        When several primitives are at the same distance (a query whose closest point is a
        vertex or an edge shared by several triangles), ``closest`` is one of them; which one
        may depend on the tree searched and on the other rows of ``Q``, as each query starts
        its search from the previous query's closest primitive
        (:func:`smoothdist._kernels.exact_query.exact_tree_batch`); a scattered batch is taken
        in Morton order (:mod:`smoothdist.query_order`), results in ``Q``'s order.
        ``device="cuda"`` evaluates on the GPU (:mod:`smoothdist.cuda`), searching the field's
        ``tree``; queries on the GPU (``device`` None) stay there, and so do the results, as in
        :meth:`smooth_distance`.
        """
        device, Q = _device_and_points(device, Q)
        if device == "cuda":
            d, g, prim, nodes, leaves = cuda.exact_distance(self.tree, Q, self.device_tree())
            out = ExactDistanceResult(d, g, prim) if return_closest else SmoothDistanceResult(d, g)
            return (*out, QueryStats(nodes, leaves)) if return_stats else out
        n = Q.shape[0]
        out = _outputs(n, return_stats, closest=True)
        if n:
            self._exact_queries = self.__dict__.get("_exact_queries", 0) + n
            use_exact_tree = ("_exact_tree" in self.__dict__
                              or self._exact_queries >= EXACT_TREE_AFTER * self.num_primitives)
            for part, rows in _passes(Q, out):
                self._exact_chunk(part, use_exact_tree, rows, return_stats)
        d, g, prim, nodes, leaves = out
        out = ExactDistanceResult(d, g, prim) if return_closest else SmoothDistanceResult(d, g)
        return (*out, QueryStats(nodes, leaves)) if return_stats else out

    def _exact_chunk(self, Q, use_exact_tree, out, return_stats):
        """:meth:`exact_distance` of the queries ``Q (k, 3)`` (at most :data:`QUERY_CHUNK`)
        into ``out = [d, g, prim, nodes, leaves]`` (views of the whole batch's arrays; the
        stats None when not asked for), on :attr:`exact_tree` or the smooth tree."""
        n = Q.shape[0]
        order = coherent_order(Q)
        if use_exact_tree:
            # the kernel takes the queries in the coherent order itself (no copies); queries
            # too few to sort and far apart are searched one by one (a group of unrelated
            # queries opens the union of their searches: 10x slower)
            group = 1 if order is None and scattered(Q, self.diagonal) else GROUP
            d, g, prim, nodes, leaves = _scratch(n, out, reuse=True)
            exact_tree_batch(self.exact_tree, Q, True, d, g, prim, nodes, leaves,
                             1 if n <= EXACT_CHUNK else parallel_tasks(n), bool(return_stats),
                             _NO_ORDER if order is None else order, group)
            return
        res = _scratch(n, out, reuse=order is None)
        d, g, prim, nodes, leaves = res
        Qo = Q if order is None else Q[order]
        if n <= TASK_BATCH:
            _tasks(_q.exact_distance_tasks, n, self.tree, Qo, -1.0, d, g, prim, nodes, leaves, 0)
        else:
            _q.exact_distance_batch(self.tree, Qo, d, g, prim, nodes, leaves, parallel_tasks(n))
        _scatter(order, res, out)

    def device_tree(self):
        """The field's ``tree`` on the GPU (:func:`smoothdist.cuda.device_tree`: the same
        :class:`~smoothdist._kernels.bvh.TreeData` of device arrays): copied at the first call
        and kept with the field, so that every later device query and render reuses it (the
        handle to pass to your own CUDA kernels). :meth:`free_device_tree` releases it."""
        if "_cuda_tree" not in self.__dict__:
            self.__dict__["_cuda_tree"] = cuda.device_tree(self.tree)
        return self.__dict__["_cuda_tree"]

    def free_device_tree(self):
        """Release the GPU copy of the tree (:meth:`device_tree`); the next device query
        copies it again."""
        self.__dict__.pop("_cuda_tree", None)

    def kernel_args(self, alpha, beta=0.5, alpha_u=None, gradient="exact"):
        """Validated scalars for :func:`smoothdist._kernels.query.smooth_distance_point`.

        ``alpha`` as in :meth:`smooth_distance`. Returns ``(alpha, beta, S, wgrad_scale)``:
        ``S = min(alpha / alpha_U, 1)``, the paper's attenuation exponent of the weights, and
        ``wgrad_scale``, the scale of the weight gradient's term in the gradient (``1/alpha``
        for the exact derivative, ``1/alpha**2`` for the paper's alpha-metric one).
        """
        beta = non_negative(beta, "beta")
        alpha = self.check_alpha(self._resolve_alpha(alpha, beta, alpha_u))
        if gradient not in GRADIENTS:
            raise ValueError(f"gradient must be one of {GRADIENTS}, got {gradient!r}")
        wgrad_scale = 1.0 / alpha if gradient == "exact" else 1.0 / (alpha * alpha)
        return alpha, beta, self.attenuation(alpha, alpha_u), wgrad_scale

    def alpha_within(self, max_error, beta=0.5, alpha_u=None):
        """The smallest alpha (1 / scene units) whose proven gap ``d - d_hat`` is at most
        ``max_error`` (scene units) wherever the exact distance ``d <= max_error``:
        ``(1 + beta) (S log A + log N) / max_error`` (:mod:`smoothdist.error_budget`).

        With ``beta = 0`` the gap is at most ``max_error`` everywhere, and the surface
        ``d_hat = 0`` lies within ``max_error`` of the data at any beta.
        """
        return self.check_alpha(point_alpha(self, within(max_error),
                                            non_negative(beta, "beta"), alpha_u))

    def _resolve_alpha(self, alpha, beta, alpha_u, tol=0.0):
        """``alpha`` with ``"auto"`` and :func:`~smoothdist.within` replaced by numbers."""
        if isinstance(alpha, str) and alpha == "auto":
            return self.auto_alpha()
        if isinstance(alpha, Within):
            if tol > 0.0:
                raise ValueError("alpha=within(...) needs tol=0: the error bound does not "
                                 "cover tolerance pruning")
            return point_alpha(self, alpha, beta, alpha_u)
        return alpha

    def __repr__(self):
        return (f"SmoothDistanceField({self.mesh!r}, {self.tree.lo.shape[0]} nodes, "
                f"depth {self.tree.depth}, A={self.weight_bound:.4g})")


def _check_device(device, method="bvh", on_gpu=False):
    """``device`` checked (``"cpu"`` or ``"cuda"``; None: where the queries are; the GPU has
    no brute-force method, and queries on the GPU are not copied to the host silently)."""
    if device is None:
        device = "cuda" if on_gpu else "cpu"
    if device not in ("cpu", "cuda"):
        raise ValueError(f"device must be one of ('cpu', 'cuda'), got {device!r}")
    if device == "cuda" and method != "bvh":
        raise ValueError(f"method {method!r} runs on the cpu only; device 'cuda' takes 'bvh'")
    if device == "cpu" and on_gpu:
        raise ValueError("Q is an array on the GPU: use device='cuda' (or leave device out), "
                         "or copy it to the host first")
    return device


def _device_and_points(device, Q, method="bvh"):
    """``(device, Q)``: the device checked, and the queries validated where they are
    (:func:`smoothdist._cast.as_points` on the host, :func:`smoothdist.cuda.device_points` on
    the GPU)."""
    on_gpu = cuda.is_device_array(Q)
    device = _check_device(device, method, on_gpu)
    return device, (cuda.device_points(Q, "Q") if on_gpu else as_points(Q, "Q"))


#: queries answered per pass (``smooth_distance`` and ``exact_distance`` on the CPU): a
#: larger batch runs as several passes of this many, each sorted along its own Morton curve, so
#: that its working memory (the sorted copy, per-query scratch) stays fixed while the outputs
#: grow with the batch. The values do not depend on it (each query's is its own)
QUERY_CHUNK = 1 << 20


def _passes(Q, out):
    """``(queries, outputs)`` of each pass over the batch ``Q``: the rows ``a:b`` of ``Q`` and
    of each array of ``out`` (views; None stays None), in passes of :data:`QUERY_CHUNK`; one
    pass, ``(Q, out)`` itself, for a batch that fits (a small call pays nothing for it)."""
    n = Q.shape[0]
    if n <= QUERY_CHUNK:
        return ((Q, out),)
    return [(Q[a:a + QUERY_CHUNK], [None if x is None else x[a:a + QUERY_CHUNK] for x in out])
            for a in range(0, n, QUERY_CHUNK)]


def _outputs(n, stats, closest=False):
    """The whole batch's result arrays ``[d (n,), g (n, 3), (prim,) nodes, leaves]``; the stats
    (``nodes``, ``leaves``) of a batch larger than a pass only when asked for (else None: each
    pass uses scratch)."""
    out = [np.empty(n), np.empty((n, 3))]
    if closest:
        out.append(np.empty(n, dtype=np.int64))
    keep = stats or n <= QUERY_CHUNK
    return out + [np.empty(n, dtype=np.int64) if keep else None for _ in range(2)]


def _scratch(n, out, reuse=False):
    """Arrays for one pass of ``n`` queries shaped as ``out``: with ``reuse``, ``out``'s own
    where given; new ones otherwise (the kernels write every array they are given)."""
    if reuse and out[-1] is not None:
        return out
    return [a if (a is not None and reuse) else
            np.empty((n,) + (() if a is None else a.shape[1:]),
                     dtype=np.int64 if a is None else a.dtype) for a in out]


def _scatter(order, res, out):
    """Write a pass's results ``res`` (in the coherent ``order``) into ``out`` (the queries'
    order); nothing to do without an order (``res`` is ``out``)."""
    if order is None:
        return
    for r, o in zip(res, out):
        if o is not None:
            o[order] = r


def _tasks(kernel, n, *args):
    """Run the serial task kernel ``kernel(*args, ntasks, task0, task1)`` over ``n`` queries
    from the persistent worker threads (:func:`smoothdist.schedule.run_tasks` with ``pool``;
    one strided task per thread, :func:`smoothdist._kernels.query.chunk_tasks`)."""
    ntasks = _q.chunk_tasks(n)
    run_tasks(lambda a, b: kernel(*args, ntasks, a, b), ntasks, pool=True)


def _exact_bvh(tree, P, floor=-1.0):
    """Exact distance and unit gradient from each row of ``P (n, 3)`` searching ``tree`` (the
    smooth-distance BVH: no exact tree built or compiled), ignoring primitives at squared
    distance ``<= floor`` (``0.0``: the nearest primitive at distance > 0). Returns
    ``(d (n,), g (n, 3))``."""
    n = P.shape[0]
    d, g = np.empty(n), np.empty((n, 3))
    if n:
        prim, nodes, leaves = (np.empty(n, dtype=np.int64) for _ in range(3))
        _tasks(_q.exact_distance_tasks, n, tree, P, float(floor), d, g, prim, nodes, leaves, 0)
    return d, g


def _nearest_other(tree, P):
    """Distance from each row of ``P (n, 3)`` to the nearest primitive at distance > 0."""
    return _exact_bvh(tree, P, 0.0)[0]
