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
from .refinement import ManifoldsTangent, Refined, refine_by_fates
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


def _refine(problem: SliceProblem, candidate: Candidate, settings: RefinementSettings) -> Refined:
    """Refine by fates, retrying with the stencil halved (to one cell) if the refinement fails: two
    crossings a few cells apart put both in the first stencil, whose fate-switch lines then fit
    neither (measured: z-p_z slices through the x-y orbit of the 3 DoF system, 6 cells apart)."""
    half = settings.stencil_half_width
    while True:
        try:
            return refine_by_fates(problem, candidate.point, replace(settings, stencil_half_width=half))
        except ManifoldsTangent:
            raise
        except RefinementFailed:
            if half <= 1.0:
                raise
            half = max(half / 2, 1.0)


def find_every_crossing(problem: SliceProblem, settings: RefinementSettings) -> SliceCrossings:
    """Fates forward and backward on the slice's grid, every candidate (:func:`crossing_candidates`)
    refined by fates; candidates that refine to the same crossing (within 10 x tolerance) count once."""
    started = time.perf_counter()
    cost = Cost()
    axes = problem.section.axis_values()
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 2)
    shape = problem.section.shape
    _, allowed = section_point_states(problem, grid)
    forward, _ = exit_fates(problem, grid, +1, settings, cost)
    backward, _ = exit_fates(problem, grid, -1, settings, cost)
    forward, backward, allowed = forward.reshape(shape), backward.reshape(shape), allowed.reshape(shape)
    crossings = []
    for candidate in crossing_candidates(forward, backward, allowed, axes):
        try:
            refined = _refine(problem, candidate, settings)
        except ManifoldsTangent as error:
            crossings.append(Crossing(candidate, "tangent", message=str(error)))
            continue
        except RefinementFailed as error:
            crossings.append(Crossing(candidate, "not_converged", message=str(error)))
            continue
        cost.add(refined.cost.trajectories, refined.cost.time_units, refined.cost.steps)
        earlier = [c.refined.point for c in crossings if c.status == "refined"]
        if any(np.linalg.norm(refined.point - p) <= 10 * settings.tolerance for p in earlier):
            crossings.append(Crossing(candidate, "duplicate", refined))
        elif not _inside(problem, refined.point):
            crossings.append(Crossing(candidate, "outside_window", refined))
        else:
            crossings.append(Crossing(candidate, "refined", refined))
    cost.wall_time = time.perf_counter() - started
    return SliceCrossings(
        crossings=crossings, forward_cells=int(switch_cells(forward, allowed).sum()),
        backward_cells=int(switch_cells(backward, allowed).sum()), allowed_fraction=float(allowed.mean()), cost=cost,
    )
