"""FTLE of gridded double-gyre data per core: ldpipe's two interpolants against numbacs, matched accuracy.

Data: the double gyre of Shadden, Lekien & Marsden (2005) (A = 0.1, eps = 0.25, w = 2 pi / 10)
sampled every 1/32 in x, y and t over [0, 2] x [0, 1] x [1.5, 7.5] (a CF netCDF file, as
``data_flows.py`` writes it). Forward FTLE from t0 = 2 over tau = 5 on an ``--nx`` x ``--nx/2``
grid of [0, 2] x [0, 1] (200 x 100: 20 000 starts), one thread each (numba.set_num_threads(1),
numbacs' prange loops too):

- ldpipe, ``interpolation: cubic_convolution`` (C1, the default) and ``cubic_bspline`` (C2), its
  flow map alone (``ldpipe.core.trajectories.flow_map``: DOP853, no LD), FTLE by
  ``ldpipe.core.maps.ftle.ftle`` (central differences on the grid);
- numbacs (cubic splines of the ``interpolation`` package, numbalsoda's DOP853,
  ``flowmap_grid_2D`` and ``ftle_grid_2D``: central differences on the same grid).

Which error: the FTLE error of each method against the FTLE of the *formula* double gyre's flow
map on the same grid (ldpipe's formula system at rtol = atol = 1e-12, the same central
differences), over the grid's interior (numbacs leaves the edge at 0): the error the flow map's
error makes, which is what the interpolant and the integrator decide. The FTLE with the exact
gradient (the formula's variational equations, ``ldpipe.core.maps.ftle.variational_ftle``, rtol
1e-12) is also computed on ``--variational-points`` of the interior: its distance from the
reference is the grid's difference error, the same for every method, printed beside.

Cost per core: ``time.process_time`` of one FTLE field (flow map + FTLE), every method at every
tolerance of the ladder (rtol = atol, half decades from ``--loosest`` to ``--tightest``), the
methods interleaved within each of ``--rounds`` rounds (a burst of load hits all alike); each
rung's fastest round kept, the spread (slowest / fastest) printed. Matched accuracy: for each
target error (1e-4 .. 1e-7) and each of the median and the worst point, each method's cost
interpolated log-log between the two rungs of its ladder that bracket the target ("-" where its
ladder does not reach it); the ratio numbacs' cost over ldpipe's. Step counts: ldpipe's DOP853
step attempts per trajectory (mean over the grid) at each rung. Setup (the data read and the
B-spline prefilter; numbacs' spline coefficients and compiled callback) and first calls (numba
compiles, numbacs' JIT) are timed apart and excluded.

Run: ``.venv/bin/python benchmarks/bspline_ftle.py [--nx 200] [--rounds 3]``; writes
``benchmarks/results/bspline_ftle_<time>.json``; results by hand in benchmarks/HISTORY.md.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import tempfile
import time
from pathlib import Path

import numba
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from support.double_gyre import DOUBLE_GYRE, double_gyre_velocity  # noqa: E402
from support.gridded import write_velocity_file  # noqa: E402

from ldpipe.core.maps.ftle import ftle, variational_ftle  # noqa: E402
from ldpipe.core.trajectories import FlowSettings, flow_map  # noqa: E402
from ldpipe.io.atomic import write_text_atomic  # noqa: E402
from ldpipe.systems import make_system  # noqa: E402

H = 1.0 / 32
T0, TAU = 2.0, 5.0
TARGETS = (1e-4, 1e-5, 1e-6, 1e-7)


def cpu_timed(function, *args, **kwargs):
    start = time.process_time()
    result = function(*args, **kwargs)
    return time.process_time() - start, result


def numbacs_setup(t, x, y, u, v):
    """numbacs' compiled velocity (its cfunc's address) and the spline coefficients it reads (kept alive)."""
    from numbacs.flows import get_flow_2D, get_interp_arrays_2D

    grid_vel, cu, cv = get_interp_arrays_2D(t, x, y, np.ascontiguousarray(u.transpose(0, 2, 1)),
                                            np.ascontiguousarray(v.transpose(0, 2, 1)))
    return get_flow_2D(grid_vel, cu, cv, extrap_mode="linear"), (grid_vel, cu, cv)


def interpolated_cost(ladder: list[tuple[float, float]], target: float) -> float:
    """The cost at error ``target``: log-log between the two rungs (error, cost) bracketing it, the
    ladder ordered from loose to tight; the first rung's cost if it already reaches the target; nan
    if no rung does."""
    for k, (error, cost) in enumerate(ladder):
        if error <= target:
            if k == 0:
                return cost
            (e0, c0), (e1, c1) = ladder[k - 1], (error, cost)
            if e0 <= e1:
                return c1
            w = (math.log(target) - math.log(e0)) / (math.log(e1) - math.log(e0))
            return math.exp(math.log(c0) + w * (math.log(c1) - math.log(c0)))
    return math.nan


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--nx", type=int, default=200)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--loosest", type=float, default=1e-3)
    parser.add_argument("--tightest", type=float, default=1e-10)
    parser.add_argument("--variational-points", type=int, default=400)
    parser.add_argument("--no-numbacs", action="store_true")
    args = parser.parse_args()
    numba.set_num_threads(1)
    nx, ny = args.nx, args.nx // 2
    x, y, t = np.arange(0, 2 + H / 2, H), np.arange(0, 1 + H / 2, H), 1.5 + H * np.arange(6 * 32 + 1)
    directory = Path(tempfile.mkdtemp(prefix="ldpipe-bench-"))
    path = write_velocity_file(directory / "double_gyre.nc", double_gyre_velocity, x, y, t)
    axes = (np.linspace(0, 2, nx), np.linspace(0, 1, ny))
    gx, gy = np.meshgrid(*axes, indexing="ij")
    states = np.column_stack([gx.ravel(), gy.ravel()])
    complete = np.ones((nx, ny), dtype=bool)
    inner = (slice(1, -1), slice(1, -1))
    load = [os.getloadavg()]

    formula = make_system("double_gyre", DOUBLE_GYRE)
    reference_map = flow_map(formula, states, TAU, FlowSettings(rtol=1e-12, atol=1e-12), t0=T0)
    exact = ftle(reference_map.end_state.reshape(nx, ny, 2), axes, TAU, complete)[0]
    rng = np.random.default_rng(0)
    picks = rng.choice((nx - 2) * (ny - 2), size=min(args.variational_points, (nx - 2) * (ny - 2)), replace=False)
    inner_states = np.column_stack([gx[inner].ravel(), gy[inner].ravel()])
    variational = variational_ftle(formula, inner_states[picks], (0, 1), T0, TAU)
    difference_floor = np.abs(exact[inner].ravel()[picks] - variational)
    print(f"{nx} x {ny} starts, 1 thread; the reference (formula flow map, rtol 1e-12, grid differences) "
          f"against the variational FTLE on {len(picks)} interior points: median "
          f"{np.median(difference_floor):.2e}, worst {difference_floor.max():.2e} (the grid's difference error)")

    methods = {}
    steps = {}
    setups = {}
    for interpolation in ("cubic_convolution", "cubic_bspline"):
        entry = {"path": str(path), "interpolation": interpolation}
        system = make_system(f"gyre_{interpolation}", {"velocity_data": entry})
        setups[interpolation], _ = cpu_timed(system.data_window, T0, T0 + TAU)
        first, _ = cpu_timed(flow_map, system, states[:2], TAU, FlowSettings(rtol=1e-6, atol=1e-6), t0=T0)

        def run(rtol, system=system, name=interpolation):
            result = flow_map(system, states, TAU, FlowSettings(rtol=rtol, atol=rtol), t0=T0)
            steps[name, rtol] = float(np.mean(result.steps))
            return ftle(result.end_state.reshape(nx, ny, 2), axes, TAU, complete)[0]

        methods[f"ldpipe {interpolation}"] = run
        print(f"ldpipe {interpolation}: setup (data window{', prefilter' if 'bspline' in interpolation else ''}) "
              f"{setups[interpolation]:.3f} s, first call {first:.1f} s")
    if not args.no_numbacs:
        try:
            import numbacs  # noqa: F401
            from numbacs.diagnostics import ftle_grid_2D
            from numbacs.integration import flowmap_grid_2D
        except ImportError:
            print("numbacs not installed (see benchmarks/compare.md): its rows are skipped")
        else:
            T, Y, X = np.meshgrid(t, y, x, indexing="ij")
            u, v = double_gyre_velocity(X, Y, T)
            first, _ = cpu_timed(numbacs_setup, t, x, y, u, v)
            setups["numbacs"], (funcptr, kept) = cpu_timed(numbacs_setup, t, x, y, u, v)
            params = np.array([1.0])
            dx, dy = axes[0][1] - axes[0][0], axes[1][1] - axes[1][0]

            def numbacs_run(rtol):
                flowmap = flowmap_grid_2D(funcptr, T0, TAU, axes[0], axes[1], params, rtol=rtol, atol=rtol)
                return ftle_grid_2D(flowmap, TAU, dx, dy)

            jit, _ = cpu_timed(numbacs_run, 1e-6)
            print(f"numbacs: setup (spline, cfunc) {setups['numbacs']:.3f} s, first call (JIT) {first + jit:.1f} s")
            methods["numbacs"] = numbacs_run

    exponents = np.arange(round(2 * math.log10(args.loosest)), round(2 * math.log10(args.tightest)) - 1, -1)
    rtols = [float(10.0 ** (e / 2)) for e in exponents]
    times = {(name, rtol): [] for name in methods for rtol in rtols}
    errors = {}
    for _ in range(args.rounds):  # interleaved: each round every rung of every method
        for rtol in rtols:
            for name, method in methods.items():
                elapsed, field = cpu_timed(method, rtol)
                times[name, rtol].append(elapsed)
                error = np.abs(field - exact)[inner]
                errors[name, rtol] = (float(np.median(error)), float(error.max()))
    load.append(os.getloadavg())

    print(f"\nload average (1, 5, 15 min) at the start {load[0]}, at the end {load[1]}")
    print("| rtol | method | CPU s (fastest) | spread | median error | worst error | steps / trajectory |")
    print("| --- | --- | ---: | ---: | ---: | ---: | ---: |")
    for rtol in rtols:
        for name in methods:
            values = times[name, rtol]
            key = name.removeprefix("ldpipe ")
            count = f"{steps[key, rtol]:.1f}" if (key, rtol) in steps else "-"
            print(f"| {rtol:.0e} | {name} | {min(values):.3f} | {max(values) / min(values):.2f} | "
                  f"{errors[name, rtol][0]:.2e} | {errors[name, rtol][1]:.2e} | {count} |")
    print("\nsteps per trajectory per decade of rtol (ratio of the step counts a decade apart):")
    for key in ("cubic_convolution", "cubic_bspline"):
        ratios = [steps[key, rtols[k + 2]] / steps[key, rtols[k]] for k in range(len(rtols) - 2)]
        print(f"  {key}: " + ", ".join(f"{rtols[k]:.0e}->{rtols[k + 2]:.0e} x{r:.2f}" for k, r in enumerate(ratios)))

    matched = {}
    print("\nmatched accuracy: CPU s per FTLE field interpolated at each target (numbacs' cost / ldpipe's)")
    print("| target | matched on | " + " | ".join(methods) + " | B-spline vs numbacs | convolution vs numbacs |")
    print("| --- | --- |" + " ---: |" * (len(methods) + 2))
    for which, index in (("median", 0), ("worst point", 1)):
        for target in TARGETS:
            costs = {name: interpolated_cost([(errors[name, r][index], min(times[name, r])) for r in rtols], target)
                     for name in methods}
            matched[which, target] = costs
            numbacs_cost = costs.get("numbacs", math.nan)
            ratio = [numbacs_cost / costs[f"ldpipe {k}"] for k in ("cubic_bspline", "cubic_convolution")]
            cells = " | ".join("-" if math.isnan(c) else f"{c:.3f}" for c in costs.values())
            ratio_cells = " | ".join("-" if math.isnan(r) else f"{r:.2f}x" for r in ratio)
            print(f"| {target:.0e} | {which} | {cells} | {ratio_cells} |")

    results = Path(__file__).resolve().parent / "results"
    results.mkdir(exist_ok=True)
    stamp = time.strftime("%Y%m%dT%H%M%S", time.gmtime())
    record = {"nx": nx, "ny": ny, "rounds": args.rounds, "load": load, "setup_cpu_s": setups,
              "difference_floor": {"median": float(np.median(difference_floor)),
                                   "worst": float(difference_floor.max())},
              "rows": [{"method": name, "rtol": rtol, "cpu_s": times[name, rtol],
                        "median_error": errors[name, rtol][0], "worst_error": errors[name, rtol][1],
                        "steps": steps.get((name.removeprefix("ldpipe "), rtol))}
                       for name in methods for rtol in rtols],
              "matched": [{"matched_on": which, "target": target, "cpu_s": costs}
                          for (which, target), costs in matched.items()]}
    write_text_atomic(results / f"bspline_ftle_{stamp}.json", json.dumps(record, indent=1, allow_nan=True))


if __name__ == "__main__":
    main()
