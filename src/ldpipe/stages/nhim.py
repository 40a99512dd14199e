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
tables and fails when a point is too far from its reference. The study is
:func:`ldpipe.core.nhim.study.nhim_study_dataset` (a slice: :func:`ldpipe.core.nhim.study_map_slice`);
this module hands it the maps and orbit files and writes the study file.
"""

from __future__ import annotations

from pathlib import Path

import xarray as xr

from ..core.nhim.study import nhim_study_dataset
from ..io.datafile import write_product


def run_nhim_study(
    *,
    study: str,
    refinement: dict,
    output: str | Path,
    maps: list[str | Path | xr.Dataset] = (),
    derived: list[dict] | None = None,
    equilibria: str | Path | xr.Dataset | None = None,
    references: list[str] = (),
    reference_files: list[str | Path | xr.Dataset] = (),
    threads: int | None = None,
) -> Path:
    """Detect and refine the NHIM point of every slice of a study and write the study file
    (:func:`ldpipe.core.nhim.study.nhim_study_dataset`).

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
    parameters = {"study": study, "refinement": refinement, "references": list(references), "derived": derived}
    return write_product(output, lambda: nhim_study_dataset(parameters, maps, reference_files, equilibria, threads=threads),
                         lambda dataset: f"{dataset.sizes['slice']} slices")
