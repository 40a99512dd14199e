"""Loading and validating the configuration against ``config.schema.yaml``.

Validation fills in the schema's defaults and turns every schema violation into
a :class:`~ldpipe.errors.ConfigError` that names the offending key and says
what is allowed there.
"""

from __future__ import annotations

import copy
import functools
import io
import re
from importlib import resources
from pathlib import Path

import jsonschema
import yaml

from .errors import ConfigError
from .config_maps import check_interval, check_ld_maps, check_vector_field_poincare
from .systems import check_builtin_parameters, is_vector_field, system_coordinates
from .systems.kinetic import kinetic_matrix

SCHEMA_RESOURCE = ("ldpipe.schemas", "config.schema.yaml")


def load_schema() -> dict:
    text = resources.files(SCHEMA_RESOURCE[0]).joinpath(SCHEMA_RESOURCE[1]).read_text()
    return yaml.safe_load(text)


@functools.lru_cache(maxsize=1)
def _schema_validator():
    # Parsing the schema costs ~0.3 s; stages and Snakemake's input functions validate often.
    # The validator copies defaults into the instance, so the cached schema is never modified.
    return _DefaultingValidator(load_schema())


def _extend_with_defaults(validator_class):
    """A validator that also writes each property's ``default`` into the instance."""
    validate_properties = validator_class.VALIDATORS["properties"]

    def properties_with_defaults(validator, properties, instance, schema):
        if isinstance(instance, dict):
            for name, subschema in properties.items():
                if "default" in subschema and name not in instance:
                    instance[name] = copy.deepcopy(subschema["default"])
        yield from validate_properties(validator, properties, instance, schema)

    return jsonschema.validators.extend(validator_class, {"properties": properties_with_defaults})


_DefaultingValidator = _extend_with_defaults(jsonschema.Draft202012Validator)


def _key(path) -> str:
    return ".".join(str(part) for part in path) or "(top level)"


def _allowed(schema: dict) -> str:
    """What a schema allows, in words."""
    parts = []
    if "enum" in schema:
        parts.append("one of " + ", ".join(repr(v) for v in schema["enum"]))
    if "type" in schema:
        parts.append(f"type {schema['type']}")
    for keyword, words in (
        ("minimum", ">="),
        ("exclusiveMinimum", ">"),
        ("maximum", "<="),
        ("exclusiveMaximum", "<"),
    ):
        if keyword in schema:
            parts.append(f"{words} {schema[keyword]}")
    if "minItems" in schema and schema.get("minItems") == schema.get("maxItems"):
        parts.append(f"exactly {schema['minItems']} items")
    if "pattern" in schema:
        parts.append(f"matching {schema['pattern']!r}")
    if "description" in schema:
        parts.append(schema["description"].strip())
    return "; ".join(parts)


def _describe(error: jsonschema.ValidationError) -> str:
    if error.validator == "additionalProperties" and isinstance(error.instance, dict):
        allowed = sorted(error.schema.get("properties", {}))
        extra = sorted(set(error.instance) - set(allowed))
        return f"config key {_key(error.absolute_path)!r}: unknown keys {extra}; allowed keys are {allowed}"
    if error.validator == "oneOf" and error.absolute_path and "systems" in error.absolute_path:
        return (
            f"config key {_key(error.absolute_path)!r}: a system needs exactly one of 'builtin', "
            "'formula' or 'vector_field' (a formula or vector field also needs 'coordinates')"
        )
    allowed = _allowed(error.schema)
    return f"config key {_key(error.absolute_path)!r}: {error.message}" + (f" (allowed: {allowed})" if allowed else "")


def _check_semantics(config: dict) -> None:
    """Rules a JSON schema cannot say: intervals ordered, box keys are coordinates."""
    for name, spec in config["systems"].items():
        coordinates = system_coordinates(spec)
        if "builtin" in spec:
            check_builtin_parameters(spec["builtin"], spec["parameters"], f"systems.{name}")
        kinetic_matrix(spec, coordinates, f"systems.{name}")
        equilibria = spec["equilibria"]
        check_interval(equilibria["default_interval"], f"systems.{name}.equilibria.default_interval")
        for coordinate, interval in equilibria["box"].items():
            key = f"systems.{name}.equilibria.box.{coordinate}"
            if coordinate not in coordinates:
                raise ConfigError(f"config key {key!r}: {coordinate!r} is not a coordinate of {name}; expected one of {list(coordinates)}")
            check_interval(interval, key)


def _check_system_reference(config: dict, name: str, key: str) -> tuple[str, ...]:
    """The coordinates of the Hamiltonian system ``name`` a stage at ``key`` refers to (orbits,
    Hamiltonian Poincaré sections, potential figures: they need a Hamiltonian, a vector field is refused)."""
    if name not in config["systems"]:
        raise ConfigError(f"config key '{key}': no system {name!r}; expected one of {sorted(config['systems'])}")
    if is_vector_field(config["systems"][name]):
        raise ConfigError(f"config key '{key}': system {name!r} is a vector field (no Hamiltonian); this stage needs "
                          "a Hamiltonian system ('builtin' or 'formula')")
    return system_coordinates(config["systems"][name])


def _check_saddle_near(spec: dict, coordinates: tuple[str, ...], key: str) -> None:
    near = spec.get("saddle_near")
    if near is not None and len(near) != len(coordinates):
        raise ConfigError(f"config key '{key}.saddle_near': expected {len(coordinates)} numbers ({list(coordinates)}), got {near}")


def _check_surface(surface: dict, coordinates: tuple[str, ...], key: str, system: dict, system_key: str) -> None:
    phase = coordinates + tuple("p" + c for c in coordinates)
    if surface["coordinate"] not in phase:
        raise ConfigError(f"config key '{key}.coordinate': {surface['coordinate']!r} is not a phase coordinate; expected one of {list(phase)}")
    index = phase.index(surface["coordinate"]) - len(coordinates)
    matrix = kinetic_matrix(system, coordinates, system_key)
    if index >= 0 and matrix is not None and sum(v != 0.0 for v in matrix[index]) > 1:
        # the integrator locates crossings of M^-1 p's components (ldpipe.flow): p_i alone only if M's row i is diagonal
        raise ConfigError(
            f"config key '{key}.coordinate': crossings of the momentum {surface['coordinate']} are located for "
            f"diagonal masses only, and {system_key}.mass_matrix couples it to other momenta; use a coordinate"
        )


def _check_orbits(config: dict) -> None:
    """Periodic-orbit families, manifold sets and Poincaré sections: references and coordinates."""
    for name, spec in config["periodic_orbits"].items():
        key = f"periodic_orbits.{name}"
        coordinates = _check_system_reference(config, spec["system"], f"{key}.system")
        _check_saddle_near(spec, coordinates, key)
        if spec["center_mode"] > len(coordinates) - 2:
            raise ConfigError(
                f"config key '{key}.center_mode': {spec['center_mode']}, but an index-1 saddle of a {len(coordinates)} "
                f"DoF system has {len(coordinates) - 1} centre modes (0 to {len(coordinates) - 2})"
            )
    for name, spec in config["manifolds"].items():
        key = f"manifolds.{name}"
        if spec["orbits"] not in config["periodic_orbits"]:
            raise ConfigError(
                f"config key '{key}.orbits': no family {spec['orbits']!r}; expected one of {sorted(config['periodic_orbits'])}"
            )
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
        _check_surface(spec["section"], system_coordinates(config["systems"][system]), f"{key}.section",
                       config["systems"][system], f"systems.{system}")
    for name, spec in config["poincare_sections"].items():
        key = f"poincare_sections.{name}"
        if spec["system"] in config["systems"] and is_vector_field(config["systems"][spec["system"]]):
            check_vector_field_poincare(config, spec, key)
            continue
        coordinates = _check_system_reference(config, spec["system"], f"{key}.system")
        if "energy" not in spec:
            raise ConfigError(f"config key '{key}.energy': a Poincaré section of the Hamiltonian system "
                              f"{spec['system']!r} needs an energy (total or excess)")
        if "t0" in spec:
            raise ConfigError(f"config key '{key}.t0': system {spec['system']!r} is autonomous (a Hamiltonian); "
                              "a start time changes nothing, leave t0 out")
        if "solve" not in spec["initial_conditions"]:
            raise ConfigError(f"config key '{key}.initial_conditions.solve': initial conditions of a Hamiltonian "
                              "need the momentum solved from the energy")
        _check_saddle_near(spec, coordinates, key)
        _check_surface(spec["section"], coordinates, f"{key}.section", config["systems"][spec["system"]],
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
        key = f"saddle_flux.{name}"
        coordinates = _check_system_reference(config, spec["system"], f"{key}.system")
        if len(coordinates) not in (2, 3):
            raise ConfigError(f"config key '{key}.system': the saddle-flux stage is for 2 and 3 DoF systems; "
                              f"{spec['system']!r} has {len(coordinates)}")
        _check_saddle_near(spec, coordinates, key)


def _check_nhim_sampling(config: dict) -> None:
    """NHIM sampling studies: the base map exists, is variable time and solves a momentum, and the grid
    names exactly its section's fixed coordinates."""
    for name, spec in config.get("nhim_sampling", {}).items():
        key = f"nhim_sampling.{name}"
        map_name = spec["base_map"]
        if map_name not in config["ld_maps"]:
            raise ConfigError(f"config key '{key}.base_map': no LD map {map_name!r}; expected one of "
                              f"{sorted(config['ld_maps'])}")
        map_spec = config["ld_maps"][map_name]
        if map_spec["time"] != "variable":
            raise ConfigError(f"config key '{key}.base_map': map {map_name!r} is fixed time; NHIM sampling needs "
                              f"variable time (a saddle region)")
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


def _check_nhim(config: dict) -> None:
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
            if map_name not in config["ld_maps"]:
                raise ConfigError(f"config key {where!r}: no LD map {map_name!r}; expected one of {sorted(config['ld_maps'])}")
            if config["ld_maps"][map_name]["time"] != "variable":
                raise ConfigError(f"config key {where!r}: map {map_name!r} is fixed time; NHIM detection needs variable time")
            if is_vector_field(config["systems"][config["ld_maps"][map_name]["system"]]):
                raise ConfigError(f"config key {where!r}: map {map_name!r} is of a vector field (no energy); NHIM "
                                  "detection needs a Hamiltonian system's map")
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
        for family in spec["reference"]:
            if family not in config["periodic_orbits"]:
                raise ConfigError(
                    f"config key '{key}.reference': no family {family!r} under periodic_orbits; expected one of "
                    f"{sorted(config['periodic_orbits'])}"
                )
            if config["periodic_orbits"][family]["system"] not in systems:
                raise ConfigError(f"config key '{key}.reference': family {family!r} is of another system than the maps")
    for name, spec in nhim["orbit_validation"].items():
        _check_nhim_orbit_validation(config, f"nhim.orbit_validation.{name}", spec)


def _check_nhim_orbit_validation(config: dict, key: str, spec: dict) -> None:
    """An orbit validation study: its map is variable time, its families are of the map's system,
    its slice axes are a position and its momentum, its window's grid has a centre point, and its
    tolerance is no tighter than the refinement's."""
    map_name = spec["base_map"]
    if map_name not in config["ld_maps"]:
        raise ConfigError(f"config key '{key}.base_map': no LD map {map_name!r}; expected one of {sorted(config['ld_maps'])}")
    if config["ld_maps"][map_name]["time"] != "variable":
        raise ConfigError(f"config key '{key}.base_map': map {map_name!r} is fixed time; the fates need its saddle region")
    system = config["ld_maps"][map_name]["system"]
    for family in spec["orbits"]:
        if family not in config["periodic_orbits"]:
            raise ConfigError(f"config key '{key}.orbits': no family {family!r} under periodic_orbits; expected one of "
                              f"{sorted(config['periodic_orbits'])}")
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


_FIGURE_REQUIRED = {
    "potential": ("system", "plane", "energies"),
    "section_maps": ("ld_maps",),
    "ld_slices": ("ld_maps",),
    "orbit_family": ("family",),
    "nhim_sample": ("sampling",),
}


def _check_names(names: list[str], section: str, key: str, config: dict) -> None:
    for name in names:
        if name not in config[section]:
            raise ConfigError(f"config key {key!r}: no {section} entry {name!r}; expected one of {sorted(config[section])}")


def _check_family_energies(config: dict, family: str, energies: dict, key: str) -> None:
    """Every energy asked of a family is one of its target energies (same kind, excess or total)."""
    targets = config["periodic_orbits"][family]["energies"]
    for kind, values in energies.items():
        for value in values if isinstance(values, list) else [values]:
            if kind not in targets or not any(abs(v - value) <= 1e-8 * max(1.0, abs(value)) for v in targets[kind]):
                raise ConfigError(
                    f"config key {key!r}: {kind} energy {value!r} is not among the energies of family {family!r} "
                    f"({targets}); add it there"
                )


def _check_figures(config: dict) -> None:
    """Figures: what each kind needs is there, and every stage output it names is declared."""
    for name, spec in config["figures"].items():
        key = f"figures.{name}"
        kind = spec["kind"]
        if spec.get("caption"):
            _check_caption(spec["caption"], f"{key}.caption")
        missing = [k for k in _FIGURE_REQUIRED[kind] if k not in spec]
        if missing:
            raise ConfigError(f"config key {key!r}: a figure of kind {kind!r} needs {missing}")
        if kind == "potential":
            coordinates = _check_system_reference(config, spec["system"], f"{key}.system")
            _check_saddle_near(spec, coordinates, key)
            named = [*spec["plane"], *spec["fixed"]]
            if sorted(named) != sorted(coordinates):
                raise ConfigError(
                    f"config key '{key}.plane': the plane's two coordinates and 'fixed' must name each of "
                    f"{list(coordinates)} exactly once; got plane {list(spec['plane'])}, fixed {list(spec['fixed'])}"
                )
            for coordinate, interval in spec["plane"].items():
                check_interval(interval, f"{key}.plane.{coordinate}")
        if kind in ("section_maps", "ld_slices"):
            _check_names(spec["ld_maps"], "ld_maps", f"{key}.ld_maps", config)
        if kind == "section_maps":
            _check_names(spec["poincare"], "poincare_sections", f"{key}.poincare", config)
            for map_name, sets in spec["manifold_curves"].items():
                if map_name not in spec["ld_maps"]:
                    raise ConfigError(f"config key '{key}.manifold_curves.{map_name}': not one of the figure's ld_maps {spec['ld_maps']}")
                _check_names(sets, "manifolds", f"{key}.manifold_curves.{map_name}", config)
        if kind == "ld_slices" and "orbit" in spec:
            family = spec["orbit"]["family"]
            _check_names([family], "periodic_orbits", f"{key}.orbit.family", config)
            if "energy" in spec["orbit"]:
                _check_family_energies(config, family, spec["orbit"]["energy"], f"{key}.orbit.energy")
            else:  # the orbit at each map's own energy
                for map_name in spec["ld_maps"]:
                    _check_family_energies(config, family, config["ld_maps"][map_name]["energy"],
                                           f"{key}.orbit (the energy of map {map_name!r})")
        if kind == "orbit_family":
            _check_names([spec["family"]], "periodic_orbits", f"{key}.family", config)
            if "energies" in spec:
                _check_family_energies(config, spec["family"], spec["energies"], f"{key}.energies")
            _check_names(spec["manifolds"], "manifolds", f"{key}.manifolds", config)
            for set_name in spec["manifolds"]:
                if config["manifolds"][set_name]["orbits"] != spec["family"]:
                    raise ConfigError(f"config key '{key}.manifolds': set {set_name!r} is of another family than {spec['family']!r}")
        if kind == "nhim_sample":
            _check_names([spec["sampling"]], "nhim_sampling", f"{key}.sampling", config)
            study = config["nhim_sampling"][spec["sampling"]]
            map_spec = config["ld_maps"][study["base_map"]]
            _check_names(spec["orbits"], "periodic_orbits", f"{key}.orbits", config)
            for family in spec["orbits"]:
                _check_family_energies(config, family, map_spec["energy"],
                                       f"{key}.orbits (the energy of study {spec['sampling']!r})")
            coordinates = system_coordinates(config["systems"][map_spec["system"]])
            phase = [*coordinates, *(f"p{c}" for c in coordinates)]
            for projection in spec["projections"]:
                unknown = [c for c in projection if c not in phase]
                if unknown or len(set(projection)) != 3:
                    raise ConfigError(f"config key '{key}.projections': {projection} must be three different phase "
                                      f"coordinates of {map_spec['system']} ({phase})")
        for axis, interval in spec.get("configuration", {}).items():
            check_interval(interval, f"{key}.configuration.{axis}")
        for limits_key in ("color_limits", "potential_range"):
            if spec.get(limits_key) is not None:
                check_interval(spec[limits_key], f"{key}.{limits_key}")
        low, high = spec.get("color_percentiles", (0, 100))
        if not low < high:
            raise ConfigError(f"config key '{key}.color_percentiles': expected [low, high] with low < high, got {[low, high]}")


def _check_caption(text: str, key: str) -> None:
    """A figure's caption is reStructuredText in the report: refuse one docutils cannot read cleanly
    (e.g. ``|v|``, a substitution reference), naming the key, before any stage runs."""
    from docutils.core import publish_doctree  # only a config with captions pays for the import

    messages = io.StringIO()
    publish_doctree(text, settings_overrides={"report_level": 2, "halt_level": 5, "warning_stream": messages})
    if messages.getvalue():
        said = " ".join(line.strip() for line in messages.getvalue().splitlines() if line.strip())
        raise ConfigError(f"config key '{key}': the caption is reStructuredText in the report and docutils "
                          f"reads it with complaints: {said}. Escape a literal | or * as \\| or \\*.")


def _check_accuracy_cost(config: dict) -> None:
    """The accuracy-cost measurement: its maps and family exist, its integrator settings are complete."""
    spec = config.get("accuracy_cost")
    if spec is None:
        return
    for map_name in spec["ld"]["maps"]:
        if map_name not in config["ld_maps"]:
            raise ConfigError(
                f"config key 'accuracy_cost.ld.maps': no LD map {map_name!r}; expected one of {sorted(config['ld_maps'])}"
            )
        if is_vector_field(config["systems"][config["ld_maps"][map_name]["system"]]):
            raise ConfigError(f"config key 'accuracy_cost.ld.maps': map {map_name!r} is of a vector field; the "
                              "accuracy ladder's reference LD and energy errors need a Hamiltonian system")
    from .engine import IntegratorSettings
    from .engine.schemes import SCHEMES

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
    if family is not None and family not in config["periodic_orbits"]:
        raise ConfigError(
            f"config key 'accuracy_cost.upo.family': no family {family!r}; expected one of {sorted(config['periodic_orbits'])}"
        )
    nhim_map = spec["nhim"]["map"]
    if nhim_map is not None:
        key = "accuracy_cost.nhim.map"
        if nhim_map not in config["ld_maps"]:
            raise ConfigError(f"config key {key!r}: no LD map {nhim_map!r}; expected one of {sorted(config['ld_maps'])}")
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


# A float as YAML 1.2 reads it. YAML 1.1 (PyYAML, and Snakemake's loader) needs a dot and a signed
# exponent, so it reads 1e-10 and 1e7 as strings; where the schema expects a number they are numbers.
_YAML12_FLOAT = re.compile(r"[-+]?(\.[0-9]+|[0-9]+(\.[0-9]*)?)([eE][-+]?[0-9]+)?")


def _number_strings(errors) -> list:
    """Paths of strings that YAML 1.2 reads as floats, found where the schema wanted a number."""
    paths = []
    for error in errors:
        types = error.validator_value if isinstance(error.validator_value, list) else [error.validator_value]
        if (error.validator == "type" and "number" in types and isinstance(error.instance, str)
                and _YAML12_FLOAT.fullmatch(error.instance.strip())):
            paths.append(tuple(error.absolute_path))
        paths += _number_strings(error.context or [])
    return paths


def _schema_errors(config: dict, validator) -> list:
    """The schema's errors, after turning in place each string such as '1e-10' into the float it
    means where a number is expected (one pass over a valid configuration)."""
    while True:
        errors = list(validator.iter_errors(config))
        paths = set(_number_strings(errors))
        if not paths:
            return errors
        for path in paths:
            parent = config
            for part in path[:-1]:
                parent = parent[part]
            parent[path[-1]] = float(parent[path[-1]])


def validate_config(config: dict) -> dict:
    """Validate ``config`` in place against the schema, fill defaults, and return it.

    Numbers written as YAML 1.1 reads them as strings (``1e-10``, ``1e7``) are converted to
    floats where the schema expects a number, so every loader's result validates alike.
    """
    if not isinstance(config, dict):
        raise ConfigError(f"the configuration must be a mapping of keys to values, got {type(config).__name__}")
    validator = _schema_validator()
    # The deepest error names the key most precisely: list those first.
    errors = sorted(_schema_errors(config, validator), key=lambda e: (-len(e.absolute_path), _key(e.absolute_path)))
    if errors:
        messages = [_describe(e) for e in errors]
        raise ConfigError("invalid configuration:\n  " + "\n  ".join(dict.fromkeys(messages)))
    _check_semantics(config)
    check_ld_maps(config)
    _check_orbits(config)
    _check_nhim_sampling(config)
    _check_figures(config)
    _check_nhim(config)
    _check_accuracy_cost(config)
    _check_transport_masses(config)
    return config


def _check_transport_masses(config: dict) -> None:
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


def load_config(path: str | Path) -> dict:
    """Read a YAML configuration file and validate it."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as error:
        raise ConfigError(f"{path}: cannot read the configuration ({error.strerror})") from None
    try:
        config = yaml.safe_load(text)
    except yaml.YAMLError as error:
        raise ConfigError(f"{path}: not valid YAML: {error}") from None
    try:
        return validate_config(config if config is not None else {})
    except ConfigError as error:
        raise ConfigError(f"{path}: {error}") from None
