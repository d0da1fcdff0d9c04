"""The interfaces made from the settings table (tracer/scenes/settings.py): one checker
(``settings.check``) for the scene loader, the API and the command line; the keyword entry
points' signatures and docstrings (``settings_entry``); ``tracer render``'s options; the
settings' keys of the JSON Schema."""

import argparse
import inspect
import json

import numpy as np
import pytest

from smoothdist import DataMesh, SmoothDistanceField
from tracer import cli_render
from tracer.cli import _Parser
from tracer.errors import CLIError, SceneError
from tracer.rendering.lighting import Lighting
from tracer.scenes import from_mesh, scene as scene_mod, scene_schema, settings
from tracer.scenes.settings import REQUIRED, check, defaults, table

TRI = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"
CAMERA = {"origin": [0.3, 0.3, 3], "dest": [0.3, 0.3, 0], "up": [0, 1, 0]}


@pytest.mark.parametrize("key,value,out", [
    ("beta", 1, 1.0), ("samples", 4.0, 4), ("width", np.int64(8), 8), ("eps", None, None),
    ("alpha", "auto", "auto"), ("alpha_u", "off", "off"), ("adaptive", np.True_, True),
    ("background", [0, 10, 255.0], (0, 10, 255)), ("color", (1, 2, 3.5), (1.0, 2.0, 3.5)),
    ("mode", "exact", "exact"), ("lighting", {"ao": False}, Lighting(ao=False)),
    ("lighting", None, Lighting()), ("max_steps", 1_000_000, 1_000_000),
])
def test_check_normalises_a_value(key, value, out):
    got = check(key, value)
    assert got == out and type(got) is type(out)


@pytest.mark.parametrize("key,value,message", [
    ("beta", -1, "beta must be >= 0, got -1"),
    ("eps", 0, "eps must be > 0, got 0"),
    ("width", 1.5, "width must be an integer, got 1.5"),
    ("width", 10 ** 400, "width is too large"),
    ("beta", True, "beta must be a number, got true"),
    ("tol", float("nan"), "tol must be finite, got nan"),
    ("samples", 1025, "samples must be at most 1024, got 1025"),
    ("max_steps", 10 ** 7, "max_steps must be at most 1000000"),
    ("mode", "fuzzy", 'mode must be one of smooth, exact; got "fuzzy"'),
    ("alpha", "big", 'alpha must be a number or "auto", got "big"'),
    ("alpha_u", "sharp", 'alpha_u must be a number or "auto" or "off", got "sharp"'),
    ("adaptive", 1, "adaptive must be true or false, got 1"),
    ("background", [0, 0, 256], "background must be [r, g, b] integers 0-255"),
    ("background", [0, 0, 0.5], "background must be [r, g, b] integers 0-255"),
    ("color", [0, 0], "color must be 3 numbers in 0..255"),
    ("lighting", {"bogus": 1}, "lighting has unknown key(s) 'bogus'"),
    ("lighting", 3, "lighting must be a tracer.rendering.lighting.Lighting or a dict"),
    ("matcap", 3, "matcap must be a string"),
])
def test_check_refuses_with_one_line_naming_the_setting(key, value, message):
    with pytest.raises(ValueError) as info:
        check(key, value)
    assert message in str(info.value) and "\n" not in str(info.value)
    with pytest.raises(ValueError, match="^--flag "):   # the name its reader knows
        check(key, value, "--flag")


def test_every_default_passes_the_check_and_null_only_where_allowed():
    for r in table():
        for entry in ("file", "api", "mesh"):
            value = getattr(r, entry)
            if value is not REQUIRED and not (value is None and not r.none):
                check(r.key, value)
        if not r.none and r.kind is not Lighting:
            with pytest.raises(ValueError, match=r.key):
                check(r.key, None)
        if r.none:     # a scene file's null is refused all the same
            with pytest.raises(ValueError, match=r.key):
                check(r.key, None, none=False)


def _scene(tmp_path, **top):
    (tmp_path / "tri.obj").write_text(TRI)
    data = {"camera": CAMERA, "objects": [{"path": "tri.obj", "alpha": 20}], "width": 8,
            "height": 8, **top}
    p = tmp_path / "s.json"
    p.write_text(json.dumps(data))
    return p


@pytest.fixture(scope="module")
def field():
    return SmoothDistanceField(DataMesh(np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]),
                                        np.array([[0, 1, 2]])))


@pytest.mark.parametrize("key,bad,message", [
    ("samples", 0, "samples must be > 0"), ("samples", 2000, "samples must be at most 1024"),
    ("max_steps", 2.5, "max_steps must be an integer"), ("tol", -1, "tol must be >= 0"),
    ("mode", "fuzzy", "mode must be one of smooth, exact"),
    ("weights", "none", "weights must be one of auto, paper, inclusion-exclusion"),
    ("background", [0, 0, 300], "background must be [r, g, b] integers 0-255"),
    ("transparent", "yes", "transparent must be true or false"),
])
def test_loader_and_api_say_the_same(tmp_path, field, key, bad, message):
    with pytest.raises(SceneError, match=f"^s.json: {message}".replace("[", r"\[")):
        scene_mod.load_scene(_scene(tmp_path, **{key: bad}))
    with pytest.raises(ValueError, match=f"^{message}".replace("[", r"\[")):
        scene_mod.scene_from_field(field, alpha=20.0, **{key: bad})


def test_loader_names_an_override_by_its_flag(tmp_path):
    p = _scene(tmp_path, beta=0.5)
    with pytest.raises(SceneError, match="^s.json: --beta must be >= 0, got -1"):
        scene_mod.load_scene(p, {"beta": -1})
    with pytest.raises(SceneError, match=r"^s.json: --size width must be > 0"):
        scene_mod.load_scene(p, {"width": 0})
    with pytest.raises(SceneError, match="newton must be a number .a multiple of eps"):
        scene_mod.load_scene(_scene(tmp_path, newton=False))
    with pytest.raises(SceneError, match="eps must be a number, got null"):
        scene_mod.load_scene(_scene(tmp_path, eps=None))
    p = _scene(tmp_path, beta=0.5)
    s = scene_mod.load_scene(p, {"beta": 0.25, "samples": 4, "adaptive": True})
    assert (s.beta, s.samples, s.adaptive) == (0.25, 4, True)


def _parse(*argv):
    p = _Parser(prog="tracer render")
    cli_render.add_arguments(p)
    return p.parse_args(["m.obj", *argv])


@pytest.mark.parametrize("argv,message", [
    (["--beta", "-0.5"], "--beta must be >= 0, got -0.5"),
    (["--samples", "0"], "--samples must be >= 1, got 0"),   # as typed: the smallest value
    (["--samples", "2000"], "--samples must be at most 1024, got 2000"),
    (["--alpha", "nan"], "--alpha must be finite"),
    (["--alpha", "big"], "--alpha must be a number or 'auto', got 'big'"),
    (["--alpha-u", "0"], "--alpha-u must be > 0"),
    (["--view-width", "0"], "--view-width must be > 0"),
    (["--background", "0", "0", "256"], "--background must be three integers 0-255, got 0 0 "
                                        "256"),
    (["--color", "0", "-1", "0"], "--color must be three integers 0-255, got 0 -1 0"),
    (["--beta", "abc"], "argument --beta: invalid float value: 'abc'"),
    (["--samples", "2.5"], "argument --samples: invalid int value: '2.5'"),
    (["--mode", "fuzzy"], "argument --mode: invalid choice: 'fuzzy'"),
    (["--newton", "1", "--no-newton"], "not allowed with argument --newton"),
])
def test_cli_options_check_with_the_table(argv, message):
    with pytest.raises(CLIError) as info:
        _parse(*argv)
    assert message in str(info.value)
    if message.startswith(argv[0]):     # an option's check: its line alone
        assert str(info.value).startswith(argv[0] + " must be"), str(info.value)


def test_cli_options_are_the_tables():
    args = _parse("--alpha", "auto", "--alpha-u", "off", "--samples", "4", "--background",
                  "0", "0", "0", "--adaptive", "--no-newton")
    assert (args.alpha, args.alpha_u, args.samples, args.background, args.adaptive,
            args.newton) == ("auto", "off", 4, [0, 0, 0], True, 0.0)
    p = argparse.ArgumentParser()
    cli_render.add_arguments(p)
    actions = {a.option_strings[0]: a for a in p._actions if a.option_strings}
    for r in table():
        if not r.flag:
            continue
        a = actions[settings.flag_of(r.key)]
        assert a.dest == r.key and a.default is None, r.key
        if r.choices:
            assert tuple(a.choices) == r.choices, r.key


def test_schema_file_is_what_the_table_makes():
    schema = scene_schema.load_schema()
    assert scene_schema.generated_schema(schema) == schema, (
        "run python -m tracer.scenes.scene_schema --write-schema")
    with open(scene_schema.SCHEMA_PATH, encoding="utf-8") as fh:
        assert scene_schema.schema_text(schema) == fh.read()
    props = schema["properties"]
    assert props["samples"]["maximum"] == settings.MAX_SAMPLES
    assert props["width"]["minimum"] == 1 and props["eps"]["exclusiveMinimum"] == 0
    assert tuple(props["weights"]["enum"]) == settings.WEIGHT_CHOICES


@pytest.mark.parametrize("fn,entry", [(scene_mod.scene_from_field, "api"),
                                      (from_mesh.mesh_scene, "mesh"),
                                      (from_mesh.render_mesh, "mesh")])
def test_entry_points_show_every_setting(fn, entry):
    params = inspect.signature(fn).parameters
    doc = inspect.getdoc(fn)
    keys = [r.key for r in table()]
    if entry == "mesh":
        keys = [k for k in keys if k not in ("width", "height", "max_steps", "gradient")]
        keys.append("size")
        assert params["size"].default == (512, 512)
    for key in keys:
        p = params[key]
        assert p.kind is p.KEYWORD_ONLY, key
        assert f"\n{key} :" in doc, key          # numpydoc's Parameters line
        if key != "size":
            d = defaults(entry)[key]
            assert p.default is (p.empty if d is REQUIRED else d), key
    assert "settings" not in params
    assert fn.__kwdefaults__ == {n: p.default for n, p in params.items()
                                 if p.kind is p.KEYWORD_ONLY and p.default is not p.empty}


def test_entry_points_refuse_a_misspelt_keyword(field):
    with pytest.raises(TypeError, match="widht"):
        scene_mod.scene_from_field(field, alpha=20.0, widht=3)
    with pytest.raises(TypeError, match="alpha"):
        scene_mod.scene_from_field(field)
    with pytest.raises(TypeError, match="sampels"):
        from_mesh.mesh_scene("m.obj", sampels=4)
    with pytest.raises(ValueError, match="size must be"):
        from_mesh.mesh_scene("m.obj", size=8)


def test_mesh_entry_points_hand_down_the_groups(monkeypatch):
    seen = {}

    def fake(mesh, F, kind, surface, march, film, view, camera=None, name=None):
        seen.update(surface=surface, march=march, film=film, view=view, kind=kind)
        return "scene"

    monkeypatch.setattr(from_mesh, "build_mesh_scene", fake)
    assert from_mesh.mesh_scene("m.obj", kind="edges", size=(64, 32), beta=0.25,
                                samples=4) == "scene"
    assert (seen["film"].width, seen["film"].height, seen["film"].samples) == (64, 32, 4)
    assert seen["march"] == settings.March(beta=0.25, weights="auto")
    assert seen["surface"] == settings.Surface(alpha="auto") and seen["kind"] == "edges"
    assert seen["view"] == settings.View(view="front", up="auto")
