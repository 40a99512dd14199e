"""Configuration rules of LD maps and Poincaré sections that a JSON schema cannot say, for
Hamiltonian and vector-field systems alike (:func:`ldpipe.config.validate_config` calls them).

A Hamiltonian's map has an energy and a coordinate solved from it; a vector field's has neither,
only two state variables on the grid, the others fixed, and an optional start time ``t0``. The
checks every configuration module shares (an interval, names of other entries) are here too.
"""

from __future__ import annotations

from ..errors import ConfigError
from ..core.maps.ftle import VARIATIONAL
from ..core.maps.grid import BOTH
from ..core.maps.symmetry import SETTING_KEY
from ..systems import is_vector_field, on_sphere, system_coordinates, system_kind, system_phase_coordinates


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


def check_ld_maps(config: dict) -> None:
    """Every map: its system exists, its section splits the phase space (or state), tiles, region."""
    for name, spec in config["ld_maps"].items():
        key = f"ld_maps.{name}"
        check_names([spec["system"]], "systems", f"{key}.system", config, "system")
        system = config["systems"][spec["system"]]
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
        check_variational_ftle(spec, key, system)
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
        if spec["section"]["axes"][0]["points"] < spec["tiles"]:
            raise ConfigError(
                f"config key '{key}.tiles': {spec['tiles']} tiles for {spec['section']['axes'][0]['points']} rows; "
                "use at most one tile per row of the first axis"
            )
        check_region(spec, key, coordinates)


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
    axes = [axis["name"] for axis in section["axes"]]
    named = [*axes, *section["fixed"]]
    if sorted(named) != sorted(state):
        raise ConfigError(
            f"config key '{key}.section': the two axes and the fixed variables must name each of {list(state)} "
            f"(the state of system {spec['system']!r}) exactly once; got axes {axes}, fixed {list(section['fixed'])}"
        )
    if any(value == "saddle" for value in section["fixed"].values()):
        raise ConfigError(f"config key '{key}.section.fixed': a vector field's map has no saddle; give numbers")
    if section["axes"][0]["points"] < spec["tiles"]:
        raise ConfigError(f"config key '{key}.tiles': {spec['tiles']} tiles for {section['axes'][0]['points']} rows; "
                          "use at most one tile per row of the first axis")
    check_region(spec, key, state)


def check_vector_field_poincare(config: dict, spec: dict, key: str) -> None:
    """A vector field's Poincaré section: no energy or saddle, initial conditions on a grid of two
    state variables with the others fixed, a surface x_i = value."""
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
