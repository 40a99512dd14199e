"""LD grids on a section: the points of one tile integrated forward and backward, as a Dataset.

A grid of ``shape`` points is split into ``tiles`` bands of rows along the
first axis; each tile is computed on its own (a separate Snakemake job) and
:func:`gather_tiles` joins them. Every trajectory is integrated independently
of the others (its results depend on its start point and the settings alone, not
on the trajectories that share its engine call or block), so the gathered grid
equals the untiled one bit for bit, however the points are batched.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import xarray as xr
from tqdm import tqdm

from ...engine import DescriptorSettings, IntegratorSettings, LDSettings, StoppingRules, compute_ld
from ...engine.schemes import check_scheme, get_scheme
from ...errors import ConfigError, StageFileError
from ...io.contracts import LD_GRID
from ...io.datafile import missing_value_encoding, open_stage_file
from .. import trajectories
from ..trajectories import ESCAPED, STEP_UNDERFLOW, FlowMap, FlowSettings
from ..sphere import sphere_positions
from .ftle import END_STATE_NAME, ftle, sphere_metric, variational_ftle
from .pilot import check_map_time
from .symmetry import MapMirror
from ...logs import get_logger, progress_bar
from ...text import per_time
from ..sections import Section, section_states
from ...systems import System, make_system

log = get_logger(__name__)
# Points per engine call: small enough for steady progress, large enough to keep every core busy.
CHUNK = 1 << 15
#: Per-trajectory stop flags of systems with boundaries of their own (velocity data's
#: ``stop_flags``: land, the data's edge), with what they say.
STOP_FLAGS = {"on_land": "stopped on land (a cell with a missing value)",
              "left_data": "stopped at the edge of the data (or of its window)"}
#: The flag of a map's points that start on land (velocity data): not integrated, so without an LD.
START_ON_LAND = "start_on_land"
#: The per-direction result fields an LD map holds (``fields`` of :func:`fields_dataset`: NAME_forward, NAME_backward).
MAP_FIELDS = ("ld", "time", "escaped", "left_region", "energy_error", "steps", "failed")
#: A map's ``directions`` setting: the directions of time it integrates, each as (sign, label).
DIRECTIONS = {"both": ((1, "forward"), (-1, "backward")), "forward": ((1, "forward"),),
              "backward": ((-1, "backward"),)}
BOTH = "both"


def map_directions(setting: str = BOTH) -> tuple[tuple[int, str], ...]:
    """The (sign, label) of each direction of time a map's ``directions`` setting integrates."""
    if setting not in DIRECTIONS:
        raise ValueError(f"directions: expected one of {list(DIRECTIONS)}, got {setting!r}")
    return DIRECTIONS[setting]


def directions_setting(parameters: dict) -> str:
    """A map's ``directions`` from its parameters (parameters recorded without it: both)."""
    return parameters.get("directions", BOTH)


def computed_directions(dataset: xr.Dataset) -> tuple[str, ...]:
    """The labels (forward, backward) of the directions a map's Dataset holds (its exit times)."""
    return tuple(label for _, label in DIRECTIONS[BOTH] if f"exit_time_{label}" in dataset)


def require_directions(attributes, needed: tuple[str, ...], what: str) -> None:
    """A ConfigError naming the map's ``directions`` key if the map whose file has ``attributes`` did not
    compute every direction of ``needed`` (labels), which ``what`` (a figure, a study) needs."""
    setting = str(attributes.get("directions", BOTH))
    computed = [label for _, label in DIRECTIONS.get(setting, ())]
    missing = [label for label in needed if label not in computed]
    if missing:
        name = attributes.get("map", "?")
        raise ConfigError(f"config key 'ld_maps.{name}.directions': map {name!r} was computed with directions: "
                          f"{setting}, and {what} needs the {' and '.join(missing)} direction too; give the map "
                          f"directions: {BOTH if len(needed) > 1 else needed[0]}")


def open_map_file(path, what: str, needed: tuple[str, ...] = ("forward", "backward"), *, only: bool = True,
                  variables: tuple[str, ...] | None = None) -> xr.Dataset:
    """An LD map's file (``ld_grid``; a path, or a Dataset in memory) with ``variables`` (default the LD
    of each direction ``needed``, and ``allowed``; ``only``: those alone), for ``what`` (a figure, a
    study): a ConfigError naming the map's ``directions`` (:func:`require_directions`) where it lacks
    one of them because it integrated the other direction alone."""
    variables = variables if variables is not None else (*(f"ld_{label}" for label in needed), "allowed")
    try:
        return open_stage_file(path, stage=LD_GRID, variables=variables, only=only)
    except StageFileError:
        require_directions(open_stage_file(path, stage=LD_GRID, variables=("allowed",), only=True).attrs, needed, what)
        raise


def tile_rows(rows: int, tile: int, tiles: int) -> slice:
    """The band of first-axis rows that tile ``tile`` of ``tiles`` covers."""
    if not 0 <= tile < tiles:
        raise ValueError(f"tile: expected 0 <= tile < {tiles}, got {tile}")
    if tiles > rows:
        raise ValueError(f"tiles: {tiles} tiles for {rows} rows; use at most one tile per row")
    return slice(rows * tile // tiles, rows * (tile + 1) // tiles)


def ld_map_settings(parameters: dict, lower=None, upper=None) -> LDSettings:
    """The engine settings of an LD map's parameters, ``lower`` and ``upper`` its region box (None: fixed time).

    The scheme, block size and order they give (what the map's engine module is compiled for)
    need no saddle, so the workflow can name a map's engine modules before any stage has run.
    """
    try:
        return LDSettings.from_parts(
            IntegratorSettings.from_config(parameters["integrator"]),
            DescriptorSettings(p=parameters["p"], quad_nodes=parameters.get("quad_nodes")),
            StoppingRules(tau=parameters["tau"], region_lower=lower, region_upper=upper),
        )
    except ValueError as error:
        raise ConfigError(f"config key 'ld_maps.{parameters['map_name']}': {error}") from None


def map_start_times(parameters: dict) -> list[float] | None:
    """The start times of a map whose ``t0`` is a list or a range ``{first, last, count}`` (its
    file has a ``t0`` dimension); None for one start time (a number, or left out)."""
    t0 = parameters.get("t0", 0.0)
    if isinstance(t0, dict):
        return [float(v) for v in np.linspace(t0["first"], t0["last"], t0["count"])]
    if isinstance(t0, (list, tuple)):
        return [float(v) for v in t0]
    return None


def paths_per_point(parameters: dict) -> int:
    """The trajectories a map integrates from each grid point in each direction: a map with noise
    its ``members`` (:mod:`ldpipe.core.maps.stochastic`), any other map one."""
    noise = parameters.get("noise")
    return 1 if noise is None else noise["members"]


def start_time_band(starts: list[float], tile: int, tiles: int) -> tuple[int, int, int]:
    """(start index, band, bands) of tile ``tile`` of ``tiles`` of a map with several start
    times: the tiles run over the start times, each split into the same number of bands of rows."""
    if tiles % len(starts):
        raise ValueError(f"tiles: {tiles} tiles do not split {len(starts)} start times evenly")
    bands = tiles // len(starts)
    index, band = divmod(tile, bands)
    return index, band, bands


def resolve_ld_map(parameters: dict, saddle: np.ndarray | None, critical_energy: float | None) -> tuple:
    """What an LD map's recorded parameters describe: ``(system, section, settings, info)``.

    ``parameters`` are the map's stage parameters (the ``ld_maps`` entry, resolved by the LD
    stage, as recorded in its file); ``saddle`` and ``critical_energy`` those of the saddle it was
    computed at (None for a vector-field system, which has no energy). ``info`` holds the total,
    critical and excess energies (None for a vector field), the saddle and the start time
    ``t0``. The LD stage resolves a map with it before computing, later stages to read the map
    as computed.
    """
    system = make_system(parameters["system_name"], parameters["system_spec"])
    key = f"ld_maps.{parameters['map_name']}"
    section = Section.from_spec(parameters["section"], system, saddle, key=f"{key}.section")
    hamiltonian = system.hamiltonian
    t0 = parameters.get("t0", 0.0)
    if hamiltonian:
        if "energy" not in parameters:
            raise ConfigError(f"config key '{key}.energy': a map of the Hamiltonian system {system.name!r} needs an energy")
        if t0 != 0.0:
            raise ConfigError(f"config key '{key}.t0': system {system.name!r} is autonomous (a Hamiltonian); "
                              "a start time changes nothing, leave t0 out")
        energy_spec = parameters["energy"]
        energy = energy_spec["total"] if "total" in energy_spec else critical_energy + energy_spec["excess"]
        excess = energy - critical_energy
    else:
        if "energy" in parameters:
            raise ConfigError(f"config key '{key}.energy': system {system.name!r} is a vector field with no energy; "
                              "leave the energy out")
        energy = excess = None
    region = parameters.get("region")
    if parameters["time"] == "variable":
        if not region:
            raise ConfigError(f"config key '{key}.region': a variable-time map needs a saddle region box")
        missing = [c for c in system.coordinates if c not in region]
        if missing:
            raise ConfigError(f"config key '{key}.region': no interval for {missing}; give one per coordinate")
        lower = [region[c][0] for c in system.coordinates]
        upper = [region[c][1] for c in system.coordinates]
    else:
        lower = upper = None
    settings = ld_map_settings(parameters, lower, upper)
    if not hamiltonian:
        try:
            check_scheme(get_scheme(settings.scheme), system)
        except ValueError as error:
            raise ConfigError(f"config key '{key}.integrator.scheme': {error}") from None
    # data: the times the directions integrated cover, in the data's time range
    ends = [float(t0) + sign * settings.tau for sign, _ in map_directions(directions_setting(parameters))]
    system.check_times(min(ends + [float(t0)]), max(ends + [float(t0)]), key=f"{key}.t0")
    info = {"energy": energy, "critical_energy": critical_energy, "excess_energy": excess,
            "saddle": [] if saddle is None else np.asarray(saddle).tolist(), "t0": float(t0)}
    return system, section, settings, info


def flow_settings(settings: LDSettings) -> FlowSettings:
    """The flow driver's settings at an LD map's tolerances, escape radius and step limit."""
    return FlowSettings(rtol=settings.rtol, atol=settings.atol, escape_radius=settings.escape_radius,
                        max_steps=settings.max_steps)


def integrate_points(system: System, states: np.ndarray, direction: int, settings: LDSettings,
                     progress: tqdm | None = None, t0: float = 0.0, descriptor: bool = True):
    """:func:`ldpipe.engine.compute_ld` of ``states`` (without the ``descriptor``, :func:`ldpipe.core.trajectories.flow_map`)
    in calls of at most :data:`CHUNK` points, updating ``progress`` (each trajectory is integrated on
    its own: the calls' sizes change no bit)."""
    if descriptor:
        def compute(chunk):
            return compute_ld(system, chunk, direction=direction, settings=settings, t0=t0)
    else:
        def compute(chunk):
            return trajectories.flow_map(system, chunk, direction * settings.tau, flow_settings(settings), t0=t0)
    results = []
    for start in range(0, len(states), CHUNK):
        chunk = states[start : start + CHUNK]
        results.append(compute(chunk))
        if progress is not None:
            progress.update(len(chunk))
    if not results:
        return compute(states)
    return type(results[0])(*(np.concatenate(parts) for parts in zip(*results)))


def pilot_integration(system: System, direction: int, settings: LDSettings, t0: float, descriptor: bool):
    """The map's integration of some start points over some time, as a pilot measures it
    (:mod:`ldpipe.core.maps.pilot`)."""
    def integrate(sample: np.ndarray, tau: float):
        return integrate_points(system, sample, direction, dataclasses.replace(settings, tau=tau), None, t0, descriptor)
    return integrate


def _flow_map_fields(result: FlowMap) -> dict[str, np.ndarray]:
    """The per-trajectory fields of a map without its LD, named as compute_ld's."""
    return {"time": np.abs(result.final_time), "escaped": result.status == ESCAPED,
            "failed": result.status == STEP_UNDERFLOW, "steps": result.steps}


#: Crossings kept per trajectory while locating a stop (the last one before it is the stop).
STOP_CROSSINGS = 256


def locate_stops(system, states: np.ndarray, end_states: np.ndarray, direction: int, settings: LDSettings,
                 t0: float) -> np.ndarray:
    """|t - t0| at which each trajectory of ``states`` stopped on land or at the data's edge
    (``end_states``, where it rests): its last crossing of the grid line it rests just past
    (:meth:`ldpipe.systems.velocity_data.VelocityDataSystem.stop_lines`), located on the flow
    driver's dense output, in forward time the way it crossed. NaN where no crossing was found."""
    axis, value, side = system.stop_lines(end_states, t0, t0 + direction * settings.tau)
    times = np.full(len(states), np.nan)
    for key in sorted(set(zip(axis.tolist(), value.tolist(), side.tolist()))):
        group = np.flatnonzero((axis == key[0]) & (value == key[1]) & (side == key[2]))
        run = trajectories.integrate(system, states[group], direction * settings.tau, flow_settings(settings), t0=t0,
                             section=(system.phase_coordinates[key[0]], key[1], direction * key[2]),
                             max_crossings=STOP_CROSSINGS)
        found = (run.crossing_count > 0) & (run.crossing_count < STOP_CROSSINGS)
        last = run.crossing_times[np.arange(len(group)), np.maximum(run.crossing_count - 1, 0)]
        times[group[found]] = np.abs(last[found])
    return times


def _long_name(name: str, system=None) -> str:
    if system is not None and not system.hamiltonian:
        return f"state variable {name}"
    return f"momentum conjugate to {name[1:]}" if name.startswith("p") and len(name) > 1 else f"coordinate {name}"


def ld_grid_dataset(
    system: System,
    section: Section,
    energy: float | None,
    settings: LDSettings,
    rows: slice | None = None,
    show_progress: bool | None = False,
    t0: float = 0.0,
    flow_map: bool = False,
    descriptor: bool = True,
    mirror: MapMirror | None = None,
    directions: str = BOTH,
    label: str | None = None,
) -> xr.Dataset:
    """Forward and backward LD on the section's grid (or the band ``rows`` of it) at ``energy``;
    ``directions`` (:data:`DIRECTIONS`) ``forward`` or ``backward``: that direction alone, integrated
    and written (its variables only).

    With a ``mirror`` (a reversing symmetry of the section, :func:`ldpipe.core.maps.symmetry.map_mirror`)
    only the forward direction is integrated, and every backward field is the forward one at the
    image pixel (attributes ``reversing_symmetry``, ``backward_fields``), where the grid's states
    are mirrored to its tolerance (:meth:`~ldpipe.core.maps.symmetry.MapMirror.maps_grid`); elsewhere the map is
    integrated both ways, with a warning. Not with ``flow_map``, without the ``descriptor``, or for
    a system with stop flags; a mirror that negates the first axis needs the whole of it (``rows``).

    For a vector-field system (no energy: ``energy`` None) every grid point is integrated from
    the start time ``t0``, and the file has no energy error and no solved coordinate. With
    ``flow_map`` the end state of every trajectory is kept too (``end_<coordinate>_<direction>``,
    the flow map :func:`add_ftle` differentiates). Without the ``descriptor`` (a vector field's
    fixed-time map, ``flow_map`` implied) only the flow map is integrated (:func:`ldpipe.core.trajectories.flow_map`):
    the file has no ``ld_*``, ``left_region_*`` (no region) variables.

    With a ``label`` (the map's name in messages) a large map is first piloted and warned about
    if it will run long (:func:`ldpipe.core.maps.pilot.check_map_time`).
    """
    rows = rows if rows is not None else slice(0, section.shape[0])
    states, allowed, solved = section_states(system, section, energy, rows)
    shape = allowed.shape
    requested = mirror
    if mirror is not None:
        if directions != BOTH:
            raise ValueError(f"mirror: a map of one direction (directions: {directions}) has no backward fields "
                             "to mirror")
        mirror = _checked_mirror(system, mirror, states, allowed, rows, section.shape[0],
                                 flow_map or not descriptor)
    directions = ((1, "forward"),) if mirror is not None else map_directions(directions)
    if label is not None:
        check_map_time(label, pilot_integration(system, directions[0][0], settings, t0, descriptor),
                       states, settings.tau, len(directions))
    fields: dict[str, np.ndarray] = {}
    ends: dict[str, np.ndarray] = {}
    if system.has_stop_flags:  # a start on land stops at once: its LD is missing, not 0
        fields[START_ON_LAND] = np.zeros(shape, dtype=bool)
        fields[START_ON_LAND][allowed] = system.stop_flags(states, t0, t0)["on_land"]
    progress = progress_bar(log, show=show_progress, total=len(directions) * len(states), unit="traj", desc="LD")
    with progress:
        for direction, label in directions:
            result = integrate_points(system, states, direction, settings, progress, t0, descriptor)
            if descriptor:
                results = {name: getattr(result, name) for name in MAP_FIELDS}
            else:
                results = _flow_map_fields(result)
            flags = {}
            if system.has_stop_flags:  # velocity data: land and the data's edge stop trajectories
                flags = system.stop_flags(result.end_state, t0, t0 + direction * settings.tau)
                stopped = np.flatnonzero(flags["on_land"] | flags["left_data"])
                if len(stopped) and not getattr(system, "stop_times_located", False):
                    # the time each stopped, where its crossing was found
                    times = locate_stops(system, states[stopped], result.end_state[stopped], direction, settings, t0)
                    results["time"] = results["time"].copy()
                    found = np.isfinite(times)
                    results["time"][stopped[found]] = times[found]
            for name, values in results.items():
                full = np.zeros(shape, dtype=values.dtype)
                full[allowed] = values
                fields[f"{name}_{label}"] = full
            if flags:
                for flag, values in flags.items():
                    full = np.zeros(shape, dtype=bool)
                    full[allowed] = values
                    fields[f"{flag}_{label}"] = full
            if flow_map or not descriptor:
                end = np.zeros(shape + (result.end_state.shape[1],))
                end[allowed] = result.end_state
                ends[label] = end
    if mirror is None:
        dataset = fields_dataset(system, section, fields, allowed, solved, rows, ends)
        if requested is not None:
            dataset.attrs[MIRROR_UNUSED] = mirror_unused_text(requested, section.solve)
        return dataset
    for name in [key for key in fields if key.endswith("_forward")]:
        fields[name[: -len("forward")] + "backward"] = np.ascontiguousarray(mirror.mirror(fields[name]))
    dataset = fields_dataset(system, section, fields, allowed, solved, rows, ends)
    dataset.attrs.update(mirror_attributes(mirror))
    return dataset


def mirror_attributes(mirror: MapMirror) -> dict[str, str | float]:
    """What a map file records of a mirror that gave its backward fields: the symmetry, and the
    largest |values[j] + values[N-1-j]| accepted on the mirrored axis and found there."""
    return {"reversing_symmetry": mirror.description,
            "backward_fields": "the forward fields at the image pixel under the reversing symmetry "
                               "(phi_-t(z) = S phi_t(S z)); not integrated",
            "reversing_symmetry_tolerance": mirror.tolerance,
            "reversing_symmetry_mismatch": mirror.mismatch}


def _checked_mirror(system, mirror: MapMirror, states: np.ndarray, allowed: np.ndarray, rows: slice, all_rows: int,
                    keeps_flow_map: bool) -> MapMirror | None:
    """``mirror`` if it gives this band's backward fields, None (integrate both ways) if the grid's
    states are not mirrored to its tolerance; ValueError where it does not apply at all."""
    if keeps_flow_map or system.has_stop_flags:
        raise ValueError("mirror: only an LD map's own fields are mirrored; a map that keeps its flow map, "
                         "or of a system with stop flags, integrates both ways")
    if mirror.mirrored[0] and (rows.start, rows.stop) != (0, all_rows):
        raise ValueError(f"mirror: {mirror.description} negates the first axis, and rows {rows.start}:{rows.stop} "
                         f"are a band of its {all_rows}")
    grid = np.zeros(allowed.shape + states.shape[1:])
    grid[allowed] = states
    if mirror.maps_grid(grid, allowed):
        return mirror
    log.debug("%s does not map this grid's states onto each other to %.3g; integrating backward",
             mirror.description, mirror.tolerance)
    return None


#: The attribute of a map whose backward half a reversing symmetry could have given but did not.
MIRROR_UNUSED = "reversing_symmetry_unused"


def mirror_unused_text(mirror: MapMirror, solve: str | None) -> str:
    """What a user should know when a map's backward half was integrated although a reversing
    symmetry would have given it: the map is right, it took twice the time, and why."""
    cause = f"the solved coordinate {solve} rounds differently" if solve else "the axis values round differently"
    return (f"the backward half was integrated, not mirrored, so the map took twice as long (its values are right): "
            f"its grid points are not each other's mirror images under the reversing symmetry {mirror.description} "
            f"to {mirror.tolerance:.1g} ({cause} on the two sides); backward_by_symmetry: false skips this check")


def fields_dataset(system: System, section: Section, fields: dict[str, np.ndarray], allowed: np.ndarray,
                   solved: np.ndarray | None, rows: slice, ends: dict[str, np.ndarray] | None = None) -> xr.Dataset:
    """The LD map's Dataset from its per-direction fields on the grid (the band ``rows`` of it):
    ``fields`` maps NAME_forward, NAME_backward (NAME in :data:`MAP_FIELDS`, and the stop flags of
    :data:`STOP_FLAGS` where the system has them) to arrays of the band's shape; ``ends`` the flow
    map's end states by direction, where kept, and ``fields[START_ON_LAND]`` the points that start on land.

    A point never integrated (outside the energetically allowed region, or starting on land) has
    no value: its floating-point fields are missing (NaN, declared as the file's ``_FillValue``),
    and the flags ``allowed`` and ``start_on_land`` say why."""
    first = section.axis_values()[0][rows]
    labels = tuple(label for _, label in DIRECTIONS[BOTH] if f"time_{label}" in fields)
    descriptor = f"ld_{labels[0]}" in fields  # a vector field's map without its LD holds the flow map alone
    dims = section.axes
    on_land = fields.get(START_ON_LAND)
    mask_note = "missing where the point is outside the energetically allowed region (see 'allowed')"
    ld_note = mask_note + (" or starts on land (see 'start_on_land')" if on_land is not None else "")
    never_integrated = ~allowed if on_land is None else ~allowed | on_land

    def field(values, attrs: dict, where: np.ndarray = ~allowed) -> tuple:
        """A floating-point field, missing (NaN, the file's declared fill value) ``where`` it has no value."""
        return (dims, np.where(where, np.nan, values), {**attrs, "comment": attrs.get("comment", mask_note)},
                missing_value_encoding())

    # each computed direction's variable of a field, forward first: (file name, field, long name, more attributes)
    per_direction = [
        ("ld_{}", "ld_{}", "Lagrangian descriptor, {} time", {"comment": ld_note}),
        ("exit_time_{}", "time_{}", None, {}),
        ("escaped_{}", "escaped_{}", "trajectory escaped ({})", {}),
        ("left_region_{}", "left_region_{}", "trajectory left the saddle region ({})", {}),
        ("failed_{}", "failed_{}", "integration stopped by a safety limit ({})", {}),
        ("steps_{}", "steps_{}", "integrator step attempts ({})", {}),
    ]
    exit_names = {"forward": "forward integration time reached: tau, or the exit or escape time",
                  "backward": "backward integration time reached (|t|): tau, or the exit or escape time"}
    variables = {}
    for name, source, long_name, extra in per_direction:
        if name in ("ld_{}", "left_region_{}") and not descriptor:  # a map without its LD has no region
            continue
        for label in labels:
            text = exit_names[label] if long_name is None else long_name.format(label)
            values = fields[source.format(label)]
            if values.dtype.kind == "f":  # the LD and the exit time: none where never integrated
                where = never_integrated if name == "ld_{}" else ~allowed
                variables[name.format(label)] = field(values, {"long_name": text, **extra}, where)
            else:  # flags and counts: false and 0 there
                variables[name.format(label)] = (dims, values, {"long_name": text, **extra})
    if section.solve is not None:  # a Hamiltonian's section (a map with its LD)
        errors = [fields[f"energy_error_{label}"] for label in labels]
        largest = np.maximum(*errors) if len(errors) == 2 else errors[0]
        text = ("largest |H(end) - H(start)| of the two directions" if len(errors) == 2
                else f"|H(end) - H(start)| of the {labels[0]} trajectory")
        variables["energy_error"] = field(largest, {"long_name": text})
    variables["allowed"] = (dims, allowed, {"long_name": "point lies in the energetically allowed region"})
    if section.solve is not None:
        variables[section.solve] = field(solved, {"long_name": f"{_long_name(section.solve)}, solved from the energy"})
    else:  # a vector field: no energy, every point integrated
        variables["allowed"] = (dims, allowed, {"long_name": "point integrated (a vector field: every point)"})
    for flag, text in STOP_FLAGS.items():
        for label in ("forward", "backward"):
            if f"{flag}_{label}" in fields:
                variables[f"{flag}_{label}"] = (dims, fields[f"{flag}_{label}"], {"long_name": f"trajectory {text} ({label})"})
    if on_land is not None:
        variables[START_ON_LAND] = (dims, on_land, {"long_name": "point starts on land (not integrated: no LD)"})
    for label, end in (ends or {}).items():
        for i, coordinate in enumerate(system.phase_coordinates):
            variables[END_STATE_NAME.format(coordinate=coordinate, direction=label)] = field(
                end[..., i], {"long_name": f"{_long_name(coordinate, system)} where the {label} trajectory stopped"})
    coords = {
        section.axes[0]: (section.axes[0], first, {"long_name": _long_name(section.axes[0], system)}),
        section.axes[1]: (section.axes[1], section.axis_values()[1], {"long_name": _long_name(section.axes[1], system)}),
    }
    return xr.Dataset(variables, coords=coords)


#: A map's attribute naming its system's unit of time (``days``), where the system names one.
TIME_UNITS = "time_units"


def add_ftle(dataset: xr.Dataset, coordinates: tuple[str, ...], tau: float, sphere: bool = False,
             solved: str | None = None) -> xr.Dataset:
    """Add ``ftle_forward``, ``ftle_backward`` and their ``ftle_defined_*`` flags to a whole map
    that keeps its flow map (``ld_grid_dataset(..., flow_map=True)``), by :func:`ldpipe.core.maps.ftle.ftle`
    (of the directions it holds, :func:`computed_directions`).

    ``coordinates`` are the system's state variables (the end-state variables' names), ``tau``
    the map's integration time; a trajectory ran the whole time when its exit time is ``tau`` and
    it neither escaped, left the region, nor failed (nor, for data, stopped on land or the edge).
    ``sphere``: the state is longitude and latitude in degrees (great-circle lengths, :func:`ldpipe.core.maps.ftle.sphere_metric`).
    ``solved``: the coordinate an energy surface's section solves for (its variable in ``dataset``),
    whose slope enters the initial separations (:func:`ldpipe.core.maps.ftle.section_chart_slope`).
    The FTLE's ``units`` are per the map's :data:`TIME_UNITS` attribute (``1/day``), where it has one.
    """
    dims = dataset.allowed.dims
    axes = tuple(dataset[d].values for d in dims)
    for label in computed_directions(dataset):
        ends = np.stack([dataset[END_STATE_NAME.format(coordinate=c, direction=label)].values for c in coordinates], axis=-1)
        complete = ran_whole_time(dataset, label, tau)
        if sphere:  # great-circle lengths: the end points as 3-D positions on the sphere
            ends = sphere_positions(ends)
        metric = sphere_metric(ends, axes, dims, coordinates) if sphere else None
        values, defined = ftle(ends, axes, tau, complete, metric, None if solved is None else dataset[solved].values)
        dataset[f"ftle_{label}"] = (dims, values, {
            "long_name": f"finite-time Lyapunov exponent, {label} time",
            "units": per_time(dataset.attrs.get(TIME_UNITS)),
            "comment": "ln(largest eigenvalue of the Cauchy-Green tensor of the flow map) / (2 tau), its gradient "
                       "by differences of end states over the grid; missing where not defined (see ftle_defined)"},
            missing_value_encoding())
        dataset[f"ftle_defined_{label}"] = (dims, defined, {
            "long_name": f"the {label} FTLE is defined: the point and the neighbours its differences read "
                         "along each axis ran the whole time"})
    return dataset


def ran_whole_time(dataset: xr.Dataset, label: str, tau: float) -> np.ndarray:
    """Where the ``label`` (forward, backward) trajectory ran the whole time ``tau``: allowed, and
    it neither escaped, left the region, nor failed (nor, for data, stopped on land or the edge)."""
    complete = (dataset.allowed.values & (dataset[f"exit_time_{label}"].values == tau)
                & ~dataset[f"escaped_{label}"].values & ~dataset[f"failed_{label}"].values)
    for flag in ("left_region", *STOP_FLAGS):  # a map without its LD has no region
        if f"{flag}_{label}" in dataset:
            complete &= ~dataset[f"{flag}_{label}"].values
    return complete


def add_variational_ftle(dataset: xr.Dataset, system, section: Section, rows: slice, tau: float, t0: float, *,
                         rtol: float, atol: float) -> xr.Dataset:
    """Add ``ftle_forward``, ``ftle_backward`` and their ``ftle_defined_*`` flags to a vector field's
    map (or its band ``rows``; the directions it holds) by the variational equations along each point's own trajectory
    (:func:`ldpipe.core.maps.ftle.variational_ftle`, scipy at ``rtol``, ``atol``, recorded as attributes):
    the exact gradient, no grid neighbours, so a tile computes its own points. A point is defined
    where its trajectory ran the whole time in the map (:func:`ran_whole_time`)."""
    allowed_states, allowed = section_states(system, section, None, rows)[:2]
    states = np.zeros(allowed.shape + allowed_states.shape[1:])
    states[allowed] = allowed_states
    axes = tuple(system.phase_coordinates.index(name) for name in section.axes)
    dims = dataset.allowed.dims
    for direction, label in DIRECTIONS[BOTH]:
        if label not in computed_directions(dataset):
            continue
        defined = ran_whole_time(dataset, label, tau)
        values = np.full(defined.shape, np.nan)
        if defined.any():
            values[defined] = variational_ftle(system, states[defined], axes, t0, direction * tau, rtol=rtol, atol=atol)
        dataset[f"ftle_{label}"] = (dims, values, {
            "long_name": f"finite-time Lyapunov exponent, {label} time",
            "units": per_time(dataset.attrs.get(TIME_UNITS)),
            "method": "variational",
            "rtol": rtol,
            "atol": atol,
            "comment": "ln(largest eigenvalue of the Cauchy-Green tensor of the flow map) / (2 tau), its gradient "
                       "exact: the state transition matrix of the variational equations along the point's "
                       "trajectory (scipy DOP853 at rtol, atol); missing where not defined (see ftle_defined)"},
            missing_value_encoding())
        dataset[f"ftle_defined_{label}"] = (dims, defined, {
            "long_name": f"the {label} FTLE is defined: the point's trajectory ran the whole time"})
    return dataset


def gather_tiles(tiles: list[xr.Dataset], axis: str) -> xr.Dataset:
    """Join tiles along the first axis, checking they cover it once, in order."""
    joined = xr.concat(tiles, dim=axis, data_vars="all", coords="minimal", compat="identical", join="exact")
    values = joined[axis].values
    if np.any(np.diff(values) <= 0):
        raise ValueError(f"tiles overlap or are out of order along {axis!r}")
    return joined
