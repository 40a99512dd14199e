"""A microcanonical ensemble in the well of a 2 DoF system, integrated until it leaves: survival.

Points are drawn uniformly on the energy shell of the well: for H = |p|²/2 + V in 2 DoF the shell
measure projects to the uniform measure on the allowed well (each q carries 2π of momentum
directions), so q is uniform on the well (rejection from a box) and p = √(2(E − V)) (cos φ, sin φ)
with φ uniform. A trajectory leaves when it crosses a dividing line outwards (s = n·(q − q_s) > 0
on one of the lines), the exit time found on samples and refined by linear interpolation of s.

The fraction left by t, F(t) = 1 − P(t), is exactly related to the gap times τ (entry to exit,
:mod:`ldpipe.core.transport.gap_times`) of the flux-weighted ensemble entering through the lines. An
exit at time s by a state that was in the well at 0 is an outward crossing of the lines (one-way flux
Φ, the sum of the lines' areas, :meth:`DividingLine.area`) whose time since its previous crossing
exceeds s; by time reversal (p → −p) that time has the gap times' distribution. So

    V · F(T) = Φ ∫_0^T G(s) ds = Φ · E[min(τ, T)],    G(s) = Pr(τ > s), V the shell volume,

for every T, and −dP/dt = (Φ / V) G(t). The initial slope is Φ/V; F(t0)/t0 falls short of it only
by the entries that leave again within t0 (recrossings near the ends of a line), a relative bias
(1/t0) ∫_0^t0 (1 − G) ds: nil at t0 = 2 on Barbanis (no gap time below 2 among 2·10⁴ entries at
each of ΔE = 0.125, 1, 2.25 and 5). Φ of the straight lines exceeds the
reactive flux (the orbit's action) by their recrossings, 5e-5 to 2e-3 relative on Barbanis, so the
initial slope equals k_TST = (reactive flux out)/V to that, far below its statistical error.

As T → ∞, Φ E[τ] = V (1 − P(∞)): the mean gap time is the reactive part of the shell over the flux
(Kac's lemma), V/Φ only when no part of the well is trapped for ever.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..trajectories import FlowSettings, integrate
from .flux import DividingLine
from .well import ray_radius


def sample_well(system, well, energy: float, lines: Sequence[DividingLine], count: int,
                rng: np.random.Generator) -> np.ndarray:
    """``count`` states (x, y, p_x, p_y) uniform on the energy shell of the well (microcanonical)."""
    well = np.asarray(well, dtype=np.float64)
    angles = np.linspace(-math.pi, math.pi, 721)
    reach = 1.05 * max(ray_radius(system, well, energy, lines, t, 0.05) for t in angles) + 0.1
    lower, upper = well - reach, well + reach
    out, have = [], 0
    while have < count:
        q = rng.uniform(lower, upper, size=(4 * (count - have) + 64, 2))
        v = system.potentials(q)
        keep = v < energy
        for line in lines:
            keep &= (q - line.saddle) @ line.normal < 0
        q, v = q[keep], v[keep]
        phi = rng.uniform(0.0, 2 * math.pi, size=len(q))
        speed = np.sqrt(2.0 * (energy - v))
        out.append(np.hstack([q, (speed * np.cos(phi))[:, None], (speed * np.sin(phi))[:, None]]))
        have += len(q)
    return np.concatenate(out)[:count]


def _largest_side(samples: np.ndarray, normals: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """max over the lines k of s_k = n_k·q − c_k at each sample (shape (traj, sample)), q = the first two
    entries of each state. Line by line, each s_k as x n_x + y n_y − c (the sum of products in
    order, as a contraction over the two coordinates forms it); the max taken pairwise, in line
    order: no (traj, sample, line) array and no reduction over a short last axis."""
    x, y = samples[:, :, 0], samples[:, :, 1]
    largest = None
    for normal, offset in zip(normals, offsets):
        side = x * normal[0] + y * normal[1] - offset
        largest = side if largest is None else np.maximum(largest, side, out=largest)
    return largest


def exit_times(system, states: np.ndarray, lines: Sequence[DividingLine], duration: float, *,
               sample_step: float = 0.05, segment: float = 20.0, flow: FlowSettings | None = None,
               threads: int | None = None, on_surface: bool = False) -> np.ndarray:
    """Time at which each state first crosses one of ``lines`` outwards (inf if not within ``duration``).

    Integrated in segments of ``segment`` time, sampled every ``sample_step``; survivors restart from
    their last sample. The crossing time is interpolated linearly in s between samples.
    ``on_surface``: the states start on a line moving inwards (gap times), so their first sample,
    where s is 0 up to rounding, is not an exit.
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
        s = _largest_side(result.samples, normals, offsets)  # (traj, sample)
        if on_surface and start == 0.0:
            s[:, 0] = -np.inf
        out = s > 0
        left = out.any(axis=1)
        first = np.argmax(out, axis=1)
        rows = np.flatnonzero(left)
        k = first[rows]
        s0, s1 = s[rows, k - 1], s[rows, k]
        # A state that starts on a line and is back across it by the first sample recrossed within one
        # step: its time is known only to that step, and the midpoint is taken.
        fraction = np.where(k > 0, np.where(np.isfinite(s0), -s0 / np.where(s1 - s0 > 0, s1 - s0, 1.0), 0.5), 0.0)
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
    """−dP/dt at 0 estimated as (fraction with exit time ≤ t0) / t0.

    The number left by t0 of N independent states is binomial(N, F(t0)), so the estimate's variance
    is F(1 − F)/(N t0²); F is estimated by the observed fraction, floored at 1/N so an ensemble of
    which none left does not claim a zero error. Its expectation is Φ E[min(τ, t0)]/(V t0) (module
    docstring): the rate Φ/V up to the few entries that leave within t0."""
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
