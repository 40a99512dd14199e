"""Composition weights compiled in or read at run time: throughput, compile time and LDs, side by side.

Two source trees of ldpipe (``--before SRC`` with the weights compiled in, one engine module per
composition; ``--after SRC`` with them as run-time coefficients, one module for every
composition) are run in alternating worker processes, round after round, on
engine_throughput.py's Barbanis 2 DoF section (E = E_c - 0.125, tau 50, p = 1/2, forward and
backward, one thread). Each worker times every setting once, in CPU seconds of the process, and
saves its LDs; the report gives, per setting, the best and the spread of the rounds, the ratio
after / before, and whether the LDs of both trees are equal bit for bit (numpy.array_equal).
rk4 and dop853 measure the driver's part of the change alone (their steps take no coefficients).
Modules a worker compiles are counted by ``$LDPIPE_COMPILE_LOG`` (a first, untimed round loads
or compiles them).

    python benchmarks/composition_coefficients.py --before /tmp/base/src --after src --rounds 5 --out /tmp/cc
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

SETTINGS = {  # label: LDSettings keyword arguments
    "sym4 dt 0.05": {"scheme": "sym4", "dt": 0.05},
    "sym6 dt 0.1": {"scheme": "sym6", "dt": 0.1},
    "sym4 dt 0.01": {"scheme": "sym4", "dt": 0.01},
    "sym6 dt 0.02": {"scheme": "sym6", "dt": 0.02},
    # the driver's change alone (their steps take no run-time coefficients)
    "rk4 dt 0.05": {"scheme": "rk4", "dt": 0.05},
    "dop853 rtol 1e-8": {"scheme": "dop853", "rtol": 1e-8, "atol": 1e-8},
}


def worker(grid: int, labels: list[str], out: Path) -> None:
    import numba

    from ldpipe.engine import LDSettings, compute_ld
    from ldpipe.systems import make_system

    numba.set_num_threads(1)
    system = make_system("barbanis_2dof", {"builtin": "barbanis_2dof"})
    energy = 15.125 - 0.125
    x, px = np.meshgrid(np.linspace(-2.0, 8.0, grid), np.linspace(-4.0, 4.0, grid))
    x, px = x.ravel(), px.ravel()
    potential = np.array([system.potential(np.array([xi, 0.0])) for xi in x])
    kinetic_y = 2.0 * (energy - potential) - px**2
    keep = kinetic_y > 0.0
    states = np.column_stack([x[keep], np.zeros(keep.sum()), px[keep], np.sqrt(kinetic_y[keep])])
    times, lds = {}, {}
    for label in labels:
        settings = LDSettings(tau=50.0, **SETTINGS[label])
        compute_ld(system, states[:64], 1, settings)  # load (or compile) outside the timing
        cpu = time.process_time()
        forward = compute_ld(system, states, 1, settings)
        backward = compute_ld(system, states, -1, settings)
        times[label] = time.process_time() - cpu
        lds[label] = np.stack([forward.ld, backward.ld])
    np.savez(out.with_suffix(".npz"), **{k.replace(" ", "_"): v for k, v in lds.items()})
    out.with_suffix(".json").write_text(json.dumps({"cpu": times, "points": int(len(states))}))


def run_worker(src: str, grid: int, labels: list[str], out: Path, compile_log: Path) -> dict:
    env = {**os.environ, "PYTHONPATH": src, "LDPIPE_COMPILE_LOG": str(compile_log)}
    subprocess.run([sys.executable, __file__, "--worker", "--grid", str(grid), "--labels", *labels, "--out", str(out)],
                   env=env, check=True)
    return json.loads(out.with_suffix(".json").read_text())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--worker", action="store_true")
    parser.add_argument("--before")
    parser.add_argument("--after")
    parser.add_argument("--grid", type=int, default=100)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--labels", nargs="+", default=list(SETTINGS))
    parser.add_argument("--out", required=True)
    args = parser.parse_args()
    if args.worker:
        worker(args.grid, args.labels, Path(args.out))
        return
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    trees = {"before": args.before, "after": args.after}
    results = {name: [] for name in trees}
    print(f"load average before {os.getloadavg()}", flush=True)
    for name, src in trees.items():  # untimed: loads or compiles the modules
        run_worker(src, 8, args.labels, out / f"warm_{name}", out / f"compile_{name}.jsonl")
    for r in range(args.rounds):
        order = list(trees) if r % 2 == 0 else list(trees)[::-1]
        for name in order:
            results[name].append(run_worker(trees[name], args.grid, args.labels, out / f"{name}_{r}",
                                            out / f"rounds_{name}.jsonl"))
    print(f"load average after {os.getloadavg()}")
    print(f"{results['before'][0]['points']} points, {args.rounds} rounds, CPU s of one forward + backward pass")
    print("| setting | before best | before spread | after best | after spread | after / before (best) "
          "| per round | LDs equal |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | --- | --- |")
    for label in args.labels:
        b = np.array([res["cpu"][label] for res in results["before"]])
        a = np.array([res["cpu"][label] for res in results["after"]])
        key = label.replace(" ", "_")
        equal = all(np.array_equal(np.load(out / f"before_{r}.npz")[key], np.load(out / f"after_{r}.npz")[key])
                    for r in range(args.rounds))
        ratios = a / b
        print(f"| {label} | {b.min():.3f} | {b.min():.3f}-{b.max():.3f} | {a.min():.3f} | {a.min():.3f}-{a.max():.3f} "
              f"| {a.min() / b.min():.3f} | {ratios.min():.3f}-{ratios.max():.3f} | {'yes' if equal else 'NO'} |")
    for name in trees:
        path = out / f"compile_{name}.jsonl"
        records = [json.loads(line) for line in path.read_text().splitlines()] if path.exists() else []
        compiled: dict[str, float] = {}
        for record in records:
            if record.get("event") == "compile":
                compiled[record["module"]] = compiled.get(record["module"], 0.0) + record["cpu_s"]
        print(f"{name}: modules compiled by the first round: "
              + ("; ".join(f"{module} {cpu:.1f} CPU s" for module, cpu in compiled.items()) or "none"))


if __name__ == "__main__":
    main()
