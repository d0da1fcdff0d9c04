"""Scenes of several objects from Python (issue 46, item 6): ``tracer.render_mesh([m1, m2])``
frames every object, each with its own parameters; ``camera=`` takes a render's camera.

Checked against independent renders: each object alone, through the combined render's own
camera, must light the same pixels as in the combined image (the objects are far apart
against 1/alpha, so the smooth union changes no silhouette; a grazing pixel may differ).
"""
import numpy as np
import pytest

import tracer
from tracer.scenes.from_mesh import is_mesh_list

trimesh = pytest.importorskip("trimesh")

SIZE = (64, 32)


def _pair():
    a = trimesh.creation.icosphere(subdivisions=2)
    b = trimesh.creation.box(extents=[1.0, 1.0, 1.0])
    b.apply_translation([3.0, 0.0, 0.0])
    return a, b


def test_several_meshes_are_framed_together_with_their_own_parameters():
    a, b = _pair()
    res = tracer.render_mesh([a, b], size=SIZE, shading="normals", alpha=[20.0, 30.0],
                             alpha_u="off", offset=[0.0, 0.05])
    objs = res.scene.objects
    assert [o.alpha for o in objs] == [20.0, 30.0]
    assert [o.smooth_offset for o in objs] == [0.0, 0.05]
    assert len({o.name for o in objs}) == 2
    cols = np.flatnonzero(res.hit.any(axis=0))
    # both objects in view, side by side, nothing cut at the image's border
    assert cols.min() > 0 and cols.max() < SIZE[0] - 1
    assert res.hit[:, : SIZE[0] // 2].sum() > 20 and res.hit[:, SIZE[0] // 2:].sum() > 20
    assert not res.hit[0].any() and not res.hit[-1].any()
    alone = [tracer.render_mesh(m, size=SIZE, shading="normals", alpha=al, alpha_u="off",
                                offset=off, camera=res.camera)
             for m, al, off in ((a, 20.0, 0.0), (b, 30.0, 0.05))]
    union = alone[0].hit | alone[1].hit
    assert not (alone[0].hit & alone[1].hit).any()
    assert np.mean(union != res.hit) <= 0.01


def test_a_renders_camera_renders_the_same_view():
    a, _ = _pair()
    res = tracer.render_mesh(a, size=SIZE, shading="normals")
    again = tracer.render_mesh(a, size=SIZE, shading="normals", camera=res.camera)
    np.testing.assert_allclose(again.camera.origin, res.camera.origin, rtol=0, atol=1e-12)
    np.testing.assert_allclose(again.camera.forward, res.camera.forward, rtol=0, atol=1e-12)
    assert np.mean(again.hit != res.hit) == 0.0
    assert np.abs(again.rgb.astype(int) - res.rgb.astype(int)).max() <= 1


def test_colours_per_object_and_the_palette():
    a, b = _pair()
    s = tracer.mesh_scene([a, b], size=SIZE, color=[(255, 0, 0), (0, 0, 255)])
    assert [o.color for o in s.objects] == [(255, 0, 0), (0, 0, 255)]
    s = tracer.mesh_scene([a, b], size=SIZE, color=(10, 200, 10))     # one colour for all
    assert [o.color for o in s.objects] == [(10, 200, 10)] * 2
    assert [o.color for o in tracer.mesh_scene([a, b], size=SIZE).objects] == [None, None]


def test_what_counts_as_a_list_of_meshes(tmp_path):
    a, b = _pair()
    V, F = np.asarray(a.vertices), np.asarray(a.faces)
    assert is_mesh_list([a, b])
    assert is_mesh_list([(V, F), (V + 3, F)])
    assert is_mesh_list([V, V + 3])                       # two point clouds
    assert not is_mesh_list(V.tolist())                   # one cloud, as a list of 3-vectors
    assert not is_mesh_list((V, F))                       # one mesh as a pair
    assert not is_mesh_list([])
    p = tmp_path / "a.obj"
    a.export(p)
    assert is_mesh_list([str(p), b])


def test_bad_lists_say_what_is_wrong():
    a, b = _pair()
    with pytest.raises(ValueError, match="alpha has 3 values for 2 meshes"):
        tracer.mesh_scene([a, b], alpha=[1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="F must be None"):
        tracer.mesh_scene([a, b], np.zeros((1, 3), int))
    with pytest.raises(ValueError, match="mesh 1: "):
        tracer.mesh_scene([a, np.full((3, 3), np.nan)])
