"""The CUDA path: smooth and exact distances of query points on an NVIDIA GPU (numba-cuda).

The kernels here are thin launch wrappers around the CPU kernels of
:mod:`smoothdist._kernels.query`: numba-cuda compiles a ``numba.njit`` function called from a
``cuda.jit`` kernel as a CUDA device function from the same Python source (``numba.cuda.target``'s
dispatcher handling), so ``smooth_distance_point_tol``, ``exact_distance_point`` and everything they
call run unchanged on the device and the two paths cannot drift apart. Each GPU thread evaluates one
query point with its own fixed-size local traversal stack (:data:`STACK` entries, enough for any
tree of depth ``<= STACK - 4``); the tree is the same flat
:class:`~smoothdist._kernels.bvh.TreeData` structure of arrays, copied to the device once per field.
All arithmetic is float64 as on the CPU (the exponential sums need it; data-centre GPUs run float64
at half the float32 rate).

Install: ``pip install -e ".[gpu]"`` in the clone (numba-cuda). Without a GPU, numba's CUDA
simulator (``NUMBA_ENABLE_CUDASIM=1`` set before ``numba.cuda`` is first imported) runs the
same kernels on the CPU, slowly; the test suite uses it (``tests/smoothdist/test_cuda_sim.py``).

Use it through ``SmoothDistanceField.smooth_distance(..., device="cuda")`` and
``exact_distance(..., device="cuda")``, or ``tracer.render(scene, device="cuda")``
(``tracer/rendering/gpu_render.py``).
"""

import os

import numba
import numpy as np

from smoothdist._kernels.query import exact_distance_point, smooth_distance_point_tol

__all__ = ["CudaUnavailable", "DEVICES", "check_device", "cuda_module", "device_tree",
           "simulated", "smooth_distance", "exact_distance", "STACK", "THREADS"]

#: the values of the ``device`` arguments
DEVICES = ("cpu", "cuda")
#: entries of each thread's local traversal stack: trees up to depth ``STACK - 4`` (the
#: CPU kernels use ``depth + 4``; the SAH build keeps the depth below about ``7.5 ln m``,
#: 121 for 1e7 primitives)
STACK = 128
#: threads per block of the 1-D query kernels
THREADS = 128


class CudaUnavailable(RuntimeError):
    """The CUDA device was asked for where it cannot run (no numba-cuda, no GPU); the message
    is one line saying which and what to do."""


def check_device(device):
    """``device`` checked: ``"cpu"`` or ``"cuda"`` (a one-line ``ValueError`` otherwise)."""
    if device not in DEVICES:
        raise ValueError(f"device must be one of {DEVICES}, got {device!r}")
    return device


def simulated():
    """Whether numba's CUDA simulator is switched on (``NUMBA_ENABLE_CUDASIM=1``)."""
    return os.environ.get("NUMBA_ENABLE_CUDASIM", "0") not in ("", "0")


def _numpy_compat():
    """numba-cuda 0.30.4 registers ``np.row_stack``, which numpy 2.5 removed (an
    ``AttributeError`` when the CUDA target first compiles). ``row_stack`` was an alias of
    ``vstack``; put the alias back where it is missing, before numba-cuda looks for it."""
    if not hasattr(np, "row_stack"):
        np.row_stack = np.vstack


def cuda_module():
    """``numba.cuda``, checked usable: the simulator, or numba-cuda with a GPU. Raises
    :class:`CudaUnavailable` (one line) otherwise."""
    _numpy_compat()
    if not simulated():
        try:
            # numba-cuda (gpu extra): loaded on use
            import numba_cuda  # noqa: F401  (the maintained CUDA target, not numba's own)
        except ImportError:
            raise CudaUnavailable("device 'cuda' needs numba-cuda: pip install numba-cuda "
                                  "(or the gpu extra in the clone: pip install -e '.[gpu]')"
                                  ) from None
    try:
        from numba import cuda  # numba-cuda (gpu extra): loaded on use
        ok = cuda.is_available()
    except Exception as exc:  # a driver or library problem, in numba's words
        raise CudaUnavailable(f"device 'cuda' is not usable: {str(exc).strip().splitlines()[0]}"
                              ) from None
    if not ok:
        raise CudaUnavailable("device 'cuda': no CUDA GPU found (numba.cuda.is_available() is "
                              "False); use device 'cpu'")
    return cuda


#: ``numba.cuda`` once :func:`kernels` has run (a module global, so that the simulator can
#: swap in its own ``cuda`` while it runs a kernel)
cuda = None
_KERNELS = {}


def _smooth_kernel(tree, Q, alpha, beta, tol, S, wgs, out_d, out_g, out_nodes, out_leaves):
    i = cuda.grid(1)
    if i < Q.shape[0]:
        stack = cuda.local.array(STACK, numba.int64)
        dstack = cuda.local.array(STACK, numba.float64)
        d, gx, gy, gz, nodes, leaves = smooth_distance_point_tol(
            tree, Q[i, 0], Q[i, 1], Q[i, 2], alpha, beta, tol, S, wgs, stack, dstack, 0)
        out_d[i] = d
        out_g[i, 0] = gx
        out_g[i, 1] = gy
        out_g[i, 2] = gz
        out_nodes[i] = nodes
        out_leaves[i] = leaves


def _exact_kernel(tree, Q, out_d, out_g, out_prim, out_nodes, out_leaves):
    i = cuda.grid(1)
    if i < Q.shape[0]:
        stack = cuda.local.array(STACK, numba.int64)
        dstack = cuda.local.array(STACK, numba.float64)
        d, gx, gy, gz, p, nodes, leaves = exact_distance_point(
            tree, Q[i, 0], Q[i, 1], Q[i, 2], stack, dstack, 0, -1.0)
        out_d[i] = d
        out_g[i, 0] = gx
        out_g[i, 1] = gy
        out_g[i, 2] = gz
        out_prim[i] = p
        out_nodes[i] = nodes
        out_leaves[i] = leaves


def kernels():
    """The query kernels ``{"smooth": ..., "exact": ...}`` as CUDA kernels (compiled at
    their first launch for the argument types given)."""
    global cuda
    if not _KERNELS:
        cuda = cuda_module()
        _KERNELS.update(smooth=cuda.jit(_smooth_kernel, cache=True),
                        exact=cuda.jit(_exact_kernel, cache=True))
    return _KERNELS


def check_depth(depth):
    """A one-line ``ValueError`` for a tree too deep for the fixed device stacks."""
    if depth + 4 > STACK:
        raise ValueError(f"device 'cuda': the tree has depth {depth}, more than the "
                         f"{STACK - 4} the device's fixed traversal stacks hold")


def device_tree(tree):
    """``tree`` (:class:`~smoothdist._kernels.bvh.TreeData`) with every array copied to the
    device."""
    cuda = cuda_module()
    check_depth(int(tree.depth))
    if simulated():
        # the simulator's device memory is host memory, and inside its kernels the shared
        # ``numba.njit`` functions run compiled for the CPU, which take numpy arrays (not the
        # simulator's array wrappers): the tree stays as it is
        return tree
    return type(tree)(*(cuda.to_device(np.ascontiguousarray(v)) if isinstance(v, np.ndarray)
                        else v for v in tree))


def _blocks(n):
    return (n + THREADS - 1) // THREADS


def smooth_distance(tree, Q, alpha, beta, S, wgs, tol, dtree=None):
    """Smooth distance of the rows of ``Q (q, 3)`` on the device, arguments as for
    :func:`smoothdist._kernels.query.smooth_distance_batch` (validated by the caller; ``dtree`` a
    :func:`device_tree` of ``tree`` to reuse). Returns host arrays ``(d, g, nodes, leaves)``."""
    cuda = cuda_module()
    dtree = device_tree(tree) if dtree is None else dtree
    n = Q.shape[0]
    d = cuda.device_array(n)
    g = cuda.device_array((n, 3))
    nodes = cuda.device_array(n, dtype=np.int64)
    leaves = cuda.device_array(n, dtype=np.int64)
    if n:
        kernels()["smooth"][_blocks(n), THREADS](
            dtree, cuda.to_device(np.ascontiguousarray(Q, dtype=np.float64)), float(alpha),
            float(beta), float(tol), float(S), float(wgs), d, g, nodes, leaves)
    return d.copy_to_host(), g.copy_to_host(), nodes.copy_to_host(), leaves.copy_to_host()


def exact_distance(tree, Q, dtree=None):
    """Exact distance of the rows of ``Q (q, 3)`` on the device (as
    :func:`smoothdist._kernels.query.exact_distance_batch`). Returns host arrays
    ``(d, g, prim, nodes, leaves)``; ``prim`` is in the mesh numbering."""
    cuda = cuda_module()
    dtree = device_tree(tree) if dtree is None else dtree
    n = Q.shape[0]
    out = (cuda.device_array(n), cuda.device_array((n, 3)),
           cuda.device_array(n, dtype=np.int64), cuda.device_array(n, dtype=np.int64),
           cuda.device_array(n, dtype=np.int64))
    if n:
        kernels()["exact"][_blocks(n), THREADS](
            dtree, cuda.to_device(np.ascontiguousarray(Q, dtype=np.float64)), *out)
    return tuple(a.copy_to_host() for a in out)
