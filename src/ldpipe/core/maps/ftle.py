"""Finite-time Lyapunov exponents of a fixed-time map, from its flow map over the map's own grid.

The flow map F sends a point x0 of the section's grid to where its trajectory is after the time
T (forward or backward). Its gradient with respect to the two section coordinates (a, b),
``J[i, k] = d F_i / d a_k`` (every state component i), is taken by differences of the end states
over the grid, as ocean tools do (Haller 2001; Shadden, Lekien & Marsden 2005): centred and
second order where both neighbours along an axis ran the whole time (``numpy.gradient``), and
elsewhere (the grid's edges, beside a neighbour that left the data, hit land or escaped) one-sided
over the next three points on the side that ran the whole time, of third order
(:func:`axis_derivative`). The second-order one-sided difference that ``numpy.gradient`` takes at
the edges errs twice as much as the centred one, with the opposite sign: an FTLE a few per cent
high along every edge of a coarse map, a bright frame around the picture. The third-order one's
error falls a power of the spacing faster than the interior's. The right Cauchy-Green tensor
``C = J^T J`` (2 x 2) has largest eigenvalue lambda_max, and

    FTLE = ln(lambda_max) / (2 |T|).

On an energy surface's section, one coordinate S is solved from the energy, so a step (da, db)
across the grid moves the start state by (da, db, dS) with dS = S_a da + S_b db: the initial
separation is measured in phase space, not in the section's two coordinates alone. Otherwise the
FTLE grows without bound at the rim of the energetically allowed region, where S ~ sqrt(distance
to the rim) and its slope diverges: a bright rim that is the chart's, not the dynamics'. With the
slope s = (S_a, S_b) (by the same differences as J), the largest stretching is the largest root of
det(J^T J - lambda G^T G) = 0, with G^T G = I + s s^T (:func:`ftle`'s ``solved``). A point beside
one off the energy surface (S missing) is not defined: a one-sided difference there would read
the square root at its singular point.

On the sphere (state longitude, latitude in degrees) lengths are great-circle ones: the end
states are differenced as 3-D positions on the sphere (:func:`ldpipe.core.sphere.sphere_positions`, in degrees of arc),
so neither the seam nor a pole between neighbours' end points breaks the differences; a step of
the grid along longitude counts cos(latitude) times one along latitude at the start point
(``sphere_metric``); the Earth's radius cancels in the ratio. A start point at a pole has no
longitude step (every longitude is the same point): its exponent is not defined there.

A point is *defined* when it ran the whole time (no region exit, escape, land, data edge or
failure) and, along each axis, either both its neighbours or the next three points on one side
did too: elsewhere the exponent is missing (NaN, the file's declared ``_FillValue``) and the
``ftle_defined_*`` flag is false.

A formula system's map may instead take the gradient exact (``ftle: variational``,
:func:`variational_ftle`): the state transition matrix along each point's own trajectory.
"""

from __future__ import annotations

import math

import numpy as np

#: A map's ``ftle`` value asking for the exact gradient (:func:`variational_ftle`); ``true``: differences.
VARIATIONAL = "variational"

#: The LD map file's variables of the flow map: the end state of every state variable, per direction.
END_STATE_NAME = "end_{coordinate}_{direction}"


def one_sided_weights(nodes: np.ndarray) -> np.ndarray:
    """Weights w of the derivative at ``nodes[0]`` from the values at ``nodes`` (any spacing):
    the derivative of the interpolating polynomial, sum_k w_k f(nodes[k]); with four nodes exact
    for cubics, an error O(h^3)."""
    offsets = np.asarray(nodes, dtype=float) - nodes[0]
    # the moments sum_k w_k offsets_k^m = (m == 1), m = 0 .. len - 1
    moments = np.vander(offsets, increasing=True).T
    target = np.zeros(len(offsets))
    target[1] = 1.0
    return np.linalg.solve(moments, target)


#: Points past a point a one-sided difference reads (four-point stencil: third order).
ONE_SIDED_REACH = 3


def axis_derivative(values: np.ndarray, coordinate: np.ndarray, usable: np.ndarray,
                    axis: int) -> tuple[np.ndarray, np.ndarray]:
    """(d values / d coordinate along ``axis``, where it was taken) over a grid whose points
    ``usable`` (its first two dimensions) may be differenced.

    Centred (``numpy.gradient``, second order) where both neighbours are usable; else one-sided of
    third order over the point and the next :data:`ONE_SIDED_REACH` usable points on one side
    (forward if it can); else not taken (False). ``values`` (n0, n1, ...) may hold anything where
    not usable: no derivative taken reads it.
    """
    coordinate = np.asarray(coordinate, dtype=float)
    n = values.shape[axis]
    derivative = np.moveaxis(np.gradient(values, coordinate, axis=axis, edge_order=2), axis, 0)
    line = np.moveaxis(values, axis, 0)
    ok = np.moveaxis(np.asarray(usable, dtype=bool), axis, 0)
    centred = np.zeros_like(ok)
    centred[1:-1] = ok[:-2] & ok[2:]
    taken = centred.copy()
    for side in (1, -1):
        for i in range(n):
            stencil = [i + side * k for k in range(ONE_SIDED_REACH + 1)]
            if not 0 <= stencil[-1] < n:
                continue
            use = ~taken[i] & np.logical_and.reduce([ok[k] for k in stencil[1:]])
            if not use.any():
                continue
            weights = one_sided_weights(coordinate[stencil])
            estimate = sum(w * line[k] for w, k in zip(weights, stencil))
            derivative[i] = np.where(use.reshape(use.shape + (1,) * (line.ndim - 2)), estimate, derivative[i])
            taken[i] |= use
    return np.moveaxis(derivative, 0, axis), np.moveaxis(taken, 0, axis)


def flow_map_gradient(end_states: np.ndarray, axis_values: tuple[np.ndarray, np.ndarray],
                      usable: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(d(end state)/d(section coordinates), where both axes' derivatives were taken) by
    differences over the grid of the ``usable`` points (default: all), :func:`axis_derivative`.

    ``end_states`` has shape (n0, n1, n_state); the gradient (n0, n1, n_state, 2), the mask (n0, n1).
    """
    if end_states.shape[0] < 3 or end_states.shape[1] < 3:
        raise ValueError(f"FTLE: the grid needs at least 3 points per axis for its differences, got {end_states.shape[:2]}")
    if usable is None:
        usable = np.ones(end_states.shape[:2], dtype=bool)
    d0, taken0 = axis_derivative(end_states, axis_values[0], usable, 0)
    d1, taken1 = axis_derivative(end_states, axis_values[1], usable, 1)
    return np.stack([d0, d1], axis=-1), taken0 & taken1


def section_chart_slope(solved: np.ndarray, axis_values: tuple[np.ndarray, np.ndarray],
                        usable: np.ndarray | None = None) -> np.ndarray:
    """(dS/da, dS/db) of a section's solved coordinate S (n0, n1) by the same differences as
    :func:`flow_map_gradient` (over the same ``usable`` points): shape (n0, n1, 2)."""
    return flow_map_gradient(np.asarray(solved, dtype=float)[..., None], axis_values, usable)[0][..., 0, :]


def largest_stretching_on_chart(gradient: np.ndarray, slope: np.ndarray) -> np.ndarray:
    """The largest root lambda of det(C - lambda M) = 0, C = J^T J, M = I + s s^T: the largest
    ratio |J v|^2 / |G v|^2 of squared separations after and before, G the chart's Jacobian."""
    c00 = np.einsum("...i,...i->...", gradient[..., 0], gradient[..., 0])
    c11 = np.einsum("...i,...i->...", gradient[..., 1], gradient[..., 1])
    c01 = np.einsum("...i,...i->...", gradient[..., 0], gradient[..., 1])
    m00, m11, m01 = 1.0 + slope[..., 0] ** 2, 1.0 + slope[..., 1] ** 2, slope[..., 0] * slope[..., 1]
    det_m = m00 * m11 - m01**2
    half_b = 0.5 * (c00 * m11 + c11 * m00 - 2.0 * c01 * m01)
    det_c = c00 * c11 - c01**2
    return (half_b + np.sqrt(np.maximum(half_b**2 - det_m * det_c, 0.0))) / det_m


def largest_stretching(gradient: np.ndarray) -> np.ndarray:
    """lambda_max of C = J^T J for J of shape (..., n_state, 2): the 2 x 2 symmetric eigenvalue in closed form."""
    c00 = np.einsum("...i,...i->...", gradient[..., 0], gradient[..., 0])
    c11 = np.einsum("...i,...i->...", gradient[..., 1], gradient[..., 1])
    c01 = np.einsum("...i,...i->...", gradient[..., 0], gradient[..., 1])
    half_trace = 0.5 * (c00 + c11)
    return half_trace + np.sqrt(0.25 * (c00 - c11) ** 2 + c01**2)


def beside(points: np.ndarray) -> np.ndarray:
    """Where a grid point or one of its (up to four) neighbours along the axes is in ``points`` (n0, n1)."""
    near = points.copy()
    near[1:] |= points[:-1]
    near[:-1] |= points[1:]
    near[:, 1:] |= points[:, :-1]
    near[:, :-1] |= points[:, 1:]
    return near


#: How near a pole (degrees of latitude) a start point is at it: no longitude step there.
POLE_LATITUDE = 90.0 - 1e-9


def sphere_metric(end_positions: np.ndarray, axis_values: tuple[np.ndarray, np.ndarray],
                  axes: tuple[str, str], coordinates: tuple[str, str]) -> tuple[np.ndarray, np.ndarray]:
    """The length scales of :func:`ftle`'s ``metric`` on the sphere: 1 for the end points' 3-D
    positions (:func:`ldpipe.core.sphere.sphere_positions`, n0, n1, 3); at the grid's points along its axes (n0, n1,
    2) cos(latitude) for longitude and 1 for latitude, NaN for longitude at a pole (undefined there)."""
    lon, lat = coordinates
    grid = np.meshgrid(*axis_values, indexing="ij")
    start_lat = grid[axes.index(lat)]
    axis_scale = np.ones(end_positions.shape[:2] + (2,))
    axis_scale[..., axes.index(lon)] = np.where(np.abs(start_lat) >= POLE_LATITUDE, np.nan,
                                                np.cos(np.radians(start_lat)))
    return np.ones(end_positions.shape), axis_scale


def ftle(end_states: np.ndarray, axis_values: tuple[np.ndarray, np.ndarray], time: float,
         complete: np.ndarray, metric: tuple[np.ndarray, np.ndarray] | None = None,
         solved: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(FTLE, defined) on the grid: see the module docstring; ``time`` is |T|, ``complete`` (n0, n1)
    where a trajectory ran the whole time; ``metric`` (optional) the length per unit of each end
    state component (n0, n1, n_state) and of each axis at the grid points (n0, n1, 2);
    ``solved`` (an energy surface's section) the solved coordinate (n0, n1), whose slope is
    differenced as the end states are (:func:`section_chart_slope`)."""
    if not time > 0:
        raise ValueError(f"FTLE: expected a positive integration time, got {time!r}")
    complete = np.asarray(complete, dtype=bool)
    gradient, defined = flow_map_gradient(np.asarray(end_states, dtype=float), axis_values, complete)
    defined &= complete
    chart_slope = None
    if solved is not None:
        chart_slope = section_chart_slope(solved, axis_values, complete)
        defined &= ~beside(~np.isfinite(solved))
    if metric is not None:
        end_scale, axis_scale = metric
        gradient = gradient * end_scale[..., :, None] / axis_scale[..., None, :]
    stretch = largest_stretching(gradient) if chart_slope is None else largest_stretching_on_chart(gradient, chart_slope)
    defined &= np.isfinite(stretch) & (stretch > 0)
    values = np.full(defined.shape, np.nan)
    values[defined] = np.log(stretch[defined]) / (2.0 * time)
    return values, defined


def variational_ftle(system, states: np.ndarray, axes: tuple[int, int], t0: float, time: float, *,
                     rtol: float = 1e-12, atol: float = 1e-12) -> np.ndarray:
    """The FTLE of a formula system's flow map over ``time`` (negative: backward) from ``t0`` at
    each of ``states``, its gradient exact: the columns ``axes`` (the section's state indices) of the
    state transition matrix from the variational equations (:func:`ldpipe.core.variational.propagate_flow`,
    per trajectory). The reference the grid differences converge to as the grid refines."""
    from ..variational import propagate_flow

    values = []
    for state in np.atleast_2d(states):
        stm = propagate_flow(system, state, t0, time, rtol=rtol, atol=atol).stm
        values.append(math.log(largest_stretching(stm[:, list(axes)])) / (2 * abs(time)))
    return np.array(values)
