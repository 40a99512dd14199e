"""Every crossing of the NHIM in one slice's window: fates on the window's grid, the separated
places where both manifold curves pass, each refined by fates (:func:`refine_by_fates`).

In n DoF the NHIM is a (2n - 3)-sphere in the (2n - 1)-dimensional energy surface, and a slice
(two axes, 2n - 3 coordinates fixed, one momentum solved) meets it in isolated points, as many as
there are: one per crossing, and a window may hold several. What cannot be a point is recorded as
such, with a reason code: a slice with no crossing, a crossing where the curves meet too flatly to
be located (the slice tangent to the NHIM), a candidate whose refinement does not converge.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np

from .detection import Candidate, crossing_candidates, switch_cells
from .fates import Cost, RefinementFailed, RefinementSettings, exit_fates
from .batched import charging, run_tasks
from .refinement import ManifoldsTangent, Refined, refine_by_fates_task
from .slices import SliceProblem, section_point_states

#: Reason codes of a candidate that is not a refined crossing, and what each means.
CROSSING_STATUS = {
    "refined": "refined by fates to the tolerance",
    "tangent": "the stable and unstable curves meet too flatly to locate their crossing (slice tangent to the NHIM)",
    "not_converged": "no fate switch around the candidate, or the refinement did not converge",
    "duplicate": "refined to a crossing an earlier candidate already gave",
    "outside_window": "refined to a crossing outside the slice's window",
}


@dataclass
class Crossing:
    """One candidate and what became of it: ``status`` is a key of :data:`CROSSING_STATUS`;
    ``refined`` is set for ``refined``, ``duplicate`` and ``outside_window``."""

    candidate: Candidate
    status: str
    refined: Refined | None = None
    message: str = ""


@dataclass
class SliceCrossings:
    """The crossings of one window and the work spent finding them.

    crossings : list of Crossing
        One per candidate, most grid cells first.
    forward_cells, backward_cells : int
        Grid cells crossed by the stable (forward fate) and unstable (backward fate) curve.
    allowed_fraction : float
        Fraction of the window's grid points where the solved momentum is real.
    cost : Cost
        All trajectories (grid and refinements).
    """

    crossings: list[Crossing]
    forward_cells: int
    backward_cells: int
    allowed_fraction: float
    cost: Cost = field(default_factory=Cost)

    @property
    def points(self) -> np.ndarray:
        """The distinct refined crossings inside the window, shape (k, 2)."""
        found = [c.refined.point for c in self.crossings if c.status == "refined"]
        return np.array(found).reshape(-1, 2)


def _inside(problem: SliceProblem, point: np.ndarray) -> bool:
    return all(lo <= v <= hi for v, (lo, hi) in zip(point, problem.section.ranges))


def _refine_task(problem: SliceProblem, candidate: Candidate, settings: RefinementSettings):
    """Refine by fates, as a task, retrying with the stencil halved (to one cell) if the refinement fails:
    two crossings a few cells apart put both in the first stencil, whose fate-switch lines then fit
    neither (measured: z-p_z slices through the x-y orbit of the 3 DoF system, 6 cells apart).
    Returns the :class:`Refined`, its cost that of the attempt that succeeded (as
    :func:`refine_by_fates` counts it), or the :class:`RefinementFailed` that ended it."""
    half = settings.stencil_half_width
    while True:
        started = time.perf_counter()
        cost = Cost()
        try:
            refined = yield from charging(
                refine_by_fates_task(problem, candidate.point, replace(settings, stencil_half_width=half)), cost)
        except ManifoldsTangent as error:
            return error
        except RefinementFailed as error:
            if half <= 1.0:
                return error
            half = max(half / 2, 1.0)
            continue
        cost.wall_time = time.perf_counter() - started
        return replace(refined, cost=cost)


def find_every_crossing(problem: SliceProblem, settings: RefinementSettings) -> SliceCrossings:
    """Fates forward and backward on the slice's grid, every candidate (:func:`crossing_candidates`)
    refined by fates; candidates that refine to the same crossing (within 10 x tolerance) count once."""
    (found,) = find_crossings_together([problem], settings)
    return found


def find_crossings_together(problems: list[SliceProblem], settings: RefinementSettings) -> list[SliceCrossings]:
    """:func:`find_every_crossing` of slices of one family (one system, energy, pair of axes and solved
    momentum: what :func:`ldpipe.core.nhim.batched.run_tasks` answers together), every candidate of
    every slice refined in the same bisection rounds. A refinement is a chain of small engine calls;
    one slice's few candidates leave most of an engine block's lanes idle, and the call's cost is the
    block's. Each crossing is the one its slice searched alone would give; the refinements' wall
    time, shared, is split among the slices by their number of candidates."""
    searched = []
    for problem in problems:
        started = time.perf_counter()
        cost = Cost()
        axes = problem.section.axis_values()
        grid = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 2)
        shape = problem.section.shape
        _, allowed = section_point_states(problem, grid)
        forward, _ = exit_fates(problem, grid, +1, settings, cost)
        backward, _ = exit_fates(problem, grid, -1, settings, cost)
        forward, backward, allowed = forward.reshape(shape), backward.reshape(shape), allowed.reshape(shape)
        candidates = list(crossing_candidates(forward, backward, allowed, axes))
        cost.wall_time = time.perf_counter() - started
        searched.append((cost, forward, backward, allowed, candidates))
    started = time.perf_counter()
    tasks = [_refine_task(problem, candidate, settings)
             for problem, (*_, candidates) in zip(problems, searched) for candidate in candidates]
    outcomes = iter(run_tasks(tasks, settings))
    refining = (time.perf_counter() - started) / max(1, len(tasks))
    found = []
    for problem, (cost, forward, backward, allowed, candidates) in zip(problems, searched):
        crossings = []
        for candidate in candidates:
            refined = next(outcomes)
            if isinstance(refined, ManifoldsTangent):
                crossings.append(Crossing(candidate, "tangent", message=str(refined)))
                continue
            if isinstance(refined, RefinementFailed):
                crossings.append(Crossing(candidate, "not_converged", message=str(refined)))
                continue
            cost.add(refined.cost.trajectories, refined.cost.time_units, refined.cost.steps)
            earlier = [c.refined.point for c in crossings if c.status == "refined"]
            if any(np.linalg.norm(refined.point - p) <= 10 * settings.tolerance for p in earlier):
                crossings.append(Crossing(candidate, "duplicate", refined))
            elif not _inside(problem, refined.point):
                crossings.append(Crossing(candidate, "outside_window", refined))
            else:
                crossings.append(Crossing(candidate, "refined", refined))
        cost.wall_time += refining * len(candidates)
        found.append(SliceCrossings(
            crossings=crossings, forward_cells=int(switch_cells(forward, allowed).sum()),
            backward_cells=int(switch_cells(backward, allowed).sum()), allowed_fraction=float(allowed.mean()),
            cost=cost,
        ))
    return found
