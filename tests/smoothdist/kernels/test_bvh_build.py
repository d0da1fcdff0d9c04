"""The BVH build's fast paths give the serial build's tree bit for bit: subtrees built on
several threads (numbered as the serial build numbers them, or renumbered afterwards for
leaves of more than one primitive), the radix sort of long ranges and the skip of ranges in
order already (both must keep the stable sort's order, ties and ``-0.0 == 0.0`` included).
The serial build itself is pinned to its specification by
``tracer/rendering/test_render_coldstart.py::test_build_matches_its_specification``."""

import numpy as np
import pytest

from smoothdist import DataMesh
from smoothdist._kernels import bvh


def grid_mesh():
    """Points on a grid: many equal coordinates, so the stable order of ties matters."""
    g = np.arange(12.0)
    return DataMesh(np.stack(np.meshgrid(g, g, g * 0.5), -1).reshape(-1, 3))


def build(mesh, leaf_size, threads, parallel_min):
    cent, plo, phi = bvh.primitive_boxes(mesh)
    done = np.zeros(threads + 1, dtype=np.int64)
    out = bvh._run_build(cent, plo, phi, leaf_size, done, threads=threads,
                         parallel_min=parallel_min)
    assert done.sum() == cent.shape[0]          # every primitive placed, counted once
    return out


@pytest.mark.parametrize("case", ["grid", "bunny_triangles", "bunny_edges", "mixed_mesh"])
@pytest.mark.parametrize("leaf_size", [1, 3])
def test_the_parallel_build_is_the_serial_one(bunny, mixed_mesh, monkeypatch, case, leaf_size):
    mesh = {"grid": grid_mesh, "mixed_mesh": lambda: mixed_mesh,
            "bunny_triangles": lambda: bunny,
            "bunny_edges": lambda: bunny.as_kind("edges")}[case]()
    serial = build(mesh, leaf_size, threads=1, parallel_min=2)
    for threads, radix_min in ((2, None), (3, None), (2, 0), (1, 0)):
        # radix_min 0: the kernel with the radix sort (_build_long), as a big mesh's
        if radix_min is not None:
            monkeypatch.setattr(bvh, "RADIX_BUILD_MIN", radix_min)
        split = build(mesh, leaf_size, threads=threads, parallel_min=2)
        for name, a, b in zip(("order", "lo", "hi", "left", "right", "start", "count",
                               "depth"), serial, split):
            np.testing.assert_array_equal(a, b, err_msg=name)
        monkeypatch.undo()


def test_build_tree_on_threads_matches_one_thread(bunny, monkeypatch):
    one = bvh.build_tree(bunny)
    monkeypatch.setattr(bvh, "PARALLEL_BUILD_MIN", 2)
    seen = []
    many = bvh.build_tree(bunny, progress=lambda done, total, s: seen.append((done, total)))
    for name in one._fields:
        np.testing.assert_array_equal(getattr(one, name), getattr(many, name), err_msg=name)
    assert seen[-1] == (bunny.num_primitives, bunny.num_primitives)


@pytest.mark.parametrize("n", [0, 1, 17, 1023, 1024, 5000])
def test_the_sorts_keep_the_stable_order(rng, n):
    """Each sort of the build, on keys with ties, signed zeros and extreme exponents, against
    numpy's stable argsort."""
    counts = np.empty(bvh.RADIX_BUCKETS, dtype=np.int64)
    cases = (rng.random(n), rng.integers(0, 4, n) * 1.0, -np.arange(n) * 1.0,
             np.arange(n) * 1.0, np.where(rng.random(n) < 0.5, 0.0, -0.0),
             rng.normal(size=n) * 1e-300, rng.normal(size=n) * 1e300, np.full(n, 3.5))
    for keys in cases:
        s, e = (n // 5, n - n // 7) if n > 10 else (0, n)
        ref = np.arange(n)
        ref[s:e] = s + np.argsort(keys[s:e], kind="stable")
        for sort in (bvh._sort_order, bvh._radix_sort, bvh._sort_short):
            items = np.arange(n, dtype=np.int64)
            sort(keys.copy(), items, np.empty(n), np.empty(n, dtype=np.int64), s, e, counts)
            np.testing.assert_array_equal(items, ref, err_msg=sort.__name__)
