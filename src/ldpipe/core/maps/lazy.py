"""An LD map as a lazy Dataset over Dask: blocks of start points, each integrated by a task.

A block is a band of rows of the section's first axis (whole rows: a backward field mirrored
by a reversing symmetry flips the second axis) for one start time. Its task is the map's own
band computation (:func:`ldpipe.core.maps.assembly.compute_ld_map` with ``rows``) on numpy
inputs, with the compiled engine loaded in the worker from the disk cache; it returns the
band's variables as numpy arrays. Every trajectory is integrated on its own, so the blocks
joined equal the map computed in one process bit for bit.

What the map's file holds besides its integrated fields is known before any task runs: the
layout (variables, their types and attributes) from an empty band, the ``allowed`` mask from
the section alone, and whether the backward fields are mirrored from the whole grid (as the
one-process map decides it). The Dataset is finished as the one-process map is
(:func:`ldpipe.core.maps.assembly.finish_ld_map`) on zeros, then its data are swapped for the
blocks. The FTLE by differences reads the flow map's neighbours: it is one task per start
time over the gathered flow map (so its bits are those of the one-process map; it holds one
start time's flow map in memory).

Dask is imported when a lazy map is asked for, so ldpipe works without it.
"""

from __future__ import annotations

import importlib
import operator
import time

import numpy as np
import xarray as xr

from ...errors import ConfigError
from ...io.datafile import check_finite
from ...logs import get_logger
from ...systems import on_sphere
from ...systems.velocity_data.memory import datasets_of, register
from ..sections import section_states
from .assembly import backward_mirror, compute_ld_map, finish_ld_map, recorded_parameters, resolve_map
from .grid import add_ftle, directions_setting, map_directions, map_start_times, pilot_integration
from .pilot import PILOT_TRAJECTORIES, pilot_rate
from .symmetry import SETTING_KEY

#: The install that brings what a lazy map needs.
INSTALL = "pip install 'ldpipe[dask]'"
#: The integration time of a block that ``chunks="auto"`` aims at: what a task costs besides its
#: integration (the scheduler's round trip, the results' transfer, the band's set-up: tens of
#: milliseconds, benchmarks/dask_scaling.py measures it) is then a few per cent of it.
AUTO_BLOCK_SECONDS = 2.0
#: ... or more, so that what a block's engine calls cost besides their trajectories (a window of
#: velocity data read) is at most this share of its integration.
AUTO_FIXED_SHARE = 0.05
#: Rows of the section the pilot of ``chunks="auto"`` spreads its start points over.
AUTO_PILOT_ROWS = 16

log = get_logger(__name__)


def require_dask(key: str):
    """dask.array and dask.delayed, imported now; a ConfigError naming ``key``'s ``chunks`` without them."""
    try:
        return importlib.import_module("dask.array"), importlib.import_module("dask").delayed
    except ImportError as error:
        raise ConfigError(f"config key '{key}.chunks': a map in blocks (chunks) needs dask, which is not "
                          f"installed ({error}); {INSTALL}, or leave chunks out") from None


def block_rows(chunks, axes: tuple[str, str], shape: tuple[int, int], key: str) -> int:
    """Rows of the first axis per block from ``chunks``: an int, points per block (at least a
    whole row: rows of ``chunks // columns``, at least 1), or a dict of points per axis (the first
    axis' rows; the second axis whole: its size or -1; ``t0``: 1, a block is one start time)."""
    columns = shape[1]
    if isinstance(chunks, bool) or not isinstance(chunks, (int, np.integer, dict)):
        raise ConfigError(f"config key '{key}.chunks': expected points per block (a positive int), a dict of "
                          f"points per axis {{{axes[0]!r}: rows}}, or 'auto', got {chunks!r}")
    if not isinstance(chunks, dict):
        if chunks < 1:
            raise ConfigError(f"config key '{key}.chunks': expected a positive number of points per block, got {chunks}")
        return max(1, int(chunks) // columns)
    unknown = sorted(set(map(str, chunks)) - {*axes, "t0"})
    if unknown:
        raise ConfigError(f"config key '{key}.chunks': unknown axes {unknown}; the map's axes are {list(axes)} (and t0)")
    for name, size in chunks.items():
        if isinstance(size, bool) or not isinstance(size, (int, np.integer)):
            raise ConfigError(f"config key '{key}.chunks.{name}': expected an int, got {size!r}")
    if chunks.get("t0", 1) != 1:
        raise ConfigError(f"config key '{key}.chunks.t0': a block is one start time; give 1 or leave t0 out")
    if chunks.get(axes[1], -1) not in (-1, columns):
        raise ConfigError(f"config key '{key}.chunks.{axes[1]}': blocks are bands of whole rows; give -1 or "
                          f"{columns} (the axis' points), or leave it out")
    rows = chunks.get(axes[0], -1)
    if rows == -1:
        return shape[0]
    if rows < 1:
        raise ConfigError(f"config key '{key}.chunks.{axes[0]}': expected a positive number of rows per block "
                          f"(or -1: all), got {rows}")
    return int(rows)


def check_client(client, key: str) -> None:
    """A ConfigError naming ``client`` unless it is a running :class:`distributed.Client`."""
    if client is None:
        return
    try:
        distributed = importlib.import_module("distributed")
    except ImportError as error:
        raise ConfigError(f"config key '{key}.client': needs distributed, which is not installed ({error}); "
                          f"{INSTALL}") from None
    if not isinstance(client, distributed.Client):
        raise ConfigError(f"config key '{key}.client': expected a distributed.Client, got {type(client).__name__}")
    if client.status != "running":
        raise ConfigError(f"config key '{key}.client': the client is {client.status}, not running; "
                          "start a new one (distributed.Client(cluster))")


def bands(rows: int, per_block: int) -> list[slice]:
    """The first axis' ``rows`` in bands of ``per_block`` (the last shorter): zarr's chunking too."""
    return [slice(start, min(start + per_block, rows)) for start in range(0, rows, per_block)]


class MapBlocks:
    """What a lazy map is cut into and what is known of it before any block runs."""

    def __init__(self, parameters: dict, equilibria: xr.Dataset | None, *, chunks, threads: int | None = None):
        key = f"ld_maps.{parameters['map_name']}"
        if parameters.get("refine") is not None:
            raise ConfigError(f"config key '{key}.chunks': an adaptive map (refine) is not computed in blocks; "
                              "leave chunks or refine out")
        if parameters.get("tiles", 1) != 1:
            raise ConfigError(f"config key '{key}.chunks': chunks cut the map into blocks instead of tiles; "
                              "leave tiles out")
        self.parameters, self.equilibria, self.threads = parameters, equilibria, threads
        self.starts = map_start_times(parameters)
        first = parameters if self.starts is None else {**parameters, "t0": self.starts[0]}
        system, section, settings, info = resolve_map(first, equilibria)
        self.axes, self.shape = tuple(section.axes), tuple(section.shape)
        self.first_axis = section.axis_values()[0]
        if isinstance(chunks, str) and chunks == "auto":
            if parameters.get("noise") is not None:
                raise ConfigError(f"config key '{key}.chunks': 'auto' sizes blocks by a pilot of the deterministic "
                                  "flow; for a map with noise give points per block (a number)")
            chunks = auto_block_points(first, system, section, settings, info)
        self.bands = bands(self.shape[0], block_rows(chunks, self.axes, self.shape, key))
        self.block_parameters = self._mirror_decided(system, section, info["energy"])
        self.coordinates, self.solved = system.phase_coordinates, section.solve
        self.sphere = on_sphere(parameters["system_spec"])

    def _mirror_decided(self, system, section, energy) -> dict:
        """The parameters each block computes with (and, kept, the whole grid's ``allowed`` mask): the backward
        fields are mirrored in every block where the whole grid is mirrored, and in none otherwise,
        as the one-process map decides (a band can be mirrored where the whole grid is not)."""
        mirror = backward_mirror(self.parameters, system, section)
        allowed, mirrored = [], mirror is not None
        for rows in self.bands:  # band by band, to hold one band's states at a time
            states, band_allowed, _ = section_states(system, section, energy, rows)
            allowed.append(band_allowed)
            if mirrored:
                grid = np.zeros(band_allowed.shape + states.shape[1:])
                grid[band_allowed] = states
                mirrored = mirror.maps_grid(grid, band_allowed)
        self.allowed = np.concatenate(allowed)
        return self.parameters if mirrored or mirror is None else {**self.parameters, SETTING_KEY: False}

    @property
    def first_start(self) -> float | None:
        return None if self.starts is None else self.starts[0]

    def at_start(self, start: float | None) -> dict:
        """The block parameters of one start time (None: the map's only one)."""
        return self.block_parameters if start is None else {**self.block_parameters, "t0": start}

    def template(self) -> xr.Dataset:
        """An empty band (no row) at the first start time: the variables, types and attributes of a band."""
        return compute_ld_map(self.at_start(self.first_start), self.equilibria, rows=slice(0, 0), show_progress=False)


def auto_block_points(parameters: dict, system, section, settings, info: dict) -> int:
    """Start points a block of ``chunks="auto"`` holds: about :data:`AUTO_BLOCK_SECONDS` of
    integration, or more where a call's fixed cost over the whole tau (the data window a block
    reads) would be over :data:`AUTO_FIXED_SHARE` of that; from a pilot of the map's own
    trajectories (at its first start time) spread over :data:`AUTO_PILOT_ROWS` rows. The whole
    map where no point is allowed."""
    rows = np.unique(np.linspace(0, section.shape[0] - 1, AUTO_PILOT_ROWS).round().astype(int))
    states = np.concatenate([section_states(system, section, info["energy"], slice(row, row + 1))[0] for row in rows])
    points = section.shape[0] * section.shape[1]
    if not len(states):
        return points
    sample = states[np.linspace(0, len(states) - 1, min(len(states), PILOT_TRAJECTORIES)).round().astype(int)]
    sample = sample[np.random.default_rng(0).permutation(len(sample))]  # its first eighth spread over the map too
    directions = map_directions(directions_setting(parameters))
    integrate = pilot_integration(system, directions[0][0], settings, info["t0"], parameters.get("ld", True))
    rate = pilot_rate(integrate, sample, settings.tau)
    fixed = rate.call * len(directions)
    if rate.trajectory < AUTO_BLOCK_SECONDS:  # one trajectory over the whole tau: the call's fixed cost there
        start = time.perf_counter()
        integrate(sample[:1], settings.tau)
        fixed = max(fixed, (time.perf_counter() - start - rate.trajectory) * len(directions))
    per_point = rate.trajectory * len(directions)
    seconds = max(AUTO_BLOCK_SECONDS, fixed / AUTO_FIXED_SHARE)
    block = int(min(points, max(1, seconds / per_point)))
    log.info("map %s: chunks='auto' gives blocks of about %d start points (%.3g s of integration a point, "
             "%.3g s a block besides, measured by a pilot)", parameters["map_name"], block, per_point, fixed)
    return block


def compute_block(parameters: dict, equilibria: xr.Dataset | None, rows: slice,
                  threads: int | None, datasets: dict | None = None) -> dict[str, np.ndarray]:
    """The band ``rows`` of a map of one start time (a task): its variables as numpy arrays,
    checked finite as the map's file is (:func:`ldpipe.io.datafile.stage_dataset`).

    ``datasets``: the in-memory velocity data the system reads (:func:`block_datasets`), kept in
    the worker's process; a dask-backed one is read there on the task's own thread (the windows
    the block needs, as numpy: :class:`ldpipe.systems.velocity_data.files.FileSeries`), not as
    tasks sent back to the cluster that runs this one."""
    register(datasets or {})
    dataset = compute_ld_map(parameters, equilibria, rows=rows, threads=threads, show_progress=False)
    check_finite(dataset, f"map {parameters['map_name']}, rows {rows.start}:{rows.stop}")
    return {name: variable.values for name, variable in dataset.data_vars.items()}


def block_datasets(blocks: MapBlocks, delayed):
    """The in-memory velocity data a block's task needs, as one key of the graph (None for a file)."""
    datasets = datasets_of(blocks.parameters["system_spec"])
    return delayed(datasets, traverse=False) if datasets else None


def block_ftle(variables: dict[str, np.ndarray], dims: tuple[str, str], axes: dict[str, np.ndarray],
               coordinates: tuple[str, ...], tau: float, sphere: bool, solved: str | None) -> dict[str, np.ndarray]:
    """The FTLE of one start time's whole flow map (a task): :func:`ldpipe.core.maps.grid.add_ftle`."""
    dataset = xr.Dataset({name: (dims, values) for name, values in variables.items()}, coords=axes)
    add_ftle(dataset, coordinates, tau, sphere, solved)
    return {name: dataset[name].values for name in dataset.data_vars if name not in variables}


def lazy_ld_map(parameters: dict, equilibria: xr.Dataset | None, *, chunks, client=None,
                threads: int | None = None) -> xr.Dataset:
    """The map :func:`ldpipe.core.maps.assembly.ld_map_dataset` computes, as a Dataset of dask arrays
    over blocks of about ``chunks`` start points (:func:`block_rows`), returned before any block is
    integrated: ``.compute()`` gives the one-process map bit for bit, data and attributes.

    ``client``: a running :class:`distributed.Client`; the blocks are sent to it now
    (``client.persist``) and the Dataset returns at once. Without it the Dataset is computed on
    the active Dask scheduler when asked. ``threads``: engine threads of each task (default every
    core of its worker)."""
    key = f"ld_maps.{parameters['map_name']}"
    check_client(client, key)
    _blocks, zeros, lazy = map_layout(parameters, equilibria, chunks=chunks, threads=threads)
    finished = zeros.copy()
    for name, data in lazy.items():
        finished[name] = finished[name].copy(data=data)
    return client.persist(finished) if client is not None else finished


def map_layout(parameters: dict, equilibria: xr.Dataset | None, *, chunks, threads: int | None = None):
    """``(blocks, zeros, lazy)``: the map's :class:`MapBlocks`; its Dataset as the one-process map's
    (coordinates, ``allowed``, attributes), every other variable a dask array of zeros chunked by
    the blocks; and each such variable's dask array over the blocks' tasks. Refuses what cannot
    be cut (ConfigError naming the key) before any block runs."""
    da, delayed = require_dask(f"ld_maps.{parameters['map_name']}")
    blocks = MapBlocks(parameters, equilibria, chunks=chunks, threads=threads)
    # the FTLE's attributes and the finish read zeros (their finiteness): computed here, not on a cluster
    with importlib.import_module("dask").config.set(scheduler="synchronous"):
        skeleton, lazy = _skeleton_and_blocks(blocks, blocks.template(), da, delayed)
        zeros = finish_ld_map(skeleton, recorded_parameters(skeleton[0], parameters))
    return blocks, zeros, lazy


def _skeleton_and_blocks(blocks: MapBlocks, template: xr.Dataset, da, delayed):
    """One Dataset per start time as the one-process map's tiles hold them, of zeros but for
    ``allowed`` (what :func:`finish_ld_map` finishes into the map's attributes without computing
    a block), and each variable's dask array over the blocks."""
    dims = template.allowed.dims
    first = template[dims[0]]
    axis = np.asarray(blocks.first_axis, dtype=first.dtype)
    coords = {dims[0]: (dims[0], axis, first.attrs), dims[1]: template[dims[1]]}
    coords.update({name: template[name] for name in template.coords if name not in coords})  # a noisy map's member
    names = [name for name in template.data_vars if name != "allowed"]
    blocks.block_variables = tuple(names)  # what a block's task gives (the FTLE by differences comes after)
    chunks = (tuple(r.stop - r.start for r in blocks.bands), blocks.shape[1])
    ftle_by_differences = blocks.parameters.get("ftle", False) is True
    skeleton, lazy = [], {name: [] for name in names}
    equilibria = delayed(blocks.equilibria, traverse=False)  # one key in the graph, not a copy per task
    datasets = block_datasets(blocks, delayed)
    for index, start in enumerate(blocks.starts or [None]):
        parameters = delayed(blocks.at_start(start), traverse=False)
        computed = [delayed(compute_block, pure=True)(parameters, equilibria, rows, blocks.threads, datasets)
                    for rows in blocks.bands]
        band = {}
        for name in names:
            band[name] = _variable_of_blocks(da, name, computed, chunks, template[name])
            lazy[name].append(band[name])
        variables = {name: (template[name].dims, da.zeros(band[name].shape, dtype=template[name].dtype,
                                                          chunks=band[name].chunks), template[name].attrs)
                     for name in names}
        variables["allowed"] = (dims, blocks.allowed, template.allowed.attrs)
        dataset = xr.Dataset({name: variables[name] for name in template.data_vars}, coords=coords,
                             attrs=dict(template.attrs))
        if ftle_by_differences:
            _add_lazy_ftle(dataset, band, blocks, chunks, lazy, da, delayed)
        if blocks.starts is not None:  # as a tile of one start time (compute_ld_map)
            dataset = dataset.expand_dims(t0=[start])
            dataset.attrs.pop("t0")
            dataset.attrs.update({"tile": index, "tiles": len(blocks.starts)})
        skeleton.append(dataset)
    stacked = {name: parts[0] if blocks.starts is None else da.stack(parts) for name, parts in lazy.items()}
    return skeleton, stacked


def _variable_of_blocks(da, name: str, computed: list, chunks, template: xr.DataArray):
    """The dask array of variable ``name`` over the block tasks ``computed``: each chunk is one
    item of a block's result, a task of its own (one layer, no chunk copied or re-keyed). A
    dimension before the section's axes (a noisy map's ``member``) is whole in every block."""
    from dask.base import tokenize
    from dask.highlevelgraph import HighLevelGraph

    leading = template.shape[:-2]
    key = f"{name}-{tokenize(name, [block.key for block in computed])}"
    layer = {(key, *(0,) * len(leading), index, 0): (operator.getitem, block.key, name)
             for index, block in enumerate(computed)}
    graph = HighLevelGraph.from_collections(key, layer, dependencies=computed)
    return da.Array(graph, key, chunks=(*((size,) for size in leading), chunks[0], (chunks[1],)),
                    dtype=template.dtype)


def _add_lazy_ftle(dataset: xr.Dataset, band: dict, blocks: MapBlocks, chunks, lazy: dict, da, delayed) -> None:
    """The FTLE variables of one start time: zeros in ``dataset`` with add_ftle's attributes (read
    from a 3 x 3 corner of zeros, which also refuses a grid too small for differences now), and in
    ``lazy`` one task over the gathered flow map."""
    dims = dataset.allowed.dims
    tau = float(dataset.attrs["tau"])
    corner = add_ftle(dataset.isel({dims[0]: slice(0, 3), dims[1]: slice(0, 3)}).compute(), blocks.coordinates, tau,
                      blocks.sphere, blocks.solved)
    inputs = {**band, "allowed": blocks.allowed}
    axes = {dim: dataset[dim].values for dim in dims}
    result = delayed(block_ftle, pure=True)(inputs, dims, axes, blocks.coordinates, tau, blocks.sphere, blocks.solved)
    for name in [name for name in corner.data_vars if name not in dataset.data_vars]:  # those add_ftle adds
        variable = corner[name]
        dataset[name] = (dims, da.zeros(blocks.shape, dtype=variable.dtype, chunks=chunks), variable.attrs)
        whole = da.from_delayed(delayed(operator.getitem)(result, name), blocks.shape, dtype=variable.dtype)
        lazy.setdefault(name, []).append(whole.rechunk(chunks))
