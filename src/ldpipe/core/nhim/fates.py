"""Fates (the side of the saddle a trajectory leaves the region by) and their bisection."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...engine import LDSettings, compute_ld
from ...errors import LdpipeError
from .slices import SliceProblem, section_point_states


class RefinementFailed(LdpipeError):
    """A refinement could not bracket or converge; the message says where and why."""


@dataclass(frozen=True)
class RefinementSettings:
    """Numerical settings of the refinements; every value is recorded in the output file.

    tolerance : float
        Target accuracy of a refined point in section coordinates (Euclidean).
    bisection_precision : float
        Width to which each fate bisection brackets a manifold crossing (< tolerance).
    rtol, atol : float
        DOP853 tolerances of every trajectory of the refinement.
    max_time : float
        Longest integration; a trajectory still in the saddle region then has no fate (it is on
        the manifold to within what the integration resolves).
    stencil_points : int
        Points per axis of the stencil around the detected cell that orients the manifolds.
    stencil_half_width : float
        Half-width of that stencil in grid cells (doubled, up to 3 times, until both fates switch).
    shrink : float
        Factor by which the secant spacing shrinks per iteration.
    max_iterations : int
        Iterations of the secant refinement before giving up.
    zoom_points : int
        Points per axis of each zoomed LD grid (odd).
    zoom_factor : float
        Span of the next zoomed grid over the current one.
    """

    tolerance: float = 1e-8
    bisection_precision: float = 5e-10
    rtol: float = 1e-12
    atol: float = 1e-12
    max_time: float = 100.0
    stencil_points: int = 9
    stencil_half_width: float = 4.0
    shrink: float = 0.05
    max_iterations: int = 12
    zoom_points: int = 11
    zoom_factor: float = 0.25

    def __post_init__(self):
        for name in ("tolerance", "bisection_precision", "rtol", "atol", "max_time",
                     "stencil_half_width", "shrink", "zoom_factor"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and np.isfinite(value) and value > 0):
                raise ValueError(f"{name}: expected a finite number > 0, got {value!r}")
        if not self.bisection_precision < self.tolerance:
            raise ValueError(f"bisection_precision: must be below tolerance {self.tolerance}, got {self.bisection_precision}")
        if not (self.shrink < 1 and self.zoom_factor < 1):
            raise ValueError("shrink, zoom_factor: expected numbers in (0, 1)")
        if self.stencil_points < 3 or self.max_iterations < 1 or self.zoom_points < 3 or self.zoom_points % 2 == 0:
            raise ValueError("stencil_points >= 3, max_iterations >= 1, zoom_points odd and >= 3 expected")


@dataclass
class Cost:
    """Work spent: trajectories integrated, trajectory time units, DOP853 steps, wall seconds."""

    trajectories: int = 0
    time_units: float = 0.0
    steps: int = 0
    wall_time: float = 0.0

    def add(self, trajectories: int, time_units: float, steps: int) -> None:
        self.trajectories += int(trajectories)
        self.time_units += float(time_units)
        self.steps += int(steps)


def fate_settings(problem: SliceProblem, settings: RefinementSettings) -> LDSettings:
    """Engine settings of the fate trajectories: DOP853 at the refinement's tolerances, the map's
    saddle region and escape radius, tau = ``max_time``. The integrand is the arc length, the
    cheapest (no cusp path); the steps, and so the exits, do not depend on it."""
    return LDSettings(
        scheme="dop853", rtol=settings.rtol, atol=settings.atol, p="arclength", tau=settings.max_time,
        region_lower=tuple(problem.region_lower), region_upper=tuple(problem.region_upper),
        escape_radius=problem.ld_settings.escape_radius,
    )


def exit_fates(
    problem: SliceProblem, points: np.ndarray, direction: int, settings: RefinementSettings, cost: Cost | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Which side of the saddle each trajectory leaves the region by, forward or backward in time.

    The engine (:func:`ldpipe.engine.compute_ld`, variable time, :func:`fate_settings`) stops each
    trajectory at its first exit from the region, located on the step's interpolant, and returns
    the state there (``end_state``).

    Parameters
    ----------
    points : array_like, shape (k, 2)
        Section points.
    direction : {+1, -1}

    Returns
    -------
    fate : ndarray of int, shape (k,)
        +1 or -1, the sign of ``reaction . (q - saddle)`` at the exit from the region (or at the
        escape, for a trajectory that leaves the escape radius first); 0 if the trajectory stays in
        the region up to ``max_time``, fails, or the point is not allowed.
    exit_time : ndarray, shape (k,)
        |t| of that exit (``max_time`` where the fate is 0).
    """
    states, allowed = section_point_states(problem, points)
    fate = np.zeros(len(states), dtype=np.int64)
    exit_time = np.full(len(states), settings.max_time)
    if not allowed.any():
        return fate, exit_time
    n = problem.system.n_dof
    result = compute_ld(problem.system, states[allowed], direction, fate_settings(problem, settings))
    left = (result.left_region | result.escaped) & ~result.failed
    side = np.sign((result.end_state[:, :n] - problem.saddle) @ problem.reaction).astype(np.int64)
    fate[allowed] = np.where(left, side, 0)
    exit_time[allowed] = np.where(left, result.time, settings.max_time)
    if cost is not None:
        cost.add(int(allowed.sum()), float(result.time.sum()), int(result.steps.sum()))
    return fate, exit_time


def clip_to_allowed(problem: SliceProblem, ends: np.ndarray, others: np.ndarray) -> np.ndarray:
    """Move each segment end that lies outside the energetically allowed region towards the segment's
    midpoint until it is inside (to 1e-3 of the half-segment), so a bracket near the boundary of the
    allowed region still has two integrable ends. Shapes (m, 2)."""
    ends = ends.copy()
    _, allowed = section_point_states(problem, ends)
    if allowed.all():
        return ends
    middle = 0.5 * (ends + others)
    bad = np.flatnonzero(~allowed)
    inside, outside = middle[bad].copy(), ends[bad].copy()
    for _ in range(12):
        trial = 0.5 * (inside + outside)
        _, ok = section_point_states(problem, trial)
        inside[ok] = trial[ok]
        outside[~ok] = trial[~ok]
    ends[bad] = inside
    return ends
