"""The accuracy–cost measurement in the Python API."""

from __future__ import annotations

import copy
from collections.abc import Sequence

import xarray as xr

from ..config import validate_config
from ..config.parameters import parameters_from_config
from ..core.accuracy.measurement import accuracy_cost_dataset
from ..errors import ConfigError
from .arguments import api_function, arguments_of, family_config, recorded_map_entry
from .invariant_sets import refinement_argument


def _map_entry(ld_map: xr.Dataset, argument: str, systems: dict) -> tuple[str, dict]:
    """The ``ld_maps`` entry (name, keys) an LD map was computed from, its system added to ``systems``."""
    if not isinstance(ld_map, xr.Dataset):
        raise ConfigError(f"ldpipe.accuracy_cost: argument '{argument}': expected an LD map (ldpipe.ld_map), "
                          f"got {type(ld_map).__name__}")
    map_name, name, spec, entry = recorded_map_entry(ld_map)
    if systems.setdefault(name, spec) != spec:
        raise ConfigError(f"ldpipe.accuracy_cost: argument '{argument}': system {name!r} {spec}, but another "
                          f"argument's system of that name is {systems[name]}")
    return map_name, {"system": name, **entry}


@api_function()
def accuracy_cost(*, equilibria: xr.Dataset | Sequence[xr.Dataset], ld: dict | None = None, upo: dict | None = None,
                  nhim: dict | None = None, refinement: dict | None = None, threads: int | None = None) -> xr.Dataset:
    """What accuracy costs on this machine: the LD engine's, the periodic-orbit corrector's and the
    NHIM detection's error against wall time over ladders of settings (the accuracy-cost stage),
    from the ``accuracy_cost:`` section.

    The wall times are the measurement: each setting is timed after a warm-up that compiles its
    engine (the pipeline compiles them beforehand in jobs of their own, which changes no number),
    as the smallest of its runs; the machine and its load average before and after are recorded.

    Parameters
    ----------
    equilibria : xarray.Dataset or sequence of them
        The equilibria (:func:`equilibria`) of every system the maps and the family are of;
        required, since a map's or a family's file does not record its system's equilibrium-search
        settings.
    ld : dict, optional
        The ``ld`` block: ``maps`` (LD maps, :func:`ld_map`, whose allowed grid points are sampled;
        the block's map names replaced by them), ``points``, ``seed``, ``ladder``, ``reference``,
        ``reference_check``, ``repeats``, ``repeat_budget``.
    upo : dict, optional
        The ``upo`` block: ``family`` (a family, :func:`periodic_orbits`, whose settings are
        measured), ``energy``, ``tolerance``, ``rtol``, ``reference`` ...
    nhim : dict, optional
        The ``nhim`` block: ``map`` (a variable-time LD map), ``grid_points``, ``refinement_grid``,
        ``tolerance`` ... (its exact point is ``upo``'s family's orbit's crossing).
    refinement : dict, optional
        Keys of the configuration's ``nhim.refinement`` block (``tolerance``, ``rtol``, ...), the
        NHIM refinement ladder's settings besides its tolerances.
    threads : int, optional
        Threads of the engine (default every core; recorded).

    Returns
    -------
    xarray.Dataset
        The measurement's file (contract ``accuracy_cost``): per map, setting and sampled point the
        errors and wall times; the orbit and NHIM ladders.

    Raises
    ------
    ConfigError
        naming the argument, with the message a bad key of the section gets.

    Examples
    --------
    >>> cost = ldpipe.accuracy_cost(equilibria=eq, ld={"maps": [m], "points": 64,
    ...                             "ladder": {"dop853": {"rtol": [1e-6, 1e-8]}}})  # doctest: +SKIP
    """
    ld, upo, nhim = (copy.deepcopy(block or {}) for block in (ld, upo, nhim))
    systems, maps, families = {}, {}, {}
    if "maps" in ld:
        names = []
        for k, ld_map in enumerate(ld["maps"]):
            name, entry = _map_entry(ld_map, f"ld.maps[{k}]", systems)
            maps[name] = entry
            names.append(name)
        ld["maps"] = names
    if nhim.get("map") is not None:
        name, entry = _map_entry(nhim["map"], "nhim.map", systems)
        maps[name] = entry
        nhim["map"] = name
    if upo.get("family") is not None:
        family, part = family_config(upo["family"])
        ((name, spec),) = part["systems"].items()
        if systems.setdefault(name, spec) != spec:
            raise ConfigError(f"ldpipe.accuracy_cost: argument 'upo.family': system {name!r} {spec}, but a map's "
                              f"system of that name is {systems[name]}")
        families.update(part["periodic_orbits"])
        upo["family"] = family
    refinement = refinement_argument("accuracy_cost", refinement, {"systems": systems})
    with arguments_of("accuracy_cost", "accuracy_cost"):
        config = validate_config({"systems": systems, "ld_maps": maps, "periodic_orbits": families,
                                  "nhim": {"refinement": refinement}, "accuracy_cost": {"ld": ld, "upo": upo, "nhim": nhim}})
        return accuracy_cost_dataset(parameters_from_config(config, "accuracy"),
                                     [equilibria] if isinstance(equilibria, xr.Dataset) else list(equilibria),
                                     threads=threads)
