"""Slices through points of periodic orbits, which lie on the NHIM, as the orbit validation
stage's file records them.

* :func:`validate_orbit_slice`: a slice through a point of a periodic orbit: every crossing in the
  window around the point, refined, and the slice's status (the orbit point found, degenerate
  with a reason, or failed) against that exact point; :func:`validate_orbit_slices`, the slices
  through points of one orbit at once.
* :func:`orbit_validation_dataset`: the orbit validation stage's product, every slice through the
  points of a study's orbits, as its file holds it.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Sequence

import numpy as np
import xarray as xr

from ...engine import LDSettings, use_threads
from ...errors import ConfigError
from ...io.contracts import EQUILIBRIA, NHIM_ORBITS, UPO
from ...io.datafile import open_stage_file, stage_dataset
from ...logs import get_logger
from ...systems import System
from ..equilibria.potential import select_saddle
from ..maps.grid import resolve_ld_map
from ..variational import propagate
from .crossings import SliceCrossings, find_crossings_together
from .fates import RefinementSettings
from .slices import boundary_distance, make_slice_problem, point_slice, slice_transversality

log = get_logger(__name__)

#: A stage file: its path, or the Dataset itself (as the Python API gives it).
StageInput = str | os.PathLike | xr.Dataset


def orbit_validation_dataset(parameters: dict, orbits: Sequence[StageInput], equilibria: StageInput, *,
                             threads: int | None = None) -> xr.Dataset:
    """Search every slice of an orbit validation study for its NHIM crossings: the stage's file
    (contract NHIM_ORBITS).

    For each family of ``parameters["orbits"]``, each energy, each of ``phases`` points along the
    orbit and each slice kind, the slice through the point (:func:`validate_orbit_slices`, the
    slices of one orbit together) with its status and its refined crossings.

    Parameters
    ----------
    parameters : dict
        The stage's (``parameters_from_config(config, "nhim_orbits", study)``): ``study``,
        ``base_map`` (an LD map's parameters: the system, saddle, region and escape radius),
        ``refinement`` (``nhim.refinement`` without ``zoom``), and the study's keys ``orbits``
        (family names), ``energies``, ``phases``, ``slices``, ``half_width``, ``points``,
        ``boundary_cells``, ``min_transversality``, ``tolerance``.
    orbits : sequence of path or xarray.Dataset
        The families' files (stage ``upo``), in the order of ``parameters["orbits"]``.
    equilibria : path or xarray.Dataset
        The system's equilibria (the saddle the base map's ``saddle_near`` selects).
    threads : int, optional
        Threads of the engine (default every core).
    """
    use_threads(threads)
    study, base_map, refinement = parameters["study"], parameters["base_map"], parameters["refinement"]
    energies, phases, slices = parameters["energies"], parameters["phases"], parameters["slices"]
    half_width, points, tolerance = parameters["half_width"], parameters["points"], parameters["tolerance"]
    boundary_cells, min_transversality = parameters["boundary_cells"], parameters["min_transversality"]
    key = f"nhim.orbit_validation.{study}"
    settings = RefinementSettings(**refinement)
    if tolerance < settings.tolerance:
        raise ConfigError(f"config key '{key}.tolerance': {tolerance:g} is below nhim.refinement.tolerance "
                          f"{settings.tolerance:g} (the refined points' own accuracy)")
    if points % 2 == 0:
        raise ConfigError(f"config key '{key}.points': {points} must be odd, so the orbit point is a grid point")
    eq = open_stage_file(equilibria, stage=EQUILIBRIA)
    saddle, critical = select_saddle(eq, base_map.get("saddle_near"))
    system, _, ld_settings, _ = resolve_ld_map(base_map, saddle, critical)
    phase_names = system.phase_coordinates
    slice_rows, crossing_rows = [], []
    for family, path in zip(parameters["orbits"], orbits):
        data = open_stage_file(path, stage=UPO)
        for k in _orbit_at(data, energies, key):
            energy, period = float(data.energy.values[k]), float(data.period.values[k])
            samples = data.trajectory.values[k]
            indices = [round(j * (len(samples) - 1) / phases) for j in range(phases)]
            monodromies = [propagate(system, samples[index], period, rtol=settings.rtol, atol=settings.atol).stm
                           for index in indices]
            # every slice of the orbit at once, so that those of one pair of axes refine together
            points_slices = [(index, samples[index], axes, monodromy)
                             for index, monodromy in zip(indices, monodromies) for axes in slices]
            outcomes = validate_orbit_slices(
                system, [(state, axes, monodromy) for _, state, axes, monodromy in points_slices], family=family,
                energy=energy, critical_energy=critical, saddle=saddle, ld_settings=ld_settings, settings=settings,
                half_width=half_width, points=points, boundary_cells=boundary_cells,
                min_transversality=min_transversality, tolerance=tolerance)
            for (index, state, _, _), (row, crossings) in zip(points_slices, outcomes):
                crossing_rows += [{"slice": len(slice_rows), **crossing} for crossing in crossings]
                row.update(family=family, energy=energy, excess_energy=energy - critical,
                           orbit_phase=index / (len(samples) - 1), orbit_state=state)
                slice_rows.append(row)
                log.info("%s: %s", row["name"], row["status"] + (f" ({row['reason']})" if row["reason"] else ""))
    dataset = _orbit_validation_variables(slice_rows, crossing_rows, phase_names)
    recorded = {"study": study, "base_map": base_map["map_name"], "orbits": parameters["orbits"], "energies": energies,
                "phases": phases, "slices": slices, "half_width": half_width, "points": points,
                "boundary_cells": boundary_cells, "min_transversality": min_transversality,
                "tolerance": tolerance, "refinement": refinement}
    dataset.attrs.update({"study": study, "tolerance": tolerance, "half_width": half_width, "points": points,
                          "boundary_cells": boundary_cells, "min_transversality": min_transversality})
    # Every refinement setting in effect (defaults included), not only those the config gave.
    dataset.attrs.update({f"refinement_{k}": v for k, v in dataclasses.asdict(settings).items()})
    return stage_dataset(dataset, stage=NHIM_ORBITS, title=f"NHIM crossings of slices through periodic orbits, study {study}",
                         parameters=recorded)


def _orbit_at(data: xr.Dataset, energies: dict, key: str) -> list[int]:
    """Indices of the family file's orbits at the study's energies (total or excess)."""
    field, values = ("excess_energy", energies["excess"]) if "excess" in energies else ("energy", energies["total"])
    indices = []
    for value in values:
        match = np.flatnonzero(np.abs(data[field].values - value) <= 1e-9 * max(1.0, abs(value)))
        if not len(match):
            raise ConfigError(f"config key '{key}.energies': family {data.attrs['family']} has no orbit at "
                              f"{field.replace('_', ' ')} {value:g}; add it to periodic_orbits.{data.attrs['family']}")
        indices.append(int(match[0]))
    return indices


def _orbit_validation_variables(slice_rows: list[dict], crossing_rows: list[dict], phase: tuple[str, ...]) -> xr.Dataset:
    variables = {}
    for key in slice_rows[0]:
        values = [r[key] for r in slice_rows]
        if key in ("orbit_point",):
            variables[key] = (("slice", "axis"), np.array(values, dtype=np.float64))
        elif key == "orbit_state":
            variables[key] = (("slice", "phase"), np.array(values, dtype=np.float64))
        elif key == "axis_names":
            variables[key] = (("slice", "axis"), np.array(values, dtype=str))
        elif isinstance(values[0], str):
            variables[key] = ("slice", np.array(values, dtype=str))
        elif isinstance(values[0], (int, np.integer)):
            variables[key] = ("slice", np.array(values, dtype=np.int64))
        else:
            variables[key] = ("slice", np.array(values, dtype=np.float64))
    variables["crossing_slice"] = ("crossing", np.array([c["slice"] for c in crossing_rows], dtype=np.int64))
    variables["crossing_point"] = (("crossing", "axis"), np.array([c["point"] for c in crossing_rows]).reshape(-1, 2))
    for key in ("uncertainty", "angle", "distance"):
        variables[f"crossing_{key}"] = ("crossing", np.array([c[key] for c in crossing_rows], dtype=np.float64))
    dataset = xr.Dataset(variables, coords={"slice": np.arange(len(slice_rows)), "axis": [0, 1], "phase": list(phase),
                                            "crossing": np.arange(len(crossing_rows))})
    long_names = {
        "orbit_point": "the orbit point's values of the slice's two axes (the window's centre)",
        "boundary_distance": "distance to where the solved momentum vanishes, first order (capped at the window's width)",
        "transversality": ("slice's transversality to the NHIM at the orbit point (0: tangent), from the monodromy; "
                           "0 also where not computed (solved_momentum_vanishes)"),
        "distance": "distance of the nearest refined crossing from the orbit point (-1: none refined)",
        "orbit_phase": "time of the orbit point over the period",
        "candidates": "separated groups of grid cells crossed by both manifold curves",
        "crossings": "distinct refined crossings inside the window",
        "crossing_point": "a refined crossing (section coordinates of its slice)",
        "crossing_distance": "distance of the crossing from its slice's orbit point",
    }
    for name, text in long_names.items():
        if name in dataset:
            dataset[name].attrs["long_name"] = text
    dataset["wall_time"].attrs["units"] = "s"
    return dataset


def validate_orbit_slice(
    system: System, state: np.ndarray, axes: tuple[str, str], monodromy: np.ndarray, *, family: str, energy: float,
    critical_energy: float, saddle: np.ndarray, ld_settings: LDSettings, settings: RefinementSettings,
    half_width: float, points: int, boundary_cells: float, min_transversality: float, tolerance: float,
) -> tuple[dict, list[dict]]:
    """Every NHIM crossing of the slice through an orbit point, and the slice's status against that point.

    The slice (:func:`point_slice`) has ``axes`` and a ``points`` x ``points`` window of half-width
    ``half_width`` centred on ``state``, a point of a periodic orbit of ``family`` at ``energy``
    whose monodromy matrix started there is ``monodromy``. Its status is ``ok`` (a refined crossing
    within ``tolerance`` of the orbit point), ``degenerate:solved_momentum_vanishes`` (the energy
    boundary within ``boundary_cells`` grid cells; not searched), ``degenerate:tangent``
    (transversality below ``min_transversality``; crossings recorded, not checked), or
    ``fail:no_crossing``, ``fail:not_converged``, ``fail:missed``; ``reason`` says why.

    Returns
    -------
    row : dict
        The slice's record, named as the orbit validation file's ``slice`` variables.
    crossings : list of dict
        Its refined crossings inside the window: ``point``, ``uncertainty``, ``angle``, and
        ``distance`` from the orbit point.
    """
    ((row, crossings),) = validate_orbit_slices(
        system, [(state, axes, monodromy)], family=family, energy=energy, critical_energy=critical_energy,
        saddle=saddle, ld_settings=ld_settings, settings=settings, half_width=half_width, points=points,
        boundary_cells=boundary_cells, min_transversality=min_transversality, tolerance=tolerance)
    return row, crossings


def validate_orbit_slices(
    system: System, slices: list[tuple[np.ndarray, tuple[str, str], np.ndarray]], *, family: str, energy: float,
    critical_energy: float, saddle: np.ndarray, ld_settings: LDSettings, settings: RefinementSettings,
    half_width: float, points: int, boundary_cells: float, min_transversality: float, tolerance: float,
) -> list[tuple[dict, list[dict]]]:
    """:func:`validate_orbit_slice` of each ``(state, axes, monodromy)`` of ``slices`` (points of one orbit
    of ``family`` at ``energy``), in order; the searched slices of one pair of axes and solved momentum
    refine their candidates together (:func:`ldpipe.core.nhim.find_crossings_together`)."""
    phase = system.phase_coordinates
    prepared, families = [], {}
    for state, axes, monodromy in slices:
        section = point_slice(system, state, tuple(axes), half_width, points)
        centre = np.array([state[phase.index(a)] for a in axes])
        momentum = float(state[phase.index(section.solve)])
        name = f"{family}/E{energy:.6g}/{'-'.join(axes)}@{'_'.join(f'{v:.4f}' for v in centre)}"
        row = {"name": name, "axis_names": list(axes), "solve": section.solve, "orbit_point": centre,
               "solved_momentum": momentum, "boundary_distance": 0.0, "transversality": 0.0, "candidates": 0, "crossings": 0, "not_converged": 0,
               "tangent_candidates": 0, "distance": -1.0, "uncertainty": 0.0, "allowed_fraction": 0.0,
               "trajectories": 0, "wall_time": 0.0, "status": "", "reason": ""}
        boundary = boundary_distance(system, section, state)
        reach = boundary_cells * 2 * half_width / (points - 1)
        row["boundary_distance"] = min(boundary, 2 * half_width)  # finite: capped at the window's width
        if boundary < reach:
            row.update(status="degenerate:solved_momentum_vanishes", reason=(
                f"{section.solve} = {momentum:.3g} vanishes {boundary:.3g} from the orbit point, within boundary_cells "
                f"{boundary_cells:g} grid cells ({reach:.3g})"))
            prepared.append((row, None))
            continue
        row["transversality"] = slice_transversality(system, section, state, monodromy)
        problem = make_slice_problem(name, system, section, energy, critical_energy, saddle, ld_settings)
        families.setdefault((tuple(section.axes), section.solve), []).append(problem)
        prepared.append((row, problem))
    found = {}
    for problems in families.values():
        found.update(zip(map(id, problems), find_crossings_together(problems, settings)))
    return [(row, []) if problem is None else _orbit_slice_outcome(row, found[id(problem)], tolerance, min_transversality)
            for row, problem in prepared]


def _orbit_slice_outcome(row: dict, found: SliceCrossings, tolerance: float,
                         min_transversality: float) -> tuple[dict, list[dict]]:
    """The searched slice's record completed from its crossings, and the crossings inside the window."""
    centre = row["orbit_point"]
    statuses = [c.status for c in found.crossings]
    row.update(candidates=len(statuses), crossings=statuses.count("refined"), not_converged=statuses.count("not_converged"),
               tangent_candidates=statuses.count("tangent"), allowed_fraction=found.allowed_fraction,
               trajectories=found.cost.trajectories, wall_time=found.cost.wall_time)
    crossings = [{"point": crossing.refined.point, "uncertainty": crossing.refined.uncertainty,
                  "angle": crossing.refined.angle, "distance": float(np.linalg.norm(crossing.refined.point - centre))}
                 for crossing in found.crossings if crossing.status == "refined"]
    if crossings:
        nearest = min(crossings, key=lambda c: c["distance"])
        row.update(distance=nearest["distance"], uncertainty=nearest["uncertainty"])
    if row["transversality"] < min_transversality:
        row.update(status="degenerate:tangent", reason=(
            f"transversality {row['transversality']:.3g} < min_transversality {min_transversality:g}; "
            f"{row['crossings']} crossing(s) of {row['candidates']} candidate(s) recorded, not checked"))
    elif not statuses:
        row.update(status="fail:no_crossing", reason=(
            f"no grid cell crossed by both manifold curves in the window ({found.forward_cells} crossed by W^s, "
            f"{found.backward_cells} by W^u)"))
    elif not crossings:
        messages = "; ".join(c.message for c in found.crossings if c.message)
        row.update(status="fail:not_converged", reason=f"{len(statuses)} candidate(s), none refined: {messages}")
    elif row["distance"] > tolerance:
        row.update(status="fail:missed", reason=(
            f"{len(crossings)} crossing(s) refined, the nearest {row['distance']:.3g} from the orbit point > tolerance "
            f"{tolerance:g}"))
    else:
        notes = [f"{len(crossings)} crossings in the window"] if len(crossings) > 1 else []
        if row["not_converged"] or row["tangent_candidates"]:
            notes.append(f"{row['not_converged'] + row['tangent_candidates']} other candidate(s) not refined: " + "; ".join(
                c.message for c in found.crossings if c.status in ("not_converged", "tangent")))
        row.update(status="ok", reason="; ".join(notes))
    return row, crossings
