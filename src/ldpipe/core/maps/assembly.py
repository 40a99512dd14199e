"""An LD map assembled as its stage file holds it: bands of start times, tiles of rows, the
adaptive, grid and FTLE variants, backward fields mirrored by a reversing symmetry, the map's
attributes and units, and the gathering of tiles into the whole map.

A map is declared under ``ld_maps:`` in the configuration (see the schema); its parameters are
:func:`ldpipe.config.parameters.parameters_from_config`'s. Its energy may be given as excess
energy over the critical energy of an index-1 saddle, and its fixed coordinates as ``saddle``
(the saddle's value), both read from the system's equilibria. :func:`ld_map_dataset` is the
whole map; :func:`ld_map_tile` and :func:`gather_ld_map` the same map in tiles, each a job of
the workflow. Each returns the Dataset its file holds (:func:`ldpipe.io.datafile.stage_dataset`).
A discrete map's LD map (:mod:`ldpipe.core.maps.discrete`) is tiled, gathered and recorded the same way.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import xarray as xr

from ...engine import LDSettings, use_threads
from ...engine.integrands import descriptor_attribute, is_arclength
from ...engine.settings import engine_escape_radius
from ...errors import ConfigError
from ...io.contracts import FLOW_MAP, FLOW_MAP_TILE, LD_GRID, LD_TILE
from ...io.datafile import MANAGED_ATTRIBUTES, stage_dataset, stage_parameters
from ...logs import get_logger, warn_user
from ...systems import is_discrete_map, on_sphere, system_phase_coordinates
from ...systems.velocity_data import calendar_attributes
from ..equilibria.potential import select_saddle
from .adaptive import RefineSettings, adaptive_ld_dataset
from .chaos import add_map_classification
from .discrete import discrete_ld_dataset
from .budget import BASE_MB, BYTES_PER_POINT, band_memory_mb, fewest_tiles, machine_memory_mb
from .ftle import VARIATIONAL
from .grid import (BOTH, DIRECTIONS, MIRROR_UNUSED, TIME_UNITS, add_ftle, add_variational_ftle, directions_setting,
                   gather_tiles, ld_grid_dataset, map_directions, map_start_times, paths_per_point, resolve_ld_map,
                   start_time_band, tile_rows)
from .stochastic import noise_attributes, resolve_noise, stochastic_grid_dataset
from .symmetry import AUTO, SETTING_KEY, MapMirror, map_mirror

log = get_logger(__name__)


def resolve_map(parameters: dict, equilibria: xr.Dataset | None) -> tuple:
    """The system, section, engine settings and energies a map's parameters describe, at the saddle
    its ``saddle_near`` selects in the equilibria file (see :func:`ldpipe.core.maps.grid.resolve_ld_map`).

    ``equilibria`` None: a map of a vector-field system, which has no energy and no saddle to select.
    """
    if equilibria is None:
        return resolve_ld_map(parameters, None, None)
    saddle, critical_energy = select_saddle(equilibria, parameters.get("saddle_near"))
    return resolve_ld_map(parameters, saddle, critical_energy)


def _attributes(parameters: dict, settings: LDSettings, info: dict, escape_radius: float) -> dict:
    """Scalar settings as attributes, so a reader sees them without parsing JSON (a vector field's
    map has no energies; it has its start time ``t0``). ``escape_radius`` is the one the engine
    used (raised for velocity data, :func:`ldpipe.engine.settings.engine_escape_radius`)."""
    common = {**_common_attributes(parameters, settings, info), "escape_radius": escape_radius}
    if info["energy"] is None:
        return {**common, "t0": info["t0"]}
    return {
        **common,
        "energy": info["energy"],
        "excess_energy": info["excess_energy"],
        "critical_energy": info["critical_energy"],
    }


def _common_attributes(parameters: dict, settings: LDSettings, info: dict) -> dict:
    return {
        "map": parameters["map_name"],
        "system": parameters["system_name"],
        "saddle_position": np.asarray(info["saddle"]),
        "tau": settings.tau,
        # a map without its LD (ld: false) holds the flow map and its FTLE only
        "descriptor": descriptor_attribute(settings.p) if parameters.get("ld", True) else "none",
        "time_mode": parameters["time"],
        # the directions of time integrated (a map of one has only that direction's variables)
        "directions": directions_setting(parameters),
        "region_lower": np.asarray(settings.region_lower if settings.region_lower else []),
        "region_upper": np.asarray(settings.region_upper if settings.region_upper else []),
        "scheme": settings.scheme,
        "rtol": settings.rtol,
        "atol": settings.atol,
        "dt": settings.dt,
        # the Taylor scheme's order in use (0: another scheme), default resolved from the tolerance
        "taylor_order": settings.order or 0,
        # the LD quadrature's settings in use (defaults resolved from scheme and rtol)
        "quadrature_window": settings.quadrature_window,
        "quad_nodes": settings.nodes,
    }


#: The attribute a map without any energetically allowed point carries (see :func:`note_allowed_points`).
EMPTY_MAP_WARNING = "warning"


def note_allowed_points(dataset: xr.Dataset, *, whole_map: bool) -> int:
    """Record how many points of ``dataset`` are energetically allowed (attribute ``allowed_points``);
    a whole map with none is empty: warn the user (once: only the whole map warns, not its tiles),
    and say so in the attribute ``warning``."""
    count = int(dataset.allowed.sum())
    dataset.attrs["allowed_points"] = count
    dataset.attrs.pop(EMPTY_MAP_WARNING, None)
    if whole_map and count == 0:
        energy = dataset.attrs.get("energy")
        text = (f"map {dataset.attrs.get('map')!r} is empty: no point of its section is energetically allowed at "
                f"E = {energy:.12g}, where the potential is above the energy everywhere on the section, so every "
                "value is missing (NaN). Raise the energy or move the section")
        warn_user(log, text)
        dataset.attrs[EMPTY_MAP_WARNING] = text
    return count


def compute_ld_map(
    parameters: dict,
    equilibria: xr.Dataset,
    *,
    tile: int = 0,
    tiles: int = 1,
    threads: int | None = None,
    show_progress: bool | None = True,
    rows: slice | None = None,
) -> xr.Dataset:
    """One tile (or, with ``tiles`` 1, the whole) of an LD map, with its attributes.

    ``rows``: the band of first-axis rows to compute instead of the tile's (a block of the Dask
    backend, :mod:`ldpipe.core.maps.lazy`, possibly empty); it is never the whole map, so the FTLE
    by differences is left to whoever joins the bands, and it is not piloted
    (:func:`ldpipe.core.maps.pilot.check_map_time`: a block's time says nothing of the map's)."""
    use_threads(threads)
    if is_discrete_map(parameters["system_spec"]):  # iterated, not integrated: no time, energy or engine settings
        dataset = discrete_ld_dataset(parameters, tile=tile, tiles=tiles)
        note_allowed_points(dataset, whole_map=False)  # the whole map warns (finish_ld_map)
        return dataset
    starts = map_start_times(parameters)
    if starts is not None:  # several start times: this tile is a band of one of them, given a t0 dimension
        index, band, bands = start_time_band(starts, tile, tiles)
        dataset = compute_ld_map({**parameters, "t0": starts[index]}, equilibria, tile=band, tiles=bands,
                                 show_progress=show_progress, rows=rows)
        dataset = dataset.expand_dims(t0=[starts[index]])
        dataset.attrs.pop("t0")
        dataset.attrs.update({"tile": tile, "tiles": tiles})
        return dataset
    system, section, settings, info = resolve_map(parameters, equilibria)
    block, whole_map = rows is not None, tiles == 1 and rows is None
    rows = tile_rows(section.shape[0], tile, tiles) if rows is None else rows
    # a map with noise holds every member's fields: a path costs what a point does
    members = paths_per_point(parameters)
    check_band_memory(parameters["map_name"], (rows.stop - rows.start) * section.shape[1] * members,
                      section.shape[0] * section.shape[1] * members,
                      what="grid points" if members == 1 else f"noisy paths ({members} members a grid point)")
    where = (f"t0 = {info['t0']:.12g}" if info["energy"] is None
             else f"E = {info['energy']:.12g} (dE = {info['excess_energy']:.6g})")
    log.info(
        "map %s, tile %d of %d (rows %d:%d of %d): %s at %s, tau = %g, %s time, %s",
        parameters["map_name"], tile + 1, tiles, rows.start, rows.stop, section.shape[0], system.name,
        where, settings.tau, parameters["time"], settings.scheme,
    )
    ftle = parameters.get("ftle", False)
    noisy = parameters.get("noise") is not None
    if noisy:  # an ensemble of noisy paths per point (ldpipe.core.maps.stochastic)
        noise, stochastic = resolve_noise(parameters, system)
        dataset = stochastic_grid_dataset(system, section, settings, noise, stochastic, rows=rows, t0=info["t0"],
                                          directions=directions_setting(parameters))
    elif parameters.get("refine") is not None:  # an adaptive map (ldpipe.core.maps.adaptive); never an FTLE map
        refine = RefineSettings.from_config(parameters["refine"])
        dataset = adaptive_ld_dataset(system, section, info["energy"], settings, refine, rows=rows,
                                      show_progress=show_progress, t0=info["t0"],
                                      directions=directions_setting(parameters))
    else:
        dataset = ld_grid_dataset(system, section, info["energy"], settings, rows=rows, show_progress=show_progress,
                                  t0=info["t0"], flow_map=bool(ftle), descriptor=parameters.get("ld", True),
                                  mirror=backward_mirror(parameters, system, section),
                                  directions=directions_setting(parameters),
                                  label=None if block else f"map {parameters['map_name']}, tile {tile + 1} of {tiles}")
    if system.time_units:  # the FTLE's units are per it
        dataset.attrs[TIME_UNITS] = system.time_units
    if ftle == VARIATIONAL:  # each point's own trajectory: every tile computes its own points
        add_variational_ftle(dataset, system, section, rows, settings.tau, info["t0"],
                             rtol=settings.rtol, atol=settings.atol)
    elif ftle and whole_map:
        add_ftle(dataset, system.phase_coordinates, settings.tau, on_sphere(parameters["system_spec"]), section.solve)
    dataset.attrs.update(_attributes(parameters, settings, info, engine_escape_radius(system, settings.escape_radius)))
    if noisy:  # the SDE scheme's settings in place of the deterministic integrator's
        for name in ("rtol", "atol", "taylor_order", "quadrature_window", "quad_nodes"):
            dataset.attrs.pop(name)
        dataset.attrs.update(noise_attributes(noise, stochastic, settings.tau))
    dataset.attrs.update({"tile": tile, "tiles": tiles})
    dataset.attrs.update(system.kinetic_attributes())
    dataset.attrs.update(getattr(system, "grid_attributes", dict)())  # velocity data's metrics, if any
    add_ld_units(dataset, system, settings.p)
    note_allowed_points(dataset, whole_map=False)  # the whole map warns (finish_ld_map), not each tile or block
    return dataset


def check_band_memory(map_name: str, points: int, map_points: int, available_mb: int | None = None,
                      what: str = "grid points") -> None:
    """A ConfigError naming the map's ``tiles`` if a band of ``points`` grid points (or ``what``
    they are: a map with noise counts its paths) needs more memory than this machine has
    (``available_mb``, default its physical memory): refused before any trajectory is integrated,
    with the estimate and the tiles that would fit."""
    available_mb = machine_memory_mb() if available_mb is None else available_mb
    need = band_memory_mb(points)
    if available_mb is None or need <= available_mb:
        return
    tiles = fewest_tiles(map_points, available_mb)
    fix = (f"give tiles: {tiles} or more (the workflow runs each as a job of its own), or fewer points"
           if tiles else "give fewer points")
    raise ConfigError(f"config key 'ld_maps.{map_name}.tiles': a band of {points} {what} needs about "
                      f"{need} MB ({BYTES_PER_POINT} bytes a point and {BASE_MB} MB for the process), more than "
                      f"this machine's {available_mb} MB; {fix}")


def backward_mirror(parameters: dict, system, section) -> MapMirror | None:
    """The reversing symmetry whose mirror gives the map's backward fields
    (:mod:`ldpipe.core.maps.symmetry`), as its ``backward_by_symmetry`` key asks: ``auto`` (left out)
    where one is found, ``true`` required (ConfigError naming the key if none), ``false`` never."""
    setting = parameters.get(SETTING_KEY, AUTO)
    if setting is False:
        return None
    directions = directions_setting(parameters)
    if directions != BOTH:
        mirror, reason = None, f"the map integrates one direction (directions: {directions})"
    elif parameters["time"] != "fixed":
        mirror, reason = None, "the map is variable-time (only fixed-time maps are mirrored)"
    elif parameters.get("refine") is not None or parameters.get("ftle", False) or not parameters.get("ld", True):
        mirror, reason = None, "the map is adaptive or keeps its flow map (only a full LD map's fields are mirrored)"
    elif not system.hamiltonian:
        mirror, reason = None, f"system {system.name!r} is a vector field (no Hamiltonian's reversing symmetry)"
    else:
        mirror, reason = map_mirror(system, section)
    if mirror is None and setting is True:
        raise ConfigError(f"config key 'ld_maps.{parameters['map_name']}.{SETTING_KEY}': true, but {reason}; "
                          f"give {SETTING_KEY}: auto or false to integrate backward")
    if mirror is not None:
        log.info("map %s: backward fields by the reversing symmetry %s", parameters["map_name"], mirror.description)
    return mirror


def add_ld_units(dataset: xr.Dataset, system, p) -> None:
    """The LD variables' ``units``, where the system names them (velocity data on the sphere: km
    for the arc length, the data's velocity units for M_p); other maps' LDs are in their state's units."""
    units = system.ld_units(is_arclength(p), p)
    if units:
        for name in ("ld_forward", "ld_backward"):
            if name in dataset:
                dataset[name].attrs["units"] = units


def map_contract(parameters: dict, *, tile_file: bool):
    """The contract of a map's tile or whole file: an LD map's, or (``ld: false``) a flow map's;
    for a map of one direction (``directions``) without the other direction's variables."""
    if parameters.get("ld", True):
        contract = LD_TILE if tile_file else LD_GRID
    else:
        contract = FLOW_MAP_TILE if tile_file else FLOW_MAP
    computed = [label for _, label in map_directions(directions_setting(parameters))]
    others = tuple(f"_{label}" for _, label in DIRECTIONS[BOTH] if label not in computed)
    if not others:
        return contract
    return dataclasses.replace(contract, variables=tuple(v for v in contract.variables if not v.endswith(others)))


def recorded_parameters(dataset: xr.Dataset, parameters: dict) -> dict:
    """The parameters a map's file records: the map's, and the energies or start time they resolved to."""
    resolved = {k: dataset.attrs[k] for k in ("energy", "excess_energy", "critical_energy", "t0") if k in dataset.attrs}
    return {**parameters, "resolved": resolved}


def map_title(parameters: dict, tile: int | None = None, tiles: int | None = None) -> str:
    """The title of a map's file, or of one tile's."""
    return f"Lagrangian descriptor map {parameters['map_name']}" + (f", tile {tile + 1} of {tiles}" if tile is not None else "")


def ld_map_tile(parameters: dict, equilibria: xr.Dataset | None, *, tile: int = 0, tiles: int = 1,
                threads: int | None = None, show_progress: bool | None = True) -> xr.Dataset:
    """Tile ``tile`` of ``tiles`` of an LD map, as its tile file holds it (:func:`gather_ld_map`
    joins them): :func:`compute_ld_map`'s band with the parameters it records."""
    dataset = compute_ld_map(parameters, equilibria, tile=tile, tiles=tiles, threads=threads, show_progress=show_progress)
    recorded = {**recorded_parameters(dataset, parameters), "tile": tile, "tiles": tiles}
    return stage_dataset(dataset, stage=map_contract(parameters, tile_file=True), title=map_title(parameters, tile, tiles),
                         parameters=recorded)


def ld_map_dataset(parameters: dict, equilibria: xr.Dataset | None, *, tiles: int = 1, threads: int | None = None,
                   show_progress: bool | None = True) -> xr.Dataset:
    """A whole LD map, as the workflow computes it and its file holds it, in memory: a map of one
    tile finished as the gather finishes tiles (:func:`finish_ld_map`), several tiles computed one
    after another (:func:`ld_map_tile`) and gathered (:func:`gather_ld_map`).

    ``equilibria`` None: a map of a vector-field system, which has no energy and no saddle."""
    if tiles == 1:
        dataset = compute_ld_map(parameters, equilibria, threads=threads, show_progress=show_progress)
        return finish_ld_map([dataset], recorded_parameters(dataset, parameters))
    return gather_ld_map([ld_map_tile(parameters, equilibria, tile=tile, tiles=tiles, threads=threads,
                                      show_progress=show_progress) for tile in range(tiles)])


def gather_bands(datasets: list[xr.Dataset], axis: str, parameters: dict) -> xr.Dataset:
    """The bands of rows of one start time joined along ``axis``, with the FTLE of the whole grid
    if the map asks for it (a single band has its FTLE already)."""
    joined = gather_tiles([d.drop_attrs(deep=False) for d in datasets], axis)
    if parameters.get("ftle", False) is True and len(datasets) > 1:  # by differences over the whole grid
        if TIME_UNITS in datasets[0].attrs:
            joined.attrs[TIME_UNITS] = datasets[0].attrs[TIME_UNITS]
        add_ftle(joined, system_phase_coordinates(parameters["system_spec"]), float(datasets[0].attrs["tau"]),
                 on_sphere(parameters["system_spec"]), parameters["section"].get("solve"))
    return joined


def note_mirrored_tiles(joined: xr.Dataset, datasets: list[xr.Dataset]) -> None:
    """The gathered map's record of mirrored backward fields (:func:`ldpipe.core.maps.grid.mirror_attributes`)
    when only some tiles were mirrored (a tile whose grid states were not exactly mirrored integrates
    backward)."""
    mirrored = [i for i, d in enumerate(datasets) if "backward_fields" in d.attrs]
    if not mirrored or len(mirrored) == len(datasets):
        return
    first = datasets[mirrored[0]].attrs
    joined.attrs["reversing_symmetry"] = first["reversing_symmetry"]
    joined.attrs["backward_fields"] = (f"tiles {mirrored} of {len(datasets)} (from 0): {first['backward_fields']}; "
                                       "the other tiles integrated backward")


def gather_ld_map(tiles: list[xr.Dataset], names: list[str] | None = None) -> xr.Dataset:
    """The whole map from all its tiles (:func:`ld_map_tile`'s Datasets, or their files read
    back), in any order; ``names`` say where each came from in errors (default its position)."""
    names = names or [f"tile dataset {i}" for i in range(len(tiles))]
    parameters = [stage_parameters(d) for d in tiles]
    counts = {p["tiles"] for p in parameters}
    if counts != {len(tiles)} or sorted(p["tile"] for p in parameters) != list(range(len(tiles))):
        raise ValueError(f"expected tiles 0..{len(tiles) - 1} of one map, got {names}")
    order = np.argsort([p["tile"] for p in parameters])
    common = {k: v for k, v in parameters[order[0]].items() if k not in ("tile", "tiles")}
    for name, p in zip(names, parameters):
        if {k: v for k, v in p.items() if k not in ("tile", "tiles")} != common:
            raise ValueError(f"{name}: computed with other parameters than {names[order[0]]}; recompute the tiles")
    return finish_ld_map([tiles[i] for i in order], common)


def finish_ld_map(datasets: list[xr.Dataset], common: dict) -> xr.Dataset:
    """The map's Dataset from all its tiles, in order, computed with the parameters ``common``
    (:func:`recorded_parameters`): joined, with the whole map's attributes."""
    axis = datasets[0].allowed.dims[-2]
    starts = map_start_times(common)
    if starts is None:
        joined = gather_bands(datasets, axis, common)
    else:  # the bands of each start time, then the start times stacked
        bands = start_time_band(starts, 0, len(datasets))[2]
        joined = xr.concat([gather_bands([d.isel(t0=0, drop=True) for d in datasets[k * bands:(k + 1) * bands]],
                                         axis, common).expand_dims(t0=[start]) for k, start in enumerate(starts)],
                           dim="t0", data_vars="all", coords="minimal", compat="identical", join="exact")
    joined.attrs.update({k: v for k, v in datasets[0].attrs.items() if k not in MANAGED_ATTRIBUTES and k != "tile"})
    joined.attrs["tiles"] = len(datasets)
    note_mirrored_tiles(joined, datasets)
    unused = next((d.attrs[MIRROR_UNUSED] for d in datasets if MIRROR_UNUSED in d.attrs), None)
    if unused is not None:  # once for the map, whichever of its tiles could not be mirrored
        joined.attrs[MIRROR_UNUSED] = unused
        # information, not a warning: the map is right (the README's own example meets it, where
        # the solved coordinate's rounding near the rim misses the mirror's tolerance)
        log.info("map %r: %s", common["map_name"], unused)
    for name in ("refine_trajectories", "refine_trajectories_forward", "refine_trajectories_backward"):
        if name in joined.attrs:  # an adaptive map: every tile's trajectories
            joined.attrs[name] = sum(int(d.attrs[name]) for d in datasets)
    note_allowed_points(joined, whole_map=True)
    # data on a calendar: the start times and tau in dates too (the numbers are the data's time units;
    # a discrete map counts iterations, not time)
    if "tau" in joined.attrs:
        joined.attrs.update(calendar_attributes(
            common["system_spec"], f"systems.{common['system_name']}",
            joined["t0"].values if starts is not None else joined.attrs.get("t0", 0.0), joined.attrs["tau"]))
    add_map_classification(joined)  # a discrete map's chaos indicators, over the whole map
    return stage_dataset(joined, stage=map_contract(common, tile_file=False), title=map_title(common),
                         parameters={**common, "tiles": len(datasets)})
