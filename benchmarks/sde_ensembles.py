"""Stochastic LD ensembles: ldpipe's compiled engine against a plain numpy Euler-Maruyama on the
same problem, side by side in one run.

Problem: the damped double well x' = y, y' = x - x^3 - 0.25 y with additive noise of diffusivity
K = 0.01 on y alone (dy gets sqrt(2 K) dW), from a ``--grid`` x ``--grid`` grid over
x in [-1.6, 1.6], y in [-1.2, 1.2], ``--members`` paths per point, tau = 5 forward, step 0.01,
and the LD M_1/2 of the drift along each path by the trapezoidal rule.

- ldpipe: :func:`ldpipe.engine.stochastic.compute_stochastic_ld` (Euler-Maruyama, Philox streams,
  numba's threads);
- numpy: every path at once as arrays of shape (points x members,), one vectorised Euler-Maruyama
  step after another, normal numbers from ``numpy.random.default_rng(seed).standard_normal``
  (one process, numpy's own threads: none for these operations), the same LD sum.

The two draw different random numbers, so they agree in distribution, not bit for bit: the script
prints each one's mean LD over all paths with its standard error, and the difference in standard
errors. Then the wall and CPU time of each (the first ldpipe call, compile or cache load, timed
apart) and path steps per CPU second.

Run: ``.venv/bin/python benchmarks/sde_ensembles.py [--grid 40] [--members 64] [--method both|ldpipe|numpy]``
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

DELTA, K, TAU, DT, P = 0.25, 0.01, 5.0, 0.01, 0.5
SPEC = {"vector_field": {"x": "y", "y": "x - x**3 - delta*y"}, "coordinates": ["x", "y"],
        "parameters": {"delta": DELTA}}


def grid(n: int) -> np.ndarray:
    x, y = np.meshgrid(np.linspace(-1.6, 1.6, n), np.linspace(-1.2, 1.2, n), indexing="ij")
    return np.column_stack([x.ravel(), y.ravel()])


def numpy_em(states: np.ndarray, members: int, seed: int) -> np.ndarray:
    """Euler-Maruyama on every path at once; the LD of the drift along each, shape (points, members)."""
    rng = np.random.default_rng(seed)
    x = np.repeat(states[:, 0], members)
    y = np.repeat(states[:, 1], members)
    steps = math.ceil(TAU / DT - 1e-12)
    h = TAU / steps
    amplitude = math.sqrt(2 * K * h)
    fx, fy = y.copy(), x - x**3 - DELTA * y
    value = np.sqrt(np.abs(fx)) + np.sqrt(np.abs(fy))
    ld = np.zeros_like(x)
    for _ in range(steps):
        x, y = x + h * fx, y + h * fy + amplitude * rng.standard_normal(x.size)
        fx, fy = y, x - x**3 - DELTA * y
        after = np.sqrt(np.abs(fx)) + np.sqrt(np.abs(fy))
        ld += 0.5 * h * (value + after)
        value = after
    return ld.reshape(len(states), members)


def ldpipe_em(system, noise, states: np.ndarray, members: int, seed: int) -> np.ndarray:
    from ldpipe.engine.stochastic import StochasticSettings, compute_stochastic_ld

    settings = StochasticSettings(scheme="euler_maruyama", dt=DT, seed=seed, members=members)
    return compute_stochastic_ld(system, noise, states, 1, TAU, P, settings, 1e6).ld


def timed(call):
    wall, cpu = time.perf_counter(), time.process_time()
    result = call()
    return result, time.perf_counter() - wall, time.process_time() - cpu


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--grid", type=int, default=40)
    parser.add_argument("--members", type=int, default=64)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--method", choices=("both", "ldpipe", "numpy"), default="both")
    args = parser.parse_args()
    states = grid(args.grid)
    path_steps = len(states) * args.members * math.ceil(TAU / DT - 1e-12)
    results = {}
    if args.method in ("both", "ldpipe"):
        import numba

        from ldpipe.systems import make_system
        from ldpipe.systems.noise import parse_noise

        system = make_system("double_well_benchmark", SPEC)
        noise = parse_noise({"diffusivity": {"x": 0.0, "y": K}}, system, "benchmark")
        _, wall, cpu = timed(lambda: ldpipe_em(system, noise, states[:1], 1, args.seed))
        print(f"ldpipe first call (compile or cache load): {wall:.2f} s wall, {cpu:.2f} s CPU; "
              f"{numba.get_num_threads()} threads")
        results["ldpipe"] = timed(lambda: ldpipe_em(system, noise, states, args.members, args.seed))
    if args.method in ("both", "numpy"):
        results["numpy"] = timed(lambda: numpy_em(states, args.members, args.seed))
    print(f"{len(states)} points x {args.members} members x {path_steps // (len(states) * args.members)} steps "
          f"= {path_steps:.3g} path steps")
    print(f"{'method':8} {'wall s':>8} {'CPU s':>8} {'steps/CPU s':>12} {'mean LD':>10} {'stderr':>9}")
    for name, (ld, wall, cpu) in results.items():
        stderr = ld.std(ddof=1) / math.sqrt(ld.size)
        print(f"{name:8} {wall:8.2f} {cpu:8.2f} {path_steps / cpu:12.3g} {ld.mean():10.6f} {stderr:9.2g}")
    if len(results) == 2:
        a, b = results["ldpipe"][0], results["numpy"][0]
        error = math.hypot(a.std(ddof=1) / math.sqrt(a.size), b.std(ddof=1) / math.sqrt(b.size))
        print(f"mean LD difference ldpipe - numpy: {(a.mean() - b.mean()) / error:+.2f} standard errors; "
              f"CPU ratio numpy / ldpipe: {results['numpy'][2] / results['ldpipe'][2]:.2f}")


if __name__ == "__main__":
    main()
