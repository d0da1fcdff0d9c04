"""The scene format's machine-readable reference: ``tracer/scenes/scene.schema.json``.

The JSON Schema (draft 2020-12) lists every key of a scene file with its type, default,
whether it is required, a description and an example. Editors use it for completion and
checking when it is associated with scene files in their settings (e.g. VS Code's
``json.schemas``; a ``"$schema"`` key inside a scene is refused like any unknown key). This
module

* loads it (:func:`load_schema`),
* checks a parsed scene against it with a small validator covering the keywords the schema
  uses (:func:`validate`; the loader's own checks stay the authority), and
* renders it as the Markdown reference ``docs/scene-format.md`` (:func:`markdown`):
  ``python -m tracer.scenes.scene_schema > docs/scene-format.md``.

The settings' keys (``width``, ``beta``, ``mode``, ...: every top-level key of the table of
:mod:`tracer.scenes.settings` but ``lighting``, whose node lists the fields of
:class:`~tracer.rendering.lighting.Lighting`) are made from the table
(:func:`setting_properties`: type, choices, range, default, description, example);
``python -m tracer.scenes.scene_schema --write-schema`` writes them into the file, and a test
checks that the file holds what the table makes (:func:`generated_schema`). The rest of the
schema (camera, objects, parts, lighting) is written by hand.

``tests/tracer/scenes/test_scene_schema.py`` keeps the schema, the docs and
:mod:`tracer.scenes.scene` equal.
"""

import json
import os
import sys

from tracer.rendering.lighting import Lighting
from tracer.scenes.settings import RGB, table

SCHEMA_PATH = os.path.join(os.path.dirname(os.path.abspath(__file__)), "scene.schema.json")


def load_schema():
    """The schema as a dict."""
    with open(SCHEMA_PATH, encoding="utf-8") as fh:
        return json.load(fh)


def _resolve(schema, node):
    """Follow a ``$ref`` (``#/$defs/name``) and merge the node's own keys over it."""
    if "$ref" not in node:
        return node
    target = schema
    for part in node["$ref"].lstrip("#/").split("/"):
        target = target[part]
    merged = dict(_resolve(schema, target))
    merged.update({k: v for k, v in node.items() if k != "$ref"})
    return merged


def sections(schema=None):
    """``[(title, where, node)]`` for the top level, camera, object and part tables."""
    schema = schema or load_schema()
    props = schema["properties"]
    return [("Top level", "", schema), ("camera", "camera.", props["camera"]),
            ("lighting", "lighting.", props["lighting"]),
            ("objects[i]", "objects[i].", schema["$defs"]["object"]),
            ("objects[i].parts[j]", "objects[i].parts[j].", schema["$defs"]["part"])]


# ---------------------------------------------------------------------- made from the table
#: JSON Schema types of the settings' kinds
_JSON_TYPES = {float: "number", int: "integer", bool: "boolean", str: "string"}


def setting_properties():
    """``{key: node}``: the schema of each top-level setting key of the table
    (:mod:`tracer.scenes.settings`) but ``lighting`` (an object of fields, written by hand)."""
    return {r.key: _setting_node(r) for r in table() if r.scene_key and r.kind is not Lighting}


def _json_number(value):
    """A number as the schema writes it (``0``, not ``0.0``)."""
    return int(value) if isinstance(value, float) and value.is_integer() else value


def _setting_node(r):
    """The schema of one setting (a :class:`~tracer.scenes.settings.Row`)."""
    if r.choices:
        node = {"enum": list(r.choices)}
    elif r.kind == RGB:
        node = {"type": "array", "items": {"type": _JSON_TYPES[r.item], "minimum": 0,
                                           "maximum": 255}, "minItems": 3, "maxItems": 3}
    else:
        node = {"type": _JSON_TYPES[r.kind]}
    if r.above is not None:     # an integer > n is one >= n + 1
        node.update({"minimum": r.above + 1} if r.kind is int else
                    {"exclusiveMinimum": _json_number(r.above)})
    if r.at_least is not None:
        node["minimum"] = _json_number(r.at_least)
    if r.at_most is not None:
        node["maximum"] = _json_number(r.at_most)
    if r.text:
        node["x-default"] = r.text
    else:
        node["default"] = (list(r.file) if isinstance(r.file, tuple) else
                           _json_number(r.file))
    node["description"] = r.doc or r.help[0].upper() + r.help[1:] + "."
    if r.example is not None:
        node["examples"] = [r.example]
    return node


def generated_schema(schema=None):
    """The schema (default: the file's) with its settings' keys as the table makes them
    (:func:`setting_properties`): each in its place, a new one before ``description``."""
    schema = json.loads(json.dumps(schema or load_schema()))
    made = setting_properties()
    props = {}
    for key, node in schema["properties"].items():
        if key == "description":
            props.update({k: v for k, v in made.items() if k not in schema["properties"]})
        props[key] = made.get(key, node)
    schema["properties"] = props
    return schema


def schema_text(schema):
    """The schema file's text: the layout of ``scene.schema.json`` (one line per key of a
    table, objects with properties spread over lines)."""
    return _layout(schema, 0) + "\n"


def _layout(node, depth):
    """``node`` as JSON: a dict with ``properties`` (or ``items`` naming a definition, or a
    table of named nodes: the root's ``properties`` and ``$defs``) over several lines, every
    other value on one."""
    spread = isinstance(node, dict) and (
        depth == 0 or "properties" in node or "$ref" in node.get("items", {})
        or node.get("_table"))
    if not spread:
        return json.dumps(node, ensure_ascii=False)
    pad = "  " * (depth + 1)
    lines = []
    for key, value in node.items():
        if key == "_table":
            continue
        if key in ("properties", "$defs") and isinstance(value, dict):
            value = dict(value, _table=True)
        lines.append(f"{pad}{json.dumps(key)}: {_layout(value, depth + 1)}")
    return "{\n" + ",\n".join(lines) + "\n" + "  " * depth + "}"


def write_schema(path=SCHEMA_PATH):
    """Write the schema file with its settings' keys made from the table
    (:func:`generated_schema`); returns whether it changed."""
    text = schema_text(generated_schema())
    with open(path, encoding="utf-8") as fh:
        old = fh.read()
    if text != old:
        with open(path, "w", encoding="utf-8") as fh:
            fh.write(text)
    return text != old


# ---------------------------------------------------------------------- validation
def _type_ok(value, t):
    if t == "object":
        return isinstance(value, dict)
    if t == "array":
        return isinstance(value, list)
    if t == "string":
        return isinstance(value, str)
    if t == "integer":
        return (isinstance(value, int) and not isinstance(value, bool)) or (
            isinstance(value, float) and value.is_integer())
    if t == "number":
        return isinstance(value, (int, float)) and not isinstance(value, bool)
    if t == "boolean":
        return isinstance(value, bool)
    raise ValueError(f"schema type {t!r} is not supported by this validator")


def validate(data, schema=None):
    """Errors (a list of one-line strings, empty when valid) of a parsed scene."""
    schema = schema or load_schema()
    errors = []
    _check(schema, schema, data, "scene", errors)
    return errors


def _check(schema, node, value, where, errors):
    node = _resolve(schema, node)
    if "const" in node and value != node["const"]:
        errors.append(f"{where}: must be {node['const']!r}")
        return
    if "enum" in node and value not in node["enum"]:
        errors.append(f"{where}: must be one of {node['enum']}")
        return
    if "type" in node and not _type_ok(value, node["type"]):
        errors.append(f"{where}: must be of type {node['type']}")
        return
    for key in ("anyOf", "oneOf"):
        if key in node:
            results = []
            for sub in node[key]:
                sub_errors = []
                _check(schema, sub, value, where, sub_errors)
                results.append(not sub_errors)
            if (key == "anyOf" and not any(results)) or (key == "oneOf" and sum(results) != 1):
                errors.append(f"{where}: must match {'one' if key == 'oneOf' else 'any'} of "
                              f"{len(results)} alternatives ({key})")
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        if "minimum" in node and value < node["minimum"]:
            errors.append(f"{where}: must be >= {node['minimum']}")
        if "maximum" in node and value > node["maximum"]:
            errors.append(f"{where}: must be <= {node['maximum']}")
        if "exclusiveMinimum" in node and value <= node["exclusiveMinimum"]:
            errors.append(f"{where}: must be > {node['exclusiveMinimum']}")
    if isinstance(value, str) and len(value) < node.get("minLength", 0):
        errors.append(f"{where}: must not be empty")
    if isinstance(value, list):
        if len(value) < node.get("minItems", 0) or len(value) > node.get("maxItems", 1 << 62):
            errors.append(f"{where}: has {len(value)} items")
        if "items" in node:
            for i, item in enumerate(value):
                _check(schema, node["items"], item, f"{where}[{i}]", errors)
    if isinstance(value, dict):
        for key in node.get("required", []):
            if key not in value:
                errors.append(f"{where}: missing required key {key!r}")
        props = node.get("properties", {})
        for key, item in value.items():
            if key in props:
                _check(schema, props[key], item, f"{where}.{key}", errors)
            elif node.get("additionalProperties", True) is False:
                errors.append(f"{where}: unknown key {key!r}")


# ---------------------------------------------------------------------- documentation
def _type_text(node):
    if "const" in node:
        return json.dumps(node["const"])
    if "enum" in node:
        return " \\| ".join(f"`{json.dumps(v)}`" for v in node["enum"])
    if "anyOf" in node:
        return " or ".join(_type_text(n) for n in node["anyOf"])
    t = node.get("type", "")
    if t == "array" and node.get("minItems") == node.get("maxItems") == 3:
        return f"list of 3 {node['items'].get('type', 'number')}s"
    if t == "array":
        return "list"
    bounds = []
    if "exclusiveMinimum" in node:
        bounds.append(f"> {node['exclusiveMinimum']}")
    if "minimum" in node:
        bounds.append(f">= {node['minimum']}")
    if "maximum" in node:
        bounds.append(f"<= {node['maximum']}")
    return t + (f" ({', '.join(bounds)})" if bounds else "")


def _default_text(node, required):
    if required:
        return "required"
    if "default" in node:
        return f"`{json.dumps(node['default'])}`"
    return node.get("x-default", "(none)")


def markdown(schema=None):
    """The Markdown reference of the scene format (``docs/scene-format.md``)."""
    schema = schema or load_schema()
    out = ["# Scene file format", "",
           "<!-- Generated from tracer/scenes/scene.schema.json by "
           "`python -m tracer.scenes.scene_schema > "
           "docs/scene-format.md`; do not edit by hand "
           "(tests/tracer/scenes/test_scene_schema.py checks it). "
           "-->", "",
           schema["description"], "",
           "`tracer render MESH` writes a complete example with `--save-scene scene.json`; "
           "`scenes/*.json` are more.", ""]
    for title, prefix, node in sections(schema):
        node = _resolve(schema, node)
        out += [f"## {title}", ""]
        if prefix and node.get("description"):
            out += [node["description"], ""]
        if "oneOf" in node:
            out += ["Give exactly one of `path` and `parts`.", ""]
        out += ["| key | type | default | example | meaning |", "|---|---|---|---|---|"]
        required = set(node.get("required", []))
        for key, sub in node["properties"].items():
            sub = _resolve(schema, sub)
            example = sub.get("examples", [None])[0]
            ex = f"`{json.dumps(example)}`" if example is not None else ""
            desc = sub.get("description", "").replace("|", "\\|")
            out.append(f"| `{prefix}{key}` | {_type_text(sub)} | "
                       f"{_default_text(sub, key in required)} | {ex} | {desc} |")
        out.append("")
    return "\n".join(out)


def main(argv=None):
    """``python -m tracer.scenes.scene_schema [--check FILE | --write-schema]``: print the
    Markdown reference, or exit 1 when FILE differs from it, or write the settings' keys of
    the schema file from the table (:func:`write_schema`)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv == ["--write-schema"]:
        changed = write_schema()
        print(f"{SCHEMA_PATH} {'written' if changed else 'is up to date'}")
        return 0
    text = markdown()
    if argv[:1] == ["--check"] and len(argv) == 2:
        with open(argv[1], encoding="utf-8") as fh:
            same = fh.read() == text
        print(f"{argv[1]} is {'up to date' if same else 'out of date'}")
        return 0 if same else 1
    sys.stdout.write(text)
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
