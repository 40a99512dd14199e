"""Systems given by gridded velocity data: ocean or atmosphere currents from a netCDF file.

A ``systems:`` entry ``{"velocity_data": {"path": "currents.nc", "u": "u", "v": "v", "x": "x",
"y": "y", "time": "time", "coordinates": "plane"}}`` names a CF dataset and its variables: the
velocity components ``u``, ``v`` on (time, y, x), the coordinates increasing. A regular grid
(every axis uniform) is this module's; an uneven axis, or 3-D data (``w`` on (time, z, y, x)),
makes the system :mod:`ldpipe.systems.velocity_data_rectilinear`'s. ``coordinates: sphere`` reads x, y as longitude and latitude in degrees and u, v
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

On the sphere a longitude grid all round it (:func:`seam_grid`) has no edge: the window read
is the ring with its first column repeated at its end, padded with the real columns across the
seam (the kernel's stencil then wraps, the kernel unchanged), and a spatial window may cross the
seam. The LD is taken in km and the data's velocity units, by the engine section
``kernels/sphere_ld_metric.py`` (:attr:`VelocityDataSystem.ld_metric_source`).
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

from ..errors import ConfigError
from ..jitcache import njit_functions
from . import kernels

# data_pointer (llvmlite and numba) and scipy.ndimage are imported where a kernel is made, bound
# or a land mask filled: a velocity-data entry is read for its coordinates (planning, figures)
# without either.

#: Defaults of a ``velocity_data`` entry.
DEFAULTS = {"u": "u", "v": "v", "time": "time", "coordinates": "plane", "earth_radius": 6371000.0}
PLANE_AXES = ("x", "y")
SPHERE_AXES = ("lon", "lat")
#: The vertical coordinate's default name of 3-D data (given ``w``), on the plane and on the sphere.
VERTICAL_AXIS = {False: "z", True: "depth"}
HEADER = 16  # the kernel's DATA_HEADER
LENGTHS = {"m": 1.0, "meter": 1.0, "metre": 1.0, "meters": 1.0, "metres": 1.0, "km": 1000.0, "cm": 0.01}
TIMES = {"s": 1.0, "sec": 1.0, "second": 1.0, "seconds": 1.0, "min": 60.0, "minute": 60.0, "minutes": 60.0,
         "h": 3600.0, "hr": 3600.0, "hour": 3600.0, "hours": 3600.0, "d": 86400.0, "day": 86400.0, "days": 86400.0}


def kernel_source() -> str:
    """The data kernel's text, with the pointer module's digest (its code is inlined into the kernel)."""
    from . import data_pointer

    text = resources.files(kernels).joinpath("gridded_velocity.py").read_text()
    return f"# data_pointer {data_pointer.SOURCE_DIGEST}\n" + text


def sphere_ld_metric_source(radius_at: int, scale_at: int) -> str:
    """The engine section that takes a sphere map's LD in km and velocity units
    (``kernels/sphere_ld_metric.py``), for a kernel whose header holds the radius and
    velocity_scale at these indices."""
    text = resources.files(kernels).joinpath("sphere_ld_metric.py").read_text()
    return text.replace("LD_RADIUS_AT", str(radius_at)).replace("LD_SCALE_AT", str(scale_at))


def velocity_units_match(units: str) -> re.Match | None:
    """``units`` read as a length per time (``m/s``, ``m s-1``, ``m s^-1``): groups length, time (2 or 3)."""
    return re.fullmatch(r"(\w+)\s*(?:/\s*(\w+)|\s+(\w+)\s*\^?-1)", units.strip().replace("**", "^"))


def parse_velocity_units(units: str, key: str) -> tuple[float, float]:
    """(metres per length unit, seconds per time unit) of a velocity's ``units`` (``m/s``, ``m s-1``, ``km/day``)."""
    match = velocity_units_match(units)
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


#: Spacings within this fraction of their mean make an axis uniform (a regular grid, served by
#: the uniform kernel); wider spread makes the grid rectilinear (``velocity_data_rectilinear``).
UNIFORM_RTOL = 1e-6


def increasing_axis(values: np.ndarray, name: str, key: str) -> np.ndarray:
    """The values of a coordinate, which must be one-dimensional, increasing, with at least 3 values."""
    values = np.asarray(values, dtype=float)
    if values.ndim != 1 or len(values) < 3:
        raise ConfigError(f"config key '{key}': coordinate {name!r} must be one-dimensional with at least 3 values, "
                          f"got shape {values.shape}")
    steps = np.diff(values)
    if not np.all(steps > 0):
        raise ConfigError(f"config key '{key}': coordinate {name!r} is not monotonic increasing "
                          f"(first decrease at index {int(np.argmax(steps <= 0)) + 1}); the grid must be sorted")
    return values


def is_uniform(values: np.ndarray) -> bool:
    """Whether an increasing axis's spacings all lie within :data:`UNIFORM_RTOL` of their mean."""
    steps = np.diff(values)
    return bool(np.max(np.abs(steps - steps.mean())) <= UNIFORM_RTOL * abs(steps.mean()))


def extend_keys(array: np.ndarray, axis: int, low_real: np.ndarray | None, high_real: np.ndarray | None) -> np.ndarray:
    """Pad ``array`` by one node on each side of ``axis``: the real neighbour if read, else Keys'
    extrapolation f[-1] = 3 f[0] - 3 f[1] + f[2] (exact for quadratics)."""
    a = np.moveaxis(array, axis, 0)
    low = low_real if low_real is not None else 3 * a[0] - 3 * a[1] + a[2]
    high = high_real if high_real is not None else 3 * a[-1] - 3 * a[-2] + a[-3]
    return np.moveaxis(np.concatenate([low[None], a, high[None]]), 0, axis)


def open_dataset(path: str) -> xr.Dataset:
    """The dataset at ``path`` (a zarr store if it ends in .zarr, else netCDF), opened lazily."""
    if path.rstrip("/").endswith(".zarr"):
        return xr.open_zarr(path, decode_times=False)
    return xr.open_dataset(path, decode_times=False)


@dataclass(frozen=True)
class DataSource:
    """A dataset's variables and grid, checked, nothing read but the coordinates.

    A regular 2-D grid is ``x_grid``, ``y_grid``, ``t_grid`` (first, spacing, count) and ``nodes``
    None. A rectilinear grid (an axis not uniform, or 3-D data with ``w`` on (time, z, y, x)) has
    ``nodes``: every axis's values, (x, y, time) or (x, y, z, time); its ``*_grid`` hold the first
    value, the mean spacing and the count.
    """

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
    mask: str | None = None  # a (y, x) variable, 0 on land (besides missing velocities); (z, y, x) in 3-D
    w: str | None = None  # the upward velocity of 3-D data
    z: str | None = None  # its vertical coordinate
    vertical_scale: float = 0.0  # dz/dt per unit of w: the units' ratio, negative when z is positive down
    z_metres: float = 1.0  # metres per unit of z (3-D data)
    velocity_units: str = ""  # as the file writes them (u's units)
    time_units: str = ""  # of the integration's time (the time coordinate's, else the velocity's)
    x_global: bool = False  # longitudes all round the sphere, joined across the seam (:func:`seam_grid`)
    nodes: tuple[tuple[float, ...], ...] | None = None

    def open(self) -> xr.Dataset:
        return open_dataset(self.path)

    def axis_values(self, which: str) -> np.ndarray:
        if self.nodes is not None:
            return np.array(self.nodes[self.axis_names.index(which)])
        first, step, count = getattr(self, f"{which}_grid")
        return first + step * np.arange(count)

    @property
    def axis_names(self) -> tuple[str, ...]:
        """The grid's axes by their roles: x, y, (z,) t."""
        return ("x", "y", "z", "t") if self.w else ("x", "y", "t")

    @property
    def time_range(self) -> tuple[float, float]:
        if self.nodes is not None:
            return self.nodes[-1][0], self.nodes[-1][-1]
        first, step, count = self.t_grid
        return first, first + step * (count - 1)


def vertical_sign(entry: dict, dataset: xr.Dataset, key: str) -> float:
    """+1 if the vertical coordinate z grows upward, -1 if downward (a depth): the entry's
    ``positive``, else the coordinate's CF ``positive`` attribute; w is the upward velocity."""
    positive = entry.get("positive") or dataset[entry["z"]].attrs.get("positive")
    positive = positive.lower() if isinstance(positive, str) else positive  # CF allows "Up", "DOWN"
    if positive not in ("up", "down"):
        raise ConfigError(f"config key '{key}.positive': the vertical coordinate {entry['z']!r} says neither "
                          f"positive: up nor positive: down (got {positive!r}); give positive: up (a height) or "
                          "down (a depth) in the entry or as the coordinate's CF attribute")
    return 1.0 if positive == "up" else -1.0


def length_of(units: str | None, name: str, key: str, default: float) -> float:
    """Metres per unit of a coordinate with ``units`` (``default`` when it has none)."""
    if units and units not in LENGTHS:
        raise ConfigError(f"config key '{key}': coordinate units {units!r} of {name!r} not a length in {sorted(LENGTHS)}")
    return LENGTHS[units] if units else default


def open_source(spec: dict, key: str) -> DataSource:
    """Check a ``velocity_data`` entry against its file: variables, dimensions, grids, units."""
    entry = {**DEFAULTS, **spec}
    unknown = set(entry) - set(DEFAULTS) - {"path", "x", "y", "window", "mask", "w", "z", "positive"}
    if unknown:
        raise ConfigError(f"config key '{key}': unknown keys {sorted(unknown)}")
    sphere = entry["coordinates"] == "sphere"
    if entry["coordinates"] not in ("plane", "sphere"):
        raise ConfigError(f"config key '{key}.coordinates': expected 'plane' or 'sphere', got {entry['coordinates']!r}")
    axes = SPHERE_AXES if sphere else PLANE_AXES
    entry.setdefault("x", axes[0])
    entry.setdefault("y", axes[1])
    three_d = "w" in entry
    if three_d:
        entry.setdefault("z", VERTICAL_AXIS[sphere])
    path = entry.get("path")
    if not path or not Path(path).exists():
        raise ConfigError(f"config key '{key}.path': no dataset at {path!r}")
    velocities = ("u", "v", "w") if three_d else ("u", "v")
    axis_roles = ("x", "y", "z", "time") if three_d else ("x", "y", "time")
    with open_dataset(str(path)) as dataset:
        for role in velocities + axis_roles + (("mask",) if entry.get("mask") else ()):
            name = entry[role]
            if name not in dataset.variables:
                raise ConfigError(f"config key '{key}.{role}': variable {name!r} not in {path} (it has "
                                  f"{sorted(map(str, dataset.variables))})")
        nodes = {role: increasing_axis(dataset[entry[role]].values, entry[role], f"{key}.{role}") for role in axis_roles}
        expected = tuple(entry[role] for role in reversed(axis_roles))  # (time, [z,] y, x)
        scales = []
        for role in velocities:
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
        mask = entry.get("mask")
        if mask and tuple(dataset[mask].dims) != expected[1:]:
            raise ConfigError(f"config key '{key}.mask': variable {mask!r} has dimensions "
                              f"{tuple(dataset[mask].dims)}; expected {expected[1:]}")
        metres, seconds = scales[0]
        time_coordinate_units = dataset[entry["time"]].attrs.get("units")
        data_seconds = time_unit_seconds(time_coordinate_units) or seconds
        velocity_units = str(dataset[entry["u"]].attrs["units"]).strip()
        if time_unit_seconds(time_coordinate_units):
            time_units = time_coordinate_units.strip().split()[0]
        else:
            match = velocity_units_match(velocity_units)
            time_units = match.group(2) or match.group(3)
        if sphere:
            length = 1.0  # the kernel divides by the radius in metres
        else:
            length = length_of(dataset[entry["x"]].attrs.get("units"), entry["x"], f"{key}.x", metres)
        vertical_scale = 0.0
        z_length = 1.0
        if three_d:
            w_metres, w_seconds = scales[2]
            z_length = length_of(dataset[entry["z"]].attrs.get("units"), entry["z"], f"{key}.z", w_metres)
            vertical_scale = vertical_sign(entry, dataset, key) * w_metres / z_length * data_seconds / w_seconds
    grids = {role: (float(values[0]), float(np.diff(values).mean()), len(values)) for role, values in nodes.items()}
    regular = not three_d and all(is_uniform(values) for values in nodes.values())  # the uniform kernel's grid
    x_global = False
    if sphere and regular:  # the seam is joined on the uniform kernel's grids only
        grids["x"], x_global = seam_grid(grids["x"], entry["x"], f"{key}.x")
    return DataSource(path=str(path), u=entry["u"], v=entry["v"], x=entry["x"], y=entry["y"], time=entry["time"],
                      x_grid=grids["x"], y_grid=grids["y"], t_grid=grids["time"],
                      velocity_scale=metres / length * data_seconds / seconds, sphere=sphere,
                      radius=float(entry["earth_radius"]), mask=mask, w=entry.get("w"), z=entry.get("z"),
                      vertical_scale=vertical_scale, z_metres=z_length, velocity_units=velocity_units, time_units=time_units,
                      x_global=x_global,
                      nodes=None if regular else tuple(tuple(float(v) for v in nodes[role]) for role in axis_roles))


#: How far, in grid spacings, a longitude grid's span may be from 360 degrees (one spacing short, or
#: none with the first column repeated) and still be taken as global: float32 coordinates at 1/12
#: degree miss by ~4e-4 spacings.
SEAM_TOLERANCE = 1e-3


#: The escape radius of a global grid's trajectories (degrees): a longitude crossing the seam
#: runs on past 360 (the kernel takes it modulo 360), as many turns as the flow makes.
WINDING_BOUND = 1.0e9


def seam_grid(grid: tuple[float, float, int], name: str, key: str) -> tuple[tuple[float, float, int], bool]:
    """A longitude grid (first, spacing, count) and whether it goes all round the sphere.

    Global: the gap from the last node round to the first (360 - (count - 1) spacing) is one
    spacing, within :data:`SEAM_TOLERANCE` spacings; the spacing is then taken as 360 / count, so
    the seam's cell is as wide as every other. A last column that repeats the first (gap 0) is
    global too, without that column (never read). Refused (ConfigError naming the coordinate):
    more than 360 degrees, and a gap shorter than a spacing (a spacing that does not divide 360:
    neither an edge nor a cell). A gap longer than a spacing is a regional grid's edge.
    """
    first, step, count = grid
    gap = 360.0 - step * (count - 1)
    slack = SEAM_TOLERANCE * step
    if abs(gap - step) <= slack:
        return (first, 360.0 / count, count), True
    if abs(gap) <= slack:
        return (first, 360.0 / (count - 1), count - 1), True
    if gap < 0.0:
        raise ConfigError(f"config key '{key}': longitude coordinate {name!r} covers {360.0 - gap:.12g} degrees, "
                          "more than the sphere's 360; give each longitude once (a repeated first column may close it)")
    if gap < step:
        raise ConfigError(f"config key '{key}': longitude coordinate {name!r} covers the sphere but for a gap of "
                          f"{gap:.12g} degrees, less than its spacing {step:.12g}: its spacing does not divide 360, "
                          "so the seam is neither a grid cell nor an edge; give a global grid with 360 / spacing "
                          "columns, or a regional one with a gap of more than a spacing")
    return grid, False


def index_window(grid: tuple[float, float, int], low: float, high: float) -> tuple[int, int]:
    """The node indices [a, b] whose cells cover [low, high], at least 3 nodes, inside the grid."""
    first, step, count = grid
    a = max(0, int(math.floor((low - first) / step + 1e-9)))
    b = min(count - 1, int(math.ceil((high - first) / step - 1e-9)))
    return at_least_three_nodes(a, b, count)


def at_least_three_nodes(a: int, b: int, count: int) -> tuple[int, int]:
    """The node range [a, b] of an axis of ``count`` nodes widened to 3 nodes (the kernels' least), upward first."""
    while b - a < 2:
        if b < count - 1:
            b += 1
        else:
            a -= 1
    return a, b


def ring_window(grid: tuple[float, float, int], low: float, high: float) -> tuple[int, int]:
    """The node indices [a, b] of a global longitude grid whose cells cover the longitudes from
    ``low`` eastward to ``high`` (either convention, across the seam too: b may pass the last
    node, the indices taken modulo the count), at least 3 nodes; (0, count) for the whole ring,
    its first node repeated at its end."""
    first, step, count = grid
    if high - low >= 360.0:
        return 0, count
    start = (low - first) % 360.0
    a = int(math.floor(start / step + 1e-9))
    b = int(math.ceil((start + (high - low) % 360.0) / step - 1e-9))
    b = max(b, a + 2)
    return (0, count) if b - a >= count else (a, b)


def column_runs(first: int, last: int, count: int) -> list[slice]:
    """Columns ``first`` .. ``last`` (inclusive, taken modulo ``count``) as contiguous slices, in order."""
    indices = np.arange(first, last + 1) % count
    breaks = np.flatnonzero(np.diff(indices) != 1) + 1
    return [slice(int(run[0]), int(run[-1]) + 1) for run in np.split(indices, breaks)]


def first_copies(columns: np.ndarray) -> np.ndarray:
    """For each position of ``columns`` (node indices, the first and last the padding), the
    position of the same node's first copy among the inner positions (itself if it has none)."""
    inner = {}
    for position in range(1, len(columns) - 1):
        inner.setdefault(int(columns[position]), position)
    return np.array([inner.get(int(node), position) for position, node in enumerate(columns)])


def fill_land(values: np.ndarray, land: np.ndarray) -> np.ndarray:
    """``values`` (time, y, x), or (time, z, y, x), with each land node (``land``: the space axes)
    given its nearest water node's value (nearest in grid indices): the stencils of water cells by
    the coast then see the flow continued, not a wall of zeros (a trajectory still stops on
    entering a cell with a land node)."""
    if not land.any():
        return values
    if land.all():
        return np.zeros_like(values)
    from scipy import ndimage

    nearest = ndimage.distance_transform_edt(land, return_distances=False, return_indices=True)
    return values[(slice(None), *nearest)]


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
    if source.x_global:  # every column has real neighbours, across the seam (indices modulo the count)
        lows[2], highs[2] = xa - 1, xb + 1
        columns = column_runs(xa - 1, xb + 1, counts[2])
    else:
        columns = [slice(lows[2], highs[2] + 1)]
    with source.open() as dataset:
        region = {source.time: slice(lows[0], highs[0] + 1), source.y: slice(lows[1], highs[1] + 1)}

        def read(name: str, dims: tuple[str, ...]) -> np.ndarray:
            parts = [np.asarray(dataset[name].isel({**{k: region[k] for k in dims}, source.x: run}).values)
                     for run in columns]
            return parts[0] if len(parts) == 1 else np.concatenate(parts, axis=-1)

        u = np.asarray(read(source.u, (source.time, source.y)), dtype=float)
        v = np.asarray(read(source.v, (source.time, source.y)), dtype=float)
        water = read(source.mask, (source.y,)) != 0 if source.mask else True
    land_all = ~(np.isfinite(u) & np.isfinite(v) & water)
    land_nodes = land_all.any(axis=0)
    u, v = fill_land(u, land_nodes), fill_land(v, land_nodes)
    if source.x_global:  # a node read twice (round the seam) keeps one filled value: its first copy inside
        copies = first_copies(np.arange(xa - 1, xb + 2) % counts[2])
        u, v = u[..., copies], v[..., copies]
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

    @property
    def engine_name(self) -> str:
        """Every velocity-data system of a kind shares one compiled engine (its data are bound at run
        time): one for the plane, one for the sphere (whose engine has the LD's metric)."""
        return "velocity_data_sphere" if self.source.sphere else "velocity_data"

    @property
    def ld_metric_source(self) -> str:
        """On the sphere, the flow engine's section that takes the LD in kilometres and the data's
        velocity units (``kernels/sphere_ld_metric.py``); on the plane none (the state's units are the data's)."""
        if not self.source.sphere:
            return ""
        return sphere_ld_metric_source(10, 11)

    def ld_units(self, arclength: bool, p: float | None = None) -> str | None:
        """The ``units`` of a map's LD variables (the arc length, or M_p with this ``p``): on the
        sphere the arc length in km, M_p in the data's velocity units to the p times the
        integration's time unit; on the plane None (the state's units, which the data may not name)."""
        if not self.source.sphere:
            return None
        if arclength:
            return "km"
        return f"({self.source.velocity_units})^{format(float(p), 'g')} {self.source.time_units}"

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
        degrees on the sphere, where longitudes wrap; on a global grid, where a longitude may wind
        round any number of times, :data:`WINDING_BOUND`): the engine raises its escape radius to it."""
        if self.source.x_global:
            return WINDING_BOUND
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
            xs = self.x_window(*self.window[self.coordinates[0]])
            ys = index_window(self.source.y_grid, *self.window[self.coordinates[1]])
        else:
            xs = (0, self.source.x_grid[2]) if self.source.x_global else (0, self.source.x_grid[2] - 1)
            ys = (0, self.source.y_grid[2] - 1)
        key = (times, xs, ys)
        if key not in self._windows:
            self._windows.clear()
            self._windows[key] = read_window(self.source, times, xs, ys)
        return self._windows[key]

    def x_window(self, low: float, high: float) -> tuple[int, int]:
        """The node indices of the ``window``'s x interval: on a global longitude grid from ``low``
        eastward to ``high`` across the seam too (:func:`ring_window`); on a regional sphere grid
        moved by whole turns if that puts its start on the grid (a longitude in the other convention)."""
        grid = self.source.x_grid
        if self.source.x_global:
            return ring_window(grid, low, high)
        first, last = grid[0], grid[0] + grid[1] * (grid[2] - 1)
        if self.source.sphere and not first <= low <= last:
            turns = 360.0 * math.floor((low - first) / 360.0)
            if low - turns <= last:
                low, high = low - turns, high - turns
        return index_window(grid, low, high)

    @contextmanager
    def time_window(self, start: float, end: float):
        """Within the block the compiled kernels read the data over [start, end]."""
        from . import data_pointer

        window = self.data_window(start, end)
        with data_pointer.bound_data(window.buffer):
            yield window

    def vector_field(self, state: np.ndarray, t: float = 0.0) -> np.ndarray:
        out = np.empty(self.n_state)
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


def velocity_data_coordinates(entry: dict) -> tuple[str, ...]:
    """The state variables' names of a ``velocity_data`` entry (its x and y coordinates, and z
    for 3-D data: an entry with ``w``), file unread."""
    sphere = entry.get("coordinates", DEFAULTS["coordinates"]) == "sphere"
    axes = SPHERE_AXES if sphere else PLANE_AXES
    horizontal = (entry.get("x", axes[0]), entry.get("y", axes[1]))
    return horizontal + (entry.get("z", VERTICAL_AXIS[sphere]),) if "w" in entry else horizontal


def make_velocity_data_system(name: str, spec: dict, key: str) -> VelocityDataSystem:
    entry = spec["velocity_data"]
    if not isinstance(entry, dict):
        raise ConfigError(f"config key '{key}.velocity_data': expected a mapping (path, u, v, ...), got {entry!r}")
    source = open_source(entry, f"{key}.velocity_data")
    coordinates = (source.x, source.y)
    window = entry.get("window")
    if window is not None:
        if sorted(set(window) - {source.z}) != sorted(coordinates):
            raise ConfigError(f"config key '{key}.velocity_data.window': expected an interval for each of "
                              f"{list(coordinates)}{f' (and optionally {source.z!r})' if source.z else ''}, "
                              f"got {sorted(window)}")
        for coordinate, (low, high) in window.items():
            # a global grid's window may cross the seam, written either way round (east from low to high)
            if not low < high and not (source.x_global and coordinate == coordinates[0]):
                raise ConfigError(f"config key '{key}.velocity_data.window.{coordinate}': expected an interval "
                                  f"[low, high] with low < high, got {[low, high]}" + (
                                      " (a window across the dateline of a regional grid: write its longitudes "
                                      "in the grid's convention, e.g. [170, 190])" if source.sphere
                                      and coordinate == coordinates[0] else ""))
    if source.nodes is not None:  # a non-uniform axis, or 3-D: the rectilinear kernel
        from .velocity_data_rectilinear import make_rectilinear_system

        return make_rectilinear_system(name, source, window, spec)
    text = kernel_source()
    (rhs,) = njit_functions(text, ("rhs",), "velocity_data")
    return VelocityDataSystem(name=name, coordinates=coordinates, source=source, window=window, kernel_source=text,
                              rhs=rhs, spec=spec)
