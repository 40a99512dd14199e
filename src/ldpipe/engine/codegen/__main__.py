"""Print the engine modules ldpipe assembles for a system and a scheme, to read or diff them.

    python -m ldpipe.engine.codegen --dump SYSTEM SCHEME [--config FILE] [--lanes N] [--order K] [--entry ENTRY]

The common modules (the LD quadrature and events, shared by every engine of one shape) come
first, then the engine module that imports from them, each under a ``# ==== <file> ====`` line.
SYSTEM is an entry of the ``systems:`` mapping of ``--config FILE`` (only that mapping is read,
so an overlay such as config.quick.yaml will do), else a built-in. A vector field's module is
the flow engine's (:mod:`ldpipe.engine.vector_field`): one module for every block size, order
and entry, so those options do not change it. Bad input is one line on stderr naming the
argument, and exit status 2.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import yaml

from ...errors import ConfigError, LdpipeError
from ...systems import BUILTINS, make_system, system_spec
from ..schemes import SCHEMES, check_scheme
from ..settings import LDSettings
from ..vector_field import vector_field_modules
from . import DRIVERS, engine_modules

PROG = "python -m ldpipe.engine.codegen"


def configured_systems(path: Path) -> dict:
    """The ``systems:`` mapping of the YAML file ``path``."""
    try:
        text = path.read_text()
    except OSError as error:
        raise ConfigError(
            f"--config {str(path)!r}: cannot read the file ({error.strerror}); expected a YAML configuration"
        ) from None
    try:
        config = yaml.safe_load(text)
    except yaml.YAMLError as error:
        problem = str(error).splitlines()[0]
        raise ConfigError(f"--config {str(path)!r}: not valid YAML ({problem})") from None
    systems = config.get("systems") if isinstance(config, dict) else None
    if not isinstance(systems, dict):
        raise ConfigError(f"--config {str(path)!r}: expected a YAML mapping with a 'systems:' mapping")
    return systems


def dumped_system(name: str, config: Path | None):
    """The system SYSTEM names: an entry of the configuration's ``systems:``, else a built-in."""
    systems = {} if config is None else configured_systems(config)
    if name in systems:
        return make_system(name, system_spec({"systems": systems}, name))
    if name in BUILTINS:
        return make_system(name, {"builtin": name})
    if config is None:
        configured = " (or give --config FILE for a system the file declares)"
    else:
        configured = f" or one of the systems {sorted(systems)} of --config {str(config)!r}"
    raise ConfigError(f"SYSTEM {name!r}: no such system; expected a built-in {sorted(BUILTINS)}{configured}")


def dumped_source(args: argparse.Namespace) -> str:
    """The modules :func:`ldpipe.engine.compute_ld` would load for these arguments: the common
    modules, then the engine module that imports from them, each under a line naming its file."""
    if args.scheme not in SCHEMES:
        raise ConfigError(f"SCHEME {args.scheme!r}: unknown scheme; expected one of {list(SCHEMES)}")
    if args.lanes is not None and args.lanes < 1:
        raise ConfigError(f"--lanes {args.lanes}: expected a whole number of at least 1")
    if args.entry not in DRIVERS:
        raise ConfigError(f"--entry {args.entry!r}: unknown entry; expected one of {list(DRIVERS)}")
    try:
        settings = LDSettings(scheme=args.scheme, taylor_order=args.order, block=args.lanes)
    except ValueError as error:
        raise ConfigError(f"--order {args.order}: {error}") from None
    system = dumped_system(args.system, args.config)
    try:
        if not system.hamiltonian:
            check_scheme(settings.record, system)  # only the schemes of general flows take one
            return vector_field_modules(system).listing()
        return engine_modules(system, args.scheme, settings.lanes, settings.order, args.entry).listing()
    except ValueError as error:  # the scheme cannot integrate the system (the message names both)
        raise ConfigError(str(error)) from None


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog=PROG, description=__doc__.split("\n\n")[0],
        epilog="A vector field's module is the flow engine's, the same for every --lanes, --order and --entry.",
    )
    parser.add_argument("--dump", action="store_true", required=True,
                        help="print the assembled modules of SYSTEM and SCHEME to stdout")
    parser.add_argument("system", metavar="SYSTEM", help="a built-in, or an entry of --config's systems:")
    parser.add_argument("scheme", metavar="SCHEME", help=f"an integration scheme: {', '.join(SCHEMES)}")
    parser.add_argument("--config", type=Path, metavar="FILE", help="a YAML file whose 'systems:' declares SYSTEM")
    parser.add_argument("--lanes", type=int, metavar="N", help="trajectories per block (default: the scheme's)")
    parser.add_argument("--order", type=int, metavar="K", help="the order of the taylor scheme (default: the "
                        "one its default tolerance picks); the other schemes ignore it")
    parser.add_argument("--entry", default="process", metavar="ENTRY",
                        help=f"the driver the module is built for: {', '.join(DRIVERS)} (default: process)")
    args = parser.parse_args(argv)
    try:
        source = dumped_source(args)
    except LdpipeError as error:
        print(f"{PROG}: error: {error}", file=sys.stderr)
        return 2
    sys.stdout.write(source)
    return 0


if __name__ == "__main__":
    sys.exit(main())
