"""One word for one thing (issue 50): one class per name, a function name used twice only for
one protocol, one spelling per concept in the API, the scene files and the code.

The table of spellings is ``docs/design-notes.md`` ("Vocabulary"); :data:`SYNONYMS` below are
the spellings it refuses, each with ours and the only places the old one may stand (the
readers of the authors' formats, and the documents that describe those formats).
"""

import ast
import inspect
import json
import re
from collections import defaultdict
from pathlib import Path

import pytest

import smoothdist
import smoothdist.kernels
import tracer
import tracer.sim
from tracer.scenes import scene as scene_mod
from tracer.scenes.from_mesh import mesh_scene, render_mesh

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("smoothdist", "tracer")

#: function names defined in several modules on purpose: one protocol, or a mirror
PROTOCOLS = {
    # every command module of the CLI (tracer/cli.py loads them by these names)
    "add_arguments": "a CLI command module's flags", "needs": "a CLI command's extras",
    "run": "a CLI command's body", "main": "a script's entry point",
    # every study (tracer.studies.*, tracer.sim.frames): the runner's protocol
    "list_tasks": "a study's tasks", "reduce": "a study's summary",
    "default_output": "a study's output folder",
    # the CUDA module mirrors the package's two queries on the device
    "smooth_distance": "smoothdist.cuda mirrors the package's query on the GPU",
    "exact_distance": "smoothdist.cuda mirrors the package's query on the GPU",
    # the import hook of moved modules: one copy per package (tracer may not import
    # smoothdist's private modules), kept equal by tests/repo/test_moved_modules.py
    "install": "the moved-modules hook of each package",
    # the library's checks raise ValueError, the command line's CLIError (tracer may not
    # import smoothdist._cast)
    "positive": "a number check: ValueError in smoothdist, CLIError in tracer",
    "non_negative": "a number check: ValueError in smoothdist, CLIError in tracer",
    # a compile-ahead child's entry point (tracer.compiling.spawn_ahead runs it): one for a
    # render, one for a simulation
    "child_main": "a compile-ahead child's entry point",
}
#: class names defined in several modules on purpose
CLASS_COPIES = {"MovedModules": "the moved-modules hook of each package (see PROTOCOLS)"}

#: refused spelling -> (ours, files where the old one may stand)
SYNONYMS = {
    "max_alpha": ("alpha_u", {"tracer/scenes/scene.py", "tracer/scenes/scene.schema.json",
                              "tracer/sim/authors_format.py", "tracer/sim/simfile.py",
                              "tracer/reproduce/experiments.py"}),
    "bvh_type": ("kind", {"tracer/scenes/scene.py", "tracer/scenes/scene.schema.json",
                          "tracer/sim/authors_format.py", "tracer/sim/simfile.py"}),
    "wgs": ("wgrad_scale", set()),
    "exact_box": ("box_test", set()),
}


def _sources():
    for pkg in PACKAGES:
        for path in sorted((ROOT / pkg).rglob("*.py")):
            yield path.relative_to(ROOT).as_posix(), path.read_text(encoding="utf-8")


def _top_level_defs():
    classes, functions = defaultdict(list), defaultdict(list)
    for rel, text in _sources():
        for node in ast.parse(text).body:
            if isinstance(node, ast.ClassDef):
                classes[node.name].append(rel)
            elif isinstance(node, ast.FunctionDef) and not node.name.startswith("_"):
                functions[node.name].append(rel)
    return classes, functions


def test_one_class_per_name():
    classes, _ = _top_level_defs()
    twice = {k: v for k, v in classes.items() if len(v) > 1 and k not in CLASS_COPIES}
    assert not twice, f"class names defined in several modules (rename one): {twice}"
    assert set(CLASS_COPIES) <= {k for k, v in classes.items() if len(v) > 1}, \
        "a class listed in CLASS_COPIES is no longer copied: remove it from the list"


def test_a_function_name_twice_only_for_one_protocol():
    _, functions = _top_level_defs()
    twice = {k: v for k, v in functions.items() if len(v) > 1 and k not in PROTOCOLS}
    assert not twice, ("public function names defined in several modules for different "
                       f"things (rename one, or list a protocol in PROTOCOLS): {twice}")
    assert set(PROTOCOLS) <= {k for k, v in functions.items() if len(v) > 1}, \
        "a name listed in PROTOCOLS is defined once now: remove it from the list"


def test_the_refused_spellings_stand_only_where_an_old_format_is_read():
    words = {old: re.compile(rf"\b{old}\b") for old in SYNONYMS}
    found = defaultdict(set)
    files = list(_sources()) + [("tracer/scenes/scene.schema.json",
                                 (ROOT / "tracer/scenes/scene.schema.json").read_text())]
    for rel, text in files:
        for old, pattern in words.items():
            if pattern.search(text):
                found[old].add(rel)
    for old, (ours, allowed) in SYNONYMS.items():
        assert found[old] <= allowed, (f"{old!r} (ours: {ours!r}) in "
                                       f"{sorted(found[old] - allowed)}")
        stale = allowed - found[old]
        assert not stale, f"{old!r} no longer in {sorted(stale)}: shrink SYNONYMS"


def test_scenes_we_ship_use_our_spelling():
    files = sorted((ROOT / "scenes").glob("*.json"))
    assert len(files) >= 10
    for f in files:
        for obj in json.loads(f.read_text())["objects"]:
            for part in [obj] + obj.get("parts", []):
                assert not set(part) & set(scene_mod.AUTHORS_KEYS), f.name
                assert part.get("kind", "mixed") in scene_mod.KINDS, f.name


def _public_callables():
    """``(qualified name, signature)`` of the public API's functions and methods."""
    out = []
    for pkg in (smoothdist, smoothdist.kernels, tracer, tracer.sim):
        for name in pkg.__all__:
            obj = getattr(pkg, name)
            members = [(name, obj)]
            if inspect.isclass(obj):
                members += [(f"{name}.{m}", f) for m, f in vars(obj).items()
                            if not m.startswith("_") and callable(f)]
            for qual, f in members:
                f = getattr(f, "py_func", f)  # a numba dispatcher: its Python function
                try:
                    out.append((f"{pkg.__name__}.{qual}", inspect.signature(f)))
                except (TypeError, ValueError):
                    continue
    return out


def test_public_signatures_use_our_spelling():
    refused = set(SYNONYMS) | {"bvh_type", "faces", "eye", "target", "max_alpha"}
    calls = _public_callables()
    assert len(calls) > 30  # the API was found
    bad = [(q, p) for q, sig in calls for p in sig.parameters if p in refused]
    assert not bad, f"parameters spelled the refused way: {bad}"


@pytest.mark.parametrize("entry", [mesh_scene, render_mesh, tracer.scene_from_field])
def test_a_view_name_is_view_everywhere(entry):
    """``view`` is the side a camera frames the data from, ``camera`` the camera itself, in
    every entry point that builds a scene."""
    params = inspect.signature(entry).parameters
    assert "view" in params and "camera" in params
    assert params["camera"].default is None


def test_scene_file_keys_are_the_api_parameters():
    """A scene file's key that is a setting of the API has the API's name (``alpha_u``, not
    ``max_alpha``); the keys that only a file has are listed with the reason."""
    api = set(inspect.signature(tracer.scene_from_field).parameters)
    api |= set(inspect.signature(mesh_scene).parameters)
    file_only = {
        "path": "the object's file (the API takes the data itself)",
        "parts": "several files merged into one object",
        "scale": "applied to a file's vertices", "translate": "applied to a file's vertices",
        "camera": "origin / dest / up, as in the authors' files",
        "objects": "the scene's objects", "description": "free text",
    }
    keys = ((scene_mod._OBJECT_KEYS | scene_mod._PART_KEYS | scene_mod._TOP_KEYS)
            - set(scene_mod.AUTHORS_KEYS))
    assert keys - api - set(file_only) == set()


def test_the_vocabulary_table_lists_every_refused_spelling():
    notes = (ROOT / "docs" / "design-notes.md").read_text(encoding="utf-8")
    section = notes.split("### Vocabulary", 1)[1].split("\n## ", 1)[0]
    for old, (ours, _) in SYNONYMS.items():
        assert f"`{ours}`" in section, ours
        if old in scene_mod.AUTHORS_KEYS:
            assert f"`{old}`" in section, old
