"""Monte Carlo reactive flux to a target relative standard error: wall time, samples per second, load.

Issue 17 asks for the flux to 1e-3 relative standard error in at most a minute on 2 cores. Cases:
Barbanis 2 DoF over the bottom saddle (ΔE = 0.125 and 5, the transport study's ends) and
Barbanis–Contopoulos 3 DoF through the dividing plane of the x > 0 saddle (E = 24, the paper's
energy, and E = 26). Settings are the transport stage's defaults (commit 2, DOP853 at rtol 1e-9,
samples every 0.1), the integration 15 time units each way in 2 DoF and 20 in 3 DoF. JIT
compilation and cache loading are excluded (each case first runs one small batch). The machine
is shared: the load average before and after each case is recorded with it.

    .venv/bin/python benchmarks/transport_mc.py                   # all cases, target 1e-3
    .venv/bin/python benchmarks/transport_mc.py --target 3e-3 --batch 1000

Writes benchmarks/results/transport_mc_<time>.{md,json}.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import time
from pathlib import Path

import numba
import numpy as np

from ldpipe.core.accuracy.machine import load_average, machine_attributes
from ldpipe.core.trajectories import FlowSettings
from ldpipe.systems import make_system
from ldpipe.core.transport import DividingLine, DividingPlane, reactive_flux_monte_carlo

RESULTS = Path(__file__).parent / "results"


def cases():
    """(label, surface, integration time each way) of every case."""
    barbanis = make_system("barbanis_2dof", {"builtin": "barbanis_2dof"})
    bottom = np.array([5.5, -math.sqrt(50.0)])
    bc = make_system("barbanis_contopoulos_3dof", {"builtin": "barbanis_contopoulos_3dof", "parameters": {
        "omega_x2": 0.9, "omega_y2": 1.6, "omega_z2": 0.4, "epsilon": 0.08, "eta": 0.01}})
    saddle = bc.closed_form_equilibria()[1]
    for excess in (0.125, 5.0):
        yield f"Barbanis 2 DoF, dE = {excess}", DividingLine.at_saddle(barbanis, bottom, 15.125 + excess), 15.0
    for energy in (24.0, 26.0):
        yield (f"Barbanis-Contopoulos 3 DoF, E = {energy} (dE = {energy - bc.potential(saddle):.3f})",
               DividingPlane.at_saddle(bc, saddle, energy), 20.0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--target", type=float, default=1e-3, help="relative standard error to reach")
    parser.add_argument("--batch", type=int, default=2000, help="samples per batch (the target is checked after each)")
    parser.add_argument("--max-samples", type=int, default=2_000_000)
    args = parser.parse_args()
    flow = FlowSettings(rtol=1e-9, atol=1e-9, escape_radius=60.0)
    rows = []
    for label, surface, duration in cases():
        settings = {"commit": 2.0, "duration": duration, "sample_step": 0.1, "flow": flow}
        reactive_flux_monte_carlo(surface, batch=50, max_samples=50, **settings)  # compile / load the kernels
        load_before = load_average().tolist()
        wall0, cpu0 = time.perf_counter(), time.process_time()
        result = reactive_flux_monte_carlo(surface, target_stderr=args.target, batch=args.batch,
                                           max_samples=args.max_samples, seed=1, **settings)
        wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
        rows.append({"case": label, "flux": result.flux, "relative_stderr": result.stderr / result.flux,
                     "one_way_flux": result.surface_flux, "samples": result.samples,
                     "recrossing_samples": result.samples - result.reactive, "undecided": result.undecided,
                     "wall_s": wall, "cpu_s": cpu, "samples_per_s": result.samples / wall,
                     "load_before": load_before, "load_after": load_average().tolist()})
        print(f"{label}: flux {result.flux:.8g} +- {result.stderr:.2g} ({result.samples} samples, "
              f"{wall:.1f} s wall, {result.samples / wall:.0f} samples/s, load {load_before[0]:.2f})", flush=True)
    stamp = time.strftime("%Y%m%dT%H%M%SZ", time.gmtime())
    RESULTS.mkdir(exist_ok=True)
    meta = {"target": args.target, "batch": args.batch, "threads": numba.get_num_threads(),
            "cpus": os.cpu_count(), "machine": machine_attributes(), "time_utc": stamp}
    (RESULTS / f"transport_mc_{stamp}.json").write_text(json.dumps({"meta": meta, "rows": rows}, indent=1))
    lines = [f"Monte Carlo reactive flux to {args.target:g} relative standard error, {meta['threads']} threads "
             f"on {meta['cpus']} CPUs ({meta['machine']['machine_cpu_model']}), {stamp}", "",
             "| case | flux | rel. stderr | samples | not reactive | wall s | samples/s | load before → after |",
             "| --- | ---: | ---: | ---: | ---: | ---: | ---: | --- |"]
    for r in rows:
        lines.append(f"| {r['case']} | {r['flux']:.8g} | {r['relative_stderr']:.2g} | {r['samples']} | "
                     f"{r['recrossing_samples']} | {r['wall_s']:.1f} | {r['samples_per_s']:.0f} | "
                     f"{r['load_before'][0]:.2f} → {r['load_after'][0]:.2f} |")
    (RESULTS / f"transport_mc_{stamp}.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
