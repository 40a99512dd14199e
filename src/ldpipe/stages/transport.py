"""Transport stage: the flux over a saddle at several energies, three independent ways (2 DoF).

The study is :func:`ldpipe.core.transport.study.transport_dataset`'s (each energy by
:func:`ldpipe.core.transport.transport_at_energy`); this module reads the family and equilibria
files, calls it and writes.
"""

from __future__ import annotations

from pathlib import Path

import xarray as xr

from ..core.transport.study import transport_dataset
from ..io.datafile import write_product


def run_transport(*, output: str | Path, upo: str | Path | xr.Dataset, equilibria: str | Path | xr.Dataset,
                  threads: int | None = None, **parameters) -> Path:
    """Flux by action, island area and Monte Carlo at each energy of the study; writes ``output``."""
    return write_product(output, lambda: transport_dataset(parameters, upo, equilibria, threads=threads))
