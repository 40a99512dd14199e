"""Fig. 3's LD maps at looser integrator settings against the configured dop853 rtol 1e-8.

    .venv/bin/python benchmarks/fig3_integrator.py --points 300 --rtols 1e-7 1e-6

Fig. 3 is a picture: a looser setting is good enough if its panels look the same. For each Fig. 3
map of config.yaml (fixed time, full maps) on a grid of --points per axis over the panel's own
range (every grid point is a pixel position of the full-resolution panel; a fixed-time LD pixel
does not depend on its neighbours, so this samples the full panel's pixels), the reference map at
the configured settings and one map per --rtols value (atol the same), each timed (process CPU,
after a warm-up map so that compiling is excluded), and

* the figure's colour level of every allowed pixel (total LD, the figure's percentile limits
  [5, 99.9] of each map, viridis' 256 levels; benchmarks/adaptive_maps.py's colour_levels):
  the fraction within one level of the reference, and the worst difference in levels;
* the LD error against the reference, |difference| over the reference field's max - min,
  forward and backward: median and worst pixel.

Writes benchmarks/results/fig3_integrator_<time>.json and prints a Markdown table.
"""

from __future__ import annotations

import argparse
import copy
import json
import os
import sys
import tempfile
import time
from pathlib import Path

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from adaptive_maps import colour_levels, timed  # noqa: E402
from ldpipe.config import load_config  # noqa: E402
from ldpipe.io.contracts import EQUILIBRIA  # noqa: E402
from ldpipe.io.datafile import open_stage_file  # noqa: E402
from ldpipe.stages import equilibria as equilibria_stage  # noqa: E402
from ldpipe.core.maps.assembly import compute_ld_map  # noqa: E402
from ldpipe.config.parameters import parameters_from_config  # noqa: E402

MAPS = ("fig3_dE-0.125", "fig3_dE0.000", "fig3_dE0.125")


def compare(candidate, reference) -> dict:
    allowed = reference.allowed.values.astype(bool)
    out = {"pixels": int(allowed.sum())}
    for name in ("ld_forward", "ld_backward"):
        values = reference[name].values[allowed]
        relative = np.abs(candidate[name].values[allowed] - values) / (values.max() - values.min())
        out[name] = {"median": float(np.median(relative)), "worst": float(relative.max())}
    levels = np.abs(colour_levels(candidate) - colour_levels(reference))
    out["colour"] = {"within_one_level": float(np.mean(levels <= 1)), "beyond_one_level_pixels": int(np.sum(levels > 1)),
                     "worst_levels": int(levels.max())}
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--config", default=str(HERE.parent / "config.yaml"))
    parser.add_argument("--maps", nargs="+", default=list(MAPS))
    parser.add_argument("--points", type=int, default=300, help="points per axis over the panel's range")
    parser.add_argument("--rtols", nargs="+", type=float, default=[1e-7, 1e-6])
    parser.add_argument("--threads", type=int, default=1)
    args = parser.parse_args(argv)
    config = load_config(args.config)
    scratch = tempfile.mkdtemp(prefix="fig3_integrator_")
    records = []
    for name in args.maps:
        parameters = parameters_from_config(config, "ld", name)
        for axis in parameters["section"]["axes"]:
            axis["points"] = args.points
        path = equilibria_stage.equilibria_file(config, parameters["system_name"], None, Path(scratch))
        equilibria = open_stage_file(path, stage=EQUILIBRIA)
        warm = copy.deepcopy(parameters)
        for axis in warm["section"]["axes"]:
            axis["points"] = 9
        compute_ld_map(warm, equilibria, show_progress=False, threads=args.threads)
        reference, _, reference_cpu = timed(compute_ld_map, parameters, equilibria, show_progress=False,
                                            threads=args.threads)
        integrator = parameters["integrator"]
        for rtol in args.rtols:
            loose = copy.deepcopy(parameters)
            loose["integrator"]["rtol"] = rtol
            candidate, _, cpu = timed(compute_ld_map, loose, equilibria, show_progress=False, threads=args.threads)
            record = {"map": name, "points": args.points, "scheme": integrator["scheme"], "reference_rtol": integrator["rtol"],
                      "rtol": rtol, "atol": integrator["atol"], "reference_cpu_s": reference_cpu, "cpu_s": cpu,
                      **compare(candidate, reference), "load": os.getloadavg()}
            records.append(record)
            print(json.dumps(record), flush=True)
    out = HERE / "results" / f"fig3_integrator_{time.strftime('%Y%m%dT%H%M%S')}.json"
    out.parent.mkdir(exist_ok=True)
    out.write_text(json.dumps({"cpu_count": os.cpu_count(), "records": records}, indent=1))
    print("| map | rtol | colour within 1 level | pixels beyond 1 level | worst levels | LD error median (fwd, bwd) "
          "| worst (fwd, bwd) | CPU s vs reference |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    for r in records:
        print(f"| {r['map']} | {r['rtol']:g} | {100 * r['colour']['within_one_level']:.3f} % | "
              f"{r['colour']['beyond_one_level_pixels']} of {r['pixels']} | {r['colour']['worst_levels']} | "
              f"{r['ld_forward']['median']:.1e}, {r['ld_backward']['median']:.1e} | "
              f"{r['ld_forward']['worst']:.1e}, {r['ld_backward']['worst']:.1e} | {r['cpu_s']:.1f} / {r['reference_cpu_s']:.1f} |")
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
