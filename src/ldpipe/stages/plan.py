"""What the workflow plans with: the names of the files each stage reads, and how its work is
split into jobs, from a validated configuration alone.

Snakemake's input functions (``workflow/rules/common.smk``) call these for every job of every
plan, dry runs included; they live apart from the stages, which import the science they run
(the engine, scipy's integrators, sympy), so that planning imports none of it.
"""

from __future__ import annotations

from ..engine.codegen import engine_name
from ..engine.settings import IntegratorSettings, integrator_ladder
from ..core.maps.grid import ld_map_settings, map_start_times, paths_per_point
from ..config.parameters import parameters_from_config


def ld_map_tiles(config: dict, map_name: str) -> int:
    """How many tiles the map is split into: bands of rows (never more than its rows), for each
    start time of a map with several (:func:`ldpipe.core.maps.grid.map_start_times`)."""
    spec = config["ld_maps"][map_name]
    parameters = parameters_from_config(config, "ld", map_name)
    rows = parameters["section"]["axes"][0]["points"]
    return min(spec["tiles"], rows) * len(map_start_times(parameters) or [None])


def ld_map_points(config: dict, map_name: str) -> int:
    """The grid points of the map's file: the section's rows times its columns, for each start
    time of a map with several; for a map with noise, its paths (a path's fields cost what a
    point's do)."""
    parameters = parameters_from_config(config, "ld", map_name)
    axes = parameters["section"]["axes"]
    return (axes[0]["points"] * axes[1]["points"] * len(map_start_times(parameters) or [None])
            * paths_per_point(parameters))


def ld_tile_points(config: dict, map_name: str, tiles: int) -> int:
    """The grid points of the largest of the map's ``tiles`` tiles (what a tile job's memory and
    time limit are sized by). A map with several start times gives each start time
    ``tiles / starts`` bands (:func:`ldpipe.core.maps.grid.start_time_band`), so a tile is a band of
    one start time's grid, not ``1 / tiles`` of one start time's grid. A map with noise counts
    its paths (:func:`ldpipe.core.maps.grid.paths_per_point`)."""
    parameters = parameters_from_config(config, "ld", map_name)
    axes = parameters["section"]["axes"]
    rows, columns = axes[0]["points"], axes[1]["points"]
    bands = max(1, tiles // len(map_start_times(parameters) or [None]))
    # the widest band of tile_rows holds ceil(rows / bands) rows; a map with noise counts its paths
    return -(-rows // bands) * columns * paths_per_point(parameters)


def nhim_study_inputs(config: dict, study: str) -> dict[str, list[str]]:
    """Names the study reads: LD maps (``maps``), periodic-orbit families (``references``), and the system whose
    equilibria a derived study needs (``systems``)."""
    spec = config["nhim"]["studies"][study]
    systems = []
    if "derived" in spec:
        systems = [config["ld_maps"][spec["derived"]["base_map"]]["system"]]
    return {"maps": list(spec.get("maps", [])), "references": list(spec.get("reference", [])), "systems": systems}


def nhim_orbit_inputs(config: dict, study: str) -> dict[str, list[str]]:
    """Names the study reads: periodic-orbit families (``orbits``) and the system (``systems``)."""
    spec = config["nhim"]["orbit_validation"][study]
    return {"orbits": list(spec["orbits"]), "systems": [config["ld_maps"][spec["base_map"]]["system"]]}


def nhim_sampling_system(config: dict, study: str) -> str:
    """The system whose equilibria file the study reads (its base map's)."""
    return config["ld_maps"][config["nhim_sampling"][study]["base_map"]]["system"]


def accuracy_systems(config: dict) -> list[str]:
    """The systems whose equilibria files the measurement reads (sorted)."""
    spec = config["accuracy_cost"]
    systems = {config["ld_maps"][name]["system"] for name in spec["ld"]["maps"]}
    if spec["upo"]["family"]:
        systems.add(config["periodic_orbits"][spec["upo"]["family"]]["system"])
    if spec["nhim"]["map"]:
        systems.add(config["ld_maps"][spec["nhim"]["map"]]["system"])
    return sorted(systems)


def ladder_engines(ld: dict) -> dict[str, dict]:
    """The engine modules the LD ladder runs, by name (:func:`ldpipe.engine.codegen.engine_name`), each with
    the first map and ladder setting that needs it: ``{"map": parameters, "setting": spec}``.

    Several settings share a module (the tolerances of dop853, the steps of a fixed-step scheme,
    every composition: sym4 and sym6); the Taylor scheme has one per order. Compiling them in jobs of their own
    (:func:`ldpipe.stages.accuracy.run_accuracy_engine`) lets the cores share the compiles the ladder would do
    one by one.
    """
    steps = [IntegratorSettings.from_spec(ld["reference"]), IntegratorSettings.from_spec(ld["reference_check"]),
             *integrator_ladder(ld["ladder"])]
    engines = {}
    for parameters in ld["maps"].values():
        base = ld_map_settings(parameters)
        for step in steps:
            settings = step.apply(base)
            name = engine_name(parameters["system_name"], settings.scheme, settings.lanes, settings.order)
            spec = {"scheme": step.scheme, **{key: getattr(step, key) for key in step.record.parameters}}
            engines.setdefault(name, {"map": parameters, "setting": spec})
    return engines
