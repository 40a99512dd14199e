"""Scale of NHIM sampling: refined NHIM points per second of the Barbanis-Contopoulos 3 DoF saddle at E = 24.

The slice family is the config's fig5_xpx study made larger: x-p_x slices (solved p_z, both
signs) over a grid of (y, z, p_y) in the box y in [5.0, 5.6], z in [1.85, 3.45], p_y in
[-0.5, 0.5] (inside the extent of the two Lyapunov orbits, so most slices meet the NHIM), with
``--per-axis`` values per fixed coordinate (default: enough for ``--points`` refined points, about
half of the box's slices giving one). The map settings are fig5_xpx's (the paper's saddle region,
tau = 50, p = 1/2, DOP853 at 1e-8), the refinement nhim.refinement's defaults (tolerance 1e-8,
DOP853 at 1e-12).

Prints and writes (``benchmarks/results/nhim_sampling_<time>.json`` and ``nhim_sampling_latest.json``):
refined points, slices by status, wall time, points per second, CPU time of the process (all its
threads) and points per CPU second (what a shared machine disturbs less), trajectories and time units,
the machine's load average before and after (os.getloadavg; the machine may be shared), the
threads, and the accuracy reached: quantiles of the refinement's uncertainty bound and of
|H(state) - E| over the points. The JIT warm-up (one slice) is timed separately.

Run: ``.venv/bin/python benchmarks/nhim_sampling.py [--points 10000] [--batch 256]``
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import time
from datetime import datetime, timezone
from pathlib import Path

import numba
import numpy as np

from ldpipe.engine import LDSettings
from ldpipe.core.nhim import Cost, RefinementSettings, make_slice_problem
from ldpipe.core.nhim.sampling import STATUS, SamplingSettings, sample_family, sample_slice
from ldpipe.core.sections import Section
from ldpipe.systems import make_system

SADDLE = np.array([10.289915108550531, 5.294117647058823, 2.6470588235294117])  # closed form (paper)
ENERGY = 24.0
BOX = {"y": (5.0, 5.6), "z": (1.85, 3.45), "py": (-0.5, 0.5)}
#: Fraction of the box's slices that gave a point (0.53 of 27 648 slices on 24 values per coordinate).
YIELD = 0.5


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=10_000, help="refined points aimed at")
    parser.add_argument("--per-axis", type=int, default=None, help="values per fixed coordinate (overrides --points)")
    parser.add_argument("--batch", type=int, default=256, help="slices searched together")
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results")
    args = parser.parse_args()

    system = make_system("barbanis_contopoulos_3dof", {"builtin": "barbanis_contopoulos_3dof"})
    section = Section(axes=("x", "px"), ranges=((9.0, 12.0), (-0.6, 0.6)), shape=(1000, 1000),
                      fixed={"y": SADDLE[1], "z": SADDLE[2], "py": 0.0}, solve="pz", sign=1)
    ld_settings = LDSettings(rtol=1e-8, atol=1e-8, p=0.5, tau=50.0, region_lower=(9.0, 2.5, 1.0),
                             region_upper=(12.0, 7.5, 4.0))
    base = make_slice_problem("fig5_xpx", system, section, ENERGY, system.potential(SADDLE), SADDLE, ld_settings)
    refinement = RefinementSettings()
    settings = SamplingSettings(batch=args.batch)
    n = args.per_axis or math.ceil((args.points / (2 * YIELD)) ** (1 / 3))
    grid = {name: np.linspace(low, high, n) for name, (low, high) in BOX.items()}
    print(f"{2 * n**3} slices ({n} per fixed coordinate, both signs), {numba.get_num_threads()} threads, "
          f"batch {args.batch}")

    started = time.perf_counter()
    sample_slice(base, dict(section.fixed), 1, None, settings, refinement)  # JIT / cache load
    warm_up = time.perf_counter() - started

    load_before = os.getloadavg()
    cost = Cost()
    started, cpu_started = time.perf_counter(), time.process_time()
    samples = sample_family(base, grid, (1, -1), settings, refinement, cost=cost)
    wall, cpu = time.perf_counter() - started, time.process_time() - cpu_started
    load_after = os.getloadavg()

    points = [s for s in samples if s.status == "ok"]
    uncertainty = np.array([s.uncertainty for s in points])
    residual = np.array([abs(system.energy(s.state) - ENERGY) for s in points])
    quantiles = (0.5, 0.9, 0.99, 1.0)
    result = {
        "when": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "machine": {"node": platform.node(), "cpus": os.cpu_count(), "threads": numba.get_num_threads(),
                    "load_before": load_before, "load_after": load_after},
        "slices": len(samples), "per_axis": n, "box": BOX, "energy": ENERGY, "batch": args.batch,
        "status": {name: sum(s.status == name for s in samples) for name in STATUS},
        "points": len(points), "wall_time_s": wall, "warm_up_s": warm_up,
        "points_per_second": len(points) / wall,
        "cpu_time_s": cpu, "points_per_cpu_second": len(points) / cpu,
        "trajectories": cost.trajectories, "time_units": cost.time_units, "steps": cost.steps,
        "uncertainty_quantiles": dict(zip(map(str, quantiles), np.quantile(uncertainty, quantiles).tolist()))
        if len(points) else {},
        "energy_residual_quantiles": dict(zip(map(str, quantiles), np.quantile(residual, quantiles).tolist()))
        if len(points) else {},
        "refinement": {"tolerance": refinement.tolerance, "rtol": refinement.rtol},
    }
    print(json.dumps(result, indent=2))
    args.out.mkdir(parents=True, exist_ok=True)
    stamp = datetime.now(timezone.utc).strftime("%Y%m%dT%H%M%S")
    for name in (f"nhim_sampling_{stamp}.json", "nhim_sampling_latest.json"):
        (args.out / name).write_text(json.dumps(result, indent=2) + "\n")


if __name__ == "__main__":
    main()
