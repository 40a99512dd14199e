"""Velocity data on a global curvilinear grid (tripolar, ORCA-like): joined across its seam and its north fold.

A tripolar grid is a regular longitude/latitude grid all round the sphere up to a latitude, and
north of it a cap whose rows end on the **north fold**, across which the grid's i and j reverse:
column i continues as column P - i, with P = n - 1 (an F-point pivot: the fold's ends between
columns) or n (a T-point pivot: a column through each end). Either the last row is on the fold,
traversed twice (node i is node P - i), or, as NEMO writes it, the last row mirrors another and
is not read: the row below it (F pivot: the fold half a row above that row) or the row below the
fold (T pivot: the fold on the last row but one). The geographic North Pole is an ordinary point
of the cap; its own two poles (where its cells shrink to nothing) lie on the cap's first row,
where models put land.

The state is the 3-D position on the sphere, as on a regular global grid (:mod:`.polar`, whose
states, LD section and end states it shares): no singularity at either geographic pole. The
velocity at a point (``kernels/folded_velocity.py``) is interpolated as its 3-D Cartesian
components, by cubic convolution in the grid's indices i, j and in time: those components are one
smooth field on the sphere, with no sign flips across the fold or a pole (a velocity's grid
components change sign across the fold, u and v across a pole). The indices of a point: below
the cap, the regular part's closed form; in the cap, Gauss-Newton on the cubic convolution of the
nodes' positions from the node a lookup table of the cap's stereographic plane gives. The
stencil reads across the seam (the ring's columns), across the fold (at row F, the row F + d of
column i is row F - d of column P - i) and, when the regular part reaches the south pole (a row
at it or half a spacing from it), across that pole (row -d of column i is row d, or d - 1, of
column i + n/2).

A point where Newton does not converge (within about a cell of the cap's poles) stops there, as
on land. Not read: halo columns repeated at the seam (refused: drop them), a cap that is not a
grid's last rows, C-grid velocities on a folded grid.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ...errors import ConfigError
from ...jitcache import njit_functions
from .grid_geometry import CENTRED
from .polar import ROWS_BEYOND, PolarVelocitySystem, read_whole_grid
from .regular import DataWindow, index_window
from .source import DataSource, kernel_text

#: How near (degrees of arc) two nodes the fold pairs must be to be one node.
FOLD_TOLERANCE = 1e-6
#: How near (in longitude spacings) a row's latitudes and a column's longitudes must be to the regular part's.
REGULAR_TOLERANCE = 1e-6
#: The largest difference (radians) between a file's rotation angle and the nodes' before it is refused.
ANGLE_TOLERANCE = 0.05
#: The lookup table of first guesses in the cap: cells a side in its stereographic plane.
TABLE_SIZE = 64
#: The kernel's header length (``kernels/folded_velocity.py``'s FOLDED_HEADER).
HEADER = 24


def unit_vectors(lon: np.ndarray, lat: np.ndarray) -> np.ndarray:
    """Unit vectors (..., 3) of longitudes and latitudes in degrees."""
    lam, phi = np.radians(lon), np.radians(lat)
    return np.stack([np.cos(phi) * np.cos(lam), np.cos(phi) * np.sin(lam), np.sin(phi)], axis=-1)


def fold_mismatch(lon: np.ndarray, lat: np.ndarray, row: int = -1, pivot: int = -1, last: int = -1
                  ) -> tuple[float, int]:
    """The largest distance (degrees of arc) between node i of row ``last`` and node ``pivot`` - i
    (modulo n) of ``row`` (the same row: a row on the fold; the one below: a row mirroring it), and its column."""
    n = lon.shape[1]
    partner = (pivot - np.arange(n)) % n
    distance = np.degrees(np.linalg.norm(unit_vectors(lon[last], lat[last])
                                         - unit_vectors(lon[row], lat[row])[partner], axis=-1))
    return float(distance.max()), int(np.argmax(distance))


def goes_round(lon: np.ndarray) -> bool:
    """Whether the first row's longitudes go once round the sphere, evenly spaced eastward."""
    steps = np.mod(np.diff(np.append(lon[0], lon[0, 0])), 360.0)
    return bool(np.allclose(steps, 360.0 / lon.shape[1], rtol=0.0, atol=1e-6 * 360.0 / lon.shape[1]))


@dataclass(frozen=True, eq=False)
class FoldedGrid:
    """A tripolar grid's layout (module docstring): its regular part, its cap, its south pole."""

    lon: np.ndarray  # (ny, n) degrees
    lat: np.ndarray
    regular_rows: int  # the rows of the regular part, the last the cap's first row
    lon0: float
    dlon: float
    lat0: float
    dlat: float
    south: int | None  # None: a southern edge; 0: a row at the south pole; 1: the first row half a spacing from it
    fold: float  # the fold's row: the last row (on the fold), or half a row beyond it (a mirrored row dropped)
    pivot: int  # across the fold column i continues as column pivot - i: n - 1 (F pivot) or n (T pivot)
    points: np.ndarray = field(repr=False, default=None)  # (ny, n, 3) unit vectors

    @property
    def shape(self) -> tuple[int, int]:
        return self.lon.shape

    @property
    def cap_latitude(self) -> float:
        return self.lat0 + self.dlat * (self.regular_rows - 1)

    @property
    def first_row(self) -> int:
        """The window row of the grid's row 0 (rows beyond the south pole before it)."""
        return ROWS_BEYOND if self.south is not None else 0

    def source_rows(self, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """For grid rows ``rows`` (past the fold, or the south pole, too): the grid row each reads
        and whether its columns are mirrored (pivot - i: past the fold) or turned half round (past the pole)."""
        fold = self.fold
        source = np.where(rows > fold, np.rint(2 * fold - rows).astype(int), rows)
        if self.south is not None:
            source = np.where(rows < 0, -rows - self.south, source)
        return source, np.sign(rows - fold).clip(0) - (rows < 0)

    def extended(self, array: np.ndarray) -> np.ndarray:
        """``array`` (..., ny, n) on the window's padded rows and columns (kernel's layout, module docstring)."""
        ny, n = self.shape
        rows = np.arange(-self.first_row - 1, ny + ROWS_BEYOND + 1)
        source, kind = self.source_rows(rows)
        columns = np.arange(-1, n + 2) % n
        out = np.empty(array.shape[:-2] + (len(rows), n + 3))
        for position, (row, how) in enumerate(zip(source, kind)):
            if row < 0:  # below a southern edge: Keys' padding
                continue
            mapped = (self.pivot - columns) % n if how > 0 else (columns + n // 2) % n if how < 0 else columns
            out[..., position, :] = array[..., row, mapped]
        if self.south is None:
            out[..., 0, :] = 3 * out[..., 1, :] - 3 * out[..., 2, :] + out[..., 3, :]
        return out

    def lookup_table(self) -> tuple[np.ndarray, float]:
        """First guesses (i, j) for Newton in the cap: on a TABLE_SIZE square of its stereographic
        plane (w = (x, y) / (1 + z)), the indices of the nearest of the cap's nodes; and the square's half-width."""
        from scipy.spatial import cKDTree

        cap = self.points[self.regular_rows - 1:]
        plane = cap[..., :2] / (1.0 + cap[..., 2:])
        half = 1.05 * float(np.abs(plane).max())
        centres = -half + (np.arange(TABLE_SIZE) + 0.5) * (2.0 * half / TABLE_SIZE)
        wx, wy = np.meshgrid(centres, centres)  # [b, a]: row b of y, column a of x
        scale = 2.0 / (1.0 + wx ** 2 + wy ** 2)  # the inverse stereographic map
        targets = np.stack([wx * scale, wy * scale, scale - 1.0], axis=-1)
        _, flat = cKDTree(cap.reshape(-1, 3)).query(targets.reshape(-1, 3))
        j, i = np.unravel_index(flat, cap.shape[:2])
        table = np.stack([i, j + self.regular_rows - 1], axis=-1).astype(float)
        return table.reshape(TABLE_SIZE, TABLE_SIZE, 2), half


def folded_grid(source: DataSource, lon: np.ndarray, lat: np.ndarray) -> FoldedGrid | None:
    """The layout of a sphere's curvilinear grid that goes all round it and ends on a north fold;
    None if it does not go round. A ConfigError names the coordinates if it goes round but does not
    end on a fold whose mirrored nodes match, or has no regular longitude/latitude part below its cap."""
    names = source.grid_coordinates
    points = unit_vectors(lon, lat)
    if lon.shape[1] > 4 and np.allclose(points[:, :2], points[:, -2:], rtol=0.0, atol=1e-9):
        raise ConfigError(f"velocity data {source.label}: the curvilinear grid {names} repeats its first two columns "
                          "as its last two (a model's halo columns): drop its first and last column from every "
                          "variable, e.g. dataset.isel(x=slice(1, -1)), so that each column is read once")
    if not goes_round(lon):
        return None
    ny, n = lon.shape
    mismatch, column = fold_mismatch(lon, lat, -1, n - 1)
    fold, pivot = ny - 1.0, n - 1
    if mismatch <= FOLD_TOLERANCE:  # the last row on the fold, an F pivot
        pass
    elif fold_mismatch(lon, lat, -1, n)[0] <= FOLD_TOLERANCE:  # the last row on the fold, a T pivot
        pivot = n
    elif ny > 3 and fold_mismatch(lon, lat, -2, n - 1)[0] <= FOLD_TOLERANCE:  # F pivot, the last row mirrored
        lon, lat, ny, fold = lon[:-1], lat[:-1], ny - 1, ny - 1.5
    elif ny > 3 and max(fold_mismatch(lon, lat, -3, n)[0], fold_mismatch(lon, lat, -2, n, -2)[0]) <= FOLD_TOLERANCE:
        lon, lat, ny, fold, pivot = lon[:-1], lat[:-1], ny - 1, ny - 2.0, n  # T pivot, the last row mirrored
    else:
        raise ConfigError(f"velocity data {source.label}: the curvilinear grid {names} goes all round the sphere, but "
                          f"its last row does not fold onto itself: its nodes of columns {column} and {n - 1 - column} "
                          f"are {mismatch:.4g} degrees apart, nor does it mirror the row below it; a global "
                          "curvilinear grid is read when its last row is on a north fold whose node i is node "
                          "n - 1 - i (F pivot) or n - i (T pivot), or when it mirrors so the row below it (NEMO's "
                          "F pivot: the fold half a row above that row) or the row below the fold (NEMO's T pivot)")
    if n % 2:
        raise ConfigError(f"velocity data {source.label}: the folded grid {names} has an odd number of columns ({n})")
    dlon = 360.0 / n
    regular = 0
    while (regular < ny and np.allclose(lat[regular], lat[regular, 0], atol=REGULAR_TOLERANCE * dlon)
           and np.allclose(np.mod(lon[regular] - lon[0] + 180.0, 360.0) - 180.0, 0.0, atol=REGULAR_TOLERANCE * dlon)):
        regular += 1
    if regular == ny:
        raise ConfigError(f"velocity data {source.label}: the curvilinear grid {names} is a regular longitude/latitude "
                          "grid reaching the north pole, its last row one point: its 2-D coordinates are not read "
                          "as a fold (a pole row is continued half way round, a fold mirrored); give its 1-D "
                          "longitudes and latitudes as x and y, which are read across the poles")
    dlat = float(lat[1, 0] - lat[0, 0]) if regular > 1 else 0.0
    if regular < 4 or dlat <= 0.0 or not np.allclose(np.diff(lat[:regular, 0]), dlat, atol=REGULAR_TOLERANCE * dlat):
        raise ConfigError(f"velocity data {source.label}: the folded grid {names} has {regular} rows of evenly "
                          "spaced latitudes with the first row's longitudes before its cap; it needs at least 4 (the "
                          "regular part south of the cap, its points located by longitude and latitude)")
    cap_latitude = float(lat[regular - 1, 0])
    if lat[regular:].size and lat[regular:].min() < cap_latitude - REGULAR_TOLERANCE:  # (a T pivot's poles on it)
        raise ConfigError(f"velocity data {source.label}: the cap of the folded grid {names} reaches "
                          f"{lat[regular:].min():.6g} degrees, south of its first row ({cap_latitude:.6g}); "
                          "its cap must lie north of it")
    gap = float(lat[0, 0]) + 90.0
    south = None
    if abs(gap) <= REGULAR_TOLERANCE * dlat:
        south = 0
    elif abs(gap - 0.5 * dlat) <= REGULAR_TOLERANCE * dlat:
        south = 1
    elif gap < dlat:
        raise ConfigError(f"velocity data {source.label}: the folded grid {names} starts {gap:.6g} degrees from the "
                          f"south pole, less than its spacing {dlat:.6g} but neither at the pole nor half a spacing "
                          "from it, so no row across the pole continues the grid")
    return FoldedGrid(lon, lat, regular, float(lon[0, 0]), dlon, float(lat[0, 0]), dlat, south, fold, pivot,
                      unit_vectors(lon, lat))


def grid_angle(grid: FoldedGrid) -> np.ndarray:
    """The angle (radians, counter-clockwise) from east to the grid's i direction at each node, from
    the nodes' 3-D positions (fourth-order centred differences along the ring): no singularity at a pole."""
    along = sum(w * np.roll(grid.points, 2 - k, axis=1) for k, w in enumerate(CENTRED))
    lam, phi = np.radians(grid.lon), np.radians(grid.lat)
    east = np.stack([-np.sin(lam), np.cos(lam), np.zeros_like(lam)], axis=-1)
    north = np.stack([-np.sin(phi) * np.cos(lam), -np.sin(phi) * np.sin(lam), np.cos(phi)], axis=-1)
    return np.arctan2(np.einsum("...k,...k", along, north), np.einsum("...k,...k", along, east))


def folded_angle(source: DataSource, grid: FoldedGrid) -> np.ndarray | None:
    """None for east and north components; for grid components the angle turning them east and
    north: the file's (a ConfigError names it if it differs from the nodes' by more than
    ``tolerance`` radians), else the nodes' (:func:`grid_angle`)."""
    if source.components != "grid":
        return None
    angle = grid_angle(grid)
    if source.angle is None:
        return angle
    with source.open() as dataset:
        values = np.asarray(dataset.read(source.angle, {}), dtype=float) * source.angle_scale
    difference = np.abs(np.mod(values - angle + math.pi, 2 * math.pi) - math.pi)
    if not np.all(np.isfinite(values)) or difference.max() > ANGLE_TOLERANCE:
        raise ConfigError(f"velocity data {source.label}: the angle variable {source.angle!r} has missing values or "
                          f"differs from the folded grid's rotation by up to {np.nanmax(difference):.3g} rad (read "
                          f"as {source.angle_scale:g} rad per unit): is it in the wrong unit, or of another grid?")
    return values


def read_folded_window(source: DataSource, grid: FoldedGrid, angle: np.ndarray | None, times: tuple[int, int],
                       table: tuple[np.ndarray, float]) -> DataWindow:
    """The whole grid's window over time nodes ``times`` (inclusive), as ``kernels/folded_velocity.py`` reads it."""
    ta, tb = times
    n = grid.shape[1]
    u, v, land_nodes, t_low = read_whole_grid(source, times, grid.shape)
    if angle is not None:  # grid components turned east and north
        c, s = np.cos(angle), np.sin(angle)
        u, v = u * c - v * s, u * s + v * c
    lam, phi = np.radians(grid.lon), np.radians(grid.lat)
    east = np.stack([-np.sin(lam), np.cos(lam), np.zeros_like(lam)])
    north = np.stack([-np.sin(phi) * np.cos(lam), -np.sin(phi) * np.sin(lam), np.cos(phi)])
    velocity = source.velocity_scale * (u[:, None] * east + v[:, None] * north)  # (time, 3, ny, n)
    velocity = grid.extended(velocity)
    first = ta - t_low  # the window's times, padded by the real neighbours where read, else Keys'
    last = first + tb - ta
    low = velocity[first - 1] if first > 0 else 3 * velocity[first] - 3 * velocity[first + 1] + velocity[first + 2]
    high = velocity[last + 1] if last + 1 < len(velocity) else 3 * velocity[last] - 3 * velocity[last - 1] + velocity[last - 2]
    velocity = np.concatenate([low[None], velocity[first:last + 1], high[None]])
    velocity = velocity.transpose(2, 3, 0, 1)  # (rows, columns, time, 3): the kernel's layout
    points = grid.extended(np.moveaxis(grid.points, -1, 0))
    points = np.moveaxis(points, 0, -1)
    land = grid.extended(land_nodes.astype(float))[1:-1, 1:-1] > 0.5  # window rows, ring columns 0 .. n
    rows = land.shape[0]
    cells = np.zeros((rows, n))
    cells[:-1] = land[:-1, :-1] | land[:-1, 1:] | land[1:, :-1] | land[1:, 1:]
    values, half = table
    header = np.zeros(HEADER)
    header[:13] = (tb - ta + 1, rows, n, grid.lon0, grid.dlon, grid.lat0, grid.dlat,
                   source.t_grid[0] + source.t_grid[1] * ta, source.t_grid[1], grid.first_row, source.radius,
                   source.velocity_scale, grid.cap_latitude)
    header[13] = HEADER + velocity.size
    header[14] = header[13] + points.size
    header[15] = header[14] + cells.size
    header[16:20] = (TABLE_SIZE, half, grid.fold, grid.pivot)
    buffer = np.concatenate([header, velocity.ravel(), points.ravel(), cells.ravel(), values.ravel()])
    x_grid = (0.0, 1.0, n)
    y_grid = (-float(grid.first_row), 1.0, rows)
    return DataWindow(np.ascontiguousarray(buffer), land[:, :n].copy(), x_grid, y_grid)


def folded_kernel_source() -> str:
    """The folded grid's kernel text (with the pointer module's digest: its code is inlined into the kernel)."""
    from .. import data_pointer

    return f"# data_pointer {data_pointer.SOURCE_DIGEST}\n" + kernel_text("folded_velocity.py")


@dataclass(frozen=True, eq=False)
class FoldedVelocitySystem(PolarVelocitySystem):
    """A flow on a tripolar global grid, integrated as 3-D positions (module docstring)."""

    grid: FoldedGrid = field(default=None, repr=False)
    angle: np.ndarray | None = field(default=None, repr=False)
    table: tuple = field(default=None, repr=False)

    @property
    def engine_name(self) -> str:
        return "velocity_data_folded"

    @property
    def description(self) -> str:
        return (f"velocity data {self.source.u}, {self.source.v} from {self.source.label} (longitude/latitude, "
                f"tripolar grid {self.source.grid_coordinates[0]}, {self.source.grid_coordinates[1]}, joined "
                "across its seam, fold and poles)")

    def states_from_engine(self, engine_states: np.ndarray) -> np.ndarray:
        """(lon, lat) of 3-D positions, the longitude from the grid's first column's cell edge on."""
        x, y, z = np.asarray(engine_states, dtype=float)[:, :3].T
        first = self.grid.lon0 - 0.5 * self.grid.dlon
        lon = first + np.mod(np.degrees(np.arctan2(y, x)) - first, 360.0)
        return np.column_stack([lon, np.degrees(np.arctan2(z, np.hypot(x, y)))])

    def data_window(self, start: float, end: float) -> DataWindow:
        """The whole grid's window over [start, end] (read once; the last few are kept)."""
        self.check_times(start, end)
        times = index_window(self.source.t_grid, *sorted((start, end)))
        if times not in self._windows:
            self._windows[times] = read_folded_window(self.source, self.grid, self.angle, times, self.table)
        return self._windows[times]

    def stop_flags(self, end_states: np.ndarray, start: float, end: float) -> dict[str, np.ndarray]:
        """Where trajectories stopped: ``left_data`` south of a southern edge, ``on_land`` where
        the kernel gives no velocity otherwise (a land cell, or the cap's poles)."""
        states = np.asarray(end_states, dtype=float)
        still = np.zeros(len(states), dtype=bool)
        rate = np.empty(self.engine_dimension)
        with self.time_window(start, end):
            for row, state in enumerate(self.engine_states(states)):
                self.rhs(state, float(end), rate)
                still[row] = rate[5] == 0.0
        south = states[:, 1] < self.grid.lat0 if self.grid.south is None else np.zeros(len(states), dtype=bool)
        return {"on_land": still & ~south, "left_data": still & south}


def make_folded_system(name: str, source: DataSource, spec: dict, coordinates: tuple[str, str],
                       grid: FoldedGrid) -> FoldedVelocitySystem:
    """The system of a checked tripolar ``source`` whose layout is ``grid`` (:func:`folded_grid`);
    a ConfigError names the time variable if its times are uneven (the kernel's are even)."""
    if source.nodes is not None:
        raise ConfigError(f"velocity data {source.label}: the times of {source.time!r} are unevenly spaced; a tripolar "
                          "global grid is read at evenly spaced times")
    angle = folded_angle(source, grid)
    text = folded_kernel_source()
    (rhs,) = njit_functions(text, ("rhs",), "velocity_data_folded")
    return FoldedVelocitySystem(name=name, coordinates=coordinates, source=source, window=None, kernel_source=text,
                                rhs=rhs, spec=spec, grid=grid, angle=angle, table=grid.lookup_table())


__all__ = ["FoldedGrid", "FoldedVelocitySystem", "folded_grid", "make_folded_system"]
