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
(:mod:`ldpipe.stages.nhim_validation`) turns the studies into
tables and fails when a point is too far from its reference. The science of a slice is
:func:`ldpipe.core.nhim.study_map_slice`; this module reads the maps and orbit files and writes the
study file.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from ..io.atomic import check_writable
from ..io.contracts import EQUILIBRIA, LD_GRID, NHIM, UPO
from ..io.datafile import input_name, open_stage_file, stage_parameters, write_stage_file
from ..errors import ConfigError
from ..core.maps.grid import resolve_ld_map
from ..logs import get_logger
from ..core.nhim import ReferenceOrbit, RefinementSettings, SliceProblem, make_slice_problem, study_map_slice
from ..core.maps import assembly

log = get_logger(__name__)


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
    check_writable(output)  # before any work: never lose a run to a bad path
    import numba

    if threads:
        numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
    zoom = refinement.get("zoom", True)
    settings = RefinementSettings(**{k: v for k, v in refinement.items() if k != "zoom"})
    references = dict(zip(references, reference_files))
    families = {family: open_stage_file(path, stage=UPO) for family, path in references.items()}
    records = []
    phase = None
    sources = []
    for path in maps:
        data = open_stage_file(path, stage=LD_GRID, only=True)
        sources.append((data, stage_parameters(data)))
    if derived:
        if equilibria is None:
            raise ValueError(f"study {study}: derived slices need the system's equilibria file")
        eq = open_stage_file(equilibria, stage=EQUILIBRIA)
        for parameters in derived:
            sources.append((assembly.compute_ld_map(parameters, eq, show_progress=False), parameters))
    if not sources:
        raise ConfigError(f"config key 'nhim.studies.{study}': no slices (give 'maps' or 'derived')")
    for data, parameters in sources:
        problem = _problem_from_map(data, parameters)
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
    path = write_stage_file(dataset, output, stage=NHIM, title=f"NHIM points of study {study}", parameters=recorded)
    log.info("wrote %s (%d slices)", path, len(records))
    return path
