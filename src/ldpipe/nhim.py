"""Points of the NHIM on a two-dimensional section: detection on an LD map, refinement below the grid.

On an isoenergetic section through the saddle region, the stable manifold of the
NHIM cuts a curve W^s (where the forward, variable-time LD has a ridge: those
points never leave the saddle region forward in time) and the unstable manifold
a curve W^u (the backward LD's ridge). The NHIM's points on the section are
where the two curves cross; for 2 DoF that is the unstable periodic orbit's
crossing of the section.

* **Detection** (:func:`detect_nhim_cell`). A grid point on W^s that happens to
  lie very close to it carries a spike of forward LD (the LD grows like
  log(1/distance)), and the plain global maximum of ld_forward + ld_backward can
  land on such a spike far from W^u. A point of the NHIM must be high in *both*
  fields, so the criterion is the largest ``min(F / F_ridge, B / B_ridge)``, each
  field in units of its typical ridge height (the median of the per-row maxima,
  which spikes barely move): a spike on one ridge alone scores no more than the
  other field there.
* **Refinement by fates** (:func:`refine_by_fates`). A trajectory that leaves
  the saddle region forward in time does so on the product or the reactant side
  of the saddle (the sign of the reaction coordinate, the saddle's unstable
  direction, at its first exit); that *forward fate* switches across W^s, and
  the backward fate across W^u. Bisection on fates along short segments across
  each curve gives points on it to integration accuracy; two such points per
  curve give its secant, the secants' intersection a new estimate, and the
  segments shrink around it until the estimate moves less than the tolerance.
  This is independent of the LD and converges quadratically in the segment
  spacing.
* **Refinement by zoomed re-gridding** (:func:`refine_by_ld_zoom`), the paper's
  way: recompute both LDs on a small grid around the estimate, take the
  detection criterion's best point, zoom in, repeat until the grid spacing is
  below the tolerance.

Every function takes plain arrays and returns plain arrays or dataclasses; the
stage (:mod:`ldpipe.stages.nhim`) does the I/O.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np

from .engine import LDSettings, compute_ld
from .errors import LdpipeError
from .flow import FlowSettings, integrate
from .periodic_orbits import linearize_saddle
from .sections import Section
from .systems import System


#: Batches of fewer trajectories than this are integrated on one thread (see :func:`exit_fates`).
SMALL_BATCH = 32


class RefinementFailed(LdpipeError):
    """A refinement could not bracket or converge; the message says where and why."""


@dataclass(frozen=True)
class SliceProblem:
    """Everything the detection and refinement need about one section of one system.

    Attributes
    ----------
    name : str
        The map's name, for messages.
    system : System
    section : Section
        Axes, ranges and grid shape of the LD map, fixed coordinates (numbers) and solved momentum.
    energy : float
        Total energy of the section.
    excess_energy : float
        Energy above the saddle's critical energy.
    saddle : ndarray, shape (n_dof,)
        Position of the index-1 saddle.
    region_lower, region_upper : ndarray, shape (n_dof,)
        The saddle region (configuration box) of the variable-time LD.
    reaction : ndarray, shape (n_dof,)
        Unit vector of the saddle's unstable direction (the Hessian's negative eigenvector); the
        sign of ``reaction . (q - saddle)`` at exit from the region is the trajectory's fate.
    ld_settings : LDSettings
        The map's LD settings (tau, p, region, integrator).
    """

    name: str
    system: System
    section: Section
    energy: float
    excess_energy: float
    saddle: np.ndarray
    region_lower: np.ndarray
    region_upper: np.ndarray
    reaction: np.ndarray
    ld_settings: LDSettings

    @property
    def spacing(self) -> np.ndarray:
        """Grid spacing along the two axes, shape (2,)."""
        return np.array([(hi - lo) / max(n - 1, 1) for (lo, hi), n in zip(self.section.ranges, self.section.shape)])


def make_slice_problem(
    name: str, system: System, section: Section, energy: float, critical_energy: float,
    saddle: np.ndarray, ld_settings: LDSettings,
) -> SliceProblem:
    """A :class:`SliceProblem` from a map's resolved pieces; the region must be set (variable time)."""
    if not ld_settings.variable_time:
        raise ValueError(f"map {name}: NHIM detection needs a variable-time LD map (a saddle region); this one is fixed time")
    saddle = np.asarray(saddle, dtype=np.float64)
    reaction = linearize_saddle(system, saddle).saddle_vector
    return SliceProblem(
        name=name, system=system, section=section, energy=float(energy),
        excess_energy=float(energy - critical_energy), saddle=saddle,
        region_lower=np.array(ld_settings.region_lower), region_upper=np.array(ld_settings.region_upper),
        reaction=reaction / np.linalg.norm(reaction), ld_settings=ld_settings,
    )


def section_point_states(problem: SliceProblem, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Phase-space states of arbitrary section points (not only grid points).

    Parameters
    ----------
    points : array_like, shape (k, 2)
        Values of the section's two axes.

    Returns
    -------
    states : ndarray, shape (k, 2 n_dof)
        The states, with the solved momentum from the energy (0 where not allowed).
    allowed : ndarray of bool, shape (k,)
        Where the solved momentum is real.
    """
    system, section = problem.system, problem.section
    points = np.atleast_2d(np.asarray(points, dtype=np.float64))
    phase = system.phase_coordinates
    n = system.n_dof
    states = np.zeros((len(points), 2 * n))
    states[:, phase.index(section.axes[0])] = points[:, 0]
    states[:, phase.index(section.axes[1])] = points[:, 1]
    for name, value in section.fixed.items():
        states[:, phase.index(name)] = value
    solve = phase.index(section.solve)
    potential = np.empty(len(states))
    system.kernels.potential_block(np.ascontiguousarray(states[:, :n].T), potential, len(states))
    other = np.delete(states[:, n:], solve - n, axis=1)
    radicand = 2.0 * (problem.energy - potential) - np.sum(other**2, axis=1)
    allowed = radicand >= 0.0
    states[allowed, solve] = section.sign * np.sqrt(radicand[allowed])
    return states, allowed


# ----------------------------------------------------------------------------------------------
# Detection on the grid


@dataclass(frozen=True)
class Detection:
    """A grid point chosen by a criterion: its index (i, j), section coordinates and score."""

    index: tuple[int, int]
    point: np.ndarray
    score: float


def ridge_level(field: np.ndarray, allowed: np.ndarray) -> float:
    """A spike-proof scale of a field's ridges: the median of the per-row maxima, or of the per-column
    maxima, whichever is larger (the scan that crosses the ridges gives the higher one). Each row that
    crosses a ridge contributes about the ridge's value there; a few grid points that happen to lie
    very close to the ridge (spikes) move the median little, unlike the global maximum."""
    masked = np.where(allowed, field, -np.inf)
    levels = []
    for axis in (1, 0):
        maxima = masked.max(axis=axis)
        maxima = maxima[np.isfinite(maxima)]
        levels.append(float(np.median(maxima)))
    return max(levels)


def nhim_score(ld_forward: np.ndarray, ld_backward: np.ndarray, allowed: np.ndarray) -> np.ndarray:
    """The detection criterion ``min(F / F_ridge, B / B_ridge)`` on the allowed points (-inf elsewhere).

    ``F_ridge``, ``B_ridge`` are :func:`ridge_level` of each field, so each field counts in units
    of its typical ridge height and a spike on one ridge (far from the other) scores only what the
    other field gives it there.

    Parameters
    ----------
    ld_forward, ld_backward : ndarray, shape (m, n)
    allowed : ndarray of bool, shape (m, n)

    Returns
    -------
    ndarray, shape (m, n)
    """
    allowed = np.asarray(allowed, dtype=bool)
    if not allowed.any():
        raise ValueError("no allowed point on the map; nothing to detect")
    level_forward = ridge_level(ld_forward, allowed)
    level_backward = ridge_level(ld_backward, allowed)
    if not (level_forward > 0 and level_backward > 0):
        raise ValueError("the LD fields' ridges are not positive on the allowed points; not an LD map")
    score = np.minimum(ld_forward / level_forward, ld_backward / level_backward)
    return np.where(allowed, score, -np.inf)


def _pick(score: np.ndarray, axes: tuple[np.ndarray, np.ndarray]) -> Detection:
    i, j = np.unravel_index(int(np.argmax(score)), score.shape)
    return Detection((int(i), int(j)), np.array([axes[0][i], axes[1][j]]), float(score[i, j]))


def detect_nhim_cell(
    ld_forward: np.ndarray, ld_backward: np.ndarray, allowed: np.ndarray, axes: tuple[np.ndarray, np.ndarray],
) -> Detection:
    """The grid point where both LD ridges meet (largest :func:`nhim_score`).

    ``axes`` are the grid coordinates along the two section axes, shapes (m,) and (n,).
    """
    return _pick(nhim_score(ld_forward, ld_backward, allowed), axes)


def detect_global_argmax(
    ld_forward: np.ndarray, ld_backward: np.ndarray, allowed: np.ndarray, axes: tuple[np.ndarray, np.ndarray],
) -> Detection:
    """The plain global maximum of ld_forward + ld_backward (the naive criterion, for comparison)."""
    total = np.where(np.asarray(allowed, dtype=bool), ld_forward + ld_backward, -np.inf)
    return _pick(total, axes)


# ----------------------------------------------------------------------------------------------
# Fates and their bisection


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
    sample_interval : float
        Time between the samples on which the first exit from the region is looked for.
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
    sample_interval: float = 0.05
    stencil_points: int = 9
    stencil_half_width: float = 4.0
    shrink: float = 0.05
    max_iterations: int = 12
    zoom_points: int = 11
    zoom_factor: float = 0.25

    def __post_init__(self):
        for name in ("tolerance", "bisection_precision", "rtol", "atol", "max_time", "sample_interval",
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


def exit_fates(
    problem: SliceProblem, points: np.ndarray, direction: int, settings: RefinementSettings, cost: Cost | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Which side of the saddle each trajectory leaves the region by, forward or backward in time.

    Parameters
    ----------
    points : array_like, shape (k, 2)
        Section points.
    direction : {+1, -1}

    Returns
    -------
    fate : ndarray of int, shape (k,)
        +1 or -1, the sign of ``reaction . (q - saddle)`` at the first sample outside the region;
        0 if the trajectory stays in the region up to ``max_time`` or the point is not allowed.
    exit_time : ndarray, shape (k,)
        |t| of that first sample outside (``max_time`` where the fate is 0).
    """
    states, allowed = section_point_states(problem, points)
    fate = np.zeros(len(states), dtype=np.int64)
    exit_time = np.full(len(states), settings.max_time)
    if not allowed.any():
        return fate, exit_time
    n = problem.system.n_dof
    flow = FlowSettings(rtol=settings.rtol, atol=settings.atol, escape_radius=problem.ld_settings.escape_radius)
    times = direction * np.arange(0.0, settings.max_time + 0.5 * settings.sample_interval, settings.sample_interval)
    # A bisection round integrates a handful of trajectories: starting numba's thread pool for them
    # costs ~20 ms a call on a busy machine, against ~0.1 ms on one thread (measured), so small
    # batches run on one thread.
    threads = 1 if allowed.sum() < SMALL_BATCH else None
    result = integrate(problem.system, states[allowed], float(times[-1]), flow, sample_times=times,
                       threads=threads)
    positions = result.samples[:, :, :n]
    outside = np.any((positions < problem.region_lower) | (positions > problem.region_upper), axis=2)
    left = outside.any(axis=1)
    first = np.argmax(outside, axis=1)
    exit_positions = positions[np.arange(len(first)), first]
    side = np.sign((exit_positions - problem.saddle) @ problem.reaction).astype(np.int64)
    fate[allowed] = np.where(left, side, 0)
    exit_time[allowed] = np.where(left, np.abs(times[first]), settings.max_time)
    if cost is not None:
        cost.add(int(allowed.sum()), float(np.abs(result.final_time).sum()), int(result.steps.sum()))
    return fate, exit_time


def _clip_to_allowed(problem: SliceProblem, ends: np.ndarray, others: np.ndarray) -> np.ndarray:
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


def bisect_fate_switch(
    problem: SliceProblem, starts: np.ndarray, ends: np.ndarray, direction: int, settings: RefinementSettings,
    cost: Cost | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Bisect each segment [start, end] to the point where the fate in ``direction`` switches.

    All segments are bisected together (one batch of trajectories per halving).

    Parameters
    ----------
    starts, ends : ndarray, shape (m, 2)

    Returns
    -------
    points : ndarray, shape (m, 2)
        Midpoints of the final brackets.
    widths : ndarray, shape (m,)
        Final bracket lengths (<= ``bisection_precision``, or 0 where a midpoint never left).

    Raises
    ------
    RefinementFailed
        If a segment's ends have the same fate (or none): the segment does not bracket the manifold.
    """
    lo = _clip_to_allowed(problem, np.array(starts, dtype=np.float64), np.array(ends, dtype=np.float64))
    hi = _clip_to_allowed(problem, np.array(ends, dtype=np.float64), np.array(starts, dtype=np.float64))
    fates, _ = exit_fates(problem, np.vstack([lo, hi]), direction, settings, cost)
    f_lo, f_hi = fates[: len(lo)], fates[len(lo):]
    bad = (f_lo * f_hi) != -1
    if bad.any():
        raise RefinementFailed(
            f"map {problem.name}: {int(bad.sum())} of {len(lo)} segments do not bracket a switch of the "
            f"{'forward' if direction > 0 else 'backward'} fate (end fates {f_lo[bad].tolist()}, {f_hi[bad].tolist()})"
        )
    width = np.linalg.norm(hi - lo, axis=1)
    while np.any(width > settings.bisection_precision):
        active = width > settings.bisection_precision
        middle = 0.5 * (lo[active] + hi[active])
        f_mid, _ = exit_fates(problem, middle, direction, settings, cost)
        index = np.flatnonzero(active)
        same_lo = f_mid == f_lo[index]
        same_hi = f_mid == f_hi[index]
        lo[index[same_lo]] = middle[same_lo]
        hi[index[same_hi]] = middle[same_hi]
        # Still inside after max_time: the midpoint is on the manifold as far as the integration can tell.
        stuck = ~(same_lo | same_hi)
        lo[index[stuck]] = middle[stuck]
        hi[index[stuck]] = middle[stuck]
        width = np.linalg.norm(hi - lo, axis=1)
    return 0.5 * (lo + hi), width


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


def _intersect(p1: np.ndarray, t1: np.ndarray, p2: np.ndarray, t2: np.ndarray, name: str) -> np.ndarray:
    """Intersection of the lines p1 + s t1 and p2 + r t2."""
    matrix = np.column_stack([t1, -t2])
    if abs(np.linalg.det(matrix)) < 1e-6:
        raise RefinementFailed(f"map {name}: the stable and unstable manifold curves are parallel here; no crossing")
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
    guess = np.asarray(guess, dtype=np.float64)
    spacing = problem.spacing
    m = settings.stencil_points
    half = settings.stencil_half_width
    lines = None
    for _ in range(4):
        offsets = np.linspace(-half, half, m)
        grid = np.stack(np.meshgrid(guess[0] + offsets * spacing[0], guess[1] + offsets * spacing[1], indexing="ij"), -1)
        stencil = grid.reshape(-1, 2)
        forward, _ = exit_fates(problem, stencil, +1, settings, cost)
        backward, _ = exit_fates(problem, stencil, -1, settings, cost)
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
    # Secant spacing and bracket half-length, in section units.
    h = float(np.hypot(*(half * spacing)) / 2)
    bracket = float(np.hypot(*(half * spacing)))
    update = np.inf
    for iteration in range(1, settings.max_iterations + 1):
        new_lines = []
        for direction, tangent in ((+1, t_s), (-1, t_u)):
            normal = np.array([-tangent[1], tangent[0]])
            centres = np.array([estimate + h * tangent, estimate - h * tangent])
            for attempt in range(6):
                try:
                    found, _ = bisect_fate_switch(
                        problem, centres - bracket * normal, centres + bracket * normal, direction, settings, cost,
                    )
                    break
                except RefinementFailed:
                    if attempt == 5:
                        raise
                    bracket *= 4
            chord = found[1] - found[0]
            new_lines.append((found[0], chord / np.linalg.norm(chord)))
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
    cost.wall_time = time.perf_counter() - started
    angle = float(np.arccos(min(1.0, abs(float(t_s @ t_u)))))
    # Each secant is known to the bisection precision across it; where the curves cross at a small
    # angle their intersection moves by that over sin(angle).
    uncertainty = max(update, settings.bisection_precision / max(np.sin(angle), 1e-300))
    if uncertainty > settings.tolerance:
        raise RefinementFailed(
            f"map {problem.name}: the manifolds cross at {angle:.3g} rad, so bisection to "
            f"{settings.bisection_precision:g} locates their crossing only to {uncertainty:.3g} > tolerance "
            f"{settings.tolerance:g}; lower nhim.refinement.bisection_precision"
        )
    return Refined(estimate, uncertainty, iteration, cost, angle, history)


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


# ----------------------------------------------------------------------------------------------
# References and evidence


def orbit_section_crossing(
    problem: SliceProblem, orbit_state: np.ndarray, period: float, *, rtol: float = 1e-13, atol: float = 1e-13,
) -> np.ndarray:
    """Where a periodic orbit of a 2 DoF system crosses the section, in section coordinates, shape (2,).

    The section must fix one coordinate q_j and solve its conjugate momentum p_j with a sign s
    (as U_xpx^+(k): y = k, p_y > 0): the crossing is the orbit's passage through q_j = value with
    dq_j/dt = p_j of sign s, located by the flow integrator's event (Newton on the step).
    """
    system, section = problem.system, problem.section
    if len(section.fixed) != 1:
        raise ValueError(
            f"map {problem.name}: a periodic orbit crosses a section with one fixed coordinate (2 DoF); "
            f"this one fixes {sorted(section.fixed)}"
        )
    (name, value), = section.fixed.items()
    if name not in system.coordinates or section.solve != "p" + name:
        raise ValueError(
            f"map {problem.name}: the orbit crossing needs the fixed coordinate to be a position and the solved "
            f"momentum its conjugate (fixed {name}, solved {section.solve})"
        )
    flow = FlowSettings(rtol=rtol, atol=atol, escape_radius=problem.ld_settings.escape_radius)
    result = integrate(system, np.atleast_2d(orbit_state), 1.5 * period, flow, section=(name, value, section.sign),
                       max_crossings=1)
    if result.crossing_count[0] < 1:
        raise ValueError(f"map {problem.name}: the periodic orbit never crosses {name} = {value} with {section.solve} "
                         f"of sign {section.sign:+d}")
    state = result.crossings[0, 0]
    phase = system.phase_coordinates
    return np.array([state[phase.index(section.axes[0])], state[phase.index(section.axes[1])]])


def orbit_section_residual(problem: SliceProblem, samples: np.ndarray) -> tuple[float, np.ndarray]:
    """How close a sampled orbit comes to the section's fixed values (for sections it may miss).

    Parameters
    ----------
    samples : ndarray, shape (s, 2 n_dof)

    Returns
    -------
    residual : float
        Smallest over the samples of the largest |coordinate - fixed value| (0 on the section),
        counting only samples whose solved momentum has the section's sign.
    point : ndarray, shape (2,)
        The section coordinates of that sample.
    """
    phase = problem.system.phase_coordinates
    columns = [phase.index(name) for name in problem.section.fixed]
    values = np.array(list(problem.section.fixed.values()))
    residual = np.max(np.abs(samples[:, columns] - values), axis=1)
    sign_ok = problem.section.sign * samples[:, phase.index(problem.section.solve)] > 0
    residual = np.where(sign_ok, residual, np.inf)
    best = int(np.argmin(residual))
    axes = [phase.index(a) for a in problem.section.axes]
    return float(residual[best]), samples[best, axes]


def residence_evidence(
    problem: SliceProblem, point: np.ndarray, settings: RefinementSettings, cost: Cost | None = None,
) -> dict[str, float]:
    """Time spent in the saddle region, forward and backward, by a point and by its grid neighbours.

    The neighbours are the 8 points one grid cell away. Integrated at the refinement's rtol with
    tau = ``max_time`` (so the exit time, not tau, ends each trajectory).

    Returns
    -------
    dict with ``residence_forward``, ``residence_backward`` (the point), and
    ``neighbour_residence_max`` (the largest min(forward, backward) over the neighbours).
    """
    offsets = np.array([(a, b) for a in (-1, 0, 1) for b in (-1, 0, 1) if (a, b) != (0, 0)], dtype=float)
    points = np.vstack([point, point + offsets * problem.spacing])
    ld_settings = replace(problem.ld_settings, scheme="dop853", rtol=settings.rtol, atol=settings.atol,
                          tau=settings.max_time)
    values = ld_at_points(problem, points, ld_settings, cost)
    both = np.minimum(values["exit_time_forward"], values["exit_time_backward"])
    return {
        "residence_forward": float(values["exit_time_forward"][0]),
        "residence_backward": float(values["exit_time_backward"][0]),
        "neighbour_residence_max": float(both[1:].max()),
    }
