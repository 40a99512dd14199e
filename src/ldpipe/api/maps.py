"""Lagrangian-descriptor maps in the Python API."""

from __future__ import annotations

import xarray as xr

from ..core.maps.assembly import ld_map_dataset
from ..stages.plan import ld_map_tiles
from .systems import equilibria_input
from .arguments import (AnySystem, arguments_of, energy_shorthand, entry_key, entry_parameters, shared_docs,
                        system_config)


@shared_docs
def ld_map(system: AnySystem, *, name: str = "map", equilibria: xr.Dataset | None = None, progress: bool = False,
           threads: int | None = None, **spec) -> xr.Dataset:
    """A Lagrangian-descriptor map, forward and backward (the LD stage), from an ``ld_maps:`` entry;
    with ``directions="forward"`` (or ``"backward"``) that direction alone, at half the trajectories.

    Parameters
    ----------
    %(system)s
    name : str
        The entry's name, recorded in the file (default ``"map"``).
    %(equilibria)s
    progress : bool
        Show a progress bar.
    %(threads)s
    **spec
        The entry's keys: ``section`` (see :func:`section`), ``energy`` (``{"total": E}``,
        ``{"excess": dE}``, or a number for a total energy), ``tau``, ``p``, ``time``, ``region``,
        ``saddle_near``, ``integrator``, ``tiles``, ``directions`` (``"both"``, the default;
        ``"forward"`` or ``"backward"``: only that direction integrated and in the file), ...

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
    """
    entry = {"system": system.name, **energy_shorthand(spec)}
    with arguments_of("ld_map", entry_key("ld_map", "ld_maps", name)):
        config, parameters = entry_parameters(entry, system_config(system), "ld_maps", name, "ld")
        return ld_map_dataset(parameters, equilibria_input(system, equilibria), tiles=ld_map_tiles(config, name),
                              threads=threads, show_progress=progress)
