"""Flux and transport over a saddle, and its normal form, in the Python API."""

from __future__ import annotations

import xarray as xr

from ..core.normal_form.study import normal_form_dataset
from ..core.transport.saddle_flux import saddle_flux_dataset
from ..core.transport.study import transport_dataset
from ..errors import ConfigError
from ..io.contracts import SADDLE_FLUX, TRANSPORT, StageFile
from ..io.datafile import open_stage_file, stage_parameters
from .systems import equilibria_input
from .arguments import (
    AnySystem, api_function, arguments_of, energy_shorthand, entry_key, entry_parameters, family_config,
    family_equilibria, system_config,
)


@api_function("$defs/saddle_flux_study", taken=("system",))
def saddle_flux(system: AnySystem, *, name: str = "flux", equilibria: xr.Dataset | None = None,
                threads: int | None = None, **spec) -> xr.Dataset:
    """The reactive flux over an index-1 saddle of a 2 or 3 DoF system (the saddle-flux stage),
    from a ``saddle_flux:`` entry.

    Parameters
    ----------
    %(system)s
    name : str
        The entry's name (default ``"flux"``).
    %(equilibria)s
    %(threads)s
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
    with arguments_of("saddle_flux", entry_key("saddle_flux", "saddle_flux", name)):
        _, parameters = entry_parameters(entry, system_config(system), "saddle_flux", name, "saddle_flux")
        return saddle_flux_dataset(parameters, equilibria_input(system, equilibria), threads=threads)


@api_function("$defs/transport_study", taken=("orbits",))
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
    %(threads)s
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
    with arguments_of("transport", entry_key("transport", "transport", name)):
        _, parameters = entry_parameters(entry, config, "transport", name, "transport")
        return transport_dataset(parameters, orbits, family_equilibria(orbits, equilibria), threads=threads)


@api_function("$defs/normal_form_study", taken=("system", "transport", "saddle_flux"))
def normal_form(system: AnySystem, *, name: str = "normal_form", equilibria: xr.Dataset | None = None,
                transport: xr.Dataset | None = None, saddle_flux: xr.Dataset | None = None,
                **spec) -> xr.Dataset:
    """The normal form of an index-1 saddle of a 2 or 3 DoF system (the normal-form stage): the
    flux over it by energy and order, its truncation error and the NHIM points, from a
    ``normal_form:`` entry.

    Parameters
    ----------
    %(system)s
    name : str
        The entry's name (default ``"normal_form"``).
    %(equilibria)s
    transport : xarray.Dataset, optional
        A transport study of the same system (:func:`transport`; the entry's ``transport`` name
        replaced by it), whose orbits' actions and Monte Carlo fluxes are copied in.
    saddle_flux : xarray.Dataset, optional
        A saddle-flux study of the same system (:func:`saddle_flux`; the entry's ``saddle_flux``
        name replaced by it), whose Monte Carlo fluxes are copied in (in place of the transport
        study's).
    **spec
        The entry's keys: ``energies``, ``saddle_near``, ``order``, ``form``, ``nhim_angles``.

    Returns
    -------
    xarray.Dataset
        The study's file (contract ``normal_form``).

    Raises
    ------
    ConfigError
        naming the argument: a ``transport`` or ``saddle_flux`` study of a system whose spec is
        not ``system``'s.

    Examples
    --------
    >>> f = ldpipe.saddle_flux(b, name="flux", energies={"excess": [0.1]})  # doctest: +SKIP
    >>> nf = ldpipe.normal_form(b, energies={"excess": [0.1]}, order=8, saddle_flux=f)  # doctest: +SKIP
    """
    entry = {"system": system.name, **energy_shorthand(spec)}
    with arguments_of("normal_form", entry_key("normal_form", "normal_form", name)):
        _, parameters = entry_parameters(entry, system_config(system), "normal_form", name, "normal_form")
        # The entry names the compared studies; here they are given, so their names are taken from
        # them (as their files record them) once they are found to be of the same system.
        compared = {section: compared_study(given, section, contract, parameters)
                    for section, given, contract in (("transport", transport, TRANSPORT),
                                                     ("saddle_flux", saddle_flux, SADDLE_FLUX))
                    if given is not None}
        return normal_form_dataset({**parameters, **compared}, equilibria_input(system, equilibria),
                                   transport=transport, saddle_flux=saddle_flux)


def compared_study(given: xr.Dataset, section: str, contract: StageFile, parameters: dict) -> str:
    """The name of a study given for comparison (a ``section`` study), checked to be of the
    normal form's system (its spec as both record it); a ConfigError names the argument."""
    recorded = stage_parameters(open_stage_file(given, stage=contract))
    if recorded["system_spec"] != parameters["system_spec"]:
        raise ConfigError(f"argument '{section}': study {recorded['name']!r} is of system "
                          f"{recorded['system_name']!r} {recorded['system_spec']}, not "
                          f"{parameters['system_name']!r} {parameters['system_spec']}")
    return recorded["name"]
