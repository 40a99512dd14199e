"""Lagrangian-descriptor maps in the Python API."""

from __future__ import annotations

import xarray as xr

from ..core.maps.assembly import ld_map_dataset
from ..core.maps.lazy import lazy_ld_map
from ..core.maps.zarr_stream import stream_ld_map
from ..errors import ConfigError
from ..stages.plan import ld_map_tiles
from .systems import equilibria_input
from .arguments import (AnySystem, api_function, arguments_of, calendar_times, energy_shorthand, entry_key,
                        entry_parameters, system_config)


@api_function("$defs/ld_map", taken=("system",))
def ld_map(system: AnySystem, *, name: str | None = None, equilibria: xr.Dataset | None = None,
           progress: bool | None = None, threads: int | None = None, chunks=None, client=None, store=None,
           **spec) -> xr.Dataset:
    """A Lagrangian-descriptor map, forward and backward (the LD stage), from an ``ld_maps:`` entry;
    with ``directions="forward"`` (or ``"backward"``) that direction alone, at half the trajectories.

    Parameters
    ----------
    %(system)s
    name : str
        The entry's name, recorded in the file (default: the system's name).
    %(equilibria)s
    progress : bool, optional
        Show a progress bar: True always, False never; by default in a notebook (tqdm's notebook
        bar) or a terminal, once the map has run for two seconds, and never when nobody watches.
    %(threads)s
    chunks : int, dict or "auto", optional
        Compute the map on Dask, in blocks of about ``chunks`` start points (whole rows of the first
        axis: ``chunks // columns`` rows, at least one), of ``{first_axis: rows}``, or ``"auto"``:
        blocks of about two seconds of integration each, measured by a pilot of the map's own
        trajectories. The Dataset returned at once holds dask arrays, and ``.compute()`` gives the
        map bit for bit as without ``chunks`` (see the guide's Dask page). Needs
        ``pip install 'ldpipe[dask]'``.
    client : distributed.Client, optional
        With ``chunks``: the running client whose cluster computes the blocks, sent there now
        (``client.persist``); default the active Dask scheduler, when the Dataset is computed.
    store : str or path, optional
        With ``chunks``: a zarr store each block is written to when it finishes; a store this
        map's stream left unfinished is resumed (its finished blocks kept). Returns once the
        map is in, as the store holds it (``xarray.open_zarr``).
    **spec
        The entry's keys: ``section`` (see :func:`section`), ``energy`` (``{"total": E}``,
        ``{"excess": dE}``, or a number for a total energy), ``tau``, ``p``, ``time``, ``region``,
        ``saddle_near``, ``integrator``, ``tiles``, ``directions`` (``"both"``, the default;
        ``"forward"`` or ``"backward"``: only that direction integrated and in the file), ... On
        velocity data whose time axis is a calendar (CF units ``UNIT since DATE``), ``t0`` may be
        a date (``"YYYY-MM-DD"``, ``numpy.datetime64``, ``pandas.Timestamp``; a list or a range of
        them) and ``tau`` a duration (``"5D"``, ``numpy.timedelta64``, ``pandas.Timedelta``): the
        file records the numbers (in the data's time units) and the dates (``t0_date``,
        ``tau_duration``, ISO 8601). Of a discrete map (``ldpipe.system(map=...)``): ``section``,
        ``iterations`` (N: the LD sums over n from -N to N-1; no ``tau``), ``p``,
        ``integrator={"escape_radius": R}`` and ``tiles``.

    Returns
    -------
    xarray.Dataset
        The map's file (contract ``ld_grid``): ``ld_forward``, ``ld_backward``, ``allowed`` ...
        (with one direction, only its variables; the attribute ``directions`` says which);
        with ``ld=False`` (a vector field's fixed-time map with ``ftle=True``) the flow map and
        its FTLE alone (contract ``flow_map``).

    %(raises)s

    Examples
    --------
    >>> import ldpipe
    >>> hh = ldpipe.system(name="henon_heiles", formula="(x**2 + y**2)/2 + x**2*y - y**3/3",
    ...                    coordinates=["x", "y"])
    >>> m = ldpipe.ld_map(hh, section=ldpipe.section(y=(-0.45, 0.8, 41), py=(-0.5, 0.5, 41),
    ...                   fixed={"px": 0.0}, solve="x", root="largest"), energy=0.125, tau=2.0)  # doctest: +SKIP
    >>> m.ldpipe.plot()  # doctest: +SKIP
    >>> henon = ldpipe.system(map="henon")
    >>> d = ldpipe.ld_map(henon, section=ldpipe.section(x=(-1.5, 1.5, 101), y=(-0.5, 0.5, 101)),
    ...                   iterations=10)  # doctest: +SKIP
    """
    name = system.name if name is None else name
    key = entry_key("ld_map", "ld_maps", name)
    with arguments_of("ld_map", key):
        entry = {"system": system.name, **calendar_times(system, energy_shorthand(spec), key)}
        config, parameters = entry_parameters(entry, system_config(system), "ld_maps", name, "ld")
        if chunks is not None and store is not None:
            return stream_ld_map(parameters, equilibria_input(system, equilibria), chunks=chunks, store=store,
                                 client=client, threads=threads)
        if chunks is not None:
            return lazy_ld_map(parameters, equilibria_input(system, equilibria), chunks=chunks, client=client,
                               threads=threads)
        for argument, value in (("client", client), ("store", store)):
            if value is not None:
                raise ConfigError(f"config key 'ld_maps.{name}.{argument}': a map in blocks takes a {argument}; "
                                  "give chunks too")
        return ld_map_dataset(parameters, equilibria_input(system, equilibria), tiles=ld_map_tiles(config, name),
                              threads=threads, show_progress=progress)
