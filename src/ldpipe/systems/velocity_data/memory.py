"""Velocity data given in memory: an ``xarray.Dataset`` (or DataArrays u, v[, w]) in place of a file.

A system's entry must be data (JSON: it is recorded in every file and keys the compiled systems'
cache), so the dataset itself stays in this process, in :data:`DATASETS`, under the hash of
what the system reads of it; the entry's ``memory`` block records that hash with the variables
and their shapes (:func:`memory_entry`), and :func:`memory_dataset` finds the dataset again
when the system is built. A file written from such a system says where its data came from: no
path, the block instead.

The hash is SHA-256 over each variable read (name, dimensions, dtype, units, values) when the
values are in memory; a lazy, dask-backed dataset (``xr.open_dataset(..., chunks=...)``,
``open_mfdataset``, ``open_zarr``) is not read to hash it (only the windows a map needs are
ever read): its hash is dask's token of the same variables (``dask:`` prefix), which names the
files and chunks the values come from, not the values.

A time coordinate decoded to dates (xarray's default) is encoded back as a file would hold it
(CF ``UNIT since DATE``, through xarray's own encoder, the one ``to_netcdf`` uses), so a map
from the Dataset equals the map from the Dataset written to netCDF.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping

import numpy as np
import xarray as xr

from ...errors import ConfigError
from .grid_metrics import FROM_COORDINATES, MODEL_METRICS

#: In-memory datasets of this process by their hash (:func:`memory_entry`).
DATASETS: dict[str, xr.Dataset] = {}
VELOCITIES = ("u", "v", "w")


def is_in_memory(value) -> bool:
    """Whether a ``velocity_data`` argument is data in memory rather than an entry of names."""
    if isinstance(value, (xr.Dataset, xr.DataArray)):
        return True
    if isinstance(value, (tuple, list)):
        return any(isinstance(item, xr.DataArray) for item in value)
    if isinstance(value, Mapping):
        return "dataset" in value or any(isinstance(item, xr.DataArray) for item in value.values())
    return False


def _as_dataset(value, key: str) -> tuple[xr.Dataset, dict]:
    """The Dataset and the entry's other keys from the forms :func:`memory_entry` takes."""
    if isinstance(value, xr.Dataset):
        return value, {}
    if isinstance(value, xr.DataArray):
        raise ConfigError(f"config key '{key}': one DataArray given; expected an xarray.Dataset, or the "
                          "DataArrays u, v (and w) as a tuple or a mapping {'u': ..., 'v': ...}")
    if isinstance(value, (tuple, list)):
        if len(value) not in (2, 3):
            raise ConfigError(f"config key '{key}': expected the DataArrays (u, v) or (u, v, w), "
                              f"got {len(value)} items")
        value = dict(zip(VELOCITIES, value))
    options = {name: item for name, item in value.items() if name != "dataset" and not isinstance(item, xr.DataArray)}
    if "dataset" in value:
        dataset = value["dataset"]
        if not isinstance(dataset, xr.Dataset):
            raise ConfigError(f"config key '{key}.dataset': expected an xarray.Dataset, got {type(dataset).__name__}")
        return dataset, options
    arrays = {}
    for name, item in value.items():
        if name in VELOCITIES:
            if not isinstance(item, xr.DataArray):
                raise ConfigError(f"config key '{key}.{name}': expected an xarray.DataArray (with its dimensions, "
                                  f"coordinates and units), got {type(item).__name__}")
            arrays[name] = item.rename(name)
    if "w" in arrays:
        options["w"] = "w"
    try:
        dataset = xr.merge(list(arrays.values()), join="exact", combine_attrs="override")
    except (ValueError, xr.MergeError) as error:
        shapes = {name: dict(array.sizes) for name, array in arrays.items()}
        raise ConfigError(f"config key '{key}': the DataArrays do not share one grid ({shapes}): "
                          f"{str(error).splitlines()[0]}") from None
    return dataset, options


def _encoded_time(dataset: xr.Dataset, name: str) -> xr.Dataset:
    """``dataset`` with its time coordinate ``name`` as numbers in CF units if it holds dates
    (encoded as ``to_netcdf`` would write it, its own encoding kept)."""
    if name not in dataset.variables or dataset[name].dtype.kind not in "MmO":
        return dataset
    encoded = xr.conventions.encode_cf_variable(dataset[name].variable, name=name)
    return dataset.assign_coords({name: (encoded.dims, np.asarray(encoded.values), encoded.attrs)})


def _digest(dataset: xr.Dataset, names: list[str]) -> str:
    """The hash of the variables ``names``: SHA-256 of their values if in memory, dask's token if lazy."""
    lazy = any(dataset[name].chunks is not None for name in names)
    if lazy:
        from dask.base import tokenize

        return "dask:" + tokenize(*(dataset[name].variable for name in names))
    sha = hashlib.sha256()
    for name in names:
        variable = dataset[name]
        head = {"name": name, "dims": list(variable.dims), "dtype": str(variable.dtype),
                "units": str(variable.attrs.get("units", ""))}
        sha.update(json.dumps(head, sort_keys=True).encode())
        sha.update(np.ascontiguousarray(variable.values).tobytes())
    return "sha256:" + sha.hexdigest()


def grid_variables(entry: dict, dataset: xr.Dataset) -> list[str]:
    """A curvilinear grid's variables besides the velocities and coordinates that the entry names
    (``angle``, ``metrics``) or that are found by name (a C-grid's metrics, :mod:`.grid_metrics`)."""
    names = [entry["angle"]] if isinstance(entry.get("angle"), str) else []
    metrics = entry.get("metrics")
    if isinstance(metrics, dict):
        names += [name for name in metrics.values() if isinstance(name, str)]
    elif metrics != FROM_COORDINATES:
        names += [name for model in MODEL_METRICS.values() for name in model.values() if name in dataset.variables]
    return names


def memory_entry(value, key: str, defaults: Mapping[str, str]) -> dict:
    """The ``velocity_data`` entry of data in memory, its dataset kept in :data:`DATASETS`.

    ``value``: an ``xarray.Dataset``; a mapping ``{"dataset": Dataset, "u": NAME, ...}`` with the
    entry's other keys; the DataArrays ``(u, v)`` or ``(u, v, w)``; or a mapping of them
    (``{"u": DataArray, "v": DataArray, "coordinates": "sphere"}``). The grid's coordinates not
    named are read from u's dimensions (time, [z,] y, x). ``defaults``: the entry's defaults (u,
    v, time). A ConfigError names the key (``key``) and the variable.
    """
    dataset, entry = _as_dataset(value, key)
    entry = dict(entry)
    u = entry.get("u", defaults["u"])
    if u not in dataset.data_vars:
        raise ConfigError(f"config key '{key}.u': variable {u!r} not in the dataset (it has "
                          f"{sorted(map(str, dataset.data_vars))})")
    dims = tuple(map(str, dataset[u].dims))
    three_d = "w" in entry
    expected = 4 if three_d else 3
    if len(dims) != expected:
        shape = "(time, z, y, x)" if three_d else "(time, y, x)"
        raise ConfigError(f"config key '{key}.u': variable {u!r} has dimensions {dims} (shape "
                          f"{tuple(dataset[u].shape)}); expected {expected}, {shape}")
    roles = ("time", "z", "y", "x") if three_d else ("time", "y", "x")
    for role, dim in zip(roles, dims):
        entry.setdefault(role, dim)
    names = [entry.get(role, defaults.get(role, role)) for role in ("u", "v")] + ([entry["w"]] if three_d else [])
    names += [entry[role] for role in roles] + ([entry["mask"]] if entry.get("mask") else [])
    names += grid_variables(entry, dataset)
    for role, name in zip(("u", "v", "w") if three_d else ("u", "v"), names):
        if name not in dataset.variables:
            raise ConfigError(f"config key '{key}.{role}': variable {name!r} not in the dataset (it has "
                              f"{sorted(map(str, dataset.variables))})")
    for role in roles:
        if entry[role] not in dataset.variables:
            raise ConfigError(f"config key '{key}.{role}': the dataset has no coordinate {entry[role]!r} "
                              f"for its dimension (it has {sorted(map(str, dataset.coords))})")
    dataset = _encoded_time(dataset[[name for name in dict.fromkeys(names)]], entry["time"])
    digest = _digest(dataset, list(dict.fromkeys(names)))
    DATASETS[digest] = dataset
    entry["memory"] = {"variables": list(dict.fromkeys(names)),
                       "shape": {str(dim): int(size) for dim, size in dataset[names[0]].sizes.items()},
                       "hash": digest}
    return entry


def memory_dataset(record, key: str) -> xr.Dataset:
    """The in-memory dataset an entry's ``memory`` block names; a ConfigError if this process has
    none by that hash (an entry read from a file, or a dataset given to another process)."""
    digest = record.get("hash") if isinstance(record, Mapping) else None
    if digest not in DATASETS:
        raise ConfigError(f"config key '{key}.memory': no dataset with hash {digest!r} in this process: an in-memory "
                          "dataset lives in the Python session that gave it to ldpipe.system(velocity_data=...); "
                          "give it again there, or write it to a file and give its path")
    return DATASETS[digest]


def datasets_of(system_spec: Mapping) -> dict[str, xr.Dataset]:
    """The in-memory datasets a system's entry reads, by hash (empty for a file or a formula): what
    another process (a Dask worker) needs, given to :func:`register`, to build the system."""
    entry = system_spec.get("velocity_data") if isinstance(system_spec, Mapping) else None
    record = entry.get("memory") if isinstance(entry, Mapping) else None
    if not isinstance(record, Mapping):
        return {}
    return {record["hash"]: memory_dataset(record, "velocity_data")}


def register(datasets: Mapping[str, xr.Dataset]) -> None:
    """Keep ``datasets`` (from :func:`datasets_of` in another process) in this process' :data:`DATASETS`."""
    for digest, dataset in datasets.items():
        DATASETS.setdefault(digest, dataset)
