"""NHIM sampling stage: points of the NHIM over a family of slices, by continuation.

A study is declared under ``nhim_sampling`` in the configuration (see the schema): a variable-time
LD map whose section, energy, saddle region, tau and integrator every slice keeps (``base_map``;
the map itself is not computed), a grid of the section's fixed values (``fixed``: a range and a
number of points per fixed coordinate), the signs of the solved momentum, and how each slice's
point is looked for (``window``, ``seed_points``, ``min_angle``, ``min_momentum``); the refinement
is ``nhim.refinement``'s. :func:`ldpipe.core.nhim.sampling.sample_family` does the science,
:func:`ldpipe.core.nhim.sampling.nhim_sampling_dataset` makes the study's file of it; this module
writes it: every slice with its status (and the reason for a degenerate one), and every
point (non-degenerate slices only) as a full phase-space state with its uncertainty, energy
residual, residence times and detection evidence.
"""

from __future__ import annotations

from pathlib import Path

import xarray as xr

from ..core.nhim.sampling import nhim_sampling_dataset
from ..io.datafile import write_product


def run_nhim_sampling(
    *,
    study: str,
    base_map: dict,
    fixed: dict,
    signs: list[int],
    sampling: dict,
    refinement: dict,
    equilibria: str | Path | xr.Dataset,
    output: str | Path,
    threads: int | None = None,
) -> Path:
    """Sample the NHIM over a study's slice family and write the study file
    (:func:`ldpipe.core.nhim.sampling.nhim_sampling_dataset`).

    Parameters
    ----------
    base_map : dict
        The base map's parameters (``parameters_from_config(config, "ld", name)``).
    fixed : dict
        ``{coordinate: {range: [low, high], points: n}}`` for every fixed coordinate of the base section.
    signs : list of {+1, -1}
        Signs of the solved momentum.
    sampling, refinement : dict
        :class:`ldpipe.core.nhim.sampling.SamplingSettings` and :class:`ldpipe.core.nhim.RefinementSettings` keywords.
    equilibria : path
        The system's equilibria file (the saddle the base map's ``saddle_near`` selects).
    """
    parameters = {"study": study, "base_map": base_map, "fixed": fixed, "signs": signs, "sampling": sampling,
                  "refinement": refinement}
    return write_product(output, lambda: nhim_sampling_dataset(parameters, equilibria, threads=threads))
