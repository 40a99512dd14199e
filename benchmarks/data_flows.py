"""LDs and FTLE from gridded velocity data, per core: ldpipe against what oceanographers use.

Data: the double gyre of Shadden, Lekien & Marsden (2005) (A = 0.1, eps = 0.25, w = 2 pi / 10)
sampled every 1/32 in x, y and t over [0, 2] x [0, 1] x [1.5, 7.5], written as a CF netCDF file;
maps from t0 = 2 over tau = 5 forward on a ``--nx`` x ``--nx/2`` grid of [0, 2] x [0, 1].

- LD (M_1/2, forward): ldpipe's velocity-data system (cubic convolution in the compiled engine,
  DOP853) against the ldds-style approach: scipy's RegularGridInterpolator (linear, its default;
  ``--cubic`` adds its cubic method on fewer points) inside ``solve_ivp`` (RK45, ldds' default),
  the LD as an extra state; scipy on ``--scipy-points`` of the points, its time per trajectory
  scaled to the grid. Accuracy: both against the formula system's LD (ldpipe at rtol 1e-12,
  validated against scipy in tests/data).
- FTLE (forward): ldpipe, with its LD (``ftle: true``) and alone (``ld: false``: the flow map
  by ``ldpipe.core.trajectories.flow_map``, no quadrature, no dense output), against numbacs (cubic splines of
  the ``interpolation`` package, numbalsoda's DOP853, its ftle_grid_2D), the same grid and
  tolerance (``--ftle-rtols``: several, to compare at matched accuracy: each method at its
  loosest tolerance whose error is within 10 % of numbacs' floor). Accuracy: all against the
  formula flow map's FTLE on that grid. The FTLE runs are repeated ``--repeat`` times,
  interleaved, and reported as their minimum and median. Setup is timed apart for both: numbacs'
  spline and cfunc are made once, as ldpipe reads its data window once.

Everything runs on one thread (numba.set_num_threads(1); numbacs' prange loops too). First
calls (compilation, or loading numba's cache) are timed apart and excluded.

Run: ``.venv/bin/python benchmarks/data_flows.py [--nx 200] [--rtol 1e-8]``; results by hand in
benchmarks/data_flows.md.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numba
import numpy as np
from scipy.integrate import solve_ivp
from scipy.interpolate import RegularGridInterpolator

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from support.double_gyre import DOUBLE_GYRE, double_gyre_velocity  # noqa: E402
from support.gridded import write_velocity_file  # noqa: E402

from ldpipe.engine import LDSettings, compute_ld  # noqa: E402
from ldpipe.core.trajectories import FlowSettings, flow_map  # noqa: E402
from ldpipe.core.maps.ftle import ftle  # noqa: E402
from ldpipe.systems import make_system  # noqa: E402

H = 1.0 / 32
T0, TAU, P = 2.0, 5.0, 0.5


def timed(function, *args, **kwargs):
    start = time.perf_counter()
    result = function(*args, **kwargs)
    return time.perf_counter() - start, result


def ldds_style_ld(interpolators, state, rtol, atol):
    """M_1/2 of one trajectory: the interpolated velocity and the LD integrand as solve_ivp states."""
    u_of, v_of = interpolators

    def rhs(t, s):
        point = (t, s[1], s[0])
        u, v = float(u_of([point])[0]), float(v_of([point])[0])
        return [u, v, abs(u) ** P + abs(v) ** P]

    return solve_ivp(rhs, (T0, T0 + TAU), [*state, 0.0], rtol=rtol, atol=atol).y[2, -1]


def numbacs_flow(t, x, y, u, v):
    """numbacs' compiled velocity: (the cfunc's address, the spline coefficients it reads), made once,
    as ldpipe's data window is read once (each call of numbacs' get_flow_2D compiles a new cfunc).
    The caller keeps the coefficients alive while it uses the address, as numbacs' examples do."""
    from numbacs.flows import get_flow_2D, get_interp_arrays_2D

    # numbacs takes (t, x, y) arrays
    grid_vel, cu, cv = get_interp_arrays_2D(t, x, y, np.ascontiguousarray(u.transpose(0, 2, 1)),
                                            np.ascontiguousarray(v.transpose(0, 2, 1)))
    return get_flow_2D(grid_vel, cu, cv, extrap_mode="linear"), (grid_vel, cu, cv)


def numbacs_ftle(funcptr, nx, ny, rtol, atol):
    from numbacs.diagnostics import ftle_grid_2D
    from numbacs.integration import flowmap_grid_2D

    xs, ys = np.linspace(0, 2, nx), np.linspace(0, 1, ny)
    params = np.array([1.0])
    flowmap = flowmap_grid_2D(funcptr, T0, TAU, xs, ys, params, rtol=rtol, atol=atol)
    return ftle_grid_2D(flowmap, TAU, xs[1] - xs[0], ys[1] - ys[0])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--nx", type=int, default=200)
    parser.add_argument("--rtol", type=float, default=1e-8)
    parser.add_argument("--scipy-points", type=int, default=40)
    parser.add_argument("--cubic", type=int, default=0, help="points for RegularGridInterpolator(method='cubic')")
    parser.add_argument("--repeat", type=int, default=3, help="timed runs of each FTLE method")
    parser.add_argument("--ftle-rtols", type=float, nargs="+", default=[1e-8],
                        help="tolerances (rtol = atol) of the FTLE comparison, each for every method")
    args = parser.parse_args()
    numba.set_num_threads(1)
    nx, ny = args.nx, args.nx // 2
    x, y, t = np.arange(0, 2 + H / 2, H), np.arange(0, 1 + H / 2, H), 1.5 + H * np.arange(6 * 32 + 1)
    directory = Path(tempfile.mkdtemp(prefix="ldpipe-bench-"))
    path = write_velocity_file(directory / "double_gyre.nc", double_gyre_velocity, x, y, t)
    data = make_system("double_gyre_benchmark", {"velocity_data": {"path": str(path)}})
    formula = make_system("double_gyre", DOUBLE_GYRE)
    gx, gy = np.meshgrid(np.linspace(0, 2, nx), np.linspace(0, 1, ny), indexing="ij")
    states = np.column_stack([gx.ravel(), gy.ravel()])
    settings = LDSettings(tau=TAU, p=P, rtol=args.rtol, atol=args.rtol)
    first, _ = timed(compute_ld, data, states[:2], 1, settings, t0=T0)
    print(f"{nx} x {ny} points, rtol = atol = {args.rtol:g}, 1 thread; ldpipe first call {first:.2f} s")

    reference = compute_ld(formula, states, 1, LDSettings(tau=TAU, p=P, rtol=1e-12, atol=1e-12), t0=T0)
    ours_time, ours = timed(compute_ld, data, states, 1, settings, t0=T0)
    scale = np.max(reference.ld)  # errors relative to the map's largest LD (the LD is 0 at the gyres' corners)
    ours_error = np.max(np.abs(ours.ld - reference.ld)) / scale
    print(f"LD ldpipe: {ours_time:.3f} s, {ours_time / len(states) * 1e6:.1f} us/trajectory, "
          f"max error {ours_error:.2e} of the largest LD")

    T, Y, X = np.meshgrid(t, y, x, indexing="ij")
    u, v = double_gyre_velocity(X, Y, T)
    sample = np.linspace(0, len(states) - 1, args.scipy_points).astype(int)
    for method, count in (("linear", args.scipy_points), ("cubic", args.cubic)):
        if not count:
            continue
        interpolators = (RegularGridInterpolator((t, y, x), u, method=method, bounds_error=False, fill_value=0.0),
                         RegularGridInterpolator((t, y, x), v, method=method, bounds_error=False, fill_value=0.0))
        chosen = sample[np.linspace(0, len(sample) - 1, count).astype(int)]
        scipy_time, values = timed(lambda: [ldds_style_ld(interpolators, states[k], args.rtol, args.rtol) for k in chosen])
        per = scipy_time / len(chosen)
        error = np.max(np.abs(np.array(values) - reference.ld[chosen])) / scale
        same = np.max(np.abs(ours.ld[chosen] - reference.ld[chosen])) / scale
        print(f"LD ldds-style ({method}): {per * 1e6:.0f} us/trajectory on {len(chosen)} points "
              f"({per * len(states):.1f} s for the grid), max error {error:.2e} of the largest LD "
              f"(ldpipe's on those points {same:.2e}); "
              f"ldpipe is {per * len(states) / ours_time:.0f}x faster")

    # FTLE: the formula flow map's FTLE on the grid is the reference for both
    complete = np.ones((nx, ny), dtype=bool)
    axes = (np.linspace(0, 2, nx), np.linspace(0, 1, ny))
    exact, _ = ftle(reference.end_state.reshape(nx, ny, 2), axes, TAU, complete)
    flow_map(data, states[:2], TAU, FlowSettings(rtol=args.rtol, atol=args.rtol), t0=T0)  # first call apart

    def with_ld(rtol):
        result = compute_ld(data, states, 1, LDSettings(tau=TAU, p=P, rtol=rtol, atol=rtol), t0=T0)
        return ftle(result.end_state.reshape(nx, ny, 2), axes, TAU, complete)[0]

    def alone(rtol):
        result = flow_map(data, states, TAU, FlowSettings(rtol=rtol, atol=rtol), t0=T0)
        return ftle(result.end_state.reshape(nx, ny, 2), axes, TAU, complete)[0]

    methods = {"ldpipe with its LD": with_ld, "ldpipe alone (ld: false)": alone}
    try:
        import numbacs  # noqa: F401
    except ImportError:
        print("numbacs not installed (pip install -e '.[bench]'): its row is skipped")
    else:
        start = time.perf_counter()
        compiled = numbacs_flow(t, x, y, u, v)
        numbacs_ftle(compiled[0], 8, 4, args.rtol, args.rtol)
        first = time.perf_counter() - start
        setup, (funcptr, coefficients) = timed(numbacs_flow, t, x, y, u, v)  # coefficients: kept alive
        print(f"numbacs first call (its JIT) {first:.1f} s; its velocity's setup (spline, cfunc) {setup:.2f} s "
              "a dataset, excluded from the timings as ldpipe's data read is")
        methods["numbacs"] = lambda rtol: numbacs_ftle(funcptr, nx, ny, rtol, rtol)
    inner = (slice(1, -1), slice(1, -1))  # numbacs leaves the grid's edge at 0
    runs = {}  # (name, rtol): (times, error)
    for rtol in args.ftle_rtols:
        times = {name: [] for name in methods}
        fields = {}
        for _ in range(args.repeat):  # interleaved, so a change in the machine's load hits every method
            for name, method in methods.items():
                elapsed, fields[name] = timed(method, rtol)
                times[name].append(elapsed)
        for name, values in times.items():
            error = np.max(np.abs(fields[name] - exact)[inner])
            runs[name, rtol] = (np.array(values), error)
            print(f"FTLE rtol = atol = {rtol:g}, {name}: min {min(values):.3f} s, median {np.median(values):.3f} s "
                  f"over {len(values)} runs ({', '.join(f'{v:.2f}' for v in values)}), max error {error:.2e} "
                  f"(FTLE up to {exact.max():.3f})")
        if "numbacs" in times:
            for name in list(methods)[:2]:
                ratios = np.array(times["numbacs"]) / np.array(times[name])
                print(f"  {name}: {np.median(ratios):.2f}x numbacs' speed at this rtol (median of the paired runs; "
                      f"from {ratios.min():.2f} to {ratios.max():.2f})")
    if "numbacs" in methods:
        matched_accuracy(runs, args.ftle_rtols, {name: methods[name] for name in ("ldpipe alone (ld: false)", "numbacs")},
                         args.repeat)


def matched_accuracy(runs: dict, rtols: list[float], methods: dict, repeat: int) -> None:
    """ldpipe alone against numbacs at matched accuracy: each at its loosest tolerance whose FTLE error is
    within 10 % of the smallest numbacs reaches over ``rtols`` (its interpolant's floor), the two then
    run again side by side, ``repeat`` interleaved pairs."""
    target = 1.1 * min(runs["numbacs", rtol][1] for rtol in rtols)
    chosen = {}
    for name in methods:
        good = [rtol for rtol in rtols if runs[name, rtol][1] <= target]
        if not good:
            print(f"matched accuracy: {name} never reaches an FTLE error of {target:.2e} over these tolerances")
            return
        chosen[name] = max(good)
    times = {name: [] for name in methods}
    for _ in range(repeat):
        for name, method in methods.items():
            times[name].append(timed(method, chosen[name])[0])
    ours, theirs = (np.array(times[name]) for name in methods)
    ratios = theirs / ours
    print(f"matched accuracy (FTLE error <= {target:.2e}), {repeat} interleaved pairs: ldpipe alone at rtol "
          f"{chosen['ldpipe alone (ld: false)']:g} (median {np.median(ours):.3f} s, error "
          f"{runs['ldpipe alone (ld: false)', chosen['ldpipe alone (ld: false)']][1]:.2e}), numbacs at rtol "
          f"{chosen['numbacs']:g} (median {np.median(theirs):.3f} s, error {runs['numbacs', chosen['numbacs']][1]:.2e}): "
          f"ldpipe {np.median(ratios):.2f}x numbacs' speed (median of the pairs; from {ratios.min():.2f} to "
          f"{ratios.max():.2f})")


if __name__ == "__main__":
    main()
