"""Velocity data on a regular grid (every axis uniform, 2-D): its window, kernel and system.

The velocity between grid nodes is the cubic convolution of ``kernels/gridded_velocity.py``
(cubic in space and time, C1), or with ``interpolation: cubic_bspline`` the same kernel's cubic
B-spline on coefficients prefiltered by :mod:`.bspline` (C2, fourth order); :func:`read_window`
reads the nodes an engine call needs into the buffer the kernel reads (through
:mod:`ldpipe.systems.data_pointer`), with the ring of a global longitude grid joined across the
seam. :class:`VelocityDataSystem` is the system.
"""

from __future__ import annotations

from collections import OrderedDict

import math
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Callable, ClassVar

import numpy as np

from ...errors import ConfigError
from ...jitcache import njit_functions
from ..model import system_repr
from .bspline import MARGIN, bspline_coefficients
from .source import (
    DataSource, at_least_three_nodes, check_speeds, fill_land, kernel_text, pad_axis, sphere_ld_metric_source,
)

# data_pointer (llvmlite and numba) is imported where a kernel is made or bound: a velocity-data
# entry is read for its coordinates (planning, figures) without it.

HEADER = 16  # the kernel's DATA_HEADER
#: The header slot holding where a window's uneven times start in the buffer (0: even times, from
#: slots 7 and 8); read by the kernel for a curvilinear grid's data (:mod:`.curvilinear`).
TIMES_AT = 15
#: The header slot saying which interpolant the kernel applies (0 cubic convolution, 1 cubic B-spline).
INTERPOLATION_AT = 14
#: The values of a ``velocity_data`` entry's ``interpolation`` key.
CUBIC_CONVOLUTION, CUBIC_BSPLINE = "cubic_convolution", "cubic_bspline"
INTERPOLATIONS = (CUBIC_CONVOLUTION, CUBIC_BSPLINE)
#: The kernel's EDGE_SLACK: with the B-spline a point this many cells outside the grid counts as on its edge.
EDGE_SLACK = 1e-9


def kernel_source() -> str:
    """The data kernel's text, with the digests of the pointer's and the stencil's modules (their code
    is inlined into the kernel)."""
    from .. import data_pointer, data_stencil

    text = (kernel_text("velocity_units.py") + kernel_text("nonuniform_cubic_weights.py")
            + kernel_text("uneven_time_weights.py") + kernel_text("gridded_velocity.py"))
    return f"# data_pointer {data_pointer.SOURCE_DIGEST}, data_stencil {data_stencil.SOURCE_DIGEST}\n" + text


def extend_keys(array: np.ndarray, axis: int, low_real: np.ndarray | None, high_real: np.ndarray | None) -> np.ndarray:
    """Pad ``array`` by one node on each side of ``axis``: the real neighbour if read, else Keys'
    extrapolation f[-1] = 3 f[0] - 3 f[1] + f[2] (exact for quadratics)."""
    a = np.moveaxis(array, axis, 0)
    low = low_real if low_real is not None else 3 * a[0] - 3 * a[1] + a[2]
    high = high_real if high_real is not None else 3 * a[-1] - 3 * a[-2] + a[-3]
    return np.moveaxis(np.concatenate([low[None], a, high[None]]), 0, axis)


#: The escape radius of a global grid's trajectories (degrees): a longitude crossing the seam
#: runs on past 360 (the kernel takes it modulo 360), as many turns as the flow makes.
WINDING_BOUND = 1.0e9


def index_window(grid: tuple[float, float, int], low: float, high: float) -> tuple[int, int]:
    """The node indices [a, b] whose cells cover [low, high], at least 3 nodes, inside the grid."""
    first, step, count = grid
    a = max(0, int(math.floor((low - first) / step + 1e-9)))
    b = min(count - 1, int(math.ceil((high - first) / step - 1e-9)))
    return at_least_three_nodes(a, b, count)


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


#: Windows a system keeps: a map's integration, its check for land at the start time and its search
#: for where a trajectory stopped each ask for their own, and each block of a map asks again.
WINDOWS_KEPT = 3


class WindowCache(OrderedDict):
    """The last :data:`WINDOWS_KEPT` windows read or used, by key; the longest unused dropped."""

    def __getitem__(self, key):
        self.move_to_end(key)
        return super().__getitem__(key)

    def __setitem__(self, key, value):
        super().__setitem__(key, value)
        self.move_to_end(key)
        while len(self) > WINDOWS_KEPT:
            self.popitem(last=False)


@dataclass(frozen=True)
class DataWindow:
    """The bound buffer of a window (see the kernel's header comment) and its land mask."""

    buffer: np.ndarray
    land: np.ndarray  # (ny, nx) of the window, True on land
    x_grid: tuple[float, float, int]
    y_grid: tuple[float, float, int]


def read_window(source: DataSource, times: tuple[int, int], x: tuple[int, int], y: tuple[int, int],
                convert: Callable | None = None, interpolation: str = CUBIC_CONVOLUTION) -> DataWindow:
    """Read nodes ``times``, ``y``, ``x`` (inclusive index ranges) and their real neighbours, padded;
    ``convert(u, v, rows, columns)`` (rows, columns: the slices of the grid read) turns the
    velocities read, land filled, into the ones the kernel interpolates (a curvilinear grid's
    index velocities). With ``interpolation`` :data:`CUBIC_BSPLINE` the buffer holds the
    B-spline coefficients of the nodes instead (:mod:`.bspline`, prefiltered over the window and
    :data:`.bspline.MARGIN` more nodes each side where the data have them). Uneven times (a
    curvilinear grid's ``source.nodes``) are padded as an uneven axis is (:func:`.source.pad_axis`)
    and written after the land cells, their start in header slot :data:`TIMES_AT`."""
    (ta, tb), (ya, yb), (xa, xb) = times, y, x
    bspline = interpolation == CUBIC_BSPLINE
    if bspline and source.x_global:
        raise ValueError("the cubic B-spline does not join a global longitude grid across its seam")
    reach = MARGIN if bspline else 1
    counts = (source.t_grid[2], source.y_grid[2], source.x_grid[2])
    lows = [max(0, lo - reach) for lo in (ta, ya, xa)]
    highs = [min(n - 1, hi + reach) for hi, n in zip((tb, yb, xb), counts)]
    if source.x_global:  # every column has real neighbours, across the seam (indices modulo the count)
        lows[2], highs[2] = xa - 1, xb + 1
        columns = column_runs(xa - 1, xb + 1, counts[2])
    else:
        columns = [slice(lows[2], highs[2] + 1)]
    with source.open() as dataset:
        region = {source.time: slice(lows[0], highs[0] + 1), source.y: slice(lows[1], highs[1] + 1)}

        def read(name: str, dims: tuple[str, ...]) -> np.ndarray:
            parts = [dataset.read(name, {**{k: region[k] for k in dims}, source.x: run}) for run in columns]
            return parts[0] if len(parts) == 1 else np.concatenate(parts, axis=-1)

        u = np.asarray(read(source.u, (source.time, source.y)), dtype=float)
        v = np.asarray(read(source.v, (source.time, source.y)), dtype=float)
        water = read(source.mask, (source.y,)) != 0 if source.mask else True
    check_speeds(source, [u, v])
    land_all = ~(np.isfinite(u) & np.isfinite(v) & water)
    land_nodes = land_all.any(axis=0)
    u, v = fill_land(u, land_nodes), fill_land(v, land_nodes)
    if convert is not None:
        u, v = convert(u, v, slice(lows[1], highs[1] + 1), slice(lows[2], highs[2] + 1))
    if source.x_global:  # a node read twice (round the seam) keeps one filled value: its first copy inside
        copies = first_copies(np.arange(xa - 1, xb + 2) % counts[2])
        u, v = u[..., copies], v[..., copies]
    padded = []
    time_nodes = None
    for array in (u, v):
        for axis, (lo, hi, low_read, high_read) in enumerate(zip((ta, ya, xa), (tb, yb, xb), lows, highs)):
            a = np.moveaxis(array, axis, 0)
            start = lo - low_read
            stop = start + hi - lo + 1
            if axis == 0 and source.nodes is not None:  # uneven times: ghosts on the end nodes' parabola
                times = np.asarray(source.nodes[-1])[low_read:high_read + 1]
                array, time_nodes = pad_axis(array, 0, times, start, stop)
                continue
            if bspline:  # the coefficients of the nodes read are c[-1..n]: the window's and one each side
                array = np.moveaxis(bspline_coefficients(a, 0)[start:stop + 2], 0, axis)
                continue
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
    header[INTERPOLATION_AT] = 1.0 if bspline else 0.0
    velocities = np.stack(padded, axis=-1).transpose(1, 2, 0, 3)  # (y, x, time, u/v): the kernel's layout
    buffer = np.concatenate([header, np.ascontiguousarray(velocities).ravel(), cells.ravel()])
    if time_nodes is not None:
        buffer[TIMES_AT] = len(buffer)
        buffer = np.concatenate([buffer, time_nodes])
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
    #: :data:`CUBIC_CONVOLUTION` (C1, the data interpolated as read) or :data:`CUBIC_BSPLINE` (C2).
    interpolation: str = CUBIC_CONVOLUTION
    _windows: WindowCache = field(default_factory=WindowCache, repr=False)

    hamiltonian: ClassVar[bool] = False
    #: A flow in continuous time, not a discrete map.
    discrete: ClassVar[bool] = False
    time_dependent: ClassVar[bool] = True
    #: Land and the data's edge stop trajectories: :meth:`stop_flags` says which, :meth:`stop_lines` where.
    has_stop_flags: ClassVar[bool] = True

    def __repr__(self) -> str:
        return system_repr(self, "velocity_data", data=self.source.label)

    @property
    def engine_name(self) -> str:
        """Every velocity-data system of a kind shares one compiled engine (its data are bound at run
        time): one for the plane, one for the sphere (whose engine has the LD's metric)."""
        return "velocity_data_sphere" if self.source.sphere else "velocity_data"

    @property
    def wraps_longitude(self) -> bool:
        """Whether the engine's first state variable is a longitude, taken modulo 360 (on the sphere)."""
        return self.source.sphere

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
    def time_units(self) -> str | None:
        """The unit of the integration's time: the time coordinate's (``days since ...``: days), else
        the velocity's (``m/s``: s)."""
        return self.source.time_units or None

    @property
    def n_state(self) -> int:
        return 2

    @property
    def phase_coordinates(self) -> tuple[str, ...]:
        return self.coordinates

    @property
    def description(self) -> str:
        kind = "longitude/latitude" if self.source.sphere else "plane"
        return f"velocity data {self.source.u}, {self.source.v} from {self.source.label} ({kind})"

    def kinetic_attributes(self) -> dict[str, str]:
        return {}

    def grid_attributes(self) -> dict[str, str | float]:
        """What a map's file records of the grid's metrics: nothing but on a C-grid (:mod:`.staggered`)."""
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
                              f"[{first:.12g}, {last:.12g}] of {self.source.label} (variable {self.source.time!r})")

    def data_window(self, start: float, end: float) -> DataWindow:
        """The window of the data [start, end] needs (read once; the last few are kept)."""
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
            self._windows[key] = read_window(self.source, times, xs, ys, interpolation=self.interpolation)
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
        from .. import data_pointer

        window = self.data_window(start, end)
        with data_pointer.bound_data(window.buffer):
            yield window

    def vector_field(self, state: np.ndarray, t: float = 0.0) -> np.ndarray:
        out = np.empty(self.n_state)
        with self.time_window(t, t):
            self.rhs(np.ascontiguousarray(state, dtype=np.float64), float(t), out)
        return out

    def engine_states(self, states: np.ndarray) -> np.ndarray:
        """The engine integrates the grid's coordinates themselves (a curvilinear grid's do not)."""
        return states

    def states_from_engine(self, engine_states: np.ndarray) -> np.ndarray:
        return engine_states

    def stop_flags(self, end_states: np.ndarray, start: float, end: float) -> dict[str, np.ndarray]:
        """Where trajectories stopped: ``on_land`` (in a cell with a land node) and ``left_data``
        (outside the data's extent or its spatial window), the boundaries the kernel stops them at."""
        window = self.data_window(start, end)
        east = end_states[:, 0] - window.x_grid[0]
        if self.wraps_longitude:  # longitudes modulo 360, as the kernel takes them
            east = np.mod(east, 360.0)
        fx = east / window.x_grid[1]
        fy = (end_states[:, 1] - window.y_grid[0]) / window.y_grid[1]
        nx, ny = window.x_grid[2], window.y_grid[2]
        slack = EDGE_SLACK if self.interpolation == CUBIC_BSPLINE else 0.0  # as the kernel's edge test
        outside = ~((fx >= -slack) & (fx <= nx - 1 + slack) & (fy >= -slack) & (fy <= ny - 1 + slack))
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
        if self.wraps_longitude:
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


def make_regular_system(name: str, source: DataSource, window: dict | None, spec: dict,
                        interpolation: str = CUBIC_CONVOLUTION) -> VelocityDataSystem:
    """The system of a checked regular ``source`` (:func:`.source.open_source`), interpolated by
    ``interpolation``: both interpolants share one kernel and its compiled engine (the window's
    header says which weights apply)."""
    text = kernel_source()
    (rhs,) = njit_functions(text, ("rhs",), "velocity_data")
    return VelocityDataSystem(name=name, coordinates=(source.x, source.y), source=source, window=window,
                              kernel_source=text, rhs=rhs, spec=spec, interpolation=interpolation)
