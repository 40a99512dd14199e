"""What every function of the Python API shares: a call's keyword arguments made the
configuration entry they stand for, validated by the configuration's own rules, with errors that
name the argument where the configuration would name the key."""

from __future__ import annotations

import contextlib
import copy
import functools
import inspect
import re
import textwrap
from collections.abc import Callable, Iterator

import xarray as xr

from ..config import validate_config
from ..config.loading import shared_schema
from ..config.parameters import parameters_from_config
from ..errors import ConfigError, LdpipeError, StageFileError
from ..io.contracts import EQUILIBRIA, FLOW_EQUILIBRIA, LD_GRID, UPO
from ..io.datafile import STAGE_ATTRIBUTE, open_stage_file, stage_parameters
from ..systems import SYSTEM_CLASSES, DiscreteMapSystem, System, VectorFieldSystem, VelocityDataSystem
from ..systems.velocity_data.calendar import numeric_times
from .keywords import keyword_docs

AnySystem = System | VectorFieldSystem | VelocityDataSystem | DiscreteMapSystem

#: What several functions' docstrings say alike, written once: ``%(NAME)s`` in a docstring, at
#: the indentation of a numpydoc section's entry, stands for the entry NAME (:func:`shared_docs`).
SHARED_DOCS = {
    "system": """system : System, VectorFieldSystem, VelocityDataSystem or DiscreteMapSystem
        The entry's system, from :func:`ldpipe.system` (the entry's ``system`` name replaced by
        the object).""",
    "equilibria": """equilibria : xarray.Dataset, optional
        The system's equilibria (:func:`ldpipe.equilibria`), where the saddle and an excess energy
        are read; default computed now with the system's ``equilibria`` settings, as the pipeline
        does (none for a vector field, which has neither). Those of another system (another spec
        recorded in their file) are refused.""",
    "threads": """threads : int, optional
        Threads of the engine (default every core).""",
    "raises": """Raises
    ------
    ConfigError
        naming the argument, with the message a bad key of the entry gets.""",
}


def shared_docs(function: Callable) -> Callable:
    """``function`` with the ``%(NAME)s`` of its docstring replaced by :data:`SHARED_DOCS`' entries."""
    function.__doc__ = re.sub(r"%\((\w+)\)s", lambda match: SHARED_DOCS[match.group(1)], function.__doc__)
    return function


def api_function(schema: str | None = None, taken: tuple[str, ...] = ()) -> Callable[[Callable], Callable]:
    """A function of the API: its docstring's ``%(NAME)s`` filled (:func:`shared_docs`), the keys
    of the schema's block at ``schema`` (a JSON pointer, ``"$defs/ld_map"``) that it takes as
    keyword arguments documented under ``Other Parameters`` (all but those ``taken``:
    its own parameters, or the objects standing for a named entry), and its errors raised at
    the caller (:func:`user_error`)."""

    def decorate(function: Callable) -> Callable:
        shared_docs(function)
        if schema is not None:
            section = textwrap.indent(keyword_docs(schema, taken), "    ").replace("\n    \n", "\n\n")
            head, returns, tail = function.__doc__.partition("\n    Returns\n")
            function.__doc__ = f"{head}\n{section}\n\n    Returns\n{tail}" if returns else f"{head}\n\n{section}\n"
        function.schema_keywords = (schema, taken)
        takes_system = next(iter(inspect.signature(function).parameters), None) == "system"

        @functools.wraps(function)
        def call(*args, **kwargs):
            __tracebackhide__ = True  # noqa: F841  (IPython and pytest hide this frame)
            try:
                if takes_system:  # before its name is read: a string would fail as no attribute 'name'
                    check_system(args[0] if args else kwargs.get("system"))
                return function(*args, **kwargs)
            except LdpipeError as error:
                raise user_error(error, function.__name__) from None

        return call

    return decorate


def check_system(system) -> None:
    """A ConfigError naming the argument ``system`` unless it is a system object."""
    if not isinstance(system, SYSTEM_CLASSES):
        raise ConfigError(f"argument 'system': expected a system from ldpipe.system(...), got {type(system).__name__} "
                          f"{system!r:.60}")


def user_error(error: LdpipeError, function: str) -> LdpipeError:
    """``error`` as the caller of ``ldpipe.<function>`` sees it: the same class, a one-line message
    that names the function, and no traceback of ldpipe's own frames (the message is the whole
    story: which argument, what was expected)."""
    text = "; ".join(line.strip() for line in str(error).splitlines() if line.strip())
    if not text.startswith("ldpipe."):
        text = f"ldpipe.{function}: {text}"
    return type(error)(text)


@contextlib.contextmanager
def arguments_of(function: str, key: str) -> Iterator[None]:
    """Turn a ConfigError about the entry at config key ``key`` into one about the arguments of
    ``ldpipe.<function>``: the same message on one line, naming the argument where it named the key."""
    try:
        yield
    except ConfigError as error:
        text = str(error).replace("invalid configuration:", "").strip()
        text = "; ".join(line.strip() for line in text.splitlines() if line.strip())
        text = re.sub(rf"config key '{re.escape(key)}\.([^']*)'", r"argument '\1'", text)
        text = re.sub(rf"config key '{re.escape(key)}': unknown keys (\[[^]]*\]( \(did you mean [^)]*\))?); "
                      "allowed keys are", r"unknown arguments \1; allowed are", text)
        if "unknown arguments" in text:  # given as the object
            text = text.replace("'system', ", "").replace(", 'system']", "]")
        text = re.sub(rf"config key '{re.escape(key)}'", "the arguments", text)
        raise ConfigError(f"ldpipe.{function}: {text}") from None


@functools.lru_cache(maxsize=None)
def _name_pattern(section: str) -> str:
    return shared_schema()["properties"][section]["propertyNames"]["pattern"]


def entry_key(function: str, section: str, name) -> str:
    """The config key of the entry ``name`` of ``section`` (``"ld_maps.map"``); a ConfigError naming
    the argument ``name`` of ``ldpipe.<function>`` if no entry may have that name (the schema's
    pattern): else a list as a name made an unhashable key, and a bad name an error about the
    whole section."""
    pattern = _name_pattern(section)
    if not isinstance(name, str) or not re.fullmatch(pattern, name):
        raise ConfigError(f"ldpipe.{function}: argument 'name': expected a name matching {pattern!r}, got {name!r}")
    return f"{section}.{name}"


def energy_shorthand(spec: dict) -> dict:
    """``energy=0.2`` for ``energy={"total": 0.2}``, ``energies=[...]`` for ``{"total": [...]}``:
    a bare number is a total energy (an excess one is always written ``{"excess": ...}``)."""
    spec = dict(spec)
    if isinstance(spec.get("energy"), (int, float)) and not isinstance(spec["energy"], bool):
        spec["energy"] = {"total": spec["energy"]}
    if isinstance(spec.get("energies"), (list, tuple)):
        spec["energies"] = {"total": list(spec["energies"])}
    return spec


def calendar_times(system: AnySystem, spec: dict, key: str) -> dict:
    """``spec`` with a date ``t0`` and a duration ``tau`` made numbers in the system's time units
    (:func:`ldpipe.systems.velocity_data.calendar.numeric_times`): dates as Python objects
    (``numpy.datetime64``, ``pandas.Timestamp``, ...) too, which a configuration cannot hold."""
    source = system.source if isinstance(system, VelocityDataSystem) else None
    return numeric_times(spec, source, system.name, key)


def system_entry(system: AnySystem) -> dict:
    if not isinstance(system, SYSTEM_CLASSES):
        raise ConfigError(f"expected a system (from ldpipe.system), got {type(system).__name__}")
    return copy.deepcopy(system.spec)


def system_config(system: AnySystem) -> dict:
    """The configuration holding ``system`` alone, as its entry."""
    return {"systems": {system.name: system_entry(system)}}


def entry_parameters(entry: dict, config: dict, section: str, name: str, stage: str) -> tuple[dict, dict]:
    """The validated configuration holding ``entry`` as ``section``'s entry ``name`` beside
    ``config`` (defaults filled), and ``stage``'s parameters from it (call it inside
    :func:`arguments_of`, so that a ConfigError names the arguments)."""
    config = validate_config(copy.deepcopy({**config, section: {name: entry}}))
    return config, parameters_from_config(config, stage, name)


def family_config(orbits: xr.Dataset) -> tuple[str, dict]:
    """The configuration a family file was computed from (its system and its entry), from the
    parameters it records."""
    orbits = open_stage_file(orbits, stage=UPO)
    recorded = stage_parameters(orbits)
    family, system_name = recorded["family"], recorded["system_name"]
    entry = {k: v for k, v in recorded.items() if k not in ("family", "system_name", "system_spec")}
    return family, {"systems": {system_name: recorded["system_spec"]},
                    "periodic_orbits": {family: {"system": system_name, **entry}}}


#: What a map's file records besides the keys of the ``ld_maps`` entry it was computed from.
MAP_RECORD = ("map_name", "system_name", "system_spec", "resolved", "tile", "tiles")


def recorded_map_entry(ld_map: xr.Dataset) -> tuple[str, str, dict, dict]:
    """The ``ld_maps`` entry an LD map was computed from, from the parameters its file records:
    the map's name, its system's name and spec, and the entry's other keys."""
    recorded = stage_parameters(open_stage_file(ld_map, stage=LD_GRID.stage))
    return (recorded["map_name"], recorded["system_name"], recorded["system_spec"],
            {k: v for k, v in recorded.items() if k not in MAP_RECORD})


def equilibria_of(given: xr.Dataset, system_name: str, spec: dict, what: str) -> xr.Dataset:
    """``given`` (an ``equilibria=`` argument), checked to be the equilibria of the system whose
    spec is ``spec`` (the entry less its equilibrium-search settings, as stage files record it):
    another system's saddle would silently place a map, a family or a flux wrongly. The name a
    system goes by does not change its equilibria, so only the specs are compared. ``what`` names
    the call's subject in the message ("the map", "the family")."""
    try:
        if not isinstance(given, xr.Dataset):  # a file's path, as the stage functions take
            given = open_stage_file(given, stage=EQUILIBRIA)
        stage = FLOW_EQUILIBRIA if given.attrs.get(STAGE_ATTRIBUTE) == FLOW_EQUILIBRIA.stage else EQUILIBRIA
        recorded = stage_parameters(open_stage_file(given, stage=stage))
    except StageFileError as error:
        raise ConfigError(f"argument 'equilibria': {error}") from None
    spec = {k: v for k, v in spec.items() if k != "equilibria"}
    if recorded["system_spec"] != spec:
        raise ConfigError(f"argument 'equilibria': equilibria of system {recorded['system_name']!r} "
                          f"{recorded['system_spec']}, but {what} is of {system_name!r} {spec}")
    return given


def family_equilibria(orbits: xr.Dataset, given: xr.Dataset | None) -> xr.Dataset:
    """The equilibria given for a family's study, checked to be of the family's system (its spec
    as both files record it; :func:`equilibria_of`); required,
    since the family's file does not record the system's equilibrium-search settings that would
    find them again. A ConfigError here names the argument (``arguments_of`` adds the function)."""
    if given is None:
        raise ConfigError("argument 'equilibria': required: give the equilibria of the family's system "
                          "(ldpipe.equilibria(system), found with the system's own 'equilibria' settings); "
                          "a family's file does not record those settings, so they cannot be found again here")
    family = stage_parameters(open_stage_file(orbits, stage=UPO))
    return equilibria_of(given, family["system_name"], family["system_spec"], "the family")
