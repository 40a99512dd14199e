"""Unstable periodic orbit stage: one Lyapunov family of an index-1 saddle per file.

The family is :func:`ldpipe.core.orbits.family.periodic_orbits_dataset`'s; this module reads the
system's equilibria file, calls it and writes.
"""

from __future__ import annotations

from pathlib import Path

import xarray as xr

from ..core.orbits.family import periodic_orbits_dataset
from ..io.datafile import write_product


def run_upo(*, output: str | Path, equilibria: str | Path | xr.Dataset, **parameters) -> Path:
    """Compute one Lyapunov family from the system's equilibria file and write ``output``."""
    return write_product(output, lambda: periodic_orbits_dataset(parameters, equilibria))
