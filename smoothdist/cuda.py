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

Arrays that live on the GPU stay there. Query points given as any object with the
``__cuda_array_interface__`` (a CuPy array, a PyTorch CUDA tensor, a numba device array) are
read where they are, and the results come back as numba device arrays (which have the
interface too: ``cupy.asarray(d)`` and ``torch.as_tensor(d, device="cuda")`` wrap them without
a copy). The field's tree is copied to the device once and kept there
(``SmoothDistanceField.device_tree()``). Device queries must be ``(n, 3)`` float64; they are
checked on the device (finite, within the coordinate limit) before any traversal.
"""

import contextlib
import ctypes
import math
import os
import warnings

import numba
import numpy as np

from smoothdist import _kernel_cache
from smoothdist._cast import COORD_LIMIT
from smoothdist._kernels.query import exact_distance_point, smooth_distance_point_tol

__all__ = ["CudaUnavailable", "DEVICES", "check_device", "cuda_module", "device_tree",
           "simulated", "smooth_distance", "exact_distance", "is_device_array", "device_points",
           "STACK", "THREADS", "quiet_small_launches"]

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
    _kernel_cache.install_cuda()  # the CUDA kernels' cache in the per-machine folder too
    return cuda


#: ``numba.cuda`` once :func:`kernels` has run (a module global, so that the simulator can
#: swap in its own ``cuda`` while it runs a kernel)
cuda = None
_KERNELS = {}


def _smooth_kernel(tree, Q, alpha, beta, tol, S, wgrad_scale, out_d, out_g, out_nodes,
                   out_leaves):
    i = cuda.grid(1)
    if i < Q.shape[0]:
        stack = cuda.local.array(STACK, numba.int64)
        dstack = cuda.local.array(STACK, numba.float64)
        d, gx, gy, gz, nodes, leaves = smooth_distance_point_tol(
            tree, Q[i, 0], Q[i, 1], Q[i, 2], alpha, beta, tol, S, wgrad_scale, stack, dstack, 0)
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


def _check_kernel(Q, limit, flags):
    """``flags[0]`` 1 if a coordinate of ``Q`` is NaN or infinite, ``flags[1]`` 1 if one is
    beyond ``limit`` in absolute value (one thread per row)."""
    i = cuda.grid(1)
    if i < Q.shape[0]:
        for k in range(3):
            x = Q[i, k]
            if not math.isfinite(x):
                cuda.atomic.max(flags, 0, 1)
            elif abs(x) > limit:
                cuda.atomic.max(flags, 1, 1)


@contextlib.contextmanager
def quiet_small_launches():
    """numba-cuda warns (``NumbaPerformanceWarning``) at every launch of fewer than 128
    blocks. A caller's few queries, and the film's batches of flagged pixels
    (:mod:`tracer.rendering.gpu_render`), are such launches by nature, and a render made
    dozens of them: the warning is silenced for the launches made inside this block, and
    stays on for everything else."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=r"Grid size \d+ will likely result in GPU "
                                r"under-utilization")
        yield


def kernels():
    """The query kernels ``{"smooth": ..., "exact": ..., "check": ...}`` as CUDA kernels
    (compiled at their first launch for the argument types given)."""
    global cuda
    if not _KERNELS:
        cuda = cuda_module()
        _KERNELS.update(smooth=cuda.jit(_smooth_kernel, cache=True),
                        exact=cuda.jit(_exact_kernel, cache=True),
                        check=cuda.jit(_check_kernel, cache=True))
    return _KERNELS


def is_device_array(obj):
    """Whether ``obj`` is an array on the GPU: it has the ``__cuda_array_interface__``, or it
    is a device array of numba's simulator. Never imports ``numba.cuda``."""
    if isinstance(obj, np.ndarray):
        return False
    return hasattr(obj, "__cuda_array_interface__") or (
        simulated() and bool(getattr(obj, "__cuda_ndarray__", False)))


def _simulator_view(obj):
    """Under the simulator, whose device memory is host memory: a numpy view of an object
    that gives the ``__cuda_array_interface__`` (its pointer is a host address)."""
    cai = obj.__cuda_array_interface__
    dtype = np.dtype(cai["typestr"])
    shape = tuple(cai["shape"])
    if dtype != np.float64:
        return np.zeros(shape, dtype)  # refused by its dtype below, by the caller
    n = int(np.prod(shape))
    buf = (ctypes.c_double * n).from_address(cai["data"][0]) if n else np.empty(0)
    view = np.frombuffer(buf, dtype=np.float64, count=n).reshape(shape)
    if cai.get("strides") is not None:
        view = np.lib.stride_tricks.as_strided(view, shape, cai["strides"])
    return view


def device_points(obj, name="Q"):
    """``obj`` (see :func:`is_device_array`) as a numba device array of shape ``(n, 3)``,
    float64, without a copy (a ``(3,)`` point becomes ``(1, 3)``); checked on the device:
    a one-line ``ValueError`` for another shape or dtype, for NaN or infinite coordinates and
    for coordinates beyond ``smoothdist._cast.COORD_LIMIT``, as for host arrays."""
    cuda = cuda_module()
    if not hasattr(obj, "__cuda_array_interface__"):
        arr = obj                                   # the simulator's own device array
    elif simulated():
        arr = cuda.to_device(_simulator_view(obj))  # host memory there: wrap, as below
    else:
        arr = cuda.as_cuda_array(obj)               # a view of the same device memory
    if np.dtype(arr.dtype) != np.float64:
        raise ValueError(f"{name} on the GPU must be float64, got {np.dtype(arr.dtype)}: "
                         "convert it on the device first (cupy: Q.astype('float64'), torch: "
                         "Q.double())")
    if arr.ndim == 1 and arr.shape[0] == 3:
        arr = arr.reshape(1, 3)
        if not is_device_array(arr):  # the simulator's reshape gives its numpy array
            arr = cuda.to_device(arr)
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ValueError(f"{name} must have shape (n, 3), got {tuple(arr.shape)}")
    if arr.shape[0]:
        flags = cuda.to_device(np.zeros(2, dtype=np.int64))
        with quiet_small_launches():
            kernels()["check"][_blocks(arr.shape[0]), THREADS](arr, COORD_LIMIT, flags)
        bad = flags.copy_to_host()
        if bad[0]:
            raise ValueError(f"{name} contains NaN or infinite coordinates (on the GPU)")
        if bad[1]:
            raise ValueError(f"{name} has coordinates beyond +-{COORD_LIMIT:.0e} (on the GPU): "
                             "rescale or recentre the data")
    return arr


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


def _on_device(cuda, Q):
    """``Q`` on the device: a host array copied there, a device array (from
    :func:`device_points`) as it is."""
    if is_device_array(Q):
        return Q
    return cuda.to_device(np.ascontiguousarray(Q, dtype=np.float64))


def _returned(arrays, keep):
    """The output arrays: kept on the device (``keep``), or copied to the host."""
    return tuple(arrays) if keep else tuple(a.copy_to_host() for a in arrays)


def smooth_distance(tree, Q, alpha, beta, S, wgrad_scale, tol, dtree=None):
    """Smooth distance of the rows of ``Q (q, 3)`` on the device, arguments as for
    :func:`smoothdist._kernels.query.smooth_distance_batch` (validated by the caller; ``dtree`` a
    :func:`device_tree` of ``tree`` to reuse). ``Q`` a host array: returns host arrays
    ``(d, g, nodes, leaves)``; ``Q`` a device array (:func:`device_points`): device arrays."""
    cuda = cuda_module()
    dtree = device_tree(tree) if dtree is None else dtree
    n = Q.shape[0]
    out = (cuda.device_array(n), cuda.device_array((n, 3)),
           cuda.device_array(n, dtype=np.int64), cuda.device_array(n, dtype=np.int64))
    if n:
        with quiet_small_launches():
            kernels()["smooth"][_blocks(n), THREADS](
                dtree, _on_device(cuda, Q), float(alpha), float(beta), float(tol), float(S),
                float(wgrad_scale), *out)
    return _returned(out, is_device_array(Q))


def exact_distance(tree, Q, dtree=None):
    """Exact distance of the rows of ``Q (q, 3)`` on the device (as
    :func:`smoothdist._kernels.query.exact_distance_batch`). Returns ``(d, g, prim, nodes,
    leaves)``, host arrays or, for a device ``Q``, device arrays; ``prim`` is in the mesh
    numbering."""
    cuda = cuda_module()
    dtree = device_tree(tree) if dtree is None else dtree
    n = Q.shape[0]
    out = (cuda.device_array(n), cuda.device_array((n, 3)),
           cuda.device_array(n, dtype=np.int64), cuda.device_array(n, dtype=np.int64),
           cuda.device_array(n, dtype=np.int64))
    if n:
        with quiet_small_launches():
            kernels()["exact"][_blocks(n), THREADS](dtree, _on_device(cuda, Q), *out)
    return _returned(out, is_device_array(Q))
