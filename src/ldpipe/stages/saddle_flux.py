"""Saddle-flux stage: the reactive flux through the dividing surface of a saddle, 2 or 3 DoF.

The study is :func:`ldpipe.core.transport.saddle_flux.saddle_flux_dataset`'s; this module reads
the system's equilibria file, calls it and writes.
"""

from __future__ import annotations

from pathlib import Path

import xarray as xr

from ..core.transport.saddle_flux import saddle_flux_dataset
from ..io.datafile import write_product


def run_saddle_flux(*, output: str | Path, equilibria: str | Path | xr.Dataset, threads: int | None = None,
                    **parameters) -> Path:
    """Monte Carlo reactive flux, one-way flux and harmonic estimate at each energy; writes ``output``."""
    return write_product(output, lambda: saddle_flux_dataset(parameters, equilibria, threads=threads))
