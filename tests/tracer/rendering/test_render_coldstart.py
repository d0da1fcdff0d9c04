"""What keeps the first render short, checked as behaviour (never as time).

* The lean path (one unposed object in smooth mode without ``tol``, its root passed to the
  march kernels as an int, ``tracer.rendering.renderer.kernel_roots``) gives bit-identical images, depths,
  normals and counters to the general path (the ``(k,)`` roots array) for points, edges,
  triangles and mixed meshes, with and without Barnes-Hut and attenuation, and both weight
  gradients; every other scene (exact mode, several objects, poses, ``tol > 0``) keeps the
  general path.
* Tiles traced by Python threads over the serial kernel ``march.render_tiles``
  (``tracer.rendering.renderer.trace_tiles``) give the image of one thread bit for bit, for any
  number of threads, bands and chunk size; the samples' and the light's task kernels give the
  values of one task, for any split into tasks and threads.
* A plain ``tracer render`` of the default scene imports none of matplotlib, pyvista,
  trimesh, dask, imageio and compiles (or loads) only the lean kernels, one signature each.
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from smoothdist import DataMesh, SmoothDistanceField
from tracer.rendering import march, renderer as render_mod
from tracer.rendering.camera import sample_rays
from tracer.rendering.frame import (LightArgs, LightBuffers, MarchArgs, SampleBuffers,
                                    SampleRays)
from tracer.rendering.frame import RayArgs, TraceOptions, camera_of, kernel_roots, scene_arrays
from tracer.rendering.renderer import render, trace_tiles
from tracer.scenes.scene import load_scene, scene_from_field

ROOT = Path(__file__).resolve().parents[3]
SCENES = ROOT / "scenes"
BUNNY = SCENES / "data" / "bunny.off"
SIZE = {"width": 24, "height": 20}


def trace(scene, roots=None, threads=None, band=None):
    """All per-pixel outputs of tracing ``scene`` (``roots`` overrides the kernel roots)."""
    tree, sroots, params, mode, lo, hi, depth_max, tol = scene_arrays(scene)
    roots = kernel_roots(sroots, params, mode, tol) if roots is None else roots
    H, W = scene.height, scene.width
    out = (np.zeros((H, W), dtype=np.bool_), np.full((H, W), np.nan), np.zeros((H, W, 3)),
           np.zeros((H, W), dtype=np.int64), np.zeros((H, W), dtype=np.int64),
           np.zeros((H, W), dtype=np.int64), np.full((H, W), -1, dtype=np.int32))
    args = RayArgs(tree, roots, params, mode, tol, camera_of(scene).as_array(), lo, hi,
                   float(scene.eps), int(scene.max_steps))
    options = TraceOptions(march.RELAX, march.OMEGA, march.CONE,
                           march.newton_distance(scene.eps, lo, hi))
    band = band or H
    for r0 in range(0, H, band):
        r1 = min(H, r0 + band)
        trace_tiles(args, r0, r1, depth_max, out, options, threads=threads)
    return [np.ascontiguousarray(a).tobytes() for a in out]


@pytest.fixture(scope="module")
def bunny():
    return DataMesh.load(BUNNY)


@pytest.mark.parametrize("kind", ["points", "edges", "triangles"])
@pytest.mark.parametrize("beta,alpha_u,gradient", [(0.5, 1200.0, "metric"),
                                                   (0.0, None, "metric"),
                                                   (0.5, None, "exact")])
@pytest.mark.slow
def test_lean_path_equals_general_path(bunny, kind, beta, alpha_u, gradient):
    field = SmoothDistanceField(bunny.as_kind(kind))
    scene = scene_from_field(field, alpha=200.0, alpha_u=alpha_u, beta=beta, width=24,
                             height=20, gradient=gradient)
    tree, roots, params, mode, lo, hi, depth_max, tol = scene_arrays(scene)
    lean = kernel_roots(roots, params, mode, tol)
    assert isinstance(lean, int) and lean == roots[0]
    assert trace(scene, roots=lean) == trace(scene, roots=roots)
    # the camera check and a bisection-only call use the slack-less specialisation
    o = [float(v) for v in scene.camera_origin]
    for p in (o, [float(v) for v in tree.pts[0, :3] + 1e-3]):
        assert march.distance_at((tree, lean, params, mode, tol), *p, depth_max) == \
            march.distance_at((tree, roots, params, mode, tol), *p, depth_max)


def test_lean_path_on_a_mixed_mesh():
    scene = load_scene(SCENES / "mixed.json", SIZE)
    assert len(scene.objects) == 1 and scene.mode == "smooth"
    tree, roots, params, mode, *_, tol = scene_arrays(scene)
    assert isinstance(kernel_roots(roots, params, mode, tol), int)
    assert trace(scene) == trace(scene, roots=roots)


@pytest.mark.parametrize("name,overrides", [("capillary_exact", {}), ("two_objects", {}),
                                            ("bunny_points", {"tol": 0.01})])
def test_other_scenes_keep_the_general_path(name, overrides):
    scene = load_scene(SCENES / f"{name}.json", {**SIZE, **overrides})
    tree, roots, params, mode, *_, tol = scene_arrays(scene)
    assert kernel_roots(roots, params, mode, tol) is roots


def test_posed_scenes_keep_the_general_path():
    scene = load_scene(SCENES / "bunny_points.json", SIZE)
    R = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    tree, roots, params, mode, *_, tol = scene_arrays(scene, transforms=[(R, np.zeros(3))])
    assert params.shape[1] == march.P_COLUMNS_POSED
    assert kernel_roots(roots, params, mode, tol) is roots


@pytest.mark.parametrize("name", ["bunny_triangles", "two_objects", "capillary_exact",
                                  "trefoil"])
@pytest.mark.slow
def test_threaded_tiles_equal_one_thread(name):
    """Any number of threads and bands gives one thread's image (the whole image in one band)
    bit for bit. (The parallel ``prange`` kernel that this compared with, ``render_rows``, is
    gone: a render never ran it, and it cost the suite seconds of compiling per scene.)"""
    scene = load_scene(SCENES / f"{name}.json", SIZE)
    ref = trace(scene, threads=1)
    assert np.frombuffer(ref[0], dtype=np.bool_).any(), "the image shows the object"
    for threads in (2, 3):
        assert trace(scene, threads=threads) == ref, f"{threads} threads"
    assert trace(scene, threads=2, band=8) == ref, "bands of 8 rows"


@pytest.mark.parametrize("per_thread", [1, 3, 10 ** 9])
def test_chunk_size_does_not_change_the_image(monkeypatch, per_thread):
    # one chunk per thread, a few, and chunks of one tile
    scene = load_scene(SCENES / "bunny_edges.json", SIZE)
    ref = trace(scene, threads=1)
    monkeypatch.setattr(render_mod, "CHUNKS_PER_THREAD", per_thread)
    assert trace(scene, threads=2) == ref


def test_progress_reaches_the_total():
    scene = load_scene(SCENES / "bunny_points.json", SIZE)
    calls = []
    render(scene, progress=lambda done, total, t: calls.append((done, total)))
    assert calls and calls[-1] == (24 * 20, 24 * 20)
    assert all(0 < d <= t for d, t in calls) and calls == sorted(calls)


def test_a_failing_worker_raises_in_the_caller(monkeypatch):
    def broken(*args):
        raise RuntimeError("kernel failed")

    monkeypatch.setattr(march, "render_tiles", broken)
    scene = load_scene(SCENES / "bunny_points.json", SIZE)
    with pytest.raises(RuntimeError, match="kernel failed"):
        render(scene)


CLI_RENDER = r"""
import json, sys
from numba.core.dispatcher import Dispatcher
import tracer.cli
rc = tracer.cli.main(["render", *sys.argv[1:], "--size", "16", "12", "-q"])
found = [(f"{name}.{attr}", obj) for name, mod in list(sys.modules.items())
         if name.split(".")[0] in ("smoothdist", "tracer")
         for attr, obj in vars(mod).items() if isinstance(obj, Dispatcher) and obj.signatures]
sigs = {key: [[str(t) for t in s] for s in obj.signatures] for key, obj in found}
kernels = {id(obj): len(obj.signatures) for key, obj in found}   # each kernel once
print(json.dumps({"rc": rc, "modules": sorted(sys.modules), "signatures": sigs,
                  "compiled": sum(kernels.values())}))
"""


def cli_render(tmp_path, *args, cache=None):
    """``tracer render ARGS --size 16 12 -q`` in a fresh process: its report (exit status,
    modules imported, the signatures of every kernel it compiled or loaded, and their number,
    ``compiled``). ``cache``: a folder for ``NUMBA_CACHE_DIR`` (new and empty: a first run,
    every kernel and callee compiled)."""
    env = dict(os.environ)
    if cache is not None:
        env["NUMBA_CACHE_DIR"] = str(cache)
        env.pop("SMOOTHDIST_CACHE_DIR", None)  # it would win over NUMBA_CACHE_DIR
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    env.pop("MPLBACKEND", None)
    p = subprocess.run([sys.executable, "-c", CLI_RENDER, *map(str, args)], env=env,
                       cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr
    report = json.loads(p.stdout.strip().splitlines()[-1])
    assert report["rc"] == 0
    return report


def test_a_plain_render_is_lean(tmp_path):
    report = cli_render(tmp_path, SCENES / "bunny_triangles.json", "-o", tmp_path / "x.png")
    assert (tmp_path / "x.png").is_file()
    heavy = {"matplotlib", "pyvista", "trimesh", "dask", "distributed", "imageio", "vtk"}
    assert not heavy & {m.split(".")[0] for m in report["modules"]}
    sigs = report["signatures"]
    # the march kernels ran with an int root (the lean path), one specialisation each
    tiles = sigs["tracer.rendering.march.render_tiles"]     # (tree, MarchArgs(roots, ...), ...)
    assert len(tiles) == 1 and tiles[0][1].startswith("MarchArgs(int64,"), tiles
    dist = sigs["tracer.rendering.march.distance_at"]       # ((tree, roots, ...), ...)
    assert len(dist) == 1 and _items(dist[0][0])[1] == "int64", dist
    # nothing of the general path was compiled or loaded
    for name in ("tracer.rendering.march._scene_distance_posed",
                 "tracer.rendering.march.trace_pixels",
                 "smoothdist._kernels.query.smooth_distance_point_tol",
                 "smoothdist._kernels.query.exact_distance_point"):
        assert name not in sigs, sigs.get(name)


def _items(typename):
    """The top-level items of a tuple type's name (``"Tuple(A(x, y), int64)"`` -> ``["A(x,
    y)", "int64"]``; a NamedTuple's fields too)."""
    inner = typename[typename.index("(") + 1:typename.rindex(")")]
    items, depth, start = [], 0, 0
    for i, ch in enumerate(inner):
        depth += {"(": 1, "[": 1, ")": -1, "]": -1}.get(ch, 0)
        if ch == "," and depth == 0:
            items.append(inner[start:i].strip())
            start = i + 1
    return items + [inner[start:].strip()]


COLDSTART = ROOT / "benchmarks" / "data" / "coldstart.json"


def coldstart():
    """The measured first renders (``benchmarks/bench_coldstart.py``)."""
    return json.loads(COLDSTART.read_text(encoding="utf-8"))["cases"]


def test_the_readme_quotes_the_measured_first_render():
    """The README's first-call figures are those of the results file (cold wall seconds and
    CPU seconds of the mesh file, the point cloud, the lit adaptive render and the library's
    first exact, smooth and whole-mesh calls), in the paragraph that names the file."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    line = " ".join(next(p for p in text.split("\n\n") if "coldstart.json" in p).split())
    cases = coldstart()
    for case in ("mesh", "cloud", "lit", "exact", "smooth", "md_triangles"):
        cold = cases[case]["cold"]
        assert f"{cold['wall_s']:.0f} s ({cold['cpu_s']:.0f} s CPU)" in line, (case, line)
    # the renders with their light compiled in a second process (issue 63)
    ahead = [f"{cases[c]['cold_ahead']['wall_s']:.0f} s" for c in ("mesh", "cloud", "lit")]
    assert (f"the mesh file {ahead[0]}, the point cloud {ahead[1]}, the lit adaptive render "
            f"{ahead[2]} of wall time") in line, line
    # the machine changed (AMD EPYC for Intel Xeon): how much more CPU the same first calls took
    # (the same code on both: the AMD run of commit 5797881, before the renders' changes of
    # issue 63's fourth round)
    intel = json.loads(COLDSTART.with_name("coldstart_issue63_intel.json").read_text(
        encoding="utf-8"))["cases"]
    amd = json.loads(COLDSTART.with_name("coldstart_issue63_amd_5797881.json").read_text(
        encoding="utf-8"))["cases"]
    more = [100 * (amd[c]["cold"]["cpu_s"] / intel[c]["cold"]["cpu_s"] - 1) for c in intel]
    assert f"took {min(more):.0f}-{max(more):.0f} % more CPU here" in line, line
    assert "coldstart_issue63_amd_5797881.json" in line


@pytest.mark.slow
def test_a_lit_adaptive_render_is_lean(tmp_path):
    report = cli_render(tmp_path, SCENES / "bunny_triangles.json", "--shading", "lit",
                        "--samples", "4", "--adaptive", "-o", tmp_path / "x.png")
    # the suite's own kernel cache (an empty one would cost a full compile, ~25 s): top-level
    # kernels show their signatures whether compiled or loaded; callees (the query functions)
    # show only where compiled, i.e. where the cache was cold for them
    sigs = report["signatures"]
    # samples, shading normals, light and the ground probe on the lean path (an int root), one
    # each; the march kernels take the roots first in their MarchArgs
    for name, arg, item in (("tracer.rendering.march.render_tiles", 1, 0),
                            ("tracer.rendering.march.sample_tasks", 1, 0),
                            ("tracer.rendering.march.gradient_tasks", 1, 0),
                            ("tracer.rendering.lighting.light_tasks", 1, 0),
                            ("tracer.rendering.lighting._lowest_hit", 0, 1)):
        assert len(sigs[name]) == 1, sigs.get(name)
        assert _items(sigs[name][0][arg])[item] == "int64", sigs.get(name)
    # no prange kernel (a parallel loop costs numba about as much again as its body), and
    # nothing of the general path
    for name in ("smoothdist._kernels.query.smooth_distance_point_tol",
                 "smoothdist._kernels.query.exact_distance_point"):
        assert name not in sigs, sigs.get(name)
    # compiled specialisations (all kernels, callees included, each counted once; each one
    # compiled, optimised and written to the cache): no more than the measured first render
    # (16 samples there, 4 here: the same kernels). With prange samples and light and the
    # general-path ground probe it was 57 (benchmarks/bench_coldstart.py, before)
    assert report["compiled"] <= coldstart()["lit"]["cold"]["compiled"], report["compiled"]


def _sample_outputs(m, K):
    return (np.zeros((m, K), dtype=np.bool_), np.full((m, K), np.nan), np.zeros((m, K, 3)),
            np.zeros((m, K), dtype=np.int64), np.full((m, K), -1, dtype=np.int32),
            np.full(m, np.nan), np.full(m, np.nan))


@pytest.mark.parametrize("name", ["bunny_triangles", "two_objects"])
def test_task_kernels_equal_one_task(name):
    """``march.sample_tasks`` and ``lighting.light_tasks`` run from Python threads
    (``smoothdist.schedule.run_tasks``, any split) give the values of one task in one call bit
    for bit. (The ``prange`` kernels they were compared with, ``trace_samples`` and
    ``light_points``, are gone: a render never ran them.)"""
    from smoothdist.schedule import run_tasks
    from tracer.rendering import lighting
    from tracer.rendering.film import sample_offsets

    scene = load_scene(SCENES / f"{name}.json", SIZE)
    tree, roots, params, mode, lo, hi, depth_max, tol = scene_arrays(scene)
    roots = kernel_roots(roots, params, mode, tol)
    cam = camera_of(scene).as_array()
    rng = np.random.default_rng(1)
    m = 37
    rows = rng.integers(0, scene.height, m).astype(np.int64)
    cols = rng.integers(0, scene.width, m).astype(np.int64)
    off = sample_offsets(5)
    head = (tree, MarchArgs(roots, params, mode, tol, cam, lo, hi, float(scene.eps), 400),
            SampleRays(rows, cols, off, 0.0, 0.02), depth_max)
    opts = TraceOptions(march.RELAX, 2.0, True, march.newton_distance(scene.eps, lo, hi))
    ref = SampleBuffers(*_sample_outputs(m, len(off)))
    march.sample_tasks(*head, ref, opts, (1, 0, 1))
    assert ref.hit.any() and not ref.hit.all()     # hits and misses among the samples
    for ntasks, threads in ((3, 1), (3, 2), (5, 3), (37, 2), (40, 2)):
        got = SampleBuffers(*_sample_outputs(m, len(off)))
        run_tasks(lambda a, b: march.sample_tasks(*head, got, opts, (ntasks, a, b)),
                  ntasks, threads)
        assert [x.tobytes() for x in got] == [x.tobytes() for x in ref], (ntasks, threads)
    # light at the hits
    hit = ref[0].ravel()
    origins, dirs = _rays(cam, rows, cols, off)
    P = np.ascontiguousarray(origins + ref[1].ravel()[hit, None] * dirs[hit])
    g = ref[2].reshape(-1, 3)[hit]
    N = np.ascontiguousarray(g / np.linalg.norm(g, axis=1, keepdims=True))
    n = len(P)
    assert n > 5
    key = np.array([0.3, 0.8, 0.52])
    key /= np.linalg.norm(key)
    args = (tree, (roots, params, mode, tol), (P, N), depth_max,
            LightArgs(key, lo, hi, float(scene.eps), 8.0, 0.01 * scene.diagonal, True, True, 0.0,
                      2 * float(scene.eps), 20 * float(scene.eps)))

    def light_out():
        return LightBuffers(np.ones(n), np.ones(n), np.zeros((n, 2), dtype=np.int64))

    ref_l = light_out()
    lighting.light_tasks(*args, ref_l, (1, 0, 1))
    assert (ref_l.shadow < 1).any() and (ref_l.ao < 1).any()    # shadows and occlusion
    for ntasks, threads in ((2, 1), (2, 2), (4, 3)):
        got = light_out()
        run_tasks(lambda a, b: lighting.light_tasks(*args, got, (ntasks, a, b)), ntasks,
                  threads)
        assert [x.tobytes() for x in got] == [x.tobytes() for x in ref_l], (ntasks, threads)


def _rays(cam, rows, cols, off):
    """``(origins, dirs)`` of the samples ``off`` of pixels ``(rows, cols)``, pixel-major."""
    r = (rows[:, None] + off[None, :, 0]).ravel()
    c = (cols[:, None] + off[None, :, 1]).ravel()
    return sample_rays(cam, r, c)


def test_run_tasks_and_bands_cover_everything_once():
    from smoothdist.schedule import run_tasks
    from tracer.rendering.threads import in_bands

    for ntasks in (1, 2, 5, 64):
        for threads in (1, 2, 3, 8):
            seen = []
            run_tasks(lambda a, b: seen.extend(range(a, b)), ntasks, threads)
            assert sorted(seen) == list(range(ntasks))
    for rows in (1, 31, 32, 1080):
        for threads in (1, 2, 7):
            seen = []
            in_bands(lambda a, b: seen.extend(range(a, b)), rows, threads)
            assert sorted(seen) == list(range(rows))

    def broken(a, b):
        if a > 0:
            raise RuntimeError("task failed")

    with pytest.raises(RuntimeError, match="task failed"):
        run_tasks(broken, 4, 2)


# ----------------------------------------------------------------------------- BVH build
def _sah_split(plo, phi):
    """Where the build splits primitives with boxes ``plo, phi (n, 3)`` (in their sorted
    order): the ``k`` of smallest ``A(:k) k + A(k:) (n - k)`` with ``A`` the half box area and
    both sides at least ``SAH_MIN n`` (at least 1); the largest such ``k`` on a tie."""
    from smoothdist._kernels.bvh import SAH_MIN

    n = len(plo)

    def area(lo, hi):
        a, b, c = (hi - lo).T
        return a * b + b * c + c * a

    left = area(np.minimum.accumulate(plo), np.maximum.accumulate(phi))        # [:k + 1]
    right = area(np.minimum.accumulate(plo[::-1]), np.maximum.accumulate(phi[::-1]))[::-1]
    k = np.arange(n - 1, 0, -1)                                                  # descending
    cost = left[k - 1] * k.astype(float) + right[k] * (n - k).astype(float)
    lo_count = max(1, int(SAH_MIN * n))
    ok = (k >= lo_count) & (k <= n - lo_count)
    return int(k[ok][np.argmin(cost[ok])])


def reference_build(cent, plo, phi, leaf_size):
    """The build's specification in plain numpy: depth-first, nodes numbered in pairs as
    their parent is split, the node's primitives ordered by ``np.argsort(kind="stable")``
    along the longest centroid axis and split by the surface area heuristic
    (:func:`_sah_split`)."""
    m = len(cent)
    order = np.arange(m)
    nodes = {}
    stack = [(0, 0, m)]
    n_nodes = 1
    while stack:
        node, s, e = stack.pop()
        idx = order[s:e]
        box = (plo[idx].min(axis=0), phi[idx].max(axis=0))
        left = right = -1
        if e - s > leaf_size:
            ext = cent[idx].max(axis=0) - cent[idx].min(axis=0)
            axis = 0
            if ext[1] > ext[0] and ext[1] >= ext[2]:
                axis = 1
            elif ext[2] > ext[0] and ext[2] > ext[1]:
                axis = 2
            order[s:e] = idx = idx[np.argsort(cent[idx, axis], kind="stable")]
            mid = _sah_split(plo[idx], phi[idx])
            left, right = n_nodes, n_nodes + 1
            n_nodes += 2
            stack += [(right, s + mid, e), (left, s, s + mid)]
        nodes[node] = (box[0], box[1], left, right, s, e - s)
    cols = list(zip(*(nodes[i] for i in range(n_nodes))))
    return order, np.array(cols[0]), np.array(cols[1]), *(np.array(c) for c in cols[2:])


@pytest.mark.parametrize("case", ["grid_points", "bunny_triangles", "bunny_edges"])
@pytest.mark.parametrize("leaf_size", [1, 3])
def test_build_matches_its_specification(bunny, case, leaf_size):
    from smoothdist._kernels.bvh import build_tree

    if case == "grid_points":  # many equal coordinates: the sort's stability matters
        g = np.arange(7.0)
        mesh = DataMesh(np.stack(np.meshgrid(g, g, g * 0.5), -1).reshape(-1, 3))
    else:
        mesh = bunny.as_kind(case.split("_")[1])
    tree = build_tree(mesh, leaf_size=leaf_size)
    k = 3 if case == "bunny_triangles" else (2 if case == "bunny_edges" else 1)
    # the primitives in the mesh's own order: tree.pts rows put back by tree.orig
    pts = np.empty_like(tree.pts)
    pts[tree.orig] = tree.pts
    X = pts[:, :3 * k].reshape(-1, k, 3)
    ref = reference_build(X.mean(axis=1), X.min(axis=1), X.max(axis=1), leaf_size)
    got = (tree.orig, tree.lo, tree.hi, tree.left, tree.right, tree.start, tree.count)
    for name, a, b in zip(("order", "lo", "hi", "left", "right", "start", "count"), got, ref):
        np.testing.assert_array_equal(a, b, err_msg=name)


def test_stable_sort_of_the_build():
    from smoothdist._kernels.bvh import _sort_by_key

    rng = np.random.default_rng(3)
    for n in (0, 1, 15, 16, 17, 33, 100, 1000):
        for keys in (rng.random(n), rng.integers(0, 4, n) * 1.0, -np.arange(n) * 1.0,
                     np.where(rng.random(n) < 0.5, 0.0, -0.0)):
            s, e = (n // 5, n - n // 7) if n > 10 else (0, n)
            k = keys.copy()
            items = np.arange(n, dtype=np.int64)
            _sort_by_key(k, items, np.empty(n), np.empty(n, dtype=np.int64), s, e)
            ref = np.arange(n)
            ref[s:e] = s + np.argsort(keys[s:e], kind="stable")
            np.testing.assert_array_equal(items, ref)
            np.testing.assert_array_equal(k, keys[ref])
