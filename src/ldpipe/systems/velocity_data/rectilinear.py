"""Velocity data on a rectilinear grid: axes spaced unevenly, and 3-D currents (u, v, w).

A ``velocity_data`` entry whose file has an axis that is not uniform (x, y, z or time: ocean
depth levels, latitudes of a Mercator grid), or that names a vertical velocity ``w`` on
(time, z, y, x), is served by this module's system: the same checks, land, edges, windows and
stop flags as :mod:`.regular` (whose regular 2-D grids keep their own
kernel), with every axis given by its node values and interpolated by the non-uniform cubic of
``kernels/rectilinear_velocity.py`` (its header derives the weights: third order, exact for
degree <= 2 in each variable, Keys' cubic convolution on equal spacings).

3-D data: the state is (x, y, z), z the vertical coordinate in its own length units; w is the
upward velocity (CF ``upward_sea_water_velocity``), converted from its units to z units per
time unit, and taken as -dz/dt when z is a depth (``positive: down``, from the entry or the
coordinate's CF attribute). Missing values (the sea floor, land) are land; the top and bottom
levels bound the data like its horizontal edges.
"""

from __future__ import annotations

from dataclasses import dataclass
from importlib import resources

import numpy as np

from ...jitcache import njit_functions
from .. import kernels
from .regular import VelocityDataSystem
from .source import DataSource, check_speeds, fill_land, kernel_text, node_window, pad_axis, sphere_ld_metric_source

# data_pointer (llvmlite and numba) is imported where a kernel is made: a velocity-data entry is
# read for its coordinates (planning, figures) without it.

#: The rectilinear kernel's header length (its GRID_HEADER).
GRID_HEADER = 16
#: The state's grid axes by role, and the dataset's name of each role in a :class:`DataSource`.
ROLE_NAMES = {"x": "x", "y": "y", "z": "z", "t": "time"}


def rectilinear_kernel_source(dims: int) -> str:
    """The rectilinear kernel's text for ``dims`` = 2 (u, v) or 3 (u, v, w), with the pointer
    module's digest (its code is inlined into the kernel)."""
    from .. import data_pointer

    text = kernel_text("velocity_units.py") + kernel_text("nonuniform_cubic_weights.py") + kernel_text("rectilinear_velocity.py")
    return f"# data_pointer {data_pointer.SOURCE_DIGEST}\nGRID_DIMS = {dims}\n" + text


@dataclass(frozen=True)
class RectilinearWindow:
    """The bound buffer of a window (see the kernel's header comment), its land mask over the
    space axes ((y, x), or (z, y, x)) and the node values of each space axis (x, y, (z))."""

    buffer: np.ndarray
    land: np.ndarray
    nodes: tuple[np.ndarray, ...]


def read_rectilinear_window(source: DataSource, ranges: dict[str, tuple[int, int]]) -> RectilinearWindow:
    """Read the nodes ``ranges`` (inclusive index ranges by role: x, y, (z,) t) and their real
    neighbours, padded, into the kernel's buffer."""
    roles = source.axis_names  # x, y, (z,) t
    order = roles[::-1]  # the arrays' axes: t, (z,) y, x
    nodes = {role: np.asarray(values) for role, values in zip(roles, source.nodes)}
    names = {role: getattr(source, ROLE_NAMES[role]) for role in roles}
    lows = {r: max(0, ranges[r][0] - 1) for r in roles}
    highs = {r: min(len(nodes[r]) - 1, ranges[r][1] + 1) for r in roles}
    region = {names[r]: slice(lows[r], highs[r] + 1) for r in order}
    velocities = (source.u, source.v) + ((source.w,) if source.w else ())
    with source.open() as dataset:
        arrays = [np.asarray(dataset.read(name, region), dtype=float) for name in velocities]
        water = (dataset.read(source.mask, {names[r]: region[names[r]] for r in order[1:]}) != 0
                 if source.mask else True)
    check_speeds(source, arrays)
    finite = np.logical_and.reduce([np.isfinite(a) for a in arrays])
    land_nodes = (~(finite & water)).any(axis=0)
    arrays = [fill_land(a, land_nodes) for a in arrays]
    padded_nodes = {}
    padded = []
    for array in arrays:
        for axis, role in enumerate(order):
            start = ranges[role][0] - lows[role]
            stop = start + ranges[role][1] - ranges[role][0] + 1
            array, padded_nodes[role] = pad_axis(array, axis, nodes[role][lows[role]: highs[role] + 1], start, stop)
        padded.append(array)
    space = order[1:]
    inner = tuple(slice(ranges[r][0] - lows[r], ranges[r][1] - lows[r] + 1) for r in space)
    counts = {r: ranges[r][1] - ranges[r][0] + 1 for r in roles}
    mask = np.zeros(tuple(counts[r] + 2 for r in space))
    mask[(slice(1, -1),) * len(space)] = land_nodes[inner]
    header = np.zeros(GRID_HEADER)
    header[:9] = (counts["t"], counts.get("z", 1), counts["y"], counts["x"], 1.0 if source.sphere else 0.0,
                  source.radius, source.velocity_scale, source.vertical_scale, source.z_metres)
    buffer = np.concatenate([header, *(padded_nodes[r] for r in roles), *(a.ravel() for a in padded), mask.ravel()])
    window_nodes = tuple(nodes[r][ranges[r][0]: ranges[r][1] + 1] for r in roles[:-1])
    return RectilinearWindow(np.ascontiguousarray(buffer), mask[(slice(1, -1),) * len(space)] > 0, window_nodes)


@dataclass(frozen=True, eq=False, repr=False)  # the one-line repr of VelocityDataSystem
class RectilinearVelocitySystem(VelocityDataSystem):
    """A flow interpolated from data on a rectilinear grid, 2-D or 3-D (module docstring)."""

    @property
    def n_state(self) -> int:
        return 3 if self.source.w else 2

    @property
    def engine_name(self) -> str:
        """One compiled engine per state dimension and geometry (the data are bound at run time;
        the sphere's engine has the LD's metric)."""
        return f"velocity_data_rectilinear{self.n_state}" + ("_sphere" if self.source.sphere else "")

    @property
    def ld_metric_source(self) -> str:
        """On the sphere the LD in km and the data's velocity units, as on a uniform grid
        (``kernels/sphere_ld_metric.py``), and in 3-D with w in u's units
        (``kernels/vertical_ld_metric.py``); on the plane none (the state's units)."""
        if not self.source.sphere:
            return ""
        text = sphere_ld_metric_source(5, 6)
        if self.source.w:
            text += "\n\n" + resources.files(kernels).joinpath("vertical_ld_metric.py").read_text()
        return text

    @property
    def description(self) -> str:
        kind = "longitude/latitude" if self.source.sphere else "plane"
        components = ", ".join(c for c in (self.source.u, self.source.v, self.source.w) if c)
        return f"velocity data {components} from {self.source.label} ({kind}, rectilinear grid)"

    @property
    def coordinate_bound(self) -> float:
        """A bound on every coordinate of any trajectory that can move (twice the data's extent,
        and 720 degrees on the sphere, where longitudes wrap): the engine raises its escape radius to it."""
        extent = max(max(abs(values[0]), abs(values[-1])) for values in self.source.nodes[:-1])
        return max(2.0 * extent, 720.0 if self.source.sphere else 0.0)

    def data_window(self, start: float, end: float) -> RectilinearWindow:
        """The window of the data [start, end] needs (read once; the last few are kept)."""
        self.check_times(start, end)
        low, high = sorted((start, end))
        roles = self.source.axis_names
        nodes = dict(zip(roles, (np.asarray(values) for values in self.source.nodes)))
        ranges = {"t": node_window(nodes["t"], low, high)}
        for role, coordinate in zip(roles[:-1], self.coordinates):
            if self.window and coordinate in self.window:
                ranges[role] = node_window(nodes[role], *self.window[coordinate])
            else:
                ranges[role] = (0, len(nodes[role]) - 1)
        key = tuple(sorted(ranges.items()))
        if key not in self._windows:
            self._windows[key] = read_rectilinear_window(self.source, ranges)
        return self._windows[key]

    def grid_positions(self, window: RectilinearWindow, end_states: np.ndarray) -> list[np.ndarray]:
        """Each state component in the grid's numbers (a longitude modulo 360 from the grid's first)."""
        positions = [end_states[:, d] for d in range(self.n_state)]
        if self.source.sphere:  # as the kernel: unwrapped only where needed
            first = window.nodes[0][0]
            east = positions[0] - first
            positions[0] = np.where((east < 0.0) | (east >= 360.0), first + np.mod(east, 360.0), positions[0])
        return positions

    def stop_flags(self, end_states: np.ndarray, start: float, end: float) -> dict[str, np.ndarray]:
        """Where trajectories stopped: ``on_land`` (in a cell with a land node: the sea floor too) and
        ``left_data`` (outside the data's extent, its levels or its window), where the kernel stops them."""
        window = self.data_window(start, end)
        positions = self.grid_positions(window, end_states)
        outside = np.zeros(len(end_states), dtype=bool)
        cells = []
        for values, nodes in zip(positions, window.nodes):
            outside |= ~((values >= nodes[0]) & (values <= nodes[-1]))
            cells.append(np.clip(np.searchsorted(nodes, np.nan_to_num(values), side="right") - 1, 0, len(nodes) - 2))
        in_land_cell = np.zeros(len(end_states), dtype=bool)
        for corner in np.ndindex(*(2,) * self.n_state):  # the land mask's axes are (z,) y, x
            in_land_cell |= window.land[tuple(cells[d] + corner[d] for d in reversed(range(self.n_state)))]
        return {"on_land": in_land_cell & ~outside, "left_data": outside}

    def stop_lines(self, end_states: np.ndarray, start: float, end: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The grid line (plane, in 3-D) each stopped trajectory crossed last, as
        :meth:`VelocityDataSystem.stop_lines` says: (state index, its value in the state's own
        numbers, +1 from below or -1 from above). Inside the grid (a land cell) the nearest of the
        cell's sides in units of the cell's width, a side the point lies exactly on last (a
        coordinate that never moved); outside, the edge passed."""
        window = self.data_window(start, end)
        positions = self.grid_positions(window, end_states)
        lines, distances, outsides = [], [], []
        for values, nodes in zip(positions, window.nodes):
            cell = np.clip(np.searchsorted(nodes, np.nan_to_num(values), side="right") - 1, 0, len(nodes) - 2)
            fraction = (values - nodes[cell]) / (nodes[cell + 1] - nodes[cell])
            below, above = values < nodes[0], values > nodes[-1]
            nearest = np.where(fraction <= 0.5, nodes[cell], nodes[cell + 1])
            lines.append(np.where(below, nodes[0], np.where(above, nodes[-1], nearest)))
            distance = np.minimum(np.abs(fraction), np.abs(1.0 - fraction))
            # exactly on a line: a coordinate that did not move (a start on a grid line), not a crossing
            distances.append(np.where(below | above, np.inf, np.where(distance == 0.0, 1.0, distance)))
            outsides.append(below | above)
        lines, distances, outside = np.column_stack(lines), np.column_stack(distances), np.column_stack(outsides)
        axis = np.where(outside.any(axis=1), np.argmax(outside, axis=1), np.argmin(distances, axis=1))
        rows = np.arange(len(end_states))
        gap = np.column_stack(positions)[rows, axis] - lines[rows, axis]  # past the line, in the state's units
        return axis, end_states[rows, axis] - gap, np.where(gap >= 0.0, 1, -1)


def make_rectilinear_system(name: str, source: DataSource, window: dict | None, spec: dict) -> RectilinearVelocitySystem:
    """The system of a checked rectilinear ``source`` (:func:`.source.open_source`)."""
    dims = 3 if source.w else 2
    text = rectilinear_kernel_source(dims)
    (rhs,) = njit_functions(text, ("rhs",), f"velocity_data_rectilinear{dims}")
    coordinates = (source.x, source.y, source.z) if source.w else (source.x, source.y)
    return RectilinearVelocitySystem(name=name, coordinates=coordinates, source=source, window=window,
                                     kernel_source=text, rhs=rhs, spec=spec)
