"""smoothdist: smooth distances to points, edges, triangles and mixed meshes.

A reference implementation of Madan & Levin, "Fast Evaluation of Smooth Distance Constraints
on Co-Dimensional Geometry" (SIGGRAPH 2022), in numpy + numba.

Conventions
-----------
* ``V (n, 3) float64`` vertices; ``F`` ``None`` (points), ``(m, 2)`` edges or ``(m, 3)``
  triangles; ``Q (q, 3)`` query points.
* Distances are unsigned, in scene units; gradients are with respect to the query point.
* The smooth distance is conservative: ``d - log(A**S N)/alpha <= d_hat <= d``.
"""

__version__ = "0.1.0"

from smoothdist._cache_guard import guard_once as _guard_kernel_cache  # noqa: E402
from smoothdist import _kernel_cache  # noqa: E402

# before any kernel module is imported: drop numba caches compiled from other sources, and
# keep our kernels in the per-machine cache keyed on the sources' content
_guard_kernel_cache()
_kernel_cache.install(__version__)

from smoothdist import _moved  # noqa: E402,F401  (the old paths' import hook)

from smoothdist.field import (ExactDistanceResult, QueryStats, SmoothDistanceField,
                              SmoothDistanceResult)
from smoothdist.mesh import DataMesh, MeshRepairWarning, as_data_mesh
from smoothdist._kernels.query import DEFAULT_TOL as _DEFAULT_TOL
from smoothdist.whole_mesh import MeshDistance, combine_distances, mesh_distance
from smoothdist.error_budget import Within, within

__all__ = ["DataMesh", "MeshRepairWarning", "SmoothDistanceField", "SmoothDistanceResult",
           "ExactDistanceResult", "QueryStats", "smooth_distance", "exact_distance",
           "load_mesh", "as_data_mesh", "MeshDistance", "mesh_distance", "combine_distances",
           "within", "Within"]


def load_mesh(path, kind=None):
    """Load an OBJ/OFF/STL/PLY file as a :class:`DataMesh` (see :meth:`DataMesh.load`)."""
    return DataMesh.load(path, kind=kind)


def smooth_distance(Q, V, F=None, *, alpha, beta=0.5, alpha_u=None, gradient="exact",
                    return_stats=False, tol=_DEFAULT_TOL, device=None):
    """Smooth distance from query points to a data mesh (Madan & Levin 2022, Eq. 3-4).

    Parameters
    ----------
    Q : (q, 3) array_like of float
        Query points.
    V : (n, 3) array_like of float, or a DataMesh / trimesh / pyvista object
        Data vertices, or a whole mesh (then ``F`` is None; see
        :func:`smoothdist.as_data_mesh`).
    F : None, (m, 2) or (m, 3) array_like of int
        ``None``: the vertices are a point cloud; ``(m, 2)`` edges; ``(m, 3)`` triangles.
    alpha : float, "auto" or :func:`within`
        Sharpness, 1 / scene units (> 0); ``"auto"``: mean surface offset <= 2 % of the
        bbox diagonal (:meth:`SmoothDistanceField.auto_alpha`); ``within(e)``: the smallest
        alpha whose proven gap ``d - d_hat`` is at most ``e`` wherever ``d <= e``
        (:mod:`smoothdist.error_budget`).
    beta : float
        Barnes-Hut parameter (>= 0); 0 is exact.
    alpha_u : float or "auto", optional
        Attenuation threshold alpha_U; None disables attenuation; ``"auto"`` is 20 x alpha.
    gradient : {"exact", "metric"}
        ``"exact"`` (default): the derivative of ``d_hat``. ``"metric"``: the paper's
        alpha-metric weight gradient (Sec. 3.3), whose weight term is divided by alpha once
        more; not the derivative for edges and triangles (equal for point clouds).
    return_stats : bool
        Also return per-query :class:`QueryStats`.
    tol : float
        Tolerance-controlled pruning (>= 0; 0 = off); with ``beta=0`` the error is at most
        ``log(1 + tol) / alpha`` and ``d_hat`` stays below the exact sum's.
    device : {"cpu", "cuda"}, optional
        Where to evaluate (default: where ``Q`` is). ``Q`` may be a float64 array on the GPU
        (CuPy, PyTorch, numba: ``__cuda_array_interface__``); the results then stay on the GPU
        too (:meth:`SmoothDistanceField.smooth_distance`).

    Returns
    -------
    d : (q,) float64
    grad : (q, 3) float64
    stats : QueryStats, only with ``return_stats``

    Examples
    --------
    >>> import numpy as np
    >>> d, g = smooth_distance([[0, 0, 2.0]], np.zeros((1, 3)), alpha=5.0)
    >>> float(d[0]), g[0].tolist()
    (2.0, [0.0, 0.0, 1.0])
    """
    field = SmoothDistanceField(V, F)
    return field.smooth_distance(Q, alpha=alpha, beta=beta, alpha_u=alpha_u, gradient=gradient,
                                 return_stats=return_stats, tol=tol, device=device)


def exact_distance(Q, V, F=None, *, device=None):
    """Exact unsigned distance ``(d (q,), grad (q, 3))`` from query points to a data mesh
    (``V``, ``F`` as in :func:`smooth_distance`; ``device`` too: queries on the GPU give
    results on the GPU)."""
    return SmoothDistanceField(V, F).exact_distance(Q, device=device)
