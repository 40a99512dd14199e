"""CPU seconds of one science job of the README's main command, run as the workflow runs it: the
stage function in a fresh process, on the inputs a finished run left in ``--results``.

Jobs: ``transport`` (results/transport/barbanis_2dof_bottom.nc), ``nhim3`` and ``nhim2`` (the
NHIM orbit validations results/nhim/orbits/barbanis_contopoulos_3dof.nc and barbanis_2dof.nc).
The output goes to ``--output`` (compare two runs' files with ``python -m ldpipe.io.filediff``).
Prints one line: the job, the process's CPU seconds (user + system, all threads) and wall seconds
from the import of the stage module to the written file. To compare two commits, run it with each
commit's ``src`` first on PYTHONPATH, in turns, and compare the whole processes' CPU seconds.

    PYTHONPATH=src .venv/bin/python benchmarks/science_jobs.py nhim3 --results results --output /tmp/a
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from ldpipe.config.loading import load_config
from ldpipe.config.parameters import parameters_from_config
from ldpipe.stages.plan import nhim_orbit_inputs

NHIM_STUDIES = {"nhim3": "barbanis_contopoulos_3dof", "nhim2": "barbanis_2dof"}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("job", choices=["transport", *NHIM_STUDIES])
    parser.add_argument("--results", type=Path, default=Path("results"), help="a finished run's results directory")
    parser.add_argument("--output", type=Path, required=True, help="directory for the job's file")
    parser.add_argument("--config", type=Path, default=Path(__file__).parent.parent / "config.yaml")
    parser.add_argument("--threads", type=int, default=2, help="as the workflow gives the job")
    args = parser.parse_args()
    config, results = load_config(args.config), args.results
    args.output.mkdir(parents=True, exist_ok=True)
    cpu, wall = time.process_time(), time.perf_counter()
    if args.job == "transport":
        from ldpipe.stages.transport import run_transport

        run_transport(**parameters_from_config(config, "transport", "barbanis_2dof_bottom"),
                      upo=results / "upo/barbanis_2dof_bottom_transport.nc",
                      equilibria=results / "barbanis_2dof/equilibria.nc", threads=args.threads,
                      output=args.output / "transport.nc")
    else:
        from ldpipe.stages.nhim_orbits import run_nhim_orbit_validation

        study = NHIM_STUDIES[args.job]
        inputs = nhim_orbit_inputs(config, study)
        run_nhim_orbit_validation(**parameters_from_config(config, "nhim_orbits", study),
                                  orbit_files=[results / f"upo/{family}.nc" for family in inputs["orbits"]],
                                  equilibria=results / f"{inputs['systems'][0]}/equilibria.nc",
                                  threads=args.threads, output=args.output / f"{args.job}.nc")
    print(f"{args.job}: cpu {time.process_time() - cpu:.2f} s, wall {time.perf_counter() - wall:.2f} s")


if __name__ == "__main__":
    main()
