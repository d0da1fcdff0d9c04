"""Build time and memory at scale: a scan of millions of primitives is ready in seconds, in
about the memory of its own arrays (against fcpw, open3d, Warp, libigl and scipy).

Data (radius 1, fixed seed; the exact sizes reached are in the results):

* ``triangles``: a uv sphere (``2 b`` segments, ``b`` bands, ``4 b (b - 1)`` triangles, ``b``
  chosen so that this is about n) whose vertices get Gaussian noise of 1e-3 of the radius;
* ``edges``: the unique edges of such a sphere with about n edges, ``(m, 2)`` int64;
* ``points``: n random points on a sphere whose radius has the same noise.

Per kind, size and library, one fresh process (this script's hidden ``--one`` mode) loads the
arrays, imports the library and runs everything once on a small copy of the data (2,000
primitives, the same number of queries: numba's and Warp's kernels compile there, so no compile
time is counted; ours counts numba's compile events in the timed part to show it), then hands
the C heap's free pages back (``malloc_trim``), reads ``VmRSS`` (before) from
``/proc/self/status``, runs the stages below and reads ``VmHWM`` (the process's peak) after
each. "Extra" memory is ``VmHWM`` after a stage minus ``VmRSS`` before (nothing is reset:
``hwm_before_mib``, the warm-up's own peak, is kept in the results; where a stage does not rise
above it, ``build_extra_bound`` marks the extra as an upper bound; below about 1e5 primitives
the readings are of the order of the allocator's noise). Stages:

* ``build``: ours ``SmoothDistanceField(V, F)``; fcpw ``scene_3D`` with a surface-area BVH
  (as ``bench_exact_mix.py``); open3d ``RaycastingScene.add_triangles`` (lazy: its tree is built
  in the first query, which is timed apart); Warp ``wp.Mesh`` on the CPU; libigl ``AABB.init``;
  scipy ``cKDTree`` (points);
* ``exact tree`` (ours only): ``field.exact_tree``, the second tree that ``exact_distance``
  builds for many exact queries (after one query per primitive), timed apart before the queries;
* ``first query`` / ``second query``: exact unsigned distance of ``--queries`` points within 1-4
  % of the bounding-box diagonal from the data (random spots, random directions), twice; queries
  per second from the second;
* ``smooth first`` / ``smooth second`` (ours only): ``smooth_distance`` at ``alpha = 100 /
  diagonal``, beta 0.5.

Every stage records wall and CPU seconds (CPU / wall shows the threads a library used; ours runs
numba's pool, scipy ``workers=-1``, the peers their defaults). The first query's distances are
compared with ours (largest difference / diagonal). A peer that is not installed or fails is
recorded as skipped, with the reason.

Renders: ``python -m tracer render FILE --size 128 128 --stage-times STAGES.json`` of the
triangles and points written as PLY (trimesh), wall seconds and the child's peak RSS
(``wait4``), its stages where the option exists (``null`` otherwise), and the ratio to a small
reference (20,000 triangles or points, rendered once before to fill the kernel cache).

Machine: CPU model, cores, numba threads, versions, load average before and after each
measurement, date, commit. ``--json`` writes the results (``benchmarks/data/build_scale.json``),
``--plot`` a log-log figure of build seconds and extra memory against size;
``python benchmarks/tables.py build-scale FILE`` makes the tables.

Usage (from the repository root; 1e7 is heavy: run it alone)::

    python benchmarks/bench_build_scale.py --json benchmarks/data/build_scale.json \\
        --plot benchmarks/data/build_scale.png
    python benchmarks/bench_build_scale.py --sizes 1e4,1e5,1e6,1e7 --kinds triangles
    python benchmarks/bench_build_scale.py --quick --json /tmp/bs.json --plot /tmp/bs.png
"""

import argparse
import gc
import importlib.metadata
import json
import os
import platform
import subprocess
import sys
import tempfile
import textwrap
import threading
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

KINDS = ("triangles", "edges", "points")
#: the libraries run on each kind (ours first)
LIBRARIES = {"triangles": ("ours", "fcpw", "open3d", "warp", "libigl"),
             "edges": ("ours", "libigl"),
             "points": ("ours", "scipy", "libigl")}
#: libraries whose tree is built by their first query
LAZY = {"open3d"}
#: the kinds rendered with ``tracer render``
RENDER_KINDS = ("triangles", "points")
NOISE = 1e-3            # vertex / radius noise, x radius
WARM = 2_000            # primitives of the warm-up data
SMALL = 20_000          # primitives of the render's small reference
ALPHA_SCALE = 100.0     # smooth query: alpha = this / diagonal
BETA = 0.5
AGREE = 1e-5            # distances agree to this x diagonal
MIB = float(1 << 20)


# --- data ---------------------------------------------------------------------------------

def uv_sphere(bands):
    """Unit uv sphere of ``bands`` latitude bands and ``2 bands`` segments, outward
    triangles: ``(V (2 + (bands - 1) 2 bands, 3), F (4 bands (bands - 1), 3) int64)``."""
    s = 2 * bands
    theta = np.pi * np.arange(1, bands) / bands
    phi = 2 * np.pi * np.arange(s) / s
    ring = np.stack([np.outer(np.sin(theta), np.cos(phi)), np.outer(np.sin(theta), np.sin(phi)),
                     np.repeat(np.cos(theta)[:, None], s, axis=1)], axis=-1).reshape(-1, 3)
    V = np.concatenate([[[0.0, 0.0, 1.0]], ring, [[0.0, 0.0, -1.0]]])
    j = np.arange(s)
    jn = (j + 1) % s
    a = 1 + s * np.arange(bands - 2)[:, None] + j          # band i's upper ring, (bands-2, s)
    b = 1 + s * np.arange(bands - 2)[:, None] + jn
    last, south = 1 + s * (bands - 2), V.shape[0] - 1
    F = np.concatenate([np.stack([np.zeros(s, dtype=np.int64), 1 + j, 1 + jn], axis=1),
                        np.stack([a, a + s, b], axis=-1).reshape(-1, 3),
                        np.stack([b, a + s, b + s], axis=-1).reshape(-1, 3),
                        np.stack([last + j, np.full(s, south), last + jn], axis=1)])
    return V, F.astype(np.int64)


def _bands(n, per):
    """Bands ``b`` for which ``per b (b - 1)`` is nearest ``n`` (at least 2)."""
    return max(2, int(round(0.5 + np.sqrt(0.25 + n / per))))


def unique_edges(F, nv):
    """The unique edges of triangles ``F`` over ``nv`` vertices, ``(m, 2)`` int64."""
    e = np.sort(F[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    _, first = np.unique(e[:, 0] * nv + e[:, 1], return_index=True)
    return np.ascontiguousarray(e[np.sort(first)])


def make_data(kind, n, seed):
    """About ``n`` primitives of ``kind`` on a noisy unit sphere: ``(V, F)``, ``F`` None for
    points, ``(m, 2)`` int64 for edges, ``(m, 3)`` int64 for triangles."""
    rng = np.random.default_rng(seed)
    if kind == "points":
        d = rng.normal(size=(int(n), 3))
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        return d * (1 + NOISE * rng.normal(size=(int(n), 1))), None
    V, F = uv_sphere(_bands(n, 4 if kind == "triangles" else 6))  # closed: 6 b (b - 1) edges
    V = V + NOISE * rng.normal(size=V.shape)
    return V, (F if kind == "triangles" else unique_edges(F, V.shape[0]))


def near_queries(V, F, count, seed):
    """``count`` points within 1-4 % of the bounding-box diagonal from the data: a random spot
    on a random primitive moved along a random direction, ``(count, 3)`` float64."""
    rng = np.random.default_rng(seed)
    L = float(np.linalg.norm(V.max(axis=0) - V.min(axis=0)))
    if F is None:
        spots = V[rng.integers(0, V.shape[0], count)]
    else:
        P = V[F[rng.integers(0, F.shape[0], count)]]          # (count, 2 or 3, 3)
        u = rng.random((count, 1))
        if F.shape[1] == 2:
            spots = P[:, 0] + u * (P[:, 1] - P[:, 0])
        else:
            v = rng.random((count, 1))
            flip = u + v > 1
            u, v = np.where(flip, 1 - u, u), np.where(flip, 1 - v, v)
            spots = P[:, 0] + u * (P[:, 1] - P[:, 0]) + v * (P[:, 2] - P[:, 0])
    d = rng.normal(size=(count, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return spots + rng.uniform(0.01, 0.04, (count, 1)) * L * d


def write_data(folder, kind, n, queries, seed):
    """``V.npy``, ``F.npy`` (not for points) and ``Q.npy`` in ``folder``; returns the row's
    description (primitives reached, input bytes of V plus F, diagonal)."""
    V, F = make_data(kind, n, seed)
    Q = near_queries(V, F, queries, seed + 1)
    np.save(folder / "V.npy", V)
    np.save(folder / "Q.npy", Q)
    if F is not None:
        np.save(folder / "F.npy", F)
    return {"kind": kind, "target": int(n), "n": int(V.shape[0] if F is None else F.shape[0]),
            "vertices": int(V.shape[0]), "input_bytes": int(V.nbytes + (0 if F is None
                                                                        else F.nbytes)),
            "diagonal": float(np.linalg.norm(V.max(axis=0) - V.min(axis=0)))}


def load_data(folder):
    """``(V, F or None, Q)`` written by :func:`write_data`."""
    f = folder / "F.npy"
    return (np.load(folder / "V.npy"), np.load(f) if f.exists() else None,
            np.load(folder / "Q.npy"))


# --- the libraries (child side) ------------------------------------------------------------
# each ``side_*(V, F, Q)`` returns its stages ``[(name, fn)]``, run in order; ``first query``
# returns the distances

def side_ours(V, F, Q):
    """``SmoothDistanceField(V, F)``, its exact tree, exact and smooth queries."""
    from smoothdist import SmoothDistanceField

    s = {}
    alpha = ALPHA_SCALE / float(np.linalg.norm(V.max(axis=0) - V.min(axis=0)))

    def build():
        s["f"] = SmoothDistanceField(V, F)

    def exact():
        return s["f"].exact_distance(Q).distance

    def smooth():
        return s["f"].smooth_distance(Q, alpha=alpha, beta=BETA).distance

    return [("build", build), ("exact tree", lambda: s["f"].exact_tree),
            ("first query", exact), ("second query", exact),
            ("smooth first", smooth), ("smooth second", smooth)]


def side_fcpw(V, F, Q):
    """fcpw's surface-area BVH in float32, as ``bench_exact_mix.competitors``."""
    import fcpw

    s = {}

    def build():
        scene = s["scene"] = fcpw.scene_3D()
        scene.set_object_count(1)
        scene.set_object_vertices(np.asfortranarray(V, dtype=np.float32), 0)
        scene.set_object_triangles(np.asfortranarray(F, dtype=np.int32), 0)
        scene.build(fcpw.aggregate_type.bvh_surface_area, True)

    def query():
        inter = fcpw.interaction_3D_list()
        s["scene"].find_closest_points(np.asfortranarray(Q, dtype=np.float32),
                                       np.full(Q.shape[0], np.inf, dtype=np.float32), inter)
        return np.array([i.d for i in inter])

    return [("build", build), ("first query", query), ("second query", query)]


def side_open3d(V, F, Q):
    """open3d's ``RaycastingScene`` (float32; it builds its tree in the first query)."""
    import open3d as o3d

    s = {}
    Qt = o3d.core.Tensor(np.ascontiguousarray(Q, dtype=np.float32))

    def build():
        s["scene"] = o3d.t.geometry.RaycastingScene()
        s["scene"].add_triangles(o3d.core.Tensor(np.ascontiguousarray(V, dtype=np.float32)),
                                 o3d.core.Tensor(np.ascontiguousarray(F, dtype=np.uint32)))

    def query():
        return s["scene"].compute_distance(Qt).numpy().astype(np.float64)

    return [("build", build), ("first query", query), ("second query", query)]


_WARP_KERNEL = []


def _warp_kernel():
    """The Warp kernel ``(mesh id, queries, max distance, out)``: unsigned distances."""
    import warp as wp

    if not _WARP_KERNEL:
        @wp.kernel
        def distance(mesh: wp.uint64, q: wp.array(dtype=wp.vec3), max_dist: float,
                     out: wp.array(dtype=float)):
            i = wp.tid()
            r = wp.mesh_query_point_no_sign(mesh, q[i], max_dist)
            out[i] = wp.length(wp.mesh_eval_position(mesh, r.face, r.u, r.v) - q[i])

        _WARP_KERNEL.append(distance)
    return _WARP_KERNEL[0]


def side_warp(V, F, Q):
    """Warp's ``wp.Mesh`` (its BVH) on the CPU, float32, ``mesh_query_point_no_sign``."""
    import warp as wp

    wp.config.quiet = True
    wp.init()
    kernel = _warp_kernel()
    s = {}

    def build():
        s["mesh"] = wp.Mesh(points=wp.array(V, dtype=wp.vec3, device="cpu"),
                            indices=wp.array(F.ravel().astype(np.int32), dtype=wp.int32,
                                             device="cpu"))

    def query():
        q = wp.array(Q, dtype=wp.vec3, device="cpu")
        out = wp.empty(Q.shape[0], dtype=float, device="cpu")
        wp.launch(kernel, dim=Q.shape[0], inputs=[s["mesh"].id, q, 1e30, out], device="cpu")
        wp.synchronize_device("cpu")
        return out.numpy().astype(np.float64)

    return [("build", build), ("first query", query), ("second query", query)]


def side_libigl(V, F, Q):
    """libigl's ``AABB`` over triangles, edges or points (``(m, 1)`` elements)."""
    import igl

    s = {}
    E = np.ascontiguousarray(np.arange(V.shape[0])[:, None] if F is None else F, dtype=np.int64)

    def build():
        s["tree"] = igl.AABB()
        s["tree"].init(V, E)

    def query():
        return np.sqrt(s["tree"].squared_distance(V, E, Q)[0])

    return [("build", build), ("first query", query), ("second query", query)]


def side_scipy(V, F, Q):
    """scipy's ``cKDTree`` over the points, queried with every core."""
    from scipy.spatial import cKDTree

    s = {}

    def build():
        s["tree"] = cKDTree(V)

    def query():
        return s["tree"].query(Q, workers=-1)[0]

    return [("build", build), ("first query", query), ("second query", query)]


SIDES = {"ours": side_ours, "fcpw": side_fcpw, "open3d": side_open3d, "warp": side_warp,
         "libigl": side_libigl, "scipy": side_scipy}


def release_free_memory():
    """Hands the C heap's free pages back to the system (glibc's ``malloc_trim``), so that
    ``VmRSS`` before a build counts no memory the build would reuse; nothing elsewhere."""
    try:
        import ctypes

        ctypes.CDLL("libc.so.6").malloc_trim(0)
    except (OSError, AttributeError):
        pass


def memory_mib():
    """``(VmRSS, VmHWM)`` of this process, MiB (``/proc/self/status``)."""
    vals = {}
    for line in Path("/proc/self/status").read_text().splitlines():
        key, _, rest = line.partition(":")
        if key in ("VmRSS", "VmHWM"):
            vals[key] = int(rest.split()[0]) / 1024
    return vals["VmRSS"], vals["VmHWM"]


class CompileCount:
    """Counts numba's compile events from now on (``.count``); 0 if numba is absent."""

    def __init__(self):
        self.count = 0
        try:
            from numba.core import event
        except ImportError:
            return
        outer = self

        class Listener(event.Listener):
            def on_start(self, ev):
                pass

            def on_end(self, ev):
                outer.count += 1

        event.register("numba:compile", Listener())


def run_stages(stages, record=None):
    """Runs ``stages``; with ``record`` (a list) appends ``{name, seconds, cpu_s, hwm_mib}``
    per stage. Returns the first query's distances."""
    first = None
    for name, fn in stages:
        c0, t0 = time.process_time(), time.perf_counter()
        out = fn()
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        if name == "first query":
            first = out
        if record is not None:
            record.append({"name": name, "seconds": wall, "cpu_s": cpu,
                           "hwm_mib": memory_mib()[1]})
    return first


def child(lib, folder, out):
    """The ``--one`` mode: one library on the data in ``folder``, results to ``out`` (JSON)."""
    V, F, Q = load_data(folder)
    kind = "points" if F is None else ("edges" if F.shape[1] == 2 else "triangles")
    try:
        Vw, Fw = make_data(kind, WARM, seed=12345)
        run_stages(SIDES[lib](Vw, Fw, near_queries(Vw, Fw, Q.shape[0], 12346)))  # import, compile
        stages = SIDES[lib](V, F, Q)
        compiles = CompileCount() if lib == "ours" else None
        gc.collect()
        release_free_memory()
        rss, hwm = memory_mib()
        result = {"rss_before_mib": rss, "hwm_before_mib": hwm, "stages": []}
        dist = run_stages(stages, result["stages"])
    except Exception as e:                     # noqa: BLE001 (a peer's failure is a result)
        result = {"skipped": f"{type(e).__name__}: {e}".strip()[:300]}
    else:
        np.save(folder / f"dist_{lib}.npy", np.asarray(dist, dtype=np.float64))
        if compiles is not None:
            import numba

            result["compiled_in_timing"] = compiles.count
            result["threads"] = numba.get_num_threads()
    Path(out).write_text(json.dumps(result), encoding="utf-8")


# --- the parent ----------------------------------------------------------------------------

def summarise(r, queries):
    """Adds the table's figures to a child's result ``r``: build seconds, extra MiB at the
    build (through the first query for a lazy library; ``build_extra_bound``: the peak did not
    rise above the warm-up's, so the figure is an upper bound), the peak extra, the first
    query's seconds, queries per second (ours: also the exact tree's and the smooth query's)."""
    st = {s["name"]: s for s in r["stages"]}
    ready = st["first query" if r["lazy_build"] else "build"]
    r.update(build_s=st["build"]["seconds"],
             build_extra_mib=ready["hwm_mib"] - r["rss_before_mib"],
             build_extra_bound=ready["hwm_mib"] <= r["hwm_before_mib"],
             peak_extra_mib=max(s["hwm_mib"] for s in r["stages"]) - r["rss_before_mib"],
             first_query_s=st["first query"]["seconds"],
             queries_per_s=queries / st["second query"]["seconds"])
    if "exact tree" in st:
        r.update(exact_tree_s=st["exact tree"]["seconds"],
                 exact_tree_extra_mib=st["exact tree"]["hwm_mib"] - r["rss_before_mib"],
                 smooth_queries_per_s=queries / st["smooth second"]["seconds"])
    return r


def run_library(lib, folder, args):
    """One library on the data in ``folder``, ``--repeat`` fresh processes (the fastest build
    kept, all build seconds recorded) or ``{"skipped": reason}``."""
    runs = []
    for _ in range(args.repeat):
        out = folder / f"result_{lib}.json"
        out.unlink(missing_ok=True)
        load = os.getloadavg()[0]
        try:
            p = subprocess.run([sys.executable, str(Path(__file__).resolve()), "--one", lib,
                                str(folder), "--out", str(out)], capture_output=True, text=True,
                               timeout=args.timeout, cwd=REPO)
        except subprocess.TimeoutExpired:
            return {"skipped": f"timed out after {args.timeout} s"}
        if p.returncode or not out.exists():
            tail = (p.stderr.strip().splitlines() or ["?"])[-1]
            return {"skipped": f"exit {p.returncode}: {tail}"[:300]}
        r = json.loads(out.read_text(encoding="utf-8"))
        if "skipped" in r:
            return r
        r.update(load_before=load, load_after=os.getloadavg()[0], lazy_build=lib in LAZY)
        runs.append(summarise(r, args.queries))
    best = min(runs, key=lambda r: r["build_s"])
    best["build_s_runs"] = [r["build_s"] for r in runs]
    return best


def compare(row, folder):
    """Each library's largest distance difference from ours, x diagonal (``max_diff``)."""
    ours = folder / "dist_ours.npy"
    if not ours.exists():
        return
    d0 = np.load(ours)
    for lib, r in row["libraries"].items():
        f = folder / f"dist_{lib}.npy"
        if lib != "ours" and "skipped" not in r and f.exists():
            r["max_diff"] = float(np.abs(np.load(f) - d0).max()) / row["diagonal"]
            r["agrees"] = r["max_diff"] <= AGREE


def write_ply(folder, kind, n, seed):
    """The data of ``kind`` (about ``n``) as ``folder/data.ply``: ``(path, primitives)``."""
    import trimesh

    V, F = make_data(kind, n, seed)
    path = folder / "data.ply"
    (trimesh.PointCloud(V) if F is None else trimesh.Trimesh(V, F, process=False)).export(path)
    return path, int(V.shape[0] if F is None else F.shape[0])


def run_render(ply, folder, args):
    """``tracer render`` of ``ply`` in a child: wall seconds, its peak RSS (MiB) and stages
    (``None`` where ``--stage-times`` is refused); killed after ``--timeout`` seconds."""
    stages_path = folder / "stages.json"
    base = [sys.executable, "-m", "tracer", "render", str(ply), "--size", str(args.render_size),
            str(args.render_size), "-o", str(folder / "out.png"), "--overwrite", "-q"]
    load = os.getloadavg()[0]
    for cmd in (base + ["--stage-times", str(stages_path)], base):
        with open(folder / "render.log", "w+", encoding="utf-8") as log:
            t0 = time.perf_counter()
            p = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, cwd=REPO)
            timer = threading.Timer(args.timeout, p.kill)
            timer.start()
            _, status, usage = os.wait4(p.pid, 0)      # the child's own peak RSS
            timer.cancel()
            wall = time.perf_counter() - t0
            p.returncode = rc = os.waitstatus_to_exitcode(status)
            log.seek(0)
            text = log.read()
        if not (rc and "--stage-times" in text and "unrecognized" in text):
            break
    out = {"wall_s": wall, "peak_rss_mib": usage.ru_maxrss / 1024, "rc": rc,
           "stage_times": "--stage-times" in cmd, "stages": None, "total_seconds": None,
           "load_before": load, "load_after": os.getloadavg()[0]}
    if rc:
        out["error"] = (text.strip().splitlines() or ["?"])[-1][:300]
    elif out["stage_times"] and stages_path.exists():
        st = json.loads(stages_path.read_text(encoding="utf-8"))
        out.update(stages=st.get("stages"), total_seconds=st.get("total_seconds"))
    return out


def render_row(kind, n, args, label=""):
    """The render of the data of ``kind`` (about ``n``) as a results row: the fastest of
    ``--repeat`` runs (all wall seconds in ``wall_s_runs``)."""
    with tempfile.TemporaryDirectory(prefix="bench_build_scale_") as tmp:
        ply, reached = write_ply(Path(tmp), kind, n, args.seed)
        size = ply.stat().st_size
        runs = [run_render(ply, Path(tmp), args) for _ in range(args.repeat)]
    best = min(runs, key=lambda r: (r["rc"] != 0, r["wall_s"]))
    return {"kind": kind, "target": int(n), "n": reached, "label": label, "ply_bytes": size,
            **best, "wall_s_runs": [r["wall_s"] for r in runs]}


def machine():
    """CPU, cores, numba threads, versions (the peers' where installed), commit, date."""
    import numba

    from benchmarks.bench_scaling import machine as scaling_machine

    model = scaling_machine()["cpu"] or platform.machine()
    versions = {}
    for dist in ("numpy", "numba", "scipy", "trimesh", "fcpw", "libigl", "open3d", "warp-lang"):
        try:
            versions[dist] = importlib.metadata.version(dist)
        except importlib.metadata.PackageNotFoundError:
            versions[dist] = None

    def git(*a):
        try:
            return subprocess.run(["git", *a], cwd=REPO, capture_output=True, text=True).stdout
        except OSError:
            return ""

    return {"cpu": model, "cores": os.cpu_count(), "threads": numba.get_num_threads(),
            "python": platform.python_version(), "versions": versions,
            "commit": git("rev-parse", "HEAD").strip(),
            "dirty": bool(git("status", "--porcelain", "--untracked-files=no").strip()),
            "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
            "load_start": os.getloadavg()[0]}


def describe(row):
    """One printed line per row."""
    parts = []
    for lib, r in row["libraries"].items():
        if "skipped" in r:
            parts.append(f"{lib} skipped ({r['skipped'][:60]})")
            continue
        text = (f"{lib} {r['build_s']:.3f} s {'<=' if r['build_extra_bound'] else '+'}"
                f"{r['build_extra_mib']:.1f} MiB, "
                f"{r['queries_per_s']:.3g} q/s")
        if "exact_tree_s" in r:
            text += f", exact tree {r['exact_tree_s']:.3f} s"
        if r.get("agrees") is False:
            text += f" (DIFFERS {r['max_diff']:.1e})"
        parts.append(text)
    return f"{row['kind']:>9} {row['n']:>11,}: " + "; ".join(parts)


def plot(result, path):
    """Log-log: build seconds and extra memory against primitives, per library, one column
    per kind (the input arrays' size dashed)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    kinds = list(dict.fromkeys(r["kind"] for r in result["rows"]))
    libs = list(dict.fromkeys(lib for r in result["rows"] for lib in r["libraries"]))
    colors = dict(zip(libs, plt.rcParams["axes.prop_cycle"].by_key()["color"]))
    side = 2.6                                         # inches for the legend, on the right
    width = 4.2 * len(kinds) + side
    fig, axes = plt.subplots(2, len(kinds), figsize=(width, 7.4), squeeze=False)
    for col, kind in enumerate(kinds):
        rows = [r for r in result["rows"] if r["kind"] == kind]
        top, bottom = axes[0, col], axes[1, col]
        for lib in libs:
            pts = [(r["n"], r["libraries"][lib]) for r in rows
                   if "build_s" in r["libraries"].get(lib, {})]
            if not pts:
                continue
            n = [p[0] for p in pts]
            lazy = pts[0][1]["lazy_build"]
            label = f"{lib} (build + first query)" if lazy else lib
            secs = [r["build_s"] + (r["first_query_s"] if lazy else 0.0) for _, r in pts]
            top.plot(n, secs, "o-", color=colors[lib], label=label)
            mib = [max(r["build_extra_mib"], 1e-2) for _, r in pts]
            bottom.plot(n, mib, "-", color=colors[lib])
            for x, y, (_, r) in zip(n, mib, pts):
                bottom.plot(x, y, "o", color=colors[lib],
                            mfc="none" if r["build_extra_bound"] else colors[lib])
        bottom.plot([r["n"] for r in rows], [r["input_bytes"] / MIB for r in rows], "k--",
                    label="input arrays (V + F)")
        top.set_title(kind)
        top.set_ylabel("build, s")
        bottom.set_ylabel("extra memory at build, MiB\n(VmHWM after - VmRSS before)")
        for ax in (top, bottom):
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.set_xlabel(f"{kind} (primitives)")
            ax.grid(True, which="major", alpha=0.3)
    handles = {}
    for ax in axes.ravel():
        for h, lab in zip(*ax.get_legend_handles_labels()):
            handles.setdefault(lab, h)
    handles["hollow: upper bound (peak not above the warm-up's)"] = plt.Line2D(
        [], [], marker="o", mfc="none", color="gray", ls="none")
    fig.legend(handles.values(), [textwrap.fill(k, 28) for k in handles], loc="center left",
               bbox_to_anchor=(1 - side / width, 0.5), frameon=False, fontsize=9)
    m = result["machine"]
    fig.suptitle(f"Build time and peak extra memory (fresh process, compile excluded)\n"
                 f"{m['cpu']}, {m['cores']} cores, numba {m['threads']} threads, {m['date']}",
                 fontsize=10)
    fig.tight_layout(rect=(0, 0, 1 - side / width, 1))
    fig.savefig(path, dpi=120)
    plt.close(fig)


def sizes_arg(text):
    """``"1e4,1e5"`` -> ``[10000, 100000]``."""
    return [int(float(s)) for s in text.split(",") if s.strip()]


def names_arg(choices):
    """A parser of comma-separated names out of ``choices``."""
    def parse(text):
        names = [s.strip() for s in text.split(",") if s.strip()]
        bad = [s for s in names if s not in choices]
        if bad:
            raise argparse.ArgumentTypeError(f"unknown {bad}; choose from {', '.join(choices)}")
        return names
    return parse


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                epilog=__doc__[__doc__.index("Usage"):],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--sizes", type=sizes_arg, default=sizes_arg("1e4,1e5,1e6"),
                   help="primitives per data set, comma-separated (default 1e4,1e5,1e6; 1e7 "
                        "only when asked: heavy, run it alone)")
    p.add_argument("--kinds", type=names_arg(KINDS), default=list(KINDS),
                   help="comma-separated, of triangles,edges,points (default all)")
    p.add_argument("--libraries", type=names_arg(list(SIDES)), default=list(SIDES),
                   help="comma-separated subset of ours,fcpw,open3d,warp,libigl,scipy "
                        "(default all that apply to a kind)")
    p.add_argument("--queries", type=int, default=100_000,
                   help="exact (and smooth) queries per batch (default 1e5)")
    p.add_argument("--repeat", type=int, default=1,
                   help="fresh processes per library, size and render; the fastest kept "
                        "(build seconds; render wall seconds)")
    p.add_argument("--render-size", type=int, default=128,
                   help="square image of the tracer render stage, pixels (default 128)")
    p.add_argument("--no-render", action="store_true", help="leave out the tracer renders")
    p.add_argument("--timeout", type=float, default=3600,
                   help="seconds a child (a library's process, a render) may run before "
                        "it is killed and recorded as skipped / failed (default 3600)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--quick", action="store_true", help="smoke test: sizes 1e3,1e4")
    p.add_argument("--json", help="write the results here")
    p.add_argument("--plot", help="write the log-log figure here (PNG)")
    p.add_argument("--one", nargs=2, metavar=("LIB", "DIR"), help=argparse.SUPPRESS)
    p.add_argument("--out", help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.one:
        child(args.one[0], Path(args.one[1]), args.out)
        return None
    if args.quick:
        args.sizes = [1_000, 10_000]
    result = {"machine": machine(), "args": vars(args), "queries": args.queries,
              "notes": ["compile excluded: each child runs everything once on 2,000 "
                        "primitives before timing (ours: compiled_in_timing counts numba's "
                        "compile events in the timed stages)",
                        "open3d builds its tree in the first query: its build_s is "
                        "add_triangles, its build_extra_mib the peak through the first query",
                        "ours' queries run after its exact tree (timed apart)"],
              "rows": [], "renders": []}
    for kind in args.kinds:
        render = kind in RENDER_KINDS and not args.no_render
        if render:
            render_row(kind, SMALL, args)                       # fills the kernel cache
            small = render_row(kind, SMALL, args, "small reference")
            result["renders"].append(small)
        for n in args.sizes:
            with tempfile.TemporaryDirectory(prefix="bench_build_scale_") as tmp:
                folder = Path(tmp)
                row = write_data(folder, kind, n, args.queries, args.seed)
                row["libraries"] = {lib: run_library(lib, folder, args)
                                    for lib in LIBRARIES[kind] if lib in args.libraries}
                compare(row, folder)
            result["rows"].append(row)
            print(describe(row), flush=True)
            if render:
                r = render_row(kind, n, args)
                r["ratio_to_small"] = (None if r["rc"] or small["rc"]
                                       else r["wall_s"] / small["wall_s"])
                result["renders"].append(r)
                print(f"{'':>9} render: {r['wall_s']:.2f} s, peak {r['peak_rss_mib']:.0f} MiB"
                      + (f", error: {r['error']}" if r["rc"]
                         else f" ({r['ratio_to_small']:.1f}x small)" if r["ratio_to_small"]
                         else ""), flush=True)
    result["machine"]["load_end"] = os.getloadavg()[0]
    if args.json:           # first: the results survive whatever comes after
        Path(args.json).write_text(json.dumps(result, indent=1) + "\n", encoding="utf-8")
    from benchmarks.tables import build_scale_markdown

    print()
    print(build_scale_markdown(result))
    if args.plot:
        plot(result, args.plot)
    return result


if __name__ == "__main__":
    main()
