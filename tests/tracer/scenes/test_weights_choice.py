"""Which weights a scene draws with (the ``weights`` setting, smoothdist.junctions): scene
files and the research API keep the paper's, the mesh entry points' automatic surface takes
inclusion-exclusion, and one scene never mixes them (its objects' trees make one forest)."""
import json

import numpy as np
import pytest
import trimesh

import smoothdist
import tracer
from tracer.cli import main
from tracer.errors import SceneError
from tracer.image import load_png
from tracer.scenes.scene import load_scene, scene_from_field

TET = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\nf 1 3 4\nf 2 3 4\n"


def _scene(tmp_path, **top):
    (tmp_path / "tet.obj").write_text(TET)
    obj = top.pop("object", {"path": "tet.obj", "alpha": 40.0})
    data = {"camera": {"origin": [3, 2, 5], "dest": [0.3, 0.3, 0.3], "up": [0, 1, 0]},
            "objects": [obj], "width": 8, "height": 8, **top}
    p = tmp_path / "s.json"
    p.write_text(json.dumps(data))
    return p


def test_scene_files_choose_their_weights(tmp_path):
    assert load_scene(_scene(tmp_path)).objects[0].field.weights == "paper"
    s = load_scene(_scene(tmp_path, weights="inclusion-exclusion"))
    assert s.march.weights == "inclusion-exclusion"
    assert s.objects[0].field.weights == "inclusion-exclusion"
    # auto: inclusion-exclusion only for the automatic surface
    assert load_scene(_scene(tmp_path, weights="auto")).march.weights == "paper"
    auto = load_scene(_scene(tmp_path, weights="auto", object={"path": "tet.obj",
                                                                "alpha": "auto"}))
    assert auto.march.weights == "inclusion-exclusion"
    # an override (tracer render --weights) wins over the file
    s = load_scene(_scene(tmp_path, weights="paper"), {"weights": "inclusion-exclusion"})
    assert s.objects[0].field.weights == "inclusion-exclusion"
    with pytest.raises(SceneError, match="weights"):
        load_scene(_scene(tmp_path, weights="exact"))


def test_mesh_entry_points_take_the_junction_weights_for_the_automatic_surface():
    box = trimesh.creation.box()
    res = tracer.render_mesh(box, size=(24, 24), progress=None)
    assert res.scene.march.weights == "inclusion-exclusion"
    assert res.scene.objects[0].field.weights == "inclusion-exclusion"
    given = tracer.mesh_scene(box, size=(24, 24), alpha=30.0)
    assert given.march.weights == "paper"
    forced = tracer.mesh_scene(box, size=(24, 24), alpha=30.0, weights="inclusion-exclusion")
    assert forced.objects[0].field.weights == "inclusion-exclusion"
    # two meshes, one automatic and one not: one scheme for the scene, the paper's
    both = tracer.mesh_scene([box, trimesh.creation.icosphere(1)], size=(24, 24),
                             alpha=["auto", 30.0])
    assert both.march.weights == "paper"
    assert {o.field.weights for o in both.objects} == {"paper"}
    # the research API keeps the paper's weights and leaves the caller's field alone
    field = smoothdist.SmoothDistanceField(box.vertices, box.faces)
    s = scene_from_field(field, alpha=30.0, weights="inclusion-exclusion", width=8, height=8)
    assert s.objects[0].field.weights == "inclusion-exclusion" and field.weights == "paper"
    assert scene_from_field(field, alpha=30.0, width=8, height=8).march.weights == "paper"


def test_saved_scene_renders_the_same_image(tmp_path, capsys):
    """tracer render MESH --save-scene writes the weights it drew with; the scene file
    renders the same pixels."""
    stl = tmp_path / "box.stl"
    trimesh.creation.box().export(stl)
    out, saved = tmp_path / "a.png", tmp_path / "box.json"
    assert main(["render", str(stl), "--size", "32", "32", "-o", str(out), "-q",
                 "--save-scene", str(saved)]) == 0
    assert json.loads(saved.read_text())["weights"] == "inclusion-exclusion"
    again = tmp_path / "b.png"
    assert main(["render", str(saved), "-o", str(again), "-q"]) == 0
    np.testing.assert_array_equal(load_png(out), load_png(again))
    assert main(["render", str(stl), "--size", "16", "16", "-o", str(tmp_path / "c.png"), "-q",
                 "--weights", "paper", "--save-scene", str(tmp_path / "c.json")]) == 0
    assert "weights" not in json.loads((tmp_path / "c.json").read_text())
