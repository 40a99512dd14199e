"""Extracting structures from a map against making the map: CPU of each, and their ratio.

    .venv/bin/python benchmarks/structures.py --points 100 200 --repeat 3

For each case (the linear saddle's LD map, tau 10, with its FTLE; Barbanis' Fig. 3 section in the
window of tests/structures/test_barbanis_manifolds.py, tau 12) at each number of points per axis:
the map computed once (process CPU and wall, after a small warm-up map so that compiling is
excluded), then ``ldpipe.structures`` on it --repeat times (the smallest CPU taken), and the
ratio extraction / map. The issue's goal is an extraction within 10 % of the map's own time.

Prints a Markdown table and writes benchmarks/results/structures_<time>.json.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import ldpipe  # noqa: E402

SADDLE = {"vector_field": {"x": "lam*x", "y": "-lam*y"}, "coordinates": ["x", "y"], "parameters": {"lam": 0.8}}


def saddle_map(n: int):
    system = ldpipe.system(name="linear_saddle", **SADDLE)
    return ldpipe.ld_map(system, section=ldpipe.section(x=(-0.5, 0.53, n), y=(-0.47, 0.6, n)), tau=10.0, p=0.5,
                         ftle=True, integrator={"rtol": 1e-10, "atol": 1e-10, "escape_radius": 1e4})


def barbanis_map(n: int):
    system = ldpipe.system(builtin="barbanis_2dof")
    section = ldpipe.section(x=(-2.3, 1.3, n), px=(-4.3, 4.3, n), fixed={"y": 0.0}, solve="py", sign=1)
    return ldpipe.ld_map(system, name="window", section=section, energy={"excess": 0.125}, tau=12.0, p=0.5,
                         integrator={"rtol": 1e-8, "atol": 1e-8}, saddle_near=[5.5, -7.0711])


CASES = {"linear saddle, LD + FTLE": saddle_map, "Barbanis Fig. 3 window, LD": barbanis_map}


def timed(call):
    wall, cpu = time.perf_counter(), time.process_time()
    result = call()
    return result, time.perf_counter() - wall, time.process_time() - cpu


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, nargs="+", default=[100, 200], help="points per axis")
    parser.add_argument("--repeat", type=int, default=3, help="extractions per map (the smallest CPU taken)")
    args = parser.parse_args()
    rows = []
    for name, make in CASES.items():
        make(9)  # compile and load the engine: not the map's cost
        for n in args.points:
            ld_map, map_wall, map_cpu = timed(lambda: make(n))
            runs = [timed(lambda: ldpipe.structures(ld_map)) for _ in range(args.repeat)]
            found, extract_wall, extract_cpu = min(runs, key=lambda run: run[2])
            rows.append({"case": name, "points": n, "map_cpu": map_cpu, "map_wall": map_wall,
                         "extract_cpu": extract_cpu, "extract_wall": extract_wall, "curves": found.sizes["curve"],
                         "curve_points": found.sizes["point"], "ratio_cpu": extract_cpu / map_cpu})
    print("| case | grid | map CPU s | extraction CPU s | extraction / map | curves (points) |")
    print("| --- | ---: | ---: | ---: | ---: | ---: |")
    for row in rows:
        print(f"| {row['case']} | {row['points']}² | {row['map_cpu']:.2f} | {row['extract_cpu']:.3f} "
              f"| {100 * row['ratio_cpu']:.1f} % | {row['curves']} ({row['curve_points']}) |")
    out = Path(__file__).parent / "results" / f"structures_{time.strftime('%Y%m%dT%H%M%S')}.json"
    out.parent.mkdir(exist_ok=True)
    out.write_text(json.dumps({"machine": os.uname().nodename, "load": os.getloadavg(), "rows": rows}, indent=1))


if __name__ == "__main__":
    main()
