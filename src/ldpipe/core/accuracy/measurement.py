"""The accuracy–cost measurement as its stage file holds it: the LD ladder on a sample of each
configured map's points, the orbit ladder on one orbit of a family, the NHIM ladders on one
variable-time map, joined with the machine and its load (:func:`accuracy_cost_dataset`).

The ladders themselves are :mod:`.ld_ladder`, :mod:`.orbit_ladder` and :mod:`.nhim_ladder`; this
module resolves the configured maps and family (with the equilibria of their systems), runs the
ladders and assembles their Datasets.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Sequence

import numpy as np
import xarray as xr

from ...engine import use_threads
from ...engine.settings import integrator_ladder
from ...errors import ConfigError, StageFileError
from ...io.contracts import ACCURACY_COST, EQUILIBRIA
from ...io.datafile import open_stage_file, stage_dataset
from ...logs import get_logger
from ...systems import make_system
from ..equilibria.potential import select_saddle
from ..maps.assembly import resolve_map
from ..maps.grid import ld_grid_dataset
from ..nhim import RefinementSettings, detect_nhim_cell, make_slice_problem, orbit_section_crossing
from ..orbits.periodic import CorrectionFailed, linearize_saddle
from ..sections import section_states
from .ld_ladder import QUANTILES, IntegratorStep, ld_ladder_dataset, same_number, sample_indices
from .machine import load_average, machine_attributes
from .nhim_ladder import nhim_grid_dataset, nhim_refinement_dataset
from .orbit_ladder import CorrectorStep, compute_orbit, corrector_ladder, orbit_ladder_dataset
from .timing import RepeatRule

log = get_logger(__name__)

#: A stage file: its path, or the Dataset itself (as the Python API gives it).
StageInput = str | os.PathLike | xr.Dataset
#: The title of the stage's file.
TITLE = "Accuracy against cost of the LD engine, the periodic-orbit corrector and the NHIM detection"


def accuracy_cost_dataset(parameters: dict, equilibria: StageInput | Sequence[StageInput], *,
                          threads: int | None = None) -> xr.Dataset:
    """Every measurement of the accuracy–cost stage, as its file (contract ACCURACY_COST) holds it.

    Parameters
    ----------
    parameters : dict
        The stage's (``parameters_from_config(config, "accuracy")``): ``ld`` (the LD ladder, its
        maps' parameters under ``maps``), ``upo`` (the orbit ladder, the family's parameters under
        ``family``), ``nhim`` (the NHIM ladders, the map's parameters under ``map``).
    equilibria : path or xarray.Dataset, or a sequence of them
        The equilibria of every system the maps and the family are of.
    threads : int, optional
        Threads of the engine (default every core; recorded with the machine).
    """
    use_threads(threads)
    files = [equilibria] if isinstance(equilibria, (str, os.PathLike, xr.Dataset)) else list(equilibria)
    data = accuracy_dataset(parameters["ld"], parameters["upo"], parameters["nhim"], files)
    return stage_dataset(data, stage=ACCURACY_COST, title=TITLE,
                         parameters={"ld": parameters["ld"], "upo": parameters["upo"], "nhim": parameters["nhim"]})


#: Why the LD reference is trusted, recorded in the file (measured with ldpipe.testing.reference_ld,
#: an independent LD: scipy DOP853 at 1e-13, every velocity zero crossing located, Gauss–Jacobi
#: rules on the pieces; see README "What accuracy costs").
REFERENCE_VALIDATION = (
    "sym6 at dt 0.005 against ldpipe.testing.reference_ld (independent: scipy DOP853 rtol 1e-13, located velocity zero "
    "crossings, Gauss-Jacobi rules): relative LD difference median 6e-14, max 4e-12 on 57 non-escaping points of "
    "fig3_dE0.125 (fixed time, tau 50), median 4e-14, max 3e-13 on 300 points of fig4_k-7.0 (variable time). "
    "dop853 at rtol 1e-13 was the worse reference (max 4e-10 and 5e-11 on the same points). "
    "Each run stores the reference's agreement with reference_check (default: half the step) as "
    "reference_check_quantile; errors below it are not resolved."
)


def equilibria_by_system(paths: list[StageInput]) -> dict[str, xr.Dataset]:
    """The equilibria files (or Datasets) by the system they are of."""
    found = {}
    for path in paths:
        data = open_stage_file(path, stage=EQUILIBRIA)
        found[str(data.attrs.get("system", ""))] = data
    return found


def equilibria_for(found: dict, system: str, key: str) -> xr.Dataset:
    """The equilibria of ``system`` among ``found``; ``key`` names what needs them."""
    if system not in found:
        raise StageFileError(f"{key}: needs the equilibria file of system {system!r}; got files of {sorted(found)}")
    return found[system]


def _map_dataset(name: str, parameters: dict, equilibria: xr.Dataset, ld: dict, steps, reference, check) -> xr.Dataset:
    """The ladder measured on a sample of one map's allowed grid points."""
    system, section, settings, info = resolve_map(parameters, equilibria)
    states, allowed, _ = section_states(system, section, info["energy"])
    if len(states) == 0:
        raise ConfigError(f"config key 'accuracy_cost.ld.maps': map {name!r} has no energetically allowed point")
    chosen = sample_indices(len(states), ld["points"], ld["seed"], multiple_of=settings.lanes)
    grid_index = np.argwhere(allowed)[chosen]  # C order of the grid, as section_states orders the states
    log.info("map %s: %d of %d allowed points sampled (grid %s), %s time, tau %g", name, len(chosen), len(states),
             section.shape, parameters["time"], settings.tau)
    data = ld_ladder_dataset(system, states[chosen], settings, steps, reference, check,
                             rule=RepeatRule(ld["repeats"], ld["repeat_budget"]))
    n = len(chosen)
    default = np.array([step.matches(settings) for step in steps])
    if not default.any():
        log.warning("map %s: its integrator setting (%s) is not on the ladder; no point is marked default",
                    name, settings.scheme)
    data["is_default"] = ("setting", default, {"long_name": "the map's own integrator setting"})
    data["map_wall_time_estimate"] = data.wall_time * len(states) / n
    data["map_wall_time_estimate"].attrs.update({
        "units": "s", "long_name": "wall time of the whole map (every allowed grid point, forward and backward) "
                                   "at the sample's time per point"})
    data["sample_index"] = (("point", "grid_axis"), grid_index, {"long_name": "grid indices of the sampled point"})
    data["sample_state"] = (("point", "phase_index"), states[chosen], {"long_name": "the sampled initial state"})
    scalars = {
        "allowed_points": len(states), "sampled_points": n, "grid_points": int(np.prod(section.shape)),
        "energy": info["energy"], "excess_energy": info["excess_energy"], "tau": settings.tau,
        "variable_time": settings.variable_time,
        "reference_wall_time": data.attrs.pop("reference_wall_time"),
        "reference_check_wall_time": data.attrs.pop("reference_check_wall_time"),
        "reference_escapes": data.attrs.pop("reference_escapes"),
    }
    for key, value in scalars.items():
        data[key] = value
    data["phase_names"] = ("phase_index", list(system.phase_coordinates))
    data.attrs.clear()
    return data


def _pad_points(data: xr.Dataset, size: int) -> xr.Dataset:
    """Pad the point dimension to ``size`` with zeros, marking the real points in ``point_used``."""
    used = np.zeros(size, dtype=bool)
    used[: data.sizes["point"]] = True
    padded = data.reindex(point=np.arange(size), fill_value=0)
    padded["point_used"] = ("point", used, {"long_name": "the point is a sampled point (the rest is padding, 0)"})
    return padded


def ld_accuracy_dataset(ld: dict, equilibria: dict[str, xr.Dataset]) -> xr.Dataset:
    """The LD ladder on every configured map, joined along ``map``."""
    steps = integrator_ladder(ld["ladder"])
    reference = IntegratorStep.from_spec(ld["reference"])
    check = IntegratorStep.from_spec(ld["reference_check"])
    datasets = []
    for name, parameters in ld["maps"].items():
        data = equilibria_for(equilibria, parameters["system_name"], f"accuracy_cost.ld.maps ({name})")
        datasets.append(_map_dataset(name, parameters, data, ld, steps, reference, check))
    size = max(d.sizes["point"] for d in datasets)
    phases = max(d.sizes["phase_index"] for d in datasets)
    datasets = [_pad_points(d, size).reindex(phase_index=np.arange(phases), fill_value=0) for d in datasets]
    joined = xr.concat(datasets, dim="map", data_vars="all", coords="minimal", compat="equals", join="exact")
    joined = joined.assign_coords(map=list(ld["maps"]))
    joined.attrs.update({
        "reference": reference.label, "reference_check": check.label, "reference_validation": REFERENCE_VALIDATION,
        "repeats": ld["repeats"], "repeat_budget": ld["repeat_budget"], "sample_seed": ld["seed"],
    })
    return joined


def orbit_accuracy_dataset(orbit: dict, equilibria: dict[str, xr.Dataset]) -> xr.Dataset:
    """The corrector ladder on the family's orbit at the configured energy."""
    family = orbit["family"]
    key = "accuracy_cost.upo"
    system = make_system(family["system_name"], family["system_spec"])
    data = equilibria_for(equilibria, family["system_name"], f"{key}.family ({family['family']})")
    position, critical_energy = select_saddle(data, family.get("saddle_near"))
    saddle = linearize_saddle(system, position)
    energy_spec = orbit["energy"]
    energy = energy_spec["total"] if "total" in energy_spec else critical_energy + energy_spec["excess"]
    if energy < critical_energy:
        raise ConfigError(f"config key '{key}.energy': {energy_spec} is below the saddle's E_c {critical_energy:.12g}")
    steps = corrector_ladder(orbit["tolerance"], orbit["rtol"], orbit["energy_tolerance_ratio"])
    ref = orbit["reference"]
    reference = CorrectorStep(ref["tolerance"], ref["energy_tolerance"], ref["rtol"], ref["rtol"])
    log.info("orbit ladder: family %s, centre mode %d, E = %.12g (dE = %.6g), %d settings", family["family"],
             family["center_mode"], energy, energy - critical_energy, len(steps))
    result = orbit_ladder_dataset(
        system, saddle, family["center_mode"], energy, steps, reference, continuation=family["continuation"],
        check_rtol=orbit["check_rtol"], rule=RepeatRule(orbit["repeats"], orbit["repeat_budget"]),
        max_iterations=family["max_iterations"],
    )
    default = [same_number(s.tolerance, family["tolerance"]) and same_number(s.rtol, family["integrator"]["rtol"])
               for s in steps]
    result["orbit_is_default"] = ("orbit_setting", np.array(default, dtype=bool),
                                  {"long_name": "the family's own correction tolerance and integrator rtol"})
    result.attrs.update({"orbit_family": family["family"], "orbit_excess_energy": energy - critical_energy})
    return result


def _reference_orbit_of(orbit_ladder: xr.Dataset | None, parameters: dict, family: dict, energy: float):
    """(initial state, period) of the orbit ladder's reference orbit if it is the NHIM's (same system,
    saddle, settings and energy: the same computation, so the same numbers); else None."""
    if orbit_ladder is None or "orbit_reference_period" not in orbit_ladder.attrs:
        return None
    same = (parameters["system_name"] == family["system_name"] and parameters["system_spec"] == family["system_spec"]
            and orbit_ladder.attrs["orbit_target_energy"] == energy)
    if not same:
        return None
    return orbit_ladder.attrs["orbit_reference_initial_state"], orbit_ladder.attrs["orbit_reference_period"]


def nhim_accuracy_dataset(nhim: dict, upo: dict, equilibria: dict[str, xr.Dataset],
                          orbit_ladder: xr.Dataset | None = None) -> xr.Dataset:
    """The NHIM ladders on one variable-time map: grid resolution -> detection error, refinement
    tolerance -> location error, both against the crossing of the tight reference orbit.

    ``orbit_ladder``: the orbit ladder's dataset (:func:`orbit_accuracy_dataset`), whose reference
    orbit is taken where it is the same orbit (same system and energy) instead of computed again.
    """
    parameters = nhim["map"]
    name = parameters["map_name"]
    key = "accuracy_cost.nhim"
    data = equilibria_for(equilibria, parameters["system_name"], f"{key}.map ({name})")
    system, section, settings, info = resolve_map(parameters, data)
    problem = make_slice_problem(name, system, section, info["energy"], info["critical_energy"],
                                 np.asarray(info["saddle"]), settings)
    family = upo["family"]
    ref = upo["reference"]
    reference = CorrectorStep(ref["tolerance"], ref["energy_tolerance"], ref["rtol"], ref["rtol"])
    known = _reference_orbit_of(orbit_ladder, parameters, family, info["energy"])
    if known is None:
        orbit_position, _ = select_saddle(data, family.get("saddle_near"))
        try:
            orbit, _ = compute_orbit(system, linearize_saddle(system, orbit_position), family["center_mode"],
                                     info["energy"], reference, family["continuation"], family["max_iterations"])
        except CorrectionFailed as error:
            raise ConfigError(f"config key '{key}': no reference orbit of family {family['family']!r} at the energy "
                              f"of map {name!r}: {error}") from None
        known = orbit.initial_state, orbit.period
    initial_state, period = known
    crossing = orbit_section_crossing(problem, initial_state, period, rtol=upo["check_rtol"], atol=upo["check_rtol"])
    log.info("NHIM ladders on %s: the orbit (period %.12g) crosses the slice at %s", name, period, crossing)
    grids = nhim_grid_dataset(problem, crossing, nhim["grid_points"],
                              rule=RepeatRule(nhim["repeats"], nhim["repeat_budget"]))
    start = dataclasses.replace(section, shape=(nhim["refinement_grid"], nhim["refinement_grid"]))
    start_problem = dataclasses.replace(problem, section=start)
    grid = ld_grid_dataset(system, start, info["energy"], settings)
    axes = (grid[start.axes[0]].values, grid[start.axes[1]].values)
    guess = detect_nhim_cell(grid.ld_forward.values, grid.ld_backward.values, grid.allowed.values, axes).point
    refinements = nhim_refinement_dataset(
        start_problem, guess, crossing, nhim["tolerance"], RefinementSettings(**nhim["refinement"]),
        precision_ratio=nhim["precision_ratio"], rule=RepeatRule(nhim["repeats"], nhim["repeat_budget"]),
    )
    result = xr.merge([grids, refinements], compat="no_conflicts", join="outer", combine_attrs="drop")
    result["nhim_grid_is_default"] = ("nhim_grid", np.array([p == section.shape[0] for p in nhim["grid_points"]]),
                                      {"long_name": "the map's own grid"})
    result["nhim_refinement_is_default"] = (
        "nhim_refinement", np.array([same_number(t, nhim["refinement"]["tolerance"]) for t in nhim["tolerance"]]),
        {"long_name": "the configured refinement tolerance (nhim.refinement.tolerance)"})
    result.attrs.update({
        "nhim_map": name, "nhim_crossing": crossing, "nhim_axes": list(section.axes),
        "nhim_refinement_grid": nhim["refinement_grid"], "nhim_refinement_start": guess,
        "nhim_refinement_start_error": float(np.linalg.norm(guess - crossing)),
        "nhim_precision_ratio": nhim["precision_ratio"], "nhim_repeats": nhim["repeats"],
        "nhim_repeat_budget": nhim["repeat_budget"],
    })
    return result


def accuracy_dataset(ld: dict, upo: dict, nhim: dict, equilibria: list[StageInput]) -> xr.Dataset:
    """Every measurement of the stage, with the machine and its load before and after."""
    found = equilibria_by_system(equilibria)
    machine = machine_attributes()
    load_before = load_average()
    parts = []
    if ld["maps"]:
        parts.append(ld_accuracy_dataset(ld, found))
    orbits = orbit_accuracy_dataset(upo, found) if upo["family"] else None
    if orbits is not None:
        parts.append(orbits)
    if nhim["map"]:
        parts.append(nhim_accuracy_dataset(nhim, upo, found, orbits))
    if not parts:
        raise ConfigError("config key 'accuracy_cost': names no LD map (ld.maps), orbit family (upo.family) "
                          "or NHIM map (nhim.map)")
    data = xr.merge(parts, compat="no_conflicts", join="outer", combine_attrs="no_conflicts")
    data.attrs.update(machine)
    data.attrs.update({"load_average_before": load_before, "load_average_after": load_average(),
                       "error_quantiles": np.array(QUANTILES)})
    return data
