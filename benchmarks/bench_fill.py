"""The film's light fill (``tracer.rendering.film._fill_light``) against the light computed at
every pixel, with and without the rule that the agreeing coarse neighbours must lie on both
sides of a pixel (``film.FILL_BETWEEN``, 2026-11-28).

For each scene, lit at ``--size`` with one sample per pixel (the centre samples, whose light
is filled in): the light at every pixel (``film.LIGHT_STRIDE = 1``, the reference), then the
default stride with the rule off and on, alternating, ``--repeat`` times each. Reported per
scene and rule: the wall time of the render (best of the repeats), the light queries, and the
pixels whose fill went wrong against the reference: shadow off by more than 0.5 on the ground
and on the surface, occlusion off by more than 0.2, colour off by more than 16 of 255.

Usage (from the repository root)::

    python benchmarks/bench_fill.py                     # the default scenes at 384 x 384
    python benchmarks/bench_fill.py --scenes lion_points --size 192 --out out.json
"""

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

import numpy as np  # noqa: E402

from tracer.rendering import film  # noqa: E402
from tracer.rendering.renderer import render  # noqa: E402
from tracer.scenes.scene import load_scene  # noqa: E402

SCENES = ("lion_points", "bunny_triangles", "octopus_lit", "two_objects", "trefoil")
DEFAULT_OUT = REPO / "benchmarks" / "data" / "fill_between.json"


def wrong_fills(res, ref):
    """Pixels of ``res`` whose filled light differs from ``ref``'s (light at every pixel)."""
    ground = res.aovs["ground"] & ref.aovs["ground"]
    hit = res.hit & ref.hit
    ds = np.abs(res.aovs["shadow"] - ref.aovs["shadow"])
    da = np.abs(res.aovs["ao"] - ref.aovs["ao"])
    rgb = np.abs(res.rgb.astype(int) - ref.rgb.astype(int)).max(axis=2)
    return {"shadow_ground": int((ds[ground] > 0.5).sum()),
            "shadow_surface": int((ds[hit] > 0.5).sum()),
            "ao": int((da[ground | hit] > 0.2).sum()), "colour": int((rgb > 16).sum())}


def bench_scene(name, size, repeat):
    scene = load_scene(REPO / "scenes" / f"{name}.json",
                       {"width": size, "height": size, "shading": "lit", "samples": 1})
    stride = film.LIGHT_STRIDE
    try:
        film.LIGHT_STRIDE = 1
        ref = render(scene)
    finally:
        film.LIGHT_STRIDE = stride
    out = {}
    rule = film.FILL_BETWEEN
    try:
        for _ in range(repeat):
            for between in (False, True):
                film.FILL_BETWEEN = between
                t0 = time.perf_counter()
                res = render(scene)
                dt = time.perf_counter() - t0
                row = out.setdefault("on" if between else "off", {"seconds": []})
                row["seconds"].append(dt)
                row.update(light_queries=int(res.aovs["light_queries"]), **wrong_fills(res, ref))
    finally:
        film.FILL_BETWEEN = rule
    out["every_pixel_light_queries"] = int(ref.aovs["light_queries"])
    return out


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scenes", nargs="+", default=list(SCENES))
    p.add_argument("--size", type=int, default=384)
    p.add_argument("--repeat", type=int, default=2)
    p.add_argument("--out", default=str(DEFAULT_OUT))
    args = p.parse_args(argv)
    # compile everything first (a small render each way)
    warm = load_scene(REPO / "scenes" / f"{args.scenes[0]}.json",
                      {"width": 32, "height": 32, "shading": "lit", "samples": 1})
    render(warm)
    load = [os.getloadavg()]
    results = {}
    for name in args.scenes:
        results[name] = bench_scene(name, args.size, args.repeat)
        r = results[name]
        print(f"{name:16s} " + "  ".join(
            f"{k}: {min(r[k]['seconds']):.2f} s, {r[k]['light_queries']} queries, wrong "
            f"{r[k]['shadow_ground']}/{r[k]['shadow_surface']}/{r[k]['ao']}/{r[k]['colour']}"
            for k in ("off", "on")), flush=True)
    load.append(os.getloadavg())
    commit = subprocess.run(["git", "rev-parse", "--short=12", "HEAD"], cwd=REPO,
                            capture_output=True, text=True).stdout.strip()
    dirty = bool(subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"],
                                cwd=REPO, capture_output=True, text=True).stdout.strip())
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_suffix(".tmp")
    tmp.write_text(json.dumps({"size": args.size, "repeat": args.repeat, "commit": commit,
                               "dirty": dirty, "load": load, "threads": os.cpu_count(),
                               "scenes": results}, indent=1))
    os.replace(tmp, out)
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
