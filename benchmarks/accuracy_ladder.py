"""Where the accuracy_cost stage's time goes: each part of its measurement, in CPU and wall seconds.

Runs the stage's measurement (``ldpipe.core.accuracy.measurement.accuracy_dataset``) on the paper
configuration's ``accuracy_cost`` section as the workflow job does (the same threads), with every
timed engine run, warm-up, reference, reference check, orbit ladder and NHIM ladder recorded as
it happens: each repeat of each rung separately, so the spread of the repeats is seen too.
Needs the barbanis_2dof equilibria file of a workflow run and the ladder's engine modules in the
cache (else their compiles are counted as warm-ups).

    python benchmarks/accuracy_ladder.py --equilibria results/barbanis_2dof/equilibria.nc --out /tmp/parts.json

The JSON lists the parts in order (``part``, ``label``, ``repeat``, ``cpu``, ``wall``); the
Markdown summary goes to stdout. ``--repeats N`` overrides the section's LD repeats,
``--repeat-budget S`` every ladder's repeat budget (a huge value: every setting ``repeats`` times).
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
import pickle
import time
from contextlib import contextmanager
from pathlib import Path

T0_CPU, T0_WALL = time.process_time(), time.perf_counter()

import numba  # noqa: E402
import yaml  # noqa: E402

import ldpipe.core.accuracy.ld_ladder as ld_ladder  # noqa: E402
import ldpipe.core.accuracy.measurement as measurement  # noqa: E402
import ldpipe.core.accuracy.orbit_ladder as orbit_ladder  # noqa: E402
import ldpipe.stages.accuracy as stage  # noqa: E402
from ldpipe.config import validate_config  # noqa: E402
from ldpipe.engine import compute_ld  # noqa: E402
from ldpipe.config.parameters import parameters_from_config  # noqa: E402

RECORDS: list[dict] = []


@contextmanager
def part(name: str, label: str = "", repeat: int = 0):
    cpu, wall = time.process_time(), time.perf_counter()
    yield
    RECORDS.append({"part": name, "label": label, "repeat": repeat,
                    "cpu": time.process_time() - cpu, "wall": time.perf_counter() - wall})


def label_of(settings) -> str:
    if settings.adaptive:
        return f"{settings.scheme} rtol {settings.rtol:g}"
    return f"{settings.scheme} dt {settings.dt:g}"


CURRENT = {"map": "", "role": "rung"}


def recorded_timed_ld(system, states, settings, rule):
    """ld_ladder.timed_ld, each run recorded."""
    runs = itertools.count()

    def run():
        wall, cpu = time.perf_counter(), time.process_time()
        result = compute_ld(system, states, 1, settings), compute_ld(system, states, -1, settings)
        RECORDS.append({"part": f"ld {CURRENT['map']}", "label": label_of(settings), "repeat": next(runs),
                        "cpu": time.process_time() - cpu, "wall": time.perf_counter() - wall, "points": len(states)})
        return result

    timed = ld_ladder.repeat_timed(run, rule)
    return ld_ladder.TimedLD(*timed.result, timed.wall_time, timed.cpu_time, timed.runs)


def wrap(module, name, part_name, label=lambda *a, **k: ""):
    original = getattr(module, name)

    def wrapped(*args, **kwargs):
        with part(part_name, label(*args, **kwargs)):
            return original(*args, **kwargs)

    setattr(module, name, wrapped)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--equilibria", required=True)
    parser.add_argument("--config", default="config.yaml")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--repeats", type=int, default=None)
    parser.add_argument("--repeat-budget", type=float, default=None, help="override every ladder's repeat_budget (s)")
    parser.add_argument("--out", required=True)
    parser.add_argument("--dataset", default=None, help="pickle the measured dataset here")
    args = parser.parse_args()
    numba.set_num_threads(min(args.threads, numba.config.NUMBA_NUM_THREADS))
    config = yaml.safe_load(Path(args.config).read_text())
    validate_config(config)
    params = parameters_from_config(config, "accuracy")
    if args.repeats:
        params["ld"]["repeats"] = args.repeats
    if args.repeat_budget:
        for section in ("ld", "upo", "nhim"):
            params[section]["repeat_budget"] = args.repeat_budget

    ld_ladder.timed_ld = recorded_timed_ld
    wrap(ld_ladder, "warm_up", "warm-up", lambda system, states, settings: settings.scheme)
    original_map = measurement._map_dataset

    def map_dataset(name, *a, **k):
        CURRENT["map"] = name
        with part("map total", name):
            return original_map(name, *a, **k)

    measurement._map_dataset = map_dataset
    wrap(measurement, "orbit_accuracy_dataset", "orbit total")
    wrap(orbit_ladder, "timed_orbit", "orbit rung", lambda *a, **k: f"{a[4].label}")
    wrap(orbit_ladder, "closure_error", "orbit closure check", lambda system, orbit, rtol: f"rtol {rtol:g}")
    wrap(measurement, "nhim_accuracy_dataset", "nhim total")
    wrap(measurement, "compute_orbit", "nhim reference orbit")
    wrap(measurement, "nhim_grid_dataset", "nhim grid ladder")
    wrap(measurement, "ld_grid_dataset", "nhim refinement start grid")
    wrap(measurement, "nhim_refinement_dataset", "nhim refinement ladder")

    load_before = os.getloadavg()
    setup_cpu, setup_wall = time.process_time() - T0_CPU, time.perf_counter() - T0_WALL
    RECORDS.append({"part": "imports", "label": "", "repeat": 0, "cpu": setup_cpu, "wall": setup_wall})
    with part("accuracy_dataset total"):
        data = measurement.accuracy_dataset(params["ld"], params["upo"], params["nhim"], [args.equilibria])
    with part("table"):
        stage.accuracy_table(data)
    load_after = os.getloadavg()
    RECORDS.append({"part": "process total", "label": "", "repeat": 0, "cpu": time.process_time() - T0_CPU,
                    "wall": time.perf_counter() - T0_WALL})
    Path(args.out).write_text(json.dumps({"load_before": load_before, "load_after": load_after,
                                          "threads": args.threads, "repeats": params["ld"]["repeats"],
                                          "repeat_budget": params["ld"]["repeat_budget"],
                                          "records": RECORDS}, indent=1))
    if args.dataset:
        Path(args.dataset).write_bytes(pickle.dumps(data))
    summarize(RECORDS, load_before, load_after)


def summarize(records, load_before, load_after) -> None:
    print(f"load average before {load_before}, after {load_after}")
    groups: dict[tuple, list] = {}
    for r in records:
        groups.setdefault((r["part"], r["label"]), []).append(r)
    print("| part | label | runs | CPU s (sum) | wall s (sum) | CPU s per run (min-max) |")
    print("| --- | --- | ---: | ---: | ---: | --- |")
    for (name, label), rs in groups.items():
        cpus = [r["cpu"] for r in rs]
        print(f"| {name} | {label} | {len(rs)} | {sum(cpus):.2f} | {sum(r['wall'] for r in rs):.2f} "
              f"| {min(cpus):.3f}-{max(cpus):.3f} |")


if __name__ == "__main__":
    main()
