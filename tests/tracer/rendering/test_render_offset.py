"""Smooth mode at an offset: the surface ``d_hat = c`` (``offset`` of ``tracer.rendering.renderer``,
``tracer.render_mesh``, scene files and ``tracer render --offset``).

Every hit is checked against the library's brute-force smooth distance (``method="brute"``,
beta 0) at the hit point, for each path of :func:`tracer.rendering.march.scene_distance`: one object
without ``tol`` (the lean kernel), one object with ``tol``, several objects (LogSumExp of
``d_hat_k - c_k``), and posed objects. Renders are 40 x 40 or smaller.
"""

import json

import numpy as np
import pytest

import tracer
from smoothdist import SmoothDistanceField
from tracer.rendering import lighting
from tracer.rendering.camera import primary_rays
from tracer.cli import main
from tracer.scenes.from_mesh import describe_parameters, mesh_scene
from tracer.rendering.frame import scene_arrays
from tracer.rendering.renderer import render
from tracer.errors import SceneError
from tracer.scenes.scene import Scene, SceneObject, load_scene, scene_from_field

SIZE = 40
CAMERA = ((0.6, 0.8, 3.2), (0.0, 0.0, 0.0), (0.0, 1.0, 0.0))


def fibonacci_sphere(n, radius=1.0, centre=(0.0, 0.0, 0.0)):
    """``n`` nearly uniform points on a sphere (Fibonacci lattice), ``(n, 3)``."""
    i = np.arange(n) + 0.5
    phi = np.arccos(1.0 - 2.0 * i / n)
    theta = np.pi * (1.0 + 5.0 ** 0.5) * i
    unit = np.stack([np.cos(theta) * np.sin(phi), np.sin(theta) * np.sin(phi), np.cos(phi)], 1)
    return radius * unit + np.asarray(centre, dtype=float)


def brute_scene_distance(objects, points, alpha_scene=None):
    """The scene's smooth distance minus the offsets, from the library's brute force:
    ``-log(sum_k exp(-a (d_hat_k - c_k))) / a`` (``a`` the largest alpha) and the object whose
    ``d_hat_k - c_k`` is the smallest."""
    D = np.stack([o.field.smooth_distance(points, alpha=o.alpha, alpha_u=o.alpha_u,
                                          method="brute")[0] - o.smooth_offset
                  for o in objects])
    if len(objects) == 1:
        return D[0], np.zeros(len(points), int)
    a = alpha_scene or max(o.alpha for o in objects)
    m = D.min(axis=0)
    return m - np.log(np.exp(-a * (D - m)).sum(axis=0)) / a, D.argmin(axis=0)


def hit_points(res):
    rays = primary_rays(res.camera)
    return (res.camera.origin + res.depth.astype(np.float64)[..., None] * rays)[res.hit]


def sphere_object(name="ball", centre=(0.0, 0.0, 0.0), radius=0.8, n=300, alpha=12.0, c=0.0):
    field = SmoothDistanceField(fibonacci_sphere(n, radius, centre))
    return SceneObject(name=name, field=field, alpha=alpha, alpha_u=alpha, beta=0.0,
                       offset=1.0 / alpha, smooth_offset=c)


def make_scene(objects, tol=0.0, shading="normals"):
    o, d, u = (np.asarray(v, float) for v in CAMERA)
    scene = Scene(path="offset.json", camera_origin=o, camera_dest=d, camera_up=u,
                  objects=objects, width=SIZE, height=SIZE, beta=0.0, tol=tol, shading=shading)
    scene.eps = 1e-4 * scene.diagonal
    return scene


#: offsets tried: 0, a fraction of the blur 1/alpha, several blurs
OFFSETS = (0.0, 0.04, 0.25)


def _case(path, c):
    """The scene (and poses) of one kernel path, every object at offset ``c``."""
    if path in ("lean", "tol"):
        return make_scene([sphere_object(c=c)], tol=1e-3 if path == "tol" else 0.0), None
    objs = [sphere_object("a", (-0.5, 0.0, 0.0), 0.5, 200, 14.0, c),
            sphere_object("b", (0.55, 0.1, -0.2), 0.45, 160, 10.0, 0.5 * c)]
    # (the lit shading keeps the object map, aovs["object"])
    if path == "objects":
        return make_scene(objs, shading="lit"), None
    theta = 0.3
    R = np.array([[np.cos(theta), 0.0, np.sin(theta)], [0.0, 1.0, 0.0],
                  [-np.sin(theta), 0.0, np.cos(theta)]])
    return make_scene(objs, shading="lit"), [(R, np.zeros(3)),
                                             (np.eye(3), np.array([0.0, 0.1, 0.0]))]


@pytest.mark.parametrize("path", ["lean", "tol", "objects", "posed"])
def test_smooth_offset_hits_lie_on_the_level_set(path):
    prev = None
    counts = []
    for c in OFFSETS:
        scene, poses = _case(path, c)
        res = render(scene, transforms=poses)
        P = hit_points(res)
        objs = scene.objects
        if poses is not None:    # brute force in each object's own frame
            D = []
            for o, (R, t) in zip(objs, poses):
                D.append(brute_scene_distance([o], (P - t) @ R)[0])
            D = np.stack(D)
            a = max(o.alpha for o in objs)
            m = D.min(axis=0)
            d = m - np.log(np.exp(-a * (D - m)).sum(axis=0)) / a
            nearest = D.argmin(axis=0)
        else:
            d, nearest = brute_scene_distance(objs, P)
        # tolerance pruning lowers d_hat by up to log(1 + tol) / alpha: the true value at a
        # hit may be that much above eps; the depth is float32
        slack = np.log1p(scene.tol) / min(o.alpha for o in objs)
        assert res.hit.sum() > 100
        assert np.all(d <= scene.eps + slack + 1e-6), (path, c, d.max())
        assert np.all(d >= -scene.eps - 1e-6), (path, c, d.min())
        if len(objs) > 1:
            # the object map names the object whose own d_hat_k - c_k is the smallest
            D_sorted = np.sort(D if poses is not None else np.stack(
                [brute_scene_distance([o], P)[0] for o in objs]), axis=0)
            clear = D_sorted[1] - D_sorted[0] > 1e-6
            obj = res.aovs["object"][res.hit]
            assert np.array_equal(obj[clear], nearest[clear])
        if prev is not None:
            # {d_hat <= c} grows with c: every ray that met the smaller surface meets the
            # larger one, no farther away
            assert not (prev.hit & ~res.hit).any()
            both = prev.hit & res.hit
            assert np.all(res.depth[both] <= prev.depth[both] + 2 * scene.eps)
        counts.append(int(res.hit.sum()))
        prev = res
    assert counts[0] < counts[1] < counts[2], counts


def test_smooth_offset_moves_the_lowest_point_and_the_shadows():
    """The lighting kernels (ground height, shadow and occlusion rays) see ``d_hat - c``: the
    surface's lowest point drops by at least ``c`` (``|grad d_hat| <= 1``), and a lit render
    at an offset is finite."""
    heights = []
    for c in (0.0, 0.1):
        scene = make_scene([sphere_object(c=c)], shading="lit")
        arrays = scene_arrays(scene)
        heights.append(lighting.ground_height(arrays, scene.objects[0].field.mesh.V,
                                              np.array([0.0, 1.0, 0.0]), scene.eps))
        res = render(scene)
        assert np.isfinite(res.rgb).all() and res.hit.sum() > 100
    assert heights[1] <= heights[0] - 0.1 + 2 * scene.eps, heights


def test_render_mesh_offset_in_smooth_mode_changes_the_surface():
    """Issue 35 (b): ``offset`` was accepted in smooth mode and ignored."""
    P = fibonacci_sphere(200)
    kw = dict(kind="points", size=(32, 32), view="iso", shading="normals", beta=0.0)
    base = tracer.render_mesh(P, **kw)
    cam = (base.scene.camera_origin, base.scene.camera_dest, base.scene.camera_up)
    res = tracer.render_mesh(P, offset=0.1, camera=cam, **kw)
    o = res.scene.objects[0]
    assert o.smooth_offset == 0.1 and base.scene.objects[0].smooth_offset == 0.0
    d = o.field.smooth_distance(hit_points(res), alpha=o.alpha, alpha_u=o.alpha_u,
                                method="brute")[0]
    assert np.all(np.abs(d - 0.1) <= res.scene.eps + 1e-6)
    assert res.hit.sum() > base.hit.sum()
    # a view framed for the offset surface frames it whole: nothing touches the border
    res = tracer.render_mesh(P, offset=1.0, **kw)
    assert res.hit.sum() > 100
    assert not (res.hit[0].any() or res.hit[-1].any() or res.hit[:, 0].any()
                or res.hit[:, -1].any())


@pytest.mark.parametrize("bad", [-0.1, float("nan"), float("inf")])
def test_offset_must_be_finite_and_not_negative(bad, tmp_path):
    with pytest.raises(ValueError, match="offset must be"):
        mesh_scene(fibonacci_sphere(20), size=(8, 8), offset=bad)
    field = SmoothDistanceField(fibonacci_sphere(20))
    with pytest.raises(ValueError, match="offset must be"):
        scene_from_field(field, alpha=5.0, offset=bad, width=8, height=8)
    scene = make_scene([sphere_object(c=0.1)])
    scene.objects[0].smooth_offset = bad           # set by hand after validation
    with pytest.raises(ValueError, match="offset must be a finite number >= 0"):
        render(scene)
    if np.isfinite(bad):     # JSON has no nan / inf
        np.savetxt(tmp_path / "p.xyz", fibonacci_sphere(20))
        p = tmp_path / "s.json"
        p.write_text(json.dumps({"camera": {"origin": [0, 0, 4], "dest": [0, 0, 0],
                                            "up": [0, 1, 0]}, "offset": bad,
                                 "objects": [{"path": "p.xyz", "alpha": 5}]}))
        with pytest.raises(SceneError, match=r"s\.json: offset must be >= 0"):
            load_scene(p)


def test_scene_file_and_cli_offset_in_smooth_mode(tmp_path, capsys):
    """The scene key and ``--offset`` set the smooth level; the summary line reports it and
    ``--save-scene`` keeps it; without it the smooth level is 0 and exact mode's 1/alpha."""
    xyz = tmp_path / "ball.xyz"
    np.savetxt(xyz, fibonacci_sphere(150))
    s = tmp_path / "s.json"
    data = {"camera": {"origin": [0.5, 0.6, 4.0], "dest": [0, 0, 0], "up": [0, 1, 0]},
            "width": 16, "height": 16, "objects": [{"path": "ball.xyz", "alpha": 6}]}
    s.write_text(json.dumps(data))
    o = load_scene(s).objects[0]
    assert (o.level("smooth"), o.level("exact")) == (0.0, pytest.approx(1 / 6))
    s.write_text(json.dumps(dict(data, offset=0.2)))
    o = load_scene(s).objects[0]
    assert (o.level("smooth"), o.level("exact")) == (0.2, 0.2)
    assert load_scene(s, {"offset": 0.05}).objects[0].smooth_offset == 0.05
    assert "offset 0.2 (" in describe_parameters(load_scene(s))
    out, saved = tmp_path / "b.png", tmp_path / "b.json"
    assert main(["render", str(xyz), "--size", "16", "16", "--offset", "0.07", "-o", str(out),
                 "--save-scene", str(saved), "--shading", "normals"]) == 0
    summary = capsys.readouterr().out
    assert "smooth mode" in summary and ", offset 0.07 (" in summary
    assert json.loads(saved.read_text())["objects"][0]["offset"] == 0.07
    assert load_scene(saved).objects[0].smooth_offset == 0.07
    assert main(["render", str(xyz), "--size", "16", "16", "--offset", "-1", "-o",
                 str(tmp_path / "c.png")]) == 2
    assert "--offset must be >= 0" in capsys.readouterr().err
