"""LD map stage: a map's file, whole or tile by tile, from the map's parameters and the system's
equilibria file; the map itself is :mod:`ldpipe.core.maps.assembly`'s."""

from __future__ import annotations

from pathlib import Path

import xarray as xr

from ..core.maps.assembly import gather_ld_map, ld_map_dataset, ld_map_tile, map_contract, map_title, \
    recorded_parameters
from ..io.contracts import EQUILIBRIA, LD_TILE
from ..io.datafile import open_stage_file, stage_dataset, stage_parameters, write_product


def open_equilibria(equilibria: str | Path | xr.Dataset | None) -> xr.Dataset | None:
    """The equilibria a map reads (None for a vector field, which has no energy)."""
    return open_stage_file(equilibria, stage=EQUILIBRIA) if equilibria is not None else None


def allowed_points(dataset: xr.Dataset) -> str:
    return f"{int(dataset.allowed.sum())} allowed points"


def write_ld_map(dataset: xr.Dataset, parameters: dict, output: str | Path, *, tile_file: bool) -> Path:
    """Write a band :func:`ldpipe.core.maps.assembly.compute_ld_map` computed: a whole map, or
    (``tile_file``) one tile of it for :func:`run_ld_gather`."""
    tile, tiles = int(dataset.attrs["tile"]), int(dataset.attrs["tiles"])
    recorded = {**recorded_parameters(dataset, parameters), "tile": tile, "tiles": tiles}
    title = map_title(parameters, tile, tiles) if tile_file else map_title(parameters)
    return write_product(output, lambda: stage_dataset(dataset, stage=map_contract(parameters, tile_file=tile_file),
                                                       title=title, parameters=recorded), allowed_points)


def run_ld_tile(*, output: str | Path, equilibria: str | Path | xr.Dataset | None, tile: int = 0, tiles: int = 1,
                threads: int | None = None, show_progress: bool = True, **parameters) -> Path:
    """Compute one tile of an LD map and write it as a tile file."""
    return write_product(output, lambda: ld_map_tile(parameters, open_equilibria(equilibria), tile=tile, tiles=tiles,
                                                     threads=threads, show_progress=show_progress), allowed_points)


def run_ld_map(*, output: str | Path, equilibria: str | Path | xr.Dataset | None, tiles: int = 1,
               threads: int | None = None, show_progress: bool = True, **parameters) -> Path:
    """Compute a whole map as the workflow does, in one process, and write its file: the
    workflow's file, bit for bit (:func:`ldpipe.core.maps.assembly.ld_map_dataset`)."""
    return write_product(output, lambda: ld_map_dataset(parameters, open_equilibria(equilibria), tiles=tiles,
                                                        threads=threads, show_progress=show_progress), allowed_points)


def run_ld_gather(*, tiles: list[str | Path], output: str | Path) -> Path:
    """Join the tile files of one map into the map's file."""

    def gathered() -> xr.Dataset:
        datasets = [open_stage_file(path, stage=LD_TILE.stage) for path in tiles]
        datasets = [open_stage_file(d, stage=map_contract(stage_parameters(d), tile_file=True)) for d in datasets]
        try:
            return gather_ld_map(datasets, names=[str(path) for path in tiles])
        except ValueError as error:
            raise ValueError(f"{output}: {error}") from None

    return write_product(output, gathered, allowed_points)
