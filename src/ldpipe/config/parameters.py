"""The parameters of every stage: the keyword arguments of its ``run_*`` function (besides paths
and threads), from a validated configuration.

Most stages take one entry of a configuration section the same way: the entry, copied, under
its name, with its system's name and spec (``system_spec``, what
:func:`ldpipe.systems.make_system` needs) in place of the ``system`` key, or, for an entry that
names a periodic-orbit family (``orbits``), the family's system. :data:`STAGES` says where each
stage's entries are and how each differs: a key taken from the family, keys that only steer the
workflow, an adjustment of the entry, or (equilibria, the NHIM studies, figures, the accuracy
measurement) a builder of its own. :func:`parameters_from_config` is the one way to get them:
for Snakemake (``workflow/rules/common.smk``, whose ``params:`` rerun a stage when they change),
the command line and tests.
"""

from __future__ import annotations

import copy
from collections.abc import Callable
from dataclasses import dataclass

from .figures import figure_settings
from ..systems import equilibrium_box, system_coordinates, system_spec


@dataclass(frozen=True)
class StageEntries:
    """Where a stage's entries are in the configuration, and how one becomes its parameters.

    ``section``: the keys leading to the entries (``("nhim", "studies")``); with ``name_key`` None
    the section itself is the one entry. ``name_key``: the keyword that carries the entry's name.
    ``system_via``: ``"system"`` (the entry names its system, and the key is replaced by
    ``system_name`` and ``system_spec``) or ``"orbits"`` (it names a periodic-orbit family, whose
    system is taken; ``from_family``: other keys taken from the family). ``drop``: keys that only
    steer the workflow. ``adjust(config, entry)``: changes the copied entry first. ``build(config,
    name, entry)``: a stage whose parameters are not the entry as it stands builds them itself.
    """

    section: tuple[str, ...]
    name_key: str | None
    system_via: str | None = "system"
    from_family: tuple[str, ...] = ()
    drop: tuple[str, ...] = ()
    adjust: Callable[[dict, dict], None] | None = None
    build: Callable[[dict, str | None, dict], dict] | None = None


def parameters_from_config(config: dict, stage: str, name: str | None = None) -> dict:
    """The parameters of ``stage`` (a module of :mod:`ldpipe.stages`, a key of :data:`STAGES`) for
    its entry ``name`` of the validated ``config`` (no name for ``accuracy``, whose section is one entry)."""
    entries = STAGES[stage]
    section = config
    for key in entries.section:
        section = section[key]
    entry = copy.deepcopy(section if entries.name_key is None else section[name])
    if entries.adjust is not None:
        entries.adjust(config, entry)
    if entries.build is not None:
        return entries.build(config, name, entry)
    if entries.system_via == "system":
        system, family = entry.pop("system"), {}
    else:
        family = config["periodic_orbits"][entry[entries.system_via]]
        system = family["system"]
    return {
        entries.name_key: name, "system_name": system, "system_spec": system_spec(config, system),
        **{key: family.get(key) for key in entries.from_family},
        **{key: value for key, value in entry.items() if key not in entries.drop},
    }


def _capped(points: int, config: dict) -> int:
    """A number of grid points under the configuration's ``max_grid_points`` cap (a quick run's)."""
    cap = config.get("max_grid_points")
    return min(points, cap) if cap else points


def _map_entry(config: dict, entry: dict) -> None:
    """An ld_maps entry as the stage takes it: the grid under the cap, a null refine block dropped."""
    for axis in entry["section"]["axes"]:
        axis["points"] = _capped(axis["points"], config)
    if entry.get("refine", False) is None:  # a full map, as if the block were left out
        del entry["refine"]


def _equilibria(config: dict, system_name: str, entry: dict) -> dict:
    settings = entry["equilibria"]
    return {
        "system_name": system_name,
        "system_spec": system_spec(config, system_name),
        "box": equilibrium_box(entry, system_coordinates(entry)),
        "seeds_per_axis": settings["seeds_per_axis"],
        "tolerance": settings["tolerance"],
    }


def _base_map(config: dict, name: str) -> dict:
    """A map's parameters as another stage uses them: its section, energy and settings, without how
    its own grid is sampled (``refine``), so that making a map adaptive reruns only the map."""
    parameters = parameters_from_config(config, "ld", name)
    parameters.pop("refine", None)
    return parameters


def _refinement(config: dict) -> dict:
    """``nhim.refinement`` without ``zoom`` (the NHIM study's alone), for the other stages that refine NHIM points."""
    return {k: v for k, v in config["nhim"]["refinement"].items() if k != "zoom"}


def _nhim_study(config: dict, study: str, entry: dict) -> dict:
    parameters = {"study": study, "refinement": copy.deepcopy(config["nhim"]["refinement"]),
                  "references": entry.get("reference", [])}
    if "derived" in entry:
        derived = entry["derived"]
        base = _base_map(config, derived["base_map"])
        points = _capped(derived["points"], config)
        slices = []
        for coordinate, values in derived["fixed"].items():
            for value in values:
                for excess in derived["excess_energies"]:
                    slice_map = copy.deepcopy(base)
                    slice_map["map_name"] = f"{coordinate}{value:g}_dE{excess:g}"
                    slice_map["section"]["fixed"][coordinate] = value
                    slice_map["energy"] = {"excess": excess}
                    for axis in slice_map["section"]["axes"]:
                        axis["points"] = points
                        if axis["name"] in derived.get("ranges", {}):
                            axis["range"] = derived["ranges"][axis["name"]]
                    slices.append(slice_map)
        parameters["derived"] = slices
    return parameters


def _odd(points: int) -> int:
    """The largest odd number <= points (the window's centre must be a grid point)."""
    return points if points % 2 else points - 1


def _nhim_orbits(config: dict, study: str, entry: dict) -> dict:
    base = entry.pop("base_map")
    points = _odd(_capped(entry["points"], config)) if config.get("max_grid_points") else entry["points"]
    return {"study": study, "base_map": _base_map(config, base), "refinement": _refinement(config),
            **entry, "points": points}


def _nhim_sampling(config: dict, study: str, entry: dict) -> dict:
    base_map = _base_map(config, entry["base_map"])
    # The map's own grid is never computed here; the whole window is searched on seed_points^2, so
    # that stands in for it (and the map's resolution, or a quick run's cap, does not rerun the study).
    for axis in base_map["section"]["axes"]:
        axis["points"] = entry["seed_points"]
    window = entry["window"]
    return {
        "study": study,
        "base_map": base_map,
        "fixed": entry["fixed"],
        "signs": entry["signs"],
        "sampling": {"window_points": window["points"], "window_half_width": window["half_width"],
                     "widen": window["widen"], "max_widenings": window["max_widenings"],
                     "seed_points": entry["seed_points"], "min_angle": entry["min_angle"],
                     "min_momentum": entry["min_momentum"], "batch": entry["batch"]},
        "refinement": _refinement(config),
    }


def _structures(config: dict, name: str, entry: dict) -> dict:
    """A map's ``structures`` block (true: every default) as the structures stage's parameters."""
    block = entry.get("structures")
    if not block:
        raise ValueError(f"map {name!r} has no structures: block; its file has no structures to extract")
    return {"map_name": name, **({} if block is True else block)}


def _manifolds(config: dict, name: str, entry: dict) -> dict:
    """A manifold set names a periodic-orbit family (``orbits``, whose system it takes) or, for
    the fixed points of a discrete map, its ``system``."""
    system = entry.pop("system") if "system" in entry else config["periodic_orbits"][entry["orbits"]]["system"]
    return {"name": name, "system_name": system, "system_spec": system_spec(config, system), **entry}


def _figure(config: dict, name: str, entry: dict) -> dict:
    # The settings the drawing reads; the caption, which the report alone prints, is added by
    # ldpipe.stages.figures.figure_parameters (it reads other stages' parameters from here).
    return {"figure_name": name, "kind": entry["kind"], "settings": figure_settings(config, name)}


def _accuracy(config: dict, _: None, entry: dict) -> dict:
    """Each sampled map's full parameters (as the ld stage gets them, grid cap applied) and the
    orbit family's are included, so that changing any of them reruns the measurement."""
    ld, orbit, nhim = entry["ld"], entry["upo"], entry["nhim"]
    maps = {name: _base_map(config, name) for name in ld.pop("maps")}
    family = orbit.pop("family")
    nhim_map = nhim.pop("map")
    return {
        "ld": {**ld, "maps": maps},
        "upo": {**orbit, "family": parameters_from_config(config, "upo", family) if family else None},
        "nhim": {
            **nhim, "map": _base_map(config, nhim_map) if nhim_map else None,
            "refinement": _refinement(config),
        },
    }


#: How each stage's parameters come from the configuration, by stage module (``ldpipe.stages.NAME``).
STAGES: dict[str, StageEntries] = {
    "equilibria": StageEntries(("systems",), "system_name", build=_equilibria),
    "ld": StageEntries(("ld_maps",), "map_name", drop=("tiles", "structures"), adjust=_map_entry),
    "structures": StageEntries(("ld_maps",), "map_name", build=_structures),
    "upo": StageEntries(("periodic_orbits",), "family"),
    "manifolds": StageEntries(("manifolds",), "name", build=_manifolds),
    "poincare": StageEntries(("poincare_sections",), "name"),
    "nhim": StageEntries(("nhim", "studies"), "study", build=_nhim_study),
    "nhim_orbits": StageEntries(("nhim", "orbit_validation"), "study", build=_nhim_orbits),
    "nhim_sampling": StageEntries(("nhim_sampling",), "study", build=_nhim_sampling),
    "saddle_flux": StageEntries(("saddle_flux",), "name"),
    "normal_form": StageEntries(("normal_form",), "name"),
    "transport": StageEntries(("transport",), "name", system_via="orbits", from_family=("saddle_near",)),
    "figures": StageEntries(("figures",), "figure_name", build=_figure),
    "accuracy": StageEntries(("accuracy_cost",), None, build=_accuracy),
}
