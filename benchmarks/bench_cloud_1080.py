"""Point clouds at 1080p, lit (issue 46 item 7): where the time of ``tracer.render_mesh`` goes.

Random samples of a torus's surface (``trimesh.sample.sample_surface``, 50,000 and 1,000,000
points), every option left to its default (``alpha="auto"``: the closing alpha), rendered at
1920 x 1080 three ways in one process after a warm-up: the normal colours (the primary march
alone), the lit look without shadow and occlusion rays (adds the shading normals and the film)
and the lit look (the default). The differences are the stages' costs.

Usage (from the repository root)::

    python benchmarks/bench_cloud_1080.py --json benchmarks/data/cloud_1080.json
"""

import argparse
import json
import os
import sys
import time
import warnings
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

WAYS = (("normals", dict(shading="normals")),
        ("lit_no_light_rays", dict(lighting=dict(shadows=False, ao=False))),
        ("lit", {}))


def run(n, size):
    import trimesh

    import tracer

    P, _ = trimesh.sample.sample_surface(trimesh.creation.torus(1.0, 0.35), n, seed=0)
    t0 = time.perf_counter()
    tracer.render_mesh(P, size=(64, 36), progress=None)              # warm-up, auto alpha
    row = {"points": n, "first_call_s": time.perf_counter() - t0}
    for tag, kw in WAYS:
        t0 = time.perf_counter()
        res = tracer.render_mesh(P, size=size, progress=None, **kw)
        s = res.summary() if callable(res.summary) else res.summary
        row[tag] = {"seconds": time.perf_counter() - t0, "mean_leaves": s["mean_leaves"],
                    "mean_steps": s["mean_steps"], "hit_fraction": s["hit_fraction"],
                    "light_queries": int(res.aovs.get("light_queries", 0))}
        print(n, tag, f"{row[tag]['seconds']:.1f} s", flush=True)
    row["alpha"] = float(res.scene.objects[0].alpha)
    return row


def words(result):
    """The troubleshooting guide's sentence about ``result`` (tests/repo/test_docs_tables.py)."""
    W, H = result["size"]
    parts = []
    for r in result["rows"]:
        lit, bare, nor = (r[k]["seconds"] for k in ("lit", "lit_no_light_rays", "normals"))
        parts.append(f"{r['points']:,} points {lit:.0f} s lit ({nor:.0f} s of it the primary "
                     f"march, {lit - bare:.0f} s the shadow and occlusion rays)")
    lo, hi = min(result["load_before"][0], result["load_after"][0]), \
        max(result["load_before"][0], result["load_after"][0])
    return (f"at {W}x{H} on {result['cores']} cores (load {lo:.1f}-{hi:.1f}), "
            + " and ".join(parts))


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--points", type=int, nargs="+", default=[50_000, 1_000_000])
    p.add_argument("--size", type=int, nargs=2, default=[1920, 1080])
    p.add_argument("--json")
    args = p.parse_args(argv)
    warnings.simplefilter("ignore")
    load0 = os.getloadavg()
    rows = [run(n, tuple(args.size)) for n in args.points]
    out = {"size": args.size, "rows": rows, "cores": os.cpu_count(),
           "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
           "load_before": list(load0), "load_after": list(os.getloadavg())}
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=1) + "\n", encoding="utf-8")
    return out


if __name__ == "__main__":
    main()
