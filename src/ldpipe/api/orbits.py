"""Periodic orbits, their manifolds and Poincaré sections in the Python API."""

from __future__ import annotations

import xarray as xr

from ..core.orbits.family import periodic_orbits_dataset
from ..core.orbits.manifolds import manifolds_dataset
from ..core.orbits.map_manifolds import map_manifolds_dataset
from ..core.orbits.poincare import poincare_dataset
from .systems import equilibria as compute_equilibria, equilibria_input
from .arguments import (
    AnySystem, api_function, arguments_of, calendar_times, energy_shorthand, entry_key, entry_parameters, equilibria_of,
    family_config, system_config, system_entry,
)


@api_function("$defs/orbit_family", taken=("system",))
def periodic_orbits(system: AnySystem, *, name: str = "family", equilibria: xr.Dataset | None = None,
                    **spec) -> xr.Dataset:
    """A Lyapunov family of periodic orbits at target energies (the UPO stage), from a
    ``periodic_orbits:`` entry.

    Parameters
    ----------
    %(system)s
    name : str
        The family's name, recorded in the file (default ``"family"``).
    %(equilibria)s
    **spec
        The entry's keys: ``energies`` (``{"excess": [...]}``, ``{"total": [...]}``, or a list of
        total energies), ``saddle_near``, ``mode``, ``energy_tolerance``, ...

    Returns
    -------
    xarray.Dataset
        The family's file (contract ``upo``): each orbit's period, trajectory, Floquet multipliers ...

    Examples
    --------
    >>> import ldpipe
    >>> b = ldpipe.system(builtin="barbanis_2dof")
    >>> orbits = ldpipe.periodic_orbits(b, name="bottom", energies={"excess": [0.125]})  # doctest: +SKIP
    """
    entry = {"system": system.name, **energy_shorthand(spec)}
    with arguments_of("periodic_orbits", entry_key("periodic_orbits", "periodic_orbits", name)):
        _, parameters = entry_parameters(entry, system_config(system), "periodic_orbits", name, "upo")
        return periodic_orbits_dataset(parameters, equilibria_input(system, equilibria))


@api_function("$defs/manifold_set", taken=("orbits",))
def manifolds(orbits: xr.Dataset, *, name: str = "manifolds", threads: int | None = None, **spec) -> xr.Dataset:
    """The stable and unstable manifolds of one orbit of a family, cut by a section (the
    manifolds stage), from a ``manifolds:`` entry.

    Parameters
    ----------
    orbits : xarray.Dataset
        The family (:func:`periodic_orbits`; the entry's ``orbits`` name replaced by it).
    name : str
        The entry's name (default ``"manifolds"``).
    %(threads)s
    **spec
        The entry's keys: ``energy`` (which orbit: one of the family's target energies), ``section``
        (the surface), ``tau``, ``points``, ``displacement``, ...

    Returns
    -------
    xarray.Dataset
        The manifolds' file (contract ``manifolds``).

    Examples
    --------
    >>> m = ldpipe.manifolds(orbits, energy={"excess": 0.125}, tau=10.0)  # doctest: +SKIP
    """
    family, config = family_config(orbits)
    entry = {"orbits": family, **energy_shorthand(spec)}
    with arguments_of("manifolds", entry_key("manifolds", "manifolds", name)):
        _, parameters = entry_parameters(entry, config, "manifolds", name, "manifolds")
        return manifolds_dataset(parameters, orbits, threads=threads)


@api_function("$defs/map_manifold_set", taken=("system",))
def map_manifolds(system: AnySystem, *, name: str = "manifolds", equilibria: xr.Dataset | None = None,
                  **spec) -> xr.Dataset:
    """The stable and unstable manifolds of a discrete map's saddle fixed points (the manifolds
    stage, for a ``manifolds:`` entry naming a ``system``), grown from fundamental segments.

    Parameters
    ----------
    system : DiscreteMapSystem
        The map, from :func:`ldpipe.system` (two coordinates, with an inverse).
    name : str
        The entry's name (default ``"manifolds"``).
    equilibria : xarray.Dataset, optional
        The map's fixed points (:func:`ldpipe.equilibria`), whose saddles are taken; default
        computed now with the map's ``equilibria`` settings, as the pipeline does. Those of
        another system are refused.
    **spec
        The entry's keys: ``iterations``, ``segment_points``, ``first_distance``,
        ``saddle_near``, ``escape_radius``.

    Returns
    -------
    xarray.Dataset
        The manifolds' file (contract ``map_manifolds``): ``curve`` by fixed point, manifold,
        branch, image and point.

    Examples
    --------
    >>> import ldpipe
    >>> henon = ldpipe.system(map="henon")
    >>> m = ldpipe.map_manifolds(henon, iterations=12)  # doctest: +SKIP
    """
    with arguments_of("map_manifolds", entry_key("map_manifolds", "manifolds", name)):
        _, parameters = entry_parameters({"system": system.name, **spec}, system_config(system), "manifolds", name,
                                         "manifolds")
        fixed = (compute_equilibria(system) if equilibria is None
                 else equilibria_of(equilibria, system.name, system_entry(system), "the map"))
        return map_manifolds_dataset(parameters, fixed)


@api_function("$defs/poincare_section", taken=("system",))
def poincare(system: AnySystem, *, name: str = "section", equilibria: xr.Dataset | None = None,
             threads: int | None = None, **spec) -> xr.Dataset:
    """A Poincaré surface of section from a grid of initial conditions (the Poincaré stage), from
    a ``poincare_sections:`` entry.

    Parameters
    ----------
    %(system)s
    name : str
        The entry's name (default ``"section"``).
    %(equilibria)s
    %(threads)s
    **spec
        The entry's keys: ``initial_conditions`` (see :func:`section`), ``section`` (the surface),
        ``energy`` (or a number for a total energy), ``final_time``, ``saddle_near``, ...

    Returns
    -------
    xarray.Dataset
        The section's file (contract ``poincare``).

    Examples
    --------
    >>> p = ldpipe.poincare(b, initial_conditions=ldpipe.section(x=(4.8, 6.0, 10), px=(-0.6, 0.6, 10),
    ...                     fixed={"y": -7.0}, solve="py"), energy={"excess": 0.125})  # doctest: +SKIP
    """
    key = entry_key("poincare", "poincare_sections", name)
    with arguments_of("poincare", key):
        entry = {"system": system.name, **calendar_times(system, energy_shorthand(spec), key)}
        _, parameters = entry_parameters(entry, system_config(system), "poincare_sections", name, "poincare")
        return poincare_dataset(parameters, equilibria_input(system, equilibria), threads=threads)
