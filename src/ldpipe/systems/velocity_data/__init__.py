"""Systems given by gridded velocity data: ocean or atmosphere currents from a netCDF file.

A ``systems:`` entry ``{"velocity_data": {"path": "currents.nc", "u": "u", "v": "v", "x": "x",
"y": "y", "time": "time", "coordinates": "plane"}}`` names a CF dataset and its variables: the
velocity components ``u``, ``v`` on (time, y, x), the coordinates increasing; ``path`` may be a
glob or a list of files along time, read lazily as one dataset (:mod:`.files`). A regular grid
(every axis uniform) makes a system of :mod:`.regular`; an uneven axis, or 3-D data (``w`` on
(time, z, y, x)), one of :mod:`.rectilinear`; both read the dataset that :mod:`.source` opened and
checked. ``coordinates: sphere`` reads x, y as longitude and latitude in degrees and u, v
as eastward and northward velocities, with the Earth's radius ``earth_radius`` (metres).

Coordinates that are 2-D make a curvilinear grid (:mod:`.grid_coordinates` finds them), integrated
in its index space (:mod:`.curvilinear`; u and v on a C-grid's faces: :mod:`.staggered`); a
tripolar global grid, joined across its seam and north fold, as 3-D positions (:mod:`.folded`).

The state is (x, y); the integration time is the data's time coordinate in its own units; u, v
are converted from their units (``m/s``, ``km/day``, ...) to coordinate units per time unit
(on the sphere, to degrees per time unit). The velocity between grid nodes is the cubic
convolution of ``kernels/gridded_velocity.py`` (cubic in space and time; on a regular grid with
``interpolation: cubic_bspline`` the same kernel's cubic B-spline, on coefficients from
:mod:`.bspline`), compiled into the flow engine like a formula's right-hand side; its data reach
the compiled code through :mod:`ldpipe.systems.data_pointer`, so one compiled engine serves
every dataset.

The data may instead be given in memory, from Python (:mod:`.memory`): an ``xarray.Dataset``,
lazy or not, or the DataArrays u, v (and w), kept in the process under the hash of their values.

Only the window an engine call needs is read (xarray opens the file lazily): the times covering
[t0, t0 +- tau] with the stencil's neighbours, over the spatial ``window`` if given (else the
whole grid). Land (missing values) and the grid's edge are boundaries: a trajectory stops on
reaching a cell with a land node, or the edge, and :meth:`VelocityDataSystem.stop_flags` says
which; a window that leaves the data's times is refused, naming both ranges.

On the sphere a longitude grid all round it (:func:`.source.seam_grid`) has no edge: the window read
is the ring with its first column repeated at its end, padded with the real columns across the
seam (the kernel's stencil then wraps, the kernel unchanged), and a spatial window may cross the
seam. The LD is taken in km and the data's velocity units, by the engine section
``kernels/sphere_ld_metric.py`` (:attr:`VelocityDataSystem.ld_metric_source`). A global grid that
reaches a pole (without a spatial window) is :mod:`.polar`'s: integrated as 3-D positions on the
sphere, its rows continued across the pole, so trajectories cross it.
"""

from __future__ import annotations

from ...errors import ConfigError
from .calendar import calendar_attributes
from .curvilinear import CurvilinearVelocitySystem, make_curvilinear_system
from .files import path_text, velocity_data_files
from .memory import is_in_memory, memory_entry
from .polar import PolarVelocitySystem, make_polar_system, pole_offsets
from .rectilinear import RectilinearVelocitySystem, make_rectilinear_system
from .regular import CUBIC_CONVOLUTION, INTERPOLATIONS, DataWindow, VelocityDataSystem, make_regular_system
from .source import DEFAULTS, DataSource, open_source, velocity_data_coordinates
from .staggered import StaggeredVelocitySystem, make_staggered_system

__all__ = ["DEFAULTS", "CurvilinearVelocitySystem", "DataSource", "DataWindow", "PolarVelocitySystem",
           "RectilinearVelocitySystem",
           "StaggeredVelocitySystem", "VelocityDataSystem", "calendar_attributes", "is_in_memory",
           "make_velocity_data_system", "memory_entry", "open_source", "path_text", "velocity_data_coordinates",
           "velocity_data_files"]


def make_velocity_data_system(name: str, spec: dict, key: str) -> VelocityDataSystem:
    """The system of a ``velocity_data`` entry: its file checked, its window checked against the
    grid, the regular or the rectilinear grid's system."""
    entry = spec["velocity_data"]
    if not isinstance(entry, dict):
        raise ConfigError(f"config key '{key}.velocity_data': expected a mapping (path, u, v, ...), got {entry!r}")
    source = open_source(entry, f"{key}.velocity_data")
    interpolation = entry.get("interpolation", CUBIC_CONVOLUTION)
    if interpolation not in INTERPOLATIONS:
        raise ConfigError(f"config key '{key}.velocity_data.interpolation': expected one of {list(INTERPOLATIONS)}, "
                          f"got {interpolation!r}")
    if interpolation != CUBIC_CONVOLUTION and (source.staggered or source.grid_coordinates or source.nodes is not None
                                               or source.x_global):
        grid = ("a curvilinear grid" if source.staggered or source.grid_coordinates else
                "a global longitude grid" if source.x_global else "an uneven or 3-D grid")
        raise ConfigError(f"config key '{key}.velocity_data.interpolation': {interpolation!r} is offered on a regular "
                          f"2-D grid that is not global; {source.label} is {grid}: use 'cubic_convolution'")
    # a curvilinear grid's state is its coordinates (x, y or longitude, latitude), not its index dimensions
    coordinates = velocity_data_coordinates(entry) if source.grid_coordinates else (source.x, source.y)
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
    if source.staggered:  # a C-grid: its face velocities, a coast a wall
        return make_staggered_system(name, source, spec, coordinates, window, f"{key}.velocity_data.window")
    if source.grid_coordinates:  # 2-D coordinates: integrated in the grid's indices
        return make_curvilinear_system(name, source, spec, coordinates, window, f"{key}.velocity_data.window")
    if source.nodes is not None:  # a non-uniform axis, or 3-D: the rectilinear kernel
        return make_rectilinear_system(name, source, window, spec)
    if source.x_global and window is None:  # a global grid reaching a pole: integrated as 3-D positions
        poles = pole_offsets(source, f"{key}.velocity_data")
        if poles != (None, None):
            return make_polar_system(name, source, spec, poles)
    return make_regular_system(name, source, window, spec, interpolation)
