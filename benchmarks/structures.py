"""Extracting structures from a map against making the map: CPU of each, and their ratio.

    .venv/bin/python benchmarks/structures.py --points 100 200 --repeat 3

For each case (the linear saddle's LD map, tau 10, with its FTLE; Barbanis' Fig. 3 section in the
window of tests/structures/test_barbanis_manifolds.py, tau 12) at each number of points per axis:
the map computed once (process CPU and wall, after a small warm-up map so that compiling is
excluded), then ``ldpipe.structures`` on it --repeat times (the smallest CPU taken), and the
ratio extraction / map. The issue's goal is an extraction within 10 % of the map's own time.

With ``--numbacs`` (numbacs from the ``bench`` extra), ldpipe's extractors and numbacs' side by
side on the same data, one thread each (``NUMBA_NUM_THREADS=1``: times are per core), interleaved
``--repeat`` times (the smallest CPU of each taken):

- FTLE ridges of the steady double gyre (A = 0.1) over [0.5, 1.5] x [0.1, 0.9], tau 8, from one
  flow map (ldpipe's): ldpipe's ``ridge_curves`` on ldpipe's FTLE; numbacs' ``C_eig_2D``
  (Cauchy-Green eigenvectors, timed apart) and ``ftle_ridges`` on its FTLE, percentile 90 (the
  brightest tenth). Accuracy against the separatrix x = 1, the only ridge there (closed form:
  tests/structures/test_fsle_ridges.py): the ridge points' distance to it in cells, and the share
  of x = 1 (the rows the stencils reach) with a ridge point within one cell.
- Coherent vortices of the translating Gaussian vortex of tests/structures/test_lavd.py, from one
  LAVD field (ldpipe's, equal to its closed form to 1e-14): ldpipe's ``coherent_vortices`` and
  numbacs' ``rotcohvrt`` (radius 0.5 between maxima), both at convexity deficiency 0.01 and 100
  levels. Accuracy: the centre's distance from the origin in cells, and the boundary's radii
  against r* (where the vorticity is its mean) and against the closed-form circle of the level it
  was drawn at.

Prints Markdown tables and writes benchmarks/results/structures_<time>.json.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from pathlib import Path

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")
if any(flag in sys.argv for flag in ("--numbacs", "--only-numbacs")):
    os.environ.setdefault("NUMBA_NUM_THREADS", "1")  # numbacs' prange loops on one core, as ldpipe's numpy

import numpy as np  # noqa: E402

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


STEADY_GYRE = {"vector_field": {"x": "-pi*A*sin(pi*x)*cos(pi*y)", "y": "pi*A*cos(pi*x)*sin(pi*y)"},
               "coordinates": ["x", "y"], "parameters": {"A": 0.1}}
R, W0, U, T = 0.3, 1.0, 0.5, 4.0
DISTANCE = "((x - U*t)**2 + y**2)"
VORTEX = {"vector_field": {"x": f"U - k*(1 - exp(-{DISTANCE}/R**2))*y/{DISTANCE}",
                           "y": f"k*(1 - exp(-{DISTANCE}/R**2))*(x - U*t)/{DISTANCE}"},
          "coordinates": ["x", "y"], "parameters": {"U": U, "k": W0 * R**2 / 2, "R": R}}


def _fastest(calls: dict, repeat: int) -> dict:
    """Each of ``calls`` run ``repeat`` times, interleaved: (result, smallest CPU s, its wall s)."""
    best = {}
    for _ in range(repeat):
        for name, call in calls.items():
            result, wall, cpu = timed(call)
            if name not in best or cpu < best[name][1]:
                best[name] = (result, cpu, wall)
    return best


def _spread(points: np.ndarray, cell: float) -> dict:
    """The distance to x = 1 in cells of the ridge points within 2 cells of it (the separatrix's
    ridge), and how many lie further (other ridges: the gyres' shear)."""
    d = np.abs(points[:, 0] - 1.0) / cell
    near = d[d < 2.0]
    if not len(near):
        return {"median": math.inf, "p95": math.inf, "worst": math.inf, "elsewhere": len(d)}
    return {"median": float(np.median(near)), "p95": float(np.percentile(near, 95)), "worst": float(near.max()),
            "elsewhere": int(np.count_nonzero(d >= 2.0))}


def ridge_comparison(n: int, repeat: int) -> list[dict]:
    """FTLE ridges of the steady double gyre by ldpipe and numbacs on one flow map (module docstring)."""
    from numbacs.diagnostics import C_eig_2D, ftle_from_eig
    from numbacs.extraction.ridges import ftle_ridges

    from ldpipe.core.structures import ridge_curves

    cell = 1.0 / n
    system = ldpipe.system(name="steady_gyre", **STEADY_GYRE)
    section = ldpipe.section(x=(0.5 + 0.3 * cell, 1.5 + 0.3 * cell, n + 1),
                             y=(0.1 + 0.2 * cell, 0.9 + 0.2 * cell, round(0.8 * n) + 1))
    field = ldpipe.ld_map(system, section=section, tau=8.0, p=0.5, ftle=True,
                          integrator={"rtol": 1e-10, "atol": 1e-10})
    x, y = field.x.values, field.y.values
    flowmap = np.ascontiguousarray(np.stack([field.end_x_forward.values, field.end_y_forward.values], axis=-1))
    eigvals, eigvecs = C_eig_2D(flowmap, cell, cell)  # compile before timing
    ftle_ridges(ftle_from_eig(eigvals[:, :, 1], 8.0), np.ascontiguousarray(eigvecs[:, :, :, 1]), x, y, percentile=90)
    defined = field.ftle_defined_forward.values.astype(bool)
    best = _fastest({
        "ldpipe": lambda: [c.points for c in ridge_curves(field.ftle_forward.values, (x, y), defined)],
        "numbacs eig": lambda: C_eig_2D(flowmap, cell, cell),
    }, repeat)
    eigvals, eigvecs = best["numbacs eig"][0]
    numbacs_ftle = ftle_from_eig(eigvals[:, :, 1], 8.0)
    vectors = np.ascontiguousarray(eigvecs[:, :, :, 1])
    best.update(_fastest({"numbacs": lambda: ftle_ridges(numbacs_ftle, vectors, x, y, percentile=90)}, repeat))
    along = np.column_stack([np.ones(400), np.linspace(y[1], y[-2], 400)])
    rows = []
    for name in ("ldpipe", "numbacs"):
        curves = [np.asarray(c, dtype=float).reshape(-1, 2) for c in best[name][0]]
        points = np.concatenate(curves) if curves else np.zeros((0, 2))
        nearest = np.array([np.min(np.hypot(*(points - p).T)) for p in along]) / cell if len(points) else np.inf
        rows.append({"case": "steady gyre FTLE ridge, x = 1", "tool": name, "points": n, "cpu": best[name][1],
                     "cpu_eig": best["numbacs eig"][1] if name == "numbacs" else 0.0, "curves": len(curves),
                     "curve_points": len(points), **{f"to_line_{k}": v for k, v in _spread(points, cell).items()},
                     "covered": float(np.mean(nearest < 1.0))})
    return rows


def vortex_comparison(n: int, repeat: int) -> list[dict]:
    """Coherent vortices of the translating Gaussian vortex by ldpipe and numbacs on one LAVD field."""
    from numbacs.extraction.elliptic import rotcohvrt

    from ldpipe.core.structures.lavd import coherent_vortices

    system = ldpipe.system(name="translating_gaussian_vortex", **VORTEX)
    # no grid point on the centre, where the formula is 0/0
    section = ldpipe.section(x=(-1.0, 1.0 + 1.3 / (n - 1), n), y=(-1.0 + 0.4 / (n - 1), 1.0, n))
    result = ldpipe.lavd(system, section=section, duration=T, interval=0.1, integrator={"rtol": 1e-10, "atol": 1e-10})
    x, y = result.x.values, result.y.values
    lavd = np.ascontiguousarray(result.lavd.values)
    settings = {"levels": 100, "convexity_deficiency": 0.01, "min_points": 8}
    rotcohvrt(lavd, x, y, 0.5, convexity_deficiency=0.01, nlevs=100)  # compile before timing
    best = _fastest({
        "ldpipe": lambda: [(v["centre"], v["boundary"], v["level"])
                           for v in coherent_vortices(lavd, result.lavd_defined.values, (x, y), settings)],
        "numbacs": lambda: rotcohvrt(lavd, x, y, 0.5, convexity_deficiency=0.01, nlevs=100),
    }, repeat)
    X, Y = np.meshgrid(x, y, indexing="ij")
    mean = float(np.mean(W0 * np.exp(-(X**2 + Y**2) / R**2)))
    r_zero = R * math.sqrt(math.log(W0 / mean))
    cell = float(x[1] - x[0])
    rows = []
    for name in ("ldpipe", "numbacs"):
        found = best[name][0]
        row = {"case": "Gaussian vortex LAVD eddy", "tool": name, "points": n, "cpu": best[name][1], "cpu_eig": 0.0,
               "vortices": len(found)}
        if found:
            if name == "ldpipe":
                centre, boundary, level = np.asarray(found[0][0]), found[0][1], found[0][2]
            else:
                boundary, centre = found[0][0], np.asarray(found[0][1])
                # numbacs keeps the contour's convex hull (vertices of the contour, on grid edges), not
                # its level: the field's linear interpolant there is the level
                from scipy.interpolate import RegularGridInterpolator

                level = float(np.median(RegularGridInterpolator((x, y), lavd)(np.asarray(boundary))))
            radius = np.hypot(*(np.asarray(boundary) - centre).T)
            r_level = R * math.sqrt(max(-math.log(level / (T * W0) + mean / W0), 0.0))
            row.update({"centre_cells": float(np.hypot(*centre)) / cell, "boundary_points": len(boundary),
                        "r_min": float(radius.min()), "r_max": float(radius.max()), "r_level": r_level,
                        "r_zero": r_zero, "to_level_circle_cells": float(np.max(np.abs(radius - r_level))) / cell})
        rows.append(row)
    return rows


def numbacs_tables(rows: list[dict]) -> None:
    print("\n| case | grid | tool | extraction CPU s | curves (points) | separatrix ridge to x = 1, cells: median / "
          "p95 / worst | points elsewhere | x = 1 covered |")
    print("| --- | ---: | --- | ---: | ---: | ---: | ---: | ---: |")
    for row in (r for r in rows if "covered" in r):
        eig = f" (+ {row['cpu_eig']:.3f} eigenvectors)" if row["cpu_eig"] else ""
        print(f"| {row['case']} | {row['points']} | {row['tool']} | {row['cpu']:.4f}{eig} | {row['curves']} "
              f"({row['curve_points']}) | {row['to_line_median']:.3f} / {row['to_line_p95']:.3f} / "
              f"{row['to_line_worst']:.3f} | {row['to_line_elsewhere']} | {100 * row['covered']:.0f} % |")
    print("\n| case | grid | tool | extraction CPU s | vortices | centre, cells | boundary radius | r* | level circle | "
          "to it, cells |")
    print("| --- | ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    for row in (r for r in rows if "vortices" in r):
        if not row["vortices"]:
            print(f"| {row['case']} | {row['points']}² | {row['tool']} | {row['cpu']:.4f} | 0 | | | | | |")
            continue
        print(f"| {row['case']} | {row['points']}² | {row['tool']} | {row['cpu']:.4f} | {row['vortices']} | "
              f"{row['centre_cells']:.3f} | {row['r_min']:.4f}-{row['r_max']:.4f} | {row['r_zero']:.4f} | "
              f"{row['r_level']:.4f} | {row['to_level_circle_cells']:.2f} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, nargs="+", default=[100, 200], help="points per axis")
    parser.add_argument("--repeat", type=int, default=3, help="extractions per map (the smallest CPU taken)")
    parser.add_argument("--numbacs", action="store_true", help="compare with numbacs' extractors (module docstring)")
    parser.add_argument("--only-numbacs", action="store_true", help="the comparison with numbacs alone")
    args = parser.parse_args()
    if args.only_numbacs:
        rows = [row for n in args.points for row in ridge_comparison(n, args.repeat) + vortex_comparison(n, args.repeat)]
        numbacs_tables(rows)
        out = Path(__file__).parent / "results" / f"structures_numbacs_{time.strftime('%Y%m%dT%H%M%S')}.json"
        out.parent.mkdir(exist_ok=True)
        out.write_text(json.dumps({"machine": os.uname().nodename, "load": os.getloadavg(), "rows": rows}, indent=1))
        return
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
    if args.numbacs:
        compared = [row for n in args.points for row in ridge_comparison(n, args.repeat) + vortex_comparison(n, args.repeat)]
        numbacs_tables(compared)
        rows += compared
    out = Path(__file__).parent / "results" / f"structures_{time.strftime('%Y%m%dT%H%M%S')}.json"
    out.parent.mkdir(exist_ok=True)
    out.write_text(json.dumps({"machine": os.uname().nodename, "load": os.getloadavg(), "rows": rows}, indent=1))


if __name__ == "__main__":
    main()
