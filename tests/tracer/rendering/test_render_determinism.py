"""Determinism: the same input gives bit-identical outputs, run to run and for any thread count.

Renders are split into tiles that one thread traces start to finish, and batch queries into
chunks that one thread evaluates in order, so the number of threads must not change a single
bit of the image, the AOVs or the distances. Checked in-process with ``numba.set_num_threads``
(restored afterwards).
"""

from pathlib import Path

import numba
import numpy as np
import pytest

from smoothdist import SmoothDistanceField
from tracer.rendering.renderer import render
from tracer.scenes.scene import load_scene, scene_from_field

SCENES = Path(__file__).resolve().parents[3] / "scenes"
SIZE = {"width": 40, "height": 32}
#: shipped scenes covering points, edges, triangles, mixed, several objects and exact mode
SCENE_NAMES = ["bunny_points", "trefoil", "torus", "mixed", "two_objects", "capillary_exact"]

needs_two_threads = pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2,
                                       reason="numba has a single thread here")


@pytest.fixture
def restore_threads():
    before = numba.get_num_threads()
    yield
    numba.set_num_threads(before)


def outputs(res):
    """Every array a render produces, as raw bytes (NaN patterns compare exactly)."""
    return {k: np.ascontiguousarray(getattr(res, k)).tobytes()
            for k in ("rgb", "hit", "depth", "normals", "steps", "leaves", "bisections")}


def assert_same(a, b, what):
    for k in a:
        assert a[k] == b[k], f"{what}: {k} differs"


@pytest.fixture(scope="module")
def scenes():
    return {name: load_scene(SCENES / f"{name}.json", SIZE) for name in SCENE_NAMES}


@needs_two_threads
@pytest.mark.parametrize("name", SCENE_NAMES)
def test_render_is_bit_identical_across_threads_and_runs(scenes, restore_threads, name):
    scene = scenes[name]
    numba.set_num_threads(1)
    one = outputs(render(scene))
    numba.set_num_threads(2)
    two = outputs(render(scene))
    two_again = outputs(render(scene))
    assert_same(one, two, "1 vs 2 threads")
    assert_same(two, two_again, "two runs")
    # the progress granularity (rows per kernel call) does not matter either
    assert_same(two, outputs(render(scene, band_rows=8)), "band_rows=8")


def test_scene_loading_is_deterministic():
    a = load_scene(SCENES / "mixed.json", SIZE)
    b = load_scene(SCENES / "mixed.json", SIZE)
    for oa, ob in zip(a.objects, b.objects):
        assert oa.alpha == ob.alpha and oa.field.num_primitives == ob.field.num_primitives
        for fa, fb in zip(oa.field.tree, ob.field.tree):
            if isinstance(fa, np.ndarray):
                assert fa.tobytes() == fb.tobytes()
            else:
                assert fa == fb


@needs_two_threads
@pytest.mark.parametrize("beta", [0.0, 0.5])
@pytest.mark.slow
def test_queries_are_bit_identical_across_threads(restore_threads, beta):
    r = np.random.default_rng(7)
    V = r.random((3000, 3))
    field = SmoothDistanceField(V)
    Q = r.normal(size=(5000, 3)) * 2.0
    results = []
    for threads in (1, 2, 2):
        numba.set_num_threads(threads)
        d, g, stats = field.smooth_distance(Q, alpha=40.0, beta=beta, return_stats=True)
        de, ge, prim = field.exact_distance(Q, return_closest=True)
        results.append([x.tobytes() for x in (d, g, *stats, de, ge, prim)])
    assert results[0] == results[1] == results[2]


@needs_two_threads
def test_auto_alpha_and_programmatic_scene_are_deterministic(restore_threads):
    V = np.random.default_rng(11).random((2000, 3))
    images = []
    for threads in (1, 2):
        numba.set_num_threads(threads)
        field = SmoothDistanceField(V)
        alpha = field.auto_alpha()
        images.append((alpha, outputs(render(scene_from_field(field, alpha=alpha, width=24,
                                                              height=24)))))
    assert images[0][0] == images[1][0]
    assert_same(images[0][1], images[1][1], "1 vs 2 threads")
