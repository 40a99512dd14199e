"""Transport stage: the flux over a saddle at several energies, three independent ways (2 DoF).

The study is :func:`ldpipe.core.transport.study.transport_dataset`'s (each energy by
:func:`ldpipe.core.transport.transport_at_energy`); this module reads the family and equilibria
files, calls it and writes.
"""

from __future__ import annotations

from pathlib import Path

import xarray as xr

from ..core.transport.study import transport_dataset
from ..io.datafile import write_stage_file
from ..io.atomic import check_writable
from ..logs import get_logger

log = get_logger(__name__)


def run_transport(*, output: str | Path, upo: str | Path | xr.Dataset, equilibria: str | Path | xr.Dataset,
                  threads: int | None = None, **parameters) -> Path:
    """Flux by action, island area and Monte Carlo at each energy of the study; writes ``output``."""
    check_writable(output)  # before any work: never lose a run to a bad path
    path = write_stage_file(transport_dataset(parameters, upo, equilibria, threads=threads), output)
    log.info("wrote %s", path)
    return path
