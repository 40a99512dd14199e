"""Poincaré section stage: crossings of a surface of section by many trajectories on one energy surface.

The section is :func:`ldpipe.core.orbits.poincare.poincare_dataset`'s; this module reads the
system's equilibria file (none for a vector field), calls it and writes.
"""

from __future__ import annotations

from pathlib import Path

import xarray as xr

from ..core.orbits.poincare import poincare_dataset
from ..io.datafile import write_product


def run_poincare(*, output: str | Path, equilibria: str | Path | xr.Dataset | None, threads: int | None = None,
                 **parameters) -> Path:
    """Integrate the section's initial conditions and write their crossings to ``output``.

    ``equilibria`` None: a vector-field system (no energy; its trajectories start at ``t0``)."""
    return write_product(output, lambda: poincare_dataset(parameters, equilibria, threads=threads))
