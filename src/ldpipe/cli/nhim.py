"""The ``ldpipe nhim`` subcommand: NHIM points of variable-time LD maps, from the command line.

It runs the same function as the Snakemake rule ``nhim_study`` on LD files given as arguments
(as ``ldpipe ld`` writes them), with the refinement settings of a configuration's ``nhim:``
section or of the options, and, with ``--upo``, compares every point with the crossing of that
family's periodic orbit (2 DoF) and fails (exit status 2) beyond ``--validate``.
"""

from __future__ import annotations

import argparse
import dataclasses
import tempfile
from pathlib import Path

from ..config import load_config
from ..logs import log_to
from .options import finite_float

EXAMPLES = """\
  ldpipe nhim results/ld/fig4_k-7.0.nc -o k70.nc --upo results/upo/barbanis_2dof_bottom.nc --validate 1e-7
  ldpipe nhim results/ld/fig5_xpx.nc results/ld/fig5_ypy.nc --config config.yaml -o fig5.nc --csv fig5.csv
"""


def _refinement(args: argparse.Namespace) -> dict:
    from ..core.nhim import RefinementSettings

    if args.config is not None:
        refinement = dict(load_config(args.config)["nhim"]["refinement"])
    else:
        refinement = {**dataclasses.asdict(RefinementSettings()), "zoom": True}
    for name in ("tolerance", "rtol", "atol", "max_time"):
        value = getattr(args, name)
        if value is not None:
            refinement[name] = value
    if args.tolerance is not None and refinement["bisection_precision"] >= args.tolerance:
        refinement["bisection_precision"] = args.tolerance / 20  # the default's ratio
    if args.no_zoom:
        refinement["zoom"] = False
    return refinement


def _run_nhim(args: argparse.Namespace) -> None:
    from ..stages.nhim import run_nhim_study
    from ..stages.nhim_validation import run_nhim_validation

    refinement = _refinement(args)
    references = [Path(args.upo).stem] if args.upo else []
    with log_to(None):
        path = run_nhim_study(
            study=args.study, refinement=refinement, maps=list(args.maps), references=references,
            reference_files=[args.upo] if args.upo else [], threads=args.threads, output=args.output,
        )
        if args.validate is not None or args.csv is not None:
            with tempfile.TemporaryDirectory() as scratch:
                csv_path = args.csv if args.csv is not None else Path(scratch) / "table.csv"
                run_nhim_validation(
                    studies=[path], csv_output=csv_path, markdown_output=Path(csv_path).with_suffix(".md"),
                    tolerance=args.validate if args.validate is not None else float("inf"),
                    residence_ratio=args.residence_ratio,
                )


def register(commands, epilog: str) -> None:
    """Add the ``nhim`` subcommand to argparse's ``commands`` (the object ``add_subparsers`` returned)."""
    nhim = commands.add_parser(
        "nhim", help="detect and refine NHIM points on variable-time LD maps, optionally against a periodic orbit",
        description=(
            "On each LD map, pick the grid point where the forward and backward LD ridges meet (largest "
            "min(F/F_ridge, B/B_ridge), each LD over the median of its per-row maxima), refine it below the grid spacing by bisection on trajectory fates (and by "
            "zoomed LD re-gridding), and write the detected and refined points with their LD values, exit times, "
            "residence evidence and refinement cost."
        ),
        epilog=epilog + EXAMPLES, formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    nhim.add_argument("maps", nargs="+", type=Path, metavar="LD.nc", help="variable-time LD map files (`ldpipe ld`)")
    nhim.add_argument("-o", "--output", type=Path, required=True, metavar="OUT.nc", help="netCDF file to write")
    nhim.add_argument("--config", type=Path, metavar="FILE", help="take the refinement settings from its nhim: section")
    nhim.add_argument("--upo", type=Path, metavar="FILE",
                      help="a UPO family file (`ldpipe upo`) with an orbit at the maps' energy: the reference")
    nhim.add_argument("--validate", type=finite_float, metavar="TOL",
                      help="fail (exit status 2) if a refined point is farther than TOL from the orbit's crossing")
    nhim.add_argument("--residence-ratio", type=finite_float, default=2.0, metavar="R",
                      help="with --validate: a refined point must stay R times longer than its neighbours (default 2)")
    nhim.add_argument("--csv", type=Path, metavar="FILE", help="also write the table as CSV (and Markdown beside it)")
    nhim.add_argument("--study", default="cli", help="name recorded in the file (default 'cli')")
    nhim.add_argument("--tolerance", type=finite_float, help="target accuracy of refined points (default 1e-8)")
    nhim.add_argument("--rtol", type=finite_float, help="DOP853 rtol of the refinement (default 1e-12)")
    nhim.add_argument("--atol", type=finite_float, help="DOP853 atol of the refinement (default 1e-12)")
    nhim.add_argument("--max-time", type=finite_float, help="longest refinement trajectory (default 100)")
    nhim.add_argument("--no-zoom", action="store_true", help="skip the zoomed-LD cross-check")
    nhim.add_argument("--threads", type=int, metavar="N", help="threads (default: all cores)")
    nhim.set_defaults(handler=_run_nhim)
