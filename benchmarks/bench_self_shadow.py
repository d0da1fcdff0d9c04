"""Lit renders that shadow their own surface wrongly, by brute force (issue 46 item 3).

For shapes of ``bench_fidelity``'s corpus, ``tracer.render_mesh`` lit at ``--size`` with the
defaults and at two other surfaces a user may ask for (the zero set, ``offset=0``; and a level
set about one edge length out, ``C = min(0.75 x mean edge, 0.08 x diagonal)`` at
``alpha = 6 / C``, the default before issue 46), and
:func:`tracer.checks.self_shadow.wrongly_dark` on each: of the pixels facing the key light that
the render shadowed, those whose light ray, sampled by brute force on the render's own surface,
passes clear of it.

Usage (from the repository root)::

    python benchmarks/bench_self_shadow.py --json benchmarks/data/self_shadow.json
"""

import argparse
import json
import os
import sys
import time
import warnings
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
for p in (str(REPO), str(REPO / "benchmarks")):
    if p not in sys.path:
        sys.path.insert(0, p)

SHAPES = ("icosphere1", "cylinder", "cone", "box", "annulus", "helix_strip", "open_plane",
          "sphere_with_holes", "two_boxes", "pv_torus", "pv_arrow", "pv_text", "bunny_low",
          "octopus_low")


def settings(field):
    h = field.mean_edge_length()
    c = min(0.75 * h, 0.08 * field.diagonal)
    return {"default": {}, "zero set": {"offset": 0.0},
            "one edge out": {"offset": c, "alpha": 6.0 / c, "alpha_u": "off"}}


def words(result, before):
    """The troubleshooting guide's sentence (tests/repo/test_docs_tables.py)."""
    shapes = len({r["shape"] for r in result["rows"]})
    surfaces = len({r["surface"] for r in result["rows"]})
    return (f"on {shapes} shapes at {surfaces} surfaces each ({result['size']}²), "
            f"{result['wrong']} of {result['checked']:,} shadowed pixels are wrongly dark "
            f"({before['wrong']} of {before['checked']:,} when one neighbour could fill a "
            f"pixel's shadow)")


def main(argv=None):
    import bench_fidelity as bf

    import tracer
    from tracer.checks.self_shadow import wrongly_dark

    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--size", type=int, default=128)
    p.add_argument("--shapes", nargs="+", default=list(SHAPES))
    p.add_argument("--json")
    args = p.parse_args(argv)
    warnings.simplefilter("ignore")
    shapes = bf.corpus()
    rows = []
    for name in args.shapes:
        shape = shapes[name]
        field = tracer.mesh_scene(shape, size=(8, 8)).objects[0].field
        for label, kw in settings(field).items():
            res = tracer.render_mesh(shape, size=(args.size, args.size), progress=None, **kw)
            w = wrongly_dark(res)
            rows.append(dict(shape=name, surface=label, **w))
            print(f"{name:>18} {label:>13}: {w['wrong']} of {w['checked']} shadowed pixels "
                  f"wrongly dark", flush=True)
    out = {"size": args.size, "rows": rows, "cores": os.cpu_count(),
           "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
           "wrong": sum(r["wrong"] for r in rows), "checked": sum(r["checked"] for r in rows)}
    print(f"{out['wrong']} of {out['checked']} shadowed pixels wrongly dark")
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=1) + "\n", encoding="utf-8")
    return out


if __name__ == "__main__":
    main()
