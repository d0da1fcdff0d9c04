"""Mesh-to-mesh benchmark: the paper's Table 3 cases (Madan & Levin 2022, Sec. 5.5).

One "evaluation" is what the paper's Table 3 times: the smooth distance between a data mesh and a
query mesh (Eq. 6) with the gradient of every query vertex (Eq. 8), ``beta = 0.5``, no
attenuation. The paper ran each on 28 CPU threads; we report wall time on this machine's cores.

Cases (the paper's data sizes and alphas; geometry generated here unless shipped):

=============  ==========================  ==========================  =======  ==========
case           data                        query                       alpha    paper (ms)
=============  ==========================  ==========================  =======  ==========
bunny-bunny    bunny.off, 6,966 triangles  the same bunny, triangles   200/200  92.5717
ring-toss      12,400 points (board, pegs) trefoil.obj resampled,      20/20    1.4727
                                           100 edges
bowl-ico       bowl, 736 edges             icosphere, 120 edges        50/50    2.72934
slide-sphere   slide, 615 edges            UV sphere, 960 triangles    100/100  33.5601
=============  ==========================  ==========================  =======  ==========

Placement: the query is moved along a fixed direction until the exact minimum pairwise distance
equals ``gap`` (default ``1 / alpha``), i.e. resting just off contact, as in the simulations. The
bunny copy sits above the data bunny (+y); the trefoil is threaded on a peg, just above the board;
the icosphere rests at the bottom of the bowl; the sphere lies in the slide's chute.

Usage (from the repository root)::

    python benchmarks/bench_mesh_distance.py                  # all cases, best of 10
    python benchmarks/bench_mesh_distance.py --case bunny-bunny --repeat 20 --json out.json
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

from smoothdist import DataMesh, MeshDistance  # noqa: E402

DATA = REPO / "scenes" / "data"


# ----------------------------------------------------------------------------- geometry
def resample_closed_polyline(V, E, n):
    """``n`` vertices and ``n`` edges evenly spaced by arc length along a closed polyline."""
    nxt = {int(a): int(b) for a, b in E}
    order = [int(E[0, 0])]
    while nxt[order[-1]] != order[0]:
        order.append(nxt[order[-1]])
    P = V[order + [order[0]]]
    seg = np.linalg.norm(np.diff(P, axis=0), axis=1)
    s = np.concatenate([[0], np.cumsum(seg)])
    u = np.linspace(0, s[-1], n, endpoint=False)
    out = np.stack([np.interp(u, s, P[:, a]) for a in range(3)], axis=1)
    return out, np.stack([np.arange(n), (np.arange(n) + 1) % n], axis=1)


def ring_toss_points():
    """12,400 points: an 80 x 80 board (4 x 4, spacing 0.05) and 6 pegs of 1,000 points each."""
    g = (np.arange(80) + 0.5) * 0.05 - 2.0
    X, Z = np.meshgrid(g, g, indexing="ij")
    board = np.stack([X.ravel(), np.zeros(X.size), Z.ravel()], axis=1)
    pegs = []
    th = np.linspace(0, 2 * np.pi, 20, endpoint=False)
    hs = (np.arange(50) + 0.5) * 0.032
    for cx, cz in ((0.0, 0.0), (-1.2, -1.2), (1.2, -1.2), (-1.2, 1.2), (1.2, 1.2), (0.0, 1.5)):
        T, H = np.meshgrid(th, hs, indexing="ij")
        pegs.append(np.stack([cx + 0.1 * np.cos(T.ravel()), H.ravel(),
                              cz + 0.1 * np.sin(T.ravel())], axis=1))
    return np.concatenate([board] + pegs)


def trefoil_100():
    """The shipped trefoil polyline resampled to 100 edges, scaled to a 2.0 bbox diagonal."""
    m = DataMesh.load(DATA / "curves" / "trefoil.obj")
    V, E = resample_closed_polyline(m.V, m.edges, 100)
    V = (V - V.mean(axis=0)) * (2.0 / np.linalg.norm(np.ptp(V, axis=0)))
    # lie flat: the knot's thin axis becomes y
    thin = int(np.argmin(np.ptp(V, axis=0)))
    perm = [a for a in range(3) if a != thin]
    V = V[:, [perm[0], thin, perm[1]]]
    return V, E


def bowl_edges(nlon=46, nrings=8, radius=1.0):
    """A hemispherical wire bowl: ``nrings`` latitude circles of ``nlon`` vertices plus
    meridians down to the bottom pole: ``2 * nlon * nrings`` = 736 edges by default."""
    V = [[0.0, -radius, 0.0]]
    E = []
    for r in range(1, nrings + 1):
        phi = 0.5 * np.pi * r / nrings          # angle from the bottom pole
        for k in range(nlon):
            th = 2 * np.pi * k / nlon
            V.append([radius * np.sin(phi) * np.cos(th), -radius * np.cos(phi),
                      radius * np.sin(phi) * np.sin(th)])
    idx = lambda r, k: 1 + (r - 1) * nlon + (k % nlon)  # noqa: E731
    for r in range(1, nrings + 1):
        for k in range(nlon):
            E.append([idx(r, k), idx(r, k + 1)])                      # latitude circle
            E.append([0 if r == 1 else idx(r - 1, k), idx(r, k)])     # meridian
    return np.array(V), np.array(E)


def icosphere_edges(radius=0.25):
    """Icosphere (1 subdivision): 42 vertices, 120 unique edges."""
    import trimesh

    ico = trimesh.creation.icosphere(subdivisions=1, radius=radius)
    return np.asarray(ico.vertices), np.asarray(ico.edges_unique)


def slide_edges(nu=48, nv=7, length=4.0, radius=0.5, drop=1.5, n_edges=615):
    """A curved half-pipe chute as a wire grid (``nu`` along, ``nv`` across), trimmed to
    ``n_edges`` edges (the paper's 615)."""
    u = np.linspace(0, 1, nu)
    a = np.linspace(-0.5 * np.pi, 0.5 * np.pi, nv)          # across the chute
    V = []
    for ui in u:
        x = length * ui
        y = drop * (1 - ui) ** 2
        yaw = 0.6 * np.sin(np.pi * ui)                         # gentle bend
        for aj in a:
            side = radius * np.sin(aj)
            V.append([x - side * np.sin(yaw), y - radius * np.cos(aj), side * np.cos(yaw)])
    V = np.array(V)
    idx = lambda i, j: i * nv + j  # noqa: E731
    E = []
    for i in range(nu):
        for j in range(nv):
            if j + 1 < nv:
                E.append([idx(i, j), idx(i, j + 1)])
            if i + 1 < nu:
                E.append([idx(i, j), idx(i + 1, j)])
    return V, np.array(E[:n_edges])


def uv_sphere(nlon=32, nlat=16, radius=0.3):
    """Latitude-longitude sphere: ``2 * nlon * (nlat - 1)`` = 960 triangles by default."""
    V = [[0, radius, 0]]
    for i in range(1, nlat):
        th = np.pi * i / nlat
        for k in range(nlon):
            ph = 2 * np.pi * k / nlon
            V.append([radius * np.sin(th) * np.cos(ph), radius * np.cos(th),
                      radius * np.sin(th) * np.sin(ph)])
    V.append([0, -radius, 0])
    V = np.array(V, dtype=float)
    ring = lambda i, k: 1 + (i - 1) * nlon + (k % nlon)  # noqa: E731
    F = []
    south = len(V) - 1
    for k in range(nlon):
        F.append([0, ring(1, k + 1), ring(1, k)])
        F.append([south, ring(nlat - 1, k), ring(nlat - 1, k + 1)])
    for i in range(1, nlat - 1):
        for k in range(nlon):
            a, b = ring(i, k), ring(i, k + 1)
            c, d = ring(i + 1, k), ring(i + 1, k + 1)
            F.append([a, b, d])
            F.append([a, d, c])
    return V, np.array(F)


def cases():
    """``{name: (data (V, F), query (V, F), alpha, alpha_q, start, direction, paper_ms)}``.

    The query starts at ``start`` and is moved along ``direction`` towards the data until the
    exact gap equals ``1 / alpha`` (see :func:`place`).
    """
    bunny = DataMesh.load(DATA / "bunny.off")
    tref_V, tref_E = trefoil_100()
    # thread the trefoil's central hole on the peg at the origin
    tref_V = tref_V - [tref_V[:, 0].mean(), 0, tref_V[:, 2].mean()]
    sl_V, sl_E = slide_edges()
    i_mid = 24 * 7 + 3                                        # a vertex mid-way down the chute
    return {
        "bunny-bunny": ((bunny.V, bunny.triangles), (bunny.V, bunny.triangles), 200.0, 200.0,
                        np.array([0.0, 0.3, 0.0]), np.array([0.0, -1.0, 0.0]), 92.5717),
        "ring-toss": ((ring_toss_points(), None), (tref_V, tref_E), 20.0, 20.0,
                      np.array([0.0, 1.2, 0.0]), np.array([0.0, -1.0, 0.0]), 1.4727),
        "bowl-ico": (bowl_edges(), icosphere_edges(), 50.0, 50.0, np.array([0.0, 0.5, 0.0]),
                     np.array([0.0, -1.0, 0.0]), 2.72934),
        "slide-sphere": ((sl_V, sl_E), uv_sphere(), 100.0, 100.0,
                         sl_V[i_mid] + np.array([0.0, 1.0, 0.0]), np.array([0.0, -1.0, 0.0]),
                         33.5601),
    }


def time_call(f, repeat):
    T = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        f()
        T.append(time.perf_counter() - t0)
    return float(np.min(T)), float(np.median(T))


def run_case(name, spec, repeat, beta, tol=0.0, placement=None):
    data, query, alpha, alpha_q, start, direction, paper_ms = spec
    md = MeshDistance(data, query, alpha=alpha, alpha_q=alpha_q, beta=beta, tol=tol)
    t = (md.translation_at_gap(1.0 / alpha, direction, start) if placement is None
         else np.asarray(placement))
    d, G = md(t=t)                                   # warm-up (JIT, caches)
    md.exact(t=t)
    best, med = time_call(lambda: md(t=t), repeat)
    ebest, emed = time_call(lambda: md.exact(t=t), repeat)
    nodes, leaves = md.last_stats
    de, _ = md.exact(t=t)
    q = md.query
    return {
        "case": name, "data_primitives": md.field.num_primitives,
        "data_kind": md.field.mesh.kind, "query_primitives": int(q.kind.size),
        "query_kind": ["points", "edges", "triangles"][int(q.kind.max())],
        "alpha": alpha, "alpha_q": alpha_q, "beta": beta, "tol": tol, "translation": t.tolist(),
        "smooth_distance": d, "exact_distance": de, "grad_norm_sum": float(np.linalg.norm(G.sum(0))),
        "ms_best": 1e3 * best, "ms_median": 1e3 * med, "exact_ms_best": 1e3 * ebest,
        "exact_ms_median": 1e3 * emed, "mean_leaves": float(leaves.mean()),
        "mean_nodes": float(nodes.mean()), "paper_ms_28_threads": paper_ms,
    }


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--case", action="append", help="run only this case (repeatable)")
    ap.add_argument("--repeat", type=int, default=10, help="timed calls per case (best is reported)")
    ap.add_argument("--beta", type=float, default=0.5)
    ap.add_argument("--tol", default="0,1e-6",
                    help="comma-separated pruning tolerances to run (0 = the paper's algorithm)")
    ap.add_argument("--json", help="also write the results to this JSON file")
    args = ap.parse_args(argv)
    if args.repeat < 1:
        print("error: --repeat must be >= 1", file=sys.stderr)
        return 2
    try:
        tols = [float(x) for x in args.tol.split(",")]
    except ValueError:
        print(f"error: --tol must be comma-separated numbers, got {args.tol!r}", file=sys.stderr)
        return 2
    if any(not np.isfinite(x) or x < 0 for x in tols):
        print("error: --tol values must be finite and >= 0", file=sys.stderr)
        return 2
    specs = cases()
    names = args.case or list(specs)
    for n in names:
        if n not in specs:
            print(f"error: unknown case {n!r}; choose from {', '.join(specs)}", file=sys.stderr)
            return 2
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"# {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, numba "
          f"{numba.get_num_threads()} threads, load average {load:.2f}")
    print(f"{'case':14s} {'data':>16s} {'query':>16s} {'alpha':>9s} {'tol':>6s} {'ms best':>8s} "
          f"{'ms med':>8s} {'paper ms':>9s} {'exact ms':>9s} {'d_hat':>9s} {'d exact':>9s} "
          f"{'leaves':>7s}")
    rows = []
    for n in names:
        placement = None
        for tol in tols:
            r = run_case(n, specs[n], args.repeat, args.beta, tol, placement)
            placement = r["translation"]
            rows.append(r)
            print(f"{n:14s} {r['data_primitives']:>7d} {r['data_kind']:>8s} "
                  f"{r['query_primitives']:>7d} {r['query_kind']:>8s} "
                  f"{r['alpha']:>4g}/{r['alpha_q']:<4g} {tol:6.0e} {r['ms_best']:8.2f} "
                  f"{r['ms_median']:8.2f} "
                  f"{r['paper_ms_28_threads']:9.2f} {r['exact_ms_best']:9.2f} "
                  f"{r['smooth_distance']:9.4f} {r['exact_distance']:9.4f} {r['mean_leaves']:7.1f}",
                  flush=True)
    if args.json:
        out = {"machine": {"processor": platform.processor() or platform.machine(),
                           "cpus": os.cpu_count(), "numba_threads": numba.get_num_threads(),
                           "load_average": load}, "repeat": args.repeat, "results": rows}
        tmp = args.json + ".tmp"
        with open(tmp, "w") as fh:
            json.dump(out, fh, indent=1)
        os.replace(tmp, args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
