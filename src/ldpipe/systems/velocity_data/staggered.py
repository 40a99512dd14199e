"""Velocity data on an Arakawa C-grid: u and v on the faces of a curvilinear grid's cells, a coast a wall.

ROMS and CROCO write u on the faces between the cells' centres (rho points) (j, i) and (j, i + 1),
an array (ny, nx - 1), and v on those between (j, i) and (j + 1, i), (ny - 1, nx), each the
velocity normal to its face (along the grid's i and j). A ``velocity_data`` entry on a curvilinear
grid whose u and v have these shapes is read as such (:func:`.source.c_grid`); NEMO's, on arrays of
the centres' shape (their last column and row the outer faces, not read), when the entry says
``c_grid: nemo``. Either is integrated in
index space as :mod:`.curvilinear` does, with the staggered interpolant of
``kernels/staggered_velocity.py``: a face's velocity (normal to the face) becomes an index
velocity by the grid's metrics (:mod:`.grid_metrics`): the file's, as the flux through the face
(u times its length) over the cell's area, or from the coordinates u / (L sin theta), L the
distance between the two centres it separates (on the sphere great-circle metres) and theta the
angle of the face to that line; linear across a cell between its two faces and constant along
them. A face next to a land centre (the ``mask``'s zeros) or with a missing value is closed (0),
so a coast is a wall: trajectories come up to it and never cross; only land centres are land. The LD is physical, by the centres' metric
(``kernels/curvilinear_ld_metric.py``), as on a collocated curvilinear grid.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .curvilinear import (
    ARC_FACTOR_AT, METRIC_AT, CurvilinearVelocitySystem, NodeBox, box_padded, grid_system, time_indices,
)
from .grid_geometry import GridGeometry
from .grid_metrics import FaceConversion, face_conversion
from .regular import HEADER, DataWindow, extend_keys
from .source import DataSource, check_speeds, kernel_text, pad_axis

#: Header slots of the staggered kernel beyond the LD metric's: where V and the land nodes start.
V_AT, LAND_AT = 14, 15
#: The header slot of where uneven times start in the buffer (0: even times, from slots 7 and 8).
STAGGERED_TIMES_AT = 9
#: How far past a wall's face (in cells) a point counts as on it, at sea: a step may overshoot the
#: wall by about the integrator's tolerance, and the kernel turns such a point back (its NEAR_WALL).
FACE_SLACK = 1e-3


def staggered_kernel_source() -> str:
    """The C-grid kernel's text, with the pointer module's digest (its code is inlined into the kernel)."""
    from .. import data_pointer

    return (f"# data_pointer {data_pointer.SOURCE_DIGEST}\n" + kernel_text("nonuniform_cubic_weights.py")
            + kernel_text("uneven_time_weights.py")
            + kernel_text("staggered_velocity.py"))


def face_lengths(geometry: GridGeometry, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """The distances between neighbouring centres along i, (ny, nx - 1), and along j, (ny - 1, nx):
    in the coordinates' units on the plane, great-circle metres on the sphere."""
    x, y = geometry.x, geometry.y

    def distance(x0, y0, x1, y1):
        if not geometry.sphere:
            return np.hypot(x1 - x0, y1 - y0)
        lam0, phi0, lam1, phi1 = (np.radians(a) for a in (x0, y0, x1, y1))
        half = np.sin((phi1 - phi0) / 2) ** 2 + np.cos(phi0) * np.cos(phi1) * np.sin((lam1 - lam0) / 2) ** 2
        return 2.0 * radius * np.arcsin(np.sqrt(np.clip(half, 0.0, 1.0)))

    return (distance(x[:, :-1], y[:, :-1], x[:, 1:], y[:, 1:]), distance(x[:-1], y[:-1], x[1:], y[1:]))


def padded_in_time(values: np.ndarray, start: int, stop: int) -> np.ndarray:
    """Times ``start`` .. ``stop - 1`` of ``values`` (time first) with one more on each side: the
    real neighbour if read, else Keys' extrapolation."""
    low = values[start - 1] if start > 0 else None
    high = values[stop] if stop < values.shape[0] else None
    return extend_keys(values[start:stop], 0, low, high)


@dataclass(frozen=True, eq=False)
class StaggeredVelocitySystem(CurvilinearVelocitySystem):
    """A flow from a C-grid's face velocities, integrated in the grid's indices (module docstring)."""

    faces: FaceConversion = field(default=None, repr=False)

    def grid_attributes(self) -> dict[str, str | float]:
        """What a map's file records of the C-grid's metrics: the variables read (or that they came
        from the coordinates) and the tolerance they were checked to."""
        if not self.faces.metrics:
            return {"grid_metrics": "from the coordinates"}
        return {"grid_metrics": self.faces.metrics, "metric_tolerance": self.source.metric_tolerance}

    @property
    def engine_name(self) -> str:
        return "velocity_data_c_grid"

    @property
    def description(self) -> str:
        return super().description.replace("curvilinear grid", "C-grid")

    def data_window(self, start: float, end: float) -> DataWindow:
        """The window of the data [start, end] needs over the box read (:attr:`box`; read once, the last few kept)."""
        self.check_times(start, end)
        times = time_indices(self.source, *sorted((start, end)))
        if times not in self._windows:
            self._windows[times] = read_staggered_window(self.source, self.geometry, self.faces, self.box, times,
                                                         self.velocities.metric, self.arc_factor)
        return self._windows[times]

    def stop_flags(self, end_states: np.ndarray, start: float, end: float) -> dict[str, np.ndarray]:
        """Where trajectories stopped: ``left_data`` out of the cells with both faces in the data,
        ``on_land`` in a land cell (a start there: no trajectory enters one)."""
        window = self.data_window(start, end)
        fi, fj = (np.nan_to_num(self.engine_states(end_states), nan=-1.0) - self.box_origin).T
        nx, ny = window.x_grid[2], window.y_grid[2]
        outside = ~((fi >= 0.5) & (fi <= nx - 1.5) & (fj >= 0.5) & (fj <= ny - 1.5))
        on_land = np.ones(len(fi), dtype=bool)
        for di in (-FACE_SLACK, FACE_SLACK):  # a point on a wall's face (to rounding) is at sea
            for dj in (-FACE_SLACK, FACE_SLACK):
                i = np.clip(np.floor(fi + di + 0.5).astype(int), 0, nx - 1)
                j = np.clip(np.floor(fj + dj + 0.5).astype(int), 0, ny - 1)
                on_land &= window.land[j, i]
        return {"on_land": on_land & ~outside, "left_data": outside}

    @property
    def box_origin(self) -> np.ndarray:
        """The whole grid's indices (i, j) of the box's first centre."""
        return np.array([self.box[0][0], self.box[1][0]], dtype=float)

    def stop_lines(self, end_states: np.ndarray, start: float, end: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The data's edge each trajectory that left it passed (an index line i or j = 1/2 or n - 3/2
        of the box read, in the engine's state); for one in a land cell (it started there) the nearest face."""
        indices = np.nan_to_num(self.engine_states(end_states), nan=-1.0) - self.box_origin
        (ia, ib), (ja, jb) = self.box
        lows, highs = np.array([0.5, 0.5]), np.array([ib - ia - 0.5, jb - ja - 0.5])
        below, above = indices < lows, indices > highs
        outside = below | above
        faces = np.floor(indices + 0.5) - 0.5
        nearest = np.where(indices - faces <= 0.5, faces, faces + 1.0)
        lines = np.where(below, lows, np.where(above, highs, nearest))
        distance = np.where(outside, np.inf, np.abs(indices - lines))
        axis = np.where(outside.any(axis=1), np.argmax(outside, axis=1), np.argmin(distance, axis=1))
        rows = np.arange(len(end_states))
        gap = indices[rows, axis] - lines[rows, axis]
        return axis, lines[rows, axis] + self.box_origin[axis], np.where(gap >= 0.0, 1, -1)


def read_staggered_window(source: DataSource, geometry: GridGeometry, faces: FaceConversion, box: NodeBox,
                          times: tuple[int, int], metric: np.ndarray, arc_factor: float) -> DataWindow:
    """The kernel's buffer for times ``times`` (an inclusive index range) and their real neighbours,
    over the centres of ``box`` (the whole grid's indices; ``geometry`` and ``faces`` cover it) and
    the faces between them."""
    ta, tb = times
    (ia, ib), (ja, jb) = box
    count = source.t_grid[2]
    first, last = max(0, ta - 1), min(count - 1, tb + 1)
    with source.open() as dataset:
        def face_values(name: str, rows: slice, columns: slice) -> np.ndarray:  # the face arrays' own dimensions
            time, y, x = dataset.dataset(0)[name].dims
            return np.asarray(dataset.read(name, {time: slice(first, last + 1), y: rows, x: columns}), dtype=float)

        # u between centres (j, i) and (j, i + 1), v between (j, i) and (j + 1, i): NEMO's outer
        # faces (its arrays' last column and row) are never among them
        u = face_values(source.u, slice(ja, jb + 1), slice(ia, ib))
        v = face_values(source.v, slice(ja, jb), slice(ia, ib + 1))
        ny, nx = jb - ja + 1, ib - ia + 1
        water = (np.asarray(dataset.read(source.mask, {source.y: slice(ja, jb + 1), source.x: slice(ia, ib + 1)})) != 0
                 if source.mask else np.ones((ny, nx), dtype=bool))
    check_speeds(source, [u, v])
    open_u = np.isfinite(u) & (water[:, :-1] & water[:, 1:])  # a face by a land centre, or missing, is closed
    open_v = np.isfinite(v) & (water[:-1] & water[1:])
    i0, j0 = geometry.offset  # the box in the geometry's nodes (faces' and cells' arrays are the geometry's)
    rows, columns = slice(ja - j0, jb - j0 + 1), slice(ia - i0, ib - i0 + 1)
    u = np.where(open_u, u, 0.0) * source.velocity_scale / faces.u_divisor[rows, columns.start:columns.stop - 1]
    v = np.where(open_v, v, 0.0) * source.velocity_scale / faces.v_divisor[rows.start:rows.stop - 1, columns]
    start, stop = ta - first, ta - first + tb - ta + 1
    time_nodes = None
    if source.nodes is not None:  # uneven times: ghosts on the end nodes' parabola, as an uneven axis's
        times_read = np.asarray(source.nodes[-1])[first:last + 1]
        (u, time_nodes), (v, _) = (pad_axis(a, 0, times_read, start, stop) for a in (u, v))
    else:
        u, v = padded_in_time(u, start, stop), padded_in_time(v, start, stop)
    u_faces = np.ascontiguousarray(np.moveaxis(u, 0, -1))  # (ny, nx - 1, nt + 2)
    v_faces = np.ascontiguousarray(np.moveaxis(v, 0, -1))
    land = (~water).astype(float)
    header = np.zeros(HEADER)
    header[:12] = (tb - ta + 1, ny, nx, float(ia), 1.0, float(ja), 1.0, source.t_grid[0] + source.t_grid[1] * ta,
                   source.t_grid[1], 0.0, source.radius, 1.0)
    header[V_AT] = HEADER + u_faces.size
    header[LAND_AT] = header[V_AT] + v_faces.size
    header[METRIC_AT] = header[LAND_AT] + 2 * land.size  # the cells' scales after the land
    header[ARC_FACTOR_AT] = arc_factor
    padded_metric = box_padded(metric, box, geometry.offset, (source.y_grid[2], source.x_grid[2]))
    buffer = np.concatenate([header, u_faces.ravel(), v_faces.ravel(), land.ravel(), faces.cell_scale[rows, columns].ravel(),
                             padded_metric.ravel()])
    if time_nodes is not None:
        buffer[STAGGERED_TIMES_AT] = len(buffer)
        buffer = np.concatenate([buffer, time_nodes])
    return DataWindow(np.ascontiguousarray(buffer), ~water, (float(ia), 1.0, nx), (float(ja), 1.0, ny))


def make_staggered_system(name: str, source: DataSource, spec: dict, coordinates: tuple[str, str],
                          window: dict | None = None, key: str = "window") -> StaggeredVelocitySystem:
    """The system of a checked C-grid ``source`` (:func:`.source.open_source`) over its ``window``:
    its faces' conversion over the geometry's nodes (the box read and a margin)."""
    def faces(geometry: GridGeometry) -> dict:
        return {"faces": face_conversion(source, geometry, *face_lengths(geometry, source.radius))}

    return grid_system(StaggeredVelocitySystem, staggered_kernel_source(), "velocity_data_c_grid", name, source, spec,
                       coordinates, window, key, faces)
