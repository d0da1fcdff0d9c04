"""Specks: dark pixels that shadow rays draw on lit renders (issue 35, item 4).

Counts, in lit renders (one sample per pixel, view iso for the clouds, the scene's own camera
for scene files), the pixels inside the silhouette (their whole 5 x 5 window hits the
surface) more than 40 grey levels darker than the median of that window: the issue's measure.
Cases: the issue's two random clouds at 512² (3,000 normal points scaled (1, 0.6, 0.4),
seed 0; 2,000 uniform points in a cube, seed 1) and shipped scenes at 256². On scenes with
thin tubes in front of other geometry (``trefoil``, ``capillary``, ``mixed``) the measure also
counts the tubes' darker outlines, and on every shape the creases where two parts meet: those
are geometry, not specks. To tell them apart each case is rendered a second time with shadows
and ambient occlusion off: ``unlit`` counts the flagged pixels of that render (geometry alone),
``added_by_light`` the pixels flagged with the light's rays on and not without them (what shadow
and occlusion rays add: specks, and also true contact shadows, which the 5 x 5 test cannot tell
from specks).

Usage::

    python benchmarks/bench_specks.py                      # writes renders/ripple/specks.csv
    python benchmarks/bench_specks.py --scenes bunny_points --no-clouds --out /tmp/s.csv
"""

import argparse
import csv
import datetime
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run from a checkout without installing
    sys.path.insert(0, str(ROOT))

import tracer  # noqa: E402
from tracer.rendering.lighting import Lighting  # noqa: E402

THRESHOLD = 40


def speck_mask(rgb, hit, threshold=THRESHOLD):
    """(H, W) bool: the pixels :func:`count_specks` counts."""
    from numpy.lib.stride_tricks import sliding_window_view

    g = np.asarray(rgb, dtype=np.float64)[..., :3].mean(axis=2)
    win = sliding_window_view(np.pad(g, 2, mode="edge"), (5, 5))
    med = np.median(win.reshape(*g.shape, 25), axis=2)
    inside = sliding_window_view(np.pad(hit, 2, constant_values=False), (5, 5)).all(axis=(2, 3))
    return inside & (g < med - threshold)


def _row(name, size, res, off, seconds):
    """One CSV row: the lit render ``res`` against the same render without shadows and AO."""
    on, geometry = speck_mask(res.rgb, res.hit), speck_mask(off.rgb, off.hit)
    return {"case": name, "size": size, "specks": int(on.sum()), "unlit": int(geometry.sum()),
            "added_by_light": int((on & ~geometry).sum()), "hit_pixels": int(res.hit.sum()),
            "seconds": seconds}


def count_specks(rgb, hit, threshold=THRESHOLD):
    """Pixels inside the silhouette more than ``threshold`` grey levels darker than the
    median of their 5 x 5 window (the same measure as ``tests/tracer/rendering/test_lighting.py``)."""
    return int(speck_mask(rgb, hit, threshold).sum())


def clouds():
    rng = np.random.default_rng(0)
    yield "normal3000", rng.normal(size=(3000, 3)) * [1.0, 0.6, 0.4]
    yield "cube2000", np.random.default_rng(1).uniform(-1.0, 1.0, size=(2000, 3))


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scenes", nargs="*", default=["bunny_points", "lion_points",
                                                   "bunny_triangles", "octopus_lit", "trefoil",
                                                   "capillary", "mixed"])
    p.add_argument("--no-clouds", action="store_true")
    p.add_argument("--out", default=str(ROOT / "renders" / "ripple" / "specks.csv"))
    args = p.parse_args(argv)
    from tracer.rendering.renderer import render
    from tracer.scenes.scene import load_scene

    rows = []
    if not args.no_clouds:
        for name, P in clouds():
            t = time.perf_counter()
            res = tracer.render_mesh(P, size=(512, 512), view="iso")
            sec = round(time.perf_counter() - t, 2)
            off = tracer.render_mesh(P, size=(512, 512), view="iso",
                                    lighting=Lighting(shadows=False, ao=False))
            rows.append(_row(name, 512, res, off, sec))
            print(rows[-1], flush=True)
    for name in args.scenes:
        t = time.perf_counter()
        sc = load_scene(str(ROOT / "scenes" / f"{name}.json"),
                        {"width": 256, "height": 256, "shading": "lit", "samples": 1,
                         "adaptive": False})
        res = render(sc)
        sec = round(time.perf_counter() - t, 2)
        off = render(load_scene(str(ROOT / "scenes" / f"{name}.json"),
                                {"width": 256, "height": 256, "shading": "lit", "samples": 1,
                                 "adaptive": False,
                                 "lighting": {"shadows": False, "ao": False}}))
        rows.append(_row(name, 256, res, off, sec))
        print(rows[-1], flush=True)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_suffix(".csv.tmp")
    with open(tmp, "w", newline="", encoding="utf-8") as fh:
        fh.write(f"# {datetime.date.today().isoformat()}: python benchmarks/bench_specks.py "
                 f"{' '.join(sys.argv[1:] if argv is None else argv)}\n")
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    os.replace(tmp, out)
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
