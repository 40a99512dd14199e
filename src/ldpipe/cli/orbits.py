"""The ``ldpipe upo``, ``ldpipe manifolds`` and ``ldpipe poincare`` subcommands.

Each names an entry of a configuration file (``--config``, then the family,
manifold set or section) and runs the same stage function as its Snakemake
rule. The inputs a stage reads (the equilibria file, the UPO file) are given
as options, or computed on the fly when left out.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

from ..config import load_config
from ..errors import ConfigError
from ..logs import log_to
from .options import equilibria_file
from ..config.parameters import parameters_from_config
from ..systems import is_vector_field

EXAMPLES = """\
  ldpipe upo --config config.yaml --family barbanis_2dof_bottom -o bottom.nc
  ldpipe manifolds --config config.yaml --manifold barbanis_2dof_bottom_dE2.25 --upo bottom.nc -o m.nc
  ldpipe poincare --config config.yaml --section fig3_dE0.125 -o p.nc
"""


def _entry(args: argparse.Namespace, table: str, name: str) -> dict:
    config = load_config(args.config)
    if name not in config[table]:
        raise ConfigError(f"{args.config}: no entry {name!r} under '{table}'; it declares {sorted(config[table])}")
    return config


def _run_upo(args: argparse.Namespace) -> None:
    from ..stages.upo import run_upo

    config = _entry(args, "periodic_orbits", args.family)
    parameters = parameters_from_config(config, "upo", args.family)
    with log_to(None), tempfile.TemporaryDirectory() as scratch:
        equilibria = equilibria_file(config, parameters["system_name"], args.equilibria, Path(scratch))
        run_upo(**parameters, equilibria=equilibria, output=args.output)


def _run_manifolds(args: argparse.Namespace) -> None:
    from ..stages.manifolds import run_manifolds, run_map_manifolds
    from ..stages.upo import run_upo

    config = _entry(args, "manifolds", args.manifold)
    parameters = parameters_from_config(config, "manifolds", args.manifold)
    with log_to(None), tempfile.TemporaryDirectory() as scratch:
        if "orbits" not in parameters:  # a discrete map's fixed points: read from its equilibria
            if args.upo is not None:
                raise ConfigError(f"--upo: manifolds.{args.manifold} is of the fixed points of the map "
                                  f"{parameters['system_name']!r}, which reads no family; give --equilibria or nothing")
            equilibria = equilibria_file(config, parameters["system_name"], args.equilibria, Path(scratch))
            run_map_manifolds(**parameters, equilibria=equilibria, output=args.output)
            return
        upo = args.upo
        if upo is None:
            family = parameters_from_config(config, "upo", parameters["orbits"])
            equilibria = equilibria_file(config, family["system_name"], args.equilibria, Path(scratch))
            upo = run_upo(**family, equilibria=equilibria, output=Path(scratch) / "upo.nc")
        run_manifolds(**parameters, upo=upo, threads=args.threads, output=args.output)


def _run_poincare(args: argparse.Namespace) -> None:
    from ..stages.poincare import run_poincare

    config = _entry(args, "poincare_sections", args.section)
    parameters = parameters_from_config(config, "poincare", args.section)
    with log_to(None), tempfile.TemporaryDirectory() as scratch:
        if is_vector_field(config["systems"][parameters["system_name"]]):
            equilibria = None  # no energy: a vector field's section needs no equilibria
        else:
            equilibria = equilibria_file(config, parameters["system_name"], args.equilibria, Path(scratch))
        run_poincare(**parameters, equilibria=equilibria, threads=args.threads, output=args.output)


def _stage_command(commands, name: str, *, help: str, description: str, epilog: str, entry: tuple[str, str],
                   inputs: dict[str, str], threads: bool, handler) -> None:
    """A subcommand that runs a stage on an entry of a configuration: ``--config``, the entry
    (``entry``: its option and what it names), the input files (by option), ``--threads`` if the
    stage uses them, and the output file."""
    parser = commands.add_parser(name, help=help, description=description, epilog=epilog,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--config", type=Path, required=True, metavar="FILE",
                        help="a YAML configuration (as config.yaml)")
    option, names = entry
    parser.add_argument(f"--{option}", required=True, metavar="NAME", help=names)
    for input_option, text in inputs.items():
        parser.add_argument(f"--{input_option}", type=Path, metavar="FILE", help=text)
    if threads:
        parser.add_argument("--threads", type=int, metavar="N", help="threads (default: all cores)")
    parser.add_argument("-o", "--output", type=Path, required=True, metavar="OUT.nc", help="netCDF file to write")
    parser.set_defaults(handler=handler)


def register(commands, epilog: str) -> None:
    """Add the three subcommands to argparse's ``commands`` (the object ``add_subparsers`` returned)."""
    epilog = epilog + EXAMPLES
    _stage_command(
        commands, "upo",
        help="a Lyapunov family of unstable periodic orbits at target energies, with Floquet multipliers",
        description=(
            "Differential correction from the linearization at an index-1 saddle, continuation of the "
            "Lyapunov family of one centre mode, and the orbit at each target energy of a "
            "'periodic_orbits' entry of the configuration, with its period, monodromy matrix, Floquet "
            "multipliers and closure error."
        ),
        epilog=epilog, entry=("family", "a family under 'periodic_orbits'"),
        inputs={"equilibria": "the system's equilibria file (default: computed now)"}, threads=False,
        handler=_run_upo,
    )
    _stage_command(
        commands, "manifolds",
        help="stable and unstable manifolds of a periodic orbit and their cuts by a section, or of a map's saddles",
        description=(
            "Globalize both branches of the stable and unstable manifolds of one orbit of a family (a "
            "'manifolds' entry of the configuration naming 'orbits') from the monodromy eigenvectors, and "
            "locate their crossings of the surface of section as ordered curves; or, for an entry naming a "
            "discrete map under 'system', grow those of the map's saddle fixed points from fundamental "
            "segments of their eigenvectors."
        ),
        epilog=epilog, entry=("manifold", "an entry under 'manifolds'"),
        inputs={"upo": "the family's file from `ldpipe upo` (default: computed now)",
                "equilibria": "the system's equilibria file, if the family is computed now (a map's: "
                              "default computed now)"},
        threads=True, handler=_run_manifolds,
    )
    _stage_command(
        commands, "poincare", help="a Poincaré surface of section from a grid of initial conditions",
        description=(
            "Integrate every allowed initial condition of a grid on the energy surface to the final time "
            "(a 'poincare_sections' entry of the configuration), record the crossings of the surface of "
            "section, and flag the trajectories that escape."
        ),
        epilog=epilog, entry=("section", "an entry under 'poincare_sections'"),
        inputs={"equilibria": "the system's equilibria file (default: computed now)"}, threads=True,
        handler=_run_poincare,
    )
