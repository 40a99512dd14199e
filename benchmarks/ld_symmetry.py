"""One tile of a Fig. 3 map with its backward fields mirrored (ldpipe.core.maps.symmetry) against integrated.

    .venv/bin/python benchmarks/ld_symmetry.py --map fig3_dE0.125 --points 1500 --tile 1 --rounds 2

Times (process CPU, one engine thread unless --threads) the tile ``--tile`` of ``--tiles`` of the
map at ``--points`` per axis in interleaved rounds of three variants: ``mirrored``
(backward_by_symmetry: auto, which mirrors where the grid is mirror-symmetric to its tolerance),
``integrated`` (backward_by_symmetry: false, at the same points) and, with --baseline-points, the
map at that many points integrated both ways (config.yaml's grid). After a warm-up tile (compiling
excluded). Then compares the mirrored tile with the integrated one: forward fields bit for bit, the
backward fields as the image of the forward ones, and the mirrored backward LD against the
integrated backward LD: max |difference|, over the field's max - min, and the figure's colour
levels (benchmarks/fig3_integrator.py's compare). Writes benchmarks/results/ld_symmetry_<time>.json.
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

from adaptive_maps import timed  # noqa: E402
from fig3_integrator import compare  # noqa: E402
from ldpipe.config import load_config  # noqa: E402
from ldpipe.io.contracts import EQUILIBRIA  # noqa: E402
from ldpipe.io.datafile import open_stage_file  # noqa: E402
from ldpipe.stages import equilibria as equilibria_stage  # noqa: E402
from ldpipe.core.maps.assembly import compute_ld_map  # noqa: E402
from ldpipe.config.parameters import parameters_from_config  # noqa: E402


def with_points(parameters: dict, points: int, setting) -> dict:
    changed = copy.deepcopy(parameters)
    for axis in changed["section"]["axes"]:
        axis["points"] = points
    changed["backward_by_symmetry"] = setting
    return changed


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--config", default=str(HERE.parent / "config.yaml"))
    parser.add_argument("--map", default="fig3_dE0.125")
    parser.add_argument("--points", type=int, default=1500, help="points per axis (Fig. 3: 1500)")
    parser.add_argument("--baseline-points", type=int, default=None, help="also time the map at this many points")
    parser.add_argument("--tile", type=int, default=1)
    parser.add_argument("--tiles", type=int, default=4)
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--threads", type=int, default=1)
    args = parser.parse_args(argv)
    config = load_config(args.config)
    parameters = parameters_from_config(config, "ld", args.map)
    path = equilibria_stage.equilibria_file(config, parameters["system_name"], None, Path(tempfile.mkdtemp()))
    equilibria = open_stage_file(path, stage=EQUILIBRIA)
    variants = {"mirrored": with_points(parameters, args.points, "auto"),
                "integrated": with_points(parameters, args.points, False)}
    if args.baseline_points:
        variants[f"integrated_{args.baseline_points}"] = with_points(parameters, args.baseline_points, False)

    def run(variant):
        return timed(compute_ld_map, variants[variant], equilibria, tile=args.tile, tiles=args.tiles,
                     show_progress=False, threads=args.threads)

    compute_ld_map(with_points(parameters, 9, "auto"), equilibria, show_progress=False, threads=args.threads)
    load_before = os.getloadavg()
    cpu: dict[str, list[float]] = {name: [] for name in variants}
    results = {}
    for round_ in range(args.rounds):
        order = list(variants) if round_ % 2 == 0 else list(variants)[::-1]
        for name in order:
            results[name], _, seconds = run(name)
            cpu[name].append(seconds)
            print(f"round {round_}: {name} {seconds:.1f} CPU s", flush=True)
    load_after = os.getloadavg()
    mirrored, integrated = results["mirrored"], results["integrated"]
    assert mirrored.attrs.get("reversing_symmetry"), "the map was not mirrored: is its grid mirror-symmetric?"
    forward = [name for name in integrated.data_vars
               if not name.endswith("_backward") and name != "energy_error"]
    allowed = integrated.allowed.values
    differences = {}
    for name in ("ld_backward", "exit_time_backward", "steps_backward", "escaped_backward", "failed_backward"):
        # the allowed pixels: elsewhere the fields are missing (NaN) in both
        a, b = mirrored[name].values.astype(float)[allowed], integrated[name].values.astype(float)[allowed]
        differences[name] = {"max_abs": float(np.max(np.abs(a - b))), "pixels_differing": int(np.sum(a != b))}
    ld = integrated.ld_backward.values[allowed]
    differences["ld_backward"]["max_over_range"] = differences["ld_backward"]["max_abs"] / float(ld.max() - ld.min())
    differences["ld_backward"]["max_relative"] = float(np.max(
        np.abs(mirrored.ld_backward.values[allowed] - ld) / ld))
    record = {
        "map": args.map, "points": args.points, "tile": args.tile, "tiles": args.tiles, "threads": args.threads,
        "cpu_s": cpu, "load_before": load_before, "load_after": load_after, "cpu_count": os.cpu_count(),
        "forward_bit_identical": all(np.array_equal(mirrored[n].values, integrated[n].values) for n in forward),
        "backward_is_mirrored_forward": all(
            np.array_equal(mirrored[f"{n}_backward"].values, mirrored[f"{n}_forward"].values[:, ::-1])
            for n in ("ld", "exit_time", "escaped", "left_region", "failed", "steps")),
        "backward_vs_integrated": differences,
        "figure": compare(mirrored, integrated),
    }
    print(json.dumps(record, indent=1))
    out = HERE / "results" / f"ld_symmetry_{time.strftime('%Y%m%dT%H%M%S')}.json"
    out.parent.mkdir(exist_ok=True)
    out.write_text(json.dumps(record, indent=1))
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
