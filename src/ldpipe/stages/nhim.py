"""NHIM stage: detection and refinement of NHIM points on LD maps, checked against periodic orbits.

A study is declared under ``nhim.studies`` in the configuration (see the
schema): a list of LD maps from the LD stage (``maps``), or slices derived from
one of them (``derived``: other values of a fixed coordinate and other excess
energies, computed here on a small grid). For every slice the study file holds
the grid point the detection criterion picks, the plain global argmax of
ld_forward + ld_backward, the point refined by fate bisection and by zoomed
re-gridding, their LD values and exit times, the cost of each refinement, the
residence evidence, and the reference: for 2 DoF sections the crossing of the
family's periodic orbit at the slice's energy, for higher DoF the closest
approach of each Lyapunov orbit to the section. The validation
(:mod:`ldpipe.stages.nhim_validation`, re-exported here) turns the studies into
tables and fails when a point is too far from its reference (:mod:`ldpipe.nhim`
has the science).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import xarray as xr

from ..io.contracts import EQUILIBRIA, LD_GRID, NHIM, UPO
from ..io.datafile import open_stage_file, stage_parameters, write_stage_file
from ..errors import ConfigError
from ..ld_grid import resolve_ld_map
from ..logs import get_logger
from ..nhim import (
    RefinementFailed, RefinementSettings, SliceProblem, detect_global_argmax, detect_nhim_cell, ld_at_points,
    make_slice_problem, orbit_section_crossing, orbit_section_residual, refine_by_fates, refine_by_ld_zoom,
    residence_evidence, section_point_states,
)
from . import ld as ld_stage

log = get_logger(__name__)


def nhim_study_inputs(config: dict, study: str) -> dict[str, list[str]]:
    """Names the study reads: LD maps (``maps``), periodic-orbit families (``references``), and the system whose
    equilibria a derived study needs (``systems``)."""
    spec = config["nhim"]["studies"][study]
    systems = []
    if "derived" in spec:
        systems = [config["ld_maps"][spec["derived"]["base_map"]]["system"]]
    return {"maps": list(spec.get("maps", [])), "references": list(spec.get("reference", [])), "systems": systems}


# ----------------------------------------------------------------------------------------------


def _problem_from_map(dataset: xr.Dataset, parameters: dict) -> SliceProblem:
    """The slice problem of an LD map file (or an in-memory map): its recorded parameters, resolved
    at the saddle the map records it was computed at, exactly as the LD stage resolved them."""
    saddle = np.asarray(dataset.attrs["saddle_position"], dtype=np.float64)
    system, section, settings, info = resolve_ld_map(parameters, saddle, float(dataset.attrs["critical_energy"]))
    if section.shape != tuple(dataset.sizes[axis] for axis in section.axes):
        raise ValueError(f"LD map {parameters['map_name']}: grid {dict(dataset.sizes)} is not its section's {section.shape}")
    if not settings.variable_time:
        raise ConfigError(f"LD map {parameters['map_name']}: NHIM detection needs a variable-time map with a saddle "
                          f"region; this one is {parameters['time']} time")
    return make_slice_problem(parameters["map_name"], system, section, info["energy"], info["critical_energy"],
                              saddle, settings)


def _orbits_at_energy(path: str | Path, energy: float) -> tuple[np.ndarray, float, np.ndarray] | None:
    """(initial state, period, samples) of the orbit of a UPO file at ``energy``, or None."""
    data = open_stage_file(path, stage=UPO)
    match = np.flatnonzero(np.abs(data.energy.values - energy) <= 1e-9 * max(1.0, abs(energy)))
    if not len(match):
        return None
    i = int(match[0])
    return data.initial_state.values[i], float(data.period.values[i]), data.trajectory.values[i]


def analyse_slice(
    problem: SliceProblem, ld_forward: np.ndarray, ld_backward: np.ndarray, allowed: np.ndarray,
    axes: tuple[np.ndarray, np.ndarray], references: dict[str, str | Path], settings: RefinementSettings,
    zoom: bool = True,
) -> dict:
    """Detection, both refinements, evidence and reference comparison of one slice, as a flat record."""
    record: dict = {"map": problem.name, "axis_names": list(problem.section.axes), "energy": problem.energy,
                    "excess_energy": problem.excess_energy, "grid_spacing": problem.spacing}
    detected = detect_nhim_cell(ld_forward, ld_backward, allowed, axes)
    naive = detect_global_argmax(ld_forward, ld_backward, allowed, axes)
    i, j = detected.index
    record.update(detected_point=detected.point, detected_score=detected.score, argmax_sum_point=naive.point,
                  detected_grid_ld_forward=float(ld_forward[i, j]), detected_grid_ld_backward=float(ld_backward[i, j]))
    fates = refine_by_fates(problem, detected.point, settings)
    record.update(refined_point=fates.point, refined_uncertainty=fates.uncertainty, refined_iterations=fates.iterations,
                  refined_trajectories=fates.cost.trajectories, refined_time_units=fates.cost.time_units,
                  refined_steps=fates.cost.steps, refined_wall_time=fates.cost.wall_time, manifold_angle=fates.angle)
    log.info("%s: detected %s (score %.3f), refined by fates to %s (+- %.2g, %d iterations, %d trajectories, %.2f s)",
             problem.name, detected.point, detected.score, fates.point, fates.uncertainty, fates.iterations,
             fates.cost.trajectories, fates.cost.wall_time)
    record["zoom_converged"] = False
    record.update(zoom_point=detected.point, zoom_uncertainty=0.0, zoom_iterations=0, zoom_trajectories=0,
                  zoom_time_units=0.0, zoom_wall_time=0.0)
    if zoom:
        try:
            z = refine_by_ld_zoom(problem, detected.point, settings)
            record.update(zoom_converged=True, zoom_point=z.point, zoom_uncertainty=z.uncertainty,
                          zoom_iterations=z.iterations, zoom_trajectories=z.cost.trajectories,
                          zoom_time_units=z.cost.time_units, zoom_wall_time=z.cost.wall_time)
            log.info("%s: zoomed re-gridding to %s (%d iterations), %.3g from the fate refinement", problem.name,
                     z.point, z.iterations, np.linalg.norm(z.point - fates.point))
        except RefinementFailed as error:
            log.warning("%s: zoomed re-gridding failed (%s); the fate refinement stands", problem.name, error)
    record["refined_state"] = section_point_states(problem, fates.point[None, :])[0][0]
    tight = dataclasses.replace(problem.ld_settings, scheme="dop853", rtol=settings.rtol, atol=settings.atol)
    values = ld_at_points(problem, np.vstack([detected.point, fates.point]), tight)
    for name, array in values.items():
        record[f"detected_{name}"] = float(array[0])
        record[f"refined_{name}"] = float(array[1])
    evidence = residence_evidence(problem, fates.point, settings)
    record.update(evidence)
    record.update(reference_kind="none", reference_family="", reference_point=np.zeros(2), reference_residual=0.0)
    if problem.system.n_dof == 2 and references:
        family, path = next(iter(references.items()))
        orbit = _orbits_at_energy(path, problem.energy)
        if orbit is None:
            raise ConfigError(f"{path}: family {family} has no orbit at E = {problem.energy:.12g} "
                              f"(dE = {problem.excess_energy:.6g}) of slice {problem.name}; add the energy to it")
        state, period, _ = orbit
        record.update(reference_kind="orbit_crossing", reference_family=family,
                      reference_point=orbit_section_crossing(problem, state, period))
    elif references:
        best = None
        for family, path in references.items():
            orbit = _orbits_at_energy(path, problem.energy)
            if orbit is None:
                continue
            residual, point = orbit_section_residual(problem, orbit[2])
            if best is None or residual < best[0]:
                best = (residual, point, family)
        if best is not None:
            record.update(reference_kind="closest_orbit_sample", reference_family=best[2], reference_point=best[1],
                          reference_residual=best[0])
    reference = record["reference_point"]
    for name in ("refined", "zoom", "detected", "argmax_sum"):
        record[f"distance_{name}"] = (float(np.linalg.norm(record[f"{name}_point"] - reference))
                                      if record["reference_kind"] != "none" else 0.0)
    record["distance_zoom_to_refined"] = float(np.linalg.norm(record["zoom_point"] - fates.point))
    log.info("%s: reference %s (%s): distance refined %.3g, detected %.3g, argmax of F + B %.3g; residence %.2f, "
             "%.2f, neighbours at most %.2f", problem.name, record["reference_kind"], record["reference_family"],
             record["distance_refined"], record["distance_detected"], record["distance_argmax_sum"],
             record["residence_forward"], record["residence_backward"], record["neighbour_residence_max"])
    return record


def _study_dataset(records: list[dict], system_phase: tuple[str, ...]) -> xr.Dataset:
    slices = [r["map"] for r in records]
    variables = {}
    units = {"wall_time": "s"}
    for key in records[0]:
        if key in ("map",):
            continue
        values = [r[key] for r in records]
        if key == "axis_names":
            variables[key] = (("slice", "axis"), np.array(values, dtype=str))
        elif key == "refined_state":
            variables[key] = (("slice", "phase"), np.array(values, dtype=np.float64),
                              {"long_name": "phase-space state of the refined point (solved momentum from the energy)"})
        elif np.ndim(values[0]) == 1:
            variables[key] = (("slice", "axis"), np.array(values, dtype=np.float64))
        elif isinstance(values[0], str):
            variables[key] = ("slice", np.array(values, dtype=str))
        elif isinstance(values[0], (bool, np.bool_)):
            variables[key] = ("slice", np.array(values, dtype=bool))
        elif isinstance(values[0], (int, np.integer)):
            variables[key] = ("slice", np.array(values, dtype=np.int64))
        else:
            variables[key] = ("slice", np.array(values, dtype=np.float64))
    dataset = xr.Dataset(variables, coords={"slice": slices, "axis": [0, 1], "phase": list(system_phase)})
    for name in dataset.data_vars:
        if name.endswith("wall_time"):
            dataset[name].attrs["units"] = units["wall_time"]
    dataset["refined_point"].attrs["long_name"] = "NHIM point refined by bisection on forward and backward fates"
    dataset["detected_point"].attrs["long_name"] = "grid point of largest min(F / F_ridge, B / B_ridge) (ldpipe.nhim.nhim_score)"
    dataset["argmax_sum_point"].attrs["long_name"] = "grid point of largest ld_forward + ld_backward (naive)"
    dataset["zoom_point"].attrs["long_name"] = "NHIM point refined by zoomed re-gridding of both LDs"
    dataset["reference_point"].attrs["long_name"] = (
        "orbit_crossing: the periodic orbit's crossing of the section; closest_orbit_sample: the Lyapunov orbit "
        "sample closest to the section (reference_residual away from it)")
    dataset.attrs["phase_coordinates"] = " ".join(system_phase)
    return dataset


def run_nhim_study(
    *,
    study: str,
    refinement: dict,
    output: str | Path,
    maps: list[str | Path] = (),
    derived: list[dict] | None = None,
    equilibria: str | Path | None = None,
    references: list[str] = (),
    reference_files: list[str | Path] = (),
    threads: int | None = None,
) -> Path:
    """Detect and refine the NHIM point of every slice of a study and write the study file.

    Parameters
    ----------
    maps : list of paths
        LD map files (stage ``ld_grid``), variable-time.
    derived : list of dict, optional
        Map parameters (``parameters_from_config(config, "ld", name)``) of slices computed here;
        needs ``equilibria``.
    references, reference_files : lists of the same length
        Periodic-orbit family names and their UPO files.
    refinement : dict
        The ``nhim.refinement`` config section.
    """
    import numba

    if threads:
        numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
    zoom = refinement.get("zoom", True)
    settings = RefinementSettings(**{k: v for k, v in refinement.items() if k != "zoom"})
    references = dict(zip(references, reference_files))
    records = []
    phase = None
    sources = []
    for path in maps:
        data = open_stage_file(path, stage=LD_GRID)
        sources.append((data, stage_parameters(data)))
    if derived:
        if equilibria is None:
            raise ValueError(f"study {study}: derived slices need the system's equilibria file")
        eq = open_stage_file(equilibria, stage=EQUILIBRIA)
        for parameters in derived:
            sources.append((ld_stage.compute_ld_map(parameters, eq, show_progress=False), parameters))
    if not sources:
        raise ConfigError(f"config key 'nhim.studies.{study}': no slices (give 'maps' or 'derived')")
    for data, parameters in sources:
        problem = _problem_from_map(data, parameters)
        if phase is None:
            phase = problem.system.phase_coordinates
        elif phase != problem.system.phase_coordinates:
            raise ConfigError(f"config key 'nhim.studies.{study}': slices of different systems; one system per study")
        axes = (data[problem.section.axes[0]].values, data[problem.section.axes[1]].values)
        records.append(analyse_slice(problem, data.ld_forward.values, data.ld_backward.values,
                                     data.allowed.values.astype(bool), axes, references, settings, zoom=zoom))
    dataset = _study_dataset(records, phase)
    dataset.attrs.update(problem.system.kinetic_attributes())
    dataset.attrs.update({f"refinement_{k}": (int(v) if isinstance(v, bool) else v) for k, v in refinement.items()})
    dataset.attrs["study"] = study
    recorded = {"study": study, "refinement": refinement, "maps": [str(m) for m in maps], "derived": derived or [],
                "references": references}
    path = write_stage_file(dataset, output, stage=NHIM, title=f"NHIM points of study {study}", parameters=recorded)
    log.info("wrote %s (%d slices)", path, len(records))
    return path
