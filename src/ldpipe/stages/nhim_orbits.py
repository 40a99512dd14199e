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
:func:`ldpipe.core.nhim.validate_orbit_slice` searches and classifies one slice;
:func:`ldpipe.core.nhim.orbit_slices.orbit_validation_dataset` reads the orbit files, computes each
orbit point's monodromy matrix and passes the slices through the points of one orbit together
(:func:`ldpipe.core.nhim.validate_orbit_slices`, which refines their candidates in shared engine
calls); this module hands it the files and writes the study file.
The validation stage (:mod:`ldpipe.stages.nhim_validation`) writes the table and fails the run on
any ``fail:``. Refined crossings are in their own table (dimension ``crossing``); a degenerate or
failed slice has none there.
"""

from __future__ import annotations

from pathlib import Path

import xarray as xr

from ..core.nhim.orbit_slices import orbit_validation_dataset
from ..io.datafile import write_product


def run_nhim_orbit_validation(
    *, study: str, base_map: dict, orbits: list[str], orbit_files: list[str | Path | xr.Dataset],
    equilibria: str | Path | xr.Dataset, energies: dict, phases: int, slices: list[list[str]], half_width: float,
    points: int, boundary_cells: float, min_transversality: float, tolerance: float, refinement: dict,
    output: str | Path, threads: int | None = None,
) -> Path:
    """Search every slice of the study for its NHIM crossings and write the study file
    (:func:`ldpipe.core.nhim.orbit_slices.orbit_validation_dataset`).

    ``base_map`` (an LD map's parameters) gives the system, saddle, region and escape radius;
    ``refinement`` the ``nhim.refinement`` section (without ``zoom``); the rest are the study's
    config keys (see the schema).
    """
    parameters = {"study": study, "base_map": base_map, "orbits": orbits, "energies": energies, "phases": phases,
                  "slices": slices, "half_width": half_width, "points": points, "boundary_cells": boundary_cells,
                  "min_transversality": min_transversality, "tolerance": tolerance, "refinement": refinement}
    return write_product(output, lambda: orbit_validation_dataset(parameters, orbit_files, equilibria, threads=threads),
                         lambda dataset: f"{dataset.sizes['slice']} slices, {dataset.sizes['crossing']} crossings")
