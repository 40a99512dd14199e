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
from .vector_field import TIME, VectorFieldSystem, make_vector_field_system, parse_vector_field, require_hamiltonian
from .kinetic import kinetic_matrix
from .velocity_data import VelocityDataSystem, make_velocity_data_system, velocity_data_coordinates

__all__ = [
    "BUILTINS", "Kernels", "System", "VectorFieldSystem", "VelocityDataSystem", "check_builtin_parameters", "equilibrium_box", "make_system", "system_coordinates",
    "has_equilibria", "is_vector_field", "on_sphere", "require_hamiltonian", "system_from_config", "system_phase_coordinates", "system_spec",
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


def make_system(name: str, spec: dict, key: str | None = None) -> System | VectorFieldSystem:
    """Build (and compile) the system described by one ``systems:`` entry of the config.

    Parameters
    ----------
    name : str
        The entry's name.
    spec : dict
        Either ``{"builtin": NAME, "parameters": {...}}`` (parameters override the
        paper's values), ``{"formula": "...", "coordinates": [...], "parameters": {...}}`` (a
        potential) or ``{"vector_field": {coordinate: "..."}, "coordinates": [...], "parameters":
        {...}}`` (a general flow dx/dt = f(x, t), see :mod:`ldpipe.systems.vector_field`).
    key : str, optional
        Where the entry sits in the configuration, for error messages.
    """
    key = key or f"systems.{name}"
    return _make_system_cached(name, json.dumps(spec, sort_keys=True), key)


@lru_cache(maxsize=32)
def _make_system_cached(name: str, spec_json: str, key: str) -> System | VectorFieldSystem:
    spec = json.loads(spec_json)
    parameters = spec.get("parameters") or {}
    for parameter, value in parameters.items():
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ConfigError(f"config key '{key}.parameters.{parameter}': expected a number, got {value!r}")
    parameters = {k: float(v) for k, v in parameters.items()}
    if sum(kind in spec for kind in ("builtin", "formula", "vector_field", "velocity_data")) != 1:
        raise ConfigError(f"config key '{key}': give exactly one of 'builtin', 'formula', 'vector_field' or 'velocity_data'")
    if "velocity_data" in spec:
        return make_velocity_data_system(name, spec, key)
    if "builtin" in spec:
        builtin = spec["builtin"]
        if builtin not in BUILTINS:
            raise ConfigError(f"config key '{key}.builtin': unknown system {builtin!r}; expected one of {sorted(BUILTINS)}")
        check_builtin_parameters(builtin, parameters, key)
        mass_matrix = kinetic_matrix(spec, BUILTINS[builtin]["coordinates"], key)
        system = make_builtin(name, builtin, {**BUILTINS[builtin]["defaults"], **parameters}, spec)
        return system if mass_matrix is None else replace(system, mass_matrix=mass_matrix)
    coordinates = spec.get("coordinates")
    if not coordinates or not all(isinstance(c, str) and c.isidentifier() for c in coordinates):
        raise ConfigError(f"config key '{key}.coordinates': expected a list of coordinate names, got {coordinates!r}")
    if len(set(coordinates)) != len(coordinates):
        raise ConfigError(f"config key '{key}.coordinates': names repeat in {coordinates!r}")
    if "vector_field" in spec:
        given = [k for k in ("masses", "mass_matrix") if k in spec]
        if given:
            raise ConfigError(f"config key '{key}.{given[0]}': a vector field has no kinetic energy to give masses to; "
                              "write them into its formulas")
        return make_vector_field_system(name, spec["vector_field"], tuple(coordinates), parameters, spec, key)
    from .formula import make_formula_system  # here: sympy, which no other kind of system needs

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


def is_vector_field(spec: dict) -> bool:
    """Whether a ``systems:`` entry is a general vector field (no Hamiltonian): formulas or velocity data."""
    return "vector_field" in spec or "velocity_data" in spec


def has_equilibria(name: str, spec: dict) -> bool:
    """Whether the equilibrium stage applies to system ``name``: every Hamiltonian, and a vector
    field that does not depend on the time (a time-dependent flow has no fixed equilibria)."""
    if not is_vector_field(spec):
        return True
    if "velocity_data" in spec:  # data depend on time
        return False
    parameters = {k: float(v) for k, v in (spec.get("parameters") or {}).items()}
    fields = parse_vector_field(spec["vector_field"], tuple(spec["coordinates"]), parameters, f"systems.{name}")
    return not any(TIME in {str(s) for s in f.free_symbols} for f in fields)


def on_sphere(spec: dict) -> bool:
    """Whether a ``systems:`` entry's state is longitude and latitude on the sphere (velocity data)."""
    return spec.get("velocity_data", {}).get("coordinates") == "sphere"


def system_phase_coordinates(spec: dict) -> tuple[str, ...]:
    """The phase-space names of a ``systems:`` entry: (q..., p...) of a Hamiltonian, a vector
    field's state variables."""
    coordinates = system_coordinates(spec)
    return coordinates if is_vector_field(spec) else coordinates + tuple("p" + c for c in coordinates)


def system_coordinates(spec: dict) -> tuple[str, ...]:
    """The coordinate names of a ``systems:`` entry (a built-in's, or the formula's or vector field's list)."""
    if "builtin" in spec:
        return BUILTINS[spec["builtin"]]["coordinates"]
    if "velocity_data" in spec:
        return velocity_data_coordinates(spec["velocity_data"])
    return tuple(spec["coordinates"])
