"""The kinds of system a ``systems:`` entry may declare, and the registry that names them.

Modelled on scipy's ``solve_ivp`` (``METHODS``) and ldpipe's own scheme registry
(:data:`ldpipe.engine.schemes.SCHEMES`): :data:`SYSTEM_KINDS` maps each kind's config key to its
record (:class:`SystemKind`: whether it is a Hamiltonian, how its system is built, its
coordinates from the entry, the classes of its systems, ...). Everything that tells kinds apart
reads it: :func:`ldpipe.systems.make_system` and the entry helpers beside it, the configuration's
checks and messages, the stages, the workflow's planning. An entry's kind is the one registered
key it has (:func:`system_kind`).

Adding a kind is a record here, with a builder whose systems satisfy
:class:`ldpipe.systems.model.SystemModel` (and :class:`~ldpipe.systems.model.HamiltonianModel` or
:class:`~ldpipe.systems.model.FlowModel`), and its branch in the config schema's ``system``;
``tests/systems/test_kinds.py`` names what is missing.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Callable

from ..errors import ConfigError
from .base import System
from .builtin import BUILTINS, make_builtin
from .discrete_map import DiscreteMapSystem, check_map, make_discrete_map_system, map_caption, map_coordinates
from .grammar import check_formulas
from .kinetic import kinetic_matrix
from .model import SystemModel
from .vector_field import TIME, VectorFieldSystem, make_vector_field_system, parse_vector_field
from .velocity_data import (
    CurvilinearVelocitySystem, RectilinearVelocitySystem, StaggeredVelocitySystem, VelocityDataSystem, make_velocity_data_system, path_text, velocity_data_coordinates,
    velocity_data_files,
)

# sympy (through .formula) is imported where a formula is parsed: the planning and the stages
# read every entry's kind and coordinates without it.

__all__ = ["SYSTEM_KINDS", "SystemKind", "hamiltonian_kinds_text", "kinds_text", "one_of", "require_hamiltonian",
           "system_kind"]


@dataclass(frozen=True)
class SystemKind:
    """One kind of system: what the code asks of a ``systems:`` entry of it.

    ``build(name, spec, parameters, key)`` makes the system (``parameters`` the entry's, as floats;
    ``key`` where the entry sits, for errors); ``coordinates(spec)`` are its coordinate names with
    no file read and nothing compiled; ``required`` the keys its entry must have (its own first)
    and ``excluded`` those it may not (besides other kinds' keys), as the schema's branch says.
    """

    key: str
    #: What an entry of this kind is, in messages ("a vector field").
    noun: str
    #: A natural Hamiltonian (phase space (q, p), energies) or not (a general flow, a map).
    hamiltonian: bool
    build: Callable[[str, dict, dict[str, float], str], SystemModel]
    coordinates: Callable[[dict], tuple[str, ...]]
    #: The classes of its systems (each satisfies the protocol of its family).
    classes: tuple[type, ...]
    required: tuple[str, ...]
    #: ``caption(spec)``: what the system is, in a figure's caption (formulas as written).
    caption: Callable[[dict], str]
    excluded: tuple[str, ...] = ()
    #: The model is given by formulas: captions state them, a flow's Jacobian is derived from them.
    formulas: bool = True
    #: Data boundaries (land, the grid's edge) stop its trajectories (its classes' ``has_stop_flags``).
    stop_flags: bool = False
    #: ``has_equilibria(name, spec)``: whether the equilibrium stage applies (a fixed set of equilibria).
    has_equilibria: Callable[[str, dict], bool] = lambda name, spec: True
    #: ``on_sphere(spec)``: whether its state is longitude and latitude on the sphere.
    on_sphere: Callable[[dict], bool] = lambda spec: False
    #: ``data_files(spec)``: the files its system reads (a rule's inputs).
    data_files: Callable[[dict], list[str]] = lambda spec: []
    #: ``check(spec, key)``: what a schema cannot say of a (validated) entry, checked without building it.
    check: Callable[[dict, str], None] = lambda spec, key: None
    #: A discrete map x_{n+1} = f(x_n) (iterated; its classes satisfy ``MapModel``), not a flow in time.
    discrete: bool = False

    def phase_coordinates(self, spec: dict) -> tuple[str, ...]:
        """The integrated state's names: (q..., p...) of a Hamiltonian, a flow's state variables."""
        coordinates = self.coordinates(spec)
        return coordinates + tuple("p" + c for c in coordinates) if self.hamiltonian else coordinates


def one_of(names) -> str:
    """``'a', 'b' or 'c'``: names quoted, for a message."""
    quoted = [f"'{name}'" for name in names]
    return quoted[0] if len(quoted) == 1 else ", ".join(quoted[:-1]) + " or " + quoted[-1]


def check_builtin_parameters(builtin: str, parameters: dict, key: str) -> None:
    """Reject parameter names the built-in ``builtin`` does not have."""
    defaults = BUILTINS[builtin]["defaults"]
    unknown = set(parameters) - set(defaults)
    if unknown:
        raise ConfigError(
            f"config key '{key}.parameters': unknown parameters {sorted(unknown)} for {builtin}; "
            f"allowed are {sorted(defaults)}"
        )


def _build_builtin(name: str, spec: dict, parameters: dict[str, float], key: str) -> System:
    builtin = spec["builtin"]
    if builtin not in BUILTINS:
        raise ConfigError(f"config key '{key}.builtin': unknown system {builtin!r}; expected one of {sorted(BUILTINS)}")
    check_builtin_parameters(builtin, parameters, key)
    mass_matrix = kinetic_matrix(spec, BUILTINS[builtin]["coordinates"], key)
    system = make_builtin(name, builtin, {**BUILTINS[builtin]["defaults"], **parameters}, spec)
    return system if mass_matrix is None else replace(system, mass_matrix=mass_matrix)


def _listed_coordinates(spec: dict, key: str) -> tuple[str, ...]:
    """The entry's ``coordinates``: a list of distinct identifiers."""
    coordinates = spec.get("coordinates")
    if not coordinates or not all(isinstance(c, str) and c.isidentifier() for c in coordinates):
        raise ConfigError(f"config key '{key}.coordinates': expected a list of coordinate names, got {coordinates!r}")
    if len(set(coordinates)) != len(coordinates):
        raise ConfigError(f"config key '{key}.coordinates': names repeat in {coordinates!r}")
    return tuple(coordinates)


def _build_formula(name: str, spec: dict, parameters: dict[str, float], key: str) -> System:
    coordinates = _listed_coordinates(spec, key)
    from .formula import make_formula_system  # here: sympy, which no other kind of system needs

    mass_matrix = kinetic_matrix(spec, coordinates, key)
    system = make_formula_system(name, spec["formula"], coordinates, parameters, spec, key)
    return system if mass_matrix is None else replace(system, mass_matrix=mass_matrix)


def _build_vector_field(name: str, spec: dict, parameters: dict[str, float], key: str) -> VectorFieldSystem:
    coordinates = _listed_coordinates(spec, key)
    given = [k for k in ("masses", "mass_matrix") if k in spec]
    if given:
        raise ConfigError(f"config key '{key}.{given[0]}': a vector field has no kinetic energy to give masses to; "
                          "write them into its formulas")
    return make_vector_field_system(name, spec["vector_field"], coordinates, parameters, spec, key)


def _build_velocity_data(name: str, spec: dict, parameters: dict[str, float], key: str) -> VelocityDataSystem:
    return make_velocity_data_system(name, spec, key)


def _build_map(name: str, spec: dict, parameters: dict[str, float], key: str) -> DiscreteMapSystem:
    return make_discrete_map_system(name, spec, key)


def _autonomous(name: str, spec: dict) -> bool:
    """A vector field that does not depend on the time (a time-dependent flow has no fixed equilibria)."""
    parameters = {k: float(v) for k, v in (spec.get("parameters") or {}).items()}
    fields = parse_vector_field(spec["vector_field"], tuple(spec["coordinates"]), parameters, f"systems.{name}")
    return not any(TIME in {str(s) for s in f.free_symbols} for f in fields)


def _check_formula(spec: dict, key: str) -> None:
    """The potential is a formula in the coordinates and parameters (its syntax tree, no sympy)."""
    check_formulas({"formula": spec["formula"]}, tuple(spec["coordinates"]), spec.get("parameters") or {}, key)


def _check_vector_field(spec: dict, key: str) -> None:
    """Each component is a formula in the coordinates, parameters and time (its syntax tree, no sympy)."""
    components = spec["vector_field"]
    formulas = {f"vector_field.{name}": text for name, text in components.items()}
    check_formulas(formulas, tuple(spec["coordinates"]), spec.get("parameters") or {}, key, time=TIME)


def _formula_caption(spec: dict) -> str:
    return f"V = {spec.get('formula', '')}"


def _vector_field_caption(spec: dict) -> str:
    return "vector field " + ", ".join(f"d{c}/dt = {f}" for c, f in spec["vector_field"].items())


def _velocity_data_caption(spec: dict) -> str:
    entry = spec["velocity_data"]
    if "path" in entry:
        return f"velocity data from {path_text(entry['path'])}"
    memory = entry.get("memory") or {}
    return f"velocity data from memory ({', '.join(memory.get('variables', []))}; {memory.get('hash', '')[:23]})"


def _check_velocity_data(spec: dict, key: str) -> None:
    """A file's path, or (from the Python API) a dataset in memory: one of them."""
    entry = spec["velocity_data"]
    if ("path" in entry) == ("memory" in entry):
        raise ConfigError(f"config key '{key}.velocity_data.path': " + (
            "a path and a dataset in memory both given; give one" if "path" in entry else
            "required: the dataset's file (netCDF, or a .zarr store), or, in Python, the xarray.Dataset itself"))

#: The keys only a map's entry takes (its inverse, its periodic coordinates).
MAP_KEYS = ("inverse", "periodic")

#: The registry: config key -> record, in the order messages list the kinds.
SYSTEM_KINDS: dict[str, SystemKind] = {
    "builtin": SystemKind(
        key="builtin", noun="a built-in", hamiltonian=True, build=_build_builtin,
        coordinates=lambda spec: BUILTINS[spec["builtin"]]["coordinates"], classes=(System,),
        required=("builtin",), caption=lambda spec: f"built-in {spec['builtin']}", excluded=MAP_KEYS,
        check=lambda spec, key: check_builtin_parameters(spec["builtin"], spec["parameters"], key),
    ),
    "formula": SystemKind(
        key="formula", noun="a formula", hamiltonian=True, build=_build_formula,
        coordinates=lambda spec: tuple(spec["coordinates"]), classes=(System,),
        required=("formula", "coordinates"), caption=_formula_caption, check=_check_formula, excluded=MAP_KEYS,
    ),
    "vector_field": SystemKind(
        key="vector_field", noun="a vector field", hamiltonian=False, build=_build_vector_field,
        coordinates=lambda spec: tuple(spec["coordinates"]), classes=(VectorFieldSystem,),
        required=("vector_field", "coordinates"), has_equilibria=_autonomous, caption=_vector_field_caption,
        check=_check_vector_field, excluded=MAP_KEYS,
    ),
    "velocity_data": SystemKind(
        key="velocity_data", noun="velocity data", hamiltonian=False, build=_build_velocity_data,
        coordinates=lambda spec: velocity_data_coordinates(spec["velocity_data"]),
        classes=(VelocityDataSystem, RectilinearVelocitySystem, CurvilinearVelocitySystem, StaggeredVelocitySystem),
        required=("velocity_data",), excluded=("coordinates", *MAP_KEYS), formulas=False, stop_flags=True,
        has_equilibria=lambda name, spec: False,  # data depend on time
        on_sphere=lambda spec: spec["velocity_data"].get("coordinates") == "sphere",
        data_files=lambda spec: velocity_data_files(spec["velocity_data"]["path"]) if "path" in spec["velocity_data"] else [],
        caption=_velocity_data_caption, check=_check_velocity_data,
    ),
    "map": SystemKind(
        key="map", noun="a map", hamiltonian=False, build=_build_map, coordinates=map_coordinates,
        classes=(DiscreteMapSystem,), required=("map",), excluded=("masses", "mass_matrix"), caption=map_caption,
        check=check_map, discrete=True,  # its equilibria are its fixed points
    ),
}


def kinds_text() -> str:
    """Every kind's key, for a message: ``'builtin', 'formula', ... or 'velocity_data'``."""
    return one_of(SYSTEM_KINDS)


def hamiltonian_kinds_text() -> str:
    """The Hamiltonian kinds' keys, for a message: ``'builtin' or 'formula'``."""
    return one_of(key for key, kind in SYSTEM_KINDS.items() if kind.hamiltonian)


def system_kind(spec: dict, key: str | None = None) -> SystemKind:
    """The kind of a ``systems:`` entry: the one registered key it has.

    ConfigError naming every kind (and ``key``, where the entry sits) for none or several.
    """
    found = [kind for name, kind in SYSTEM_KINDS.items() if name in spec]
    if len(found) != 1:
        where = f"config key '{key}': " if key else ""
        raise ConfigError(f"{where}give exactly one of {kinds_text()}")
    return found[0]


def require_hamiltonian(system: SystemModel, what: str, key: str | None = None) -> None:
    """ConfigError if ``system`` is a flow: ``what`` (a stage or quantity) needs a Hamiltonian."""
    if not system.hamiltonian:
        where = f"config key '{key}': " if key else ""
        raise ConfigError(
            f"{where}system {system.name!r} is {'a discrete map' if system.discrete else 'a vector field'} (no "
            f"Hamiltonian); {what} needs a Hamiltonian "
            f"system ({hamiltonian_kinds_text()})"
        )
