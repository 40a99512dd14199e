"""Finite-time Lyapunov exponents of a fixed-time map, from its flow map over the map's own grid.

The flow map F sends a point x0 of the section's grid to where its trajectory is after the time
T (forward or backward). Its gradient with respect to the two section coordinates (a, b),
``J[i, k] = d F_i / d a_k`` (every state component i), is taken by differences of the end states
over the grid, as ocean tools do (Haller 2001; Shadden, Lekien & Marsden 2005): centred in the
interior, one-sided and second order at the grid's edges (``numpy.gradient``). The right
Cauchy-Green tensor ``C = J^T J`` (2 x 2) has largest eigenvalue lambda_max, and

    FTLE = ln(lambda_max) / (2 |T|).

On an energy surface's section, one coordinate S is solved from the energy, so a step (da, db)
across the grid moves the start state by (da, db, dS) with dS = S_a da + S_b db: the initial
separation is measured in phase space, not in the section's two coordinates alone. Otherwise the
FTLE grows without bound at the rim of the energetically allowed region, where S ~ sqrt(distance
to the rim) and its slope diverges: a bright rim that is the chart's, not the dynamics'. With the
slope s = (S_a, S_b) (by the same differences as J), the largest stretching is the largest root of
det(J^T J - lambda G^T G) = 0, with G^T G = I + s s^T (``chart_slope``).

On the sphere (state longitude, latitude in degrees) lengths are great-circle ones: the end
states are differenced as 3-D positions on the sphere (``sphere_positions``, in degrees of arc),
so neither the seam nor a pole between neighbours' end points breaks the differences; a step of
the grid along longitude counts cos(latitude) times one along latitude at the start point
(``sphere_metric``); the Earth's radius cancels in the ratio. A start point at a pole has no
longitude step (every longitude is the same point): its exponent is not defined there.

A point is *defined* when it and every grid neighbour its differences use ran the whole time
(no region exit, escape, land, data edge or failure): elsewhere the exponent is missing (NaN,
the file's declared ``_FillValue``) and the ``ftle_defined_*`` flag is false.

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


def flow_map_gradient(end_states: np.ndarray, axis_values: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """d(end state)/d(section coordinates) by differences over the grid.

    ``end_states`` has shape (n0, n1, n_state); the result (n0, n1, n_state, 2).
    """
    first, second = (np.asarray(a, dtype=float) for a in axis_values)
    if end_states.shape[0] < 3 or end_states.shape[1] < 3:
        raise ValueError(f"FTLE: the grid needs at least 3 points per axis for its differences, got {end_states.shape[:2]}")
    d0 = np.gradient(end_states, first, axis=0, edge_order=2)
    d1 = np.gradient(end_states, second, axis=1, edge_order=2)
    return np.stack([d0, d1], axis=-1)


def section_chart_slope(solved: np.ndarray, axis_values: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """(dS/da, dS/db) of a section's solved coordinate S (n0, n1) by the same differences as
    :func:`flow_map_gradient`: shape (n0, n1, 2)."""
    return flow_map_gradient(np.asarray(solved, dtype=float)[..., None], axis_values)[..., 0, :]


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


def complete_neighbourhood(complete: np.ndarray) -> np.ndarray:
    """Where a point and every neighbour its differences read (along each axis) ran the whole time."""
    ok = complete.copy()
    for axis in (0, 1):
        n = complete.shape[axis]
        moved = np.moveaxis(complete, axis, 0)
        near = np.moveaxis(ok, axis, 0)
        near[1:-1] &= moved[:-2] & moved[2:]
        near[0] &= moved[1] & moved[2]  # the one-sided second-order edge differences read two neighbours
        near[n - 1] &= moved[n - 2] & moved[n - 3]
    return ok


def sphere_positions(end_states: np.ndarray) -> np.ndarray:
    """End states (..., 2) as longitude, latitude in degrees, as 3-D positions (..., 3) on the
    sphere of radius 180/pi: a chord between near points is their great-circle distance in degrees."""
    lon, lat = np.radians(end_states[..., 0]), np.radians(end_states[..., 1])
    return np.degrees(np.stack([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)], axis=-1))


#: How near a pole (degrees of latitude) a start point is at it: no longitude step there.
POLE_LATITUDE = 90.0 - 1e-9


def sphere_metric(end_positions: np.ndarray, axis_values: tuple[np.ndarray, np.ndarray],
                  axes: tuple[str, str], coordinates: tuple[str, str]) -> tuple[np.ndarray, np.ndarray]:
    """The length scales of :func:`ftle`'s ``metric`` on the sphere: 1 for the end points' 3-D
    positions (:func:`sphere_positions`, n0, n1, 3); at the grid's points along its axes (n0, n1,
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
         chart_slope: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(FTLE, defined) on the grid: see the module docstring; ``time`` is |T|, ``complete`` (n0, n1)
    where a trajectory ran the whole time; ``metric`` (optional) the length per unit of each end
    state component (n0, n1, n_state) and of each axis at the grid points (n0, n1, 2);
    ``chart_slope`` (an energy surface's section) the solved coordinate's slope
    (:func:`section_chart_slope`)."""
    if not time > 0:
        raise ValueError(f"FTLE: expected a positive integration time, got {time!r}")
    defined = complete_neighbourhood(np.asarray(complete, dtype=bool))
    gradient = flow_map_gradient(np.asarray(end_states, dtype=float), axis_values)
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
