"""Manifold stage: the stable and unstable manifolds of one periodic orbit, and their section
curves; or, for an entry naming a discrete map, those of the map's saddle fixed points.

The manifolds are :func:`ldpipe.core.orbits.manifolds.manifolds_dataset`'s (an orbit's) and
:func:`ldpipe.core.orbits.map_manifolds.map_manifolds_dataset`'s (a map's); this module reads
the family's or the map's equilibria file, calls one and writes.
"""

from __future__ import annotations

from pathlib import Path

import xarray as xr

from ..core.orbits.manifolds import manifolds_dataset
from ..core.orbits.map_manifolds import map_manifolds_dataset
from ..io.datafile import write_product


def run_manifolds(*, output: str | Path, upo: str | Path | xr.Dataset, threads: int | None = None,
                  **parameters) -> Path:
    """Globalize both manifolds of the selected orbit of the UPO file ``upo`` and write ``output``."""
    return write_product(output, lambda: manifolds_dataset(parameters, upo, threads=threads))


def run_map_manifolds(*, output: str | Path, equilibria: str | Path | xr.Dataset, **parameters) -> Path:
    """Grow both manifolds of the map's saddle fixed points in its ``equilibria`` file and write ``output``."""
    return write_product(output, lambda: map_manifolds_dataset(parameters, equilibria))
