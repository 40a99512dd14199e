"""The help of the API's keyword arguments, written from the configuration schema.

A function of the API takes an entry's keys as keyword arguments; their types, defaults and
meanings are the schema's (``schemas/config.schema.yaml``), so :func:`keyword_docs` writes them
into the function's docstring from there, one source for ``help()``, the configuration's
messages and the docs. Units are said where the schema's description says them (a
velocity-data system's times are its data's).
"""

from __future__ import annotations

import textwrap

from ..config.loading import shared_schema

#: How the schema's JSON types read in a docstring.
TYPE_WORDS = {"number": "float", "integer": "int", "string": "str", "boolean": "bool", "object": "dict",
              "array": "list", "null": "None"}
WIDTH = 100


def schema() -> dict:
    """The schema, parsed once per process (read here, never changed)."""
    return shared_schema()


def schema_at(pointer: str) -> dict:
    """The schema's node at a JSON pointer (``"$defs/ld_map"``), ``$ref`` followed."""
    node = schema()
    for part in pointer.split("/"):
        node = node[part]
    return resolved(node)


def resolved(node: dict) -> dict:
    """``node`` with its ``$ref`` (a pointer into the schema's ``$defs``) merged under its own keys."""
    if "$ref" not in node:
        return node
    target = schema()
    for part in node["$ref"].removeprefix("#/").split("/"):
        target = target[part]
    return {**resolved(target), **{key: value for key, value in node.items() if key != "$ref"}}


def type_words(node: dict) -> str:
    """The Python types a schema node accepts, in words (``float or list of float``)."""
    node = resolved(node)
    if "enum" in node:
        return "one of " + ", ".join(repr(value) for value in node["enum"])
    if "oneOf" in node or "anyOf" in node:
        words = dict.fromkeys(type_words(branch) for branch in node.get("oneOf", node.get("anyOf")))
        return " or ".join(word for word in words if word)
    types = node.get("type")
    if types is None:
        return "dict" if "properties" in node else ""
    types = types if isinstance(types, list) else [types]
    words = []
    for name in types:
        word = TYPE_WORDS.get(name, name)
        if name == "array" and isinstance(node.get("items"), dict):
            inner = type_words(node["items"])
            word = f"list of {inner}" if inner else word
        words.append(word)
    return " or ".join(words)


def bounds_words(node: dict) -> str:
    """The bounds a schema node puts on a number (``> 0, <= 10000``), empty if none."""
    parts = [f"{words} {node[keyword]}" for keyword, words in
             (("minimum", ">="), ("exclusiveMinimum", ">"), ("maximum", "<="), ("exclusiveMaximum", "<"))
             if keyword in node]
    return ", ".join(parts)


def one_line(text: str) -> str:
    return " ".join(str(text).split())


def keyword_entry(name: str, node: dict, indent: str) -> list[str]:
    """One numpydoc entry: ``name : type, default D`` and the description (with the bounds and,
    for a block, its keys one level down)."""
    node = resolved(node)
    head = f"{name} : {type_words(node) or 'any'}"
    head += f", default {node['default']!r}" if "default" in node else ", optional"
    body = one_line(node.get("description", ""))
    bounds = bounds_words(node)
    if bounds:
        body += f" ({bounds})"
    lines = [indent + head]
    lines += textwrap.wrap(body, WIDTH, initial_indent=indent + "    ", subsequent_indent=indent + "    ")
    if node.get("properties"):
        lines.append("")  # a list after a paragraph starts after a blank line
    for key, child in node.get("properties", {}).items():
        child = resolved(child)
        words = f"``{key}`` ({type_words(child) or 'any'}"
        words += f", default {child['default']!r})" if "default" in child else ")"
        description = one_line(child.get("description", ""))
        bounds = bounds_words(child)
        text = f"- {words}" + (f": {description}" if description else "") + (f" ({bounds})" if bounds else "")
        lines += textwrap.wrap(text, WIDTH, initial_indent=indent + "    ", subsequent_indent=indent + "      ")
    return lines


def keyword_names(pointer: str, taken: tuple[str, ...] = ()) -> list[str]:
    """The keys of the schema's block at ``pointer`` that a function takes as ``**keywords``:
    all but those ``taken`` (its own parameters, or the objects that stand for a named entry)."""
    return [name for name in schema_at(pointer).get("properties", {}) if name not in taken]


def keyword_docs(pointer: str, taken: tuple[str, ...] = ()) -> str:
    """A numpydoc section ``Other Parameters``: every key of the schema's block at ``pointer`` that
    is not ``taken``, with its type, default, bounds and description."""
    node = schema_at(pointer)
    lines = ["Other Parameters", "----------------"]
    for name in keyword_names(pointer, taken):
        lines += keyword_entry(name, node["properties"][name], "")
    return "\n".join(lines)
