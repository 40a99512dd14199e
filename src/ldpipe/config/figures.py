"""Configuration checks of the figures: what each kind needs, the stage outputs it names, and a
caption the report can render. :func:`ldpipe.config.validate_config` runs them.
"""

from __future__ import annotations

import copy
import io

from ..errors import ConfigError
from ..systems import system_coordinates
from ..core.maps.grid import BOTH
from .maps import check_interval, check_names
from .studies import check_family_energies, check_saddle_near, check_system_reference

FIGURE_REQUIRED = {
    "potential": ("system", "plane", "energies"),
    "section_maps": ("ld_maps",),
    "ld_slices": ("ld_maps",),
    "orbit_family": ("family",),
    "nhim_sample": ("sampling",),
    "ld_ftle": ("ld_maps",),
    "ld_animation": ("ld_maps",),
}

#: The settings of each kind (besides 'kind' and 'caption'); other keys of an entry are ignored.
KIND_SETTINGS = {
    "potential": ("system", "plane", "fixed", "saddle_near", "energies", "points", "levels", "surface",
                  "potential_range"),
    "section_maps": ("poincare", "ld_maps", "manifold_curves", "descriptor", "color_percentiles", "color_limits",
                     "point_size"),
    "ld_slices": ("ld_maps", "slices", "slice_through_orbit", "orbit", "configuration", "descriptor",
                  "color_percentiles", "color_limits", "view"),
    "orbit_family": ("family", "energies", "manifolds", "configuration", "view3d_axes", "view3d_limits",
                     "trajectories_per_branch", "view"),
    "nhim_sample": ("sampling", "orbits", "projections", "view"),
    "ld_ftle": ("ld_maps", "descriptor", "color_percentiles"),
    "ld_animation": ("ld_maps", "descriptor", "color_percentiles", "fps"),
}


def figure_settings(config: dict, name: str) -> dict:
    """The settings of figure ``name`` that its kind uses, defaults filled (a validated config)."""
    spec = config["figures"][name]
    return {key: copy.deepcopy(spec[key]) for key in ("kind", *KIND_SETTINGS[spec["kind"]]) if key in spec}



def check_figures(config: dict) -> None:
    """Figures: what each kind needs is there, and every stage output it names is declared."""
    for name, spec in config["figures"].items():
        key = f"figures.{name}"
        kind = spec["kind"]
        if spec.get("caption"):
            check_caption(spec["caption"], f"{key}.caption")
        missing = [k for k in FIGURE_REQUIRED[kind] if k not in spec]
        if missing:
            raise ConfigError(f"config key {key!r}: a figure of kind {kind!r} needs {missing}")
        if kind == "potential":
            coordinates = check_system_reference(config, spec["system"], f"{key}.system")
            check_saddle_near(spec, coordinates, key)
            named = [*spec["plane"], *spec["fixed"]]
            if sorted(named) != sorted(coordinates):
                raise ConfigError(
                    f"config key '{key}.plane': the plane's two coordinates and 'fixed' must name each of "
                    f"{list(coordinates)} exactly once; got plane {list(spec['plane'])}, fixed {list(spec['fixed'])}"
                )
            for coordinate, interval in spec["plane"].items():
                check_interval(interval, f"{key}.plane.{coordinate}")
        if kind in ("section_maps", "ld_slices", "ld_ftle", "ld_animation"):
            check_names(spec["ld_maps"], "ld_maps", f"{key}.ld_maps", config)
            check_descriptor_directions(config, spec, key)
        if kind in ("section_maps", "ld_slices", "ld_ftle"):
            for map_name in spec["ld_maps"]:
                if isinstance(config["ld_maps"][map_name].get("t0"), (list, dict)):
                    raise ConfigError(f"config key '{key}.ld_maps': map {map_name!r} has several start times "
                                      f"(config key ld_maps.{map_name}.t0); a figure of kind {kind!r} draws one, "
                                      "kind 'ld_animation' draws them all")
        if kind == "ld_animation":
            if len(spec["ld_maps"]) != 1:
                raise ConfigError(f"config key '{key}.ld_maps': an animation is of one map (its start times), "
                                  f"got {len(spec['ld_maps'])}")
            if not config["ld_maps"][spec["ld_maps"][0]].get("ld", True):
                raise ConfigError(f"config key '{key}.ld_maps': map {spec['ld_maps'][0]!r} has no LD to animate "
                                  f"(config key ld_maps.{spec['ld_maps'][0]}.ld is false)")
        if kind == "ld_ftle":
            for map_name in spec["ld_maps"]:
                if not config["ld_maps"][map_name].get("ld", True):
                    raise ConfigError(f"config key '{key}.ld_maps': map {map_name!r} has no LD to draw beside its "
                                      f"FTLE (config key ld_maps.{map_name}.ld is false)")
                if not config["ld_maps"][map_name].get("ftle"):
                    raise ConfigError(f"config key '{key}.ld_maps': map {map_name!r} has no FTLE to draw; give it "
                                      f"ftle: true (config key ld_maps.{map_name}.ftle)")
        if kind == "section_maps":
            check_names(spec["poincare"], "poincare_sections", f"{key}.poincare", config)
            for map_name, sets in spec["manifold_curves"].items():
                if map_name not in spec["ld_maps"]:
                    raise ConfigError(f"config key '{key}.manifold_curves.{map_name}': not one of the figure's ld_maps {spec['ld_maps']}")
                check_names(sets, "manifolds", f"{key}.manifold_curves.{map_name}", config)
        if kind == "ld_slices" and "orbit" in spec:
            family = spec["orbit"]["family"]
            check_names([family], "periodic_orbits", f"{key}.orbit.family", config)
            if "energy" in spec["orbit"]:
                check_family_energies(config, family, spec["orbit"]["energy"], f"{key}.orbit.energy")
            else:  # the orbit at each map's own energy
                for map_name in spec["ld_maps"]:
                    check_family_energies(config, family, config["ld_maps"][map_name]["energy"],
                                           f"{key}.orbit (the energy of map {map_name!r})")
        if kind == "orbit_family":
            check_names([spec["family"]], "periodic_orbits", f"{key}.family", config)
            if "energies" in spec:
                check_family_energies(config, spec["family"], spec["energies"], f"{key}.energies")
            check_names(spec["manifolds"], "manifolds", f"{key}.manifolds", config)
            for set_name in spec["manifolds"]:
                if config["manifolds"][set_name]["orbits"] != spec["family"]:
                    raise ConfigError(f"config key '{key}.manifolds': set {set_name!r} is of another family than {spec['family']!r}")
        if kind == "nhim_sample":
            check_names([spec["sampling"]], "nhim_sampling", f"{key}.sampling", config)
            study = config["nhim_sampling"][spec["sampling"]]
            map_spec = config["ld_maps"][study["base_map"]]
            check_names(spec["orbits"], "periodic_orbits", f"{key}.orbits", config)
            for family in spec["orbits"]:
                check_family_energies(config, family, map_spec["energy"],
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



def check_descriptor_directions(config: dict, spec: dict, key: str) -> None:
    """The LD a figure draws (``descriptor``: total, forward or backward) is of directions its maps
    integrated: a map of one direction (``directions``) is drawn with that descriptor."""
    descriptor = spec.get("descriptor", "total")
    for map_name in spec["ld_maps"]:
        directions = config["ld_maps"][map_name].get("directions", BOTH)
        if directions != BOTH and descriptor != directions:
            raise ConfigError(f"config key '{key}.descriptor': {descriptor} needs the map's {descriptor} LD"
                              + (" (forward plus backward)" if descriptor == "total" else "")
                              + f", and map {map_name!r} integrates {directions} time alone (config key "
                              f"ld_maps.{map_name}.directions: {directions}); give descriptor: {directions}, "
                              f"or the map directions: {BOTH}")


def check_caption(text: str, key: str) -> None:
    """A figure's caption is reStructuredText in the report: refuse one docutils cannot read cleanly
    (e.g. ``|v|``, a substitution reference), naming the key, before any stage runs.

    A caption is text, not a program: directives that read files or URLs (``include``, ``raw``
    with ``:file:``, ``csv-table`` with ``:file:`` or ``:url:``) or paste raw HTML are refused here,
    where docutils reads them switched off, so the report (whose docutils has them on) never
    meets one."""
    from docutils.core import (
        publish_doctree,  # only a config with captions pays for the import
    )

    messages = io.StringIO()
    publish_doctree(text, settings_overrides={"report_level": 2, "halt_level": 5, "warning_stream": messages,
                                              "file_insertion_enabled": False, "raw_enabled": False})
    if messages.getvalue():
        said = " ".join(line.strip() for line in messages.getvalue().splitlines() if line.strip())
        raise ConfigError(f"config key '{key}': the caption is reStructuredText in the report and docutils "
                          f"reads it with complaints: {said}. Escape a literal | or * as \\| or \\*.")
