"""GPU benchmark: the CUDA path against the CPU path (all cores) on the same machine.

Measures, on an NVIDIA GPU through numba-cuda (``pip install "smoothdist[gpu]"``):

* the paper's bunny (``scenes/bunny_{points,edges,triangles}.json``: alpha 200, alpha_U 1200,
  beta 0.5) sphere-traced at ``--size`` (default 1920 x 1080) with the ``"normals"`` shading,
  at the authors' hit threshold eps = 1e-3 (absolute) unless ``--eps`` is given; the GPU
  time is the best of ``--repeat`` launches of the render kernel with the scene already on
  the device (kernel plus copying the image back), the CPU time the best
  ``tracer.rendering.renderer``;
* the 1e6-point grid of ``benchmarks/bench_grid.py`` (``--grid 100``: the voxel centres of
  the unit cube, the bunny normalised to a 0.5 diagonal, alpha = 1 / shortest edge, beta 0.5)
  for the smooth distance of points, edges and triangles; GPU time: kernel plus copies (the
  queries in, distances, gradients and counters out), and the kernel alone with everything
  already on the device (``gpu_kernel_s``), and the public call given queries that live on the
  device (``gpu_resident_s``: their check, the launch, the outputs left there);
* image agreement: pixels whose hit differs, the largest depth difference over the common
  hits (as a fraction of the scene diagonal; two marches that stop within eps of the
  surface may differ by about ``2 eps / cos``, 8e-3 of the bunny's diagonal at eps 1e-3) and
  the largest colour difference; for the grid the largest distance difference;
* the first GPU call of each case (compiling the kernel, or loading it from numba-cuda's
  disk cache, plus copying the tree), as ``gpu_first_s``.

It prints a markdown table (the card's name in its title) and writes the results as JSON
(``--json``, default ``renders/gpu/bench_gpu.json``). Targets (issue 34): each 1080p frame
<= 40 ms, the grid <= 10 ms.

Without a usable GPU (no numba-cuda, no card, or numba's CUDA simulator switched on) it
refuses: one line on stderr, exit status 2, nothing written.

Usage (from the repository root)::

    python benchmarks/bench_gpu.py                        # 1920 x 1080, grid 100
    python benchmarks/bench_gpu.py --size 640 360 --grid 50 --repeat 3 --json out.json
"""

import argparse
import functools
import json
import os
import platform
import sys
import time
import types
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

import numba  # noqa: E402
import numpy as np  # noqa: E402

from benchmarks.machine import cpu_name  # noqa: E402


KINDS = ("points", "edges", "triangles")
DEFAULT_JSON = REPO / "renders" / "gpu" / "bench_gpu.json"


def gpu_or_exit():
    """``numba.cuda`` on a real GPU, or exit 2 with one line."""
    from smoothdist import cuda as sdcuda

    if sdcuda.simulated():
        print("bench_gpu: NUMBA_ENABLE_CUDASIM is set: the simulator is not a GPU; unset it",
              file=sys.stderr)
        sys.exit(2)
    try:
        return sdcuda.cuda_module()
    except sdcuda.CudaUnavailable as exc:
        print(f"bench_gpu: {exc}", file=sys.stderr)
        sys.exit(2)


def best(fn, repeat):
    """``(best seconds, last result)`` of ``repeat`` calls."""
    t, out = np.inf, None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        t = min(t, time.perf_counter() - t0)
    return t, out


def bench_render(kind, size, eps, repeat, blocks=()):
    from tracer.rendering import gpu_render
    from tracer.rendering.renderer import render
    from tracer.scenes.scene import load_scene

    W, H = size
    over = {"width": W, "height": H, "shading": "normals"}
    if eps is not None:
        over["eps"] = eps
    scene = load_scene(REPO / "scenes" / f"bunny_{kind}.json", over)
    cpu_s, cpu = best(lambda: render(scene), repeat)
    # warm-up: compiles the kernel (or loads it from numba-cuda's cache); its time is kept
    t0 = time.perf_counter()
    gpu = render(scene, device="cuda")
    first_s = time.perf_counter() - t0
    camera, args, shape, _ = gpu_render.prepare(scene)

    def frame(cone=True, block=gpu_render.BLOCK, out=None):
        out = gpu_render.launch(args, shape, cone, block, out)
        return gpu_render.to_host(out[7])    # the image; waits for the kernel

    gpu_s, _ = best(frame, repeat)
    # without the cone pass; and with the output arrays of an earlier launch (no allocation)
    nocone_s, _ = best(lambda: frame(cone=False), repeat)
    kept = gpu_render.launch(args, shape)
    reuse_s, _ = best(lambda: frame(out=kept), repeat)
    by_block = {f"{b[0]}x{b[1]}": best(lambda: frame(block=b, out=kept), repeat)[0]
                for b in blocks}
    both = cpu.hit & gpu.hit
    depth = (float(np.abs(cpu.depth[both].astype(float) - gpu.depth[both]).max())
             / scene.diagonal if both.any() else 0.0)
    return dict(what=f"bunny {kind}", size=f"{W}x{H}", eps=scene.eps, diag=scene.diagonal,
                primitives=scene.objects[0].field.num_primitives, cpu_s=cpu_s, gpu_s=gpu_s,
                speedup=cpu_s / gpu_s, gpu_first_s=first_s, gpu_nocone_s=nocone_s,
                gpu_reuse_s=reuse_s, gpu_by_block=by_block,
                hit_differs=int((cpu.hit != gpu.hit).sum()),
                depth_max_over_diag=depth,
                rgb_max=int(np.abs(cpu.rgb.astype(int) - gpu.rgb)[both].max(initial=0)),
                mean_steps_cpu=float(cpu.steps.mean()), mean_steps_gpu=float(gpu.steps.mean()))


def bench_render_variant(kind, size, eps, repeat, variant):
    """The 1080p frame of :func:`bench_render` with a kernel ``variant`` (issue 49 item 3):
    ``box32``, the node boxes stored as float32, rounded outwards (:func:`boxes32`); ``regsN``,
    the cone and render kernels compiled with at most N registers a thread (more threads
    resident on each multiprocessor, the rest spilled to local memory; see
    ``benchmarks/check_cuda_ptx.py --ptxas``). Returns its time beside the default kernels'
    in the same process, its first launch (the variant's compile), and what differs from the
    default frame (hit mask, depth over the diagonal, colour, leaves visited)."""
    from smoothdist import cuda as sdcuda
    from tracer.rendering import gpu_render
    from tracer.rendering.frame import scene_arrays
    from tracer.scenes.scene import load_scene

    W, H = size
    over = {"width": W, "height": H, "shading": "normals"}
    if eps is not None:
        over["eps"] = eps
    scene = load_scene(REPO / "scenes" / f"bunny_{kind}.json", over)
    camera, args, shape, _ = gpu_render.prepare(scene)
    ref_args = args
    ref = [gpu_render.to_host(a) for a in gpu_render.launch(args, shape)]
    kernels = None
    if variant == "box32":
        tree = scene_arrays(scene)[0]
        args = args._replace(data=(sdcuda.device_tree(boxes32(tree)),) + tuple(args.data[1:]))
    elif variant.startswith("regs"):
        regs = registers_of(variant)
        kernels = {k: capped_jit(getattr(gpu_render, f"_{k}_kernel"), regs)
                   for k in ("cone", "render")}
    else:
        raise ValueError(f"unknown render variant {variant!r}; one of {RENDER_VARIANTS}")

    t0 = time.perf_counter()
    out = [gpu_render.to_host(a) for a in gpu_render.launch(args, shape, kernels=kernels)]
    first_s = time.perf_counter() - t0
    # timed as bench_render's "GPU ms": the launches and the image copied back, each side
    # best of ``repeat``, one after the other in this process
    def image(a, kernels=None):
        return gpu_render.to_host(gpu_render.launch(a, shape, kernels=kernels)[7])
    gpu_s, _ = best(lambda: image(args, kernels), repeat)
    ref_s, _ = best(lambda: image(ref_args), repeat)
    both = ref[0] & out[0]
    return dict(gpu_s=gpu_s, gpu_ref_s=ref_s, first_s=first_s,
                hit_differs=int((ref[0] != out[0]).sum()),
                depth_max_over_diag=(float(np.abs(ref[1][both] - out[1][both]).max())
                                     / scene.diagonal if both.any() else 0.0),
                rgb_max=int(np.abs(ref[7].astype(int) - out[7])[both].max(initial=0)),
                leaves_ratio=float(out[4].sum() / max(1, ref[4].sum())))


def bench_lit(kind, size, repeat, samples=16, images=None):
    """The gallery's look (lit, ``samples`` adaptive samples per pixel) of the bunny of
    ``kind``, on the CPU and on the GPU (issue 49: 1080p in 1 s or less on an H100 / H200),
    each best of ``repeat`` after a warm-up (the CPU's at 64 x 36: its kernels compiled
    before the timing); what differs between the two images. Also on the GPU: the film's
    samples one thread per pixel (``gpu_whole_s``, ``gpu_render.SPLIT_SAMPLES`` off) against
    one thread per ray (``gpu_s``), and where one frame's time goes (``gpu_parts``: the
    samples and light launches, each with its copies, and the rest: the centre render and
    the film's host work)."""
    from tracer.rendering import gpu_render
    from tracer.rendering.renderer import render
    from tracer.scenes.scene import load_scene

    W, H = size
    over = {"shading": "lit", "samples": samples, "adaptive": True}
    path = REPO / "scenes" / f"bunny_{kind}.json"
    scene = load_scene(path, dict(over, width=W, height=H))
    render(load_scene(path, dict(over, width=64, height=36)))
    cpu_s, cpu = best(lambda: render(scene), repeat)
    t0 = time.perf_counter()
    render(scene, device="cuda")
    first_s = time.perf_counter() - t0
    split = gpu_render.SPLIT_SAMPLES
    try:
        gpu_render.SPLIT_SAMPLES = False
        whole_s, whole = best(lambda: render(scene, device="cuda"), repeat)
    finally:
        gpu_render.SPLIT_SAMPLES = split
    gpu_s, gpu = best(lambda: render(scene, device="cuda"), repeat)
    parts = _timed_parts(lambda: render(scene, device="cuda"))
    if images:
        from PIL import Image  # pillow (a dependency): loaded on use

        Path(images).mkdir(parents=True, exist_ok=True)
        Image.fromarray(gpu.rgb).save(Path(images) / f"lit_{kind}_gpu.png")
    both = cpu.hit & gpu.hit
    return dict(what=f"bunny {kind}, lit, {samples} adaptive", size=f"{W}x{H}", eps=scene.eps,
                diag=scene.diagonal, primitives=scene.objects[0].field.num_primitives,
                cpu_s=cpu_s, gpu_s=gpu_s, speedup=cpu_s / gpu_s, gpu_first_s=first_s,
                gpu_whole_s=whole_s, whole_equal=bool((whole.rgb == gpu.rgb).all()),
                gpu_parts=parts,
                hit_differs=int((cpu.hit != gpu.hit).sum()),
                depth_max_over_diag=(float(np.abs(cpu.depth[both].astype(float)
                                                  - gpu.depth[both]).max()) / scene.diagonal
                                     if both.any() else 0.0),
                rgb_max=int(np.abs(cpu.rgb.astype(int) - gpu.rgb).max(initial=0)))


def _timed_parts(run):
    """One call of ``run`` with the GPU film's launches timed (each waits for its copies
    back): ``{"total_s", "samples": [[pixels, K, s], ...], "light": [[points, s], ...],
    "rest_s"}``."""
    from tracer.rendering import gpu_render

    log = {"samples": [], "light": []}
    orig = gpu_render.trace_samples_cuda, gpu_render.light_points_cuda

    def samples(tree, ray, rays, *rest):
        t = time.perf_counter()
        orig[0](tree, ray, rays, *rest)
        log["samples"].append([int(rays.rows.size), int(rays.offsets.shape[0]),
                               time.perf_counter() - t])

    def light(tree, objs, points, *rest):
        t = time.perf_counter()
        orig[1](tree, objs, points, *rest)
        log["light"].append([int(points[0].shape[0]), time.perf_counter() - t])

    gpu_render.trace_samples_cuda, gpu_render.light_points_cuda = samples, light
    try:
        t0 = time.perf_counter()
        run()
        total = time.perf_counter() - t0
    finally:
        gpu_render.trace_samples_cuda, gpu_render.light_points_cuda = orig
    log["total_s"] = total
    log["rest_s"] = total - sum(v[-1] for v in log["samples"] + log["light"])
    return log


def bench_grid(kind, n, repeat, variants=()):
    from benchmarks.bench_grid import grid, normalise
    from smoothdist import DataMesh, SmoothDistanceField
    from smoothdist import cuda as sdcuda

    source = DataMesh.load(REPO / "scenes" / "data" / "bunny.off")
    mesh = normalise(source.as_kind(kind))
    field = SmoothDistanceField(mesh)
    e = mesh.min_edge_length()
    alpha = 1.0 / e if e is not None else 1.0 / normalise(source).min_edge_length()
    Q = grid(n)
    kw = dict(alpha=alpha, beta=0.5)
    field.smooth_distance(Q[:64], **kw)
    t0 = time.perf_counter()
    field.smooth_distance(Q[:64], device="cuda", **kw)
    first_s = time.perf_counter() - t0
    cpu_s, cpu = best(lambda: field.smooth_distance(Q, **kw), repeat)
    alpha, beta, S, wgrad_scale = field.kernel_args(alpha, 0.5)
    dtree = field.device_tree()
    gpu_s, gpu = best(lambda: sdcuda.smooth_distance(field.tree, Q, alpha, beta, S, wgrad_scale,
                                                     0.0, dtree), repeat)
    # the kernel alone, the queries and the outputs already on the device (no copies)
    cu = sdcuda.cuda_module()
    dQ = cu.to_device(Q)
    outs = (cu.device_array(len(Q)), cu.device_array((len(Q), 3)),
            cu.device_array(len(Q), dtype=np.int64), cu.device_array(len(Q), dtype=np.int64))

    def kernel_only():
        sdcuda.kernels()["smooth"][sdcuda._blocks(len(Q)), sdcuda.THREADS](
            dtree, dQ, float(alpha), float(beta), 0.0, float(S), float(wgrad_scale), *outs)
        cu.synchronize()

    kernel_s, _ = best(kernel_only, repeat)

    def resident():
        # the public call with the queries on the device (issue 49): the check of the
        # queries, the launch and the outputs allocated there; nothing copied
        field.smooth_distance(dQ, **kw)
        cu.synchronize()

    resident_s, _ = best(resident, repeat)
    # issue 49 item 3, measured side by side in this run: the kernel alone with a 32-bit
    # traversal stack, and with the node boxes stored as float32 (rounded outwards)
    trials = {}
    for variant in variants:
        t_first = time.perf_counter()
        launch_variant = variant_launch(variant, field.tree, dtree)
        launch_variant(dQ, float(alpha), float(beta), float(S), float(wgrad_scale), outs)
        t_first = time.perf_counter() - t_first
        t_var, _ = best(lambda: launch_variant(dQ, float(alpha), float(beta), float(S),
                                               float(wgrad_scale), outs), repeat)
        trials[variant] = dict(kernel_s=t_var, first_s=t_first,
                               distance_max_diff=float(np.abs(outs[0].copy_to_host()
                                                              - gpu[0]).max()),
                               leaves_ratio=float(outs[3].copy_to_host().sum()
                                                  / max(1, gpu[3].sum())))
    return dict(what=f"grid {kind}", size=f"{n}^3", eps=None, primitives=field.num_primitives,
                cpu_s=cpu_s, gpu_s=gpu_s, speedup=cpu_s / gpu_s, gpu_first_s=first_s,
                gpu_kernel_s=kernel_s, gpu_resident_s=resident_s,
                hit_differs=None,
                depth_max_over_diag=None, rgb_max=None,
                distance_max_diff=float(np.abs(cpu.distance - gpu[0]).max()),
                mean_leaves_gpu=float(gpu[3].mean()), gpu_variants=trials)


#: the kernel variants ``--variants`` times: a 32-bit traversal stack (the grid), float32 node
#: boxes (the grid and the renders), a cap on the registers a thread uses (both)
VARIANTS = ("stack32", "box32", "regs128", "regs96", "regs64")
#: the variants that apply to the render kernels too
RENDER_VARIANTS = ("box32", "regs128", "regs96", "regs64")


def registers_of(variant):
    """The register cap N of a ``regsN`` variant."""
    return int(variant[len("regs"):])


@functools.lru_cache(maxsize=None)
def capped_jit(fn, registers):
    """``fn`` as a CUDA kernel compiled with at most ``registers`` registers a thread
    (``numba.cuda.jit(max_registers=...)``; the simulator, which has no registers, takes none),
    one per process (its compile is paid once, at its first launch). Call it after the
    kernels' module has set its global ``cuda``."""
    from smoothdist import cuda as sdcuda
    cuda = sdcuda.cuda_module()
    if sdcuda.simulated():
        return cuda.jit(fn)
    return cuda.jit(fn, max_registers=int(registers))


def smooth_stack32():
    """``smoothdist.cuda``'s smooth kernel function with an int32 traversal stack (half its
    local memory): the same code object, read with globals in which ``numba.int64`` is
    ``numba.int32`` (the stack is the kernel's only int64 local array), so that the variant
    cannot drift from the kernel it is measured against. Call it after
    ``smoothdist.cuda.kernels()`` (the kernel's global ``cuda`` must be set)."""
    from smoothdist import cuda as sdcuda

    fn = sdcuda._smooth_kernel
    types32 = types.ModuleType("numba_int32_stack")
    types32.int64, types32.float64 = numba.int32, numba.float64
    return types.FunctionType(fn.__code__, dict(fn.__globals__, numba=types32),
                              "_smooth_kernel_stack32", fn.__defaults__, fn.__closure__)


def boxes32(tree):
    """``tree`` with its node boxes as float32 rounded outwards (every box contains the
    float64 one, so each box distance stays a lower bound)."""
    lo = tree.lo.astype(np.float32)
    lo = np.where(lo > tree.lo, np.nextafter(lo, np.float32(-np.inf)), lo)
    hi = tree.hi.astype(np.float32)
    hi = np.where(hi < tree.hi, np.nextafter(hi, np.float32(np.inf)), hi)
    assert (lo <= tree.lo).all() and (hi >= tree.hi).all()
    return tree._replace(lo=np.ascontiguousarray(lo), hi=np.ascontiguousarray(hi))


def variant_launch(variant, tree, dtree):
    """A function ``(dQ, alpha, beta, S, wgrad_scale, outs)`` that launches the smooth
    kernel's ``variant`` (tol 0) and waits for it."""
    from smoothdist import cuda as sdcuda
    cuda = sdcuda.cuda_module()
    if variant == "stack32":
        sdcuda.kernels()
        kern, tr = cuda.jit(smooth_stack32()), dtree
    elif variant == "box32":
        kern, tr = sdcuda.kernels()["smooth"], sdcuda.device_tree(boxes32(tree))
    elif variant.startswith("regs"):
        sdcuda.kernels()
        kern, tr = capped_jit(sdcuda._smooth_kernel, registers_of(variant)), dtree
    else:
        raise ValueError(f"unknown variant {variant!r}; one of {VARIANTS}")

    def go(dQ, alpha, beta, S, wgrad_scale, outs):
        kern[sdcuda._blocks(dQ.shape[0]), sdcuda.THREADS](tr, dQ, alpha, beta, 0.0, S,
                                                          wgrad_scale, *outs)
        cuda.synchronize()
    return go


def markdown(card, rows, threads, cpu=None):
    """The results as a markdown table; ``cpu``: the CPU's name (default: this machine's)."""
    out = [f"GPU: {card}; CPU: {cpu or cpu_name()}, {threads} threads",
           "",
           "| case | size | primitives | CPU ms | GPU ms | speed-up | GPU ms, no cone pass "
           "| GPU ms, kernel only | GPU ms, queries on the GPU | GPU first call s "
           "| hits differ | depth / diag | colour | distance |",
           "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        def f(v, fmt):
            return "" if v is None else format(v, fmt)
        out.append(f"| {r['what']} | {r['size']} | {r['primitives']} | {1e3 * r['cpu_s']:.1f} "
                   f"| {1e3 * r['gpu_s']:.2f} | {r['speedup']:.1f}x "
                   f"| {f(r.get('gpu_nocone_s') and 1e3 * r['gpu_nocone_s'], '.2f')} "
                   f"| {f(r.get('gpu_kernel_s') and 1e3 * r['gpu_kernel_s'], '.2f')} "
                   f"| {f(r.get('gpu_resident_s') and 1e3 * r['gpu_resident_s'], '.2f')} "
                   f"| {r['gpu_first_s']:.1f} "
                   f"| {f(r['hit_differs'], 'd')} "
                   f"| {f(r['depth_max_over_diag'], '.2g')} | {f(r['rgb_max'], 'd')} "
                   f"| {f(r.get('distance_max_diff'), '.2g')} |")
    return "\n".join(out)


def write_results(path, card, rows):
    """The results so far as JSON (written whole after each case, so that a run stopped at
    its time limit keeps the cases it finished); returns the markdown table."""
    table = markdown(card, rows, numba.get_num_threads(), cpu_name())
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_suffix(".tmp")
    tmp.write_text(json.dumps({"card": card, "threads": numba.get_num_threads(),
                               "cpu": cpu_name(),
                               "load": os.getloadavg(), "rows": rows, "table": table},
                              indent=2))
    os.replace(tmp, out)
    return table


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--size", nargs=2, type=int, default=(1920, 1080), metavar=("W", "H"))
    p.add_argument("--eps", type=float, default=1e-3,
                   help="hit threshold, absolute (default 1e-3, the authors'; 0: the scene's)")
    p.add_argument("--grid", type=int, default=100, help="grid side N (N^3 queries)")
    p.add_argument("--repeat", type=int, default=5)
    p.add_argument("--blocks", nargs="*", default=[], metavar="CxR",
                   help="also time the render kernel with these thread blocks (columns x rows, "
                        "e.g. 32x4 8x8), the outputs kept between launches")
    p.add_argument("--cases", nargs="+", default=["render", "grid"],
                   choices=("render", "grid", "lit"),
                   help="what to measure: the normals renders, the grid, the lit look with 16 "
                        "adaptive samples (default: render grid)")
    p.add_argument("--lit", action="store_true", help="also the lit look (as --cases ... lit)")
    p.add_argument("--kinds", nargs="+", default=list(KINDS), choices=KINDS,
                   help="the bunny's kinds, in this order (default: all three)")
    p.add_argument("--variants", nargs="*", default=[], choices=VARIANTS,
                   help="also time the grid's kernel alone with a 32-bit traversal stack "
                        "(stack32), float32 node boxes rounded outwards (box32) or at most N "
                        "registers a thread (regsN), and the renders with box32 and regsN "
                        "(after every other case)")
    p.add_argument("--images", default=None, metavar="DIR",
                   help="write the GPU's lit images there (lit_KIND_gpu.png)")
    p.add_argument("--image-kinds", nargs="*", default=list(KINDS), choices=KINDS,
                   help="which kinds' lit images --images writes (default: all)")
    p.add_argument("--json", default=str(DEFAULT_JSON))
    args = p.parse_args(argv)
    cases = set(args.cases) | ({"lit"} if args.lit else set())
    cuda = gpu_or_exit()

    card = cuda.get_current_device().name
    card = card.decode() if isinstance(card, bytes) else str(card)
    rows = []

    def done(row):
        rows.append(row)
        print(row, flush=True)
        write_results(args.json, card, rows)

    blocks = [tuple(int(v) for v in b.lower().split("x")) for b in args.blocks]
    for kind in args.kinds if "render" in cases else ():
        done(bench_render(kind, tuple(args.size), args.eps or None, args.repeat, blocks))
    for kind in args.kinds if "grid" in cases else ():
        done(bench_grid(kind, args.grid, args.repeat, args.variants))
    for kind in args.kinds if "lit" in cases else ():
        done(bench_lit(kind, tuple(args.size), max(1, min(args.repeat, 3)),
                       images=args.images if kind in args.image_kinds else None))
    render_variants = [v for v in args.variants if v in RENDER_VARIANTS]
    if render_variants and "render" in cases:
        for row, kind in zip(rows, args.kinds):
            row["gpu_variants"] = {}
            for variant in render_variants:
                row["gpu_variants"][variant] = bench_render_variant(
                    kind, tuple(args.size), args.eps or None, args.repeat, variant)
                print(kind, variant, row["gpu_variants"][variant], flush=True)
                write_results(args.json, card, rows)
    print(write_results(args.json, card, rows))
    print(f"wrote {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
