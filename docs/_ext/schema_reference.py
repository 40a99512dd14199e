"""The configuration reference, generated from the configuration schema when the docs build.

The directive ``schema-reference`` walks ``src/ldpipe/schemas/config.schema.yaml``, the file the
workflow validates every configuration against, and writes one section per top-level key with a
definition list of every key below it (dotted path; type, default, allowed values; description). The schema
stays the one home of each key's meaning: the page cannot fall behind it.
"""

from __future__ import annotations

import json
from importlib.resources import files
from pathlib import Path

import yaml
from docutils import nodes
from docutils.statemachine import StringList
from sphinx.util.docutils import SphinxDirective
from sphinx.util.nodes import nested_parse_with_titles

SCHEMA = Path(str(files("ldpipe") / "schemas/config.schema.yaml"))  # the installed schema, the workflow's own
MAX_DEPTH = 6  # the schema nests four levels at most; a deeper walk would be a reference cycle


def _resolve(schema: dict, node: dict) -> dict:
    """``node`` with a local ``$ref`` replaced by its target (keeping the node's own description)."""
    while "$ref" in node:
        target = schema
        for part in node["$ref"].removeprefix("#/").split("/"):
            target = target[part]
        node = {**target, **{k: v for k, v in node.items() if k != "$ref"}}
    return node


def _type(schema: dict, node: dict) -> str:
    node = _resolve(schema, node)
    if "type" in node:
        kinds = node["type"] if isinstance(node["type"], list) else [node["type"]]
        text = " or ".join(kinds)
        if "array" in kinds and "items" in node and isinstance(node["items"], dict):
            text += f" of {_type(schema, node['items'])}"
        return text
    for key in ("oneOf", "anyOf"):
        if key in node:
            return " or ".join(dict.fromkeys(_type(schema, option) for option in node[key]))
    values = node.get("enum", [node["const"]] if "const" in node else [])
    if values:
        return " or ".join(dict.fromkeys(_json_type(v) for v in values))
    return "any"


def _json_type(value) -> str:
    """The JSON type of an allowed value, as the schema's ``type`` would name it."""
    for kind, name in ((bool, "boolean"), (int, "integer"), (float, "number"), (str, "string"), (list, "array"),
                       (dict, "object")):
        if isinstance(value, kind):
            return name
    return "null"


def _literal(value) -> str:
    return "``" + json.dumps(value, ensure_ascii=False) + "``"


def _allowed(schema: dict, node: dict) -> str:
    node = _resolve(schema, node)
    parts = []
    if "enum" in node:
        parts.append(", ".join(_literal(v) for v in node["enum"]))
    if "const" in node:
        parts.append(_literal(node["const"]))
    for bound, word in (("minimum", "≥"), ("exclusiveMinimum", ">"), ("maximum", "≤"), ("exclusiveMaximum", "<")):
        if bound in node:
            parts.append(f"{word} {node[bound]}")
    if "items" in node and isinstance(node["items"], dict):
        inner = _allowed(schema, node["items"])
        if inner:
            parts.append(f"items {inner}")
    return "; ".join(parts)


def _text(value: str) -> str:
    """A description as one table cell: one line, and no character that starts reStructuredText
    markup by accident (the schema's descriptions are plain text)."""
    text = " ".join(str(value).split())
    for char in ("\\", "*", "`", "|", "_"):
        text = text.replace(char, "\\" + char)
    return text


def _rows(schema: dict, node: dict, path: str, depth: int = 0):
    """``(dotted key, type, default, allowed, description)`` for every key below ``node``: ``<name>``
    stands for an entry of a mapping by name, ``[]`` for an item of a list."""
    node = _resolve(schema, node)
    if depth > MAX_DEPTH:
        return
    properties = dict(node.get("properties", {}))
    for option in node.get("oneOf", []) + node.get("anyOf", []):
        properties.update({k: v for k, v in _resolve(schema, option).get("properties", {}).items() if k not in properties})
    for key, child in properties.items():
        child = _resolve(schema, child)
        name = f"{path}.{key}" if path else key
        default = _literal(child["default"]) if "default" in child else ""
        yield name, _type(schema, child), default, _allowed(schema, child), _text(child.get("description", ""))
        yield from _rows(schema, child, name, depth + 1)
    items = node.get("items")
    if isinstance(items, dict) and _resolve(schema, items).get("properties"):
        yield from _rows(schema, items, f"{path}[]", depth + 1)
    extra = node.get("additionalProperties")
    if isinstance(extra, dict):
        extra = _resolve(schema, extra)
        if extra.get("properties") or extra.get("oneOf"):
            yield from _rows(schema, extra, f"{path}.<name>" if path else "<name>", depth + 1)


def schema_reference_lines(schema: dict) -> list[str]:
    """The reference as reStructuredText lines."""
    lines = []
    for key, node in schema["properties"].items():
        node = _resolve(schema, node)
        lines += [f"``{key}``", "-" * (len(key) + 4), "", _text(node.get("description", "")), ""]
        facts = [f"Type: {_type(schema, node)}."]
        if "default" in node:
            facts.append(f"Default: {_literal(node['default'])}.")
        lines += [" ".join(facts), ""]
        for name, kind, default, allowed, meaning in _rows(schema, node, key):
            facts = [f"*{kind}*"] + ([f"default {default}"] if default else []) + ([f"allowed {allowed}"] if allowed else [])
            lines += [f"``{name}``", "   " + "; ".join(facts), ""]
            if meaning:
                lines += ["   " + meaning, ""]
    return lines


class SchemaReference(SphinxDirective):
    """``.. schema-reference::``: every key of the configuration schema, by top-level section."""

    def run(self):
        self.env.note_dependency(str(SCHEMA))
        schema = yaml.safe_load(SCHEMA.read_text())
        container = nodes.section()
        container.document = self.state.document
        nested_parse_with_titles(self.state, StringList(schema_reference_lines(schema), source=str(SCHEMA)),
                                 container)
        return container.children


def setup(app):
    app.add_directive("schema-reference", SchemaReference)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
