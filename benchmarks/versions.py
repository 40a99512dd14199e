"""Engine throughput of two versions of ldpipe, side by side in one run.

Did a change cost speed? Each round runs the same LD settings on the same grid in a fresh process
of each version (``--old`` and ``--new``: the ``src`` folders of two checkouts, put first on the
path), alternating, so a burst of load from other processes hits both alike. JIT compilation and
cache loading are excluded (every setting is warmed up on 8 points first). Reported per setting:
the CPU-time throughput of each version (trajectory time units per CPU second, all threads; the
best of the rounds) and the ratio new/old with its spread over the rounds, and whether the LDs of
the two versions are equal bit for bit.

    .venv/bin/python benchmarks/versions.py --old ../baseline/src --new src --rounds 3 --repeat 3 --n 200

The grid (``--flow barbanis``, the default) is compare.py's: Barbanis 2 DoF, U_xpx (y = 0,
p_y > 0) at ΔE = -0.125, x and p_x in [-5.6, 5.6], tau = 50 forward. ``--flow one-way`` is a flow
in which no velocity component ever comes near zero, for the speed of the steps that need none
of the quadrature's special cases (issue 18: "the speed the fast path has where nothing is near
zero"): V = -(x + y) - (sin x + sin y) / 2, so that dp/dt = 1 + cos(q) / 2 >= 1/2 for both
coordinates, started at x, y in [0, 1] with p = 1 + q (dq/dt = p > 1 and growing):

    .venv/bin/python benchmarks/versions.py --old ../baseline/src --new src --flow one-way --tau 10
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

#: (label, scheme, tolerance or step, p)
SETTINGS = (
    ("dop853 rtol 1e-4, M_1/2", "dop853", 1e-4, 0.5),
    ("dop853 rtol 1e-5, M_1/2", "dop853", 1e-5, 0.5),
    ("dop853 rtol 1e-8, M_1/2", "dop853", 1e-8, 0.5),
    ("dop853 rtol 1e-10, M_1/2", "dop853", 1e-10, 0.5),
    ("taylor rtol 1e-10, M_1/2", "taylor", 1e-10, 0.5),
    ("rk4 dt 0.05, M_1/2", "rk4", 0.05, 0.5),
    ("sym4 dt 0.05, M_1/2", "sym4", 0.05, 0.5),
    ("sym6 dt 0.1, M_1/2", "sym6", 0.1, 0.5),
    ("sym6 dt 0.02, M_1/2", "sym6", 0.02, 0.5),
    ("dop853 rtol 1e-10, arc length", "dop853", 1e-10, "arclength"),
    ("taylor rtol 1e-10, arc length", "taylor", 1e-10, "arclength"),
    ("taylor rtol 1e-12, arc length", "taylor", 1e-12, "arclength"),
)


FLOWS = ("barbanis", "one-way")


def flow(name: str, n: int):
    """(system, initial states) of the flow ``name`` on an n x n grid (see the module docstring)."""
    from ldpipe.systems import make_system

    if name == "one-way":
        system = make_system("one_way", {"formula": "-(x + y) - a*(sin(x) + sin(y))", "coordinates": ["x", "y"],
                                         "parameters": {"a": 0.5}})
        x, y = (a.ravel() for a in np.meshgrid(np.linspace(0.0, 1.0, n), np.linspace(0.0, 1.0, n)))
        return system, np.column_stack([x, y, 1.0 + x, 1.0 + y])
    system = make_system("barbanis_2dof", {"builtin": "barbanis_2dof"})
    energy = 15.125 - 0.125
    x, px = (a.ravel() for a in np.meshgrid(np.linspace(-5.6, 5.6, n), np.linspace(-5.6, 5.6, n)))
    kinetic_y = 2.0 * (energy - 0.5 * x**2) - px**2  # V(x, 0) = wx^2 x^2 / 2 with wx = 1
    keep = kinetic_y > 0.0
    return system, np.column_stack([x[keep], np.zeros(keep.sum()), px[keep], np.sqrt(kinetic_y[keep])])


def worker(n: int, tau: float, repeat: int, only: list[str] | None = None, flow_name: str = "barbanis") -> None:
    """Time every setting in this process (the version first on sys.path); JSON on stdout."""
    import time

    import ldpipe
    from ldpipe.engine import LDSettings, compute_ld
    from ldpipe.engine.schemes import get_scheme

    system, states = flow(flow_name, n)
    rows = {}
    for label, scheme, accuracy, p in selected(only):
        step = {"rtol": accuracy, "atol": accuracy} if get_scheme(scheme).adaptive else {"dt": accuracy}
        settings = LDSettings(scheme=scheme, p=p, tau=tau, **step)
        compute_ld(system, states[:8], +1, settings)
        wall = cpu = float("inf")
        for _ in range(repeat):  # the fastest of a few calls: a call takes about a second
            wall0, cpu0 = time.perf_counter(), time.process_time()
            result = compute_ld(system, states, +1, settings)
            wall, cpu = min(wall, time.perf_counter() - wall0), min(cpu, time.process_time() - cpu0)
        rows[label] = {"cpu": cpu, "wall": wall, "time_units": float(result.time.sum()),
                       "ld_sum": float(np.sum(result.ld)), "ld_hash": hashlib.sha256(result.ld.tobytes()).hexdigest()}
    json.dump({"ldpipe": ldpipe.__file__, "points": int(len(states)), "rows": rows}, sys.stdout)


def selected(only: list[str] | None) -> list[tuple]:
    """The SETTINGS whose label contains one of ``only`` (all of them without it)."""
    return [row for row in SETTINGS if not only or any(part in row[0] for part in only)]


def run(source: Path, n: int, tau: float, repeat: int, only: list[str] | None, flow_name: str) -> dict:
    env = {**os.environ, "PYTHONPATH": str(source.resolve())}
    done = subprocess.run([sys.executable, __file__, "--worker", "--n", str(n), "--tau", str(tau),
                           "--repeat", str(repeat), "--flow", flow_name, *(["--only", *only] if only else [])],
                          env=env, capture_output=True, text=True, check=True)
    result = json.loads(done.stdout)
    if not Path(result["ldpipe"]).resolve().is_relative_to(source.resolve()):
        raise SystemExit(f"{source}: the worker imported ldpipe from {result['ldpipe']}")
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--old", type=Path, help="the src folder of the version to compare against")
    parser.add_argument("--new", type=Path, default=Path(__file__).resolve().parents[1] / "src")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--n", type=int, default=200, help="grid points per side (default 200)")
    parser.add_argument("--tau", type=float, default=50.0)
    parser.add_argument("--repeat", type=int, default=3, help="calls per setting in a round; the fastest counts")
    parser.add_argument("--only", nargs="+", metavar="PART",
                        help='run the settings whose label contains one of these, e.g. "dop853 rtol 1e-5, M"')
    parser.add_argument("--flow", choices=FLOWS, default="barbanis",
                        help="the grid's flow: compare.py's Barbanis section (default) or one with no velocity near zero")
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        return worker(args.n, args.tau, args.repeat, args.only, args.flow)
    if args.old is None:
        parser.error("--old is required")
    if not selected(args.only):
        parser.error(f"--only {args.only}: no setting matches; the labels are {[row[0] for row in SETTINGS]}")
    print(f"load average before: {' '.join(f'{v:.2f}' for v in os.getloadavg())}, {os.cpu_count()} CPUs")
    runs = {"old": [], "new": []}
    for round_ in range(args.rounds):
        for version in ("old", "new") if round_ % 2 == 0 else ("new", "old"):
            runs[version].append(run(getattr(args, version), args.n, args.tau, args.repeat, args.only, args.flow))
    print(f"load average after: {' '.join(f'{v:.2f}' for v in os.getloadavg())}")
    print(f"{args.flow} flow, {runs['new'][0]['points']} points, tau = {args.tau}, {args.rounds} rounds, "
          "throughput per CPU second")
    print("| setting | old | new | new/old (best) | new/old per round, min–max | LD equal |")
    print("| --- | ---: | ---: | ---: | ---: | --- |")
    for label, *_ in selected(args.only):
        old = [r["rows"][label] for r in runs["old"]]
        new = [r["rows"][label] for r in runs["new"]]
        rate = lambda row: row["time_units"] / row["cpu"]  # noqa: E731
        best_old, best_new = max(map(rate, old)), max(map(rate, new))
        ratios = [rate(b) / rate(a) for a, b in zip(old, new)]
        equal = all(a["ld_hash"] == b["ld_hash"] for a, b in zip(old, new))
        print(f"| {label} | {best_old:.3g} | {best_new:.3g} | {best_new / best_old:.2f} | "
              f"{min(ratios):.2f}–{max(ratios):.2f} | {'yes' if equal else 'no'} |")


if __name__ == "__main__":
    main()
