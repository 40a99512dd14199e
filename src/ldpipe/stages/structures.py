"""Structures stage: an LD map's singular curves and FTLE ridges, as a ragged-array file.

The extraction is :func:`ldpipe.core.structures.curves.structures_dataset`'s; this module hands it
the map's file and writes.
"""

from __future__ import annotations

from pathlib import Path

import xarray as xr

from ..io.datafile import write_product


def run_structures(*, output: str | Path, ld_map: str | Path | xr.Dataset, map_name: str, **parameters) -> Path:
    """The structures of the map ``map_name`` (its file ``ld_map``); writes ``output``."""
    from ..core.structures.curves import structures_dataset

    return write_product(output, lambda: structures_dataset(parameters, ld_map),
                         lambda dataset: f"{dataset.sizes['curve']} curves of map {map_name}")
