"""Manifold stage: the stable and unstable manifolds of one periodic orbit, and their section curves.

The manifolds are :func:`ldpipe.core.orbits.manifolds.manifolds_dataset`'s; this module reads the
family's file, calls it and writes.
"""

from __future__ import annotations

from pathlib import Path

import xarray as xr

from ..core.orbits.manifolds import manifolds_dataset
from ..io.datafile import write_product


def run_manifolds(*, output: str | Path, upo: str | Path | xr.Dataset, threads: int | None = None,
                  **parameters) -> Path:
    """Globalize both manifolds of the selected orbit of the UPO file ``upo`` and write ``output``."""
    return write_product(output, lambda: manifolds_dataset(parameters, upo, threads=threads))
