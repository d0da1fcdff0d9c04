"""PNG encoding of a 1080p render: Pillow against our threaded writer.

Renders the paper's bunny (``scenes/bunny_points.json``, and the triangles in the lit shading
with 16 adaptive samples: ``lit``) once at 1920 x 1080, eps 1e-3 (as ``bench_scaling.py``),
then encodes each image into memory with Pillow (``Image.save(format="PNG")``: zlib level 6,
a filter chosen per row, one thread) and with :func:`tracer.image.write_png_bands` (Up filter,
level 6, one band per thread) at 1, 2, 4, ... threads up to the machine's cores, the encoders
alternating within each repeat, best of ``--repeat`` (5). Prints milliseconds (wall, and the
process's CPU time: on a shared machine the second thread may wait for a core) and file sizes,
and writes ``benchmarks/data/png.json`` with the machine and the load average.

Usage::

    python benchmarks/bench_png.py                    # points and lit, best of 5
    python benchmarks/bench_png.py --kinds points --threads 1 2 --out out/png.json
"""

import argparse
import io
import json
import os
import platform
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run from a checkout without installing
    sys.path.insert(0, str(ROOT))

import numba  # noqa: E402
import numpy as np  # noqa: E402
from PIL import Image  # noqa: E402

from tracer.image import PNG_LEVEL, write_png_bands  # noqa: E402
from tracer.rendering.renderer import render  # noqa: E402
from tracer.scenes.scene import load_scene  # noqa: E402

DEFAULT_OUT = ROOT / "benchmarks" / "data" / "png.json"


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    cores = min(os.cpu_count() or 1, numba.config.NUMBA_NUM_THREADS)
    counts = [n for n in (1, 2, 4, 8, 16, 32, 64) if n < cores] + [cores]
    p.add_argument("--kinds", nargs="+", choices=("points", "lit"), default=["points", "lit"])
    p.add_argument("--size", type=int, nargs=2, metavar=("W", "H"), default=[1920, 1080])
    p.add_argument("--threads", type=int, nargs="+", default=sorted(set(counts)), metavar="N",
                   help=f"thread counts of our writer (default 1, 2, 4, ... up to {cores})")
    p.add_argument("--repeat", type=int, default=5, help="encodings per encoder, best kept")
    p.add_argument("--out", default=str(DEFAULT_OUT))
    return p.parse_args(argv)


def render_image(kind, size):
    over = {"width": size[0], "height": size[1], "eps": 1e-3}
    if kind == "lit":
        over.update(shading="lit", samples=16, adaptive=True)
    name = "triangles" if kind == "lit" else kind
    return render(load_scene(ROOT / "scenes" / f"bunny_{name}.json", over)).rgb


def pillow_png(rgb):
    buf = io.BytesIO()
    Image.fromarray(rgb).save(buf, format="PNG")
    return buf.getvalue()


def our_png(rgb, threads):
    buf = io.BytesIO()
    write_png_bands(buf, rgb, threads=threads)
    return buf.getvalue()


def measure(rgb, threads, repeat):
    """``{encoder: {"ms": best, "cpu_ms": its process CPU time, "bytes": size}}``, the encoders
    alternating in each repeat."""
    encoders = {"pillow": pillow_png, **{f"ours_{n}": (lambda a, n=n: our_png(a, n))
                                         for n in threads}}
    best = {k: (float("inf"), 0.0) for k in encoders}
    size = {}
    for _ in range(repeat):
        for name, enc in encoders.items():
            t0, c0 = time.perf_counter(), time.process_time()
            data = enc(rgb)
            best[name] = min(best[name], (time.perf_counter() - t0, time.process_time() - c0))
            size[name] = len(data)
    with Image.open(io.BytesIO(our_png(rgb, max(threads)))) as img:  # decodes to the render
        assert (np.asarray(img) == rgb).all()
    return {k: {"ms": 1e3 * best[k][0], "cpu_ms": 1e3 * best[k][1], "bytes": size[k]}
            for k in encoders}


def main(argv=None):
    args = parse_args(argv)
    out = {"machine": {"cpu": platform.processor(), "cores": os.cpu_count(),
                       "python": platform.python_version(),
                       "pillow": Image.__version__},
           "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
           "size": args.size, "level": PNG_LEVEL, "repeat": args.repeat, "kinds": {}}
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            out["machine"]["cpu"] = next(ln.split(":", 1)[1].strip() for ln in f
                                         if ln.startswith("model name"))
    except (OSError, StopIteration):
        pass
    for kind in args.kinds:
        rgb = render_image(kind, args.size)
        load = [os.getloadavg()[0]]
        res = measure(rgb, args.threads, args.repeat)
        load.append(os.getloadavg()[0])
        out["kinds"][kind] = {"load_average": load, "encoders": res}
        base = res["pillow"]
        print(f"{kind}, {args.size[0]}x{args.size[1]}, best of {args.repeat}, load "
              f"{load[0]:.2f} -> {load[1]:.2f}")
        for name, r in res.items():
            print(f"  {name:>9}: {r['ms']:7.1f} ms ({base['ms'] / r['ms']:4.2f}x Pillow's speed), "
                  f"CPU {r['cpu_ms']:6.1f} ms, {r['bytes'] / 1e3:7.1f} kB "
                  f"({r['bytes'] / base['bytes']:.3f}x)")
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    tmp = f"{args.out}.{os.getpid()}.tmp"
    with open(tmp, "w", encoding="utf-8") as fh:
        json.dump(out, fh, indent=1)
    os.replace(tmp, args.out)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
