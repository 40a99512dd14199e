"""The energy-shell volume of the reactant well of a 2 DoF system, and the TST rate.

The microcanonical phase-space volume of the well at energy E is ∫ δ(E − H) dq dp over the well.
For H = |p|²/2 + V in 2 DoF, ∫ δ(E − |p|²/2 − V) d²p = 2π wherever V < E, so the volume is 2π
times the area of the energetically allowed well, bounded by the dividing lines of the saddles.
The transition-state (RRKM) rate is the total flux out of the well over that volume.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from scipy import integrate as sp_integrate
from scipy import optimize

from .flux import DividingLine


#: Steps of a ray whose potential is evaluated in one kernel call (most rays end within ~150).
RAY_CHUNK = 64

#: How far a ray is followed before the well is declared unbounded in its direction.
RAY_REACH = 1e6


def ray_radius(system, well: np.ndarray, energy: float, lines: Sequence[DividingLine], theta: float,
               step: float) -> float:
    """Distance from ``well`` along direction θ to the first of: V = E, or a dividing line (s = 0).

    The ray is walked in steps of ``step`` (r_k = r_{k-1} + step, summed in that order) until V ≥ E
    or the nearest line is reached, then the crossing is found by Brent's method in the last step.
    The steps are evaluated a chunk at a time in one kernel call; the walk and the bracket are the
    ones a step-by-step loop finds.
    """
    direction = np.array([math.cos(theta), math.sin(theta)])
    limit = math.inf
    for line in lines:
        approach = float(line.normal @ direction)
        if approach > 0:
            limit = min(limit, float(line.normal @ (line.saddle - well)) / approach)
    inner = 0.0
    while True:
        outers = np.add.accumulate(np.concatenate([[inner], np.full(RAY_CHUNK, step)]))[1:]
        at_limit = outers >= limit
        if at_limit.any():  # the walk stops at the line: the step that would pass it ends on it
            outers = outers[: int(np.argmax(at_limit)) + 1]
            outers[-1] = limit
        beyond = outers > RAY_REACH
        if beyond.any():  # a step past the reach that is not a crossing is the last one tried
            outers = outers[: int(np.argmax(beyond)) + 1]
        above = system.potentials(well[None, :] + outers[:, None] * direction[None, :]) >= energy
        if above.any():
            k = int(np.argmax(above))
            lower = inner if k == 0 else float(outers[k - 1])
            return optimize.brentq(lambda r: system.potential(well + r * direction) - energy, lower,
                                   float(outers[k]), xtol=1e-14, rtol=4 * np.finfo(float).eps)
        if outers[-1] == limit:
            return limit
        if beyond.any():
            raise ValueError(f"the well is not bounded in direction θ = {theta:.6g}")
        inner = float(outers[-1])


def well_area(system, well, energy: float, lines: Sequence[DividingLine] = (), *, step: float = 0.05) -> float:
    """Area of {q: V(q) ≤ E} seen from the well's minimum, cut off by the dividing ``lines``.

    In polar coordinates about ``well`` the area is ½ ∮ r(θ)² dθ, r(θ) the first point of the ray
    where V reaches E or a line is crossed (found by steps of ``step`` and bisection). The region
    must be star-shaped about the well (each ray leaves it once), as a potential well near its
    minimum is. r(θ) has kinks where the boundary passes from the equipotential to a line, at the
    angles of the lines' allowed ends; the quadrature is split there, so each piece is smooth.
    """
    well = np.asarray(well, dtype=np.float64)
    if system.potential(well) >= energy:
        raise ValueError(f"energy {energy!r} is not above the well's potential {system.potential(well)!r}")
    kinks = [-math.pi, math.pi]
    for line in lines:
        for u in line.interval():
            end = line.saddle + u * line.tangent - well
            kinks.append(math.atan2(end[1], end[0]))
    kinks = sorted(set(kinks))
    total = 0.0
    for a, b in zip(kinks[:-1], kinks[1:]):
        if b - a < 1e-15:
            continue
        value, _ = sp_integrate.quad(lambda t: 0.5 * ray_radius(system, well, energy, lines, t, step) ** 2, a, b,
                                     epsabs=0.0, epsrel=1e-11, limit=200)
        total += value
    return float(total)


def well_shell_volume(system, well, energy: float, lines: Sequence[DividingLine] = (), **kwargs) -> float:
    """∫ δ(E − H) dq dp over the well: 2π times :func:`well_area` (2 DoF, H = |p|²/2 + V)."""
    if system.n_dof != 2:
        raise ValueError(f"well_shell_volume is for 2 DoF systems; {system.name} has {system.n_dof}")
    return 2.0 * math.pi * well_area(system, well, energy, lines, **kwargs)
