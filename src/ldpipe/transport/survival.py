"""A microcanonical ensemble in the well of a 2 DoF system, integrated until it leaves: survival.

Points are drawn uniformly on the energy shell of the well: for H = |p|²/2 + V in 2 DoF the shell
measure projects to the uniform measure on the allowed well (each q carries 2π of momentum
directions), so q is uniform on the well (rejection from a box) and p = √(2(E − V)) (cos φ, sin φ)
with φ uniform. A trajectory leaves when it crosses a dividing line outwards (s = n·(q − q_s) > 0
on one of the lines), the exit time found on samples and refined by linear interpolation of s.

For t shorter than the quickest path across the well no trajectory that left can have entered
after t = 0, so the fraction left by t is exactly k_TST · t (the flux out of an invariant ensemble
is constant): the initial slope of the survival probability is the TST rate.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..flow import FlowSettings, integrate
from .flux import DividingLine
from .well import _ray_radius


def sample_well(system, well, energy: float, lines: Sequence[DividingLine], count: int,
                rng: np.random.Generator) -> np.ndarray:
    """``count`` states (x, y, p_x, p_y) uniform on the energy shell of the well (microcanonical)."""
    well = np.asarray(well, dtype=np.float64)
    angles = np.linspace(-math.pi, math.pi, 721)
    reach = 1.05 * max(_ray_radius(system, well, energy, lines, t, 0.05) for t in angles) + 0.1
    lower, upper = well - reach, well + reach
    out, have = [], 0
    while have < count:
        q = rng.uniform(lower, upper, size=(4 * (count - have) + 64, 2))
        v = np.array([system.potential(row) for row in q])
        keep = v < energy
        for line in lines:
            keep &= (q - line.saddle) @ line.normal < 0
        q, v = q[keep], v[keep]
        phi = rng.uniform(0.0, 2 * math.pi, size=len(q))
        speed = np.sqrt(2.0 * (energy - v))
        out.append(np.hstack([q, (speed * np.cos(phi))[:, None], (speed * np.sin(phi))[:, None]]))
        have += len(q)
    return np.concatenate(out)[:count]


def exit_times(system, states: np.ndarray, lines: Sequence[DividingLine], duration: float, *,
               sample_step: float = 0.05, segment: float = 20.0, flow: FlowSettings | None = None,
               threads: int | None = None) -> np.ndarray:
    """Time at which each state first crosses one of ``lines`` outwards (inf if not within ``duration``).

    Integrated in segments of ``segment`` time, sampled every ``sample_step``; survivors restart from
    their last sample. The crossing time is interpolated linearly in s between samples.
    """
    flow = FlowSettings() if flow is None else flow
    normals = np.array([line.normal for line in lines])
    offsets = np.array([line.normal @ line.saddle for line in lines])
    times = np.full(len(states), np.inf)
    alive = np.arange(len(states))
    current = np.asarray(states, dtype=np.float64).copy()
    start = 0.0
    while len(alive) and start < duration:
        length = min(segment, duration - start)
        grid = np.linspace(0.0, length, max(1, math.ceil(length / sample_step - 1e-9)) + 1)
        result = integrate(system, current, grid[-1], flow, sample_times=grid, threads=threads)
        s = np.einsum("tsi,ki->tsk", result.samples[:, :, :2], normals) - offsets  # (traj, sample, line)
        s = s.max(axis=2)
        out = s > 0
        left = out.any(axis=1)
        first = np.argmax(out, axis=1)
        rows = np.flatnonzero(left)
        k = first[rows]
        s0, s1 = s[rows, k - 1], s[rows, k]
        fraction = np.where(k > 0, -s0 / np.where(s1 - s0 > 0, s1 - s0, 1.0), 0.0)
        times[alive[rows]] = start + grid[np.maximum(k - 1, 0)] + fraction * (grid[k] - grid[np.maximum(k - 1, 0)])
        stay = ~left
        current = result.samples[stay, -1]
        alive = alive[stay]
        start += grid[-1]
    return times


@dataclass(frozen=True)
class InitialSlope:
    """Fraction of the ensemble left by ``t0`` over ``t0``, and its binomial standard error."""

    rate: float
    stderr: float
    left: int
    count: int


def initial_slope(times: np.ndarray, t0: float) -> InitialSlope:
    """−dP/dt at 0 estimated as (fraction with exit time ≤ t0) / t0 (exact while t0 is below the
    quickest crossing of the well)."""
    left = int(np.sum(times <= t0))
    count = len(times)
    f = left / count
    return InitialSlope(f / t0, math.sqrt(max(f * (1 - f), 1.0 / count) / count) / t0, left, count)


def survival(times: np.ndarray, grid: np.ndarray) -> np.ndarray:
    """P(t): the fraction of exit times beyond each t of ``grid``."""
    ordered = np.sort(times)
    return 1.0 - np.searchsorted(ordered, grid, side="right") / len(times)


def decay_rate(times: np.ndarray, t_start: float, t_end: float) -> float:
    """Long-time decay rate: the least-squares slope of −log P(t) on [t_start, t_end]."""
    grid = np.linspace(t_start, t_end, 200)
    p = survival(times, grid)
    if np.any(p <= 0):
        raise ValueError("the survival probability reaches 0 inside the fitting window")
    slope = np.polyfit(grid, np.log(p), 1)[0]
    return float(-slope)
