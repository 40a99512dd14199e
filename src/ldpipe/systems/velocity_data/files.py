"""The files of a ``velocity_data`` entry: one dataset, or many along time read as one.

``path:`` names a file (netCDF, or a zarr store), a glob (``currents/*.nc``: its matches in name
order) or a list of files, in time order. Many files are checked against the first
(:func:`series_times`: the same variables on the same grid, their times increasing from file to
file) and read lazily as one dataset along time (:class:`FileSeries`): a window of times opens
only the files that hold it and reads only its nodes, without dask.
"""

from __future__ import annotations

import glob as globbing
from pathlib import Path

import numpy as np
import xarray as xr

from ...errors import ConfigError

#: What xarray and its backends raise for a file they cannot read (truncated, damaged, not netCDF
#: or zarr at all): netCDF4's OSError "NetCDF: HDF error", xarray's ValueError "did not find a
#: match in any of xarray's currently installed IO backends", a zarr store's missing metadata.
READ_ERRORS = (OSError, ValueError, RuntimeError, KeyError)
GLOB_CHARACTERS = "*?["


def open_dataset(path: str) -> xr.Dataset:
    """The dataset at ``path`` (a zarr store if it ends in .zarr, else netCDF), opened lazily; a
    ConfigError naming the file if it cannot be read."""
    try:
        if path.rstrip("/").endswith(".zarr"):
            return xr.open_zarr(path, decode_times=False)
        return xr.open_dataset(path, decode_times=False)
    except READ_ERRORS as error:
        raise unreadable(path, error) from None


def unreadable(path: str, error: BaseException) -> ConfigError:
    """The error for a velocity-data file that cannot be read (its data read lazily, a damaged
    block fails only when a window of it is read, during an integration)."""
    reason = str(error).splitlines()[0] if str(error).strip() else type(error).__name__
    return ConfigError(f"velocity data {path}: cannot read the file ({reason}); expected a netCDF file or a zarr store")


def data_files(path, key: str) -> list[str]:
    """The files ``path`` names (a file, a glob, or a list of files), in time order; a ConfigError
    naming ``key`` if one is missing or a glob matches nothing."""
    if isinstance(path, (list, tuple)):
        if not path:
            raise ConfigError(f"config key '{key}': expected a file, a glob or a list of files, got an empty list")
        files = [str(item) for item in path]
    elif isinstance(path, (str, Path)) and str(path) and any(c in str(path) for c in GLOB_CHARACTERS):
        files = sorted(globbing.glob(str(path)))
        if not files:
            raise ConfigError(f"config key '{key}': the glob {str(path)!r} matches no file")
    else:
        files = [str(path)] if path else []
    missing = [name for name in files if not Path(name).exists()]
    if not files or missing:
        raise ConfigError(f"config key '{key}': no dataset at {(missing[0] if missing else path)!r}")
    if len(set(files)) < len(files):
        twice = next(name for name in files if files.count(name) > 1)
        raise ConfigError(f"config key '{key}': file {twice} is listed twice; each file of a series holds its own times")
    return files


def velocity_data_files(path) -> list[str]:
    """The files an entry's ``path`` names, for planning (a workflow's inputs): a glob's matches
    (itself if none, which the workflow then reports missing), a list, or the one file; unchecked."""
    if isinstance(path, (list, tuple)):
        return [str(item) for item in path]
    if any(c in str(path) for c in GLOB_CHARACTERS):
        return sorted(globbing.glob(str(path))) or [str(path)]
    return [str(path)]


def path_text(path) -> str:
    """The entry's ``path`` for messages: a file, a glob, or a list's first and last files."""
    if isinstance(path, (list, tuple)):
        return str(path[0]) if len(path) == 1 else f"{path[0]} ... {path[-1]} ({len(path)} files)"
    return str(path)


def _grid_of(dataset: xr.Dataset, name: str, time: str) -> dict[str, np.ndarray]:
    """The non-time coordinates of variable ``name`` as their values, by dimension."""
    return {dim: np.asarray(dataset[dim].values) if dim in dataset.variables else np.arange(dataset.sizes[dim])
            for dim in dataset[name].dims if dim != time}


def grid_lines(variable: xr.DataArray) -> np.ndarray:
    """The values of a grid variable (2-D coordinates, a mask, an angle) that a series compares
    from file to file: a 2-D one's edge rows and columns and its middle row and column, read
    alone, so that opening hundreds of files of a large grid does not read each one's grid whole;
    other shapes whole."""
    if variable.ndim != 2:
        return np.asarray(variable.values).ravel()
    rows, columns = variable.shape
    lines = [variable[k, :] for k in sorted({0, rows // 2, rows - 1})]
    lines += [variable[:, k] for k in sorted({0, columns // 2, columns - 1})]
    return np.concatenate([np.asarray(line.values).ravel() for line in lines])


def series_times(files: list[str], variables: tuple[str, ...], time: str, key: str) -> tuple[np.ndarray, tuple[int, ...]]:
    """The time coordinate of the files read as one, and the index of each file's first time.

    Each file after the first must hold ``variables`` on the first file's dimensions and grid
    (the same coordinate values; a 2-D grid variable compared on :func:`grid_lines`), with the same units, and times after the previous file's
    last; a ConfigError names both files otherwise (different grids, overlapping or
    out-of-order times)."""
    times, starts = [], []
    with open_dataset(files[0]) as first:
        reference = {name: (first[name].dims, _grid_of(first, name, time), first[name].attrs.get("units"))
                     for name in variables if name in first.variables}
        # variables without time (a mask, a curvilinear grid's coordinates) are the grid: the same in every file
        fixed = {name: grid_lines(first[name]) for name in variables
                 if name in first.variables and time not in first[name].dims}
        first_shapes = {name: first[name].shape for name in fixed}
        time_units = first[time].attrs.get("units") if time in first.variables else None
    count = 0
    for index, name in enumerate(files):
        with open_dataset(name) as dataset:
            if time not in dataset.variables:
                raise ConfigError(f"config key '{key}': file {name} has no time coordinate {time!r}")
            values = np.atleast_1d(np.asarray(dataset[time].values))
            if index:
                _check_like_first(dataset, name, files[0], reference, time, time_units, key)
                for variable, grid_values in fixed.items():
                    if (dataset[variable].shape != first_shapes[variable]
                            or not np.array_equal(grid_lines(dataset[variable]), grid_values, equal_nan=True)):
                        raise ConfigError(f"config key '{key}': the grids of {files[0]} and {name} differ (variable "
                                          f"{variable!r}); every file of a series is on one grid")
        if values.dtype.kind in "iuf" and values.size:
            previous = files[index - 1] if index else None
            if previous is not None and not values[0] > times[-1][-1]:
                how = "overlap" if values[-1] >= times[-1][0] else "are out of order"
                raise ConfigError(f"config key '{key}': the times of {previous} (to {times[-1][-1]:.12g}) and {name} "
                                  f"(from {values[0]:.12g}) {how}; list the files in time order, each after the last")
        times.append(values)
        starts.append(count)
        count += values.size
    return np.concatenate(times), tuple(starts)


def _check_like_first(dataset: xr.Dataset, name: str, first: str, reference: dict, time: str, time_units, key: str):
    """A ConfigError unless file ``name`` holds the first file's variables on its grid, in its units."""
    units = dataset[time].attrs.get("units")
    if units != time_units:
        raise ConfigError(f"config key '{key}': the time units of {name} ({units!r}) differ from {first}'s "
                          f"({time_units!r}); every file of a series counts time alike")
    for variable, (dims, grid, variable_units) in reference.items():
        if variable not in dataset.variables:
            raise ConfigError(f"config key '{key}': variable {variable!r} is in {first} but not in {name}")
        if dataset[variable].dims != dims:
            raise ConfigError(f"config key '{key}': variable {variable!r} has dimensions {dataset[variable].dims} in "
                              f"{name} but {dims} in {first}")
        here = _grid_of(dataset, variable, time)
        for dim, values in grid.items():
            if here[dim].shape != values.shape or not np.array_equal(here[dim], values):
                raise ConfigError(f"config key '{key}': the grids of {first} and {name} differ (coordinate {dim!r} "
                                  f"of variable {variable!r}); every file of a series is on one grid")
        if dataset[variable].attrs.get("units") != variable_units:
            raise ConfigError(f"config key '{key}': variable {variable!r} has units "
                              f"{dataset[variable].attrs.get('units')!r} in {name} but {variable_units!r} in {first}")


class FileSeries:
    """Files along time read as one dataset (the context of :meth:`.source.DataSource.open`).

    ``read(name, indexers)`` is ``dataset[name].isel(indexers).values`` of the files joined on
    ``time``: a time slice opens only the files that hold it. A read that fails is a
    ConfigError naming the file."""

    def __init__(self, files: tuple[str, ...], starts: tuple[int, ...], time: str, dataset: xr.Dataset | None = None):
        # a dataset given (in memory) is the one "file", named by ``files[0]``, and not closed here
        self.files, self.starts, self.time = files, starts, time
        self._open: dict[int, xr.Dataset] = {}
        self._given = dataset

    def __enter__(self) -> FileSeries:
        return self

    def __exit__(self, *exc) -> None:
        for dataset in self._open.values():
            dataset.close()
        self._open.clear()

    def dataset(self, index: int) -> xr.Dataset:
        if self._given is not None:
            return self._given
        if index not in self._open:
            self._open[index] = open_dataset(self.files[index])
        return self._open[index]

    def _read(self, index: int, name: str, indexers: dict) -> np.ndarray:
        try:
            selected = self.dataset(index)[name].isel(indexers)
            if selected.chunks is not None:  # dask-backed (given in memory): read on this thread, even in a
                selected = selected.compute(scheduler="synchronous")  # Dask task, not by its cluster
            return np.asarray(selected.values)
        except READ_ERRORS as error:
            raise unreadable(self.files[index], error) from None

    def read(self, name: str, indexers: dict) -> np.ndarray:
        """The values of variable ``name`` at ``indexers`` (slices by dimension)."""
        dims = self.dataset(0)[name].dims
        if self.time not in dims or len(self.files) == 1:
            return self._read(0, name, {d: s for d, s in indexers.items() if d in dims})
        wanted = indexers.get(self.time, slice(None))
        ends = self.starts[1:] + (self.starts[-1] + self.dataset(len(self.files) - 1).sizes[self.time],)
        start, stop, _ = wanted.indices(ends[-1])
        parts = []
        for index, (first, end) in enumerate(zip(self.starts, ends)):
            if first < stop and end > start:
                local = {**{d: s for d, s in indexers.items() if d in dims},
                         self.time: slice(max(start, first) - first, min(stop, end) - first)}
                parts.append(self._read(index, name, local))
        return np.concatenate(parts, axis=dims.index(self.time))
