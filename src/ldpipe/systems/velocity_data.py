"""Systems given by gridded velocity data: ocean or atmosphere currents from a netCDF file.

A ``systems:`` entry ``{"velocity_data": {"path": "currents.nc", "u": "u", "v": "v", "x": "x",
"y": "y", "time": "time", "coordinates": "plane"}}`` names a CF dataset and its variables: the
velocity components ``u``, ``v`` on (time, y, x), the coordinates on regular grids (uniform,
increasing). ``coordinates: sphere`` reads x, y as longitude and latitude in degrees and u, v
as eastward and northward velocities, with the Earth's radius ``earth_radius`` (metres).

The state is (x, y); the integration time is the data's time coordinate in its own units; u, v
are converted from their units (``m/s``, ``km/day``, ...) to coordinate units per time unit
(on the sphere, to degrees per time unit). The velocity between grid nodes is the cubic
convolution of ``kernels/gridded_velocity.py`` (cubic in space and time), compiled into the
flow engine like a formula's right-hand side; its data reach the compiled code through
:mod:`ldpipe.systems.data_pointer`, so one compiled engine serves every dataset.

Only the window an engine call needs is read (xarray opens the file lazily): the times covering
[t0, t0 +- tau] with the stencil's neighbours, over the spatial ``window`` if given (else the
whole grid). Land (missing values) and the grid's edge are boundaries: a trajectory stops on
reaching a cell with a land node, or the edge, and :meth:`VelocityDataSystem.stop_flags` says
which; a window that leaves the data's times is refused, naming both ranges.
"""

from __future__ import annotations

import math
import re
from contextlib import contextmanager
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Callable, ClassVar

import numpy as np
import xarray as xr
from scipy import ndimage

from ..errors import ConfigError
from ..jitcache import njit_functions
from . import data_pointer, kernels

#: Defaults of a ``velocity_data`` entry.
DEFAULTS = {"u": "u", "v": "v", "time": "time", "coordinates": "plane", "earth_radius": 6371000.0}
PLANE_AXES = ("x", "y")
SPHERE_AXES = ("lon", "lat")
HEADER = 16  # the kernel's DATA_HEADER
LENGTHS = {"m": 1.0, "meter": 1.0, "metre": 1.0, "meters": 1.0, "metres": 1.0, "km": 1000.0, "cm": 0.01}
TIMES = {"s": 1.0, "sec": 1.0, "second": 1.0, "seconds": 1.0, "min": 60.0, "minute": 60.0, "minutes": 60.0,
         "h": 3600.0, "hr": 3600.0, "hour": 3600.0, "hours": 3600.0, "d": 86400.0, "day": 86400.0, "days": 86400.0}


def kernel_source() -> str:
    """The data kernel's text, with the pointer module's digest (its code is inlined into the kernel)."""
    text = resources.files(kernels).joinpath("gridded_velocity.py").read_text()
    return f"# data_pointer {data_pointer.SOURCE_DIGEST}\n" + text


def parse_velocity_units(units: str, key: str) -> tuple[float, float]:
    """(metres per length unit, seconds per time unit) of a velocity's ``units`` (``m/s``, ``m s-1``, ``km/day``)."""
    text = units.strip().replace("**", "^")
    match = re.fullmatch(r"(\w+)\s*(?:/\s*(\w+)|\s+(\w+)\s*\^?-1)", text)
    if not match or match.group(1) not in LENGTHS or (match.group(2) or match.group(3)) not in TIMES:
        raise ConfigError(f"config key '{key}': velocity units {units!r} not understood; expected a length per time, "
                          f"e.g. 'm/s', 'm s-1' or 'km/day' (lengths {sorted(LENGTHS)}, times {sorted(TIMES)})")
    return LENGTHS[match.group(1)], TIMES[match.group(2) or match.group(3)]


def time_unit_seconds(units: str | None) -> float | None:
    """Seconds per unit of a time coordinate (``days since ...``, ``hours``, ``s``), None if not given."""
    if not units:
        return None
    word = units.strip().split()[0]
    return TIMES.get(word)


def regular_axis(values: np.ndarray, name: str, key: str) -> tuple[float, float]:
    """(first value, spacing) of a coordinate that must be increasing and uniform (a regular grid)."""
    values = np.asarray(values, dtype=float)
    if values.ndim != 1 or len(values) < 3:
        raise ConfigError(f"config key '{key}': coordinate {name!r} must be one-dimensional with at least 3 values, "
                          f"got shape {values.shape}")
    steps = np.diff(values)
    if not np.all(steps > 0):
        raise ConfigError(f"config key '{key}': coordinate {name!r} is not monotonic increasing "
                          f"(first decrease at index {int(np.argmax(steps <= 0)) + 1}); the grid must be sorted")
    if np.max(np.abs(steps - steps.mean())) > 1e-6 * abs(steps.mean()):
        raise ConfigError(f"config key '{key}': coordinate {name!r} is not uniformly spaced (spacings from "
                          f"{steps.min():.6g} to {steps.max():.6g}); a regular grid is required")
    return float(values[0]), float(steps.mean())


def extend_keys(array: np.ndarray, axis: int, low_real: np.ndarray | None, high_real: np.ndarray | None) -> np.ndarray:
    """Pad ``array`` by one node on each side of ``axis``: the real neighbour if read, else Keys'
    extrapolation f[-1] = 3 f[0] - 3 f[1] + f[2] (exact for quadratics)."""
    a = np.moveaxis(array, axis, 0)
    low = low_real if low_real is not None else 3 * a[0] - 3 * a[1] + a[2]
    high = high_real if high_real is not None else 3 * a[-1] - 3 * a[-2] + a[-3]
    return np.moveaxis(np.concatenate([low[None], a, high[None]]), 0, axis)


@dataclass(frozen=True)
class DataSource:
    """A dataset's variables and regular grid, checked, nothing read but the coordinates."""

    path: str
    u: str
    v: str
    x: str
    y: str
    time: str
    x_grid: tuple[float, float, int]  # first, spacing, count
    y_grid: tuple[float, float, int]
    t_grid: tuple[float, float, int]
    velocity_scale: float
    sphere: bool
    radius: float
    mask: str | None = None  # a (y, x) variable, 0 on land (besides missing velocities)

    def open(self) -> xr.Dataset:
        if self.path.rstrip("/").endswith(".zarr"):
            return xr.open_zarr(self.path, decode_times=False)
        return xr.open_dataset(self.path, decode_times=False)

    def axis_values(self, which: str) -> np.ndarray:
        first, step, count = getattr(self, f"{which}_grid")
        return first + step * np.arange(count)

    @property
    def time_range(self) -> tuple[float, float]:
        first, step, count = self.t_grid
        return first, first + step * (count - 1)


def open_source(spec: dict, key: str) -> DataSource:
    """Check a ``velocity_data`` entry against its file: variables, dimensions, grids, units."""
    entry = {**DEFAULTS, **spec}
    unknown = set(entry) - set(DEFAULTS) - {"path", "x", "y", "window", "mask"}
    if unknown:
        raise ConfigError(f"config key '{key}': unknown keys {sorted(unknown)}")
    sphere = entry["coordinates"] == "sphere"
    if entry["coordinates"] not in ("plane", "sphere"):
        raise ConfigError(f"config key '{key}.coordinates': expected 'plane' or 'sphere', got {entry['coordinates']!r}")
    axes = SPHERE_AXES if sphere else PLANE_AXES
    entry.setdefault("x", axes[0])
    entry.setdefault("y", axes[1])
    path = entry.get("path")
    if not path or not Path(path).exists():
        raise ConfigError(f"config key '{key}.path': no dataset at {path!r}")
    source = DataSource(path=str(path), u=entry["u"], v=entry["v"], x=entry["x"], y=entry["y"], time=entry["time"],
                        x_grid=(0, 1, 0), y_grid=(0, 1, 0), t_grid=(0, 1, 0), velocity_scale=1.0, sphere=sphere,
                        radius=float(entry["earth_radius"]), mask=entry.get("mask"))
    with source.open() as dataset:
        for role in ("u", "v", "x", "y", "time") + (("mask",) if source.mask else ()):
            name = entry[role]
            if name not in dataset.variables:
                raise ConfigError(f"config key '{key}.{role}': variable {name!r} not in {path} (it has "
                                  f"{sorted(map(str, dataset.variables))})")
        grids = {}
        for role in ("x", "y", "time"):
            grids[role] = (*regular_axis(dataset[entry[role]].values, entry[role], f"{key}.{role}"),
                           dataset[entry[role]].size)
        expected = (entry["time"], entry["y"], entry["x"])
        scales = []
        for role in ("u", "v"):
            variable = dataset[entry[role]]
            if tuple(variable.dims) != expected:
                raise ConfigError(f"config key '{key}.{role}': variable {entry[role]!r} has dimensions "
                                  f"{tuple(variable.dims)}; expected {expected}")
            units = variable.attrs.get("units")
            if not units:
                raise ConfigError(f"config key '{key}.{role}': variable {entry[role]!r} has no 'units' attribute; "
                                  "a velocity needs its units (e.g. 'm/s')")
            scales.append(parse_velocity_units(units, f"{key}.{role}"))
        if scales[0] != scales[1]:
            raise ConfigError(f"config key '{key}.v': u and v have different units")
        if source.mask and tuple(dataset[source.mask].dims) != expected[1:]:
            raise ConfigError(f"config key '{key}.mask': variable {source.mask!r} has dimensions "
                              f"{tuple(dataset[source.mask].dims)}; expected {expected[1:]}")
        metres, seconds = scales[0]
        data_seconds = time_unit_seconds(dataset[entry["time"]].attrs.get("units")) or seconds
        if sphere:
            length = 1.0  # the kernel divides by the radius in metres
        else:
            x_units = dataset[entry["x"]].attrs.get("units")
            if x_units and x_units not in LENGTHS:
                raise ConfigError(f"config key '{key}.x': coordinate units {x_units!r} not a length in {sorted(LENGTHS)}")
            length = LENGTHS[x_units] if x_units else metres
    return DataSource(path=source.path, u=source.u, v=source.v, x=source.x, y=source.y, time=source.time,
                      x_grid=grids["x"], y_grid=grids["y"], t_grid=grids["time"],
                      velocity_scale=metres / length * data_seconds / seconds, sphere=sphere, radius=source.radius,
                      mask=source.mask)


def index_window(grid: tuple[float, float, int], low: float, high: float) -> tuple[int, int]:
    """The node indices [a, b] whose cells cover [low, high], at least 3 nodes, inside the grid."""
    first, step, count = grid
    a = max(0, int(math.floor((low - first) / step + 1e-9)))
    b = min(count - 1, int(math.ceil((high - first) / step - 1e-9)))
    while b - a < 2:
        if b < count - 1:
            b += 1
        else:
            a -= 1
    return a, b


def fill_land(values: np.ndarray, land: np.ndarray) -> np.ndarray:
    """``values`` (time, y, x) with each land node given its nearest water node's value: the
    stencils of water cells by the coast then see the flow continued, not a wall of zeros (a
    trajectory still stops on entering a cell with a land node)."""
    if not land.any():
        return values
    if land.all():
        return np.zeros_like(values)
    nearest = ndimage.distance_transform_edt(land, return_distances=False, return_indices=True)
    return values[:, nearest[0], nearest[1]]


@dataclass(frozen=True)
class DataWindow:
    """The bound buffer of a window (see the kernel's header comment) and its land mask."""

    buffer: np.ndarray
    land: np.ndarray  # (ny, nx) of the window, True on land
    x_grid: tuple[float, float, int]
    y_grid: tuple[float, float, int]


def read_window(source: DataSource, times: tuple[int, int], x: tuple[int, int], y: tuple[int, int]) -> DataWindow:
    """Read nodes ``times``, ``y``, ``x`` (inclusive index ranges) and their real neighbours, padded."""
    (ta, tb), (ya, yb), (xa, xb) = times, y, x
    counts = (source.t_grid[2], source.y_grid[2], source.x_grid[2])
    lows = [max(0, lo - 1) for lo in (ta, ya, xa)]
    highs = [min(n - 1, hi + 1) for hi, n in zip((tb, yb, xb), counts)]
    with source.open() as dataset:
        region = {source.time: slice(lows[0], highs[0] + 1), source.y: slice(lows[1], highs[1] + 1),
                  source.x: slice(lows[2], highs[2] + 1)}
        u = np.asarray(dataset[source.u].isel(region).values, dtype=float)
        v = np.asarray(dataset[source.v].isel(region).values, dtype=float)
        water = (np.asarray(dataset[source.mask].isel({k: region[k] for k in (source.y, source.x)}).values) != 0
                 if source.mask else True)
    land_all = ~(np.isfinite(u) & np.isfinite(v) & water)
    land_nodes = land_all.any(axis=0)
    u, v = fill_land(u, land_nodes), fill_land(v, land_nodes)
    padded = []
    for array in (u, v):
        for axis, (lo, hi, low_read, high_read) in enumerate(zip((ta, ya, xa), (tb, yb, xb), lows, highs)):
            a = np.moveaxis(array, axis, 0)
            start = lo - low_read
            stop = start + hi - lo + 1
            inner = a[start:stop]
            low = a[start - 1] if start > 0 else None
            high = a[stop] if stop < a.shape[0] else None
            array = np.moveaxis(extend_keys(inner, 0, low, high), 0, axis)
        padded.append(array)
    ny, nx = yb - ya + 1, xb - xa + 1
    ys, xs = slice(ya - lows[1], ya - lows[1] + ny), slice(xa - lows[2], xa - lows[2] + nx)
    land = land_nodes[ys, xs]
    cells = np.zeros((ny + 2, nx + 2))  # the kernel's land cells: a cell with a land corner
    cells[:ny - 1, :nx - 1] = land[:-1, :-1] | land[:-1, 1:] | land[1:, :-1] | land[1:, 1:]
    x_grid = (source.x_grid[0] + source.x_grid[1] * xa, source.x_grid[1], nx)
    y_grid = (source.y_grid[0] + source.y_grid[1] * ya, source.y_grid[1], ny)
    t_first = source.t_grid[0] + source.t_grid[1] * ta
    header = np.zeros(HEADER)
    header[:12] = (tb - ta + 1, ny, nx, x_grid[0], x_grid[1], y_grid[0], y_grid[1], t_first, source.t_grid[1],
                   1.0 if source.sphere else 0.0, source.radius, source.velocity_scale)
    velocities = np.stack(padded, axis=-1).transpose(1, 2, 0, 3)  # (y, x, time, u/v): the kernel's layout
    buffer = np.concatenate([header, np.ascontiguousarray(velocities).ravel(), cells.ravel()])
    return DataWindow(np.ascontiguousarray(buffer), land.copy(), x_grid, y_grid)


@dataclass(frozen=True, eq=False)
class VelocityDataSystem:
    """A flow dx/dt = u(x, y, t), dy/dt = v(x, y, t) interpolated from gridded data (module docstring)."""

    name: str
    coordinates: tuple[str, str]
    source: DataSource
    window: dict | None
    kernel_source: str
    rhs: Callable
    spec: dict = field(default_factory=dict)
    parameters: dict = field(default_factory=dict)
    _windows: dict = field(default_factory=dict, repr=False)

    hamiltonian: ClassVar[bool] = False
    time_dependent: ClassVar[bool] = True
    #: Every velocity-data system shares one compiled engine (its data are bound at run time).
    engine_name: ClassVar[str] = "velocity_data"

    @property
    def n_state(self) -> int:
        return 2

    @property
    def phase_coordinates(self) -> tuple[str, ...]:
        return self.coordinates

    @property
    def description(self) -> str:
        kind = "longitude/latitude" if self.source.sphere else "plane"
        return f"velocity data {self.source.u}, {self.source.v} from {self.source.path} ({kind})"

    def kinetic_attributes(self) -> dict[str, str]:
        return {}

    @property
    def coordinate_bound(self) -> float:
        """A bound on |x|, |y| of any trajectory that can move (twice the data's extent, and 720
        degrees on the sphere, where longitudes wrap): the engine raises its escape radius to it."""
        extent = max(abs(v) for grid in (self.source.x_grid, self.source.y_grid)
                     for v in (grid[0], grid[0] + grid[1] * (grid[2] - 1)))
        return max(2.0 * extent, 720.0 if self.source.sphere else 0.0)

    def check_times(self, start: float, end: float, key: str | None = None) -> None:
        """ConfigError unless [min, max] of ``start``, ``end`` lies in the data's time range, naming both."""
        low, high = sorted((start, end))
        first, last = self.source.time_range
        if low < first - 1e-9 * abs(first) or high > last + 1e-9 * abs(last):
            where = f"config key '{key}': " if key else ""
            raise ConfigError(f"{where}the trajectories need times [{low:.12g}, {high:.12g}], outside the time range "
                              f"[{first:.12g}, {last:.12g}] of {self.source.path} (variable {self.source.time!r})")

    def data_window(self, start: float, end: float) -> DataWindow:
        """The window of the data [start, end] needs (read once; the last one is kept)."""
        self.check_times(start, end)
        low, high = sorted((start, end))
        times = index_window(self.source.t_grid, low, high)
        if self.window:
            xs = index_window(self.source.x_grid, *self.window[self.coordinates[0]])
            ys = index_window(self.source.y_grid, *self.window[self.coordinates[1]])
        else:
            xs = (0, self.source.x_grid[2] - 1)
            ys = (0, self.source.y_grid[2] - 1)
        key = (times, xs, ys)
        if key not in self._windows:
            self._windows.clear()
            self._windows[key] = read_window(self.source, times, xs, ys)
        return self._windows[key]

    @contextmanager
    def time_window(self, start: float, end: float):
        """Within the block the compiled kernels read the data over [start, end]."""
        window = self.data_window(start, end)
        with data_pointer.bound_data(window.buffer):
            yield window

    def vector_field(self, state: np.ndarray, t: float = 0.0) -> np.ndarray:
        out = np.empty(2)
        with self.time_window(t, t):
            self.rhs(np.ascontiguousarray(state, dtype=np.float64), float(t), out)
        return out

    def stop_flags(self, end_states: np.ndarray, start: float, end: float) -> dict[str, np.ndarray]:
        """Where trajectories stopped: ``on_land`` (in a cell with a land node) and ``left_data``
        (outside the data's extent or its spatial window), the boundaries the kernel stops them at."""
        window = self.data_window(start, end)
        east = end_states[:, 0] - window.x_grid[0]
        if self.source.sphere:  # longitudes modulo 360, as the kernel takes them
            east = np.mod(east, 360.0)
        fx = east / window.x_grid[1]
        fy = (end_states[:, 1] - window.y_grid[0]) / window.y_grid[1]
        nx, ny = window.x_grid[2], window.y_grid[2]
        outside = ~((fx >= 0.0) & (fx <= nx - 1) & (fy >= 0.0) & (fy <= ny - 1))
        i = np.clip(np.floor(np.nan_to_num(fx)).astype(int), 0, nx - 2)
        j = np.clip(np.floor(np.nan_to_num(fy)).astype(int), 0, ny - 2)
        land = window.land
        in_land_cell = land[j, i] | land[j, i + 1] | land[j + 1, i] | land[j + 1, i + 1]
        return {"on_land": in_land_cell & ~outside, "left_data": outside}


    def stop_lines(self, end_states: np.ndarray, start: float, end: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The grid line each stopped trajectory (``end_states``: where it stopped, on land or past
        the edge) crossed last: (state index 0 or 1, the line's value in the state's own numbers,
        the side it came from: +1 from below, -1 from above). The kernel stops a trajectory
        as it crosses into a land cell or out of the grid, so it rests just past that line."""
        window = self.data_window(start, end)
        grids = (window.x_grid, window.y_grid)
        offsets = [end_states[:, 0] - window.x_grid[0], end_states[:, 1] - window.y_grid[0]]
        if self.source.sphere:
            offsets[0] = np.mod(offsets[0], 360.0)
        units = np.column_stack([offsets[a] / grids[a][1] for a in (0, 1)])  # grid units from the window's first node
        counts = np.array([grids[0][2], grids[1][2]])
        # outside the grid: the edge passed; inside (a land cell): the nearest of the cell's four sides
        below = units < 0.0
        above = units > counts - 1
        lines = np.where(below, 0.0, np.where(above, counts - 1.0, np.round(units)))
        distance = np.where(below | above, np.inf, np.abs(units - lines))
        outside = below | above
        axis = np.where(outside.any(axis=1), np.argmax(outside, axis=1), np.argmin(distance, axis=1))
        rows = np.arange(len(end_states))
        line = lines[rows, axis]
        gap = units[rows, axis] - line  # past the line, in grid units
        sign = np.where(gap >= 0.0, 1, -1)
        steps = np.array([grids[0][1], grids[1][1]])[axis]
        return axis, end_states[rows, axis] - gap * steps, sign


def velocity_data_coordinates(entry: dict) -> tuple[str, str]:
    """The state variables' names of a ``velocity_data`` entry (its x and y coordinates), file unread."""
    axes = SPHERE_AXES if entry.get("coordinates", DEFAULTS["coordinates"]) == "sphere" else PLANE_AXES
    return entry.get("x", axes[0]), entry.get("y", axes[1])


def make_velocity_data_system(name: str, spec: dict, key: str) -> VelocityDataSystem:
    entry = spec["velocity_data"]
    if not isinstance(entry, dict):
        raise ConfigError(f"config key '{key}.velocity_data': expected a mapping (path, u, v, ...), got {entry!r}")
    source = open_source(entry, f"{key}.velocity_data")
    coordinates = (source.x, source.y)
    window = entry.get("window")
    if window is not None:
        if sorted(window) != sorted(coordinates):
            raise ConfigError(f"config key '{key}.velocity_data.window': expected an interval for each of "
                              f"{list(coordinates)}, got {sorted(window)}")
    text = kernel_source()
    (rhs,) = njit_functions(text, ("rhs",), "velocity_data")
    return VelocityDataSystem(name=name, coordinates=coordinates, source=source, window=window, kernel_source=text,
                              rhs=rhs, spec=spec)
