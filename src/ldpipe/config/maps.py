"""Configuration rules of LD maps and Poincaré sections that a JSON schema cannot say, for
Hamiltonian and vector-field systems alike (:func:`ldpipe.config.validate_config` calls them).

A Hamiltonian's map has an energy and a coordinate solved from it; a vector field's has neither,
only two state variables on the grid, the others fixed, and an optional start time ``t0``; a
discrete map's LD map counts ``iterations`` and has no time at all. On velocity data with a
calendar, ``t0`` may be a date and ``tau`` a duration, made numbers here before the other checks.
The checks every configuration module shares (an interval, names of other entries) are here too.
"""

from __future__ import annotations

from pathlib import Path

from ..errors import ConfigError
from ..core.maps.ftle import VARIATIONAL
from ..core.maps.grid import BOTH, DIRECTIONS
from ..core.maps.symmetry import SETTING_KEY
from ..systems import (is_discrete_map, is_vector_field, on_sphere, system_coordinates, system_data_files,
                       system_kind, system_phase_coordinates)
from ..systems.noise import check_noise
from ..systems.velocity_data import open_source
from ..systems.velocity_data.calendar import numeric_times

#: The sections whose entries take a start time ``t0`` (and an integration time ``tau``).
TIMED_SECTIONS = ("ld_maps", "poincare_sections")


def check_interval(value, key: str) -> None:
    """An interval [low, high] with low < high, or a ConfigError naming ``key``."""
    if not value[0] < value[1]:
        raise ConfigError(f"config key {key!r}: expected an interval [low, high] with low < high, got {value}")


def check_names(names: list[str], section: str, key: str, config: dict, noun: str | None = None) -> None:
    """Every name given at config key ``key`` is an entry of the config's ``section`` (``noun``: what
    such an entry is called in the error; default "<section> entry")."""
    for name in names:
        if name not in config[section]:
            # the section named too: with none declared, 'expected one of []' alone says not where to add one
            raise ConfigError(f"config key {key!r}: no {noun or section + ' entry'} {name!r}; expected one of "
                              f"{sorted(config[section])} (the entries under {section!r})")


def check_energy_surface_grid(spec: dict, key: str, grid: str, what: str) -> None:
    """A Hamiltonian's map or Poincaré section (``what``, for errors) starts on its energy surface:
    it has an energy, no start time, and its grid (the key ``grid``) names the coordinate solved
    from the energy."""
    if "energy" not in spec:
        raise ConfigError(f"config key '{key}.energy': {what} of the Hamiltonian system {spec['system']!r} needs an "
                          "energy (total or excess)")
    if "t0" in spec:
        raise ConfigError(f"config key '{key}.t0': system {spec['system']!r} is autonomous (a Hamiltonian); "
                          "a start time changes nothing, leave t0 out")
    if "solve" not in spec[grid]:
        raise ConfigError(f"config key '{key}.{grid}.solve': a grid on the energy surface of a Hamiltonian needs the "
                          "coordinate solved from the energy")


def numeric_calendar_times(config: dict) -> bool:
    """Each map's and Poincaré section's date ``t0`` and duration ``tau`` (text) made numbers in
    its system's time units (:func:`ldpipe.systems.velocity_data.calendar.numeric_times`; a
    ConfigError naming the key for a date on a system without a calendar); whether any was text
    (the numbers then to be validated as the schema says)."""
    changed = False
    for section in TIMED_SECTIONS:
        for name, entry in config.get(section, {}).items():
            t0 = entry.get("t0")
            times = [*t0.values()] if isinstance(t0, dict) else t0 if isinstance(t0, list) else [t0]
            if not any(isinstance(value, str) for value in [*times, entry.get("tau")]):
                continue
            system = config["systems"].get(entry["system"])
            if system is None:
                continue  # the entry's check names the missing system
            missing = [path for path in system_data_files(system) if not Path(path).exists()]
            if missing:
                given = "t0" if any(isinstance(value, str) for value in times) else "tau"
                raise ConfigError(f"config key '{section}.{name}.{given}': {entry[given]!r} is placed on the calendar "
                                  f"of the data's time coordinate, read from {missing[0]}, which does not exist yet (a "
                                  "file a rule makes is made after the configuration is read); give it as a number "
                                  "in the data's time units, or make the file first")
            source = (open_source(system["velocity_data"], f"systems.{entry['system']}.velocity_data")
                      if "velocity_data" in system else None)
            config[section][name] = numeric_times(entry, source, entry["system"], f"{section}.{name}")
            changed = True
    return changed


def given_map_keys(config) -> dict[str, dict[str, set]]:
    """The keys each ``ld_maps`` entry of an unvalidated ``config`` gives, and those of its
    ``integrator`` block, before the schema fills in its defaults: a discrete map's entry refuses
    a ``tau`` or an integrator setting given, and takes the defaults filled in silently."""
    maps = config.get("ld_maps") if isinstance(config, dict) else None
    if not isinstance(maps, dict):
        return {}
    return {name: {"entry": set(entry), "integrator": set(entry.get("integrator") or {})
                   if isinstance(entry.get("integrator"), dict) else set()}
            for name, entry in maps.items() if isinstance(entry, dict)}


def check_ld_maps(config: dict, given: dict[str, dict[str, set]] | None = None) -> None:
    """Every map: its system exists, its section splits the phase space (or state), tiles, region.

    ``given``: the keys each entry gave before defaults (:func:`given_map_keys`); None: every key
    it holds now."""
    for name, spec in config["ld_maps"].items():
        key = f"ld_maps.{name}"
        check_names([spec["system"]], "systems", f"{key}.system", config, "system")
        system = config["systems"][spec["system"]]
        if is_discrete_map(system):
            entry_given = (given or {}).get(name) or {"entry": set(spec), "integrator": set(spec["integrator"])}
            check_discrete_map(spec, key, system_coordinates(system), entry_given)
            continue
        if "iterations" in spec:
            raise ConfigError(f"config key '{key}.iterations': system {spec['system']!r} is a flow in time; its map "
                              "integrates over the time tau (iterations are of a discrete map)")
        if spec.get("chaos_indicators") is not None:
            raise ConfigError(f"config key '{key}.chaos_indicators': system {spec['system']!r} is a flow in time; "
                              "the LD chaos indicators are of a discrete map's LD map")
        coordinates = system_coordinates(system)
        phase = system_phase_coordinates(system)
        axes = [axis["name"] for axis in spec["section"]["axes"]]
        for index, axis in enumerate(spec["section"]["axes"]):
            check_interval(axis["range"], f"{key}.section.axes.{index}.range")
        if system_kind(system).stop_flags and spec.get("refine") is not None:
            raise ConfigError(f"config key '{key}.refine': an adaptive map refines on the fates of region exits and "
                              "escapes, not on land or the data's edge; give refine: null for a velocity-data map")
        if spec.get("ftle") and on_sphere(system) and len(coordinates) == 3:
            raise ConfigError(f"config key '{key}.ftle': system {spec['system']!r} is 3-D data on the sphere (its "
                              "velocity_data names w), whose FTLE would mix degrees of arc with the vertical "
                              "coordinate's units; it is not supported (on the plane it is)")
        check_flow_map_only(spec, key, is_vector_field(system))
        check_noisy_map(spec, key, system)
        check_variational_ftle(spec, key, system)
        check_structures(spec, key)
        check_directions(spec, key)
        if is_vector_field(system):
            check_vector_field_map(spec, key, phase)
            continue
        check_energy_surface_grid(spec, key, "section", "a map")
        named = [*axes, *spec["section"]["fixed"], spec["section"]["solve"]]
        if sorted(named) != sorted(phase):
            raise ConfigError(
                f"config key '{key}.section': the two axes, the fixed coordinates and the solved momentum must "
                f"name each of {list(phase)} exactly once; got axes {axes}, fixed {list(spec['section']['fixed'])}, "
                f"solve {spec['section']['solve']!r}"
            )
        if spec["section"]["solve"] in coordinates and "root" not in spec["section"]:
            raise ConfigError(
                f"config key '{key}.section.root': solving the position {spec['section']['solve']!r} needs the root "
                "to take: largest, smallest or {nearest: VALUE}"
            )
        check_tiles(spec, key)
        check_region(spec, key, coordinates)


def check_structures(spec: dict, key: str) -> None:
    """The fields a map's ``structures`` names must be fields the map holds."""
    block = spec.get("structures")
    if block and isinstance(spec.get("t0"), (list, dict)):
        raise ConfigError(f"config key '{key}.structures': the map has a start-time dimension (t0 is a list or a "
                          "range); structures are extracted from maps of one start time (give t0 a number)")
    if not isinstance(block, dict) or "fields" not in block:
        return
    directions = [label for _, label in DIRECTIONS[spec.get("directions", BOTH)]]
    held = ([f"ld_{label}" for label in directions] if spec.get("ld", True) else []) + (
        [f"ftle_{label}" for label in directions] if spec.get("ftle") else [])
    missing = [name for name in block["fields"] if name not in held]
    if missing:
        raise ConfigError(f"config key '{key}.structures.fields': the map holds no {missing} (it holds {held}); "
                          "give ftle: true for FTLE ridges, or name only the fields it holds")


def check_flow_map_only(spec: dict, key: str, vector_field: bool) -> None:
    """A map without its LD (``ld: false``) is a fixed-time map of a vector field with its FTLE."""
    if spec.get("ld", True):
        return
    if not spec.get("ftle"):
        raise ConfigError(f"config key '{key}.ld': a map without its LD holds only the flow map and its FTLE; "
                          "give ftle: true (or leave ld out)")
    if not vector_field:
        raise ConfigError(f"config key '{key}.ld': a map without its LD is of a vector-field system; system "
                          f"{spec['system']!r} is a Hamiltonian (leave ld out)")


def check_noisy_map(spec: dict, key: str, system: dict) -> None:
    """A map with noise: a fixed-time full LD map of a vector field or of velocity data on the plane,
    its noise block well formed (:func:`ldpipe.systems.noise.check_noise`)."""
    noise = spec.get("noise")
    if noise is None:
        return
    if not is_vector_field(system):
        raise ConfigError(f"config key '{key}.noise': noise is added to a vector field or velocity data; system "
                          f"{spec['system']!r} is a Hamiltonian")
    if on_sphere(system):
        raise ConfigError(f"config key '{key}.noise': system {spec['system']!r} is velocity data on the sphere, "
                          "whose state is in degrees; noise is supported on the plane only")
    for name, refused, why in (("time", spec["time"] != "fixed", "give time: fixed"),
                               ("refine", spec.get("refine") is not None, "give refine: null"),
                               ("ftle", bool(spec.get("ftle")), "leave ftle out"),
                               ("ld", not spec.get("ld", True), "leave ld out"),
                               ("structures", bool(spec.get("structures")),
                                "leave structures out (they are traced on one field, not on an ensemble)")):
        if refused:
            raise ConfigError(f"config key '{key}.{name}': a map with noise is a fixed-time map of the LD along "
                              f"each noisy path; {why}")
    check_noise(noise, system_coordinates(system), system.get("parameters") or {}, f"{key}.noise")


def check_directions(spec: dict, key: str) -> None:
    """A map of one direction (``directions``) has no backward fields to take from its forward ones."""
    directions = spec.get("directions", BOTH)
    if directions != BOTH and spec.get(SETTING_KEY) is True:
        raise ConfigError(f"config key '{key}.{SETTING_KEY}': true takes the backward fields from the forward ones, "
                          f"and the map integrates one direction (directions: {directions}); leave "
                          f"{SETTING_KEY} out, or give directions: {BOTH}")


def check_both_directions(config: dict, map_name: str, key: str, what: str) -> None:
    """A ConfigError naming ``key`` and the map's ``directions`` if map ``map_name``, which ``what``
    (a study, a figure) reads, integrates one direction of time and ``what`` needs both."""
    directions = config["ld_maps"][map_name].get("directions", BOTH)
    if directions != BOTH:
        raise ConfigError(f"config key {key!r}: map {map_name!r} integrates one direction of time (config key "
                          f"ld_maps.{map_name}.directions: {directions}), and {what} needs both; give the map "
                          f"directions: {BOTH}")


def check_variational_ftle(spec: dict, key: str, system: dict) -> None:
    """``ftle: variational`` integrates the variational equations of a vector field given by formulas."""
    if spec.get("ftle") != VARIATIONAL:
        return
    kind = system_kind(system)
    if not kind.formulas:
        raise ConfigError(f"config key '{key}.ftle': the variational FTLE needs the Jacobian of a vector field given by "
                          f"formulas; system {spec['system']!r} is {kind.noun}: give ftle: true (differences over "
                          "the grid)")
    if not is_vector_field(system):
        raise ConfigError(f"config key '{key}.ftle': the variational FTLE is of a vector field's map; on the energy "
                          f"surface of the Hamiltonian {spec['system']!r} the gradient along the section would also "
                          "need the solved coordinate's derivative, which is not implemented: give ftle: true "
                          "(differences over the grid)")


def check_region(spec: dict, key: str, coordinates: tuple[str, ...]) -> None:
    region = spec.get("region")
    if spec["time"] == "variable" and not region:
        raise ConfigError(f"config key '{key}.region': a variable-time map needs a saddle region (an interval per coordinate)")
    if spec.get("ftle") and spec["time"] == "variable":
        raise ConfigError(f"config key '{key}.ftle': the FTLE is of a fixed-time map (a flow map over the time tau); "
                          "give time: fixed")
    if spec.get("ftle") and spec.get("refine") is not None:
        raise ConfigError(f"config key '{key}.ftle': the FTLE differences end states of neighbouring pixels, which an "
                          "adaptive map interpolates; give refine: null for an FTLE map")
    if region:
        if sorted(region) != sorted(coordinates):
            raise ConfigError(f"config key '{key}.region': expected an interval for each of {list(coordinates)}, got {sorted(region)}")
        for coordinate, interval in region.items():
            check_interval(interval, f"{key}.region.{coordinate}")


def check_vector_field_map(spec: dict, key: str, state: tuple[str, ...]) -> None:
    """A map of a vector field: no energy, nothing solved, every state variable an axis or fixed."""
    section = spec["section"]
    # (the schema fills in sign: 1, meaningless without a solved coordinate)
    given = [f"{key}.{name}" for name in ("energy", "saddle_near") if name in spec]
    given += [f"{key}.section.{name}" for name in ("solve", "root", "search") if name in section]
    given += [f"{key}.section.sign"] if section.get("sign", 1) != 1 else []
    if given:
        raise ConfigError(f"config key '{given[0]}': system {spec['system']!r} is a vector field with no energy; its "
                          "map has two axes, every other state variable fixed, and no energy, saddle or solved coordinate")
    check_state_grid(spec, key, state)
    check_region(spec, key, state)


def check_state_grid(spec: dict, key: str, state: tuple[str, ...]) -> None:
    """A map's grid over a system's whole state, as a flow's or a discrete map's is: two axes and
    every other state variable fixed, each named once, the fixed ones numbers; its tiles."""
    section = spec["section"]
    axes = [axis["name"] for axis in section["axes"]]
    named = [*axes, *section["fixed"]]
    if sorted(named) != sorted(state):
        raise ConfigError(
            f"config key '{key}.section': the two axes and the fixed variables must name each of {list(state)} "
            f"(the state of system {spec['system']!r}) exactly once; got axes {axes}, fixed {list(section['fixed'])}"
        )
    if any(value == "saddle" for value in section["fixed"].values()):
        raise ConfigError(f"config key '{key}.section.fixed': system {spec['system']!r} has no saddle (it is no "
                          "Hamiltonian); give numbers")
    check_tiles(spec, key)


def check_tiles(spec: dict, key: str) -> None:
    """At most one tile per row of a map's first axis."""
    rows = spec["section"]["axes"][0]["points"]
    if rows < spec["tiles"]:
        raise ConfigError(f"config key '{key}.tiles': {spec['tiles']} tiles for {rows} rows; use at most one tile per "
                          "row of the first axis")


#: The keys of an ``ld_maps`` entry that a discrete map's LD map refuses, with why.
FLOW_ONLY_MAP_KEYS = {
    "energy": "a map has no energy", "saddle_near": "a map has no saddle", "t0": "a map has no time",
    "region": "a map's orbits stop only at the escape radius", "ftle": "a map has no flow map over a time",
    "refine": "a map's LD map is computed at every point", "quad_nodes": "a map's LD is a sum, not a quadrature",
    "ld": "a map's file is its LD", "backward_by_symmetry": "a map's backward half iterates its inverse",
    "noise": "noise is added to a flow's dx = f dt (a stochastic map of a map is not implemented)",
}


def drop_flow_defaults(config: dict) -> None:
    """Take out of each discrete map's ``ld_maps`` entry what the schema filled in for a flow in
    time (``tau``, ``time``, the integrator's settings but the escape radius), once
    :func:`check_ld_maps` has passed it: its parameters and file record only what a map reads,
    and validating the configuration again finds nothing it was not given."""
    for spec in config["ld_maps"].values():
        if is_discrete_map(config["systems"][spec["system"]]):
            for key in ("tau", "time"):
                spec.pop(key, None)
            spec["integrator"] = {"escape_radius": spec["integrator"]["escape_radius"]}


def check_discrete_map(spec: dict, key: str, state: tuple[str, ...], given: dict[str, set]) -> None:
    """An LD map of a discrete map: ``iterations`` instead of ``tau``, no time, energy or region,
    two axes and every other coordinate fixed; of the integrator's settings the escape radius alone."""
    system = spec["system"]
    where = f"system {system!r} is a discrete map"
    if "tau" in given["entry"]:
        raise ConfigError(f"config key '{key}.tau': {where}, iterated, not integrated over a time; give iterations "
                          "instead of tau")
    if "iterations" not in spec:
        raise ConfigError(f"config key '{key}.iterations': {where}; its LD sums over iterations: give iterations N "
                          "(the LD then runs over n from -N to N-1)")
    if "time" in given["entry"]:
        raise ConfigError(f"config key '{key}.time': {where}; every orbit runs its iterations (or escapes): leave "
                          "time out")
    for name, why in FLOW_ONLY_MAP_KEYS.items():
        if name in spec and not (name in ("refine", "noise") and spec[name] is None):
            raise ConfigError(f"config key '{key}.{name}': {where}, and {why}; leave {name} out")
    if spec.get("chaos_indicators") is not None and spec.get("directions", BOTH) != BOTH:
        raise ConfigError(f"config key '{key}.chaos_indicators': the indicators are of the LD's two halves summed, and "
                          f"the map computes one (directions: {spec.get('directions', BOTH)}); give directions: {BOTH}")
    other = sorted(given["integrator"] - {"escape_radius"})
    if other:
        raise ConfigError(f"config key '{key}.integrator.{other[0]}': {where}, iterated without an integrator; of "
                          "the integrator block it reads escape_radius alone")
    if spec["p"] == "arclength":
        raise ConfigError(f"config key '{key}.p': {where}; its LD is the p-norm sum over iterations, with p in "
                          "(0, 1]; the arc length is of a flow")
    section = spec["section"]
    solved = [name for name in ("solve", "root", "search") if name in section]
    solved += ["sign"] if section.get("sign", 1) != 1 else []
    if solved:
        raise ConfigError(f"config key '{key}.section.{solved[0]}': {where} with no energy; its section has two axes "
                          "and every other coordinate fixed, nothing solved")
    for index, axis in enumerate(section["axes"]):
        check_interval(axis["range"], f"{key}.section.axes.{index}.range")
    check_state_grid(spec, key, state)


def check_vector_field_poincare(config: dict, spec: dict, key: str) -> None:
    """A vector field's Poincaré section: no energy or saddle, initial conditions on a grid of two
    state variables with the others fixed, a surface x_i = value."""
    if is_discrete_map(config["systems"][spec["system"]]):
        raise ConfigError(f"config key '{key}.system': system {spec['system']!r} is a discrete map, whose orbits are "
                          "sequences of points already; a Poincaré section is of a flow in time")
    state = system_coordinates(config["systems"][spec["system"]])
    start = spec["initial_conditions"]
    given = [f"{key}.{name}" for name in ("energy", "saddle_near") if name in spec]
    given += [f"{key}.initial_conditions.solve"] if "solve" in start else []
    given += [f"{key}.initial_conditions.sign"] if start.get("sign", 1) != 1 else []
    if given:
        raise ConfigError(f"config key '{given[0]}': system {spec['system']!r} is a vector field with no energy; its "
                          "Poincaré section starts on a grid of two state variables, the others fixed")
    if spec["section"]["coordinate"] not in state:
        raise ConfigError(f"config key '{key}.section.coordinate': {spec['section']['coordinate']!r} is not a state "
                          f"variable; expected one of {list(state)}")
    for index, axis in enumerate(start["axes"]):
        check_interval(axis["range"], f"{key}.initial_conditions.axes.{index}.range")
    named = [axis["name"] for axis in start["axes"]] + list(start["fixed"])
    if sorted(named) != sorted(state):
        raise ConfigError(f"config key '{key}.initial_conditions': the two axes and the fixed variables must name "
                          f"each of {list(state)} (the state of system {spec['system']!r}) exactly once; got {named}")
