"""Gap times: how long a trajectory entering the well through a dividing line stays before it leaves.

The entering ensemble is flux-weighted: points uniform on each line's allowed (u, p_u) region (the
measure δ(E − H) δ(s) |ṡ| dq dp, see :mod:`ldpipe.core.transport.flux`), the line chosen with
probability proportional to its area, with the normal momentum pointing into the well. Each is
integrated until it crosses any of the lines outwards (:func:`ldpipe.core.transport.exit_times`).

What holds exactly (derived in :mod:`ldpipe.core.transport.survival`): with Φ the total one-way flux
(the lines' areas), V the shell volume of the well, G(s) = Pr(τ > s) and P(t) the survival of the
well's microcanonical ensemble,

    Φ · E[min(τ, T)] = V · (1 − P(T))   for every T,        Φ · E[τ] = V · (1 − P(∞)):

Φ times the mean gap time is the volume of the reactive part of the shell (the states that enter
and leave, Kac's lemma); it equals V, ⟨τ⟩ = V/Φ, only if no part of the well is trapped for ever.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..trajectories import FlowSettings
from .flux import DividingLine
from .survival import exit_times


def entering_states(lines: Sequence[DividingLine], count: int, rng: np.random.Generator) -> np.ndarray:
    """``count`` flux-weighted states on ``lines`` moving into the well (normal momentum reversed)."""
    areas = np.array([line.area() for line in lines])
    per_line = rng.multinomial(count, areas / areas.sum())
    out = []
    for line, n in zip(lines, per_line):
        if n == 0:
            continue
        states = line.states(*line.sample(int(n), rng))
        q_dim = len(line.saddle)
        pn = states[:, q_dim:] @ line.normal
        states[:, q_dim:] -= 2.0 * pn[:, None] * line.normal[None, :]
        out.append(states)
    return np.concatenate(out)


@dataclass(frozen=True)
class GapTimes:
    """Gap times (inf: not left within ``duration``) and the total one-way flux ``flux`` of the lines."""

    times: np.ndarray
    flux: float
    duration: float

    def survival(self, grid: np.ndarray) -> np.ndarray:
        """G(t) = Pr(τ > t) at each t of ``grid``."""
        ordered = np.sort(self.times)
        return 1.0 - np.searchsorted(ordered, grid, side="right") / len(self.times)

    def truncated_mean(self, horizon: float) -> tuple[float, float]:
        """E[min(τ, T)] and its standard error (independent samples), T = ``horizon`` ≤ duration."""
        if horizon > self.duration:
            raise ValueError(f"horizon {horizon} is beyond the gap times' duration {self.duration}")
        clipped = np.minimum(self.times, horizon)
        return float(clipped.mean()), float(clipped.std(ddof=1) / np.sqrt(len(clipped)))

    def reactive_volume(self, horizon: float) -> tuple[float, float]:
        """Φ E[min(τ, T)] ± its standard error: the shell volume of the well that leaves by T
        (V (1 − P(T)) by the identity above), tending to the reactive volume as T grows."""
        mean, stderr = self.truncated_mean(horizon)
        return self.flux * mean, self.flux * stderr


def gap_times(system, lines: Sequence[DividingLine], count: int, duration: float, rng: np.random.Generator, *,
              sample_step: float = 0.05, segment: float = 20.0, flow: FlowSettings | None = None,
              threads: int | None = None) -> GapTimes:
    """Gap times of ``count`` flux-weighted states entering through ``lines``, each followed to ``duration``."""
    states = entering_states(lines, count, rng)
    times = exit_times(system, states, lines, duration, sample_step=sample_step, segment=segment, flow=flow,
                       threads=threads, on_surface=True)
    return GapTimes(times, float(sum(line.area() for line in lines)), float(duration))
