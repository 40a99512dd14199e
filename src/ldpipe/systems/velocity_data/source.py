"""The dataset of a ``velocity_data`` entry: opened, its variables, grid and units checked.

:func:`open_source` reads the entry against its file (nothing but the coordinates is read) into a
:class:`DataSource`, which both grids' systems use (:mod:`.regular`, :mod:`.rectilinear`); with it
live what they share: the stencil's least window (:func:`at_least_three_nodes`), an uneven axis's
window and padding (:func:`node_window`, :func:`pad_axis`), land given its
nearest water's values (:func:`fill_land`) and the sphere's LD metric section
(:func:`sphere_ld_metric_source`).
"""

from __future__ import annotations

import contextlib
import re
from collections.abc import Iterator
from dataclasses import dataclass
from importlib import resources

import numpy as np
import xarray as xr

from ...errors import ConfigError
from .. import kernels
from .files import FileSeries, data_files, open_dataset, path_text, series_times
from .grid_coordinates import angle_variable, curvilinear_coordinates, velocity_components
from .grid_metrics import METRIC_TOLERANCE, metric_variables
from .memory import memory_dataset

# scipy.ndimage is imported where a land mask is filled: a velocity-data entry is read for its
# coordinates (planning, figures) without it.

#: Defaults of a ``velocity_data`` entry.
DEFAULTS = {"u": "u", "v": "v", "time": "time", "coordinates": "plane", "earth_radius": 6371000.0}
PLANE_AXES = ("x", "y")
SPHERE_AXES = ("lon", "lat")
#: The vertical coordinate's default name of 3-D data (given ``w``), on the plane and on the sphere.
VERTICAL_AXIS = {False: "z", True: "depth"}
LENGTHS = {"m": 1.0, "meter": 1.0, "metre": 1.0, "meters": 1.0, "metres": 1.0, "km": 1000.0, "cm": 0.01}
TIMES = {"s": 1.0, "sec": 1.0, "second": 1.0, "seconds": 1.0, "min": 60.0, "minute": 60.0, "minutes": 60.0,
         "h": 3600.0, "hr": 3600.0, "hour": 3600.0, "hours": 3600.0, "d": 86400.0, "day": 86400.0, "days": 86400.0}


def kernel_text(name: str) -> str:
    """The text of the kernel template ``name`` (a file of :mod:`ldpipe.systems.kernels`)."""
    return resources.files(kernels).joinpath(name).read_text()


def sphere_ld_metric_source(radius_at: int, scale_at: int) -> str:
    """The engine section that takes a sphere map's LD in km and velocity units
    (``kernels/sphere_ld_metric.py``), for a kernel whose header holds the radius and
    velocity_scale at these indices."""
    text = kernel_text("sphere_ld_metric.py")
    return text.replace("LD_RADIUS_AT", str(radius_at)).replace("LD_SCALE_AT", str(scale_at))


def velocity_units_match(units: str) -> re.Match | None:
    """``units`` read as a length per time (``m/s``, ``m s-1``, ``m s^-1``): groups length, time (2 or 3)."""
    return re.fullmatch(r"(\w+)\s*(?:/\s*(\w+)|\s+(\w+)\s*\^?-1)", units.strip().replace("**", "^"))


def parse_velocity_units(units: str, key: str, name: str = "") -> tuple[float, float]:
    """(metres per length unit, seconds per time unit) of a velocity's ``units`` (``m/s``, ``m s-1``,
    ``km/day``); ``name``: the variable, for the error."""
    match = velocity_units_match(units)
    if not match or match.group(1) not in LENGTHS or (match.group(2) or match.group(3)) not in TIMES:
        of = f" (variable {name!r})" if name else ""
        raise ConfigError(f"config key '{key}': velocity units {units!r} not understood{of}; expected a length per "
                          f"time, e.g. 'm/s', 'm s-1' or 'km/day' (lengths {sorted(LENGTHS)}, times {sorted(TIMES)})")
    return LENGTHS[match.group(1)], TIMES[match.group(2) or match.group(3)]


def units_of(dataset: xr.Dataset, name: str, key: str) -> str | None:
    """The ``units`` attribute of variable ``name``, stripped; None if absent or blank. Refused
    if not text (netCDF lets an attribute be a number, which no unit is)."""
    units = dataset[name].attrs.get("units")
    if units is None:
        return None
    if not isinstance(units, str):
        raise ConfigError(f"config key '{key}': variable {name!r} has units {units!r}, a number, not a unit; "
                          "expected text such as 'm/s', 'm' or 'days since 2000-01-01'")
    return units.strip() or None


def time_unit_seconds(units: str | None) -> float | None:
    """Seconds per unit of a time coordinate (``days since ...``, ``hours``, ``s``), None if not given."""
    if not units:
        return None
    word = units.strip().split()[0]
    return TIMES.get(word)


#: Spacings within this fraction of their mean make an axis uniform (a regular grid, served by
#: the uniform kernel); wider spread makes the grid rectilinear (:mod:`.rectilinear`).
UNIFORM_RTOL = 1e-6


def increasing_axis(values: np.ndarray, name: str, key: str) -> np.ndarray:
    """The values of a coordinate, which must be one-dimensional, increasing, with at least 3 values."""
    values = np.asarray(values)
    if values.dtype.kind not in "iuf":
        raise ConfigError(f"config key '{key}': coordinate {name!r} holds {values.dtype} values, not numbers")
    values = values.astype(float)
    if values.ndim != 1 or len(values) < 3:
        raise ConfigError(f"config key '{key}': coordinate {name!r} must be one-dimensional with at least 3 values, "
                          f"got shape {values.shape}")
    missing = ~np.isfinite(values)
    if missing.any():
        raise ConfigError(f"config key '{key}': coordinate {name!r} has a missing or infinite value (at index "
                          f"{int(np.argmax(missing))}); every node of the grid needs its coordinate")
    steps = np.diff(values)
    if not np.all(steps > 0):
        raise ConfigError(f"config key '{key}': coordinate {name!r} is not monotonic increasing "
                          f"(first decrease at index {int(np.argmax(steps <= 0)) + 1}); the grid must be sorted")
    return values


def is_uniform(values: np.ndarray) -> bool:
    """Whether an increasing axis's spacings all lie within :data:`UNIFORM_RTOL` of their mean."""
    steps = np.diff(values)
    return bool(np.max(np.abs(steps - steps.mean())) <= UNIFORM_RTOL * abs(steps.mean()))


@dataclass(frozen=True)
class DataSource:
    """A dataset's variables and grid, checked, nothing read but the coordinates.

    A regular 2-D grid is ``x_grid``, ``y_grid``, ``t_grid`` (first, spacing, count) and ``nodes``
    None. A rectilinear grid (an axis not uniform, or 3-D data with ``w`` on (time, z, y, x)) has
    ``nodes``: every axis's values, (x, y, time) or (x, y, z, time); its ``*_grid`` hold the first
    value, the mean spacing and the count.
    """

    path: str  # the entry's path as given (a file, a glob, a list), for messages; empty for a dataset in memory
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
    metres_per_second: tuple[float, ...] = ()  # of each velocity (u, v, (w,)) per unit, by its units
    time_units: str = ""  # of the integration's time (the time coordinate's, else the velocity's)
    x_global: bool = False  # longitudes all round the sphere, joined across the seam (:func:`seam_grid`)
    nodes: tuple[tuple[float, ...], ...] | None = None
    files: tuple[str, ...] = ()  # the files along time, in order (one, for a single dataset)
    #: A curvilinear grid's 2-D x and y (longitude, latitude) variables; ``x``, ``y`` then name its
    #: index dimensions, which ``x_grid``, ``y_grid`` count (first 0, spacing 1)
    grid_coordinates: tuple[str, str] | None = None
    components: str = "geographic"  # u, v east and north (x and y), or along the grid's i and j ("grid")
    angle: str | None = None  # a variable holding the grid's rotation angle (grid components)
    angle_scale: float = 1.0  # radians per unit of ``angle``
    #: An Arakawa C-grid's layout (:data:`C_GRIDS`; "" for velocities at the nodes): u on the faces
    #: between nodes (j, i) and (j, i + 1), v on those between (j, i) and (j + 1, i), the nodes the
    #: cells' centres
    staggered: str = ""
    #: A C-grid's metrics read from the file (:mod:`.grid_metrics`): (role, variable, metres per unit,
    #: power of the length) each; empty: computed from the coordinates
    metrics: tuple[tuple[str, str, float, int], ...] = ()
    metric_tolerance: float = METRIC_TOLERANCE  # the relative difference from the coordinates' lengths allowed
    coordinate_metres: float = 1.0  # metres per unit of the coordinates on the plane (1 on the sphere: metres)
    file_starts: tuple[int, ...] = (0,)  # the time index of each file's first time
    memory: str = ""  # the hash of a dataset given in memory (:mod:`.memory`), no path
    time_reference: str = ""  # the time coordinate's units as written ("days since 2000-01-01"), if any
    calendar: str = ""  # its CF calendar attribute, if any

    @property
    def label(self) -> str:
        """Where the data are, for messages and captions: the path, or the in-memory dataset's hash."""
        return self.path or f"the in-memory dataset {self.memory[:23]}"

    @contextlib.contextmanager
    def open(self) -> Iterator[FileSeries]:
        """The data as one dataset along time (:class:`.files.FileSeries`): the files opened lazily,
        or the dataset in memory; a read in the block that fails (a damaged block of a file whose
        coordinates read well) is a ConfigError naming the file."""
        in_memory = memory_dataset({"hash": self.memory}, "velocity_data") if self.memory else None
        with FileSeries(self.files or (self.label,), self.file_starts, self.time, dataset=in_memory) as series:
            yield series

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


@contextlib.contextmanager
def dataset_of(entry: dict, key: str, path: str | None = None) -> Iterator[xr.Dataset]:
    """The dataset of a ``velocity_data`` entry: the one in memory its ``memory`` block names, or
    its file ``path`` (the first of a series) opened lazily (and closed after the block)."""
    if entry.get("memory"):
        yield memory_dataset(entry["memory"], key)
        return
    with open_dataset(str(path or entry["path"])) as dataset:
        yield dataset


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
    """Check a ``velocity_data`` entry against its file: variables, dimensions, grids, units; a
    ConfigError names the entry's key, the variable and the file."""
    try:
        return _checked_source(spec, key)
    except ConfigError as error:
        path = path_text(spec.get("path")) if isinstance(spec, dict) and spec.get("path") else None
        if not path or path in str(error) or spec.get("memory"):
            raise
        raise ConfigError(f"{error} (in {path})") from None


#: The C-grid layouts read: ROMS's faces one fewer than the centres (found from the shapes), NEMO's
#: on arrays of the centres' shape, the last column of u and row of v the outer faces (said by ``c_grid``).
C_GRIDS = ("roms", "nemo")


def c_grid(dataset: xr.Dataset, entry: dict, expected: tuple[str, ...], key: str) -> str:
    """The C-grid layout (:data:`C_GRIDS`) of u and v of a curvilinear grid whose centres are on
    ``expected`` (time, y, x), or "" for velocities at the centres: ROMS's faces (u (time, ny,
    nx - 1), v (time, ny - 1, nx)) from the shapes, NEMO's (u, v of the centres' shape) when the
    entry says ``c_grid: nemo``; a ConfigError names the variables if they fit neither."""
    u, v = dataset[entry["u"]], dataset[entry["v"]]
    ny, nx = dataset.sizes[expected[1]], dataset.sizes[expected[2]]
    layout = entry.get("c_grid")
    if layout not in (None,) + C_GRIDS:
        raise ConfigError(f"config key '{key}.c_grid': expected one of {list(C_GRIDS)}, got {layout!r}")
    timed = u.ndim == v.ndim == 3 and u.dims[0] == v.dims[0] == expected[0]
    if layout == "nemo":
        if timed and u.shape[1:] == v.shape[1:] == (ny, nx):
            return "nemo"
        raise ConfigError(f"config key '{key}.c_grid': NEMO's u and v are on arrays of the centres' shape "
                          f"({expected[0]}, {ny}, {nx}); {entry['u']!r} is {dict(u.sizes)}, {entry['v']!r} "
                          f"{dict(v.sizes)}")
    if layout is None and tuple(u.dims) == expected and tuple(v.dims) == expected:
        return ""
    if timed and u.shape[1:] == (ny, nx - 1) and v.shape[1:] == (ny - 1, nx):
        return "roms"
    raise ConfigError(f"config key '{key}.u': variables {entry['u']!r} {dict(u.sizes)} and {entry['v']!r} "
                      f"{dict(v.sizes)} fit neither the coordinates' points ({expected[0]}, {ny}, {nx}) nor an "
                      f"Arakawa C-grid's faces (u ({expected[0]}, {ny}, {nx - 1}), v ({expected[0]}, {ny - 1}, {nx}), "
                      "ROMS's); give u and v at the points, or on the faces (a C-grid's coordinates are its cells' "
                      "centres: name them, e.g. longitude: lon_rho, latitude: lat_rho)")


def curvilinear_entry(entry: dict, dataset: xr.Dataset, coordinates: tuple[str, str], three_d: bool, key: str) -> dict:
    """What a :class:`DataSource` records of a curvilinear grid beyond its coordinates' names."""
    if three_d:
        raise ConfigError(f"config key '{key}.w': 3-D data on a curvilinear grid are not supported yet")
    components = velocity_components(entry, dataset, key)
    angle = angle_variable({**entry, "components": components}, dataset, dataset[coordinates[0]].dims, key)
    return {"components": components, "angle": angle[0] if angle else None, "angle_scale": angle[1] if angle else 1.0}


def _checked_source(spec: dict, key: str) -> DataSource:
    entry = {**DEFAULTS, **spec}
    unknown = set(entry) - set(DEFAULTS) - {"path", "memory", "x", "y", "window", "mask", "w", "z", "positive",
                                            "longitude", "latitude", "components", "angle", "c_grid",
                                            "interpolation", "metrics", "metric_tolerance"}
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
    memory = entry.get("memory")
    if memory and path:
        raise ConfigError(f"config key '{key}': both a path and a dataset in memory; give one")
    files = [] if memory else data_files(path, f"{key}.path")
    where = files[0] if files else "the dataset"
    velocities = ("u", "v", "w") if three_d else ("u", "v")
    axis_roles = ("x", "y", "z", "time") if three_d else ("x", "y", "time")
    with dataset_of(entry, key, where if files else None) as dataset:
        grid_coordinates = curvilinear_coordinates(entry, dataset, sphere, key)
        curvilinear = {}
        if grid_coordinates:  # the state's axes are the grid's index dimensions
            curvilinear = curvilinear_entry(entry, dataset, grid_coordinates, three_d, key)
            entry["y"], entry["x"] = dataset[grid_coordinates[0]].dims
        elif {"components", "angle", "c_grid", "metrics", "metric_tolerance"} & set(entry):
            raise ConfigError(f"config key '{key}': components, angle, c_grid and metrics are of a curvilinear grid's "
                              "velocities; this grid's coordinates are 1-D (u and v along them)")
        checked = ("time",) if grid_coordinates else axis_roles
        for role in velocities + checked + (("mask",) if entry.get("mask") else ()):
            name = entry[role]
            if name not in dataset.variables:
                raise ConfigError(f"config key '{key}.{role}': variable {name!r} not in {where} (it has "
                                  f"{sorted(map(str, dataset.variables))})")
        times, file_starts = dataset[entry["time"]].values, (0,)
        if len(files) > 1:  # the files along time, checked against the first
            times, file_starts = series_times(files, tuple(entry[role] for role in velocities) + (
                (entry["mask"],) if entry.get("mask") else ()) + tuple(grid_coordinates or ()) + (
                (curvilinear["angle"],) if curvilinear.get("angle") else ()), entry["time"], f"{key}.path")
        nodes = {role: increasing_axis(times if role == "time" else
                                       np.arange(dataset.sizes[entry[role]]) if grid_coordinates else
                                       dataset[entry[role]].values, entry[role], f"{key}.{role}") for role in axis_roles}
        expected = tuple(entry[role] for role in reversed(axis_roles))  # (time, [z,] y, x)
        staggered = c_grid(dataset, entry, expected, key) if grid_coordinates else ""
        if staggered and curvilinear["components"] != "grid":
            raise ConfigError(f"config key '{key}.components': a C-grid's u and v are normal to its cells' faces; "
                              "give components: grid")
        if grid_coordinates:
            curvilinear["metrics"] = metric_variables(entry, dataset, dataset[grid_coordinates[0]].dims, staggered, key)
            tolerance = entry.get("metric_tolerance", METRIC_TOLERANCE)
            if isinstance(tolerance, bool) or not isinstance(tolerance, (int, float)) or not tolerance > 0:
                raise ConfigError(f"config key '{key}.metric_tolerance': expected a number above 0, got {tolerance!r}")
            curvilinear["metric_tolerance"] = float(tolerance)
        scales = []
        for role in velocities:
            variable = dataset[entry[role]]
            if tuple(variable.dims) != expected and not staggered:
                raise ConfigError(f"config key '{key}.{role}': variable {entry[role]!r} has dimensions "
                                  f"{tuple(variable.dims)}; expected {expected}")
            if variable.dtype.kind not in "iuf":
                raise ConfigError(f"config key '{key}.{role}': variable {entry[role]!r} holds {variable.dtype} "
                                  "values, not numbers")
            units = units_of(dataset, entry[role], f"{key}.{role}")
            if not units:
                raise ConfigError(f"config key '{key}.{role}': variable {entry[role]!r} has no 'units' attribute; "
                                  "a velocity needs its units (e.g. 'm/s')")
            scales.append(parse_velocity_units(units, f"{key}.{role}", entry[role]))
        if scales[0] != scales[1]:
            raise ConfigError(f"config key '{key}.v': variables {entry['u']!r} and {entry['v']!r} have different units "
                              f"({dataset[entry['u']].attrs['units']!r}, {dataset[entry['v']].attrs['units']!r})")
        mask = entry.get("mask")
        if mask and tuple(dataset[mask].dims) != expected[1:]:
            raise ConfigError(f"config key '{key}.mask': variable {mask!r} has dimensions "
                              f"{tuple(dataset[mask].dims)}; expected {expected[1:]}")
        metres, seconds = scales[0]
        time_coordinate_units = units_of(dataset, entry["time"], f"{key}.time")
        if time_coordinate_units and time_unit_seconds(time_coordinate_units) is None:
            # else the times would be read in the velocity's time unit, silently wrong
            raise ConfigError(f"config key '{key}.time': time units {time_coordinate_units!r} of variable "
                              f"{entry['time']!r} not understood; expected one of {sorted(TIMES)}, or 'UNIT since "
                              "DATE' (or no units: the velocity's time unit)")
        data_seconds = time_unit_seconds(time_coordinate_units) or seconds
        calendar = dataset[entry["time"]].attrs.get("calendar")
        velocity_units = units_of(dataset, entry["u"], f"{key}.u")
        if time_unit_seconds(time_coordinate_units):
            time_units = time_coordinate_units.strip().split()[0]
        else:
            match = velocity_units_match(velocity_units)
            time_units = match.group(2) or match.group(3)
        if sphere:
            length = 1.0  # the kernel divides by the radius in metres
        else:
            x_name = grid_coordinates[0] if grid_coordinates else entry["x"]
            length = length_of(units_of(dataset, x_name, f"{key}.x"), x_name, f"{key}.x", metres)
        vertical_scale = 0.0
        z_length = 1.0
        if three_d:
            w_metres, w_seconds = scales[2]
            z_length = length_of(units_of(dataset, entry["z"], f"{key}.z"), entry["z"], f"{key}.z", w_metres)
            vertical_scale = vertical_sign(entry, dataset, key) * w_metres / z_length * data_seconds / w_seconds
    grids = {role: (float(values[0]), float(np.diff(values).mean()), len(values)) for role, values in nodes.items()}
    regular = not three_d and all(is_uniform(values) for values in nodes.values())  # the uniform kernel's grid
    x_global = False
    if sphere and regular and not grid_coordinates:  # the seam is joined on the uniform kernel's grids only
        grids["x"], x_global = seam_grid(grids["x"], entry["x"], f"{key}.x")
    return DataSource(path=path_text(path) if path else "", memory=memory["hash"] if memory else "",
                      files=tuple(files), file_starts=file_starts, u=entry["u"], v=entry["v"], x=entry["x"],
                      y=entry["y"], time=entry["time"],
                      x_grid=grids["x"], y_grid=grids["y"], t_grid=grids["time"],
                      velocity_scale=metres / length * data_seconds / seconds, sphere=sphere,
                      radius=float(entry["earth_radius"]), mask=mask, w=entry.get("w"), z=entry.get("z"),
                      vertical_scale=vertical_scale, z_metres=z_length, velocity_units=velocity_units, time_units=time_units,
                      x_global=x_global, time_reference=time_coordinate_units or "",
                      calendar=str(calendar or ""),
                      metres_per_second=tuple(metres / seconds for metres, seconds in scales),
                      nodes=None if regular else tuple(tuple(float(v) for v in nodes[role]) for role in axis_roles),
                      grid_coordinates=grid_coordinates, staggered=staggered, coordinate_metres=length, **curvilinear)


#: How far, in grid spacings, a longitude grid's span may be from 360 degrees (one spacing short, or
#: none with the first column repeated) and still be taken as global: float32 coordinates at 1/12
#: degree miss by ~4e-4 spacings.
SEAM_TOLERANCE = 1e-3


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


#: No flow is faster than light: a velocity beyond it (in m/s, by its units) is damaged or
#: mis-scaled data (a few flipped bytes make 1e17), and a trajectory through it would take every
#: step it may, the run seeming to hang.
LIGHT_SPEED = 299_792_458.0


def check_speeds(source: DataSource, arrays: list[np.ndarray]) -> None:
    """A ConfigError naming the file and the variable if a velocity read (``arrays``, in the order
    u, v, (w)) is faster than light; missing values (land) are not speeds."""
    names = (source.u, source.v) + ((source.w,) if source.w else ())
    for name, array, factor in zip(names, arrays, source.metres_per_second):
        finite = np.abs(array[np.isfinite(array)])
        fastest = float(finite.max()) if finite.size else 0.0
        if fastest * factor > LIGHT_SPEED:
            raise ConfigError(f"velocity data {source.label}: variable {name!r} holds a speed of {fastest:.3g} "
                              f"({fastest * factor:.3g} m/s by its units), faster than light: damaged or "
                              "mis-scaled data")


def at_least_three_nodes(a: int, b: int, count: int) -> tuple[int, int]:
    """The node range [a, b] of an axis of ``count`` nodes widened to 3 nodes (the kernels' least), upward first."""
    while b - a < 2:
        if b < count - 1:
            b += 1
        else:
            a -= 1
    return a, b


def node_window(values: np.ndarray, low: float, high: float) -> tuple[int, int]:
    """The node indices [a, b] whose cells cover [low, high], at least 3 nodes, inside the axis."""
    count = len(values)
    slack = 1e-9 * (values[-1] - values[0]) / (count - 1)  # as the regular grid's rounding allowance
    a = max(0, int(np.searchsorted(values, low + slack, side="right")) - 1)
    b = min(count - 1, int(np.searchsorted(values, high - slack, side="left")))
    return at_least_three_nodes(a, b, count)


def quadratic_ghost(nodes: np.ndarray, values: np.ndarray, at: float) -> np.ndarray:
    """The parabola through (nodes[k], values[k]), k = 0, 1, 2, at ``at`` (values' first axis)."""
    c0, c1, c2 = nodes
    weights = ((at - c1) * (at - c2) / ((c0 - c1) * (c0 - c2)), (at - c0) * (at - c2) / ((c1 - c0) * (c1 - c2)),
               (at - c0) * (at - c1) / ((c2 - c0) * (c2 - c1)))
    return weights[0] * values[0] + weights[1] * values[1] + weights[2] * values[2]


def pad_axis(array: np.ndarray, axis: int, nodes: np.ndarray, start: int, stop: int) -> tuple[np.ndarray, np.ndarray]:
    """Nodes ``start`` .. ``stop - 1`` of ``array`` along ``axis`` (``nodes`` the values of what was
    read) with one more on each side: the real neighbour if read, else a ghost at the mirrored
    spacing on the parabola through the three end nodes. Returns (values, node values)."""
    a = np.moveaxis(array, axis, 0)
    inner, inner_nodes = a[start:stop], nodes[start:stop]
    if start > 0:
        low, low_node = a[start - 1], nodes[start - 1]
    else:
        low_node = 2.0 * inner_nodes[0] - inner_nodes[1]
        low = quadratic_ghost(inner_nodes[:3], inner[:3], low_node)
    if stop < a.shape[0]:
        high, high_node = a[stop], nodes[stop]
    else:
        high_node = 2.0 * inner_nodes[-1] - inner_nodes[-2]
        high = quadratic_ghost(inner_nodes[-3:], inner[-3:], high_node)
    padded = np.moveaxis(np.concatenate([low[None], inner, high[None]]), 0, axis)
    return padded, np.concatenate([[low_node], inner_nodes, [high_node]])


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


def velocity_data_coordinates(entry: dict) -> tuple[str, ...]:
    """The state variables' names of a ``velocity_data`` entry (its x and y coordinates, and z
    for 3-D data: an entry with ``w``), file unread."""
    sphere = entry.get("coordinates", DEFAULTS["coordinates"]) == "sphere"
    axes = SPHERE_AXES if sphere else PLANE_AXES
    horizontal = (entry.get("x", axes[0]), entry.get("y", axes[1]))
    return horizontal + (entry.get("z", VERTICAL_AXIS[sphere]),) if "w" in entry else horizontal
