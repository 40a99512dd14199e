"""Model systems declared as data: a built-in name or a formula, with parameters.

>>> system = make_system("barbanis_2dof", {"builtin": "barbanis_2dof"})
>>> system.coordinates
('x', 'y')
"""

from __future__ import annotations

import json
from dataclasses import replace
from functools import lru_cache

from ..errors import ConfigError
from .base import Kernels, System
from .builtin import BUILTINS, make_builtin
from .formula import make_formula_system
from .kinetic import kinetic_matrix

__all__ = [
    "BUILTINS", "Kernels", "System", "check_builtin_parameters", "equilibrium_box", "make_system", "system_coordinates",
    "system_from_config", "system_spec",
]


def check_builtin_parameters(builtin: str, parameters: dict, key: str) -> None:
    """Reject parameter names the built-in ``builtin`` does not have."""
    defaults = BUILTINS[builtin]["defaults"]
    unknown = set(parameters) - set(defaults)
    if unknown:
        raise ConfigError(
            f"config key '{key}.parameters': unknown parameters {sorted(unknown)} for {builtin}; "
            f"allowed are {sorted(defaults)}"
        )


def make_system(name: str, spec: dict, key: str | None = None) -> System:
    """Build (and compile) the system described by one ``systems:`` entry of the config.

    Parameters
    ----------
    name : str
        The entry's name.
    spec : dict
        Either ``{"builtin": NAME, "parameters": {...}}`` (parameters override the
        paper's values) or ``{"formula": "...", "coordinates": [...], "parameters": {...}}``.
    key : str, optional
        Where the entry sits in the configuration, for error messages.
    """
    key = key or f"systems.{name}"
    return _make_system_cached(name, json.dumps(spec, sort_keys=True), key)


@lru_cache(maxsize=32)
def _make_system_cached(name: str, spec_json: str, key: str) -> System:
    spec = json.loads(spec_json)
    parameters = spec.get("parameters") or {}
    for parameter, value in parameters.items():
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ConfigError(f"config key '{key}.parameters.{parameter}': expected a number, got {value!r}")
    parameters = {k: float(v) for k, v in parameters.items()}
    if ("builtin" in spec) == ("formula" in spec):
        raise ConfigError(f"config key '{key}': give exactly one of 'builtin' or 'formula'")
    if "builtin" in spec:
        builtin = spec["builtin"]
        if builtin not in BUILTINS:
            raise ConfigError(f"config key '{key}.builtin': unknown system {builtin!r}; expected one of {sorted(BUILTINS)}")
        check_builtin_parameters(builtin, parameters, key)
        mass_matrix = kinetic_matrix(spec, BUILTINS[builtin]["coordinates"], key)
        system = make_builtin(name, builtin, {**BUILTINS[builtin]["defaults"], **parameters}, spec)
    else:
        coordinates = spec.get("coordinates")
        if not coordinates or not all(isinstance(c, str) and c.isidentifier() for c in coordinates):
            raise ConfigError(f"config key '{key}.coordinates': expected a list of coordinate names, got {coordinates!r}")
        if len(set(coordinates)) != len(coordinates):
            raise ConfigError(f"config key '{key}.coordinates': names repeat in {coordinates!r}")
        mass_matrix = kinetic_matrix(spec, tuple(coordinates), key)
        system = make_formula_system(name, spec["formula"], tuple(coordinates), parameters, spec, key)
    return system if mass_matrix is None else replace(system, mass_matrix=mass_matrix)


def system_from_config(config: dict, name: str) -> System:
    """The system ``name`` declared under ``systems:`` in a loaded configuration."""
    systems = config.get("systems", {})
    if name not in systems:
        raise ConfigError(f"config key 'systems.{name}': no such system; the configuration declares {sorted(systems)}")
    return make_system(name, systems[name])


def equilibrium_box(config_system: dict, coordinates: tuple[str, ...]) -> dict[str, list[float]]:
    """The full search box of a validated system entry: configured intervals plus the default."""
    settings = config_system["equilibria"]
    return {c: list(settings["box"].get(c, settings["default_interval"])) for c in coordinates}


def system_spec(config: dict, name: str) -> dict:
    """What :func:`ldpipe.systems.make_system` needs of system ``name``: its entry less the
    equilibrium-search settings, so that changing those reruns only the equilibrium stage."""
    return {k: v for k, v in config["systems"][name].items() if k != "equilibria"}


def system_coordinates(spec: dict) -> tuple[str, ...]:
    """The coordinate names of a ``systems:`` entry (a built-in's, or the formula's list)."""
    if "builtin" in spec:
        return BUILTINS[spec["builtin"]]["coordinates"]
    return tuple(spec["coordinates"])
