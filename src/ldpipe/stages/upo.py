"""Unstable periodic orbit stage: one Lyapunov family of an index-1 saddle per file.

The family is :func:`ldpipe.core.orbits.family.periodic_orbits_dataset`'s; this module reads the
system's equilibria file, calls it and writes.
"""

from __future__ import annotations

from pathlib import Path

import xarray as xr

from ..core.orbits.family import periodic_orbits_dataset
from ..io.atomic import check_writable
from ..io.datafile import write_stage_file
from ..logs import get_logger

log = get_logger(__name__)


def run_upo(*, output: str | Path, equilibria: str | Path | xr.Dataset, **parameters) -> Path:
    """Compute one Lyapunov family from the system's equilibria file and write ``output``."""
    check_writable(output)  # before any work: never lose a run to a bad path
    path = write_stage_file(periodic_orbits_dataset(parameters, equilibria), output)
    log.info("wrote %s", path)
    return path
