"""Configuration checks of the studies (orbits, NHIM, sampling, saddle flux, transport, accuracy) that a
JSON schema cannot say: references between entries resolve, systems are of the kind a stage needs,
energies are in the families named. :func:`ldpipe.config.validate_config` runs them.
"""

from __future__ import annotations

from ..errors import ConfigError
from ..systems import is_discrete_map, is_vector_field, system_coordinates
from ..systems.kinds import hamiltonian_kinds_text
from ..systems.kinetic import kinetic_matrix
from .maps import (check_both_directions, check_energy_surface_grid, check_interval, check_names,
                   check_vector_field_poincare)


def check_system_reference(config: dict, name: str, key: str) -> tuple[str, ...]:
    """The coordinates of the Hamiltonian system ``name`` a stage at ``key`` refers to (orbits,
    Hamiltonian Poincaré sections, potential figures: they need a Hamiltonian, a vector field is refused)."""
    check_names([name], "systems", key, config, "system")
    if is_vector_field(config["systems"][name]):
        noun = "a discrete map" if is_discrete_map(config["systems"][name]) else "a vector field"
        raise ConfigError(f"config key '{key}': system {name!r} is {noun} (no Hamiltonian); this stage needs "
                          f"a Hamiltonian system ({hamiltonian_kinds_text()})")
    return system_coordinates(config["systems"][name])


def check_saddle_near(spec: dict, coordinates: tuple[str, ...], key: str) -> None:
    near = spec.get("saddle_near")
    if near is not None and len(near) != len(coordinates):
        raise ConfigError(f"config key '{key}.saddle_near': expected {len(coordinates)} numbers ({list(coordinates)}), got {near}")


def check_saddle_study(config: dict, spec: dict, key: str, stage: str) -> None:
    """A study of a saddle of a 2 or 3 DoF Hamiltonian system (``spec["system"]``, ``saddle_near``)."""
    coordinates = check_system_reference(config, spec["system"], f"{key}.system")
    if len(coordinates) not in (2, 3):
        raise ConfigError(f"config key '{key}.system': the {stage} stage is for 2 and 3 DoF systems; "
                          f"{spec['system']!r} has {len(coordinates)}")
    check_saddle_near(spec, coordinates, key)


def check_surface(surface: dict, coordinates: tuple[str, ...], key: str, system: dict, system_key: str) -> None:
    phase = coordinates + tuple("p" + c for c in coordinates)
    if surface["coordinate"] not in phase:
        raise ConfigError(f"config key '{key}.coordinate': {surface['coordinate']!r} is not a phase coordinate; expected one of {list(phase)}")
    index = phase.index(surface["coordinate"]) - len(coordinates)
    matrix = kinetic_matrix(system, coordinates, system_key)
    if index >= 0 and matrix is not None and sum(v != 0.0 for v in matrix[index]) > 1:
        # the integrator locates crossings of M^-1 p's components (ldpipe.core.trajectories): p_i alone only if M's row i is diagonal
        raise ConfigError(
            f"config key '{key}.coordinate': crossings of the momentum {surface['coordinate']} are located for "
            f"diagonal masses only, and {system_key}.mass_matrix couples it to other momenta; use a coordinate"
        )


def check_map_manifolds(config: dict, spec: dict, key: str) -> None:
    """A manifold set of a discrete map's saddle fixed points: a map of two coordinates (whose
    saddles' manifolds are curves) with an inverse (the stable ones are iterated by it)."""
    check_names([spec["system"]], "systems", f"{key}.system", config, "system")
    system = config["systems"][spec["system"]]
    if not is_discrete_map(system):
        raise ConfigError(f"config key '{key}.system': system {spec['system']!r} is not a discrete map; the "
                          "manifolds of a flow's periodic orbit are an entry naming its family under 'orbits'")
    coordinates = system_coordinates(system)
    if len(coordinates) != 2:
        raise ConfigError(f"config key '{key}.system': map {spec['system']!r} has {len(coordinates)} coordinates; "
                          "the manifolds of a map's fixed points are grown as curves, for maps of two coordinates")
    if isinstance(system["map"], dict) and system.get("inverse") is None:
        raise ConfigError(f"config key 'systems.{spec['system']}.inverse': {key} iterates "
                          "the map backward for the stable manifolds, and the map gives no inverse; "
                          "give one formula per coordinate for x_n in terms of x_{n+1}")
    check_saddle_near(spec, coordinates, key)


def check_family_energies(config: dict, family: str, energies: dict, key: str) -> None:
    """Every energy asked of a family is one of its target energies (same kind, excess or total)."""
    targets = config["periodic_orbits"][family]["energies"]
    for kind, values in energies.items():
        for value in values if isinstance(values, list) else [values]:
            if kind not in targets or not any(abs(v - value) <= 1e-8 * max(1.0, abs(value)) for v in targets[kind]):
                raise ConfigError(
                    f"config key {key!r}: {kind} energy {value!r} is not among the energies of family {family!r} "
                    f"({targets}); add it there"
                )


def check_orbits(config: dict) -> None:
    """Periodic-orbit families, manifold sets and Poincaré sections: references and coordinates."""
    for name, spec in config["periodic_orbits"].items():
        key = f"periodic_orbits.{name}"
        coordinates = check_system_reference(config, spec["system"], f"{key}.system")
        check_saddle_near(spec, coordinates, key)
        if spec["center_mode"] > len(coordinates) - 2:
            raise ConfigError(
                f"config key '{key}.center_mode': {spec['center_mode']}, but an index-1 saddle of a {len(coordinates)} "
                f"DoF system has {len(coordinates) - 1} centre modes (0 to {len(coordinates) - 2})"
            )
    for name, spec in config["manifolds"].items():
        key = f"manifolds.{name}"
        if "system" in spec:
            check_map_manifolds(config, spec, key)
            continue
        check_names([spec["orbits"]], "periodic_orbits", f"{key}.orbits", config, "family")
        family = config["periodic_orbits"][spec["orbits"]]
        kind, value = next(iter(spec["energy"].items()))
        if kind not in family["energies"] or not any(
            abs(v - value) <= 1e-8 * max(1.0, abs(value)) for v in family["energies"][kind]
        ):
            raise ConfigError(
                f"config key '{key}.energy': {kind} energy {value!r} is not among the energies of family "
                f"{spec['orbits']!r} ({family['energies']}); add it there"
            )
        system = family["system"]
        check_surface(spec["section"], system_coordinates(config["systems"][system]), f"{key}.section",
                       config["systems"][system], f"systems.{system}")
    for name, spec in config["poincare_sections"].items():
        key = f"poincare_sections.{name}"
        if spec["system"] in config["systems"] and is_vector_field(config["systems"][spec["system"]]):
            check_vector_field_poincare(config, spec, key)
            continue
        coordinates = check_system_reference(config, spec["system"], f"{key}.system")
        check_energy_surface_grid(spec, key, "initial_conditions", "a Poincaré section")
        check_saddle_near(spec, coordinates, key)
        check_surface(spec["section"], coordinates, f"{key}.section", config["systems"][spec["system"]],
                       f"systems.{spec['system']}")
        start = spec["initial_conditions"]
        phase = coordinates + tuple("p" + c for c in coordinates)
        for index, axis in enumerate(start["axes"]):
            check_interval(axis["range"], f"{key}.initial_conditions.axes.{index}.range")
        named = [axis["name"] for axis in start["axes"]] + list(start["fixed"]) + [start["solve"]]
        if sorted(named) != sorted(phase) or start["solve"] not in phase[len(coordinates):]:
            raise ConfigError(
                f"config key '{key}.initial_conditions': the two axes, the fixed coordinates and the solved momentum "
                f"must name each of {list(phase)} exactly once, the solved one a momentum; got {named}"
            )
    for name, spec in config["saddle_flux"].items():
        check_saddle_study(config, spec, f"saddle_flux.{name}", "saddle-flux")


def check_nhim_sampling(config: dict) -> None:
    """NHIM sampling studies: the base map exists, is variable time and solves a momentum, and the grid
    names exactly its section's fixed coordinates."""
    for name, spec in config.get("nhim_sampling", {}).items():
        key = f"nhim_sampling.{name}"
        map_name = spec["base_map"]
        check_names([map_name], "ld_maps", f"{key}.base_map", config, "LD map")
        map_spec = config["ld_maps"][map_name]
        if map_spec["time"] != "variable":
            raise ConfigError(f"config key '{key}.base_map': map {map_name!r} is fixed time; NHIM sampling needs "
                              f"variable time (a saddle region)")
        check_both_directions(config, map_name, f"{key}.base_map", "NHIM sampling (forward and backward fates)")
        section = map_spec["section"]
        if not str(section["solve"]).startswith("p"):
            raise ConfigError(f"config key '{key}.base_map': map {map_name!r} solves {section['solve']!r}; NHIM "
                              f"sampling needs a section that solves a momentum")
        if sorted(spec["fixed"]) != sorted(section.get("fixed", {})):
            raise ConfigError(f"config key '{key}.fixed': expected exactly the fixed coordinates "
                              f"{sorted(section.get('fixed', {}))} of map {map_name!r}, got {sorted(spec['fixed'])}")
        for coordinate, axis in spec["fixed"].items():
            low, high = axis["range"]
            if not low <= high:
                raise ConfigError(f"config key '{key}.fixed.{coordinate}.range': expected [low, high] with "
                                  f"low <= high, got {axis['range']}")


def check_nhim(config: dict) -> None:
    """NHIM studies: maps and families exist, maps are variable time and of one system."""
    nhim = config["nhim"]
    refinement = nhim["refinement"]
    if not refinement["bisection_precision"] < refinement["tolerance"]:
        raise ConfigError(
            f"config key 'nhim.refinement.bisection_precision': {refinement['bisection_precision']} must be below "
            f"nhim.refinement.tolerance ({refinement['tolerance']})"
        )
    if refinement["zoom_points"] % 2 == 0:
        raise ConfigError(f"config key 'nhim.refinement.zoom_points': expected an odd number, got {refinement['zoom_points']}")
    for name, spec in nhim["studies"].items():
        key = f"nhim.studies.{name}"
        if ("maps" in spec) == ("derived" in spec):
            raise ConfigError(f"config key {key!r}: give either 'maps' (LD maps) or 'derived' (slices of one map)")
        maps = spec["maps"] if "maps" in spec else [spec["derived"]["base_map"]]
        where = f"{key}.maps" if "maps" in spec else f"{key}.derived.base_map"
        systems = set()
        for map_name in maps:
            check_names([map_name], "ld_maps", where, config, "LD map")
            if config["ld_maps"][map_name]["time"] != "variable":
                raise ConfigError(f"config key {where!r}: map {map_name!r} is fixed time; NHIM detection needs variable time")
            if is_vector_field(config["systems"][config["ld_maps"][map_name]["system"]]):
                raise ConfigError(f"config key {where!r}: map {map_name!r} is of a vector field (no energy); NHIM "
                                  "detection needs a Hamiltonian system's map")
            check_both_directions(config, map_name, where, "NHIM detection (the forward plus backward LD)")
            systems.add(config["ld_maps"][map_name]["system"])
        if len(systems) > 1:
            raise ConfigError(f"config key {where!r}: maps of several systems {sorted(systems)}; one system per study")
        if "derived" in spec:
            section = config["ld_maps"][maps[0]]["section"]
            for coordinate in spec["derived"]["fixed"]:
                if coordinate not in section["fixed"]:
                    raise ConfigError(
                        f"config key '{key}.derived.fixed.{coordinate}': not a fixed coordinate of map {maps[0]!r} "
                        f"(it fixes {sorted(section['fixed'])})"
                    )
            for axis, interval in spec["derived"]["ranges"].items():
                if axis not in [a["name"] for a in section["axes"]]:
                    raise ConfigError(f"config key '{key}.derived.ranges.{axis}': not an axis of map {maps[0]!r}")
                check_interval(interval, f"{key}.derived.ranges.{axis}")
        check_names(spec["reference"], "periodic_orbits", f"{key}.reference", config, "family")
        for family in spec["reference"]:
            if config["periodic_orbits"][family]["system"] not in systems:
                raise ConfigError(f"config key '{key}.reference': family {family!r} is of another system than the maps")
    for name, spec in nhim["orbit_validation"].items():
        check_nhim_orbit_validation(config, f"nhim.orbit_validation.{name}", spec)


def check_nhim_orbit_validation(config: dict, key: str, spec: dict) -> None:
    """An orbit validation study: its map is variable time, its families are of the map's system,
    its slice axes are a position and its momentum, its window's grid has a centre point, and its
    tolerance is no tighter than the refinement's."""
    map_name = spec["base_map"]
    check_names([map_name], "ld_maps", f"{key}.base_map", config, "LD map")
    if config["ld_maps"][map_name]["time"] != "variable":
        raise ConfigError(f"config key '{key}.base_map': map {map_name!r} is fixed time; the fates need its saddle region")
    check_both_directions(config, map_name, f"{key}.base_map", "the orbit validation (forward and backward fates)")
    system = config["ld_maps"][map_name]["system"]
    check_names(spec["orbits"], "periodic_orbits", f"{key}.orbits", config, "family")
    for family in spec["orbits"]:
        if config["periodic_orbits"][family]["system"] != system:
            raise ConfigError(f"config key '{key}.orbits': family {family!r} is not of the map's system {system!r}")
        # Energies given the same way (both total or both excess) are checked here; mixed ones, which
        # need the saddle's E_c, when the stage reads the family's file.
        (kind, wanted), = spec["energies"].items()
        computed = config["periodic_orbits"][family]["energies"].get(kind)
        missing = [e for e in wanted if computed is not None and not any(abs(e - c) <= 1e-9 * max(1, abs(e)) for c in computed)]
        if missing:
            raise ConfigError(f"config key '{key}.energies': family {family!r} has no orbit at {kind} energies {missing}; "
                              f"add them to periodic_orbits.{family}.energies")
    for axes in spec["slices"]:
        if axes[1] != "p" + axes[0]:
            raise ConfigError(f"config key '{key}.slices': expected a position and its momentum, e.g. [x, px]; got {axes}")
    if spec["points"] % 2 == 0:
        raise ConfigError(f"config key '{key}.points': expected an odd number (the orbit point a grid point), got {spec['points']}")
    if spec["tolerance"] < config["nhim"]["refinement"]["tolerance"]:
        raise ConfigError(f"config key '{key}.tolerance': {spec['tolerance']} is below nhim.refinement.tolerance "
                          f"({config['nhim']['refinement']['tolerance']}), the refined points' own accuracy")


def check_accuracy_cost(config: dict) -> None:
    """The accuracy-cost measurement: its maps and family exist, its integrator settings are complete."""
    spec = config.get("accuracy_cost")
    if spec is None:
        return
    check_names(spec["ld"]["maps"], "ld_maps", "accuracy_cost.ld.maps", config, "LD map")
    for map_name in spec["ld"]["maps"]:
        if is_vector_field(config["systems"][config["ld_maps"][map_name]["system"]]):
            raise ConfigError(f"config key 'accuracy_cost.ld.maps': map {map_name!r} is of a vector field; the "
                              "accuracy ladder's reference LD and energy errors need a Hamiltonian system")
    from ..engine import IntegratorSettings
    from ..engine.schemes import SCHEMES

    for name in ("reference", "reference_check"):
        setting = spec["ld"][name]
        try:
            IntegratorSettings.from_spec(setting)
        except ValueError:
            uses = "rtol (and atol), not dt" if SCHEMES[setting["scheme"]].adaptive else "dt, not rtol/atol"
            raise ConfigError(f"config key 'accuracy_cost.ld.{name}': {setting['scheme']} takes {uses}; got {setting}") from None
    for scheme, record in SCHEMES.items():
        tolerances = spec["ld"]["ladder"].get(scheme, {})
        if record.adaptive and "atol" in tolerances and len(tolerances["atol"]) != len(tolerances["rtol"]):
            raise ConfigError(
                f"config key 'accuracy_cost.ld.ladder.{scheme}.atol': {len(tolerances['atol'])} values for "
                f"{len(tolerances['rtol'])} rtol values; give one atol per rtol (or none: atol = rtol)"
            )
    family = spec["upo"]["family"]
    if family is not None:
        check_names([family], "periodic_orbits", "accuracy_cost.upo.family", config, "family")
    nhim_map = spec["nhim"]["map"]
    if nhim_map is not None:
        key = "accuracy_cost.nhim.map"
        check_names([nhim_map], "ld_maps", key, config, "LD map")
        check_both_directions(config, nhim_map, key, "the NHIM detection")
        map_spec = config["ld_maps"][nhim_map]
        if map_spec["time"] != "variable" or len(map_spec["section"]["fixed"]) != 1:
            raise ConfigError(
                f"config key {key!r}: map {nhim_map!r} must be variable time on a 2 DoF section (one fixed coordinate), "
                "where the periodic orbit's crossing is the exact NHIM point"
            )
        if family is None or config["periodic_orbits"][family]["system"] != map_spec["system"]:
            raise ConfigError(
                f"config key {key!r}: needs accuracy_cost.upo.family, a family of the map's system "
                f"{map_spec['system']!r}, for the exact NHIM point (the orbit's crossing); got {family!r}"
            )


def check_transport(config: dict) -> None:
    """Each transport study's family is a family of the configuration (the stage reads its file)."""
    for name, spec in (config.get("transport") or {}).items():
        check_names([spec["orbits"]], "periodic_orbits", f"transport.{name}.orbits", config, "family")


def check_transport_masses(config: dict) -> None:
    """The transport and saddle-flux stages take |p|^2/2 as the kinetic energy (their well volume,
    one-way flux and Monte Carlo sampling of momenta): a study of a system with masses is refused
    before anything runs."""
    studies = [(f"transport.{name}.orbits", config.get("periodic_orbits", {}).get(spec.get("orbits"), {}).get("system"))
               for name, spec in (config.get("transport") or {}).items()]
    studies += [(f"saddle_flux.{name}.system", spec.get("system")) for name, spec in (config.get("saddle_flux") or {}).items()]
    for key, system in studies:
        if system in config["systems"] and kinetic_matrix(config["systems"][system], system_coordinates(
                config["systems"][system]), f"systems.{system}") is not None:
            raise ConfigError(
                f"config key '{key}': the {key.split('.')[0].replace('_', '-')} stage is for unit masses; system "
                f"{system!r} has a kinetic matrix (systems.{system}.masses or .mass_matrix)"
            )


def check_normal_form(config: dict) -> None:
    """Normal-form studies: a 2 or 3 DoF Hamiltonian system, and compared studies of that system."""
    for name, spec in (config.get("normal_form") or {}).items():
        key = f"normal_form.{name}"
        check_saddle_study(config, spec, key, "normal-form")
        for section in ("transport", "saddle_flux"):
            if section in spec:
                check_names([spec[section]], section, f"{key}.{section}", config, f"{section} study")
                other = config[section][spec[section]]
                system = (config["periodic_orbits"][other["orbits"]]["system"] if section == "transport"
                          else other["system"])
                if system != spec["system"]:
                    raise ConfigError(f"config key '{key}.{section}': study {spec[section]!r} is of system "
                                      f"{system!r}, not {spec['system']!r}")
