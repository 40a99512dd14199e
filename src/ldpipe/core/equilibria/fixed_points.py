"""Fixed points of a discrete map x_{n+1} = f(x_n) in a box, and their multipliers.

A map's equilibria are its fixed points, the roots of g(x) = f(x) - x (a periodic coordinate's
difference taken on the circle, so a fixed point of the torus or cylinder map is one), found by
the multi-start search of the flows' and Hamiltonians' equilibria
(:func:`ldpipe.core.equilibria.potential.roots_in_box` over g and Dg = Df - I). Its linear
analysis is the spectrum of the tangent map Df there: the multipliers. The type counts the
multipliers outside and inside the unit circle (the unstable and stable dimensions): a ``sink``,
a ``source``, a ``saddle`` (both), or ``non-hyperbolic`` where one lies on the circle to the
tolerance (an elliptic point of an area-preserving map among them). The file is the flow
equilibria's (contract ``FLOW_EQUILIBRIA``), with ``fixed_point`` in its attributes.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from .flow import spectral_table
from .potential import box_bounds, roots_in_box


def circle_difference(difference: np.ndarray, periods) -> np.ndarray:
    """``difference`` with the components of periodic coordinates wrapped into [-period/2, period/2)."""
    difference = np.array(difference, dtype=float)
    for i, period in enumerate(periods):
        if period:
            difference[..., i] -= period * np.floor(difference[..., i] / period + 0.5)
    return difference


def map_fixed_points(system, lower: np.ndarray, upper: np.ndarray, seeds_per_axis: int = 9,
                     tolerance: float = 1e-10) -> np.ndarray:
    """Fixed points of the map in the box, shape (k, n), periodic coordinates in [0, period),
    sorted (see :func:`~ldpipe.core.equilibria.potential.roots_in_box` for the seeds, the
    acceptance test and the merge)."""
    identity = np.eye(system.n_state)

    def residual(x):
        return circle_difference(system.step(x) - x, system.periods)

    def jacobian(x):
        return system.jacobian(x) - identity

    found = system.wrap(roots_in_box(residual, jacobian, lower, upper, seeds_per_axis, tolerance))
    # a fixed point found at both ends of a period is one point
    kept: list[np.ndarray] = []
    scale = float(np.max(upper - lower))
    for x in found:
        if all(np.max(np.abs(circle_difference(x - other, system.periods))) > np.sqrt(tolerance) * scale
               for other in kept):
            kept.append(x)
    return np.array(sorted(kept, key=tuple)).reshape(-1, system.n_state)


def classify_map(multipliers: np.ndarray, tolerance: float) -> tuple[str, int, int]:
    """(type, unstable dimension, stable dimension) from the tangent map's multipliers."""
    modulus = np.abs(multipliers)
    unstable = int(np.sum(modulus > 1 + tolerance))
    stable = int(np.sum(modulus < 1 - tolerance))
    if unstable + stable < len(multipliers):
        return "non-hyperbolic", unstable, stable
    if unstable and stable:
        return "saddle", unstable, stable
    return ("source" if unstable else "sink"), unstable, stable


def map_fixed_point_table(system, box: dict[str, list[float]], seeds_per_axis: int = 9,
                          tolerance: float = 1e-10) -> xr.Dataset:
    """The equilibrium stage's result for a discrete map: its fixed points in the box with the
    multipliers (eigenvalues of Df) by decreasing modulus, then decreasing imaginary part;
    eigenvectors of unit norm, phased so that their largest component is real and positive."""
    lower, upper = box_bounds(system, box)
    positions = map_fixed_points(system, lower, upper, seeds_per_axis, tolerance)
    return spectral_table(
        system, positions, tolerance, order=lambda e: (-e.imag, -np.abs(e)), classify=classify_map,
        matrix="tangent map's",
        words={"position": "fixed point (f(x) = x)", "type": "type of fixed point",
               "unstable": "number of multipliers outside the unit circle",
               "stable": "number of multipliers inside the unit circle"},
        attributes={"fixed_point": "the equilibria of a discrete map: its fixed points; eigenvalues are the "
                                   "multipliers of the tangent map Df",
                    "mode_order": "decreasing modulus of the multiplier, then decreasing imaginary part"})
