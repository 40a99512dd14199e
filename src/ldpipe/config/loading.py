"""Loading and validating the configuration against ``config.schema.yaml``.

Validation fills in the schema's defaults and turns every schema violation into
a :class:`~ldpipe.errors.ConfigError` that names the offending key and says
what is allowed there.
"""

from __future__ import annotations

import copy
import datetime
import difflib
import functools
import math
import re
from importlib import resources
from pathlib import Path

import jsonschema
import yaml

from ..errors import ConfigError
from ..systems import SYSTEM_KINDS, system_coordinates, system_kind
from ..systems.kinds import kinds_text
from ..systems.kinetic import kinetic_matrix
from .figures import check_figures
from .maps import check_interval, check_ld_maps, drop_flow_defaults, given_map_keys, numeric_calendar_times
from .studies import (
    check_accuracy_cost,
    check_nhim,
    check_nhim_sampling,
    check_normal_form,
    check_orbits,
    check_transport,
    check_transport_masses,
)

SCHEMA_RESOURCE = ("ldpipe.schemas", "config.schema.yaml")


#: PyYAML's safe loader, in C (libyaml) where PyYAML was built with it: the same documents, parsed
#: about ten times faster than by the pure-Python loader (the schema is read by every process
#: that validates a configuration, Snakemake's planning included).
SAFE_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


@functools.lru_cache(maxsize=1)
def shared_schema() -> dict:
    """The configuration schema, parsed once per process and shared by its readers: read it, never
    change it (:func:`load_schema` gives a copy to change)."""
    text = resources.files(SCHEMA_RESOURCE[0]).joinpath(SCHEMA_RESOURCE[1]).read_text()
    return yaml.load(text, Loader=SAFE_LOADER)


def load_schema() -> dict:
    """The configuration schema, a copy of its own that the caller may change."""
    return copy.deepcopy(shared_schema())


@functools.lru_cache(maxsize=1)
def _schema_validator():
    # Stages and Snakemake's input functions validate often. The validator copies defaults into
    # the instance, so the shared schema is never modified.
    return _DefaultingValidator(shared_schema())


def _extend_with_defaults(validator_class):
    """A validator that also writes each property's ``default`` into the instance."""
    validate_properties = validator_class.VALIDATORS["properties"]

    def properties_with_defaults(validator, properties, instance, schema):
        if isinstance(instance, dict):
            for name, subschema in properties.items():
                if "default" in subschema and name not in instance:
                    instance[name] = copy.deepcopy(subschema["default"])
        yield from validate_properties(validator, properties, instance, schema)

    return jsonschema.validators.extend(validator_class, {"properties": properties_with_defaults})


_DefaultingValidator = _extend_with_defaults(jsonschema.Draft202012Validator)


def _key(path) -> str:
    return ".".join(str(part) for part in path) or "(top level)"


def _allowed(schema: dict) -> str:
    """What a schema allows, in words."""
    parts = []
    if "enum" in schema:
        parts.append("one of " + ", ".join(repr(v) for v in schema["enum"]))
    if "type" in schema:
        parts.append(f"type {schema['type']}")
    for keyword, words in (
        ("minimum", ">="),
        ("exclusiveMinimum", ">"),
        ("maximum", "<="),
        ("exclusiveMaximum", "<"),
    ):
        if keyword in schema:
            parts.append(f"{words} {schema[keyword]}")
    if "minItems" in schema and schema.get("minItems") == schema.get("maxItems"):
        parts.append(f"exactly {schema['minItems']} items")
    if "pattern" in schema:
        parts.append(f"matching {schema['pattern']!r}")
    if "description" in schema:
        parts.append(schema["description"].strip())
    return "; ".join(parts)


def _describe(error: jsonschema.ValidationError) -> str:
    if error.validator == "additionalProperties" and isinstance(error.instance, dict):
        allowed = sorted(error.schema.get("properties", {}))
        extra = sorted(set(error.instance) - set(allowed))
        guesses = [match for name in extra for match in difflib.get_close_matches(str(name), allowed, n=1)]
        guess = f" (did you mean {', '.join(map(repr, dict.fromkeys(guesses)))}?)" if guesses else ""
        return f"config key {_key(error.absolute_path)!r}: unknown keys {extra}{guess}; allowed keys are {allowed}"
    if error.validator == "oneOf" and error.absolute_path and "systems" in error.absolute_path:
        return f"config key {_key(error.absolute_path)!r}: a system needs exactly one of {_kinds_requirement()}"
    allowed = _allowed(error.schema)
    return f"config key {_key(error.absolute_path)!r}: {error.message}" + (f" (allowed: {allowed})" if allowed else "")


def _kinds_requirement() -> str:
    """The registered kinds and the keys each needs or refuses besides its own, for a message."""
    needs = {}
    for kind in SYSTEM_KINDS.values():
        for extra in kind.required[1:]:
            needs.setdefault(extra, []).append(kind.noun)
    refuses = {}
    for kind in SYSTEM_KINDS.values():
        for key in kind.excluded:
            refuses.setdefault(key, []).append(kind.noun)
    refused_by = {}  # the keys the same kinds refuse, in one note
    for key, nouns in refuses.items():
        refused_by.setdefault(tuple(nouns), []).append(key)
    notes = [f"{' or '.join(nouns)} also needs '{key}'" for key, nouns in needs.items()]
    notes += [f"{_listed(nouns, 'and')} take{'s' if len(nouns) == 1 else ''} no {_listed([repr(k) for k in keys], 'or')}"
              for nouns, keys in refused_by.items()]
    return kinds_text() + (f" ({'; '.join(notes)})" if notes else "")


def _listed(items, conjunction: str) -> str:
    """``a, b and c``."""
    items = list(items)
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + f" {conjunction} " + items[-1]


def _check_semantics(config: dict) -> None:
    """Rules a JSON schema cannot say: intervals ordered, box keys are coordinates."""
    for name, spec in config["systems"].items():
        coordinates = system_coordinates(spec)
        system_kind(spec).check(spec, f"systems.{name}")
        kinetic_matrix(spec, coordinates, f"systems.{name}")
        equilibria = spec["equilibria"]
        check_interval(equilibria["default_interval"], f"systems.{name}.equilibria.default_interval")
        for coordinate, interval in equilibria["box"].items():
            key = f"systems.{name}.equilibria.box.{coordinate}"
            if coordinate not in coordinates:
                raise ConfigError(f"config key {key!r}: {coordinate!r} is not a coordinate of {name}; expected one of {list(coordinates)}")
            check_interval(interval, key)


# A float as YAML 1.2 reads it. YAML 1.1 (PyYAML, and Snakemake's loader) needs a dot and a signed
# exponent, so it reads 1e-10 and 1e7 as strings; where the schema expects a number they are numbers.
_YAML12_FLOAT = re.compile(r"[-+]?(\.[0-9]+|[0-9]+(\.[0-9]*)?)([eE][-+]?[0-9]+)?")


def _number_strings(errors) -> list:
    """Paths of strings that YAML 1.2 reads as floats, found where the schema wanted a number."""
    paths = []
    for error in errors:
        types = error.validator_value if isinstance(error.validator_value, list) else [error.validator_value]
        if (error.validator == "type" and "number" in types and isinstance(error.instance, str)
                and _YAML12_FLOAT.fullmatch(error.instance.strip())):
            paths.append(tuple(error.absolute_path))
        paths += _number_strings(error.context or [])
    return paths


def _schema_errors(config: dict, validator) -> list:
    """The schema's errors, after turning in place each string such as '1e-10' into the float it
    means where a number is expected (one pass over a valid configuration)."""
    while True:
        errors = list(validator.iter_errors(config))
        paths = set(_number_strings(errors))
        if not paths:
            return errors
        for path in paths:
            parent = config
            for part in path[:-1]:
                parent = parent[part]
            parent[path[-1]] = float(parent[path[-1]])


def non_finite_values(value, path: tuple = ()) -> list[tuple[str, float]]:
    """Each key (a dotted path) of ``value`` that holds a NaN or an infinity, at any depth, with its
    value: JSON schema takes them for numbers, and a computation would then run on them (an energy
    of nan solves no point of a section, an inf reaches the file writer)."""
    if isinstance(value, float) and not math.isfinite(value):
        return [(_key(path), value)]
    if isinstance(value, dict):
        return [found for name, item in value.items() for found in non_finite_values(item, (*path, name))]
    if isinstance(value, (list, tuple)):
        return [found for index, item in enumerate(value) for found in non_finite_values(item, (*path, index))]
    return []


def dates_as_text(value):
    """``value`` with each date YAML read as a timestamp (``t0: 2000-01-02``) in ISO 8601 text, in
    place: the schema takes a date as text, and a date where it expects something else is named
    as the text that was written."""
    if isinstance(value, dict):
        for name, item in value.items():
            value[name] = dates_as_text(item)
    elif isinstance(value, list):
        value[:] = [dates_as_text(item) for item in value]
    elif isinstance(value, datetime.date):
        return value.isoformat()
    return value


def _raise_schema_errors(errors: list) -> None:
    # The deepest error names the key most precisely: list those first.
    if errors:
        errors = sorted(errors, key=lambda e: (-len(e.absolute_path), _key(e.absolute_path)))
        messages = [_describe(e) for e in errors]
        raise ConfigError("invalid configuration:\n  " + "\n  ".join(dict.fromkeys(messages)))


def check_finite(config: dict) -> None:
    """A ConfigError naming the first key that holds a non-finite number (nan, inf)."""
    for key, value in non_finite_values(config):
        raise ConfigError(f"config key {key!r}: expected a finite number, got {value!r}")


def validate_config(config: dict) -> dict:
    """Validate ``config`` in place against the schema, fill defaults, and return it.

    Numbers written as YAML 1.1 reads them as strings (``1e-10``, ``1e7``) are converted to
    floats where the schema expects a number, so every loader's result validates alike.
    """
    if not isinstance(config, dict):
        raise ConfigError(f"the configuration must be a mapping of keys to values, got {type(config).__name__}")
    validator = _schema_validator()
    given = given_map_keys(config)  # before the schema fills defaults in: a map refuses a tau it was given
    dates_as_text(config)
    errors = _schema_errors(config, validator)
    check_finite(config)  # after _schema_errors, which reads '1e999' as the float it means
    _raise_schema_errors(errors)
    _check_semantics(config)
    if numeric_calendar_times(config):  # dates made numbers, which the schema bounds as any number given
        _raise_schema_errors(_schema_errors(config, validator))
        check_finite(config)
    check_ld_maps(config, given)
    drop_flow_defaults(config)
    check_orbits(config)
    check_nhim_sampling(config)
    check_figures(config)
    check_nhim(config)
    check_accuracy_cost(config)
    check_transport(config)
    check_transport_masses(config)
    check_normal_form(config)
    return config


def load_config(path: str | Path) -> dict:
    """Read a YAML configuration file and validate it."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as error:
        raise ConfigError(f"{path}: cannot read the configuration ({error.strerror})") from None
    try:
        config = yaml.safe_load(text)
    except yaml.YAMLError as error:
        raise ConfigError(f"{path}: not valid YAML: {error}") from None
    try:
        return validate_config(config if config is not None else {})
    except ConfigError as error:
        raise ConfigError(f"{path}: {error}") from None
