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

``--ptxas`` goes one step further, still without a GPU: NVIDIA's PTX assembler (``ptxas``,
``pip install nvidia-cuda-nvcc``) turns each kernel's PTX into machine code for the compute
capability and reports what a thread of it holds: registers, the stack frame (the traversal
stacks) and what spills to local memory. From the registers and the kernel's launch block the
script works out the occupancy, the share of a multiprocessor's 64 warps that can be resident
at once (:func:`occupancy`). ``--max-registers 128 64`` reports the same with each register
cap (``ptxas -maxrregcount``, what ``numba.cuda.jit(max_registers=...)`` asks for); ``--json``
writes it all. On a card the driver assembles the PTX with its own ``ptxas``, whose version may
differ from the pip one's by a few registers::

    LD_LIBRARY_PATH=... python benchmarks/check_cuda_ptx.py --ptxas --max-registers 128 96 64 \
        --json benchmarks/data/cuda_registers.json
"""

import argparse
import json
import math
import re
import shutil
import subprocess
import sys
import tempfile
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
    p.add_argument("--ptxas", nargs="?", const="", default=None, metavar="PATH",
                   help="also assemble each kernel with ptxas (when no PATH is given: the "
                        "one of the nvidia wheels, else the one on PATH) and report its "
                        "registers, spills and occupancy")
    p.add_argument("--max-registers", nargs="*", type=int, default=[], metavar="N",
                   help="with --ptxas: also assemble with each of these register caps")
    p.add_argument("--json", default=None, help="write the report there (JSON)")
    args = p.parse_args(argv)
    cc = tuple(int(v) for v in args.cc.split("."))
    assembler = None
    if args.ptxas is not None:
        assembler = args.ptxas or find_ptxas()
        if not assembler:
            print("check_cuda_ptx: no ptxas found; pip install nvidia-cuda-nvcc, or give its "
                  "path to --ptxas")
            return 2
        if cc not in SM_LIMITS:
            print(f"check_cuda_ptx: no occupancy limits for compute capability {args.cc}; "
                  f"one of {', '.join(f'{a}.{b}' for a, b in SM_LIMITS)}")
            return 2
    status = 0
    report = {"cc": list(cc), "ptxas": assembler and ptxas_version(assembler),
              "numba_cuda": _version("numba_cuda"), "numba": _version("numba"), "kernels": []}
    for name, fn, sig, threads in kernel_jobs(cc, args.scene):
        t0 = time.perf_counter()
        try:
            ptx, _ = _compile_ptx(fn, sig, cc)
        except Exception as exc:  # report and go on with the others
            print(f"{name}: FAILED: {type(exc).__name__}: {str(exc).strip().splitlines()[0]}")
            if args.verbose:
                print(str(exc))
            status = 1
            continue
        local = re.findall(r"__local_depot\d+\[(\d+)\]", ptx)
        row = {"kernel": name, "ptx_mb": len(ptx) / 1e6, "threads_per_block": threads,
               "local_bytes": max(map(int, local), default=0)}
        print(f"{name}: ok, sm_{cc[0]}{cc[1]}, {row['ptx_mb']:.2f} MB of PTX, "
              f"{row['local_bytes']} bytes of local memory per thread, "
              f"{time.perf_counter() - t0:.0f} s")
        if assembler:
            row["assembled"] = []
            for cap in [None] + list(args.max_registers):
                try:
                    info = assemble(assembler, ptx, cc, cap)
                except (RuntimeError, ValueError) as exc:
                    print(f"    {name}: ptxas FAILED: {str(exc).splitlines()[0]}")
                    status = 1
                    break
                info.update(max_registers=cap,
                            occupancy=occupancy(info["registers"], threads, cc))
                row["assembled"].append(info)
                print(f"    {'no cap' if cap is None else f'cap {cap}':>7}: "
                      f"{info['registers']} registers, {info['stack_bytes']} bytes of stack, "
                      f"spills {info['spill_stores']} / {info['spill_loads']} bytes (stores / "
                      f"loads), occupancy {info['occupancy']:.1%} at {threads} threads a block")
        report["kernels"].append(row)
    if args.json:
        Path(args.json).write_text(json.dumps(report, indent=1) + "\n")
        print(f"wrote {args.json}")
    return status


#: per compute capability: (registers per multiprocessor, most warps resident on one, most
#: blocks resident on one, registers a thread may use); NVIDIA's CUDA C++ Programming Guide,
#: "Features and Technical Specifications", table of technical specifications per compute
#: capability. Registers are allocated per warp in units of 256.
SM_LIMITS = {(7, 0): (65536, 64, 32, 255), (7, 5): (65536, 32, 16, 255),
             (8, 0): (65536, 64, 32, 255), (8, 6): (65536, 48, 16, 255),
             (8, 9): (65536, 48, 24, 255), (9, 0): (65536, 64, 32, 255)}
REGISTER_UNIT = 256


def occupancy(registers, threads_per_block, cc=(9, 0)):
    """The share of a multiprocessor's warps that a kernel using ``registers`` per thread,
    launched in blocks of ``threads_per_block``, can keep resident (no shared memory), as
    NVIDIA's occupancy calculator works it out: registers are allocated per warp, rounded up
    to :data:`REGISTER_UNIT`, and blocks are resident whole."""
    regs_sm, warps_sm, blocks_sm, _ = SM_LIMITS[tuple(cc)]
    warps_block = math.ceil(threads_per_block / 32)
    per_warp = math.ceil(max(1, registers) * 32 / REGISTER_UNIT) * REGISTER_UNIT
    by_registers = (regs_sm // per_warp) // warps_block
    blocks = min(by_registers, blocks_sm, warps_sm // warps_block)
    return blocks * warps_block / warps_sm


def parse_ptxas(text):
    """``{"registers", "stack_bytes", "spill_stores", "spill_loads"}`` from the ``-v`` report
    of ``ptxas`` for one kernel."""
    frame = re.search(r"(\d+) bytes stack frame, (\d+) bytes spill stores, (\d+) bytes spill "
                      r"loads", text)
    regs = re.search(r"Used (\d+) registers", text)
    if not (frame and regs):
        raise ValueError(f"not a ptxas -v report: {text.strip()[:200]!r}")
    return {"registers": int(regs.group(1)), "stack_bytes": int(frame.group(1)),
            "spill_stores": int(frame.group(2)), "spill_loads": int(frame.group(3))}


def find_ptxas():
    """The path of ``ptxas``: from the ``nvidia`` wheels beside numba-cuda's NVVM first (``pip
    install nvidia-cuda-nvcc``; the same CUDA release as the NVVM that wrote the PTX, whose
    ``.version`` an older ``ptxas`` refuses), else on PATH; None when there is none."""
    for site in filter(None, sys.path):
        hits = sorted(Path(site).glob("nvidia/*/bin/ptxas"))
        if hits:
            return str(hits[0])
    return shutil.which("ptxas")


def ptxas_version(ptxas):
    """The last line of ``ptxas --version``."""
    out = subprocess.run([ptxas, "--version"], capture_output=True, text=True, check=True)
    return out.stdout.strip().splitlines()[-1]


def assemble(ptxas, ptx, cc, max_registers=None):
    """Assemble ``ptx`` for ``sm_XY`` and return :func:`parse_ptxas`'s report."""
    with tempfile.TemporaryDirectory() as tmp:
        src = Path(tmp) / "kernel.ptx"
        src.write_text(ptx)
        cmd = [ptxas, f"-arch=sm_{cc[0]}{cc[1]}", "-v", "-o", str(Path(tmp) / "kernel.cubin")]
        if max_registers:
            cmd += ["-maxrregcount", str(max_registers)]
        out = subprocess.run(cmd + [str(src)], capture_output=True, text=True)
    if out.returncode:
        raise RuntimeError(f"{ptxas}: {(out.stderr or out.stdout).strip()}")
    return parse_ptxas(out.stdout + out.stderr)


def _version(module):
    return getattr(__import__(module), "__version__", None)


def _compile_ptx(fn, sig, cc):
    from numba import cuda
    return cuda.compile_ptx(fn, sig, cc=cc)


def kernel_jobs(cc, scene_path):
    """``[(name, function, signature, threads per block), ...]``: every kernel of the GPU
    path and of ``bench_gpu.py``'s variants, typed as their launches type them, with the
    answers numba-cuda would ask a device for patched in (``cc``)."""
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
    scene = load_scene(scene_path, {"width": 8, "height": 8})
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
                                        SampleRays, TraceOptions, scene_arrays)
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
    sdata = (tree, ray, SampleRays(n, n, np.zeros((K, 2)), 0.0, 0.02), sbuf, opts)
    light = LightArgs(np.zeros(3), lo, hi, 1e-3, 10.0, 0.01, True, True, 0.0, 1e-3, 1e-2)
    lbuf = LightBuffers(d, d.copy(), np.zeros((4, 2), np.int64))
    ldata = (tree, (roots, params, mode, tol), (Q, Q.copy()), light, lbuf)
    q1, tr, tc, tf = (sdcuda.THREADS, gpu_render.BLOCK[0] * gpu_render.BLOCK[1],
                      gpu_render.CONE_BLOCK[0] * gpu_render.CONE_BLOCK[1], gpu_render.THREADS)
    smooth_sig = (ty(tree), ty(Q), f64, f64, f64, f64, f64, ty(d), ty(g), ty(n), ty(n))
    render_tail = (ty(tuple(rargs[1:])), ty(cone_f), ty(cone_n), ty(outs[:7]), ty(outs[7]))
    return [("smoothdist.cuda smooth", sdcuda._smooth_kernel, smooth_sig, q1),
            ("smoothdist.cuda exact", sdcuda._exact_kernel,
             (ty(tree), ty(Q), ty(d), ty(g), ty(n), ty(n), ty(n)), q1),
            ("smoothdist.cuda check", sdcuda._check_kernel, (ty(Q), f64, ty(n)), q1),
            ("tracer.rendering.gpu_render cone", gpu_render._cone_kernel,
             (ty(rargs.data), ty(tuple(rargs[1:])), ty(cone_f), ty(cone_n)), tc),
            ("tracer.rendering.gpu_render render", gpu_render._render_kernel,
             (ty(rargs.data),) + render_tail, tr),
            ("tracer.rendering.gpu_render samples", gpu_render._samples_kernel,
             (ty(sdata), numba.int64, numba.int64), tf),
            ("tracer.rendering.gpu_render light", gpu_render._light_kernel,
             (ty(ldata), numba.int64), tf),
            # bench_gpu.py's kernel variants (issue 49 item 3: --variants stack32 box32)
            ("benchmarks.bench_gpu stack32", bench_gpu.smooth_stack32(), smooth_sig, q1),
            ("benchmarks.bench_gpu box32 render", gpu_render._render_kernel,
             (ty((bench_gpu.boxes32(rargs.data[0]),) + tuple(rargs.data[1:])),) + render_tail,
             tr),
            ("benchmarks.bench_gpu box32", sdcuda._smooth_kernel,
             (ty(bench_gpu.boxes32(tree)),) + smooth_sig[1:], q1)]


if __name__ == "__main__":
    sys.exit(main())
