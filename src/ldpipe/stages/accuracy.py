"""Accuracy–cost stage: the work–precision measurement of the LD engine and the orbit corrector.

Declared under ``accuracy_cost:`` in the configuration (see the schema): the LD maps whose
points are sampled, the ladder of integrator settings, the reference; the periodic-orbit
family, its energy and the ladder of correction and integrator tolerances; the variable-time
map of the NHIM ladders, its grid sizes and refinement tolerances. One netCDF file holds every
measurement (dimensions ``map``, ``setting``, ``direction``, ``point``, ``quantile``;
``orbit_setting``; ``nhim_grid``, ``nhim_method``, ``nhim_refinement``) with the machine and
its load in the attributes, and Markdown tables summarize it. The science is in
:mod:`ldpipe.core.accuracy`, the file's Dataset :func:`ldpipe.core.accuracy.measurement.accuracy_cost_dataset`;
this module writes it and its tables, and compiles the ladder's engines in jobs of their own.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from ..core.accuracy import IntegratorStep, RepeatRule, warm_up
from ..core.accuracy.measurement import accuracy_cost_dataset, equilibria_by_system, equilibria_for
from ..io.atomic import check_writable, write_text_atomic
from ..core.maps.assembly import resolve_map
from ..core.sections import section_states
from ..engine.codegen import engine_compiled, engine_name
from ..io.datafile import write_stage_file
from ..logs import get_logger

log = get_logger(__name__)


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
    found = equilibria_by_system([equilibria] if isinstance(equilibria, (str, Path)) else list(equilibria))
    data = equilibria_for(found, map["system_name"], f"accuracy_cost.ld.maps ({map['map_name']})")
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
    """Measure every ladder, write the netCDF file ``output`` and the Markdown ``table``
    (:func:`ldpipe.core.accuracy.measurement.accuracy_cost_dataset`)."""
    check_writable(output, table)  # before any work: never lose a run to a bad path
    data = accuracy_cost_dataset({"ld": ld, "upo": upo, "nhim": nhim}, equilibria, threads=threads)
    path = write_stage_file(data, output)
    table = write_text_atomic(table, accuracy_table(data))
    log.info("wrote %s and %s", path, table)
    return path
