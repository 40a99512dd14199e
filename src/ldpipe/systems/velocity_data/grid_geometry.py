"""The geometry of a curvilinear grid: coordinates at fractional indices, the metric, the inverse map.

A curvilinear grid gives each node (j, i) its coordinates X = (x, y) (longitude and latitude in
degrees on the sphere, the longitudes unwrapped about the grid's centre so that a grid across the
dateline is continuous). Between nodes X(i, j) is the cubic convolution of the nodes (Keys 1981,
a = -1/2, the velocity kernels' interpolant, third order, exact for quadratics; the nodes padded
by Keys' extrapolation), so positions mapped back from index space have the interpolant's order.

The metric dX/d(i, j) at the nodes is taken by fourth-order differences (one-sided at the two
rows next to an edge): its error is two orders below the interpolant's, so converting velocities
to index velocities costs no order. :meth:`GridGeometry.indices` inverts X by Newton's method
from the nearest node (a k-d tree; on the sphere over unit vectors).

A geometry may hold a box of a larger grid (a spatial ``window``): its ``offset`` is the index
(i, j) of its first node, and every index it takes or gives is the whole grid's. An integer offset
is subtracted exactly, so inside the box the interpolants give the whole grid's values bit for bit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

#: Fourth-order first differences: interior (centred), and one-sided at the first two nodes.
CENTRED = np.array([1.0, -8.0, 0.0, 8.0, -1.0]) / 12.0
EDGE0 = np.array([-25.0, 48.0, -36.0, 16.0, -3.0]) / 12.0
EDGE1 = np.array([-3.0, -10.0, 18.0, -6.0, 1.0]) / 12.0
#: Newton's iterations and its convergence (in grid indices) when mapping points to indices.
NEWTON_STEPS = 40
NEWTON_TOLERANCE = 1e-12


def index_derivative(values: np.ndarray, axis: int) -> np.ndarray:
    """d values / d index along ``axis`` (at least 5 nodes) by fourth-order differences."""
    a = np.moveaxis(np.asarray(values, dtype=float), axis, 0)
    n = a.shape[0]
    out = np.empty_like(a)
    out[2:n - 2] = sum(w * a[k:n - 4 + k] for k, w in enumerate(CENTRED))
    out[0] = sum(w * a[k] for k, w in enumerate(EDGE0))
    out[1] = sum(w * a[k] for k, w in enumerate(EDGE1))
    out[n - 1] = -sum(w * a[n - 1 - k] for k, w in enumerate(EDGE0))
    out[n - 2] = -sum(w * a[n - 1 - k] for k, w in enumerate(EDGE1))
    return np.moveaxis(out, 0, axis)


def keys_padded(values: np.ndarray) -> np.ndarray:
    """A (ny, nx, ...) array padded by one node on each side of its first two axes by Keys'
    extrapolation f[-1] = 3 f[0] - 3 f[1] + f[2] (exact for quadratics)."""
    out = np.asarray(values, dtype=float)
    for axis in (0, 1):
        a = np.moveaxis(out, axis, 0)
        low, high = 3 * a[0] - 3 * a[1] + a[2], 3 * a[-1] - 3 * a[-2] + a[-3]
        out = np.moveaxis(np.concatenate([low[None], a, high[None]]), 0, axis)
    return out


def cubic_weights(s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Catmull-Rom's four weights at fraction ``s`` and their derivatives, shape (4,) + s.shape."""
    weights = np.array([((-0.5 * s + 1.0) * s - 0.5) * s, (1.5 * s - 2.5) * s * s + 1.0,
                        ((-1.5 * s + 2.0) * s + 0.5) * s, (0.5 * s - 0.5) * s * s])
    slopes = np.array([(-1.5 * s + 2.0) * s - 0.5, (4.5 * s - 5.0) * s, (-4.5 * s + 4.0) * s + 0.5, (1.5 * s - 1.0) * s])
    return weights, slopes


def interpolate(padded: np.ndarray, fi: np.ndarray, fj: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The cubic convolution of ``padded`` ((ny + 2, nx + 2, k): nodes with Keys' padding) at
    fractional indices (fi, fj), and its derivatives in i and in j: each (len(fi), k). Off the
    grid the edge cell's cubic is continued."""
    ny, nx = padded.shape[0] - 2, padded.shape[1] - 2
    fi, fj = np.asarray(fi, dtype=float), np.asarray(fj, dtype=float)
    i = np.clip(np.floor(np.nan_to_num(fi)), 0, nx - 2).astype(int)
    j = np.clip(np.floor(np.nan_to_num(fj)), 0, ny - 2).astype(int)
    wx, dx = cubic_weights(fi - i)
    wy, dy = cubic_weights(fj - j)
    value = np.zeros((len(fi), padded.shape[2]))
    d_i, d_j = np.zeros_like(value), np.zeros_like(value)
    for b in range(4):
        for a in range(4):
            node = padded[j + b, i + a]
            value += (wy[b] * wx[a])[:, None] * node
            d_i += (wy[b] * dx[a])[:, None] * node
            d_j += (dy[b] * wx[a])[:, None] * node
    return value, d_i, d_j


@dataclass(frozen=True, eq=False)
class GridGeometry:
    """A curvilinear grid's coordinates ``x``, ``y`` (ny, nx) and what is derived from them."""

    x: np.ndarray
    y: np.ndarray
    sphere: bool
    centre_longitude: float = 0.0  # the sphere's longitudes are unwrapped into [centre - 180, centre + 180)
    padded: np.ndarray = field(repr=False, default=None)
    jacobian: np.ndarray = field(repr=False, default=None)  # (ny, nx, 2, 2): d(x, y)/d(i, j)
    offset: tuple[int, int] = (0, 0)  # the whole grid's index (i, j) of the first node (module docstring)

    @classmethod
    def from_coordinates(cls, x: np.ndarray, y: np.ndarray, sphere: bool, centre: float | None = None,
                         offset: tuple[int, int] = (0, 0)) -> GridGeometry:
        """The geometry of nodes ``x``, ``y`` (a box of a grid from node ``offset``); on the sphere
        the longitudes taken about ``centre`` (default: the middle node's)."""
        x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
        if not sphere:
            centre = 0.0
        elif centre is None:  # one branch of longitude about the grid's centre: continuous across the dateline
            centre = float(x[x.shape[0] // 2, x.shape[1] // 2])
        if sphere:
            x = centre + np.mod(x - centre + 180.0, 360.0) - 180.0
        stacked = np.stack([x, y], axis=-1)
        jacobian = np.stack([index_derivative(stacked, 1), index_derivative(stacked, 0)], axis=-1)
        return cls(x, y, sphere, centre, keys_padded(stacked), jacobian, (int(offset[0]), int(offset[1])))

    @property
    def shape(self) -> tuple[int, int]:
        return self.x.shape

    def _at(self, fi: np.ndarray, fj: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:func:`interpolate` of the coordinates at the whole grid's indices (fi, fj)."""
        return interpolate(self.padded, fi - self.offset[0], fj - self.offset[1])

    def branch(self, longitudes: np.ndarray) -> np.ndarray:
        """Longitudes on the grid's branch (the sphere's); other coordinates unchanged."""
        if not self.sphere:
            return np.asarray(longitudes, dtype=float)
        return self.centre_longitude + np.mod(np.asarray(longitudes, dtype=float) - self.centre_longitude + 180.0,
                                              360.0) - 180.0

    def coordinates(self, indices: np.ndarray) -> np.ndarray:
        """The coordinates (x, y) at fractional indices (rows (i, j))."""
        indices = np.atleast_2d(np.asarray(indices, dtype=float))
        return self._at(indices[:, 0], indices[:, 1])[0]

    def coordinate_jacobian(self, indices: np.ndarray) -> np.ndarray:
        """d(x, y)/d(i, j) of the interpolated coordinates at fractional indices: (n, 2, 2)."""
        indices = np.atleast_2d(np.asarray(indices, dtype=float))
        _, d_i, d_j = self._at(indices[:, 0], indices[:, 1])
        return np.stack([d_i, d_j], axis=-1)

    def _embedded(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Points as the node search measures them: (x, y) on the plane, unit vectors on the sphere."""
        if not self.sphere:
            return np.column_stack([np.ravel(x), np.ravel(y)])
        lam, phi = np.radians(np.ravel(x)), np.radians(np.ravel(y))
        return np.column_stack([np.cos(phi) * np.cos(lam), np.cos(phi) * np.sin(lam), np.sin(phi)])

    @cached_property
    def _node_tree(self):
        """A k-d tree of the nodes (built once: every map's starts and ends are searched in it)."""
        from scipy.spatial import cKDTree

        return cKDTree(self._embedded(self.x, self.y))

    def nearest_nodes(self, points: np.ndarray) -> np.ndarray:
        """The indices (i, j) of the node nearest each point (rows (x, y)): on the sphere by chord."""
        usable = np.all(np.isfinite(points), axis=1)
        out = np.full((len(points), 2), np.nan)
        _, flat = self._node_tree.query(self._embedded(points[usable, 0], points[usable, 1]))
        j, i = np.unravel_index(flat, self.shape)
        out[usable] = np.column_stack([i + self.offset[0], j + self.offset[1]])
        return out

    def indices(self, points: np.ndarray) -> np.ndarray:
        """The fractional indices (i, j) where the interpolated coordinates are ``points`` (rows
        (x, y)), by Newton's method from the nearest node. A point off the grid gets the indices
        of the edge cells' cubics continued (outside [0, n - 1]) if Newton finds them, else NaN."""
        points = np.atleast_2d(np.asarray(points, dtype=float)).copy()
        points[:, 0] = self.branch(points[:, 0])
        guess = self.nearest_nodes(points)
        active = np.all(np.isfinite(points), axis=1)
        for _ in range(NEWTON_STEPS):
            if not active.any():
                break
            at = guess[active]
            value, d_i, d_j = self._at(at[:, 0], at[:, 1])
            residual = value - points[active]
            jacobian = np.stack([d_i, d_j], axis=-1)
            determinant = np.linalg.det(jacobian)
            usable = np.abs(determinant) > 0.0
            step = np.zeros_like(at)
            step[usable] = np.linalg.solve(jacobian[usable], residual[usable][..., None])[..., 0]
            step = np.clip(step, -2.0, 2.0)  # a cell or two at a time, from a first guess a node away
            at = at - step
            at[~usable] = np.nan
            rows = np.flatnonzero(active)
            guess[rows] = at
            active[rows] = usable & (np.max(np.abs(step), axis=1) > NEWTON_TOLERANCE)
        guess[active] = np.nan  # not converged
        return guess


def angle_from_coordinates(geometry: GridGeometry) -> np.ndarray:
    """The angle (radians, counter-clockwise) from east (from x on the plane) to the grid's i
    direction at each node, from the metric (on the sphere a degree of longitude is cos(lat) of
    a degree of latitude)."""
    east, north = geometry.jacobian[..., 0, 0], geometry.jacobian[..., 1, 0]
    if geometry.sphere:
        east = east * np.cos(np.radians(geometry.y))
    return np.arctan2(north, east)


def wrapped(angle: np.ndarray) -> np.ndarray:
    """Angles (radians) into [-pi, pi)."""
    return np.mod(angle + math.pi, 2 * math.pi) - math.pi
