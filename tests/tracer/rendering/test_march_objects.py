"""Scenes of several objects (tracer.rendering.march): the object skip against a plain combination.

``tracer.rendering.march.scene_distance`` evaluates the object with the nearest root box first and skips
an object whose lower bound (``object_lower_bound``) shows that it cannot change the result:
in exact-offset mode when the bound is not below the minimum so far, in smooth mode when its
LogSumExp term would be below one unit in the last place of the sum. The reference here
evaluates every object on its own (brute force, every primitive) and combines them in numpy
(LogSumExp with the largest alpha, or the minimum), for posed and unposed objects.
"""

import math

import numpy as np
import pytest

from smoothdist import DataMesh, SmoothDistanceField
from tracer.rendering import march
from tracer.rendering.frame import scene_arrays
from tracer.scenes.scene import Scene, SceneObject


def _rot(axis, angle):
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def _objects(rng):
    """A triangle sheet, a wire and a point cloud, far enough apart that most queries can skip
    two of them at the alphas used."""
    g = np.linspace(-1.0, 1.0, 9)
    X, Y = np.meshgrid(g, g)
    V = np.c_[X.ravel(), Y.ravel(), 0.05 * np.sin(3 * X.ravel())]
    F = []
    for i in range(8):
        for j in range(8):
            a, b, c, d = i * 9 + j, i * 9 + j + 1, (i + 1) * 9 + j, (i + 1) * 9 + j + 1
            F += [[a, b, d], [a, d, c]]
    sheet = DataMesh(V, np.array(F))
    s = np.linspace(0, 2 * np.pi, 25)[:-1]
    wire = DataMesh(np.c_[0.5 * np.cos(s) + 2.5, 0.5 * np.sin(s), 0.3 + 0.1 * np.sin(2 * s)],
                    np.c_[np.arange(24), (np.arange(24) + 1) % 24])
    cloud = DataMesh(rng.normal(size=(60, 3)) * 0.2 + [0.0, 2.5, 0.4])
    return [sheet, wire, cloud]


def _scene(meshes, mode, alphas):
    objs = [SceneObject(name=f"o{i}", field=SmoothDistanceField(m), alpha=a, alpha_u=None, beta=0.0,
                        offset=0.05) for i, (m, a) in enumerate(zip(meshes, alphas))]
    return Scene(path="objects.json", camera_origin=np.array([0.0, 0.0, 6.0]),
                 camera_dest=np.zeros(3), camera_up=np.array([0.0, 1.0, 0.0]), objects=objs,
                 width=8, height=8, mode=mode, eps=1e-4)


def _reference(scene, poses, Q, mode, own=False):
    """Every object on its own (brute force at its local points), combined in numpy; ``own``:
    also each object's own distance ``(k, n)``."""
    ds, gs = [], []
    for o, (R, t) in zip(scene.objects, poses):
        local = (Q - t) @ R             # R^T (q - t), row by row
        if mode == "exact":
            d, g = o.field.exact_distance(local)[:2]
            d = d - o.offset
        else:
            d, g = o.field.smooth_distance(local, alpha=o.alpha, method="brute",
                                           gradient=scene.gradient)
        ds.append(d)
        gs.append(g @ R.T)
    D, G = np.array(ds), np.array(gs)
    if mode == "exact":
        k = np.argmin(D, axis=0)
        res = D[k, np.arange(len(Q))], G[k, np.arange(len(Q))]
    else:
        a = max(o.alpha for o in scene.objects)
        m = D.min(axis=0)
        w = np.exp(-a * (D - m))
        s = w.sum(axis=0)
        res = m - np.log(s) / a, (w[:, :, None] * G).sum(axis=0) / s[:, None]
    return res + (D,) if own else res


def _kernel(arrays, Q):
    tree, roots, params, mode, lo, hi, depth_max, tol = arrays
    stack = np.empty(depth_max + 4, dtype=np.int64)
    dstack = np.empty(depth_max + 4)
    out = np.empty((len(Q), 4))
    leaves = np.empty(len(Q), dtype=np.int64)
    near = np.empty(len(Q), dtype=np.int64)
    for i, q in enumerate(Q):
        d, gx, gy, gz, nodes, lv, nearest = march.scene_distance(
            (tree, roots, params, mode, tol), *q, (stack, dstack), 0.0)
        out[i] = d, gx, gy, gz
        leaves[i] = lv
        near[i] = nearest
    return out[:, 0], out[:, 1:], leaves, near


@pytest.mark.parametrize("posed", [False, True])
@pytest.mark.parametrize("mode", ["smooth", "exact"])
def test_object_skip_equals_every_object(mode, posed, rng):
    meshes = _objects(rng)
    alphas = [60.0, 80.0, 40.0]
    scene = _scene(meshes, mode, alphas)
    poses = ([(_rot([1, 2, 0.5], 0.4), np.array([0.1, -0.2, 0.3])),
              (_rot([0, 1, 1], -0.7), np.array([0.5, 0.0, 0.2])),
              (_rot([1, 0, 0], 1.1), np.array([-0.3, 0.2, 0.0]))] if posed else
             [(np.eye(3), np.zeros(3))] * 3)
    arrays = scene_arrays(scene, poses if posed else None)
    lo, hi = arrays.lo, arrays.hi
    Q = rng.uniform(lo, hi, size=(400, 3))
    d, g, leaves, near = _kernel(arrays, Q)
    dr, gr, Dr = _reference(scene, poses, Q, mode, own=True)
    np.testing.assert_allclose(d, dr, rtol=1e-12, atol=1e-12)
    # the nearest object (the one a ray's hit shows) is the argmin of the objects' own
    # distances, wherever that is not a near tie
    gap = np.sort(Dr, axis=0)[1] - Dr.min(axis=0)
    clear = gap > 1e-9
    assert clear.mean() > 0.9
    np.testing.assert_array_equal(near[clear], np.argmin(Dr, axis=0)[clear])
    if mode == "smooth":
        np.testing.assert_allclose(g, gr, rtol=1e-9, atol=1e-9)
    else:
        # the exact gradient is that of the nearest object (ties aside)
        cos = (g * gr).sum(axis=1) / np.maximum(np.linalg.norm(g, axis=1)
                                                * np.linalg.norm(gr, axis=1), 1e-300)
        assert np.mean(cos > 1 - 1e-9) > 0.99
    # the skip happens: fewer leaves than the three objects' own traversals together
    total = sum(o.field.num_primitives for o in scene.objects)
    assert np.median(leaves) < 0.75 * total


def test_object_lower_bound_is_below_each_object(rng):
    """Fuzz: the bound never exceeds the object's own distance (smooth, Barnes-Hut and tol
    included; exact-offset), posed."""
    meshes = _objects(rng)
    for mode in ("smooth", "exact"):
        scene = _scene(meshes, mode, [5.0, 200.0, 30.0])
        for o in scene.objects:
            o.beta = 0.7
        poses = [(_rot(rng.normal(size=3), rng.uniform(0, 3)), rng.normal(size=3))
                 for _ in range(3)]
        tree, roots, params, mode_k, lo, hi, depth_max, tol = scene_arrays(scene, poses)
        stack = np.empty(depth_max + 4, dtype=np.int64)
        dstack = np.empty(depth_max + 4)
        Q = rng.uniform(lo - 1.0, hi + 1.0, size=(300, 3))
        for tol in (0.0, 0.3):
            if mode == "exact" and tol:
                continue
            for q in Q:
                for k in range(3):
                    sc = (tree, roots, params, mode_k, tol)
                    lb = march.object_lower_bound(sc, k, *q, 0.0)
                    d = march._object_distance(sc, k, *q, (stack, dstack), 0.0)[0]
                    assert lb <= d + 1e-12 * (1 + abs(d)), (mode, tol, k, lb, d)
                    assert math.isfinite(lb)


@pytest.mark.parametrize("samples", [1, 4])
@pytest.mark.parametrize("mode", ["smooth", "exact"])
def test_render_object_map_is_the_nearest_object(mode, samples, rng):
    """A lit render's object map (``aovs["object"]``), which the march finds at each hit, is
    what ``tracer.rendering.lighting.object_ids`` computes at the hit points on its own (each object's
    own distance, smallest); the anti-aliasing samples colour their hits the same way (an
    image with the samples' colours from ``object_ids`` is the same image)."""
    from tracer.rendering import film, lighting
    from tracer.rendering.camera import primary_rays
    from tracer.rendering.renderer import render

    meshes = _objects(rng)
    # blunt enough for the wire and the cloud to cover pixels at 48 x 48
    scene = _scene(meshes, mode, [60.0, 10.0, 8.0])
    for o in scene.objects:
        o.offset = 0.15
    scene.width = scene.height = 48
    scene.camera_origin = np.array([1.0, 1.0, 5.0])
    scene.camera_dest = np.array([1.0, 1.0, 0.0])
    scene.shading = "lit"
    scene.samples = samples
    res = render(scene)
    obj = res.aovs["object"]
    assert set(np.unique(obj[res.hit])) == {0, 1, 2}       # all three objects in view
    assert (obj[~res.hit] == -1).all()
    P = res.camera.origin + np.asarray(res.depth, float)[..., None] * primary_rays(res.camera)
    arrays = scene_arrays(scene)
    tree, roots, params, mode_k, lo, hi, depth_max, tol = arrays
    ref = np.empty(int(res.hit.sum()), dtype=np.int64)
    lighting.object_ids(tree, (roots, params, mode_k, tol), np.ascontiguousarray(P[res.hit]),
                        depth_max, ref, 1)
    # depth is stored in float32: hit points lie within rounding of the march's own points
    assert np.mean(obj[res.hit] == ref) > 0.995
    if samples > 1:
        # the samples' objects from object_ids instead of the march: the same image
        shade = film._Shader.shade

        def shade_found_again(self, hit, t, grad, dirs, reuse=None, grid=None, objs=None):
            return shade(self, hit, t, grad, dirs, reuse, grid,
                         objs if grid is not None else None)

        film._Shader.shade = shade_found_again
        try:
            again = render(scene)
        finally:
            film._Shader.shade = shade
        assert np.abs(again.rgb.astype(int) - res.rgb.astype(int)).max() <= 1
