"""Bad input, made on purpose: configurations one key away from a valid one, and velocity-data
files corrupted one way at a time, each with what a correct refusal must say.

A configuration case is ``(path, mutation)``: the key at ``path`` (a tuple of keys and list
indices into the configuration, its defaults filled) given a wrong value, removed, or a key the
schema knows added where the configuration left it out. :func:`config_sites` walks the
configuration and the schema beside it, so every key a configuration holds or may hold is
reached. A file case is a name of :data:`CORRUPTIONS`. Both are plain values, so the hypothesis
tests draw them (``sampled_from``) and ``benchmarks/fuzz_inputs.py`` runs thousands from a seed;
the checks (:func:`check_config_case`, :func:`check_refusal`) are shared too.

Every outcome is one of two: the input is valid, or the error is a :class:`~ldpipe.errors.LdpipeError`
whose message names what was wrong (the key, the argument, the file and its variable).
Anything else is a :class:`FuzzFailure`, carrying the case so it can be replayed.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from pathlib import Path

import jsonschema
import numpy as np
import xarray as xr

from ..errors import ConfigError, LdpipeError
from ..io.atomic import atomic_path
from ..io.datafile import declares_missing_values


class FuzzFailure(AssertionError):
    """An example that ended neither valid nor refused with a message naming its input."""


#: Key added where a mapping may hold no such key.
UNKNOWN_KEY = "fuzz_unknown_key"

#: Wrong values, by name: each replaces the value at a key (``missing`` removes the key,
#: ``unknown_key`` adds :data:`UNKNOWN_KEY` to a mapping, ``reversed`` and ``empty_range`` apply to
#: a pair). Functions of the value they replace.
MUTATIONS = {
    "string": lambda value: "not-a-value",
    "empty_string": lambda value: "",
    "null": lambda value: None,
    "bool": lambda value: True,
    "list": lambda value: [1, "two"],
    "empty_list": lambda value: [],
    "mapping": lambda value: {"a": 1},
    "nan": lambda value: math.nan,
    "inf": lambda value: math.inf,
    "minus_inf": lambda value: -math.inf,
    "zero": lambda value: 0,
    "negative": lambda value: -abs(value) - 1 if _is_number(value) else -1,
    "huge": lambda value: 1e300,
    "huge_int": lambda value: 10**15,
    "reversed": lambda value: list(reversed(value)) if isinstance(value, list) else value,
    "empty_range": lambda value: [value[0], value[0]] if isinstance(value, list) and value else value,
    "missing": None,
    "unknown_key": None,
}


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def plain(config):
    """A copy of ``config`` that shares no object (a YAML alias makes two keys one object, and a
    mutation of one would change both)."""
    return json.loads(json.dumps(config))


def _schema_at(schema: dict, root: dict, part) -> dict | None:
    """The subschema for ``part`` (a key or an index) of an instance of ``schema``."""
    schema = _resolve(schema, root)
    if isinstance(part, int):
        items = schema.get("items")
        return _resolve(items, root) if isinstance(items, dict) else None
    for branch in [schema, *schema.get("oneOf", []), *schema.get("anyOf", []), *schema.get("allOf", [])]:
        branch = _resolve(branch, root)
        if part in branch.get("properties", {}):
            return _resolve(branch["properties"][part], root)
    extra = schema.get("additionalProperties")
    return _resolve(extra, root) if isinstance(extra, dict) else None


def _resolve(schema: dict, root: dict) -> dict:
    while isinstance(schema, dict) and "$ref" in schema:
        target = root
        for part in schema["$ref"].lstrip("#/").split("/"):
            target = target[part]
        schema = {**target, **{k: v for k, v in schema.items() if k != "$ref"}}
    return schema


def _chosen(schema: dict | None, root: dict, value) -> dict | None:
    """``schema`` with its ``if``/``then``/``else`` resolved for the instance ``value`` (a
    manifold set names an orbit family or a map: each form has its own keys)."""
    if not schema:
        return schema
    schema = _resolve(schema, root)
    if "if" not in schema:
        return schema
    branch = "then" if jsonschema.Draft202012Validator(schema["if"]).is_valid(value) else "else"
    return _resolve(schema.get(branch, {}), root)


def _properties(schema: dict, root: dict) -> set[str]:
    schema = _resolve(schema, root)
    names = set(schema.get("properties", {}))
    for branch in [*schema.get("oneOf", []), *schema.get("anyOf", []), *schema.get("allOf", [])]:
        names |= set(_resolve(branch, root).get("properties", {}))
    return names


def config_sites(config: dict, schema: dict) -> list[tuple]:
    """Every key of ``config`` (validated: its defaults filled), as a path, and every key the
    configuration's ``schema`` (``ldpipe.config.loading.load_schema()``) allows where ``config``
    has none (a path ending in a key absent from its mapping)."""
    root = schema
    sites: list[tuple] = []

    def walk(value, path: tuple, schema: dict | None) -> None:
        schema = _chosen(schema, root, value)
        if path:
            sites.append(path)
        if isinstance(value, dict):
            for key, item in value.items():
                walk(item, (*path, key), _schema_at(schema, root, key) if schema else None)
            if schema:
                sites.extend((*path, key) for key in sorted(_properties(schema, root) - set(value)))
        elif isinstance(value, list):
            for index, item in enumerate(value):
                walk(item, (*path, index), _schema_at(schema, root, index) if schema else None)

    walk(config, (), root)
    return sites


def mutate(config: dict, path: tuple, mutation: str) -> dict:
    """A copy of ``config`` with ``mutation`` applied at ``path`` (a key absent from its mapping is
    added, with the mutation's value of None)."""
    config = plain(config)
    parent = config
    for part in path[:-1]:
        parent = parent[part]
    last = path[-1]
    present = (last in parent) if isinstance(parent, dict) else (0 <= last < len(parent))
    if mutation == "missing":
        if present:
            del parent[last]
        return config
    if mutation == "unknown_key":
        value = parent[last] if present else None
        if isinstance(value, dict):
            value[UNKNOWN_KEY] = 1
        else:
            parent[last] = {UNKNOWN_KEY: 1}
        return config
    parent[last] = MUTATIONS[mutation](parent[last] if present else None)
    return config


def dotted(path: tuple) -> str:
    return ".".join(str(part) for part in path)


def names_the_key(message: str, path: tuple) -> bool:
    """Whether ``message`` names the key at ``path``: the key itself or a mapping holding it, down
    to the entry (``ld_maps.NAME``), or that entry's name quoted (an error in another entry that
    refers to it, e.g. a map of a system whose coordinates changed)."""
    if len(path) == 1:
        return repr(str(path[0])) in message or f"'{path[0]}." in message or str(path[0]) in message
    prefixes = [dotted(path[:end]) for end in range(len(path), 1, -1)]
    if any(prefix in message for prefix in prefixes):
        return True
    return f"'{path[1]}'" in message or f"{path[1]}." in message


def check_message(error: BaseException, what: str) -> str:
    """The message of ``error``, checked to be a message for a user (not empty, no traceback)."""
    message = str(error)
    if not message.strip() or "Traceback" in message:
        raise FuzzFailure(f"{what}: an empty or traceback message: {message!r}")
    return message


def check_config_case(base: dict, path: tuple, mutation: str, validate_config: Callable[[dict], dict]) -> str:
    """``'valid'`` or ``'refused'`` for the configuration ``base`` with ``mutation`` at ``path``;
    a :class:`FuzzFailure` if ``validate_config`` (``ldpipe.config.validate_config``, given by the
    caller: this module sits below the configuration's layer) raised anything but a ConfigError
    naming the key."""
    what = f"config {dotted(path)} <- {mutation}"
    config = mutate(base, path, mutation)
    try:
        validate_config(config)
    except ConfigError as error:
        message = check_message(error, what)
        if not names_the_key(message, path):
            raise FuzzFailure(f"{what}: the message does not name the key: {message}") from None
        return "refused"
    except Exception as error:  # the fault a fuzzer looks for
        raise FuzzFailure(f"{what}: {type(error).__name__}: {error}") from error
    return "valid"


def merged(base: dict, override: dict) -> dict:
    """``override`` merged into ``base`` key by key, as Snakemake merges a --configfile."""
    result = plain(base)
    for key, value in override.items():
        if isinstance(value, dict) and isinstance(result.get(key), dict):
            result[key] = merged(result[key], value)
        else:
            result[key] = plain(value)
    return result


# Velocity-data files ----------------------------------------------------------------------------

#: The grid of the files written here: a double gyre, small (a file is a few kB).
GRID = {"x": np.linspace(0.0, 2.0, 9), "y": np.linspace(0.0, 1.0, 6), "time": np.linspace(0.0, 10.0, 6)}


def gyre_dataset() -> xr.Dataset:
    """The double gyre (A = 0.1, eps = 0.25, omega = 2 pi / 10) on :data:`GRID`, as CF netCDF holds it."""
    T, Y, X = np.meshgrid(GRID["time"], GRID["y"], GRID["x"], indexing="ij")
    a, eps, omega = 0.1, 0.25, 2 * np.pi / 10
    f = eps * np.sin(omega * T) * X**2 + (1 - 2 * eps * np.sin(omega * T)) * X
    dfdx = 2 * eps * np.sin(omega * T) * X + 1 - 2 * eps * np.sin(omega * T)
    u = -np.pi * a * np.sin(np.pi * f) * np.cos(np.pi * Y)
    v = np.pi * a * np.cos(np.pi * f) * np.sin(np.pi * Y) * dfdx
    dims = ("time", "y", "x")
    return xr.Dataset({"u": (dims, u, {"units": "m/s"}), "v": (dims, v, {"units": "m/s"})},
                      coords={"x": ("x", GRID["x"], {"units": "m"}), "y": ("y", GRID["y"], {"units": "m"}),
                              "time": ("time", GRID["time"], {"units": "s"})})


def _with_coordinate(dataset: xr.Dataset, name: str, values) -> xr.Dataset:
    return dataset.assign_coords({name: (name, np.asarray(values), dataset[name].attrs)})


def _drop_attr(variable: str, attribute: str):
    def corrupt(dataset):
        dataset[variable].attrs.pop(attribute, None)
        return dataset
    return corrupt


def _set_attr(variable: str, attribute: str, value):
    def corrupt(dataset):
        dataset[variable].attrs[attribute] = value
        return dataset
    return corrupt


def _nan_coordinate(name: str):
    def corrupt(dataset):
        values = dataset[name].values.astype(float).copy()
        values[len(values) // 2] = np.nan
        return _with_coordinate(dataset, name, values)
    return corrupt


def _decreasing(name: str):
    """The axis reversed with the data along it: the same field, its coordinate decreasing."""
    def corrupt(dataset):
        return dataset.isel({name: slice(None, None, -1)})
    return corrupt


def _duplicated_time(dataset):
    values = dataset["time"].values.copy()
    values[2] = values[1]
    return _with_coordinate(dataset, "time", values)


def _transposed(dataset):
    dataset["u"] = dataset["u"].transpose("time", "x", "y")
    return dataset


def _no_time_dimension(dataset):
    dataset["u"] = dataset["u"].isel(time=0, drop=True)
    return dataset


def _two_points(dataset):
    return dataset.isel(y=slice(0, 2))


def _constant_axis(dataset):
    return _with_coordinate(dataset, "x", np.zeros(dataset.sizes["x"]))


def _string_coordinate(dataset):
    return _with_coordinate(dataset, "x", np.array([f"c{i}" for i in range(dataset.sizes["x"])]))


def _integer_velocity(dataset):
    dataset["u"] = dataset["u"].round().astype("int32")
    return dataset


def _string_velocity(dataset):
    dataset["u"] = dataset["u"].astype(str)
    return dataset


def _infinite_velocity(dataset):
    dataset["u"][dict(time=1, y=2, x=3)] = np.inf
    return dataset


def _faster_than_light(dataset):
    dataset["u"][dict(time=2, y=2, x=4)] = 1.2e17  # as a few flipped bytes made it
    return dataset


def _all_nan_velocity(dataset):
    dataset["u"][:] = np.nan
    dataset["v"][:] = np.nan
    return dataset


def _drop(variable: str):
    def corrupt(dataset):
        return dataset.drop_vars(variable)
    return corrupt


#: Corruptions of a valid file's Dataset, by name (each a function of the Dataset, returning it).
#: The byte-level ones (:data:`BYTE_CORRUPTIONS`) act on the written file.
CORRUPTIONS = {
    "none": lambda dataset: dataset,
    "u_without_units": _drop_attr("u", "units"),
    "v_without_units": _drop_attr("v", "units"),
    "u_units_unknown": _set_attr("u", "units", "furlongs/fortnight"),
    "u_units_a_number": _set_attr("u", "units", 5.0),
    "u_units_empty": _set_attr("u", "units", " "),
    "v_units_differ": _set_attr("v", "units", "km/day"),
    "time_units_a_number": _set_attr("time", "units", 3),
    "time_units_unknown": _set_attr("time", "units", "fortnights since 1900-01-01"),
    "x_units_unknown": _set_attr("x", "units", "parsecs"),
    "x_units_a_number": _set_attr("x", "units", 2),
    "nan_x": _nan_coordinate("x"),
    "nan_y": _nan_coordinate("y"),
    "nan_time": _nan_coordinate("time"),
    "decreasing_x": _decreasing("x"),
    "decreasing_y": _decreasing("y"),
    "decreasing_time": _decreasing("time"),
    "duplicated_time": _duplicated_time,
    "constant_x": _constant_axis,
    "string_x": _string_coordinate,
    "two_y_points": _two_points,
    "u_transposed": _transposed,
    "u_without_time": _no_time_dimension,
    "u_integer": _integer_velocity,
    "u_strings": _string_velocity,
    "u_infinite": _infinite_velocity,
    "u_faster_than_light": _faster_than_light,
    "all_land": _all_nan_velocity,
    "v_missing": _drop("v"),
    "u_missing": _drop("u"),
    "time_missing": _drop("time"),
}

#: Damage to the bytes of a written file, by name: a function of the file's bytes and a fraction
#: in [0, 1) (where to cut).
BYTE_CORRUPTIONS = {
    "truncated": lambda data, fraction: data[: int(len(data) * fraction)],
    "empty_file": lambda data, fraction: b"",
    "garbage": lambda data, fraction: bytes(range(256)) * 8,
    "bytes_flipped": lambda data, fraction: _flipped(data, fraction),
}

FILE_CASES = (*CORRUPTIONS, *BYTE_CORRUPTIONS)


def _flipped(data: bytes, fraction: float) -> bytes:
    position = int(len(data) * fraction)
    block = bytes(b ^ 0xFF for b in data[position:position + 64])
    return data[:position] + block + data[position + 64:]


def write_velocity_case(directory: str | Path, corruption: str, fraction: float = 0.5) -> tuple[Path, dict]:
    """The double gyre's file with ``corruption`` (a name of :data:`FILE_CASES`), written under
    ``directory``, and the ``velocity_data`` entry that reads it."""
    path = Path(directory) / f"gyre_{corruption}.nc"
    dataset = gyre_dataset()
    if corruption in CORRUPTIONS:
        dataset = CORRUPTIONS[corruption](dataset)
    with atomic_path(path, fsync=False) as temporary:
        dataset.to_netcdf(temporary)
        if corruption in BYTE_CORRUPTIONS:
            temporary.write_bytes(BYTE_CORRUPTIONS[corruption](temporary.read_bytes(), fraction))
    return path, {"path": str(path), "u": "u", "v": "v", "x": "x", "y": "y", "time": "time"}


#: The variable (besides the file) a refusal of each corruption must name.
NAMED_VARIABLE = {
    "u_without_units": "u", "v_without_units": "v", "u_units_unknown": "u", "u_units_a_number": "u",
    "u_units_empty": "u", "v_units_differ": "v", "time_units_a_number": "time", "time_units_unknown": "time",
    "x_units_unknown": "x", "x_units_a_number": "x", "nan_x": "x", "nan_y": "y", "nan_time": "time",
    "decreasing_x": "x", "decreasing_y": "y", "decreasing_time": "time", "duplicated_time": "time",
    "constant_x": "x", "string_x": "x", "two_y_points": "y", "u_transposed": "u", "u_without_time": "u",
    "u_integer": "u", "u_strings": "u", "u_infinite": "u", "u_faster_than_light": "u", "all_land": "u",
    "v_missing": "v", "u_missing": "u", "time_missing": "time",
}


def check_refusal(error: BaseException, what: str, *names: str) -> str:
    """``'refused'`` if ``error`` is an LdpipeError whose message is one line naming each of
    ``names`` (quoted or as a path); else a :class:`FuzzFailure`."""
    if not isinstance(error, LdpipeError):
        raise FuzzFailure(f"{what}: {type(error).__name__}: {error}") from error
    message = check_message(error, what)
    missing = [name for name in names if name not in message]
    if missing:
        raise FuzzFailure(f"{what}: the message does not name {missing}: {message}")
    return "refused"


def file_case_names(path: Path, corruption: str) -> tuple[str, ...]:
    """What a refusal of a corrupted file must name: the file, and the variable if one is at fault."""
    variable = NAMED_VARIABLE.get(corruption)
    return (path.name,) + ((f"'{variable}'",) if variable else ())


def _explained(dataset: xr.Dataset, name: str) -> np.ndarray | None:
    """Where a map's flags say variable ``name`` has no value: not allowed (never integrated), a
    start on land (no LD), an FTLE not defined; None for a Dataset without an ``allowed`` flag."""
    if "allowed" not in dataset:
        return None
    missing = ~dataset.allowed.values.astype(bool)
    if name.startswith("ld_") and "start_on_land" in dataset:
        missing = missing | dataset.start_on_land.values.astype(bool)
    if name.startswith("ftle_") and f"ftle_defined_{name[5:]}" in dataset:
        missing = missing | ~dataset[f"ftle_defined_{name[5:]}"].values.astype(bool)
    return missing


def finite_dataset(dataset: xr.Dataset, what: str) -> None:
    """Every floating variable of ``dataset`` is finite where it has a value: never inf, and NaN
    only in a variable that declares it its missing value, at points a flag says have none (a
    NaN the engine made at an integrated point is a fault)."""
    for name, variable in dataset.data_vars.items():
        if variable.dtype.kind != "f":
            continue
        values = variable.values
        if np.any(np.isinf(values)):
            raise FuzzFailure(f"{what}: variable {name!r} holds inf")
        nan = np.isnan(values)
        if not nan.any():
            continue
        explained = _explained(dataset, name)
        if not declares_missing_values(variable) or explained is None or np.any(nan & ~explained):
            raise FuzzFailure(f"{what}: variable {name!r} holds a non-finite value where it should have one")


__all__ = ["BYTE_CORRUPTIONS", "CORRUPTIONS", "FILE_CASES", "MUTATIONS", "FuzzFailure", "check_config_case",
           "check_message", "check_refusal", "config_sites", "file_case_names", "finite_dataset", "merged",
           "mutate", "names_the_key", "plain", "write_velocity_case"]
