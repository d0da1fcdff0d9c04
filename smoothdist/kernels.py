"""Public numba kernels for code that evaluates distances inside its own njit loops.

Use them with a :class:`~smoothdist.field.SmoothDistanceField`'s ``tree`` and the scalars from
``field.kernel_args(...)``; allocate the scratch stacks once per thread with :func:`new_stack`::

    stack, dstack = new_stack(field.tree)
    d, gx, gy, gz, nodes, leaves = smooth_distance_point(field.tree, x, y, z, alpha, beta, S,
                                                         wgrad_scale, stack, dstack)

Inside a kernel, allocate ``np.empty(tree.depth + 4, np.int64)`` and ``np.empty(tree.depth + 4)``.
``smooth_distance_point_tol(tree, x, y, z, alpha, beta, tol, S, wgrad_scale, stack, dstack)`` adds
tolerance-controlled pruning (``tol > 0``; same scratch arrays; ``DEFAULT_TOL`` = 0 is off).

Your own kernels take the package's compilation policy from here, so that they are compiled
(and cached) like these: decorate them ``@numba.njit(**NJIT)``,
``@numba.njit(**NJIT_IR_INLINE)`` for functions merged into their callers (no compiled library
of their own: a traversal kind, a task body), or ``@numba.njit(**NJIT_PARALLEL)`` for batch
loops over ``prange``; ``PARALLEL`` is false under
``SMOOTHDIST_PARALLEL=0`` (see ``smoothdist/_config.py``). ``borrowed(tree)`` inside a kernel
gives the tree (or any array, or tuple of arrays) as views without reference counts, for
loops that pass it down at every step; valid while the kernel's caller holds the arrays.
``box_distance2(x, y, z, lo, hi, node)`` is ``(d2, cx, cy, cz)``: the squared distance from a
point to a node's box and the box's closest point (the point itself inside), for culling.
"""

import numpy as np

from smoothdist._config import NJIT, NJIT_IR_INLINE, NJIT_PARALLEL, PARALLEL
from smoothdist._kernels.bvh import TreeData, concatenate_trees
from smoothdist._kernels.closest_point import box_distance2
from smoothdist._kernels.query import (DEFAULT_TOL, exact_distance_point, logsumexp_accumulate,
                                       smooth_distance_point, smooth_distance_point_tol, stack_size)
from smoothdist._kernels.traversal import borrowed

__all__ = ["TreeData", "concatenate_trees", "box_distance2", "exact_distance_point",
           "logsumexp_accumulate",
           "smooth_distance_point", "smooth_distance_point_tol", "new_stack", "stack_size",
           "DEFAULT_TOL", "NJIT", "NJIT_IR_INLINE", "NJIT_PARALLEL", "PARALLEL",
           "borrowed"]


def new_stack(tree):
    """Scratch arrays ``(stack int64, dstack float64)`` for one traversal of ``tree``."""
    k = stack_size(tree)
    return np.empty(k, dtype=np.int64), np.empty(k)
