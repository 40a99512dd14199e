"""An LD map streamed to a zarr store block by block, resumed from the blocks already there.

The store is made first, atomically (:func:`ldpipe.io.atomic.atomic_path` on its folder): the
map's coordinates, ``allowed`` mask, attributes and every variable's metadata, its zarr chunks
the blocks (:mod:`ldpipe.core.maps.lazy`). Each block's task then integrates its band, writes
it into its own region of the store (no two blocks share a zarr chunk, so they may write at
once) and, once that is complete, puts a marker for the block in the folder beside the store
(``NAME.zarr.blocks/``, outside it: zarr warns of files it does not know in a store;
:func:`ldpipe.io.atomic.write_text_atomic`). A stream that was
interrupted (the kernel died, a job ended, a task failed) is resumed by the same call: the
blocks with a marker are kept, the others computed again, so a region half written when its
task died is rewritten. A map's FTLE by differences is written after all of one start time's
blocks, from the flow map the store holds, with a marker of its own.

The store is zarr format 2 with consolidated metadata, as published ocean stores are.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import xarray as xr

from ...errors import ConfigError
from ...io.atomic import atomic_path, write_text_atomic
from .lazy import MapBlocks, block_datasets, block_ftle, check_client, compute_block, map_layout

#: The suffix of the folder of block markers beside a store.
MARKERS = ".blocks"
#: zarr's format for the store (2: consolidated metadata without a warning, read by every zarr).
ZARR_FORMAT = 2


def block_name(index: int, rows: slice) -> str:
    """The marker of the block of start time ``index`` and first-axis ``rows``."""
    return f"t{index}_rows{rows.start}-{rows.stop}.done"


def ftle_name(index: int) -> str:
    """The marker of the FTLE of start time ``index``."""
    return f"t{index}_ftle.done"


def markers_folder(store: Path) -> Path:
    """The folder of ``store``'s block markers, beside it."""
    return store.with_name(store.name + MARKERS)


def write_region(store: Path, variables: dict, dims: dict[str, tuple[str, ...]], index: int | None,
                 rows: slice) -> None:
    """``variables`` (arrays over the band ``rows`` of start time ``index``, each on its ``dims``,
    the section's two axes last) into their region of the store."""
    dataset = xr.Dataset({name: (dims[name], values) for name, values in variables.items()})
    region = {dims[next(iter(variables))][-2]: rows}
    if index is not None:
        dataset = dataset.expand_dims("t0")
        region["t0"] = slice(index, index + 1)
    # A region of existing arrays, whole zarr chunks no other block writes; the block's marker is
    # put in place atomically after it, and a block without one is written again on resuming.
    dataset.to_zarr(store, region=region, mode="r+", consolidated=False, zarr_format=ZARR_FORMAT)


def stream_block(parameters: dict, equilibria, rows: slice, threads, datasets, store: Path, index: int | None,
                 dims: dict[str, tuple[str, ...]], marker: Path) -> str:
    """A block's task: its band computed (:func:`ldpipe.core.maps.lazy.compute_block`), its
    variables (``dims``: each one's dimensions) written, marked. A block already marked is not
    computed again: the scheduler runs a finished task again when the worker holding its result
    (the marker's name) is lost, but its band is in the store."""
    if marker.exists():
        return marker.name
    values = compute_block(parameters, equilibria, rows, threads, datasets)
    write_region(store, {name: values[name] for name in dims}, dims, index, rows)
    write_text_atomic(marker, "written\n")
    return marker.name


def stream_ftle(store: Path, index: int | None, dims: tuple[str, str], inputs: tuple[str, ...],
                coordinates: tuple[str, ...], tau: float, sphere: bool, solved: str | None, marker: Path,
                *written: str) -> str:
    """One start time's FTLE by differences (a task after its blocks, ``written``), from the store's
    flow map (its variables ``inputs``)."""
    with xr.open_zarr(store, consolidated=True) as opened:
        start = opened if index is None else opened.isel(t0=index)
        inputs = {name: start[name].values for name in inputs}
        axes = {dim: start[dim].values for dim in dims}
    values = block_ftle(inputs, dims, axes, coordinates, tau, sphere, solved)
    write_region(store, values, dict.fromkeys(values, dims), index, slice(0, len(axes[dims[0]])))
    write_text_atomic(marker, "written\n")
    return marker.name


def _check_resumable(store: Path, zeros: xr.Dataset, blocks: MapBlocks, key: str) -> None:
    """A ConfigError naming ``store`` if the store there is not this map's, or ``chunks`` if it was
    cut otherwise (its zarr chunks are the first run's blocks)."""
    try:
        opened = xr.open_zarr(store, consolidated=True)
    except (OSError, ValueError, KeyError) as error:
        raise ConfigError(f"config key '{key}.store': {store} exists and is not a zarr store of a map ({error}); "
                          "give another path or remove it") from None
    with opened:
        same = (json.loads(opened.attrs.get("parameters", "null")) == json.loads(zeros.attrs["parameters"])
                and dict(opened.sizes) == dict(zeros.sizes) and set(opened.data_vars) == set(zeros.data_vars))
        if not same:
            raise ConfigError(f"config key '{key}.store': {store} holds another map (other parameters or "
                              "variables); give another path, or remove it to start again")
        stored = opened[blocks.block_variables[0]].encoding["chunks"][-2]  # chunked by the blocks
    wanted = blocks.bands[0].stop - blocks.bands[0].start
    if stored != wanted:
        raise ConfigError(f"config key '{key}.chunks': {store} was started with blocks of {stored} rows, "
                          f"these chunks give {wanted}; resume it with chunks={{{blocks.axes[0]!r}: {stored}}}")


def _stored_blocks(store: Path) -> dict | None:
    """``{first axis: rows}``, the blocks a stream in ``store`` was started with; None if it is not
    a map's store (refused by :func:`_check_resumable`, naming it)."""
    try:
        with xr.open_zarr(store, consolidated=True) as opened:
            variable = next(value for name, value in opened.data_vars.items() if name != "allowed")
            return {variable.dims[-2]: int(variable.encoding["chunks"][-2])}
    except (OSError, ValueError, KeyError, StopIteration, IndexError):
        return None


def stream_ld_map(parameters: dict, equilibria: xr.Dataset | None, *, chunks, store: str | os.PathLike,
                  client=None, threads: int | None = None) -> xr.Dataset:
    """The map :func:`ldpipe.core.maps.lazy.lazy_ld_map` computes, each block written to the zarr
    store ``store`` when it finishes, resuming a stream of the same map there (the blocks with a
    marker kept); returns the map as the store holds it (``xarray.open_zarr``) once every block is in.

    ``client``: the running :class:`distributed.Client` whose cluster runs the blocks (they write
    the store themselves, so it must be on a file system every worker sees); default the active
    Dask scheduler."""
    key = f"ld_maps.{parameters['map_name']}"
    check_client(client, key)
    if not isinstance(store, (str, os.PathLike)):
        raise ConfigError(f"config key '{key}.store': expected the path of a zarr store, got {store!r}")
    store = Path(store)
    if isinstance(chunks, str) and chunks == "auto" and store.exists():
        chunks = _stored_blocks(store) or chunks  # resumed as it was cut, not as a new pilot would cut it
    blocks, zeros, _lazy = map_layout(parameters, equilibria, chunks=chunks, threads=threads)
    markers = markers_folder(store)
    if store.exists():
        _check_resumable(store, zeros, blocks, key)
        done = {path.name for path in markers.glob("*.done")}
    else:  # a new stream: markers a removed store left are not its blocks
        done = set()
        for stale in markers.glob("*.done"):
            stale.unlink()
        with atomic_path(store, keep_suffix=True) as temporary:
            zeros.to_zarr(temporary, compute=False, consolidated=True, zarr_format=ZARR_FORMAT)
    from dask import compute, delayed  # imported by map_layout already, or refused there

    dims = tuple(blocks.axes)
    names = blocks.block_variables
    variable_dims = {name: tuple(dim for dim in zeros[name].dims if dim != "t0") for name in names}
    equilibria_key = delayed(blocks.equilibria, traverse=False)
    datasets = block_datasets(blocks, delayed)
    tasks = []
    for index, start in enumerate(blocks.starts or [None]):
        at = None if blocks.starts is None else index
        parameters_key = delayed(blocks.at_start(start), traverse=False)
        written = [delayed(stream_block)(parameters_key, equilibria_key, rows, threads, datasets, store, at,
                                         variable_dims, markers / block_name(index, rows))
                   for rows in blocks.bands if block_name(index, rows) not in done]
        tasks += written
        if blocks.parameters.get("ftle") is True and ftle_name(index) not in done:
            tasks.append(delayed(stream_ftle)(store, at, dims, (*names, "allowed"), blocks.coordinates,
                                              float(zeros.attrs["tau"]), blocks.sphere, blocks.solved,
                                              markers / ftle_name(index), *written))
    if tasks:
        if client is not None:
            client.gather(client.compute(tasks))
        else:
            compute(*tasks)
    return xr.open_zarr(store, consolidated=True)
