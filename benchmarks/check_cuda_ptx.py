"""Compile every CUDA kernel of the GPU path to PTX, without a GPU.

numba's CUDA simulator (``tests/smoothdist/test_cuda_sim.py``) runs the kernels' launch code
but calls the shared ``numba.njit`` functions compiled for the CPU, so it cannot show that numba-cuda
compiles them for a GPU. This script does: it types and lowers ``smoothdist.cuda``'s query
kernels and ``tracer.rendering.gpu_render``'s cone, render, samples and light kernels for a
compute capability (default 9.0,
H100 / H200) through NVIDIA's NVVM, as the first launch on a card would, and prints the size
of the PTX and of each thread's local memory (the traversal stacks).

Needs numba-cuda and the NVVM and NVRTC libraries, which pip installs without a GPU or a
driver::

    pip install "smoothdist[gpu]" nvidia-nvvm nvidia-cuda-nvrtc
    LD_LIBRARY_PATH=<site-packages>/nvidia/cu13/lib python benchmarks/check_cuda_ptx.py

Without a device, numba-cuda cannot ask one for its compute capability when it compiles a
device function; the script answers for it (``--cc``). Exit status 0 when every kernel
compiles, 1 otherwise (the error's first line printed).
"""

import argparse
import re
import sys
import time
import types
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--cc", default="9.0", help="compute capability (default 9.0)")
    p.add_argument("--scene", default=str(REPO / "scenes" / "bunny_triangles.json"))
    p.add_argument("--verbose", action="store_true", help="the whole error of a failure")
    args = p.parse_args(argv)
    cc = tuple(int(v) for v in args.cc.split("."))

    import numba
    import numpy as np

    from smoothdist import cuda as sdcuda

    sdcuda._numpy_compat()
    from numba import cuda
    import numba.cuda.dispatcher as dispatcher

    # device functions are compiled for the current device's compute capability: answer it
    dispatcher.get_current_device = lambda: types.SimpleNamespace(compute_capability=cc)
    # the kernels' host-side preparation only needs the argument types: host arrays do
    sdcuda.simulated = lambda: True
    sdcuda.cuda_module = lambda: cuda
    sdcuda.cuda = cuda
    from tracer.rendering import gpu_render
    from tracer.scenes.scene import load_scene

    gpu_render.cuda = cuda
    scene = load_scene(args.scene, {"width": 8, "height": 8})
    tree = scene.objects[0].field.tree
    ty = numba.typeof
    f64 = numba.float64
    Q, d, g = np.zeros((4, 3)), np.zeros(4), np.zeros((4, 3))
    n = np.zeros(4, np.int64)
    camera, rargs, (H, W), _ = gpu_render.prepare(scene)
    outs = (np.zeros((H, W), np.bool_), np.zeros((H, W)), np.zeros((H, W, 3)),
            np.zeros((H, W), np.int64), np.zeros((H, W), np.int64), np.zeros((H, W), np.int64),
            np.zeros((H, W), np.int32), np.zeros((H, W, 3), np.uint8))
    cone_f, cone_n = np.zeros((2, 2, 6)), np.zeros((2, 2, 2), np.int64)
    # the film's kernels (issue 49): the extra samples and the light, with the arguments the
    # film passes (tracer.rendering.film._trace and _Shader.light_at)
    from tracer.rendering.frame import (LightArgs, LightBuffers, MarchArgs, SampleBuffers,
                                        TraceOptions, scene_arrays)
    from tracer.rendering.frame import kernel_roots

    from benchmarks import bench_gpu

    tr, roots, params, mode, lo, hi, depth_max, tol = scene_arrays(scene)
    roots = gpu_render._root_array(kernel_roots(roots, params, mode, tol))
    ray = MarchArgs(roots, params, mode, tol, camera.as_array(), lo, hi, 1e-3, 100)
    m, K = 4, 2
    sbuf = SampleBuffers(np.zeros((m, K), np.bool_), np.zeros((m, K)), np.zeros((m, K, 3)),
                         np.zeros((m, K), np.int64), np.zeros((m, K), np.int32), np.zeros(m),
                         np.zeros(m))
    opts = TraceOptions(1.0, 1.0, True, 0.0)
    sdata = (tree, ray, n, n, np.zeros((K, 2)), sbuf, opts)
    light = LightArgs(np.zeros(3), lo, hi, 1e-3, 10.0, 0.01, True, True, 0.0, 1e-3, 1e-2)
    lbuf = LightBuffers(d, d.copy(), np.zeros((4, 2), np.int64))
    ldata = (tree, roots, params, mode, tol, Q, Q.copy(), light, lbuf)
    jobs = (("smoothdist.cuda smooth", sdcuda._smooth_kernel,
             (ty(tree), ty(Q), f64, f64, f64, f64, f64, ty(d), ty(g), ty(n), ty(n))),
            ("smoothdist.cuda exact", sdcuda._exact_kernel,
             (ty(tree), ty(Q), ty(d), ty(g), ty(n), ty(n), ty(n))),
            ("smoothdist.cuda check", sdcuda._check_kernel, (ty(Q), f64, ty(n))),
            ("tracer.rendering.gpu_render cone", gpu_render._cone_kernel,
             (ty(rargs.data), ty(rargs.mode), f64, f64, f64, f64, ty(cone_f), ty(cone_n))),
            ("tracer.rendering.gpu_render render", gpu_render._render_kernel,
             tuple(ty(a) for a in rargs) + (ty(cone_f), ty(cone_n))
             + tuple(ty(o) for o in outs)),
            ("tracer.rendering.gpu_render samples", gpu_render._samples_kernel,
             (ty(sdata), numba.int64, f64, f64, numba.int64)),
            ("tracer.rendering.gpu_render light", gpu_render._light_kernel,
             (ty(ldata), numba.int64)),
            # bench_gpu.py's kernel variants (issue 49 item 3: --variants stack32 box32)
            ("benchmarks.bench_gpu stack32", bench_gpu.smooth_stack32(),
             (ty(tree), ty(Q), f64, f64, f64, f64, f64, ty(d), ty(g), ty(n), ty(n))),
            ("benchmarks.bench_gpu box32 render", gpu_render._render_kernel,
             (ty((bench_gpu.boxes32(rargs.data[0]),) + tuple(rargs.data[1:])),)
             + tuple(ty(a) for a in rargs[1:]) + (ty(cone_f), ty(cone_n))
             + tuple(ty(o) for o in outs)),
            ("benchmarks.bench_gpu box32", sdcuda._smooth_kernel,
             (ty(bench_gpu.boxes32(tree)), ty(Q), f64, f64, f64, f64, f64, ty(d), ty(g), ty(n),
              ty(n))))
    status = 0
    for name, fn, sig in jobs:
        t0 = time.perf_counter()
        try:
            ptx, _ = cuda.compile_ptx(fn, sig, cc=cc)
        except Exception as exc:  # report and go on with the others
            print(f"{name}: FAILED: {type(exc).__name__}: {str(exc).strip().splitlines()[0]}")
            if args.verbose:
                print(str(exc))
            status = 1
            continue
        local = re.findall(r"__local_depot\d+\[(\d+)\]", ptx)
        print(f"{name}: ok, sm_{cc[0]}{cc[1]}, {len(ptx) / 1e6:.2f} MB of PTX, "
              f"{max(map(int, local), default=0)} bytes of local memory per thread, "
              f"{time.perf_counter() - t0:.0f} s")
    return status


if __name__ == "__main__":
    sys.exit(main())
