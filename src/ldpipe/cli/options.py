"""What the subcommands share: numbers from the command line, and the equilibria file a stage reads.

Numbers are finite ones only, each refused by the option that gave it: ``float("nan")`` and
``float("inf")`` parse, and would then run a whole stage on them (an energy of nan solves no
point of a section; an inf dies in the file writer); they are refused here, before any work starts.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from ..config.parameters import parameters_from_config
from ..errors import ConfigError
from ..stages.equilibria import run_equilibria


def number(text: str, what: str) -> float:
    """The finite number ``text`` means, or a ConfigError naming ``what`` (the option)."""
    try:
        value = float(text)
    except ValueError:
        raise ConfigError(f"{what}: expected a number, got {text!r}") from None
    if not math.isfinite(value):
        raise ConfigError(f"{what}: expected a finite number, got {text!r}")
    return value


def finite_float(text: str) -> float:
    """An argparse ``type``: a finite number (argparse names the option in its error)."""
    try:
        return number(text, "value")
    except ConfigError:
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}") from None


def equilibria_file(config: dict, system_name: str, given: str | Path | None, scratch: Path) -> Path:
    """The equilibria file ``given``, or one computed now into the folder ``scratch`` (for the CLI,
    whose later stages read the equilibria from a file as their Snakemake rules do)."""
    if given is not None:
        return Path(given)
    parameters = parameters_from_config(config, "equilibria", system_name)
    return run_equilibria(**parameters, output=Path(scratch) / f"{system_name}_equilibria.nc")
