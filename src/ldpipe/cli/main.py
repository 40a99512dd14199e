"""The ``ldpipe`` command: one subcommand per pipeline stage.

The subcommands call the same stage functions as the Snakemake rules, so a
stage can be run and debugged on its own.
"""

from __future__ import annotations

import argparse
import copy
import sys
import tempfile
from pathlib import Path

from .._version import __version__
from ..config import load_config, validate_config
from ..core.maps.grid import DIRECTIONS
from ..engine import SCHEMES, DescriptorSettings, IntegratorSettings, StoppingRules
from ..engine.integrands import ARCLENGTH
from ..errors import ConfigError, LdpipeError
from ..io.atomic import check_writable
from ..logs import log_to
from ..systems import BUILTINS, is_discrete_map, is_vector_field
from ..text import short_number
from . import nhim, orbits
from .noise import add_noise_options, named_by_option, noise_options, with_noise
from .options import equilibria_file, finite_float, number

EPILOG = """\
examples:
  ldpipe equilibria --system barbanis_2dof -o barbanis_2dof_equilibria.nc
  ldpipe equilibria --system barbanis_2dof --parameter delta=-0.12 -o delta012.nc
  ldpipe equilibria --config config.yaml --system barbanis_contopoulos_3dof -o bc3.nc
  ldpipe ld --config config.yaml --map fig4_k-7.0 -o fig4a.nc
  ldpipe ld --system barbanis_2dof --axis x=4.8:6.0:300 --axis px=-0.6:0.6:300 \\
      --fixed y=-7.0 --solve py --excess-energy 0.125 --tau 50 --p 0.5 \\
      --time variable --region x=4.5:6.5 --region y=-8.5:-5.5 --saddle-near 5.5,-7 -o slice.nc
  ldpipe ld --config config.yaml --map fig4_k-7.0 --refine-tolerance 0.002 --coarse-spacing 16 -o fig4a.nc
  ldpipe ld --config config.yaml --map fig4_k-7.0 --directions forward -o fig4a_forward.nc
  ldpipe ld --config flows.yaml --system duffing --axis x=-1.5:1.5:201 --axis y=-1:1:201 --tau 10 \\
      --p 0.5 --diffusivity 0.001 --members 16 --seed 0 -o duffing_noisy.nc
"""


#: The defaults of ``ldpipe ld``: the engine's (as the config schema's).
INTEGRATOR, DESCRIPTOR, STOPPING = IntegratorSettings(), DescriptorSettings(), StoppingRules()


def _key_value(text: str) -> tuple[str, str]:
    name, sep, value = text.partition("=")
    if not sep or not name:
        raise argparse.ArgumentTypeError(f"expected NAME=VALUE, got {text!r}")
    return name.strip(), value.strip()


def _system_config(args: argparse.Namespace) -> dict:
    """A validated config holding the requested system, with command-line overrides applied."""
    if args.config is not None:
        config = copy.deepcopy(load_config(args.config))
        if args.system not in config["systems"]:
            raise ConfigError(
                f"{args.config}: no system {args.system!r} under 'systems'; it declares {sorted(config['systems'])}"
            )
    elif args.system in BUILTINS:
        config = {"systems": {args.system: {"builtin": args.system}}}
    else:
        raise ConfigError(
            f"--system {args.system!r} is not a built-in system ({', '.join(sorted(BUILTINS))}); "
            "give --config FILE to use a system declared there"
        )
    spec = config["systems"][args.system]
    for name, value in args.parameter:
        spec.setdefault("parameters", {})[name] = number(value, f"--parameter {name}")
    for coordinate, interval in getattr(args, "box", []):
        low, sep, high = interval.partition(":")
        if not sep:
            raise ConfigError(f"--box {coordinate}: expected LOW:HIGH, got {interval!r}")
        spec.setdefault("equilibria", {}).setdefault("box", {})[coordinate] = [
            number(low, f"--box {coordinate}"), number(high, f"--box {coordinate}")
        ]
    return validate_config(config)


def _run_equilibria(args: argparse.Namespace) -> None:
    from ..stages.equilibria import run_equilibria
    from ..config.parameters import parameters_from_config

    config = _system_config(args)
    with log_to(None):
        run_equilibria(**parameters_from_config(config, "equilibria", args.system), output=args.output)


def _map_from_options(args: argparse.Namespace, vector_field: bool = False, discrete: bool = False) -> dict:
    """An ld_maps entry built from the command-line options (validated later with the schema);
    ``vector_field``: the system is one (no energy, nothing solved, a start time); ``discrete``:
    it is a discrete map (iterations, no time)."""
    if len(args.axis) != 2:
        raise ConfigError(f"--axis: give exactly two, NAME=LOW:HIGH:POINTS each; got {len(args.axis)}")
    axes = []
    for name, text in args.axis:
        parts = text.split(":")
        if len(parts) != 3:
            raise ConfigError(f"--axis {name}: expected LOW:HIGH:POINTS, got {text!r}")
        points = number(parts[2], f"--axis {name} points")
        if points != int(points):
            raise ConfigError(f"--axis {name}: POINTS must be a whole number, got {parts[2]!r}")
        axes.append({"name": name, "range": [number(parts[0], f"--axis {name}"), number(parts[1], f"--axis {name}")],
                     "points": int(points)})
    spec = {
        "system": args.system,
        "section": {
            "axes": axes,
            "fixed": {name: value if value == "saddle" else number(value, f"--fixed {name}") for name, value in args.fixed},
        },
        "tau": args.tau,
        "p": ARCLENGTH if args.p == ARCLENGTH else number(args.p, "--p"),
        "time": args.time,
        **({"quad_nodes": args.quad_nodes} if args.quad_nodes is not None else {}),
        "integrator": {"scheme": args.scheme, "rtol": args.rtol, "atol": args.atol, "dt": args.dt,
                       "taylor_order": args.taylor_order, "escape_radius": args.escape_radius},
    }
    if args.region:
        spec["region"] = {}
        for coordinate, interval in args.region:
            low, sep, high = interval.partition(":")
            if not sep:
                raise ConfigError(f"--region {coordinate}: expected LOW:HIGH, got {interval!r}")
            spec["region"][coordinate] = [number(low, f"--region {coordinate}"), number(high, f"--region {coordinate}")]
    if args.saddle_near:
        spec["saddle_near"] = [number(v, "--saddle-near") for v in args.saddle_near.split(",")]
    if discrete:  # a map: iterations, no time, energy or integrator but the escape radius
        given = [option for option, value in (("--solve", args.solve), ("--energy", args.energy),
                                              ("--excess-energy", args.excess_energy), ("--root", args.root),
                                              ("--search", args.search), ("--t0", args.t0),
                                              ("--quad-nodes", args.quad_nodes), ("--saddle-near", args.saddle_near))
                 if value is not None]
        given += [option for option, value, default in (("--tau", args.tau, STOPPING.tau), ("--time", args.time, "fixed"),
                                                        ("--scheme", args.scheme, INTEGRATOR.scheme))
                  if value != default] + (["--region"] if args.region else [])
        if given:
            raise ConfigError(f"{given[0]}: system {args.system!r} is a discrete map, iterated: its map has two --axis, "
                              "every other coordinate --fixed, --iterations, --p and --escape-radius")
        if args.iterations is None:
            raise ConfigError(f"--iterations: system {args.system!r} is a discrete map; give the N of its LD (the sum "
                              "over n from -N to N-1)")
        return {"system": args.system, "section": spec["section"], "iterations": args.iterations, "p": spec["p"],
                "integrator": {"escape_radius": args.escape_radius}}
    if args.iterations is not None:
        raise ConfigError(f"--iterations: system {args.system!r} is a flow in time; give --tau")
    if vector_field:  # no energy, nothing solved; a start time
        given = [option for option, value in (("--solve", args.solve), ("--energy", args.energy),
                                              ("--excess-energy", args.excess_energy), ("--root", args.root),
                                              ("--search", args.search)) if value is not None]
        if given:
            raise ConfigError(f"{given[0]}: system {args.system!r} is a vector field with no energy; its map has two "
                              "--axis, every other state variable --fixed, and optionally --t0")
        if args.t0 is not None:
            spec["t0"] = args.t0
        return spec
    if args.t0 is not None:
        raise ConfigError(f"--t0: system {args.system!r} is autonomous (a Hamiltonian); a start time changes nothing")
    if args.solve is None:
        raise ConfigError("--solve: a map of a Hamiltonian system needs the coordinate solved from the energy")
    if (args.energy is None) == (args.excess_energy is None):
        raise ConfigError("give exactly one of --energy (total) or --excess-energy (over the saddle's E_c)")
    spec["section"].update({"solve": args.solve, **_solve_options(args)})
    spec["energy"] = {"total": args.energy} if args.energy is not None else {"excess": args.excess_energy}
    return spec


def _solve_options(args: argparse.Namespace) -> dict:
    """How the solved coordinate is chosen: a momentum's --sign, or a position's --root and --search."""
    if args.root is None and args.search is None:
        return {"sign": args.sign}
    if args.sign != 1:
        raise ConfigError("--sign is for a solved momentum; a solved position takes --root (and --search)")
    options = {}
    if args.root is not None:
        rule, sep, value = args.root.partition(":")
        if rule == "nearest" and sep:
            options["root"] = {"nearest": number(value, "--root nearest")}
        elif rule in ("largest", "smallest") and not sep:
            options["root"] = rule
        else:
            raise ConfigError(f"--root: expected largest, smallest or nearest:VALUE, got {args.root!r}")
    if args.search is not None:
        low, sep, high = args.search.partition(":")
        if not sep:
            raise ConfigError(f"--search: expected LOW:HIGH, got {args.search!r}")
        options["search"] = [number(low, "--search"), number(high, "--search")]
    return options


def _run_ld(args: argparse.Namespace) -> None:
    from ..stages.ld import run_ld_map
    from ..stages.plan import ld_map_tiles
    from ..config.parameters import parameters_from_config

    noise = noise_options(args)
    map_name = args.map if args.map is not None else "cli"
    with named_by_option(map_name, noise, matrix=bool(args.diffusion_row)):
        if args.map is not None:
            if args.config is None:
                raise ConfigError("--map NAME needs --config FILE, the configuration that declares it")
            config = load_config(args.config)
            if args.map not in config["ld_maps"]:
                raise ConfigError(f"{args.config}: no map {args.map!r} under 'ld_maps'; it declares "
                                  f"{sorted(config['ld_maps'])}")
        else:
            if args.system is None:
                raise ConfigError("give --config FILE --map NAME, or describe the map with --system, --axis, --solve, ...")
            config = copy.deepcopy(load_config(args.config)) if args.config is not None else {"systems": {}}
            if args.system not in config["systems"]:
                if args.system not in BUILTINS:
                    raise ConfigError(f"--system {args.system!r} is neither a built-in ({', '.join(sorted(BUILTINS))}) "
                                      "nor in --config")
                config["systems"][args.system] = {"builtin": args.system}
            vector_field = is_vector_field(config["systems"][args.system])
            config.setdefault("ld_maps", {})["cli"] = _map_from_options(args, vector_field,
                                                                        is_discrete_map(config["systems"][args.system]))
            if noise:
                with_noise(config["ld_maps"]["cli"], noise)
            config = validate_config(config)
            args.map = "cli"
        if args.refine_tolerance is not None or args.coarse_spacing is not None or args.directions is not None or (
                noise and map_name != "cli"):
            config = copy.deepcopy(config)
            if args.refine_tolerance is not None or args.coarse_spacing is not None:
                refine = config["ld_maps"][args.map].setdefault("refine", {})
                for key, value in (("tolerance", args.refine_tolerance), ("coarse_spacing", args.coarse_spacing)):
                    if value is not None:
                        refine[key] = value
            if args.directions is not None:
                config["ld_maps"][args.map]["directions"] = args.directions
            if noise:
                with_noise(config["ld_maps"][args.map], noise)
            config = validate_config(config)
        parameters = parameters_from_config(config, "ld", args.map)
        with log_to(None), tempfile.TemporaryDirectory() as scratch:
            if is_vector_field(config["systems"][parameters["system_name"]]):
                equilibria = None  # a vector field's map has no energy and no saddle
            else:
                equilibria = equilibria_file(config, parameters["system_name"], args.equilibria, Path(scratch))
            run_ld_map(**parameters, equilibria=equilibria, tiles=ld_map_tiles(config, args.map), threads=args.threads,
                       show_progress=not args.quiet, output=args.output)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="ldpipe",
        description=(
            "Phase-space structures of index-1 saddles (normally hyperbolic invariant manifolds, "
            "periodic orbits, their manifolds) from Lagrangian descriptors. Each subcommand runs "
            "one stage of the pipeline and writes a netCDF file; `snakemake` chains them all."
        ),
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"ldpipe {__version__}")
    commands = parser.add_subparsers(dest="command", metavar="STAGE", required=True)

    equilibria = commands.add_parser(
        "equilibria",
        help="equilibria of a system in a box, with eigenvalues, eigenvectors and type",
        description=(
            "Find every equilibrium of the system in a box (closed forms for the built-ins, "
            "cross-checked by a multi-start root search; numeric for formula systems), and "
            "write its energy, the Jacobian's eigenvalues and eigenvectors, its type (minimum, "
            "index-1 saddle, ...) and the critical energy of each index-1 saddle."
        ),
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    equilibria.add_argument(
        "--system", required=True, metavar="NAME",
        help=f"a built-in system ({', '.join(sorted(BUILTINS))}) or a system declared in --config",
    )
    equilibria.add_argument("--config", type=Path, metavar="FILE", help="a YAML configuration (as config.yaml)")
    equilibria.add_argument(
        "--parameter", type=_key_value, action="append", default=[], metavar="NAME=VALUE",
        help="override a parameter of the system (repeatable), e.g. delta=-0.12",
    )
    equilibria.add_argument(
        "--box", type=_key_value, action="append", default=[], metavar="COORD=LOW:HIGH",
        help="search interval of one coordinate (repeatable); default [-20, 20]",
    )
    equilibria.add_argument("-o", "--output", type=Path, required=True, metavar="OUT.nc", help="netCDF file to write")
    equilibria.set_defaults(handler=_run_equilibria)

    ld = commands.add_parser(
        "ld",
        help="forward and backward Lagrangian descriptors on a two-dimensional section",
        description=(
            "Compute an LD map: M_p = integral of sum |dx_i/dt|^p dt (or the arc length) forward and "
            "backward from every allowed point of an isoenergetic section, to a fixed time tau or, "
            "with --time variable, until the trajectory leaves a saddle region. Either name a map "
            "of a configuration (--config, --map) or describe one with the options below."
        ),
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    ld.add_argument("--config", type=Path, metavar="FILE", help="a YAML configuration (as config.yaml)")
    ld.add_argument("--map", metavar="NAME", help="a map under 'ld_maps' in --config")
    ld.add_argument("--system", metavar="NAME", help="a built-in system or one declared in --config")
    ld.add_argument("--axis", type=_key_value, action="append", default=[], metavar="NAME=LOW:HIGH:POINTS",
                    help="a section axis (give two), e.g. x=4.8:6.0:1500 then px=-0.6:0.6:1500")
    ld.add_argument("--fixed", type=_key_value, action="append", default=[], metavar="NAME=VALUE",
                    help="a fixed phase coordinate (repeatable); VALUE 'saddle' takes the saddle's value")
    ld.add_argument("--solve", metavar="COORDINATE", help="the coordinate solved from the energy, e.g. py (or x, with --root; Hamiltonian systems)")
    ld.add_argument("--sign", type=int, choices=(1, -1), default=1, help="sign of the solved momentum (default +1)")
    ld.add_argument("--root", metavar="RULE",
                    help="the root a solved position takes: largest, smallest or nearest:VALUE")
    ld.add_argument("--search", metavar="LOW:HIGH",
                    help="interval a solved position's roots are sought in, for a V not quadratic in it "
                         "(with a negative LOW write --search=-3:3)")
    ld.add_argument("--energy", type=finite_float, metavar="E", help="total energy")
    ld.add_argument("--excess-energy", type=finite_float, metavar="DE", help="energy above the saddle's critical energy")
    ld.add_argument("--saddle-near", metavar="Q1,Q2,...", help="use the index-1 saddle nearest this point")
    ld.add_argument("--t0", type=finite_float, metavar="T0",
                    help="start time (a vector-field system declared in --config; default 0)")
    ld.add_argument("--tau", type=finite_float, default=STOPPING.tau, help=f"integration time each way (default {short_number(STOPPING.tau)})")
    ld.add_argument("--iterations", type=int, metavar="N",
                    help="a discrete map's iterations each way (its LD sums n from -N to N-1); instead of --tau")
    ld.add_argument("--p", default=str(DESCRIPTOR.p), metavar="P",
                    help=f"LD exponent in (0, 1], or {ARCLENGTH!r} (default {DESCRIPTOR.p})")
    ld.add_argument("--quad-nodes", type=int, metavar="N",
                    help="Gauss nodes per step of the LD quadrature (default: the scheme's for the tolerance)")
    ld.add_argument("--time", choices=("fixed", "variable"), default="fixed", help="fixed or variable time (default fixed)")
    ld.add_argument("--region", type=_key_value, action="append", default=[], metavar="COORD=LOW:HIGH",
                    help="saddle region interval of one coordinate (repeatable; variable time)")
    schemes = ", ".join(f"{name} (default)" if name == INTEGRATOR.scheme else name for name in SCHEMES)
    adaptive = " and ".join(name for name, record in SCHEMES.items() if record.adaptive)
    ld.add_argument("--scheme", default=INTEGRATOR.scheme, help=f"integrator: {schemes}")
    ld.add_argument("--rtol", type=finite_float, default=INTEGRATOR.rtol,
                    help=f"relative tolerance of {adaptive} (default {short_number(INTEGRATOR.rtol)})")
    ld.add_argument("--atol", type=finite_float, default=INTEGRATOR.atol,
                    help=f"absolute tolerance of {adaptive} (default {short_number(INTEGRATOR.atol)})")
    ld.add_argument("--taylor-order", type=int, metavar="M", default=INTEGRATOR.taylor_order,
                    help="order of the taylor scheme (default: from the tolerance)")
    ld.add_argument("--dt", type=finite_float, default=INTEGRATOR.dt,
                    help=f"step of the fixed-step schemes (default {short_number(INTEGRATOR.dt)})")
    ld.add_argument("--escape-radius", type=finite_float, default=INTEGRATOR.escape_radius, metavar="R",
                    help=f"a trajectory stops, flagged escaped, when max |q_i| exceeds R (default {short_number(INTEGRATOR.escape_radius)})")
    ld.add_argument("--equilibria", type=Path, metavar="FILE",
                    help="the system's equilibria file from `ldpipe equilibria` (default: computed now)")
    ld.add_argument("--refine-tolerance", type=float, metavar="TOL",
                    help="an adaptive map: integrate where the map is not resolved to TOL (a fraction of each LD "
                         "field's value range), interpolate elsewhere (see docs/guide/adaptive_maps.md)")
    ld.add_argument("--coarse-spacing", type=int, metavar="PIXELS",
                    help="an adaptive map's coarse lattice spacing in pixels (with --refine-tolerance, or alone)")
    ld.add_argument("--directions", choices=tuple(DIRECTIONS),
                    help="the directions of time integrated: both, or forward or backward alone (default: the "
                         "map's directions, else both)")
    add_noise_options(ld)
    ld.add_argument("--threads", type=int, metavar="N", help="threads (default: all cores)")
    ld.add_argument("--quiet", action="store_true", help="no progress bar")
    ld.add_argument("-o", "--output", type=Path, required=True, metavar="OUT.nc", help="netCDF file to write")
    ld.set_defaults(handler=_run_ld)

    orbits.register(commands, EPILOG)
    nhim.register(commands, EPILOG)
    return parser


def one_line(message: str) -> str:
    """A message on one line (a configuration's errors are listed one a line): what a log line or a
    shell script's ``2>`` capture keeps whole."""
    lines = [line.strip() for line in message.splitlines() if line.strip()]
    return " ".join(lines[:1] + ["; ".join(lines[1:])] if len(lines) > 1 else lines)


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    argv = sys.argv[1:] if argv is None else list(argv)
    for token in argv:
        # argparse reads OPTION=-- as an empty list, past the option's type and its check
        option, sep, value = token.partition("=")
        if token.startswith("--") and sep and value == "--":
            parser.error(f"argument {option}: expected one argument, got '--'")
    args = parser.parse_args(argv)
    try:
        # Every output the command will write, checked before any work: a bad path fails in a second, not after the run.
        check_writable(getattr(args, "output", None), getattr(args, "csv", None))
        args.handler(args)
    except LdpipeError as error:
        print(f"ldpipe {args.command}: error: {one_line(str(error))}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
