"""Adaptive LD maps against full ones on the paper's panels: trajectories, wall time, error, throughput.

    .venv/bin/python benchmarks/adaptive_maps.py --maps fig4_k-7.0 --points 1500
    .venv/bin/python benchmarks/adaptive_maps.py --maps fig3_dE0.125 --points 385 --flattened 200

For each map of config.yaml (its ``refine:`` block, or --tolerance/--coarse-spacing), at its own
resolution or --points per axis: the full map (every allowed pixel) and the adaptive one, each
timed (wall and process CPU, after a small warm-up map so that compiling is excluded), and

* trajectories integrated, full (2 per allowed pixel) over adaptive (``refine_trajectories``; each
  direction's too);
* wall time, full over adaptive (--repeat runs each: min, median, max);
* error: the fraction of allowed pixels within the tolerance of the full map (|difference| over
  the full field's max - min), forward and backward, and the worst pixel; the figure's colour
  level (total LD, the figure's percentile limits [5, 99.9] of each map, viridis' 256 levels):
  the fraction of pixels within one level of the full map's figure;
* the NHIM stage's detection (variable-time maps): the grid point it picks on each map;
* whole-map throughput, allowed pixels per CPU-second, adaptive and full, and (2 DoF Barbanis
  only) the flattened solve_ivp approach (benchmarks/alternatives.py, RK45 at the map's rtol,
  fixed time tau: it cannot stop a trajectory at the region's exit) on a sample of the panel's
  pixels.

Writes benchmarks/results/adaptive_maps_<time>.json and prints a Markdown table.
"""

from __future__ import annotations

import argparse
import copy
import json
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from ldpipe.config import load_config  # noqa: E402
from ldpipe.figures.style import color_limits  # noqa: E402
from ldpipe.io.contracts import EQUILIBRIA  # noqa: E402
from ldpipe.io.datafile import open_stage_file  # noqa: E402
from ldpipe.stages import equilibria as equilibria_stage  # noqa: E402
from ldpipe.core.maps.assembly import compute_ld_map  # noqa: E402
from ldpipe.config.parameters import parameters_from_config  # noqa: E402

LEVELS = 256  # matplotlib's colormaps (viridis) have 256 colours
PERCENTILES = (5.0, 99.9)  # the figures' default color_percentiles


def timed(function, *args, **kwargs):
    wall, cpu = time.perf_counter(), time.process_time()
    result = function(*args, **kwargs)
    return result, time.perf_counter() - wall, time.process_time() - cpu


def colour_levels(dataset) -> np.ndarray:
    """The colour index (0..255) of each allowed pixel in the figure of the total LD."""
    allowed = dataset.allowed.values.astype(bool)
    total = (dataset.ld_forward.values + dataset.ld_backward.values)[allowed]
    low, high = color_limits(total, PERCENTILES)
    return np.clip(np.floor((total - low) / (high - low) * LEVELS), 0, LEVELS - 1).astype(int)


def errors(adaptive, full, tolerance: float) -> dict:
    allowed = full.allowed.values.astype(bool)
    out = {}
    for name in ("ld_forward", "ld_backward"):
        reference = full[name].values[allowed]
        relative = np.abs(adaptive[name].values[allowed] - reference) / (reference.max() - reference.min())
        out[name] = {"within_tolerance": float(np.mean(relative <= tolerance)), "worst": float(relative.max()),
                     "beyond_tolerance_pixels": int(np.sum(relative > tolerance))}
    levels = np.abs(colour_levels(adaptive) - colour_levels(full))
    out["colour"] = {"within_one_level": float(np.mean(levels <= 1)), "worst_levels": int(levels.max())}
    flags = [name for name in full.data_vars if full[name].dtype == bool]
    out["flags_differing"] = int(sum(np.sum(adaptive[n].values != full[n].values) for n in flags))
    return out


def flattened_throughput(parameters: dict, dataset, sample: int) -> dict:
    """Pixels per CPU-second of the flattened solve_ivp approach on ``sample`` pixels of the panel,
    forward and backward (the backward run: the reversed momenta, integrated forward)."""
    import alternatives as alt

    allowed = dataset.allowed.values.astype(bool)
    axes = list(dataset.ld_forward.dims)
    grids = np.meshgrid(dataset[axes[0]].values, dataset[axes[1]].values, indexing="ij")
    fixed = parameters["section"].get("fixed", {})
    solve = parameters["section"]["solve"]
    columns = {axes[0]: grids[0][allowed], axes[1]: grids[1][allowed], solve: dataset[solve].values[allowed]}
    rng = np.random.default_rng(0)
    chosen = rng.choice(int(allowed.sum()), size=min(sample, int(allowed.sum())), replace=False)
    states = np.stack([np.asarray(columns[c][chosen]) if c in columns else np.full(len(chosen), float(fixed[c]))
                       for c in ("x", "y", "px", "py")], axis=1)
    reversed_states = states * np.array([1.0, 1.0, -1.0, -1.0])
    rtol = parameters["integrator"]["rtol"]
    wall = cpu = 0.0
    for start in (states, reversed_states):
        _, w, c = timed(alt.scipy_flattened, start, parameters["tau"], parameters["p"], rtol=rtol)
        wall, cpu = wall + w, cpu + c
    return {"sample": len(chosen), "rtol": rtol, "cpu_s": cpu, "wall_s": wall, "pixels_per_cpu_s": len(chosen) / cpu}


def measure(config: dict, name: str, args, equilibria) -> dict:
    parameters = parameters_from_config(config, "ld", name)
    if args.points:
        for axis in parameters["section"]["axes"]:
            axis["points"] = args.points
    refine = dict(parameters.get("refine") or {"tolerance": 2e-3, "coarse_spacing": 16, "max_level": None})
    if args.tolerance:
        refine["tolerance"] = args.tolerance
    if args.coarse_spacing:
        refine["coarse_spacing"] = args.coarse_spacing
    adaptive_parameters = {**parameters, "refine": refine}
    full_parameters = {k: v for k, v in parameters.items() if k != "refine"}
    warm = copy.deepcopy(adaptive_parameters)
    for axis in warm["section"]["axes"]:
        axis["points"] = 17
    compute_ld_map(warm, equilibria, show_progress=False, threads=args.threads)  # compile, load the cache
    runs = {"full": [], "adaptive": []}
    for _ in range(args.repeat):
        full, wall, cpu = timed(compute_ld_map, full_parameters, equilibria, show_progress=False, threads=args.threads)
        runs["full"].append((wall, cpu))
        adaptive, wall, cpu = timed(compute_ld_map, adaptive_parameters, equilibria, show_progress=False,
                                    threads=args.threads)
        runs["adaptive"].append((wall, cpu))
    allowed = int(full.allowed.values.sum())
    trajectories = {"full": 2 * allowed, "adaptive": int(adaptive.attrs["refine_trajectories"])}
    record = {
        "map": name, "shape": list(full.ld_forward.shape), "allowed_pixels": allowed, "refine": refine,
        "trajectories": trajectories, "trajectory_ratio": trajectories["full"] / trajectories["adaptive"],
        "trajectories_per_direction": {label: int(adaptive.attrs[f"refine_trajectories_{label}"])
                                       for label in ("forward", "backward")},
        "computed_pixels": {label: int(adaptive[f"computed_{label}"].values.sum()) for label in ("forward", "backward")},
        "wall_s": {k: [w for w, _ in v] for k, v in runs.items()},
        "cpu_s": {k: [c for _, c in v] for k, v in runs.items()},
        "errors": errors(adaptive, full, refine["tolerance"]),
    }
    wall = {k: statistics.median(v) for k, v in record["wall_s"].items()}
    cpu = {k: statistics.median(v) for k, v in record["cpu_s"].items()}
    record["wall_ratio"] = wall["full"] / wall["adaptive"]
    record["wall_ratios_each_run"] = [f / a for f, a in zip(record["wall_s"]["full"], record["wall_s"]["adaptive"])]
    record["pixels_per_cpu_s"] = {k: allowed / cpu[k] for k in cpu}
    if parameters["time"] == "variable":  # the NHIM stage's detection, on both maps
        from ldpipe.core.nhim import detect_nhim_cell

        axes = tuple(full[a].values for a in full.ld_forward.dims)
        found = [detect_nhim_cell(d.ld_forward.values, d.ld_backward.values, d.allowed.values.astype(bool), axes)
                 for d in (full, adaptive)]
        record["nhim_detection"] = {"full": list(found[0].index), "adaptive": list(found[1].index),
                                    "equal": found[0].index == found[1].index}
    if args.flattened and parameters["system_name"] == "barbanis_2dof":
        record["flattened"] = flattened_throughput(parameters, full, args.flattened)
        record["throughput_vs_flattened"] = record["pixels_per_cpu_s"]["adaptive"] / record["flattened"]["pixels_per_cpu_s"]
    return record


def table(records: list[dict]) -> str:
    lines = ["| map | grid | tol, s | trajectories full / adaptive (ratio) | wall full / adaptive s (ratio) | "
             "within tol fwd, bwd | worst pixel | colour within 1 level | px per CPU-s adaptive / full | vs flattened |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in records:
        e = r["errors"]
        wall = {k: statistics.median(v) for k, v in r["wall_s"].items()}
        flattened = f"{r['throughput_vs_flattened']:.1f}x" if "throughput_vs_flattened" in r else "n/a"
        lines.append(
            f"| {r['map']} | {r['shape'][0]}x{r['shape'][1]} | {r['refine']['tolerance']:g}, {r['refine']['coarse_spacing']} | "
            f"{r['trajectories']['full']} / {r['trajectories']['adaptive']} ({r['trajectory_ratio']:.1f}x) | "
            f"{wall['full']:.1f} / {wall['adaptive']:.1f} ({r['wall_ratio']:.1f}x) | "
            f"{100 * e['ld_forward']['within_tolerance']:.3f} %, {100 * e['ld_backward']['within_tolerance']:.3f} % | "
            f"{max(e['ld_forward']['worst'], e['ld_backward']['worst']):.2g} | {100 * e['colour']['within_one_level']:.3f} % | "
            f"{r['pixels_per_cpu_s']['adaptive']:.0f} / {r['pixels_per_cpu_s']['full']:.0f} | {flattened} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--config", default=str(HERE.parent / "config.yaml"))
    parser.add_argument("--maps", nargs="+", required=True, help="map names under ld_maps")
    parser.add_argument("--points", type=int, help="points per axis (default: the map's own)")
    parser.add_argument("--tolerance", type=float, help="refine tolerance (default: the map's refine block, or 0.002)")
    parser.add_argument("--coarse-spacing", type=int, help="coarse spacing (default: the map's, or 16)")
    parser.add_argument("--repeat", type=int, default=1, help="runs of each map, for the spread")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--flattened", type=int, default=0, metavar="N",
                        help="also time the flattened solve_ivp approach on N pixels of each 2 DoF panel")
    args = parser.parse_args(argv)
    config = load_config(args.config)
    records = []
    equilibria = {}
    scratch = tempfile.mkdtemp(prefix="adaptive_maps_")
    for name in args.maps:
        system_name = config["ld_maps"][name]["system"]
        if system_name not in equilibria:  # as `ldpipe ld` gets it
            path = equilibria_stage.equilibria_file(config, system_name, None, Path(scratch))
            equilibria[system_name] = open_stage_file(path, stage=EQUILIBRIA)
        record = measure(config, name, args, equilibria[system_name])
        record["load_before"] = os.getloadavg()
        records.append(record)
        print(json.dumps(record), flush=True)
    out = HERE / "results" / f"adaptive_maps_{time.strftime('%Y%m%dT%H%M%S')}.json"
    out.parent.mkdir(exist_ok=True)
    out.write_text(json.dumps({"load_after": os.getloadavg(), "cpu_count": os.cpu_count(), "records": records}, indent=1))
    print(table(records))
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
