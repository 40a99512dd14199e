"""Throughput of the vector-field LD path (first-order DOP853, one trajectory per lane) on the
forced Duffing oscillator, against scipy's DOP853 on the same trajectories.

System: x' = y, y' = x - x^3 - 0.25 y + 0.3 cos(1.2 t), from t0 = 1.5, tau = 10 each way, on a
grid of ``--grid`` x ``--grid`` points over x in [-1.6, 1.6], y in [-1.2, 1.2] (the quick
configuration's map). For each tolerance it prints the wall time of ``compute_ld`` (forward,
M_1/2), the throughput in trajectory time units per second and per CPU second, and the mean step
attempts. The reference is scipy ``solve_ivp`` (DOP853, the same rtol = atol) integrating the
arc-length LD as an extra state on ``--scipy-points`` of the points (scipy's cost per trajectory
does not depend on the integrand), and the arc-length LD of ldpipe on those points, with the
relative difference between the two at the tightest tolerance as a check that both ran the
same problem. The first call is timed separately (the JIT compilation, or its loading from
numba's disk cache).

Run: ``.venv/bin/python benchmarks/vector_field_throughput.py [--grid 100] [--repeat 3]``
"""

from __future__ import annotations

import argparse
import math
import time

import numba
import numpy as np
from scipy.integrate import solve_ivp

from ldpipe.engine import LDSettings, compute_ld
from ldpipe.systems import make_system

DELTA, FORCE, OMEGA, T0, TAU = 0.25, 0.3, 1.2, 1.5, 10.0
SPEC = {"vector_field": {"x": "y", "y": "x - x**3 - delta*y + F*cos(omega*t)"}, "coordinates": ["x", "y"],
        "parameters": {"delta": DELTA, "F": FORCE, "omega": OMEGA}}


def grid(n: int) -> np.ndarray:
    x, y = np.meshgrid(np.linspace(-1.6, 1.6, n), np.linspace(-1.2, 1.2, n), indexing="ij")
    return np.column_stack([x.ravel(), y.ravel()])


def scipy_arclength(state: np.ndarray, rtol: float) -> float:
    def rhs(t, s):
        vx, vy = s[1], s[0] - s[0] ** 3 - DELTA * s[1] + FORCE * math.cos(OMEGA * t)
        return [vx, vy, math.hypot(vx, vy)]

    return solve_ivp(rhs, (T0, T0 + TAU), [*state, 0.0], method="DOP853", rtol=rtol, atol=rtol).y[2, -1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--grid", type=int, default=100)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--scipy-points", type=int, default=50)
    args = parser.parse_args()
    system = make_system("forced_duffing_benchmark", SPEC)
    states = grid(args.grid)
    start = time.perf_counter()
    compute_ld(system, states[:1], 1, LDSettings(tau=TAU), t0=T0)
    print(f"first call (compile or load): {time.perf_counter() - start:.2f} s; {numba.get_num_threads()} threads")
    sample = states[np.linspace(0, len(states) - 1, args.scipy_points).astype(int)]
    for rtol in (1e-6, 1e-8, 1e-10):
        settings = LDSettings(tau=TAU, p=0.5, rtol=rtol, atol=rtol)
        best = (math.inf, math.inf)
        for _ in range(args.repeat):
            wall, cpu = time.perf_counter(), time.process_time()
            result = compute_ld(system, states, 1, settings, t0=T0)
            best = min(best, (time.perf_counter() - wall, time.process_time() - cpu))
        units = float(result.time.sum())
        start = time.perf_counter()
        reference = np.array([scipy_arclength(s, rtol) for s in sample])
        scipy_rate = len(sample) * TAU / (time.perf_counter() - start)
        ours = compute_ld(system, sample, 1, LDSettings(tau=TAU, p="arclength", rtol=rtol, atol=rtol), t0=T0).ld
        print(f"rtol {rtol:.0e}: {best[0]:.3f} s wall, {units / best[0]:.3g} time units/s, {units / best[1]:.3g} per "
              f"CPU s, {result.steps.mean():.1f} steps/trajectory; scipy DOP853 {scipy_rate:.3g} time units/s "
              f"(one core); arc length ldpipe vs scipy: median relative difference "
              f"{np.median(np.abs(ours - reference) / reference):.1e}")


if __name__ == "__main__":
    main()
