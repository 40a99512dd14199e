"""A C-grid file advected by ldpipe and by Parcels, a peer no one here wrote: agreement and cost.

Data: the double gyre of Shadden, Lekien & Marsden (2005) (A = 0.1, eps = 0.25, w = 2 pi / 10)
written by ``ldpipe.data.curvilinear.double_gyre_c_grid_dataset`` as a ROMS-like Arakawa C-grid
file: centres ``x_rho``/``y_rho`` on the ``conformal`` grid (the rotated grid bent by a conformal
map: orthogonal and curved, as ROMS grids are), u on (time, eta, xi_u) and v on (time, eta_v, xi)
the velocity through each face, the cells' corners ``x_psi``/``y_psi``; ``--spacing`` in the
grid's frame, every 0.1 s over [0, tau + 0.5].

Starts: a ``--points`` x ``--points/2`` grid over [0.05, 1.95] x [0.05, 0.95], advected forward
from t = 0 over ``--tau`` (10 s, one period of the forcing).

- ldpipe: the file as a ``velocity_data`` system (``x: x_rho``, ``y: y_rho``, ``components:
  grid``: read as a C-grid), its flow map alone (``ldpipe.ld_map(..., ld=False, ftle=True,
  directions="forward")``, end points ``end_x_rho_forward``, ``end_y_rho_forward``), DOP853 at
  ``--rtols`` (rtol = atol), one thread; and the flow map by exact cell crossing
  (``ldpipe.core.trajectories.flow_map`` with ``FlowSettings(method="cell_crossing")``: the
  interpolant's trajectory from face to face, no tolerance), one thread.
- Parcels (``pip install 'ldpipe[bench]'``): ``FieldSet.from_sgrid_conventions`` on the same
  file's arrays, its default ``Particle`` (float32 positions), ``AdvectionRK4`` at fixed steps
  ``--dts`` and ``AdvectionRK45`` at ``--rk45-tols`` (its step halved or doubled from 0.1 s).
  Parcels interpolates a C-grid in cells whose corners are the grid's f-points (ROMS's psi
  points; Delandmeter & van Sebille 2019, Parcels' C-grid documentation): the file's ``x_psi``,
  ``y_psi`` are its nodes, u and v its faces, in the SGRID layout of NEMO's output (faces padded
  low: the last row of u and column of v, outside the corners' cells, are not read).

Errors: the distance from each end point to the closed form's (scipy DOP853 at rtol = atol =
1e-12 on the analytic field), median and worst over the starts; the *integration error* beside
it is the distance to the same tracker's end point at its tightest setting (the same interpolated
field; Parcels' RK4 converges at first order across the cells' faces, so its tightest step is a
reference only to about its own error at twice that step). Each tracker's *interpolation
error* is its error at its tightest setting (the integration error then far below it). The two
trackers' end points at their tightest settings are compared in units of it. *Matched accuracy*:
for each tracker the cheapest setting whose median and worst errors are within 10 % of the larger
of the two trackers' interpolation errors.

Cost: CPU seconds of the process (``time.process_time``) for all starts, one thread each
(``threads=1``; Parcels is NumPy over the particles, the BLAS and OpenMP pools pinned to one
thread); the data read and the FieldSet made once, apart. The sweep times every setting once;
then ``--rounds`` rounds time the matched settings interleaved, and the table gives each side's
median, with the spread (slowest / fastest round) and the load average.

Run: ``.venv/bin/python benchmarks/parcels_peer.py [--points 40] [--spacing 0.025]``; results
by hand in benchmarks/HISTORY.md and docs/performance.md.
"""

from __future__ import annotations

import os

for _pool in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_pool, "1")

import argparse  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402
from scipy.integrate import solve_ivp  # noqa: E402

import ldpipe  # noqa: E402
from ldpipe.data.curvilinear import double_gyre_c_grid_dataset, double_gyre_velocity, write_dataset  # noqa: E402

T0 = 0.0
DATA_STEP = 0.1
#: SGRID's topology of the file's arrays as Parcels reads them: the corners (psi points) are the
#: nodes, u's rows and v's columns the faces between them, padded low (NEMO's layout).
SGRID_TOPOLOGY = {"cf_role": "grid_topology", "topology_dimension": 2, "node_dimensions": "xi_psi eta_psi",
                  "face_dimensions": "xi_c:xi_psi (padding:low) eta_c:eta_psi (padding:low)",
                  "node_coordinates": "lon lat"}


def starts_grid(points: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The section's axes and its starts, x-major (the order of ldpipe's map arrays)."""
    xs, ys = np.linspace(0.05, 1.95, points), np.linspace(0.05, 0.95, points // 2)
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    return xs, ys, np.column_stack([X.ravel(), Y.ravel()])


def closed_form(starts: np.ndarray, tau: float) -> np.ndarray:
    """End points of the analytic double gyre's trajectories (all at once: they do not interact)."""
    n = len(starts)

    def rhs(t, s):
        u, v = double_gyre_velocity(s[:n], s[n:], t)
        return np.concatenate([u, v])

    solution = solve_ivp(rhs, (T0, T0 + tau), starts.T.ravel(), method="DOP853", rtol=1e-12, atol=1e-12)
    return solution.y[:, -1].reshape(2, n).T


def parcels_fieldset(roms: xr.Dataset):
    """The ROMS-like file's arrays as a Parcels FieldSet (module docstring: psi points as nodes)."""
    import parcels

    ny, nx = roms.x_rho.shape
    u = roms.u.isel(eta=slice(0, ny - 1)).rename(eta="eta_c", xi_u="xi_psi").drop_vars("time")
    v = roms.v.isel(xi=slice(0, nx - 1)).rename(eta_v="eta_psi", xi="xi_c").drop_vars("time")
    seconds = (roms.time.values * 1e9).astype("timedelta64[ns]")
    data = xr.Dataset({"U": u, "V": v}, coords={
        "lon": (("eta_psi", "xi_psi"), roms.x_psi.values, {"units": "m"}),
        "lat": (("eta_psi", "xi_psi"), roms.y_psi.values, {"units": "m"}),
        "time": ("time", seconds, {"axis": "T"})})
    data["grid"] = xr.DataArray(0, attrs=SGRID_TOPOLOGY)
    return parcels.FieldSet.from_sgrid_conventions(data, mesh="flat")


def run_parcels(fieldset, starts: np.ndarray, tau: float, kernel: str, setting: float) -> np.ndarray:
    """End points of Parcels' ``kernel`` ("rk4": dt = setting; "rk45": tolerance = setting)."""
    import parcels

    pclass, advection, dt = parcels.Particle, parcels.kernels.AdvectionRK4, setting
    if kernel == "rk45":
        pclass = parcels.Particle.add_variable(parcels.Variable("next_dt", dtype=np.float64, initial=DATA_STEP))
        advection, dt = parcels.kernels.AdvectionRK45, DATA_STEP
        for name, value in (("RK45_tol", setting), ("RK45_min_dt", DATA_STEP / 2**12), ("RK45_max_dt", DATA_STEP)):
            fieldset.context[name] = value
    particles = parcels.ParticleSet(fieldset=fieldset, pclass=pclass, x=starts[:, 0], y=starts[:, 1],
                                    t=np.full(len(starts), np.timedelta64(0, "s")))
    particles.execute(advection, runtime=tau, dt=dt, verbose_progress=False)
    if kernel == "rk45":
        for name in ("RK45_tol", "RK45_min_dt", "RK45_max_dt"):
            del fieldset.context[name]
    return np.column_stack([particles.x, particles.y]).astype(float)


def run_ldpipe(system, axes, tau: float, rtol: float) -> np.ndarray:
    """End points of ldpipe's flow map at rtol = atol, x-major."""
    xs, ys = axes
    flow = ldpipe.ld_map(system, section=ldpipe.section(x_rho=(xs[0], xs[-1], len(xs)), y_rho=(ys[0], ys[-1], len(ys))),
                         t0=T0, tau=tau, ld=False, ftle=True, directions="forward",
                         integrator={"rtol": rtol, "atol": rtol}, threads=1, progress=False)
    return np.column_stack([flow.end_x_rho_forward.values.ravel(), flow.end_y_rho_forward.values.ravel()])


def run_cells(system, starts: np.ndarray, tau: float) -> np.ndarray:
    """End points of ldpipe's flow map by exact cell crossing (no tolerance)."""
    from ldpipe.core.trajectories import FlowSettings, flow_map

    return flow_map(system, starts, tau, FlowSettings(method="cell_crossing"), t0=T0, threads=1).end_state


def timed(function, *args):
    start = time.process_time()
    result = function(*args)
    return time.process_time() - start, result


def errors(ends: np.ndarray, reference: np.ndarray) -> tuple[float, float]:
    distance = np.hypot(*(ends - reference).T)
    return float(np.median(distance)), float(distance.max())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=40)
    parser.add_argument("--spacing", type=float, default=0.025)
    parser.add_argument("--tau", type=float, default=10.0)
    parser.add_argument("--rtols", type=float, nargs="+", default=[1e-4, 1e-5, 1e-6, 3e-7, 1e-7, 3e-8, 1e-8, 1e-10])
    parser.add_argument("--dts", type=float, nargs="+", default=[0.1, 0.05, 0.02, 0.01, 0.005])
    parser.add_argument("--rk45-tols", type=float, nargs="+", default=[1e-4, 1e-5])
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()

    xs, ys, starts = starts_grid(args.points)
    n = len(starts)
    times = np.arange(0.0, T0 + args.tau + 0.5 + DATA_STEP / 2, DATA_STEP)
    with tempfile.TemporaryDirectory() as folder:
        path = write_dataset(double_gyre_c_grid_dataset("conformal", args.spacing, times), Path(folder) / "roms.nc")
        with xr.open_dataset(path) as dataset:
            roms = dataset.load()
        system = ldpipe.system(name="roms", velocity_data={"path": str(path), "x": "x_rho", "y": "y_rho",
                                                          "components": "grid"})
        setup_ldpipe, _ = timed(run_ldpipe, system, (xs, ys), args.tau, 1e-4)  # compiles or loads the cache
        setup_parcels, fieldset = timed(parcels_fieldset, roms)
        print(f"{n} starts, grid {roms.x_rho.shape} centres (spacing {args.spacing}), tau {args.tau}; "
              f"setup CPU s: ldpipe {setup_ldpipe:.2f} (first map), Parcels {setup_parcels:.2f} (FieldSet)")
        exact = closed_form(starts, args.tau)

        runs = {}  # (tracker, setting) -> (cpu, ends)
        sweep = [("ldpipe", rtol) for rtol in args.rtols] + [("ldpipe cells", 0.0)] + \
                [("parcels rk4", dt) for dt in args.dts] + \
                [("parcels rk45", tol) for tol in args.rk45_tols]

        def run(tracker, setting):
            if tracker == "ldpipe":
                return timed(run_ldpipe, system, (xs, ys), args.tau, setting)
            if tracker == "ldpipe cells":
                return timed(run_cells, system, starts, args.tau)
            return timed(run_parcels, fieldset, starts, args.tau, tracker.split()[1], setting)

        load_before = os.getloadavg()
        for tracker, setting in sweep:
            runs[tracker, setting] = run(tracker, setting)
            print(f"  swept {tracker} {setting:g}: {runs[tracker, setting][0]:.2f} CPU s", flush=True)

        tight_ldpipe = runs["ldpipe", min(args.rtols)][1]
        tight_parcels = runs["parcels rk4", min(args.dts)][1]
        print("\n| tracker | setting | error median | error worst | integration error median, worst | "
              "trajectories per CPU s (sweep) |")
        print("| --- | --- | ---: | ---: | ---: | ---: |")
        for (tracker, setting), (cpu, ends) in runs.items():
            label = {"ldpipe": "rtol", "ldpipe cells": "cell_crossing", "parcels rk4": "dt", "parcels rk45": "tol"}[tracker]
            median, worst = errors(ends, exact)
            own = errors(ends, tight_ldpipe if tracker.startswith("ldpipe") else tight_parcels)
            shown = label if tracker == "ldpipe cells" else f"{label} {setting:g}"
            print(f"| {tracker} | {shown} | {median:.2e} | {worst:.2e} | {own[0]:.1e}, {own[1]:.1e} | "
                  f"{n / cpu:.4g} |")
        floor = {"ldpipe": errors(tight_ldpipe, exact), "parcels": errors(tight_parcels, exact)}
        apart = errors(tight_ldpipe, tight_parcels)
        print(f"\ninterpolation error (median, worst): ldpipe {floor['ldpipe'][0]:.3e}, {floor['ldpipe'][1]:.3e}; "
              f"Parcels {floor['parcels'][0]:.3e}, {floor['parcels'][1]:.3e}")
        print(f"ldpipe - Parcels at their tightest: median {apart[0]:.3e} "
              f"({apart[0] / max(floor['ldpipe'][0], floor['parcels'][0]):.2f} interpolation errors), worst "
              f"{apart[1]:.3e} ({apart[1] / max(floor['ldpipe'][1], floor['parcels'][1]):.2f})")

        target = (1.1 * max(floor["ldpipe"][0], floor["parcels"][0]), 1.1 * max(floor["ldpipe"][1], floor["parcels"][1]))
        matched = {}
        for tracker in ("ldpipe", "ldpipe cells", "parcels rk4", "parcels rk45"):
            meeting = [(cpu, setting) for (who, setting), (cpu, ends) in runs.items()
                       if who == tracker and all(e <= t for e, t in zip(errors(ends, exact), target))]
            if meeting:
                matched[tracker] = min(meeting)[1]
        print(f"matched accuracy: median <= {target[0]:.3e}, worst <= {target[1]:.3e}: "
              + ", ".join(f"{k} {v:g}" for k, v in matched.items())
              + (f"; not reached: {', '.join(k for k in ('parcels rk45',) if k not in matched)}"
                 if "parcels rk45" not in matched else ""))

        rounds = {tracker: [] for tracker in matched}
        for _ in range(args.rounds):
            for tracker, setting in matched.items():
                rounds[tracker].append(n / run(tracker, setting)[0])
        load_after = os.getloadavg()
        print(f"\nload average {load_before[0]:.2f} before, {load_after[0]:.2f} after; {args.rounds} rounds, "
              "interleaved")
        print("| tracker | setting | trajectories per CPU s (median) | spread (max/min) | ratio ldpipe / it | "
              "ratio ldpipe cells / it |")
        print("| --- | --- | ---: | ---: | ---: | ---: |")
        ours = float(np.median(rounds.get("ldpipe", [np.nan])))
        cells = float(np.median(rounds.get("ldpipe cells", [np.nan])))
        for tracker, rates in rounds.items():
            rate = float(np.median(rates))
            print(f"| {tracker} | {matched[tracker]:g} | {rate:.4g} | {max(rates) / min(rates):.2f} | "
                  f"{ours / rate:.3g} | {cells / rate:.3g} |")


if __name__ == "__main__":
    main()
