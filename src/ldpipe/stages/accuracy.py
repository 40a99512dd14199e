"""Accuracy–cost stage: the work–precision measurement of the LD engine and the orbit corrector.

Declared under ``accuracy_cost:`` in the configuration (see the schema): the LD maps whose
points are sampled, the ladder of integrator settings, the reference; the periodic-orbit
family, its energy and the ladder of correction and integrator tolerances; the variable-time
map of the NHIM ladders, its grid sizes and refinement tolerances. One netCDF file holds every
measurement (dimensions ``map``, ``setting``, ``direction``, ``point``, ``quantile``;
``orbit_setting``; ``nhim_grid``, ``nhim_method``, ``nhim_refinement``) with the machine and
its load in the attributes, and Markdown tables summarize it. The science is in
:mod:`ldpipe.core.accuracy`.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numba
import numpy as np
import xarray as xr

from ..core.accuracy import (
    QUANTILES, CorrectorStep, IntegratorStep, RepeatRule, compute_orbit, corrector_ladder, integrator_ladder,
    ld_ladder_dataset, load_average, machine_attributes, nhim_grid_dataset, nhim_refinement_dataset, orbit_ladder_dataset,
    sample_indices, same_number, warm_up,
)
from ..engine.codegen import engine_compiled, engine_name
from ..io.atomic import check_writable, write_text_atomic
from ..io.contracts import ACCURACY_COST, EQUILIBRIA
from ..io.datafile import open_stage_file, write_stage_file
from ..core.equilibria.potential import select_saddle
from ..errors import ConfigError, StageFileError
from ..core.maps.grid import ld_grid_dataset
from ..logs import get_logger
from ..core.nhim import RefinementSettings, detect_nhim_cell, make_slice_problem, orbit_section_crossing
from ..core.orbits.periodic import CorrectionFailed, linearize_saddle
from ..core.sections import section_states
from ..systems import make_system
from ..core.maps.assembly import resolve_map

log = get_logger(__name__)

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


def _equilibria_by_system(paths: list[str | Path]) -> dict[str, xr.Dataset]:
    found = {}
    for path in paths:
        data = open_stage_file(path, stage=EQUILIBRIA)
        found[str(data.attrs.get("system", ""))] = data
    return found


def _equilibria_for(found: dict, system: str, key: str) -> xr.Dataset:
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
    data = ld_ladder_dataset(system, states[chosen], settings, steps, reference, check, repeats=ld["repeats"],
                              repeat_budget=ld["repeat_budget"])
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
        data = _equilibria_for(equilibria, parameters["system_name"], f"accuracy_cost.ld.maps ({name})")
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
    data = _equilibria_for(equilibria, family["system_name"], f"{key}.family ({family['family']})")
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
        check_rtol=orbit["check_rtol"], repeats=orbit["repeats"],
        repeat_budget=orbit["repeat_budget"], max_iterations=family["max_iterations"],
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
    data = _equilibria_for(equilibria, parameters["system_name"], f"{key}.map ({name})")
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
    grids = nhim_grid_dataset(problem, crossing, nhim["grid_points"], repeats=nhim["repeats"],
                              repeat_budget=nhim["repeat_budget"])
    start = dataclasses.replace(section, shape=(nhim["refinement_grid"], nhim["refinement_grid"]))
    start_problem = dataclasses.replace(problem, section=start)
    grid = ld_grid_dataset(system, start, info["energy"], settings)
    axes = (grid[start.axes[0]].values, grid[start.axes[1]].values)
    guess = detect_nhim_cell(grid.ld_forward.values, grid.ld_backward.values, grid.allowed.values, axes).point
    refinements = nhim_refinement_dataset(
        start_problem, guess, crossing, nhim["tolerance"], RefinementSettings(**nhim["refinement"]),
        precision_ratio=nhim["precision_ratio"], repeats=nhim["repeats"], repeat_budget=nhim["repeat_budget"],
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


def accuracy_dataset(ld: dict, upo: dict, nhim: dict, equilibria: list[str | Path]) -> xr.Dataset:
    """Every measurement of the stage, with the machine and its load before and after."""
    found = _equilibria_by_system(equilibria)
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


def _scientific(value: float) -> str:
    return f"{value:.1e}" if value else "0"


def _table_head(columns: list[str], left: tuple[str, ...] = ()) -> list[str]:
    """A Markdown table's header and alignment rows: numbers right-aligned, the columns in ``left`` not."""
    return ["| " + " | ".join(columns) + " |", "| " + " | ".join("---" if c in left else "---:" for c in columns) + " |"]


def _default_mark(is_default) -> str:
    """The mark of the row of the configured setting."""
    return " *" if bool(is_default) else ""


def _repeat_rule(attrs: dict, repeats: str, budget: str) -> RepeatRule:
    """The repeat rule a ladder was timed with, from the file's attributes (a file without a budget repeated every setting)."""
    return RepeatRule(int(attrs[repeats]), float(attrs.get(budget, np.inf)))


def _ld_tables(data: xr.Dataset) -> list[str]:
    quantiles = list(np.round(data["quantile"].values, 6))
    median, p99, worst = quantiles.index(0.5), quantiles.index(0.99), quantiles.index(1.0)
    lines = [
        f"LD: reference {data.attrs['reference']}; the reference check ({data.attrs['reference_check']}) "
        f"is listed per map. Wall time: the {_repeat_rule(data.attrs, 'repeats', 'repeat_budget').description()} "
        "(column runs); the full-map "
        "estimate scales it to every allowed grid point. Errors are relative to the reference, over the "
        "sampled points and both directions where the reference did not escape (a fixed-step reference stops "
        "an escape at the start of a step, short by up to one step's LD); energy drift is |H(end) - H(0)|. "
        "`*` marks the map's own setting.",
        "",
    ]
    for m, name in enumerate(data["map"].values):
        d = data.isel(map=m)
        check = d.reference_check_quantile.values
        lines += [
            f"## {name}: {int(d.sampled_points)} of {int(d.allowed_points)} allowed points, "
            f"{'variable' if bool(d.variable_time) else 'fixed'} time, tau {float(d.tau):g}, "
            f"dE = {float(d.excess_energy):g}",
            "",
            f"Reference check: median {_scientific(check[median])}, 99% {_scientific(check[p99])}, "
            f"worst {_scientific(check[worst])}; reference wall time {float(d.reference_wall_time):.2f} s; "
            f"{int(d.reference_escapes)} of {2 * int(d.sampled_points)} reference trajectories escaped "
            "(left out of the error columns).",
            "",
            *_table_head(["setting", "wall s (sample)", "runs", "full map s", "time units / s", "LD error median", "99%",
                          "worst", "energy drift median", "worst", "stop mismatches", "non-finite energy"],
                         left=("setting",)),
        ]
        for s in range(d.sizes["setting"]):
            e = d.ld_error_quantile.values[s]
            h = d.energy_error_quantile.values[s]
            lines.append(
                f"| {d.label.values[s]}{_default_mark(d.is_default.values[s])} | {float(d.wall_time[s]):.3f} "
                f"| {int(d.timed_runs[s])} | {float(d.map_wall_time_estimate[s]):.1f} "
                f"| {float(d.throughput[s]):.2e} | {_scientific(e[median])} | {_scientific(e[p99])} "
                f"| {_scientific(e[worst])} | {_scientific(h[median])} | {_scientific(h[worst])} "
                f"| {int(d.stop_mismatches[s])} | {int(d.nonfinite_energy_errors[s])} |"
            )
        lines.append("")
    return lines


def _orbit_table(data: xr.Dataset) -> list[str]:
    a = data.attrs
    ratio = float(data.orbit_energy_tolerance[0] / data.orbit_tolerance[0])
    lines = [
        f"## Periodic orbit: family {a['orbit_family']} at dE = {a['orbit_excess_energy']:g}",
        "",
        f"Reference: {a['orbit_reference']}, period {a['orbit_reference_period']:.15g}, closure error "
        f"{a['orbit_reference_closure_error']:.1e}. Closure errors re-measured at rtol {a['orbit_check_rtol']:g}; "
        f"energy tolerance {ratio:g} x tolerance; wall time from the saddle (continuation, bracketing, "
        f"correction, monodromy), the {_repeat_rule(a, 'orbit_repeats', 'orbit_repeat_budget').description()}. "
        "`*` marks the family's own setting.",
        "",
        *_table_head(["tolerance", "integrator rtol", "wall s", "closure error", "period error", "energy error",
                      "x(0) error"]),
    ]
    for k in range(data.sizes["orbit_setting"]):
        head = (f"| {float(data.orbit_tolerance[k]):g}{_default_mark(data.orbit_is_default.values[k])} | {float(data.orbit_rtol[k]):g} "
                f"| {float(data.orbit_wall_time[k]):.3f} ")
        if not bool(data.orbit_converged.values[k]):
            lines.append(head + "| did not converge | | | |")
            continue
        errors = [data[name].values[k] for name in ("orbit_closure_error", "orbit_period_error", "orbit_energy_error",
                                                    "orbit_initial_state_error")]
        lines.append(head + "".join(f"| {_scientific(float(e))} " for e in errors) + "|")
    lines.append("")
    return lines


def _nhim_tables(data: xr.Dataset) -> list[str]:
    a = data.attrs
    lines = [
        f"## NHIM point on {a['nhim_map']}: detection and refinement",
        "",
        f"Exact point: the reference orbit's crossing of the slice, ({', '.join(a['nhim_axes'])}) = "
        f"({', '.join(f'{v:.12g}' for v in a['nhim_crossing'])}). Detection: the LD map at n x n points (forward and "
        "backward) and its cell of largest min(F/F_ridge, B/B_ridge); the plain maximum of F + B for comparison. "
        "Wall times (of the grid and of each refinement): the "
        f"{_repeat_rule(a, 'nhim_repeats', 'nhim_repeat_budget').description()}. `*` marks the map's own grid.",
        "",
        *_table_head(["n", "wall s", "cell diagonal", "distance (detected cell)", "distance (plain maximum)"]),
    ]
    for k in range(data.sizes["nhim_grid"]):
        lines.append(
            f"| {int(data.nhim_grid_points[k])}{_default_mark(data.nhim_grid_is_default.values[k])} | {float(data.nhim_grid_wall_time[k]):.3f} "
            f"| {_scientific(float(data.nhim_grid_diagonal[k]))} | {_scientific(float(data.nhim_detection_error[k]))} "
            f"| {_scientific(float(data.nhim_argmax_error[k]))} |"
        )
    lines += [
        "",
        f"Refinement from the detected cell of the {a['nhim_refinement_grid']} x {a['nhim_refinement_grid']} grid "
        f"(distance {a['nhim_refinement_start_error']:.1e}); bisection precision {a['nhim_precision_ratio']:g} x "
        "tolerance. `*` marks the configured tolerance (nhim.refinement.tolerance).",
        "",
        *_table_head(["tolerance", "method", "wall s", "trajectories", "distance from the crossing"], left=("method",)),
    ]
    for k in range(data.sizes["nhim_refinement"]):
        mark = _default_mark(data.nhim_refinement_is_default.values[k])
        for m, method in enumerate(data.nhim_method.values):
            head = f"| {float(data.nhim_tolerance[k]):g}{mark} | {method} "
            if not bool(data.nhim_refinement_converged.values[m, k]):
                lines.append(head + "| did not converge | | |")
                continue
            lines.append(
                head + f"| {float(data.nhim_refinement_wall_time[m, k]):.3f} "
                f"| {int(data.nhim_refinement_trajectories[m, k])} "
                f"| {_scientific(float(data.nhim_refinement_error[m, k]))} |"
            )
    lines.append("")
    return lines


def accuracy_table(data: xr.Dataset) -> str:
    """The measurements as Markdown: one table per LD map, one for the orbit ladder, two for the NHIM."""
    load = {when: ", ".join(f"{v:.2f}" for v in np.atleast_1d(data.attrs[f"load_average_{when}"]))
            for when in ("before", "after")}
    lines = [
        "# Accuracy against cost",
        "",
        f"Machine: {data.attrs['machine_cpu_model']}, {data.attrs['machine_cores']} cores, "
        f"{data.attrs['machine_threads_used']} threads used; load average (1, 5, 15 min) before {load['before']}, "
        f"after {load['after']}.",
        "",
    ]
    if "map" in data.dims:
        lines += _ld_tables(data)
    if "orbit_setting" in data.dims:
        lines += _orbit_table(data)
    if "nhim_grid" in data.dims:
        lines += _nhim_tables(data)
    return "\n".join(lines)


def run_accuracy_engine(*, output: str | Path, equilibria: list[str | Path], map: dict, setting: dict) -> Path:
    """Compile the engine of ``setting`` on the LD map ``map`` unless numba's cache holds it, and write its name to ``output``.

    The LD ladder then loads it from numba's cache; the measurement is unchanged (it times after a warm-up).
    """
    check_writable(output)  # before any work: never lose a run to a bad path
    found = _equilibria_by_system([equilibria] if isinstance(equilibria, (str, Path)) else list(equilibria))
    data = _equilibria_for(found, map["system_name"], f"accuracy_cost.ld.maps ({map['map_name']})")
    system, section, settings, info = resolve_map(map, data)
    settings = IntegratorStep.from_spec(setting).apply(settings)
    name = engine_name(system.name, settings.scheme, settings.lanes, settings.order)
    if engine_compiled(system, settings.scheme, settings.lanes, settings.order):
        how = "found compiled in the cache"
    else:
        states, _, _ = section_states(system, section, info["energy"])
        warm_up(system, states, settings)
        how = "compiled"
    log.info("engine %s %s (%s on map %s)", name, how, IntegratorStep.from_spec(setting).label, map["map_name"])
    return write_text_atomic(output, f"{name}: {IntegratorStep.from_spec(setting).label} on map {map['map_name']}\n")


def run_accuracy_cost(
    *,
    output: str | Path,
    table: str | Path,
    equilibria: list[str | Path],
    ld: dict,
    upo: dict,
    nhim: dict,
    threads: int | None = None,
) -> Path:
    """Measure both ladders, write the netCDF file ``output`` and the Markdown ``table``."""
    check_writable(output, table)  # before any work: never lose a run to a bad path
    if threads:
        numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
    data = accuracy_dataset(ld, upo, nhim, [equilibria] if isinstance(equilibria, (str, Path)) else list(equilibria))
    path = write_stage_file(data, output, stage=ACCURACY_COST, title="Accuracy against cost of the LD engine, the "
                            "periodic-orbit corrector and the NHIM detection", parameters={"ld": ld, "upo": upo, "nhim": nhim})
    table = write_text_atomic(table, accuracy_table(data))
    log.info("wrote %s and %s", path, table)
    return path
