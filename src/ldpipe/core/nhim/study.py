"""NHIM studies of LD maps, as the NHIM study stage's file records them (slices through points of
periodic orbits: :mod:`.orbit_slices`).

* :func:`nhim_study_dataset`: the NHIM study stage's product, every slice of a study (LD maps
  given, or derived slices computed here) by :func:`study_map_slice`, as its file holds it.
* :func:`study_map_slice`: a slice of an LD map: its NHIM point detected on the grid, refined by
  fates and by zoomed re-gridding, the residence evidence, and the distance of each point from the
  reference (the periodic orbit's crossing of a 2 DoF section; the closest sample of a Lyapunov
  orbit for higher DoF).

The slice functions take arrays and return records; :func:`nhim_study_dataset` reads its input
files (or Datasets) through :func:`ldpipe.io.datafile.open_stage_file` and writes nothing.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Mapping, Sequence

import numpy as np
import xarray as xr

from ...engine import use_threads
from ...errors import ConfigError
from ...io.contracts import EQUILIBRIA, NHIM, UPO
from ...io.datafile import input_name, open_stage_file, stage_dataset, stage_parameters
from ...logs import get_logger
from ..maps.assembly import compute_ld_map
from ..maps.grid import open_map_file, resolve_ld_map
from .detection import detect_global_argmax, detect_nhim_cell
from .evidence import orbit_section_crossing, orbit_section_residual, residence_evidence
from .fates import RefinementFailed, RefinementSettings
from .refinement import ld_at_points, refine_by_fates, refine_by_ld_zoom
from .slices import SliceProblem, make_slice_problem, section_point_states

log = get_logger(__name__)

#: A periodic orbit at a slice's energy: its state at t = 0, its period, and its samples over one
#: period (shape (s, 2 n_dof)), as a family's file holds them.
ReferenceOrbit = tuple[np.ndarray, float, np.ndarray]


def study_map_slice(
    problem: SliceProblem, ld_forward: np.ndarray, ld_backward: np.ndarray, allowed: np.ndarray,
    axes: tuple[np.ndarray, np.ndarray], reference_orbits: Mapping[str, ReferenceOrbit | None],
    settings: RefinementSettings, zoom: bool = True,
) -> dict:
    """Detection, both refinements, evidence and reference comparison of one LD map's slice, as a flat record.

    Parameters
    ----------
    ld_forward, ld_backward, allowed : ndarray, shape (n_a, n_b)
        The map's fields on the section's grid, ``axes`` its coordinates.
    reference_orbits : mapping of family name to ReferenceOrbit or None
        Each reference family's orbit at the slice's energy, None where the family has none. For a
        2 DoF section the first family's orbit is the reference and must exist (its crossing of the
        section is exact); for higher DoF the family whose orbit comes closest to the section is.
    zoom : bool
        Also refine by zoomed re-gridding (otherwise its record is the detected point, not converged).

    Returns
    -------
    dict
        Named as the NHIM study file's variables (``map`` is the slice's name).
    """
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
    if problem.system.n_dof == 2 and reference_orbits:
        family, orbit = next(iter(reference_orbits.items()))
        if orbit is None:
            raise ConfigError(f"family {family} has no orbit at E = {problem.energy:.12g} "
                              f"(dE = {problem.excess_energy:.6g}) of slice {problem.name}; add the energy to the family")
        state, period, _ = orbit
        record.update(reference_kind="orbit_crossing", reference_family=family,
                      reference_point=orbit_section_crossing(problem, state, period))
    elif reference_orbits:
        best = None
        for family, orbit in reference_orbits.items():
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


#: A stage file: its path, or the Dataset itself (as the Python API gives it).
StageInput = str | os.PathLike | xr.Dataset


def nhim_study_dataset(parameters: dict, maps: Sequence[StageInput] = (), references: Sequence[StageInput] = (),
                       equilibria: StageInput | None = None, *, threads: int | None = None) -> xr.Dataset:
    """Detect and refine the NHIM point of every slice of a study: the NHIM study stage's file (contract NHIM).

    Parameters
    ----------
    parameters : dict
        The stage's (``parameters_from_config(config, "nhim", study)``): ``study``, ``refinement``
        (the ``nhim.refinement`` section), ``references`` (periodic-orbit family names) and
        ``derived`` (map parameters of slices computed here; optional).
    maps : sequence of path or xarray.Dataset
        LD map files (stage ``ld_grid``), variable-time.
    references : sequence of path or xarray.Dataset
        The families' files (stage ``upo``), in the order of ``parameters["references"]``.
    equilibria : path or xarray.Dataset, optional
        The system's equilibria, which derived slices need.
    threads : int, optional
        Threads of the engine (default every core).
    """
    use_threads(threads)
    study, refinement, derived = parameters["study"], parameters["refinement"], parameters.get("derived")
    zoom = refinement.get("zoom", True)
    settings = RefinementSettings(**{k: v for k, v in refinement.items() if k != "zoom"})
    references = dict(zip(parameters.get("references", ()), references))
    families = {family: open_stage_file(path, stage=UPO) for family, path in references.items()}
    records = []
    phase = None
    sources = []
    for path in maps:
        data = open_map_file(path, f"NHIM study {study!r} (the forward plus backward LD)")
        sources.append((data, stage_parameters(data)))
    if derived:
        if equilibria is None:
            raise ValueError(f"study {study}: derived slices need the system's equilibria file")
        eq = open_stage_file(equilibria, stage=EQUILIBRIA)
        for map_parameters in derived:
            sources.append((compute_ld_map(map_parameters, eq, show_progress=False), map_parameters))
    if not sources:
        raise ConfigError(f"config key 'nhim.studies.{study}': no slices (give 'maps' or 'derived')")
    for data, map_parameters in sources:
        problem = _problem_from_map(data, map_parameters)
        if phase is None:
            phase = problem.system.phase_coordinates
        elif phase != problem.system.phase_coordinates:
            raise ConfigError(f"config key 'nhim.studies.{study}': slices of different systems; one system per study")
        axes = (data[problem.section.axes[0]].values, data[problem.section.axes[1]].values)
        reference_orbits = {family: _orbit_at_energy(orbits, problem.energy) for family, orbits in families.items()}
        records.append(study_map_slice(problem, data.ld_forward.values, data.ld_backward.values,
                                       data.allowed.values.astype(bool), axes, reference_orbits, settings, zoom=zoom))
    dataset = _study_dataset(records, phase)
    dataset.attrs.update(problem.system.kinetic_attributes())
    dataset.attrs.update({f"refinement_{k}": (int(v) if isinstance(v, bool) else v) for k, v in refinement.items()})
    dataset.attrs["study"] = study
    recorded = {"study": study, "refinement": refinement, "maps": [input_name(m) for m in maps],
                "derived": derived or [], "references": {family: input_name(f) for family, f in references.items()}}
    return stage_dataset(dataset, stage=NHIM, title=f"NHIM points of study {study}", parameters=recorded)


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


def _orbit_at_energy(data: xr.Dataset, energy: float) -> ReferenceOrbit | None:
    """(initial state, period, samples) of the orbit of a UPO file at ``energy``, or None."""
    match = np.flatnonzero(np.abs(data.energy.values - energy) <= 1e-9 * max(1.0, abs(energy)))
    if not len(match):
        return None
    i = int(match[0])
    return data.initial_state.values[i], float(data.period.values[i]), data.trajectory.values[i]


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
    dataset["detected_point"].attrs["long_name"] = "grid point of largest min(F / F_ridge, B / B_ridge) (ldpipe.core.nhim.nhim_score)"
    dataset["argmax_sum_point"].attrs["long_name"] = "grid point of largest ld_forward + ld_backward (naive)"
    dataset["zoom_point"].attrs["long_name"] = "NHIM point refined by zoomed re-gridding of both LDs"
    dataset["reference_point"].attrs["long_name"] = (
        "orbit_crossing: the periodic orbit's crossing of the section; closest_orbit_sample: the Lyapunov orbit "
        "sample closest to the section (reference_residual away from it)")
    dataset.attrs["phase_coordinates"] = " ".join(system_phase)
    return dataset
