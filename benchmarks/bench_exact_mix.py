"""Exact distance on many query mixes, against fcpw and libigl in the same process; the smooth
distance's cost beside it.

Mixes (each on its own data; ``Q`` in scene units):

* ``grid``: the paper's 100^3 grid around the bunny (``scenes/data/bunny.off`` scaled to a 0.5
  diagonal in the unit cube, as ``bench_grid.py``), in the grid's own order;
* ``box``: points uniform in the data's bounding box grown 1.3x, in random order;
* ``near``: points within 1 % of the diagonal from the surface (random spots, random
  directions), in random order;
* ``far``: points 2 to 10 diagonals from the data's centre, in random order;

on bumpy spheres of about 10k, 100k and 1M triangles (``trimesh.creation.uv_sphere`` with a
5 % bump), and on the 100k sphere's edges and vertices as edge and point data. ``box/100``
and ``near/100``: the same mixes asked ``--batch`` (100) queries per call, as a solver asks
(``--batch-queries`` of them in all), on the 100k sphere; ``near/1``, ``near/10`` and
``near/1000`` (``--batches``): the near mix at the other batch sizes (``near/1``: a tenth
of the queries), where libigl, which builds its tree at every call, is left out.

``--shapes`` adds users' shapes that are not round (issue 60):

* ``needle``: a 1000:1 open tube along z (radius 1, length 2000; 64 sections x 999 rings,
  127,872 triangles), asked ``tube`` queries: 1 to 4 radii from its axis, uniform along it,
  in random order;
* ``plane``: 199,712 coplanar triangles (a 317 x 317 grid of the unit square), near and far;
* ``cube``: a cube's surface in 1,298,892 triangles (329 x 329 squares a face), box and near.

Protocol: in one process, for ``--repeat`` rounds, each side runs once per round (fcpw, libigl,
ours, alternating); the table gives each side's best wall and CPU seconds and the spread
(worst / best wall), and the ratio ours / theirs of the best wall times. Every side uses every
thread of the machine (fcpw and libigl their own thread pools, ours numba's). Trees are built
before timing (build times recorded apart). Results are compared: the largest difference of
the distances (fcpw works in float32). fcpw and libigl are not dependencies of this project;
a side that is not installed is left out (``pip install fcpw libigl open3d``). open3d's
``RaycastingScene.compute_distance`` (float32, triangles only) builds its tree at its first
query: that first call is its build time. fcpw has no 3D line
segments or points: edges and points go in as degenerate triangles, used only where its
distances agree with ours to 1e-5 of the diagonal.

``--smooth`` adds the smooth distance (``alpha = --alpha-scale / diagonal``) at beta 0,
beta 0.5 and beta 0 with ``tol = --tol``, on ``--smooth-queries`` of each mix (evenly spaced
rows, in the mix's order), as the cost per query relative to the exact query's on the same rows.

Usage (from the repository root)::

    python benchmarks/bench_exact_mix.py --json benchmarks/data/exact_mix.json --smooth
    python benchmarks/bench_exact_mix.py --quick          # small sizes, a minute
"""

import argparse
import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

import numba  # noqa: E402
import numpy as np  # noqa: E402

from benchmarks.bench_grid import grid, normalise  # noqa: E402
from smoothdist import DataMesh, SmoothDistanceField  # noqa: E402

SIZES = {"10k": 51, "100k": 160, "1M": 501}     # uv_sphere count c -> 4 c (c - 2) triangles


def bumpy_sphere(count):
    """A uv sphere of radius 1 with a 5 % bump, ``(V, F)``."""
    import trimesh

    m = trimesh.creation.uv_sphere(count=[count, count])
    V = m.vertices * (1 + 0.05 * np.sin(7 * m.vertices[:, :1]) * np.cos(5 * m.vertices[:, 1:2]))
    return np.ascontiguousarray(V), np.ascontiguousarray(m.faces, dtype=np.int64)


def needle(sections=64, rings=1000, radius=1.0, ratio=1000):
    """An open tube along z, ``ratio`` diameters long: ``(V, F)``."""
    th = np.linspace(0, 2 * np.pi, sections, endpoint=False)
    z = np.linspace(0, 2 * radius * ratio, rings)
    ring = np.stack([radius * np.cos(th), radius * np.sin(th), np.zeros(sections)], 1)
    V = (ring[None] + z[:, None, None] * np.array([0.0, 0.0, 1.0])).reshape(-1, 3)
    a = np.arange(rings - 1)[:, None] * sections + np.arange(sections)[None]
    b = a - np.arange(sections)[None] + (np.arange(sections)[None] + 1) % sections
    F = np.concatenate([np.stack([a, b, b + sections], -1).reshape(-1, 3),
                        np.stack([a, b + sections, a + sections], -1).reshape(-1, 3)])
    return np.ascontiguousarray(V), np.ascontiguousarray(F, dtype=np.int64)


def grid_square(count):
    """The unit square of z = 0 as a ``count`` x ``count`` grid of vertices: ``(V, F)``."""
    c = np.linspace(0.0, 1.0, count)
    x, y = np.meshgrid(c, c, indexing="ij")
    V = np.stack([x.ravel(), y.ravel(), np.zeros(x.size)], 1)
    a = (np.arange(count - 1)[:, None] * count + np.arange(count - 1)[None]).ravel()
    F = np.concatenate([np.stack([a, a + count, a + count + 1], 1),
                        np.stack([a, a + count + 1, a + 1], 1)])
    return V, F.astype(np.int64)


def cube_surface(count):
    """A unit cube's surface, each face a ``count`` x ``count`` grid of squares, as one
    mesh with shared vertices: ``(V, F)``."""
    import trimesh

    V0, F0 = grid_square(count + 1)
    faces = []
    for axis in range(3):
        for side in (0.0, 1.0):
            V = np.roll(V0, axis + 1, axis=1)      # the zero column to ``axis``
            V[:, axis] = side
            faces.append(trimesh.Trimesh(V, F0 if side else F0[:, ::-1], process=False))
    m = trimesh.util.concatenate(faces)
    m.merge_vertices()
    return np.ascontiguousarray(m.vertices), np.ascontiguousarray(m.faces, dtype=np.int64)


def tube_queries(n, rng, radius=1.0, length=2000.0):
    """``n`` points 1 to 4 radii from the z axis, uniform along ``[0, length]``."""
    z = rng.uniform(0.0, length, n)
    a = rng.uniform(0.0, 2 * np.pi, n)
    r = rng.uniform(1.0, 4.0, n) * radius
    return np.stack([r * np.cos(a), r * np.sin(a), z], 1)


def mix_queries(name, field, n, rng):
    """``n`` queries of mix ``name`` around ``field``'s data, ``(n, 3)`` float64."""
    lo, hi = field.bounds
    c, L = 0.5 * (lo + hi), field.diagonal
    if name == "box":
        return c + rng.uniform(-1, 1, (n, 3)) * 0.5 * 1.3 * (hi - lo)
    dirs = rng.normal(size=(n, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    if name == "far":
        return c + rng.uniform(2.0, 10.0, (n, 1)) * L * dirs
    if name == "near":
        m = field.mesh
        V = m.V
        if m.triangles.shape[0]:
            T = m.triangles[rng.integers(0, m.triangles.shape[0], n)]
            u, v = rng.random((2, n, 1))
            flip = (u + v) > 1
            u, v = np.where(flip, 1 - u, u), np.where(flip, 1 - v, v)
            spots = V[T[:, 0]] + u * (V[T[:, 1]] - V[T[:, 0]]) + v * (V[T[:, 2]] - V[T[:, 0]])
        elif m.edges.shape[0]:
            E = m.edges[rng.integers(0, m.edges.shape[0], n)]
            s = rng.random((n, 1))
            spots = V[E[:, 0]] + s * (V[E[:, 1]] - V[E[:, 0]])
        else:
            spots = V[m.points[rng.integers(0, m.points.size, n)]]
        return spots + rng.uniform(0.0, 0.01, (n, 1)) * L * dirs
    raise ValueError(name)


def competitors(field, batch=0):
    """``{name: (build_s, query_fn)}`` for fcpw, open3d (triangles) and libigl (not for
    batches under 100 per call: it builds its tree at every call) where installed."""
    m = field.mesh
    V = m.V
    if m.triangles.shape[0]:
        F = m.triangles
    elif m.edges.shape[0]:
        F = m.edges
    else:
        F = m.points[:, None]
    out = {}
    try:
        import fcpw
    except ImportError:
        fcpw = None
    if fcpw is not None:
        tri = np.concatenate([F, np.repeat(F[:, -1:], 3 - F.shape[1], axis=1)], axis=1)
        t0 = time.perf_counter()
        scene = fcpw.scene_3D()
        scene.set_object_count(1)
        scene.set_object_vertices(np.asfortranarray(V, dtype=np.float32), 0)
        scene.set_object_triangles(np.asfortranarray(tri, dtype=np.int32), 0)
        scene.build(fcpw.aggregate_type.bvh_surface_area, True)
        build = time.perf_counter() - t0

        def fcpw_query(Q, scene=scene):
            inter = fcpw.interaction_3D_list()
            scene.find_closest_points(np.asfortranarray(Q, dtype=np.float32),
                                      np.full(Q.shape[0], np.inf, dtype=np.float32), inter)
            return np.array([i.d for i in inter])
        out["fcpw"] = (build, fcpw_query)
    try:
        import open3d
    except ImportError:
        open3d = None
    if open3d is not None and m.triangles.shape[0] and not m.edges.shape[0] \
            and not m.points.shape[0]:
        t0 = time.perf_counter()
        o3 = open3d.t.geometry.RaycastingScene()
        o3.add_triangles(open3d.core.Tensor(np.asarray(V, dtype=np.float32)),
                         open3d.core.Tensor(np.asarray(F, dtype=np.uint32)))
        o3.compute_distance(open3d.core.Tensor(np.zeros((1, 3), dtype=np.float32)))
        build = time.perf_counter() - t0

        def open3d_query(Q, o3=o3):
            return o3.compute_distance(open3d.core.Tensor(
                np.asarray(Q, dtype=np.float32))).numpy().astype(np.float64)
        out["open3d"] = (build, open3d_query)
    try:
        import igl
    except ImportError:
        igl = None
    if igl is not None and not 0 < batch < 100:
        Fi = np.ascontiguousarray(F, dtype=np.int64)

        def igl_query(Q):
            return np.sqrt(igl.point_mesh_squared_distance(Q, V, Fi)[0])
        out["libigl"] = (0.0, igl_query)
    return out


def timed(fn):
    c0, t0 = time.process_time(), time.perf_counter()
    out = fn()
    return time.perf_counter() - t0, time.process_time() - c0, out


def _batched(fn, batch):
    """``fn`` asked ``batch`` rows per call; the results concatenated."""
    if not batch:
        return fn
    return lambda Q: np.concatenate([fn(Q[i:i + batch]) for i in range(0, Q.shape[0], batch)])


def run_case(label, kind, mix, field, Q, repeat, smooth=None, batch=0):
    """One row: every side ``repeat`` times, alternating (``batch``: rows per call)."""
    sides = competitors(field, batch)
    sides["ours"] = (None, lambda Q: field.exact_distance(Q).distance)
    sides = {k: (b, _batched(fn, batch)) for k, (b, fn) in sides.items()}
    if batch:
        mix = f"{mix}/{batch}"
    field.exact_distance(Q[:256])                          # compiled, warm
    times = {k: [] for k in sides}
    results = {}
    for _ in range(repeat):
        for name, (_, fn) in sides.items():
            wall, cpu, results[name] = timed(lambda fn=fn: fn(Q))
            times[name].append((wall, cpu))
    L = field.diagonal
    row = {"data": label, "kind": kind, "mix": mix, "primitives": field.num_primitives,
           "queries": int(Q.shape[0]), "sides": {}}
    for name, ts in times.items():
        walls = [w for w, _ in ts]
        diff = float(np.abs(results[name] - results["ours"]).max())
        row["sides"][name] = {"wall_s": min(walls), "cpu_s": min(c for _, c in ts),
                              "spread": max(walls) / min(walls), "max_diff": diff,
                              "agrees": diff <= 1e-5 * L,
                              "build_s": sides[name][0]}
    ours = row["sides"]["ours"]["wall_s"]
    for name, s in row["sides"].items():
        s["ours_over_theirs"] = ours / s["wall_s"] if name != "ours" else 1.0
    if smooth:
        pick = np.linspace(0, Q.shape[0] - 1, min(smooth["queries"], Q.shape[0])).astype(int)
        row["smooth"] = smooth_costs(field, Q[pick], smooth, repeat)   # spread over the mix
    print(f"{label:>10} {kind:>9} {mix:>5}: " + ", ".join(
        f"{k} {v['wall_s']:.3f} s" + ("" if k == "ours" else f" (ours/theirs {v['ours_over_theirs']:.2f}"
                                      f"{'' if v['agrees'] else ', DIFFERS'})")
        for k, v in row["sides"].items()), flush=True)
    return row


def smooth_costs(field, Q, smooth, repeat):
    """Per query: exact and smooth (beta 0, 0.5, tol) seconds, best of ``repeat``, with
    spread, and the smooth/exact ratios."""
    alpha = smooth["alpha_scale"] / field.diagonal
    configs = {"exact": None, "beta 0": dict(beta=0.0), "beta 0.5": dict(beta=0.5),
               f"beta 0, tol {smooth['tol']:g}": dict(beta=0.0, tol=smooth["tol"])}
    for kw in configs.values():
        if kw is not None:
            field.smooth_distance(Q[:64], alpha=alpha, **kw)
    times = {k: [] for k in configs}
    for _ in range(repeat):
        for name, kw in configs.items():
            if kw is None:
                wall, cpu, _ = timed(lambda: field.exact_distance(Q))
            else:
                wall, cpu, _ = timed(lambda kw=kw: field.smooth_distance(Q, alpha=alpha, **kw))
            times[name].append(wall)
    n = Q.shape[0]
    out = {"alpha": alpha, "queries": n, "configs": {}}
    ex = min(times["exact"])
    for name, ts in times.items():
        out["configs"][name] = {"us_per_query": 1e6 * min(ts) / n,
                                "spread": max(ts) / min(ts), "over_exact": min(ts) / ex}
    return out


def cases(args):
    """``(label, kind, mix, field, Q)`` for every row, built lazily."""
    rng = np.random.default_rng(args.seed)
    bunny = normalise(DataMesh.load(REPO / "scenes" / "data" / "bunny.off").as_kind("triangles"))
    f = SmoothDistanceField(bunny)
    yield "bunny", "triangles", "grid", f, grid(args.grid), 0
    for size in args.sizes:
        V, F = bumpy_sphere(SIZES[size])
        f = SmoothDistanceField(V, F)
        for mix in args.mixes:
            yield (f"sphere {size}", "triangles", mix, f, mix_queries(mix, f, args.queries, rng),
                   0)
        if size == args.kinds_on and args.batch:
            for mix in ("box", "near"):
                yield (f"sphere {size}", "triangles", mix, f,
                       mix_queries(mix, f, args.batch_queries, rng), args.batch)
        if size == args.kinds_on:
            for batch in args.batches:      # a tenth of the queries one by one
                n = args.batch_queries // (10 if batch == 1 else 1)
                yield f"sphere {size}", "triangles", "near", f, mix_queries("near", f, n, rng), batch
        if size == args.kinds_on:
            for kind in ("edges", "points"):
                g = SmoothDistanceField(f.mesh.as_kind(kind))
                for mix in ("box", "near"):
                    yield (f"sphere {size}", kind, mix, g, mix_queries(mix, g, args.queries, rng),
                           0)
    shapes = {"needle": (needle, ("tube",)), "plane": (lambda: grid_square(317), ("near", "far")),
              "cube": (lambda: cube_surface(329), ("box", "near"))}
    for name in args.shapes:
        make, mixes = shapes[name]
        f = SmoothDistanceField(*make())
        for mix in mixes:
            Q = (tube_queries(args.queries, rng) if mix == "tube"
                 else mix_queries(mix, f, args.queries, rng))
            yield name, "triangles", mix, f, Q, 0


def markdown(result):
    """The performance guide's table."""
    names = [n for n in ("fcpw", "open3d", "libigl")
             if any(n in r["sides"] for r in result["rows"])]
    head = ["data", "primitives", "mix", "queries", "ours wall s (spread)"]
    for n in names:
        head += [f"{n} wall s", f"ours / {n}"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in result["rows"]:
        o = r["sides"]["ours"]
        cells = [f"{r['data']} {r['kind']}", f"{r['primitives']:,}", r["mix"],
                 f"{r['queries']:,}", f"{o['wall_s']:.3f} ({o['spread']:.2f})"]
        for n in names:
            s = r["sides"].get(n)
            if s is None or not s["agrees"]:
                cells += ["-", "-"]
            else:
                cells += [f"{s['wall_s']:.3f}", f"{s['ours_over_theirs']:.2f}"]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def smooth_markdown(result):
    """The smooth-vs-exact cost table (rows with ``smooth``)."""
    rows = [r for r in result["rows"] if "smooth" in r]
    if not rows:
        return ""
    configs = list(rows[0]["smooth"]["configs"])
    head = ["data", "mix", "queries"] + [f"{c} us/query (x exact)" for c in configs]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        s = r["smooth"]
        cells = [f"{r['data']} {r['kind']}", r["mix"], f"{s['queries']:,}"]
        for c in configs:
            v = s["configs"][c]
            cells.append(f"{v['us_per_query']:.2f} ({v['over_exact']:.1f}x, spread "
                         f"{v['spread']:.2f})")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def machine():
    try:
        commit = subprocess.run(["git", "rev-parse", "HEAD"], cwd=REPO, capture_output=True,
                                text=True).stdout.strip()
    except OSError:
        commit = ""
    return {"cores": os.cpu_count(), "threads": numba.get_num_threads(),
            "cpu": platform.processor() or platform.machine(), "python": platform.python_version(),
            "load_before": os.getloadavg()[0], "commit": commit,
            "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())}


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--queries", type=int, default=200_000, help="queries per random mix")
    p.add_argument("--grid", type=int, default=100, help="the bunny grid's points per axis")
    p.add_argument("--sizes", nargs="+", default=["10k", "100k", "1M"], choices=list(SIZES))
    p.add_argument("--mixes", nargs="+", default=["box", "near", "far"],
                   choices=["box", "near", "far"])
    p.add_argument("--kinds-on", default="100k", help="size whose edges and points are run")
    p.add_argument("--batch", type=int, default=100,
                   help="queries per call of the batched rows (0: none)")
    p.add_argument("--batch-queries", type=int, default=20_000)
    p.add_argument("--batches", nargs="*", type=int, default=[1, 10, 1000],
                   help="more batch sizes, on the near mix of the --kinds-on sphere")
    p.add_argument("--shapes", nargs="*", default=["needle", "plane", "cube"],
                   choices=["needle", "plane", "cube"], help="users' shapes that are not round")
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--smooth", action="store_true", help="add the smooth distance's cost")
    p.add_argument("--smooth-queries", type=int, default=20_000)
    p.add_argument("--alpha-scale", type=float, default=200.0,
                   help="smooth distance: alpha = this / bbox diagonal")
    p.add_argument("--tol", type=float, default=1e-4)
    p.add_argument("--quick", action="store_true",
                   help="small sizes: 20k queries, grid 40, 10k and 100k spheres, no cube, "
                   "2 repeats")
    p.add_argument("--json", help="write the results here")
    args = p.parse_args(argv)
    if args.quick:
        args.queries, args.grid, args.repeat = 20_000, 40, 2
        args.sizes = [s for s in args.sizes if s != "1M"]
        args.shapes = [s for s in args.shapes if s != "cube"]
        args.smooth_queries = min(args.smooth_queries, 5_000)
    smooth = (dict(queries=args.smooth_queries, alpha_scale=args.alpha_scale, tol=args.tol)
              if args.smooth else None)
    result = {"machine": machine(), "args": vars(args), "rows": []}
    for label, kind, mix, field, Q, batch in cases(args):
        field.exact_tree
        with_smooth = smooth if (mix in ("grid", "box", "near") and kind == "triangles"
                                 and field.num_primitives < 500_000 and not batch) else None
        result["rows"].append(run_case(label, kind, mix, field, Q, args.repeat, with_smooth,
                                       batch))
    result["machine"]["load_after"] = os.getloadavg()[0]
    print(markdown(result))
    print()
    print(smooth_markdown(result))
    if args.json:
        Path(args.json).write_text(json.dumps(result, indent=1) + "\n", encoding="utf-8")
    return result


if __name__ == "__main__":
    main()
