"""The film's host work: the seconds a lit, sampled frame spends in numpy on the calling thread
(shading, light fill, sample bookkeeping, compositing, sRGB) beside those in its ray kernels.

The film (:func:`tracer.rendering.film.form_image`) runs its ray kernels (extra samples,
shadow and occlusion rays) through ``smoothdist.schedule.run_tasks``; this script times every
such call and the film as a whole, so that ``host = film - kernels``. On a GPU render the
kernels run on the card and the host part is what is left on the CPU (issue 49: 66-73 % of
the lit 1080p frame on the H200's host, ``benchmarks/data/gpu_h200_lit.json``). The image's
SHA-1 is recorded, so that a change to the host code can show it draws the same pixels.

Usage (from the repository root)::

    python benchmarks/bench_film_host.py                         # bunny, 1920 x 1080, 16 adaptive
    python benchmarks/bench_film_host.py --size 960 540 --repeat 3 --out out.json
    python benchmarks/bench_film_host.py --batches benchmarks/data/film_batches.json
"""

import argparse
import hashlib
import json
import os
import platform
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

import numba  # noqa: E402
import numpy as np  # noqa: E402

from tracer.rendering import film, renderer  # noqa: E402
from tracer.scenes.scene import load_scene  # noqa: E402


class Timed:
    """A stand-in for a function that adds the wall time of each call to ``seconds``."""

    def __init__(self, fn):
        self.fn, self.seconds = fn, 0.0

    def __call__(self, *args, **kw):
        t = time.perf_counter()
        try:
            return self.fn(*args, **kw)
        finally:
            self.seconds += time.perf_counter() - t


def one_frame(scene, samples):
    """``(film_s, kernel_s, total_s, rgb sha1)`` of one lit render of ``scene``."""
    kernels, whole = Timed(film.run_tasks), Timed(film.form_image)
    film.run_tasks, renderer.form_image = kernels, whole
    try:
        res = renderer.render(scene, samples=samples, adaptive=True)
    finally:
        film.run_tasks, renderer.form_image = kernels.fn, whole.fn
    return whole.seconds, kernels.seconds, res.seconds, hashlib.sha1(res.rgb.tobytes()).hexdigest()


def sample_batches(scene, samples):
    """The film's batches of extra samples in one lit render of ``scene``: per call of its
    sample kernel, the pixels, the samples each and the distance evaluations of each ray (its
    mean, 99th percentile and largest; the pixel's cone bounds are booked on its first ray).
    On a card each batch is one launch, one thread a ray (``gpu_render.SPLIT_SAMPLES``), so a
    batch that fills the card once takes as long as its slowest ray."""
    batches = []
    trace = film._trace

    def counted(kargs, depth_max, options, pixels, W, offsets, *rest, **kw):
        out = trace(kargs, depth_max, options, pixels, W, offsets, *rest, **kw)
        ev = out[3]
        if ev.size:
            batches.append({"pixels": int(pixels.size), "samples": len(offsets),
                            "rays": int(ev.size), "evals_mean": float(ev.mean()),
                            "evals_p99": float(np.percentile(ev, 99)),
                            "evals_max": int(ev.max())})
        return out

    film._trace = counted
    try:
        renderer.render(scene, samples=samples, adaptive=True)
    finally:
        film._trace = trace
    return batches


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scene", default="bunny_triangles")
    p.add_argument("--size", type=int, nargs=2, default=(1920, 1080), metavar=("W", "H"))
    p.add_argument("--samples", type=int, default=16)
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--out", default=None, help="JSON results file")
    p.add_argument("--batches", default=None, metavar="JSON",
                   help="instead: count the evaluations of the film's sample batches in one "
                        "frame (sample_batches) and write them there")
    args = p.parse_args(argv)
    W, H = args.size
    small = load_scene(REPO / "scenes" / f"{args.scene}.json",
                       {"width": 64, "height": 48, "shading": "lit"})
    one_frame(small, args.samples)          # compile (or load) the kernels first
    scene = load_scene(REPO / "scenes" / f"{args.scene}.json",
                       {"width": W, "height": H, "shading": "lit"})
    if args.batches:
        batches = sample_batches(scene, args.samples)
        for b in batches:
            print(b)
        Path(args.batches).write_text(json.dumps(
            {"scene": args.scene, "size": [W, H], "samples": args.samples, "adaptive": True,
             "eps": float(scene.march.eps), "batches": batches}, indent=1) + "\n")
        return batches
    runs = []
    for _ in range(args.repeat):
        film_s, kernel_s, total_s, sha = one_frame(scene, args.samples)
        runs.append({"film_s": film_s, "kernel_s": kernel_s, "host_s": film_s - kernel_s,
                     "frame_s": total_s, "rgb_sha1": sha})
        print(f"frame {total_s:.2f} s: film {film_s:.2f} s = kernels {kernel_s:.2f} s + host "
              f"{film_s - kernel_s:.2f} s")
    best = min(runs, key=lambda r: r["host_s"])
    out = {"scene": args.scene, "size": [W, H], "samples": args.samples, "adaptive": True,
           "threads": numba.get_num_threads(), "cpu": platform.processor() or platform.machine(),
           "cpu_count": os.cpu_count(), "runs": runs, "best_host_s": best["host_s"],
           "rgb_sha1": sorted({r["rgb_sha1"] for r in runs})}
    if args.out:
        Path(args.out).write_text(json.dumps(out, indent=2) + "\n")
    return out


if __name__ == "__main__":
    main()
