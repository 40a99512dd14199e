"""The ``noise:`` block of an LD map from ``ldpipe ld``'s options, and errors about it by option.

Every key of the block has its option: ``--diffusivity K`` (every state variable) or
``--diffusivity VAR=K`` (repeatable), ``--diffusion VAR=FORMULA`` (repeatable: a diagonal G) or
``--diffusion-row "F1, F2, ..."`` (repeatable: one row of a full G per state variable),
``--noise-parameter NAME=VALUE``, ``--noise-scheme``, ``--noise-dt``, ``--seed``, ``--members``
and ``--reflect VAR=LOW:HIGH``. Given with ``--map``, they change that entry's block (a G given
replaces the entry's); a configuration error about a key an option gave names the option.
"""

from __future__ import annotations

import argparse
import contextlib
import re
from collections.abc import Iterator

from ..engine.stochastic import SDE_SCHEMES
from ..errors import ConfigError
from .options import number

#: The option of each key of the noise block (``diffusion`` is ``--diffusion-row`` for a matrix).
OPTIONS = {"diffusivity": "--diffusivity", "diffusion": "--diffusion", "parameters": "--noise-parameter",
           "scheme": "--noise-scheme", "dt": "--noise-dt", "seed": "--seed", "members": "--members",
           "reflect": "--reflect"}


def add_noise_options(parser: argparse.ArgumentParser) -> None:
    """``ldpipe ld``'s options of a stochastic map (a vector field or planar velocity data)."""
    group = parser.add_argument_group(
        "noise", "a stochastic map dx = f dt + G dW (see docs/guide/stochastic.md): give --diffusivity or "
                 "--diffusion (or --diffusion-row); the others default as the noise block's keys do")
    group.add_argument("--diffusivity", action="append", default=[], metavar="K|VAR=K",
                       help="additive noise, G = diag(sqrt(2 K)): one K for every state variable, or one per "
                            "variable (repeatable)")
    group.add_argument("--diffusion", action="append", default=[], metavar="VAR=FORMULA",
                       help="a diagonal G by formula, one variable at a time (repeatable)")
    group.add_argument("--diffusion-row", action="append", default=[], metavar="'F1, F2, ...'",
                       help="a full G by formula: one row per state variable, in order, of equally many formulas "
                            "(repeatable)")
    group.add_argument("--noise-parameter", action="append", default=[], metavar="NAME=VALUE",
                       help="a number the diffusion formulas may use (repeatable)")
    group.add_argument("--noise-scheme", choices=tuple(SDE_SCHEMES),
                       help="the SDE scheme")
    group.add_argument("--noise-dt", metavar="DT", help="the largest time step")
    group.add_argument("--seed", metavar="N", help="the key of every path's random numbers")
    group.add_argument("--members", metavar="N", help="noisy paths from every point")
    group.add_argument("--reflect", action="append", default=[], metavar="VAR=LOW:HIGH",
                       help="a reflecting wall pair for a state variable (repeatable)")


def _pairs(values: list[str], option: str, what: str) -> list[tuple[str, str]]:
    pairs = []
    for text in values:
        name, sep, value = text.partition("=")
        if not sep or not name.strip():
            raise ConfigError(f"{option}: expected {what}, got {text!r}")
        pairs.append((name.strip(), value.strip()))
    return pairs


def _whole(text: str, option: str) -> int:
    value = number(text, option)
    if value != int(value):
        raise ConfigError(f"{option}: expected a whole number, got {text!r}")
    return int(value)


def split_formulas(text: str) -> list[str]:
    """A row's formulas, split at the commas outside parentheses (a function may take two arguments)."""
    parts, depth, current = [], 0, ""
    for character in text:
        depth += {"(": 1, ")": -1}.get(character, 0)
        if character == "," and depth == 0:
            parts.append(current.strip())
            current = ""
        else:
            current += character
    return [*parts, current.strip()]


def noise_options(args: argparse.Namespace) -> dict:
    """The keys of the noise block the options give (empty: none given)."""
    block: dict = {}
    if args.diffusivity:
        if len(args.diffusivity) == 1 and "=" not in args.diffusivity[0]:
            block["diffusivity"] = number(args.diffusivity[0], "--diffusivity")
        else:
            block["diffusivity"] = {name: number(value, f"--diffusivity {name}")
                                    for name, value in _pairs(args.diffusivity, "--diffusivity",
                                                              "VAR=K each when given more than once")}
    if args.diffusion and args.diffusion_row:
        raise ConfigError("--diffusion-row: G is given by --diffusion (diagonal) or by --diffusion-row (a full "
                          "matrix), not both")
    if args.diffusion:
        block["diffusion"] = dict(_pairs(args.diffusion, "--diffusion", "VAR=FORMULA"))
    if args.diffusion_row:
        block["diffusion"] = [split_formulas(row) for row in args.diffusion_row]
    if args.noise_parameter:
        block["parameters"] = {name: number(value, f"--noise-parameter {name}")
                               for name, value in _pairs(args.noise_parameter, "--noise-parameter", "NAME=VALUE")}
    if args.noise_scheme is not None:
        block["scheme"] = args.noise_scheme
    if args.noise_dt is not None:
        block["dt"] = number(args.noise_dt, "--noise-dt")
    for key, option in (("seed", "--seed"), ("members", "--members")):
        if getattr(args, key) is not None:
            block[key] = _whole(getattr(args, key), option)
    if args.reflect:
        block["reflect"] = {}
        for name, interval in _pairs(args.reflect, "--reflect", "VAR=LOW:HIGH"):
            low, sep, high = interval.partition(":")
            if not sep:
                raise ConfigError(f"--reflect {name}: expected LOW:HIGH, got {interval!r}")
            block["reflect"][name] = [number(low, f"--reflect {name}"), number(high, f"--reflect {name}")]
    return block


def with_noise(entry: dict, block: dict) -> None:
    """The ld_maps ``entry`` with the options' ``block`` over its noise block: a G the options give
    (diffusivity or diffusion) replaces the entry's."""
    noise = dict(entry.get("noise") or {})
    if "diffusivity" in block or "diffusion" in block:
        noise.pop("diffusivity", None)
        noise.pop("diffusion", None)
    entry["noise"] = {**noise, **block}


def _option(path: str, block: dict, matrix: bool) -> str:
    """The option that gave the noise key at ``path`` (``diffusivity.x``, ``diffusion.1.0``)."""
    key, _, rest = path.partition(".")
    if key == "diffusion" and matrix:
        place = [int(index) + 1 for index in rest.split(".")] if rest else []  # row, then formula, from 1
        return " ".join(["--diffusion-row", *[str(n) for n in place[:1]], *[f"formula {n}" for n in place[1:2]]])
    return OPTIONS[key] + (f" {rest.split('.')[0]}" if rest else "")


@contextlib.contextmanager
def named_by_option(map_name: str, block: dict, matrix: bool) -> Iterator[None]:
    """A ConfigError about a key of map ``map_name``'s noise block that the options gave (``block``)
    raised naming the option instead (``matrix``: G came from ``--diffusion-row``)."""
    try:
        yield
    except ConfigError as error:
        if not block:
            raise
        prefix = re.escape(f"ld_maps.{map_name}.noise")

        def rename(match: re.Match) -> str:
            path = match.group(1)
            if not path:
                return "the noise options (" + ", ".join(OPTIONS[key] for key in block) + ")"
            return _option(path, block, matrix) if path.split(".")[0] in block else match.group(0)

        text = re.sub(rf"config key '{prefix}(?:\.([^']*))?'", rename, str(error))
        raise ConfigError(text.replace("invalid configuration:", "").strip()) from None
