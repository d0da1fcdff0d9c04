"""The settings table (tracer/scenes/settings.py) is the one place a default is written: the Scene
dataclass, scene_from_field, mesh_scene / render_mesh, ``tracer render`` (flags, help text and
the mesh path), the scene loader and tracer/scenes/scene.schema.json agree with it."""

import argparse
import ast
import dataclasses
import inspect
import json
import pathlib

import numpy as np
import pytest

from tracer import cli_render
from tracer.scenes import from_mesh, scene as scene_mod, settings
from tracer.rendering.lighting import Lighting
from tracer.scenes.scene_schema import load_schema
from tracer.scenes.settings import REQUIRED, default_text, defaults, table

FILE, API, MESH = defaults("file"), defaults("api"), defaults("mesh")

def _signature_defaults(fn, renamed=None):
    """Keyword-only defaults of ``fn`` by setting name (``renamed``: parameter -> setting)."""
    renamed = renamed or {}
    out = {}
    for name, p in inspect.signature(fn).parameters.items():
        if p.kind is not p.KEYWORD_ONLY:
            continue
        if name == "size":
            out["width"], out["height"] = p.default
            continue
        out[renamed.get(name, name)] = REQUIRED if p.default is p.empty else p.default
    return out


def test_table_has_every_group_field_once_and_says_why_entries_differ():
    keys = [r.key for r in table()]
    assert len(keys) == len(set(keys))
    for r in table():
        assert r.help, r.key
        if not (r.file == r.api == r.mesh):
            assert r.why, f"{r.key}: entry points differ without a reason"
    # the module's prose names every setting whose entry points differ
    for r in table():
        if not (r.file == r.api == r.mesh):
            assert f"``{r.key}``" in settings.__doc__, r.key
    # the frozen groups build with their defaults and refuse assignment
    for group in settings.GROUPS:
        obj = group()
        with pytest.raises(dataclasses.FrozenInstanceError):
            setattr(obj, dataclasses.fields(group)[0].name, 0)


def test_scene_defaults_are_the_file_defaults():
    # a Scene built without settings holds the groups' defaults, which are the file column;
    # each setting also reads through the scene's shorthand of the same name
    scene = scene_mod.Scene("s.json", camera_origin=[0, 0, 3], camera_dest=[0, 0, 0],
                            camera_up=[0, 1, 0])
    assert scene.march == settings.March() and scene.film == settings.Film()
    shared = set(scene_mod._SHORTHANDS) & set(FILE)
    assert {"width", "beta", "newton", "shading", "lighting", "background"} <= shared
    for key in shared:
        assert getattr(scene, key) == FILE[key], key


def test_scene_settings_travel_as_groups_and_shorthands_write_them():
    scene = scene_mod.Scene("s.json", camera_origin=[0, 0, 3], camera_dest=[0, 0, 0],
                            camera_up=[0, 1, 0], width=64, eps=1e-3, newton=0.0)
    assert (scene.film.width, scene.march.eps, scene.march.newton) == (64, 1e-3, 0.0)
    march, film = scene.march, scene.film
    scene.eps, scene.samples = 2e-3, 4        # a shorthand replaces its (frozen) group
    assert (scene.march.eps, scene.film.samples) == (2e-3, 4)
    assert (march.eps, film.samples) == (1e-3, 1)      # the old groups are unchanged
    scene.camera_origin = [0, 0, 5]
    assert scene.camera.origin.tolist() == [0, 0, 5] and scene.camera.origin.dtype == float
    # dataclasses.replace takes the shorthands too, over the groups of the scene it copies
    other = dataclasses.replace(scene, height=32, camera_up=[1, 0, 0])
    assert (other.film.height, other.film.width, other.film.samples) == (32, 64, 4)
    assert other.camera.up.tolist() == [1, 0, 0] and scene.camera.up.tolist() == [0, 1, 0]
    assert other.march is scene.march
    listed = scene_mod.Scene("s.json", camera=([0, 0, 3], [0, 0, 0], [0, 1, 0]))
    assert all(isinstance(v, np.ndarray) and v.dtype == float for v in listed.camera[:3])
    assert listed.camera.projection == "perspective" and listed.camera.view_width is None
    with pytest.raises(TypeError, match="'widht'"):
        scene_mod.Scene("s.json", camera=scene.camera, widht=3)
    with pytest.raises(TypeError, match="camera"):
        scene_mod.Scene("s.json", camera_origin=[0, 0, 3])


def test_scene_from_field_signature_is_the_api_column():
    sig = _signature_defaults(scene_mod.scene_from_field, {"camera": "view"})
    shared = set(sig) & set(API)
    assert shared >= {"alpha", "alpha_u", "beta", "view", "shading", "tol", "newton", "up"}
    for key in shared:
        assert sig[key] == API[key], key


@pytest.mark.parametrize("fn", [from_mesh.mesh_scene, from_mesh.render_mesh])
def test_mesh_entry_points_are_the_mesh_column(fn):
    sig = _signature_defaults(fn)
    shared = set(sig) & set(MESH)
    assert shared >= {"alpha", "alpha_u", "width", "height", "view", "up", "shading", "tol"}
    for key in shared:
        assert sig[key] == MESH[key], key


def _render_parser():
    p = argparse.ArgumentParser()
    cli_render.add_arguments(p)
    return p


def test_cli_mesh_file_without_flags_gets_the_mesh_column(monkeypatch):
    seen = {}

    def fake(path, F, kind, *groups, camera=None):
        seen.clear()
        for group in groups:
            seen.update(dataclasses.asdict(group))
        seen.update(kind=kind, camera=camera)
        return "scene"

    monkeypatch.setattr(from_mesh, "build_mesh_scene", fake)
    args = _render_parser().parse_args(["bunny.obj"])
    assert cli_render._build_mesh_scene(args) == "scene"
    assert seen.pop("camera") is None and seen.pop("kind") is None
    assert seen.pop("lighting") == {}  # no flag given: Lighting() inside field_scene
    assert set(seen) == set(MESH) - {"lighting"}
    for key, value in seen.items():
        assert value == MESH[key], key
    # and a flag wins
    cli_render._build_mesh_scene(_render_parser().parse_args(["bunny.obj", "--beta", "0.25"]))
    assert seen["beta"] == 0.25


def test_cli_help_names_the_table_defaults():
    helps = {a.option_strings[0].lstrip("-"): " ".join((a.help or "").split()).replace("%%", "%")
             for a in _render_parser()._actions if a.option_strings}
    assert f"mesh default {MESH['width']} {MESH['height']}" in helps["size"]
    for r in table():
        flag = r.key.replace("_", "-")
        if not r.flag:
            assert flag not in helps, r.key
            continue
        text = helps[flag]
        assert " ".join(r.help.split()) in text, r.key        # the field's help
        assert default_text(r.key, "mesh") in text, r.key      # and its defaults
        if r.file is not REQUIRED:
            assert f"the scene file's, else {r.text or default_text(r.key)}" in text, r.key
    assert f"else {default_text('newton')}" in helps["newton"]
    assert f"for a mesh file: {MESH['shading']}" in helps["shading"]
    assert f"else {FILE['weights']}; for a mesh file: {MESH['weights']}" in helps["weights"]
    assert f"for a mesh file: {MESH['view']}" in helps["view"]


def _schema_default(node):
    return node.get("default", node.get("x-default"))


def _as_json(value):
    if isinstance(value, settings.Lighting):
        return {}  # the schema's lighting default: no key given
    return json.loads(json.dumps(value))


def test_schema_and_loader_keys_and_defaults_are_the_table():
    schema = load_schema()
    top = schema["properties"]
    assert set(top) == scene_mod._TOP_KEYS
    assert settings.SCENE_KEYS <= set(top)
    for r in table():
        if not r.scene_key:
            continue
        node = top[r.key]
        if r.text:
            assert node.get("x-default") == r.text, r.key
        else:
            assert _schema_default(node) == _as_json(r.file), r.key
    obj = schema["$defs"]["object"]["properties"]
    assert obj["alpha_u"]["default"] == FILE["alpha_u"]
    assert "alpha" in schema["$defs"]["object"]["required"] or "alpha" in json.dumps(
        schema["$defs"]["object"])  # alpha: required by the authors' format


def test_loader_fills_left_out_keys_with_the_file_column(tmp_path):
    (tmp_path / "tri.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    (tmp_path / "s.json").write_text(json.dumps({
        "camera": {"origin": [0.3, 0.3, 3], "dest": [0.3, 0.3, 0], "up": [0, 1, 0]},
        "objects": [{"path": "tri.obj", "alpha": 20}]}))
    sc = scene_mod.load_scene(tmp_path / "s.json")
    for key in set(FILE) & {f.name for f in dataclasses.fields(sc)}:
        if key == "eps":
            assert sc.eps == pytest.approx(1e-4 * np.sqrt(2))  # the text's 1e-4 x diagonal
            continue
        assert getattr(sc, key) == FILE[key], key
    o = sc.objects[0]
    assert o.alpha_u == pytest.approx(o.field.auto_alpha_u(20.0))  # max_alpha "auto"
    assert sc.march == settings.March(eps=sc.eps)
    assert sc.film == settings.Film()
    # the research API's deliberate difference: no attenuation unless asked
    api = scene_mod.scene_from_field(o.field, alpha=20.0, width=8, height=8)
    assert api.objects[0].alpha_u == 20.0 and api.shading == API["shading"]


#: the modules a render goes through, scene to kernels
RENDER_PATH = ("tracer/scenes/scene.py", "tracer/scenes/from_mesh.py", "tracer/cli_render.py",
               "tracer/rendering/renderer.py", "tracer/rendering/frame.py",
               "tracer/rendering/film.py", "tracer/rendering/gpu_render.py",
               "tracer/rendering/march.py", "tracer/rendering/lighting.py",
               "tracer/rendering/shading.py", "tracer/rendering/camera.py")
#: the public entry points, which keep one keyword argument per setting (a pyvista user's
#: habit) and build the settings groups once
KEYWORD_ENTRY_POINTS = {"scene_from_field", "mesh_scene", "render_mesh"}
#: the most settings a function below them takes one by one (the march kernels' ray function
#: takes 8 scalars: numba compiles it for the GPU too, a NamedTuple of them is no cheaper)
MOST_SETTINGS = 8


def test_no_function_of_the_render_path_takes_more_than_eight_settings_one_by_one():
    root = pathlib.Path(__file__).resolve().parents[3]
    names = ({r.key for r in table()} | {f.name for f in dataclasses.fields(Lighting)}
             | {"relax", "omega", "cone", "size", "newton_cos", "kind"})
    seen, over = 0, {}
    for module in RENDER_PATH:
        for node in ast.walk(ast.parse((root / module).read_text())):
            if isinstance(node, ast.FunctionDef):
                a = node.args
                mine = [p.arg for p in a.posonlyargs + a.args + a.kwonlyargs if p.arg in names]
                seen += 1
                if len(mine) > MOST_SETTINGS:
                    over[node.name] = mine
    assert seen > 200, seen     # the walk found the functions
    assert not over, sorted(over)
    # the keyword entry points take one keyword per setting, made from the table
    # (settings.settings_entry): their signatures, not their definitions
    for name in KEYWORD_ENTRY_POINTS:
        fn = getattr(scene_mod, name, None) or getattr(from_mesh, name)
        assert len(set(inspect.signature(fn).parameters) & names) > MOST_SETTINGS, name


def test_cli_mesh_options_come_from_the_table():
    """``tracer render MESH`` takes every setting it has an option of the same name for, with
    no list to keep: the keys are the table's, the flags their names with dashes."""
    p = argparse.ArgumentParser()
    cli_render.add_arguments(p)
    args = p.parse_args(["m.obj"])
    taken = cli_render.mesh_options(args)
    assert {"projection", "view_width", "alpha_u", "samples", "background"} <= set(taken)
    assert set(taken) <= {r.key for r in table()}
    flags = {s for a in p._actions for s in a.option_strings}
    assert all(cli_render._flag_of(k) in flags for k in taken)
