"""Velocity data on a global longitude/latitude grid that reaches a pole: trajectories cross it.

A regular grid on the sphere, all round it in longitude (joined across the seam, :func:`.source.seam_grid`)
and reaching a pole (its last row at the pole, or half a spacing from it), is integrated in a form
with no singularity there: the engine's state is the 3-D position on the sphere, X = D (cos lat cos
lon, cos lat sin lon, sin lat) with D = 180/pi (so a component's error is in degrees of arc, as a
latitude's), and dX/dt = D / R (u e_east + v e_north), u and v the data's eastward and northward
velocities interpolated at the point's longitude and latitude by the regular grid's kernel
(``kernels/gridded_velocity.py``, unchanged) and e_east, e_north the local basis
(``kernels/polar_velocity.py``). The basis turns round fast near the pole, but u e_east + v e_north,
the velocity itself, does not: it is as smooth as the data.

The interpolation across the pole: the grid's chart (lon, lat) -> X continues smoothly past lat 90
(X(lon, 90 + d) = X(lon + 180, 90 - d)), and on it e_east(lon) = -e_east(lon + 180) and
e_north(lon, 90 + d) = -e_north(lon + 180, 90 - d). So u and v of the continued chart, the components
of one smooth velocity field in a smooth frame, are smooth across the pole, with

    u(lon, 90 + d) = -u(lon + 180, 90 - d),   v(lon, 90 + d) = -v(lon + 180, 90 - d)

(the same at the south pole): :func:`read_polar_window` adds rows beyond the pole, each a row of the
grid shifted by half the columns with both components' signs flipped, so the kernel's stencil reads
real data across the pole (the number of columns must be even, so that lon + 180 is a column). A
row at the pole itself is direction-dependent (u, v at the pole are a single vector's components in
each meridian's frame): it enters the stencil as any row does, and the flip maps it onto itself.

The engine integrates three more components with X: the eastward and northward distances run,
dE/dt = D u / R and dN/dt = D v / R (N, started at the start's latitude, is the latitude), and the
time moved, which stops growing where a trajectory stops on land or at the data's edge: the step
control locates that instant, the trajectory's exit time, as it locates any kink. The LD is taken in km and the data's velocity units as on any
sphere grid (``kernels/polar_ld_metric.py``): the arc length from |dX/dt|, which does not depend on
the basis, and M_p from u and v, whose turning with the basis near a pole the step control follows
because E and N are states.
End states are returned as longitude (in the grid's convention) and latitude: how many times a
trajectory wound round the sphere is not kept. A spatial ``window`` keeps the regional sphere engine: the
trajectories stop at its edges.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ...errors import ConfigError
from ...jitcache import njit_functions
from .regular import (
    HEADER,
    WINDING_BOUND,
    DataWindow,
    VelocityDataSystem,
    extend_keys,
    index_window,
    kernel_source,
)
from .source import DataSource, check_speeds, fill_land, kernel_text

#: Degrees of arc per radian: the engine's positions are on the sphere of this radius.
DEGREES = 180.0 / math.pi
#: How close (in spacings) the last latitude must be to the pole, or to half a spacing from it.
POLE_TOLERANCE = 1e-6
#: Rows added beyond a pole: the kernel's stencil (two rows past the last cell) and the padding.
ROWS_BEYOND = 3


def pole_offsets(source: DataSource, key: str) -> tuple[int | None, int | None]:
    """For the south and the north pole, None if the grid's latitudes stay a spacing or more away
    from it, else how the grid meets it: 0 with a row at the pole, 1 with its last row half a
    spacing away (the mirrored rows then continue the spacing). A ConfigError names the latitude
    coordinate for a grid that ends nearer the pole than a spacing otherwise, or whose number of
    longitudes is odd (the meridian across the pole is not a column)."""
    first, step, count = source.y_grid
    gaps = {"south": first + 90.0, "north": 90.0 - (first + step * (count - 1))}  # negative: past the pole
    offsets = []
    for pole, gap in gaps.items():
        if gap >= step * (1.0 - POLE_TOLERANCE):
            offsets.append(None)
            continue
        if gap < -POLE_TOLERANCE * step:
            raise ConfigError(f"config key '{key}.y': latitude coordinate {source.y!r} passes the {pole} pole "
                              f"(by {-gap:.6g} degrees); latitudes lie in [-90, 90]")
        if abs(gap) <= POLE_TOLERANCE * step:
            offsets.append(0)
        elif abs(gap - 0.5 * step) <= POLE_TOLERANCE * step:
            offsets.append(1)
        else:
            raise ConfigError(f"config key '{key}.y': latitude coordinate {source.y!r} ends {gap:.6g} degrees from "
                              f"the {pole} pole, less than its spacing {step:.6g} but neither at the pole nor half a "
                              "spacing from it, so no row across the pole continues the grid; give a grid with a "
                              "row at the pole or half a spacing from it, or a window that stays a spacing away")
    if any(offset is not None for offset in offsets) and source.x_grid[2] % 2:
        raise ConfigError(f"config key '{key}.x': the global grid reaches a pole, but its {source.x_grid[2]} "
                          f"longitudes of {source.x!r} are an odd number: the meridian across the pole (180 degrees "
                          "on) is not a column; give an even number of longitudes")
    return offsets[0], offsets[1]


def beyond_pole(array: np.ndarray, rows: list[int], half: int, sign: float) -> np.ndarray:
    """The rows ``rows`` of ``array`` (..., y, x) as seen across the pole: each column takes the
    column half the ring on (longitude + 180), times ``sign`` (-1 for a velocity component)."""
    return sign * np.roll(array[..., rows, :], -half, axis=-1)


def extended_rows(array: np.ndarray, offsets: tuple[int | None, int | None], sign: float) -> np.ndarray:
    """``array`` (..., y, x) with :data:`ROWS_BEYOND` rows added beyond each pole the grid reaches
    (the k-th beyond the north pole is row ``last - k + offset``, module docstring)."""
    ny, half = array.shape[-2], array.shape[-1] // 2
    parts = [array]
    south, north = offsets
    if south is not None:  # the k-th row south of the first: row k - 1 + (1 - offset), nearest last in order
        rows = [k - 1 + (1 - south) for k in range(ROWS_BEYOND, 0, -1)]
        parts.insert(0, beyond_pole(array, rows, half, sign))
    if north is not None:
        rows = [ny - 1 - k + north for k in range(1, ROWS_BEYOND + 1)]
        parts.append(beyond_pole(array, rows, half, sign))
    return np.concatenate(parts, axis=-2)


def padded_axis(array: np.ndarray, axis: int, start: int, stop: int) -> np.ndarray:
    """The slice [start, stop) of ``axis`` with one node each side: the real one where read, else Keys'."""
    a = np.moveaxis(array, axis, 0)
    low = a[start - 1] if start > 0 else None
    high = a[stop] if stop < a.shape[0] else None
    return np.moveaxis(extend_keys(a[start:stop], 0, low, high), 0, axis)


def read_whole_grid(source: DataSource, times: tuple[int, int], shape: tuple[int, int]
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """u and v of the whole grid (``shape`` (rows, columns)) over time nodes ``times`` (inclusive)
    and their real neighbours in time, land filled; the land nodes (a land or missing value at
    any of these times); the first time node read."""
    ta, tb = times
    ny, nx = shape
    t_low, t_high = max(0, ta - 1), min(source.t_grid[2] - 1, tb + 1)
    with source.open() as dataset:
        region = {source.time: slice(t_low, t_high + 1), source.y: slice(0, ny), source.x: slice(0, nx)}
        u = np.asarray(dataset.read(source.u, region), dtype=float)
        v = np.asarray(dataset.read(source.v, region), dtype=float)
        water = dataset.read(source.mask, {source.y: region[source.y], source.x: region[source.x]}) != 0 \
            if source.mask else np.ones((ny, nx), dtype=bool)
    check_speeds(source, [u, v])
    land_nodes = (~(np.isfinite(u) & np.isfinite(v) & water)).any(axis=0)
    return fill_land(u, land_nodes), fill_land(v, land_nodes), land_nodes, t_low


def read_polar_window(source: DataSource, times: tuple[int, int], offsets: tuple[int | None, int | None]) -> DataWindow:
    """The window of the whole globe over time nodes ``times`` (inclusive), as the regular kernel
    reads it (:func:`.regular.read_window`'s layout): the ring of longitudes with its first column
    repeated at its end and the real columns across the seam as padding; the rows beyond each pole
    reached (:func:`extended_rows`), the padding beyond them real too; the header's sphere flag 0
    (the polar kernel hands the kernel a longitude already on the grid's first turn)."""
    (ta, tb) = times
    nx = source.x_grid[2]
    u, v, land_nodes, t_low = read_whole_grid(source, times, (source.y_grid[2], nx))
    u, v = extended_rows(u, offsets, -1.0), extended_rows(v, offsets, -1.0)
    land_nodes = extended_rows(land_nodes.astype(float), offsets, 1.0) > 0.5
    south, north = offsets
    y_start = ROWS_BEYOND - 1 if south is not None else 0  # the outermost row beyond a pole pads the window
    y_stop = u.shape[-2] - (1 if north is not None else 0)
    columns = np.arange(-1, nx + 2) % nx  # the ring, its first column again at its end, padded across the seam
    padded = []
    for array in (u, v):
        array = padded_axis(array[..., columns], 0, ta - t_low, ta - t_low + tb - ta + 1)
        padded.append(padded_axis(array, 1, y_start, y_stop))
    land = land_nodes[y_start:y_stop][:, columns[1:-1]]
    nyw, nxw = land.shape
    cells = np.zeros((nyw + 2, nxw + 2))  # the kernel's land cells: a cell with a land corner
    cells[:nyw - 1, :nxw - 1] = land[:-1, :-1] | land[:-1, 1:] | land[1:, :-1] | land[1:, 1:]
    y_first = source.y_grid[0] + source.y_grid[1] * (y_start - (ROWS_BEYOND if south is not None else 0))
    x_grid = (source.x_grid[0], source.x_grid[1], nxw)
    y_grid = (y_first, source.y_grid[1], nyw)
    header = np.zeros(HEADER)
    header[:12] = (tb - ta + 1, nyw, nxw, x_grid[0], x_grid[1], y_grid[0], y_grid[1],
                   source.t_grid[0] + source.t_grid[1] * ta, source.t_grid[1], 0.0, source.radius, source.velocity_scale)
    velocities = np.stack(padded, axis=-1).transpose(1, 2, 0, 3)  # (y, x, time, u/v): the kernel's layout
    buffer = np.concatenate([header, np.ascontiguousarray(velocities).ravel(), cells.ravel()])
    return DataWindow(np.ascontiguousarray(buffer), land.copy(), x_grid, y_grid)


def polar_kernel_source() -> str:
    """The polar kernel's text: the regular kernel's, its ``rhs`` renamed (the grid's velocity at a
    longitude and latitude), then ``kernels/polar_velocity.py``'s ``rhs`` of the 3-D position."""
    text = kernel_source()
    if text.count("\ndef rhs(") != 1:
        raise RuntimeError("the regular velocity kernel no longer defines rhs once; the polar kernel wraps it")
    return text.replace("\ndef rhs(", "\ndef polar_grid_velocity(") + kernel_text("polar_velocity.py")


def positions(states: np.ndarray) -> np.ndarray:
    """3-D positions (degrees of arc) of rows (longitude, latitude) in degrees."""
    lon, lat = np.radians(states[:, 0]), np.radians(states[:, 1])
    return DEGREES * np.column_stack([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)])


@dataclass(frozen=True, eq=False)
class PolarVelocitySystem(VelocityDataSystem):
    """A flow on a global grid reaching a pole, integrated as 3-D positions (module docstring)."""

    poles: tuple[int | None, int | None] = (None, None)

    #: The engine integrates the 3-D position on the sphere, the eastward distance run, the latitude
    #: and the time moved (module docstring).
    engine_dimension: ClassVar[int] = 6
    #: The time a trajectory stopped on land or at the data's edge is the time it moved
    #: (:meth:`times_from_engine`), located by the engine's step control: no search for it after.
    stop_times_located: ClassVar[bool] = True

    @property
    def engine_name(self) -> str:
        return "velocity_data_polar"

    @property
    def ld_metric_source(self) -> str:
        """The LD in km and the data's velocity units from the 3-D positions' stages (``kernels/polar_ld_metric.py``)."""
        return kernel_text("polar_ld_metric.py").replace("LD_RADIUS_AT", "10").replace("LD_SCALE_AT", "11")

    @property
    def description(self) -> str:
        return (f"velocity data {self.source.u}, {self.source.v} from {self.source.label} (longitude/latitude, "
                "global, across the poles)")

    @property
    def coordinate_bound(self) -> float:
        return WINDING_BOUND

    def engine_states(self, states: np.ndarray) -> np.ndarray:
        """3-D positions on the sphere (degrees of arc) of rows (lon, lat), no eastward distance run
        yet, the latitude, no time moved yet."""
        states = np.asarray(states, dtype=float)
        zeros = np.zeros((len(states), 1))
        return np.column_stack([positions(states), zeros, states[:, 1:2], zeros])

    def states_from_engine(self, engine_states: np.ndarray) -> np.ndarray:
        """(lon, lat) of 3-D positions: the longitude on the grid's first turn from its first column."""
        x, y, z = np.asarray(engine_states, dtype=float)[:, :3].T
        first = self.source.x_grid[0]
        lon = first + np.mod(np.degrees(np.arctan2(y, x)) - first, 360.0)
        return np.column_stack([lon, np.degrees(np.arctan2(z, np.hypot(x, y)))])

    def times_from_engine(self, engine_ends: np.ndarray, times: np.ndarray) -> np.ndarray:
        """|t - t0| each trajectory ran, given the engine's (``times``): the time it moved where it
        stopped on land or at the data's edge before (the engine ran on, standing still)."""
        moved = np.abs(np.asarray(engine_ends, dtype=float)[:, 5])  # t - t0: negative backward
        return np.where(np.isfinite(moved), np.minimum(times, moved), times)

    def data_window(self, start: float, end: float) -> DataWindow:
        """The whole globe's window over [start, end] (read once; the last few are kept)."""
        self.check_times(start, end)
        times = index_window(self.source.t_grid, *sorted((start, end)))
        if times not in self._windows:
            self._windows[times] = read_polar_window(self.source, times, self.poles)
        return self._windows[times]

    def vector_field(self, state: np.ndarray, t: float = 0.0) -> np.ndarray:
        """d(lon, lat)/dt in degrees per time unit (singular at a pole, as the chart is)."""
        position = self.engine_states(np.asarray(state, dtype=float)[None])[0]
        rate = np.empty(self.engine_dimension)
        with self.time_window(t, t):
            self.rhs(position, float(t), rate)
        rate = rate[:3]
        lon, lat = np.radians(state[0]), np.radians(state[1])
        east = np.array([-math.sin(lon), math.cos(lon), 0.0])
        north = np.array([-math.sin(lat) * math.cos(lon), -math.sin(lat) * math.sin(lon), math.cos(lat)])
        return np.array([rate @ east / math.cos(lat), rate @ north])


def make_polar_system(name: str, source: DataSource, spec: dict, poles: tuple[int | None, int | None]
                      ) -> PolarVelocitySystem:
    """The system of a checked global regular ``source`` that reaches a pole (:func:`pole_offsets`)."""
    text = polar_kernel_source()
    (rhs,) = njit_functions(text, ("rhs",), "velocity_data_polar")
    return PolarVelocitySystem(name=name, coordinates=(source.x, source.y), source=source, window=None,
                               kernel_source=text, rhs=rhs, spec=spec, poles=poles)
