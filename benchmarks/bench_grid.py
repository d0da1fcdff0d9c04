"""Grid benchmark: smooth and exact distance over the N^3 voxel centres of the unit cube.

The protocol of the paper's CPU benchmark (Madan & Levin 2022, Sec. 5; the authors'
``app/benchmark_cpu.cpp``):

* load a mesh and make its three data meshes: points (V), unique edges (E), triangles (F);
* normalise each so that its bounding box is centred at (0.5, 0.5, 0.5) with diagonal 0.5;
* query the N^3 voxel centres ``((i + 0.5) / N, (j + 0.5) / N, (k + 0.5) / N)`` of [0, 1]^3;
* smooth distance with ``alpha = 1 / (shortest edge of the normalised mesh)`` (the paper's
  heuristic; the authors' benchmark code itself uses alpha = 1), ``beta = 0.5``, no
  attenuation; and exact distance;
* report, per data type, the wall time of the whole grid (best of ``--repeat``), the mean
  number of leaves visited (exact primitive evaluations plus Barnes-Hut far-field nodes, the
  authors' ``num_visited``), the mean number of nodes visited and queries per second.

With ``--fcpw``, the exact distance to the triangles (F) is also computed by fcpw
(https://github.com/rohan-sawhney/fcpw, its CPU closest-point query; ``pip install fcpw``; not a
dependency of this project, the comparison is skipped when it is not installed) on the same
grid in the same run, interleaved with ours; the table then gives both CPU times (all
threads), their ratio, and the largest difference of the distances (fcpw works in float32).

Usage (from the repository root)::

    python benchmarks/bench_grid.py                      # scenes/data/bunny.off, N = 100
    python benchmarks/bench_grid.py mesh.obj --grid 50 --beta 0.25 --json out.json
    python benchmarks/bench_grid.py --fcpw                # exact distance against fcpw

The JIT is warmed up on a few queries before timing; compiled kernels are cached on disk.
"""

import argparse
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

from smoothdist import DataMesh, SmoothDistanceField  # noqa: E402

DEFAULT_MESH = REPO / "scenes" / "data" / "bunny.off"  # the paper's 3,485-vertex bunny
KINDS = (("V", "points"), ("E", "edges"), ("F", "triangles"))


def normalise(mesh):
    """A copy of ``mesh`` with its bbox centred at (0.5, 0.5, 0.5) and bbox diagonal 0.5."""
    lo, hi = mesh.bounds
    diag = float(np.linalg.norm(hi - lo))
    if diag == 0.0:
        raise ValueError(f"{mesh.name}: the bounding box is a single point; cannot normalise")
    V = (mesh.V - 0.5 * (lo + hi)) * (0.5 / diag) + 0.5
    return DataMesh(V, points=mesh.points if mesh.points.size else None,
                    edges=mesh.edges if mesh.edges.shape[0] else None,
                    triangles=mesh.triangles if mesh.triangles.shape[0] else None,
                    name=mesh.name)


def grid(n):
    """``(n^3, 3)`` voxel centres of [0, 1]^3, x slowest."""
    c = (np.arange(n) + 0.5) / n
    X, Y, Z = np.meshgrid(c, c, c, indexing="ij")
    return np.ascontiguousarray(np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=1))


def best_time(fn, repeat):
    best, out = np.inf, None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def run(args):
    path = Path(args.mesh)
    source = DataMesh.load(path)
    Q = grid(args.grid)
    nq = Q.shape[0]
    rows = []
    alpha_src = None
    for label, kind in KINDS:
        try:
            mesh = normalise(source.as_kind(kind))
        except ValueError as exc:          # e.g. a curve has no triangles
            print(f"# skipping {label} ({kind}): {exc}", file=sys.stderr)
            continue
        if alpha_src is None:
            e = normalise(source).min_edge_length()
            alpha_src = (1.0 / e) if e is not None else None
        t0 = time.perf_counter()
        field = SmoothDistanceField(mesh, leaf_size=args.leaf_size)
        build_s = time.perf_counter() - t0
        if args.alpha is not None:
            alpha = args.alpha
        else:
            e = mesh.min_edge_length()
            alpha = 1.0 / e if e is not None else (alpha_src or field.paper_alpha())
        kw = dict(alpha=alpha, beta=args.beta, alpha_u=args.alpha_u, gradient=args.gradient,
                  return_stats=True)
        # warm up the JIT (and the caches) on a few queries
        field.smooth_distance(Q[:64], **kw)
        field.exact_tree                   # the exact-query tree, built on first use
        field.exact_distance(Q[:64], return_stats=True)
        secs, (_, _, st) = best_time(lambda: field.smooth_distance(Q, **kw), args.repeat)
        rows.append(dict(type=label, kind=kind, query="smooth", primitives=field.num_primitives,
                         alpha=alpha, beta=args.beta, alpha_u=args.alpha_u, seconds=secs,
                         mean_leaves=float(st.leaves_visited.mean()),
                         mean_nodes=float(st.nodes_visited.mean()), queries_per_s=nq / secs,
                         build_s=build_s))
        secs, (_, _, st) = best_time(lambda: field.exact_distance(Q, return_stats=True),
                                     args.repeat)
        rows.append(dict(type=label, kind=kind, query="exact", primitives=field.num_primitives,
                         alpha=None, beta=None, alpha_u=None, seconds=secs,
                         mean_leaves=float(st.leaves_visited.mean()),
                         mean_nodes=float(st.nodes_visited.mean()), queries_per_s=nq / secs,
                         build_s=build_s))
    return rows, nq


def fcpw_compare(source, Q, repeat):
    """Exact distance to the normalised triangles: ours against fcpw, interleaved.

    Returns a dict with both CPU and wall times (best of ``repeat``), the ratio and the
    largest distance difference, or None when fcpw is not installed.
    """
    try:
        import fcpw
    except ImportError:
        print("# fcpw is not installed (pip install fcpw): skipping the comparison",
              file=sys.stderr)
        return None
    mesh = normalise(source.as_kind("triangles"))
    field = SmoothDistanceField(mesh)
    scene = fcpw.scene_3D()
    scene.set_object_count(1)
    scene.set_object_vertices(np.asfortranarray(mesh.V, dtype=np.float32), 0)
    scene.set_object_triangles(np.asfortranarray(mesh.triangles, dtype=np.int32), 0)
    scene.build(fcpw.aggregate_type.bvh_surface_area, True)
    Qf = np.asfortranarray(Q, dtype=np.float32)
    radii = np.full(Q.shape[0], np.inf, dtype=np.float32)

    def theirs():
        inter = fcpw.interaction_3D_list()
        scene.find_closest_points(Qf, radii, inter)
        return inter

    def ours():
        return field.exact_distance(Q)

    field.exact_tree                       # built on first use; untimed like scene.build
    field.exact_distance(Q[:64])
    best = {"ours": (np.inf, np.inf), "fcpw": (np.inf, np.inf)}
    out = {}
    for _ in range(repeat):
        for name, fn in (("fcpw", theirs), ("ours", ours)):
            c0, t0 = time.process_time(), time.perf_counter()
            out[name] = fn()
            cpu, wall = time.process_time() - c0, time.perf_counter() - t0
            best[name] = min(best[name], (cpu, wall))
    d_fcpw = np.array([i.d for i in out["fcpw"]])
    diff = float(np.abs(out["ours"][0] - d_fcpw).max())
    return dict(ours_cpu=best["ours"][0], ours_wall=best["ours"][1], fcpw_cpu=best["fcpw"][0],
                fcpw_wall=best["fcpw"][1], ratio_cpu=best["ours"][0] / best["fcpw"][0],
                max_diff=diff, triangles=field.num_primitives)


def markdown(rows):
    head = ("| type | primitives | query | alpha | beta | seconds | mean leaves | mean nodes "
            "| queries/s |")
    lines = [head, "|" + "---|" * 9]
    for r in rows:
        a = "" if r["alpha"] is None else f"{r['alpha']:.4g}"
        b = "" if r["beta"] is None else f"{r['beta']:g}"
        lines.append(f"| {r['type']} | {r['primitives']:,} | {r['query']} | {a} | {b} | "
                     f"{r['seconds']:.3f} | {r['mean_leaves']:.1f} | {r['mean_nodes']:.1f} | "
                     f"{r['queries_per_s']:,.0f} |")
    return "\n".join(lines)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("mesh", nargs="?", default=str(DEFAULT_MESH),
                   help="mesh file (OBJ/OFF/STL/PLY); default scenes/data/bunny.off")
    p.add_argument("--grid", type=int, default=100, help="N: N^3 queries (default 100)")
    p.add_argument("--alpha", type=float, default=None,
                   help="alpha (default: 1 / shortest edge of the normalised mesh)")
    p.add_argument("--beta", type=float, default=0.5, help="Barnes-Hut beta (default 0.5)")
    p.add_argument("--alpha-u", type=float, default=None, dest="alpha_u",
                   help="attenuation alpha_U (default: none)")
    p.add_argument("--gradient", choices=("metric", "exact"), default="metric")
    p.add_argument("--leaf-size", type=int, default=1, dest="leaf_size",
                   help="primitives per BVH leaf (default 1, as the authors)")
    p.add_argument("--repeat", type=int, default=3, help="timed runs, best kept (default 3)")
    p.add_argument("--threads", type=int, default=None, help="numba threads (default: all)")
    p.add_argument("--json", default=None, metavar="OUT", help="also write the rows as JSON")
    p.add_argument("--fcpw", action="store_true",
                   help="also time fcpw's exact distance to the triangles (if installed)")
    args = p.parse_args(argv)
    if args.grid < 1 or args.repeat < 1:
        p.error("--grid and --repeat must be >= 1")
    if not Path(args.mesh).is_file():
        p.error(f"mesh file not found: {args.mesh}")
    if args.threads is not None:
        numba.set_num_threads(args.threads)

    threads = numba.get_num_threads()
    print(f"mesh: {Path(args.mesh).resolve()}")
    print(f"grid: {args.grid}^3 = {args.grid ** 3:,} queries; beta = {args.beta}; "
          f"alpha_u = {args.alpha_u}; gradient = {args.gradient}; leaf size = {args.leaf_size}; "
          f"best of {args.repeat}")
    print(f"numba threads: {threads}; CPU count: {os.cpu_count()}; numba {numba.__version__}; "
          f"numpy {np.__version__}; {platform.processor() or platform.machine()}")
    rows, nq = run(args)
    print()
    print(markdown(rows))
    if args.fcpw:
        cmp_ = fcpw_compare(DataMesh.load(Path(args.mesh)), grid(args.grid), args.repeat)
        if cmp_ is not None:
            print()
            print(f"Exact distance to the {cmp_['triangles']:,} triangles, {nq:,} queries, "
                  f"best of {args.repeat}, interleaved:")
            print()
            print("| | CPU s | wall s |")
            print("|---|---:|---:|")
            print(f"| ours | {cmp_['ours_cpu']:.3f} | {cmp_['ours_wall']:.3f} |")
            print(f"| fcpw | {cmp_['fcpw_cpu']:.3f} | {cmp_['fcpw_wall']:.3f} |")
            print(f"| ratio ours / fcpw | {cmp_['ratio_cpu']:.2f} | "
                  f"{cmp_['ours_wall'] / cmp_['fcpw_wall']:.2f} |")
            print()
            print(f"largest |d_ours - d_fcpw| = {cmp_['max_diff']:.2e}")
            rows.append(dict(type="F", query="exact_vs_fcpw", **cmp_))
    if args.json:
        meta = dict(mesh=str(Path(args.mesh).resolve()), grid=args.grid, queries=nq,
                    repeat=args.repeat, leaf_size=args.leaf_size, gradient=args.gradient,
                    numba_threads=threads, cpu_count=os.cpu_count(),
                    numba=numba.__version__, numpy=np.__version__)
        Path(args.json).write_text(json.dumps(dict(meta=meta, rows=rows), indent=2))
        print(f"\nwrote {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
