"""Refinement of a detected NHIM point: by bisection on fates, and by zoomed LD re-gridding."""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np

from ...engine import LDSettings, compute_ld
from .batched import bisect_task, run_tasks
from .fates import Cost, RefinementFailed, RefinementSettings
from .slices import SliceProblem, section_point_states


def _switch_line(points: np.ndarray, fates: np.ndarray, shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray] | None:
    """Point and unit tangent of the line through the midpoints of stencil edges where the fate switches."""
    grid = points.reshape(*shape, 2)
    f = fates.reshape(shape)
    mids = []
    for a, b in (((slice(None, -1), slice(None)), (slice(1, None), slice(None))),
                 ((slice(None), slice(None, -1)), (slice(None), slice(1, None)))):
        switch = f[a] * f[b] == -1
        mids.append(0.5 * (grid[a][switch] + grid[b][switch]))
    mids = np.vstack(mids)
    if len(mids) < 2:
        return None
    centre = mids.mean(axis=0)
    _, _, vt = np.linalg.svd(mids - centre)
    return centre, vt[0]


class ManifoldsTangent(RefinementFailed):
    """The stable and unstable curves meet at too small an angle to locate their crossing: the slice
    is (nearly) tangent to the NHIM there, a degenerate slice, not a failed refinement."""


def _intersect(p1: np.ndarray, t1: np.ndarray, p2: np.ndarray, t2: np.ndarray, name: str) -> np.ndarray:
    """Intersection of the lines p1 + s t1 and p2 + r t2."""
    matrix = np.column_stack([t1, -t2])
    if abs(np.linalg.det(matrix)) < 1e-6:
        raise ManifoldsTangent(f"map {name}: the stable and unstable manifold curves are parallel here; no crossing")
    s, _ = np.linalg.solve(matrix, p2 - p1)
    return p1 + s * t1


@dataclass
class Refined:
    """A refined NHIM point and how it was obtained.

    point : ndarray, shape (2,)
    uncertainty : float
        Fates: the larger of the last update and bisection_precision / sin(angle); zoom: the final
        grid spacing. A bound on the error.
    iterations : int
    cost : Cost
    angle : float
        Angle between the stable and unstable curves at the point, radians (fates only; 0 otherwise).
    history : list of ndarray
        The estimate after each iteration.
    """

    point: np.ndarray
    uncertainty: float
    iterations: int
    cost: Cost
    angle: float = 0.0
    history: list = field(default_factory=list)


def refine_by_fates_task(problem: SliceProblem, guess: np.ndarray, settings: RefinementSettings):
    """The refinement of a detected NHIM point by bisection on forward and backward fates, as a task
    of :func:`ldpipe.core.nhim.batched.run_tasks` (the stable curve's segments by forward fates, the
    unstable curve's by backward fates, bisected in the same rounds): returns a :class:`Refined`
    (its ``cost`` left empty: a batch's cost is shared) or raises :class:`RefinementFailed`
    (:class:`ManifoldsTangent` where the curves cross too flatly for the tolerance)."""
    guess = np.asarray(guess, dtype=np.float64)
    spacing = problem.spacing
    m = settings.stencil_points
    half = settings.stencil_half_width
    lines = None
    for _ in range(4):
        offsets = np.linspace(-half, half, m)
        grid = np.stack(np.meshgrid(guess[0] + offsets * spacing[0], guess[1] + offsets * spacing[1], indexing="ij"), -1)
        stencil = grid.reshape(-1, 2)
        both = (yield problem, "fates", np.vstack([stencil, stencil]),
                np.repeat([1, -1], len(stencil)))["fate"]
        forward, backward = both[: len(stencil)], both[len(stencil):]
        lines = [_switch_line(stencil, forward, (m, m)), _switch_line(stencil, backward, (m, m))]
        if all(line is not None for line in lines):
            break
        half *= 2
        lines = None
    if lines is None:
        raise RefinementFailed(
            f"map {problem.name}: no switch of both the forward and the backward fate within {half / 2:g} grid "
            f"cells of the detected point {guess.tolist()}; the detection missed the NHIM"
        )
    (p_s, t_s), (p_u, t_u) = lines
    estimate = _intersect(p_s, t_s, p_u, t_u, problem.name)
    history = [estimate]
    h = float(np.hypot(*(half * spacing)) / 2)
    bracket = float(np.hypot(*(half * spacing)))
    update = np.inf
    for iteration in range(1, settings.max_iterations + 1):
        # Two segments across each curve, at +-h along it; the stable curve's by forward fates, the
        # unstable curve's by backward fates, all four bisected together.
        normals = [np.array([-t[1], t[0]]) for t in (t_s, t_s, t_u, t_u)]
        centres = [estimate + h * t_s, estimate - h * t_s, estimate + h * t_u, estimate - h * t_u]
        directions = np.array([1, 1, -1, -1])
        for attempt in range(6):
            try:
                found, _ = yield from bisect_task(
                    problem, np.array([c - bracket * m for c, m in zip(centres, normals)]),
                    np.array([c + bracket * m for c, m in zip(centres, normals)]), directions, settings)
                break
            except RefinementFailed:
                if attempt == 5:
                    raise
                bracket *= 4
        new_lines = []
        for pair in (found[:2], found[2:]):
            chord = pair[1] - pair[0]
            new_lines.append((pair[0], chord / np.linalg.norm(chord)))
        (p_s, t_s), (p_u, t_u) = new_lines
        new = _intersect(p_s, t_s, p_u, t_u, problem.name)
        update = float(np.linalg.norm(new - estimate))
        estimate = new
        history.append(estimate)
        if update <= settings.tolerance and h * h <= settings.tolerance:
            break
        h = max(h * settings.shrink, 10 * settings.bisection_precision)
        bracket = max(4 * update, 4 * h * h + 20 * settings.bisection_precision)
    else:
        raise RefinementFailed(
            f"map {problem.name}: fate refinement did not reach tolerance {settings.tolerance:g} in "
            f"{settings.max_iterations} iterations (last update {update:.3g})"
        )
    angle = float(np.arccos(min(1.0, abs(float(t_s @ t_u)))))
    # Each secant is known to the bisection precision across it; where the curves cross at a small
    # angle their intersection moves by that over sin(angle).
    uncertainty = max(update, settings.bisection_precision / max(np.sin(angle), 1e-300))
    if uncertainty > settings.tolerance:
        raise ManifoldsTangent(
            f"map {problem.name}: the manifolds cross at {angle:.3g} rad, so bisection to "
            f"{settings.bisection_precision:g} locates their crossing only to {uncertainty:.3g} > tolerance "
            f"{settings.tolerance:g}; lower nhim.refinement.bisection_precision"
        )
    return Refined(estimate, uncertainty, iteration, Cost(), angle, history)


def refine_by_fates(problem: SliceProblem, guess: np.ndarray, settings: RefinementSettings) -> Refined:
    """Refine a detected NHIM point by bisection on forward and backward fates; see the module docstring.

    Parameters
    ----------
    guess : array_like, shape (2,)
        The detected grid point (section coordinates).

    Returns
    -------
    Refined
        ``uncertainty`` <= ``settings.tolerance``.

    Raises
    ------
    RefinementFailed
        If no fate switch is found near the guess, or the iteration does not converge.
    """
    started = time.perf_counter()
    cost = Cost()
    (refined,) = run_tasks([refine_by_fates_task(problem, guess, settings)], settings, cost)
    cost.wall_time = time.perf_counter() - started
    return replace(refined, cost=cost)


def ld_at_points(
    problem: SliceProblem, points: np.ndarray, settings: LDSettings, cost: Cost | None = None,
) -> dict[str, np.ndarray]:
    """Forward and backward LD and exit times at section points, shapes (k,) each (0 where not allowed)."""
    states, allowed = section_point_states(problem, points)
    out = {name: np.zeros(len(states)) for name in ("ld_forward", "ld_backward", "exit_time_forward", "exit_time_backward")}
    if not allowed.any():
        return out
    for direction, suffix in ((1, "forward"), (-1, "backward")):
        result = compute_ld(problem.system, states[allowed], direction, settings)
        out[f"ld_{suffix}"][allowed] = result.ld
        out[f"exit_time_{suffix}"][allowed] = result.time
        if cost is not None:
            cost.add(int(allowed.sum()), float(result.time.sum()), int(result.steps.sum()))
    return out


def _ridge_line(field: np.ndarray, axes: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray] | None:
    """Point and unit tangent of a field's ridge on a small grid: the line through the per-row (or
    per-column) maxima, whichever scan crosses the ridge more squarely. Maxima on the window's
    edge are left out (the ridge leaves the window there)."""
    best = None
    n0, n1 = field.shape
    for axis in (1, 0):
        index = np.argmax(field, axis=axis)
        length = field.shape[axis]
        keep = (index > 0) & (index < length - 1)
        if keep.sum() < 3:
            continue
        other = np.arange(field.shape[1 - axis])[keep]
        found = index[keep]
        i, j = (other, found) if axis == 1 else (found, other)
        points = np.column_stack([axes[0][i], axes[1][j]])
        centre = points.mean(axis=0)
        _, _, vt = np.linalg.svd(points - centre)
        tangent = vt[0]
        # A scan along axis 1 (rows) suits a ridge running along axis 0, and vice versa.
        squareness = abs(tangent[0] if axis == 1 else tangent[1])
        if best is None or squareness > best[0]:
            best = (squareness, centre, tangent)
    return None if best is None else (best[1], best[2])


def refine_by_ld_zoom(problem: SliceProblem, guess: np.ndarray, settings: RefinementSettings) -> Refined:
    """Refine by zoomed re-gridding of both LDs (the paper's approach, made iterative).

    Each grid of ``zoom_points``^2 points spans ``stencil_half_width`` cells of the current grid
    on each side of the estimate. On it, each field's ridge is the line through its per-row (or
    per-column) maxima (each within half a cell of the true ridge, whatever the spikes), and the
    ridges' intersection is the next estimate; the next grid's span is ``zoom_factor`` times this
    one's. Stops when the grid spacing is below the tolerance. The LD uses the map's tau and p at
    the refinement's rtol.
    """
    started = time.perf_counter()
    cost = Cost()
    estimate = np.asarray(guess, dtype=np.float64)
    half_span = settings.stencil_half_width * problem.spacing
    ld_settings = replace(problem.ld_settings, scheme="dop853", rtol=settings.rtol, atol=settings.atol)
    n = settings.zoom_points
    history = [estimate]
    for iteration in range(1, settings.max_iterations * 4 + 1):
        axes = (estimate[0] + np.linspace(-1, 1, n) * half_span[0], estimate[1] + np.linspace(-1, 1, n) * half_span[1])
        grid = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 2)
        values = ld_at_points(problem, grid, ld_settings, cost)
        ridges = [_ridge_line(values[name].reshape(n, n), axes) for name in ("ld_forward", "ld_backward")]
        if any(ridge is None for ridge in ridges):
            raise RefinementFailed(f"map {problem.name}: an LD ridge left the zoomed grid around {estimate.tolist()}")
        (p_s, t_s), (p_u, t_u) = ridges
        estimate = _intersect(p_s, t_s, p_u, t_u, problem.name)
        history.append(estimate)
        spacing = float(np.hypot(*(2 * half_span / (n - 1))))
        if spacing <= settings.tolerance:
            break
        half_span = half_span * settings.zoom_factor
    else:
        raise RefinementFailed(f"map {problem.name}: zoomed re-gridding did not reach tolerance {settings.tolerance:g}")
    cost.wall_time = time.perf_counter() - started
    return Refined(estimate, spacing, iteration, cost, 0.0, history)
