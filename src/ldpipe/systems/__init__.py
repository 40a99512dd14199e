"""Model systems declared as data: a built-in name, a formula, a vector field, velocity data or a map.

An entry's kind is the one key of :data:`~ldpipe.systems.kinds.SYSTEM_KINDS` it has; everything
here asks the kind's record, never the entry's keys.

>>> system = make_system("barbanis_2dof", {"builtin": "barbanis_2dof"})
>>> system.coordinates
('x', 'y')
"""

from __future__ import annotations

import json
from functools import lru_cache

from ..errors import ConfigError
from .base import Kernels, System
from .builtin import BUILTINS
from .kinds import SYSTEM_KINDS, SystemKind, check_builtin_parameters, require_hamiltonian, system_kind
from .discrete_map import DiscreteMapSystem
from .model import DataFlowModel, FlowModel, HamiltonianModel, MapModel, SystemModel
from .vector_field import VectorFieldSystem
from .velocity_data import VelocityDataSystem

__all__ = [
    "BUILTINS", "DataFlowModel", "DiscreteMapSystem", "FlowModel", "HamiltonianModel", "Kernels", "MapModel", "SYSTEM_CLASSES", "SYSTEM_KINDS", "System",
    "SystemKind", "SystemModel", "VectorFieldSystem", "VelocityDataSystem", "check_builtin_parameters",
    "equilibrium_box", "has_equilibria", "is_discrete_map", "is_vector_field", "make_system", "on_sphere", "require_hamiltonian",
    "system_coordinates", "system_data_files", "system_from_config", "system_kind", "system_phase_coordinates",
    "system_spec",
]

#: Every class a system may be of, over the registered kinds.
SYSTEM_CLASSES: tuple[type, ...] = tuple(dict.fromkeys(c for kind in SYSTEM_KINDS.values() for c in kind.classes))


def make_system(name: str, spec: dict, key: str | None = None) -> SystemModel:
    """Build (and compile) the system described by one ``systems:`` entry of the config.

    Parameters
    ----------
    name : str
        The entry's name.
    spec : dict
        Either ``{"builtin": NAME, "parameters": {...}}`` (parameters override the
        paper's values), ``{"formula": "...", "coordinates": [...], "parameters": {...}}`` (a
        potential), ``{"vector_field": {coordinate: "..."}, "coordinates": [...], "parameters":
        {...}}`` (a general flow dx/dt = f(x, t), see :mod:`ldpipe.systems.vector_field`),
        ``{"velocity_data": {"path": ..., ...}}`` (see :mod:`ldpipe.systems.velocity_data`) or
        ``{"map": {coordinate: "..."}, "inverse": {...}, "coordinates": [...]}`` or ``{"map":
        "henon"}`` (a discrete map, see :mod:`ldpipe.systems.discrete_map`): one of
        :data:`~ldpipe.systems.kinds.SYSTEM_KINDS`.
    key : str, optional
        Where the entry sits in the configuration, for error messages.
    """
    key = key or f"systems.{name}"
    return _make_system_cached(name, json.dumps(spec, sort_keys=True), key)


@lru_cache(maxsize=32)
def _make_system_cached(name: str, spec_json: str, key: str) -> SystemModel:
    spec = json.loads(spec_json)
    parameters = spec.get("parameters") or {}
    for parameter, value in parameters.items():
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ConfigError(f"config key '{key}.parameters.{parameter}': expected a number, got {value!r}")
    parameters = {k: float(v) for k, v in parameters.items()}
    return system_kind(spec, key).build(name, spec, parameters, key)


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
    """Whether a ``systems:`` entry has no Hamiltonian: a general flow (formulas or velocity data),
    or a discrete map (:func:`is_discrete_map` tells them apart)."""
    return not system_kind(spec).hamiltonian


def is_discrete_map(spec: dict) -> bool:
    """Whether a ``systems:`` entry is a discrete map x_{n+1} = f(x_n) (iterated, no time)."""
    return system_kind(spec).discrete


def has_equilibria(name: str, spec: dict) -> bool:
    """Whether the equilibrium stage applies to system ``name``: every Hamiltonian, and a vector
    field that does not depend on the time (a time-dependent flow has no fixed equilibria)."""
    return system_kind(spec).has_equilibria(name, spec)


def on_sphere(spec: dict) -> bool:
    """Whether a ``systems:`` entry's state is longitude and latitude on the sphere (velocity data)."""
    return system_kind(spec).on_sphere(spec)


def system_phase_coordinates(spec: dict) -> tuple[str, ...]:
    """The phase-space names of a ``systems:`` entry: (q..., p...) of a Hamiltonian, a vector
    field's state variables."""
    return system_kind(spec).phase_coordinates(spec)


def system_coordinates(spec: dict) -> tuple[str, ...]:
    """The coordinate names of a ``systems:`` entry (a built-in's, the list of a formula or vector
    field, the grid's axes of velocity data), nothing read or compiled."""
    return system_kind(spec).coordinates(spec)


def system_data_files(spec: dict) -> list[str]:
    """The files a ``systems:`` entry's system reads (velocity data's dataset; none for formulas)."""
    return system_kind(spec).data_files(spec)
