"""Flux and transport over a saddle in the Python API."""

from __future__ import annotations

import xarray as xr

from ..core.transport.saddle_flux import saddle_flux_dataset
from ..core.transport.study import transport_dataset
from .systems import equilibria_input
from .arguments import AnySystem, arguments_of, energy_shorthand, entry_parameters, family_config, \
    family_equilibria, system_config

def saddle_flux(system: AnySystem, *, name: str = "flux", equilibria: xr.Dataset | None = None,
                threads: int | None = None, **spec) -> xr.Dataset:
    """The reactive flux over an index-1 saddle of a 2 or 3 DoF system (the saddle-flux stage),
    from a ``saddle_flux:`` entry.

    Parameters
    ----------
    system : System
        The system.
    name : str
        The entry's name (default ``"flux"``).
    equilibria : xarray.Dataset, optional
        The system's equilibria (default computed now).
    threads : int, optional
        Threads (default every core).
    **spec
        The entry's keys: ``energies``, ``saddle_near``, ``monte_carlo``, ...

    Returns
    -------
    xarray.Dataset
        The study's file (contract ``saddle_flux``).

    Examples
    --------
    >>> f = ldpipe.saddle_flux(b, energies={"excess": [0.1]})  # doctest: +SKIP
    """
    entry = {"system": system.name, **energy_shorthand(spec)}
    with arguments_of("saddle_flux", f"saddle_flux.{name}"):
        _, parameters = entry_parameters(entry, system_config(system), "saddle_flux", name, "saddle_flux")
        return saddle_flux_dataset(parameters, equilibria_input(system, equilibria), threads=threads)


def transport(orbits: xr.Dataset, *, name: str = "transport", equilibria: xr.Dataset | None = None,
              threads: int | None = None, **spec) -> xr.Dataset:
    """Transport over the saddle of a 2 DoF family (the transport stage): the flux by the orbit's
    action, by the reactive islands' area and by Monte Carlo, from a ``transport:`` entry.

    Parameters
    ----------
    orbits : xarray.Dataset
        The Lyapunov family (:func:`periodic_orbits`; the entry's ``orbits`` name replaced by it).
    name : str
        The entry's name (default ``"transport"``).
    equilibria : xarray.Dataset
        Required: the equilibria of the family's system (:func:`equilibria`), as the pipeline's
        equilibria stage finds them with the system's ``equilibria`` settings. The study reads the
        well, the saddle's centre frequencies and every other saddle from them, and a family's file
        does not record those settings, so they cannot be found again from ``orbits`` alone.
    threads : int, optional
        Threads (default every core).
    **spec
        The entry's keys: ``energies`` (some of the family's target energies), ``island``,
        ``monte_carlo``, ``survival``, ``gap_times``.

    Returns
    -------
    xarray.Dataset
        The study's file (contract ``transport``).

    Raises
    ------
    ConfigError
        naming the argument: ``equilibria`` missing, or of a system whose spec is not the family's.

    Examples
    --------
    >>> eq = ldpipe.equilibria(b)  # doctest: +SKIP
    >>> orbits = ldpipe.periodic_orbits(b, name="bottom", equilibria=eq, energies={"excess": [0.125]})  # doctest: +SKIP
    >>> t = ldpipe.transport(orbits, equilibria=eq, energies={"excess": [0.125]})  # doctest: +SKIP
    """
    family, config = family_config(orbits)
    entry = {"orbits": family, **energy_shorthand(spec)}
    with arguments_of("transport", f"transport.{name}"):
        _, parameters = entry_parameters(entry, config, "transport", name, "transport")
        return transport_dataset(parameters, orbits, family_equilibria(orbits, equilibria), threads=threads)
