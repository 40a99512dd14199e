"""Comparing a stage file the Python API returns with the one the pipeline writes for the same entry."""

from __future__ import annotations

import json

import numpy as np
import xarray as xr


def wall_times(dataset: xr.Dataset) -> list[str]:
    """The variables that time parts of a run: wall-clock seconds, measured, never the same twice."""
    return [name for name in dataset.data_vars if name.endswith(("_seconds", "wall_time"))]


def wall_time_attributes(dataset: xr.Dataset) -> list[str]:
    """The global attributes that time a run (the normal form's ``normal_form_seconds``), as measured."""
    return [name for name in dataset.attrs if name.endswith(("_seconds", "wall_time"))]


def assert_same_file(result: xr.Dataset, stored: xr.Dataset, inputs: tuple[str, ...] = ()) -> None:
    """Data, coordinates and attributes (of the file and every variable) equal, bit for bit, and
    the same dtypes; but for ``history`` (when and how the file was written), the values of wall
    times (variables: their names, shapes and attributes compared; global attributes: their names
    and types) and the recorded parameters named in ``inputs`` (the names of input files: a path
    in the pipeline, a Dataset's title in the API, which the caller compares)."""
    result, stored = result.copy(deep=True), stored.copy(deep=True)
    assert wall_times(result) == wall_times(stored)
    assert sorted(wall_time_attributes(result)) == sorted(wall_time_attributes(stored))
    for dataset in (result, stored):
        dataset.attrs.pop("history")
        for name in wall_times(dataset):
            assert dataset[name].attrs["units"] == "s" and np.all(dataset[name].values >= 0), name
            dataset[name].values[...] = 0.0
        for name in wall_time_attributes(dataset):
            assert isinstance(dataset.attrs[name], float) and dataset.attrs[name] >= 0, name
            dataset.attrs[name] = 0.0
        parameters = json.loads(dataset.attrs["parameters"])
        for key in inputs:
            parameters.pop(key)
        dataset.attrs["parameters"] = json.dumps(parameters, sort_keys=True)
    xr.testing.assert_identical(result, stored)
    for name in stored.variables:
        assert result[name].dtype == stored[name].dtype, name
