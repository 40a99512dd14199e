"""Velocity data on a curvilinear grid (2-D coordinates, e.g. rotated): integrated in index space.

The state the engine integrates is the grid's fractional indices (i, j). Once per window the
velocities at the nodes are turned into index velocities: grid components rotated east and
north by the grid's angle (the file's, else the coordinates'), then d(i, j)/dt = J^-1 dX/dt,
with J = dX/d(i, j) at the node (:mod:`.grid_geometry`: fourth-order differences) and dX/dt the
velocity in coordinate units (degrees on the sphere). Between nodes the regular grid's kernel
(``kernels/gridded_velocity.py``, cubic convolution in i, j and t) interpolates them on the unit
grid, unchanged; land and the grid's edge stop trajectories as they do there. Uneven times (monthly
means) are interpolated by the same kernel with the rectilinear grid's non-uniform cubic in time
(the window's header slot :data:`.regular.TIMES_AT`), exact for quadratics in time.

Starts are mapped to indices by Newton's method on the interpolated coordinates, end states
back by that interpolant (:meth:`CurvilinearVelocitySystem.engine_states`,
:meth:`~CurvilinearVelocitySystem.states_from_engine`: the engine calls them). The LD is taken
in physical units (``kernels/curvilinear_ld_metric.py``): the stage's index velocity times the
metric P, interpolated from its nodes, gives the velocity in coordinate units per time unit on
the plane and in the data's velocity units on the sphere (the arc length in km), as a regular
grid's LD.

A spatial ``window`` (an interval of each coordinate: x, y or longitude, latitude) is read as the
box of nodes that covers it (:func:`window_box`): the nodes inside it and one more each side.
Only that box is read per window of times (with the stencil's ring of real neighbours), and its
edges are the data's edges; the geometry is built over the box and :data:`GEOMETRY_MARGIN` more
nodes, so that inside the box every value is the whole grid's bit for bit.

A C-grid's face velocities are :mod:`.staggered`'s; a tripolar global grid without a window
(joined across its fold) is :mod:`.folded`'s. Not yet: other grids through a pole or folded, 3-D
data; a map's region box (variable-time LDs).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from ...errors import ConfigError
from ...jitcache import njit_functions
from .folded import folded_grid, make_folded_system
from .grid_geometry import GridGeometry, angle_from_coordinates, wrapped
from .regular import DataWindow, VelocityDataSystem, extend_keys, index_window, kernel_source, read_window
from .source import DataSource, at_least_three_nodes, kernel_text, node_window

#: The largest difference (radians) between a file's rotation angle and the coordinates' before the
#: file's is refused (an angle in degrees labelled radians, or of another grid, differs by far more).
ANGLE_TOLERANCE = 0.05
#: Header slots the curvilinear LD metric reads (the regular kernel's header leaves them free).
METRIC_AT, ARC_FACTOR_AT = 12, 13
#: Nodes of the geometry beyond the box a window reads: the stencil's one real neighbour, and two
#: more for the metric's centred fourth-order differences there (then the whole grid's, bit for bit).
GEOMETRY_MARGIN = 3

#: An inclusive box of a grid's nodes: ((first column i, last), (first row j, last)).
NodeBox = tuple[tuple[int, int], tuple[int, int]]


@dataclass(frozen=True)
class IndexVelocities:
    """How a window's velocities become index velocities, and the LD's metric P at the nodes."""

    inverse: np.ndarray  # (ny, nx, 2, 2): d(i, j)/d(x, y)
    rate: np.ndarray  # (ny, nx, 2): coordinate units per time unit per data velocity unit, x and y
    cos_angle: np.ndarray | None  # grid components: the angle turning them east and north
    sin_angle: np.ndarray | None
    metric: np.ndarray  # (ny, nx, 4): the LD's P (physical velocity per index velocity), row by row

    def convert(self, u: np.ndarray, v: np.ndarray, rows: slice, columns: slice) -> tuple[np.ndarray, np.ndarray]:
        """Index velocities from u, v read at nodes (time, rows, columns)."""
        if self.cos_angle is not None:
            c, s = self.cos_angle[rows, columns], self.sin_angle[rows, columns]
            u, v = u * c - v * s, u * s + v * c
        rate = self.rate[rows, columns]
        dx, dy = u * rate[..., 0], v * rate[..., 1]
        inverse = self.inverse[rows, columns]
        return (inverse[..., 0, 0] * dx + inverse[..., 0, 1] * dy, inverse[..., 1, 0] * dx + inverse[..., 1, 1] * dy)


def index_velocities(source: DataSource, geometry: GridGeometry,
                     angle: np.ndarray | None) -> tuple[IndexVelocities, float]:
    """The node-wise conversion of ``source``'s velocities to index velocities (module docstring),
    and the arc length's factor to the LD's units."""
    jacobian = geometry.jacobian
    determinant = jacobian[..., 0, 0] * jacobian[..., 1, 1] - jacobian[..., 0, 1] * jacobian[..., 1, 0]
    if not np.all(np.abs(determinant) > 0.0):
        j, i = np.argwhere(~(np.abs(determinant) > 0.0))[0]
        raise ConfigError(f"velocity data {source.label}: the curvilinear grid {source.grid_coordinates} folds or "
                          f"collapses at node (j, i) = ({j}, {i}): its cells must not degenerate")
    inverse = np.linalg.inv(jacobian)
    rate = np.full(geometry.shape + (2,), source.velocity_scale)
    physical = jacobian.copy()  # P: physical velocity per index velocity
    arc_factor = 1.0
    if source.sphere:
        degrees = 180.0 / math.pi
        cos_lat = np.cos(np.radians(geometry.y))
        rate[..., 0] *= degrees / (source.radius * cos_lat)
        rate[..., 1] *= degrees / source.radius
        physical[..., 0, :] *= (source.radius * cos_lat / degrees / source.velocity_scale)[..., None]
        physical[..., 1, :] *= source.radius / degrees / source.velocity_scale
        arc_factor = source.velocity_scale / 1000.0  # the data's velocity unit times a time unit in km
    cos_angle = sin_angle = None
    if source.components == "grid":
        if angle is None:
            angle = angle_from_coordinates(geometry)
        cos_angle, sin_angle = np.cos(angle), np.sin(angle)
    metric = physical.reshape(geometry.shape + (4,))
    return IndexVelocities(inverse, rate, cos_angle, sin_angle, metric), arc_factor


@dataclass(frozen=True, eq=False)
class CurvilinearVelocitySystem(VelocityDataSystem):
    """A flow interpolated from data on a curvilinear grid, integrated in its indices (module docstring)."""

    geometry: GridGeometry = field(default=None, repr=False)
    velocities: IndexVelocities = field(default=None, repr=False)
    arc_factor: float = 1.0
    box: NodeBox = ((0, 0), (0, 0))  # the nodes read: the whole grid, or the box covering a ``window``

    @property
    def engine_name(self) -> str:
        """One compiled engine for every curvilinear grid, plane or sphere (P carries the geometry)."""
        return "velocity_data_curvilinear"

    @property
    def ld_metric_source(self) -> str:
        return kernel_text("curvilinear_ld_metric.py")

    @property
    def description(self) -> str:
        kind = "longitude/latitude" if self.source.sphere else "plane"
        return (f"velocity data {self.source.u}, {self.source.v} from {self.source.label} ({kind}, curvilinear grid "
                f"{self.source.grid_coordinates[0]}, {self.source.grid_coordinates[1]})")

    @property
    def coordinate_bound(self) -> float:
        """A bound on the indices of any trajectory that can move (the grid's, twice)."""
        return 2.0 * max(self.source.x_grid[2], self.source.y_grid[2]) + 4.0

    def engine_states(self, states: np.ndarray) -> np.ndarray:
        """The fractional indices (i, j) of states (x, y); off the grid beyond its edge cells' cubics: NaN."""
        return self.geometry.indices(np.asarray(states, dtype=float))

    def states_from_engine(self, engine_states: np.ndarray) -> np.ndarray:
        return self.geometry.coordinates(engine_states)

    @property
    def grid_shape(self) -> tuple[int, int]:
        """The whole grid's (ny, nx)."""
        return self.source.y_grid[2], self.source.x_grid[2]

    def convert(self, u: np.ndarray, v: np.ndarray, rows: slice, columns: slice) -> tuple[np.ndarray, np.ndarray]:
        """Index velocities from u, v read at the whole grid's ``rows``, ``columns`` (the geometry's box)."""
        i0, j0 = self.geometry.offset
        return self.velocities.convert(u, v, slice(rows.start - j0, rows.stop - j0),
                                       slice(columns.start - i0, columns.stop - i0))

    def data_window(self, start: float, end: float) -> DataWindow:
        """The window of the data [start, end] needs over the box read (:attr:`box`), as index
        velocities with the LD's metric after them (read once; the last few are kept)."""
        self.check_times(start, end)
        times = time_indices(self.source, *sorted((start, end)))
        if times not in self._windows:
            index_source = replace(self.source, sphere=False, velocity_scale=1.0)
            window = read_window(index_source, times, *self.box, convert=self.convert)
            metric = box_padded(self.velocities.metric, self.box, self.geometry.offset, self.grid_shape)
            buffer = np.concatenate([window.buffer, metric.ravel()])
            buffer[METRIC_AT], buffer[ARC_FACTOR_AT] = len(window.buffer), self.arc_factor
            self._windows[times] = replace(window, buffer=np.ascontiguousarray(buffer))
        return self._windows[times]

    def vector_field(self, state: np.ndarray, t: float = 0.0) -> np.ndarray:
        """d(x, y)/dt at a state (x, y): the index velocity times the interpolated coordinates' Jacobian."""
        indices = self.engine_states(np.asarray(state, dtype=float)[None])[0]
        rate = VelocityDataSystem.vector_field(self, indices, t)
        return self.geometry.coordinate_jacobian(indices[None])[0] @ rate

    @property
    def wraps_longitude(self) -> bool:
        """The engine's state is indices, never a longitude."""
        return False

    def stop_flags(self, end_states: np.ndarray, start: float, end: float) -> dict[str, np.ndarray]:
        """Where trajectories stopped (as :meth:`VelocityDataSystem.stop_flags`), in index space;
        an end state whose indices are not found is off the grid."""
        return super().stop_flags(np.nan_to_num(self.engine_states(end_states), nan=-1.0), start, end)

    def stop_lines(self, end_states: np.ndarray, start: float, end: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The grid line each stopped trajectory crossed last, as an index (i or j) and its value:
        the engine's state, so its crossing is located where the engine integrates."""
        return super().stop_lines(np.nan_to_num(self.engine_states(end_states), nan=-1.0), start, end)


def time_indices(source: DataSource, low: float, high: float) -> tuple[int, int]:
    """The time indices [a, b] whose intervals cover [low, high]: of even times, or of uneven ones
    (``source.nodes``, the kernel then interpolating them by the non-uniform cubic)."""
    if source.nodes is None:
        return index_window(source.t_grid, low, high)
    return node_window(np.asarray(source.nodes[-1]), low, high)


def box_padded(values: np.ndarray, box: NodeBox, offset: tuple[int, int], shape: tuple[int, int]) -> np.ndarray:
    """``values`` (a geometry's nodes from the whole grid's node ``offset``, (ny, nx, ...)) over
    ``box`` padded by one node each side as the velocities are: the real neighbour where the whole
    grid (``shape``) has one, else Keys' extrapolation (the whole grid: :func:`.grid_geometry.keys_padded`)."""
    out = np.asarray(values, dtype=float)
    for axis, (low, high), first, count in ((0, box[1], offset[1], shape[0]), (1, box[0], offset[0], shape[1])):
        a = np.moveaxis(out, axis, 0)
        start, stop = low - first, high - first + 1
        below = a[start - 1] if low > 0 else None
        above = a[stop] if high < count - 1 else None
        out = np.moveaxis(extend_keys(a[start:stop], 0, below, above), 0, axis)
    return out


def region_of(source: DataSource, geometry: GridGeometry) -> dict[str, slice]:
    """The indexers of a geometry's nodes in the dataset (its index dimensions)."""
    (i0, j0), (ny, nx) = geometry.offset, geometry.shape
    return {source.y: slice(j0, j0 + ny), source.x: slice(i0, i0 + nx)}


def file_angle(source: DataSource, geometry: GridGeometry) -> np.ndarray | None:
    """The file's rotation angle in radians at the geometry's nodes, checked against the coordinates'
    (a ConfigError names the variable if they differ by more than :data:`ANGLE_TOLERANCE`, e.g.
    degrees read as radians)."""
    if source.angle is None:
        return None
    with source.open() as dataset:
        values = np.asarray(dataset.read(source.angle, region_of(source, geometry)), dtype=float) * source.angle_scale
    if not np.all(np.isfinite(values)):
        raise ConfigError(f"velocity data {source.label}: the angle variable {source.angle!r} has missing values")
    difference = np.abs(wrapped(values - angle_from_coordinates(geometry)))
    if difference.max() > ANGLE_TOLERANCE:
        j, i = np.unravel_index(int(np.argmax(difference)), difference.shape)
        i, j = i + geometry.offset[0], j + geometry.offset[1]
        raise ConfigError(f"velocity data {source.label}: the angle variable {source.angle!r} differs from the grid "
                          f"coordinates' rotation by {difference.max():.3g} rad at node (j, i) = ({j}, {i}) (read "
                          f"with its units as {source.angle_scale:g} rad per unit): is it in the wrong unit, or of "
                          "another grid?")
    return values


def window_box(source: DataSource, x: np.ndarray, y: np.ndarray, window: dict, names: tuple[str, str],
               key: str) -> NodeBox:
    """The box of nodes whose cells cover ``window`` (an interval of each coordinate ``names``: x
    and y, or longitude and latitude) on a grid of nodes ``x``, ``y``: the nodes inside it and one
    more each side, within the grid, at least three a side. A ConfigError naming ``key`` if no node is inside."""
    (x_low, x_high), (y_low, y_high) = window[names[0]], window[names[1]]
    if source.sphere:  # a longitude interval eastward from x_low, in either convention
        inside_x = np.mod(x - x_low, 360.0) <= x_high - x_low
    else:
        inside_x = (x >= x_low) & (x <= x_high)
    inside = inside_x & (y >= y_low) & (y <= y_high)
    if not inside.any():
        raise ConfigError(f"config key '{key}': no node of the curvilinear grid {source.grid_coordinates} of "
                          f"{source.label} lies in the window {names[0]} {list(window[names[0]])}, {names[1]} "
                          f"{list(window[names[1]])} (the grid spans {names[0]} [{x.min():.6g}, {x.max():.6g}], "
                          f"{names[1]} [{y.min():.6g}, {y.max():.6g}]); give a window on the grid, a cell wide at least")
    box = []
    for axis, count in ((1, x.shape[1]), (0, x.shape[0])):
        nodes = np.flatnonzero(inside.any(axis=1 - axis))
        box.append(at_least_three_nodes(max(0, int(nodes[0]) - 1), min(count - 1, int(nodes[-1]) + 1), count))
    return box[0], box[1]


def curvilinear_parts(source: DataSource, window: dict | None = None, names: tuple[str, str] = ("x", "y"),
                      key: str = "window") -> tuple[GridGeometry, IndexVelocities, float, NodeBox]:
    """A checked curvilinear ``source``'s geometry, its velocities' conversion and the LD's metric,
    the arc length's factor, and the box of nodes read: the whole grid, or the box covering
    ``window`` (:func:`window_box`: an interval of each coordinate ``names``; ``key`` names it), the geometry then over the box and
    :data:`GEOMETRY_MARGIN` nodes more each side."""
    with source.open() as dataset:
        x, y = (np.asarray(dataset.read(variable, {}), dtype=float) for variable in source.grid_coordinates)
    ny, nx = x.shape
    centre = float(x[ny // 2, nx // 2]) if source.sphere else None  # the whole grid's branch of longitude
    if window is None:
        box = ((0, nx - 1), (0, ny - 1))
    else:
        box = window_box(source, x, y, window, names, key)
    (ia, ib), (ja, jb) = box
    i0, j0 = max(0, ia - GEOMETRY_MARGIN), max(0, ja - GEOMETRY_MARGIN)
    i1, j1 = min(nx, ib + GEOMETRY_MARGIN + 1), min(ny, jb + GEOMETRY_MARGIN + 1)
    geometry = GridGeometry.from_coordinates(x[j0:j1, i0:i1], y[j0:j1, i0:i1], source.sphere, centre, (i0, j0))
    del x, y  # a large grid's coordinates: only the box's are kept
    if source.sphere:
        check_no_pole(source, geometry)
    velocities, arc_factor = index_velocities(source, geometry, file_angle(source, geometry))
    return geometry, velocities, arc_factor, box


#: The largest jump of longitude (degrees) between neighbouring nodes of a grid that is neither
#: round a pole nor all round the sphere (its longitudes on one branch about its centre).
LONGITUDE_JUMP = 90.0


#: How near (degrees of arc) the nodes i and n - 1 - i of a row are when the row folds onto itself.
FOLD_TOLERANCE = 1e-6


def folded_row(x: np.ndarray, y: np.ndarray) -> str:
    """"first" or "last" if that row of a sphere's grid (longitudes ``x``, latitudes ``y``, degrees)
    folds onto itself reversed, node i on node n - 1 - i (a tripolar grid's north fold), else ""."""
    for name, row in (("last", -1), ("first", 0)):
        lam, phi = np.radians(x[row]), np.radians(y[row])
        points = np.stack([np.cos(phi) * np.cos(lam), np.cos(phi) * np.sin(lam), np.sin(phi)], axis=-1)
        if np.degrees(np.linalg.norm(points - points[::-1], axis=-1)).max() <= FOLD_TOLERANCE:
            return name
    return ""


def check_no_pole(source: DataSource, geometry: GridGeometry) -> None:
    """A ConfigError naming the coordinates if a sphere's curvilinear grid reaches a pole, goes round
    one, folds (tripolar) or goes all round the sphere: its longitudes are not one continuous branch
    (not yet read)."""
    jumps = max(np.abs(np.diff(geometry.x, axis=axis)).max() for axis in (0, 1))
    pole = np.abs(geometry.y).max() >= 90.0 - 1e-9
    fold = folded_row(geometry.x, geometry.y)
    if fold:
        raise ConfigError(f"velocity data {source.label}: the curvilinear grid {source.grid_coordinates} folds onto "
                          f"itself along its {fold} row (node i on node n - 1 - i: a tripolar grid's north fold); "
                          "a fold is joined on a grid that goes all round the sphere with its velocities at the "
                          "nodes (not a C-grid's faces)")
    if pole or jumps > LONGITUDE_JUMP:
        why = "has a node at a pole" if pole else f"jumps by {jumps:.4g} degrees of longitude between neighbours"
        raise ConfigError(f"velocity data {source.label}: the curvilinear grid {source.grid_coordinates} {why}: a grid "
                          "that reaches or goes round a pole, or all round the sphere (tripolar, a rotated pole "
                          "inside it), is not supported yet")


def grid_system(system_class: type[CurvilinearVelocitySystem], text: str, module: str, name: str, source: DataSource,
                spec: dict, coordinates: tuple[str, str], window: dict | None = None, key: str = "window",
                extra=None) -> CurvilinearVelocitySystem:
    """A system of ``system_class`` (curvilinear, or a C grid) of a checked ``source``
    (:func:`.source.open_source`) over its ``window`` (the whole grid if None; ``key`` names it):
    its grid's geometry and index velocities, the fields ``extra(geometry)`` gives (a C-grid's
    faces, over the geometry's nodes), and the kernel ``text`` compiled as the module ``module``."""
    geometry, velocities, arc_factor, box = curvilinear_parts(source, window, coordinates, key)
    fields = extra(geometry) if extra else {}
    (rhs,) = njit_functions(text, ("rhs",), module)
    return system_class(name=name, coordinates=coordinates, source=source, window=window, kernel_source=text, rhs=rhs,
                        spec=spec, geometry=geometry, velocities=velocities, arc_factor=arc_factor, box=box, **fields)


def make_curvilinear_system(name: str, source: DataSource, spec: dict, coordinates: tuple[str, str],
                            window: dict | None = None, key: str = "window") -> CurvilinearVelocitySystem:
    """The system of a checked curvilinear ``source`` (:func:`.source.open_source`) over its
    ``window``; a sphere's grid that goes all round it and ends on a north fold, read whole, is
    :mod:`.folded`'s."""
    if source.sphere and not source.staggered and window is None:
        with source.open() as dataset:
            x, y = (np.asarray(dataset.read(variable, {}), dtype=float) for variable in source.grid_coordinates)
        grid = folded_grid(source, x, y)
        if grid is not None:
            return make_folded_system(name, source, spec, coordinates, grid)
    return grid_system(CurvilinearVelocitySystem, kernel_source(), "velocity_data", name, source, spec, coordinates,
                       window, key)
