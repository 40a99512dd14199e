"""NHIM orbit validation stage: slices through points of Lyapunov orbits, every crossing found and refined.

A Lyapunov orbit lies on the NHIM, so a slice that fixes every coordinate but its two axes and
one solved momentum at the values of an orbit point (:func:`ldpipe.core.nhim.point_slice`) has a NHIM
point exactly there. For each family under ``orbits``, each energy, each of ``phases`` points
along the orbit and each slice kind, the stage searches the window around the orbit point for
every crossing (:func:`ldpipe.core.nhim.find_every_crossing`, fates on a ``points`` x ``points`` grid)
and records per slice a status:

* ``ok``: a refined crossing within ``tolerance`` of the orbit point;
* ``degenerate:solved_momentum_vanishes``: the solved momentum vanishes (the slice's energy
  boundary, :func:`ldpipe.core.nhim.boundary_distance`) closer to the orbit point than
  ``boundary_cells`` grid cells, as at a turning point of the orbit; not searched;
* ``degenerate:tangent``: the slice's transversality to the NHIM (from the orbit's monodromy
  matrix, :func:`ldpipe.core.nhim.slice_transversality`) is below ``min_transversality``; searched,
  its crossings recorded, not checked;
* ``fail:no_crossing``, ``fail:not_converged``, ``fail:missed``: no candidate in the window; no
  candidate refined; crossings refined but none within the tolerance.

The reference (the orbit point) comes from the periodic-orbit corrector, not from LDs or fates.
:func:`ldpipe.core.nhim.validate_orbit_slice` searches and classifies one slice; this module reads the
orbit files, computes each orbit point's monodromy matrix, passes the slices through the points of one
orbit together (:func:`ldpipe.core.nhim.validate_orbit_slices`, which refines their candidates in
shared engine calls) and writes the study file.
The validation stage (:mod:`ldpipe.stages.nhim_validation`) writes the table and fails the run on
any ``fail:``. Refined crossings are in their own table (dimension ``crossing``); a degenerate or
failed slice has none there.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import xarray as xr

from ..io.atomic import check_writable
from ..io.contracts import EQUILIBRIA, NHIM_ORBITS, UPO
from ..io.datafile import open_stage_file, write_stage_file
from ..core.equilibria.potential import select_saddle
from ..errors import ConfigError
from ..core.maps.grid import resolve_ld_map
from ..logs import get_logger
from ..core.nhim import RefinementSettings, validate_orbit_slices
from ..core.variational import propagate

log = get_logger(__name__)


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


def run_nhim_orbit_validation(
    *, study: str, base_map: dict, orbits: list[str], orbit_files: list[str | Path], equilibria: str | Path,
    energies: dict, phases: int, slices: list[list[str]], half_width: float, points: int,
    boundary_cells: float, min_transversality: float, tolerance: float, refinement: dict,
    output: str | Path, threads: int | None = None,
) -> Path:
    """Search every slice of the study for its NHIM crossings and write the study file.

    ``base_map`` (an LD map's parameters) gives the system, saddle, region and escape radius;
    ``refinement`` the ``nhim.refinement`` section (without ``zoom``); the rest are the study's
    config keys (see the schema).
    """
    check_writable(output)  # before any work: never lose a run to a bad path
    import numba

    if threads:
        numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
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
    for family, path in zip(orbits, orbit_files):
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
    dataset = _dataset(slice_rows, crossing_rows, phase_names)
    parameters = {"study": study, "base_map": base_map["map_name"], "orbits": orbits, "energies": energies,
                  "phases": phases, "slices": slices, "half_width": half_width, "points": points,
                  "boundary_cells": boundary_cells, "min_transversality": min_transversality,
                  "tolerance": tolerance, "refinement": refinement}
    dataset.attrs.update({"study": study, "tolerance": tolerance, "half_width": half_width, "points": points,
                          "boundary_cells": boundary_cells, "min_transversality": min_transversality})
    # Every refinement setting in effect (defaults included), not only those the config gave.
    dataset.attrs.update({f"refinement_{k}": v for k, v in dataclasses.asdict(settings).items()})
    written = write_stage_file(dataset, output, stage=NHIM_ORBITS,
                               title=f"NHIM crossings of slices through periodic orbits, study {study}",
                               parameters=parameters)
    log.info("wrote %s (%d slices, %d crossings)", written, len(slice_rows), len(crossing_rows))
    return written


def _dataset(slice_rows: list[dict], crossing_rows: list[dict], phase: tuple[str, ...]) -> xr.Dataset:
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
