"""What uneven grids and 3-D data cost: the rectilinear kernel against the uniform one, per core.

Data: the double gyre of Shadden, Lekien & Marsden (2005) sampled on 65 x 33 x 193 nodes of
[0, 2] x [0, 1] x [1.5, 7.5] three ways:

- ``uniform``: evenly spaced (the uniform kernel, cubic convolution);
- ``uneven``: the same node counts at x(s) = s - 0.08 sin(2 pi s) of even s, spacings varying
  threefold (the rectilinear kernel, 2-D);
- ``3-D``: the uneven grid with 17 uneven depth levels, u, v the same at every depth and w = 0
  (the rectilinear kernel, 3-D: tricubic in space, 4 x 4 x 4 x 4 nodes per component), the map at
  a fixed depth (the trajectories are the 2-D ones).

An LD map (M_1/2, forward, t0 = 2, tau = 5) on a ``--nx`` x ``--nx/2`` grid of [0.05, 1.95] x
[0.05, 0.95], rtol = atol = ``--rtol``, one thread; the three runs interleaved ``--repeat`` times,
so a change of load hits all three; ratios per round against ``uniform``, with the step counts
(the work) beside them. First calls (compilation, or loading numba's cache) are excluded.

Run: ``.venv/bin/python benchmarks/rectilinear_data.py [--nx 100] [--repeat 5]``; results by hand in
benchmarks/rectilinear_data.md.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numba
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from support.double_gyre import double_gyre_velocity  # noqa: E402
from support.gridded import write_velocity_file, write_velocity_file_3d  # noqa: E402

from ldpipe.engine import LDSettings, compute_ld  # noqa: E402
from ldpipe.systems import make_system  # noqa: E402

T0, TAU, P = 2.0, 5.0, 0.5


def warped(low: float, high: float, count: int) -> np.ndarray:
    s = np.linspace(0.0, 1.0, count)
    return low + (high - low) * (s - 0.08 * np.sin(2 * np.pi * s))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--nx", type=int, default=100)
    parser.add_argument("--rtol", type=float, default=1e-8)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    numba.set_num_threads(1)
    directory = Path(tempfile.mkdtemp(prefix="ldpipe-bench-"))
    counts = (65, 33, 193)
    even = (np.linspace(0, 2, counts[0]), np.linspace(0, 1, counts[1]), np.linspace(1.5, 7.5, counts[2]))
    uneven = (warped(0, 2, counts[0]), warped(0, 1, counts[1]), warped(1.5, 7.5, counts[2]))
    depths = 500.0 * np.linspace(0.0, 1.0, 17) ** 1.5

    def gyre_3d(x, y, z, t):
        u, v = double_gyre_velocity(x, y, t)
        return u + 0 * z, v + 0 * z, 0 * u

    systems = {
        "uniform": make_system("gyre_uniform", {"velocity_data": {"path": str(
            write_velocity_file(directory / "uniform.nc", double_gyre_velocity, *even))}}),
        "uneven": make_system("gyre_uneven", {"velocity_data": {"path": str(
            write_velocity_file(directory / "uneven.nc", double_gyre_velocity, *uneven))}}),
        "3-D": make_system("gyre_3d", {"velocity_data": {"path": str(write_velocity_file_3d(
            directory / "gyre3d.nc", gyre_3d, uneven[0], uneven[1], depths, uneven[2])), "w": "w"}}),
    }
    gx, gy = np.meshgrid(np.linspace(0.05, 1.95, args.nx), np.linspace(0.05, 0.95, args.nx // 2), indexing="ij")
    plane = np.column_stack([gx.ravel(), gy.ravel()])
    states = {name: plane if system.n_state == 2 else np.column_stack([plane, np.full(len(plane), 100.0)])
              for name, system in systems.items()}
    settings = LDSettings(tau=TAU, p=P, rtol=args.rtol, atol=args.rtol)
    for name, system in systems.items():
        compute_ld(system, states[name][:2], 1, settings, t0=T0)  # first call apart
    times = {name: [] for name in systems}
    steps = {}
    for _ in range(args.repeat):
        for name, system in systems.items():
            start = time.perf_counter()
            result = compute_ld(system, states[name], 1, settings, t0=T0)
            times[name].append(time.perf_counter() - start)
            steps[name] = int(result.steps.sum())
    print(f"{len(plane)} trajectories, rtol = atol = {args.rtol:g}, 1 thread, {args.repeat} interleaved rounds")
    for name in systems:
        ratios = np.array(times[name]) / np.array(times["uniform"])
        print(f"{name:8s} {min(times[name]):.3f} - {max(times[name]):.3f} s, "
              f"{min(times[name]) / steps[name] * 1e9:.0f} ns per step attempt (best), {steps[name]} steps; "
              f"time / uniform's: median {np.median(ratios):.2f} ({ratios.min():.2f} - {ratios.max():.2f})")


if __name__ == "__main__":
    main()
