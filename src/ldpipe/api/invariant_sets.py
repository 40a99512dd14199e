"""NHIM studies in the Python API: points of LD maps, slices through periodic-orbit points, the
NHIM sampled over a family of slices."""

from __future__ import annotations

import copy
from collections.abc import Sequence

import xarray as xr

from ..config import validate_config
from ..config.parameters import parameters_from_config
from ..core.nhim.orbit_slices import orbit_validation_dataset
from ..core.nhim.sampling import nhim_sampling_dataset
from ..core.nhim.study import nhim_study_dataset
from ..errors import ConfigError
from ..io.contracts import LD_GRID, UPO
from ..io.datafile import open_stage_file, stage_parameters
from .arguments import (
    AnySystem, api_function, arguments_of, energy_shorthand, family_config, family_equilibria,
    recorded_map_entry, system_config,
)
from .systems import equilibria_input


@api_function("$defs/nhim/properties/refinement")
def nhim(maps: Sequence[xr.Dataset], *, study: str = "study", references: Sequence[xr.Dataset] = (),
         threads: int | None = None, **refinement) -> xr.Dataset:
    """NHIM points of variable-time LD maps, detected and refined (the NHIM study stage).

    Parameters
    ----------
    maps : sequence of xarray.Dataset
        Variable-time LD maps (:func:`ld_map`), one slice each.
    study : str
        The study's name, recorded in the file (default ``"study"``).
    references : sequence of xarray.Dataset
        Periodic-orbit families (:func:`periodic_orbits`), each with an orbit at every map's energy:
        every point is compared with its crossing of the map's section.
    %(threads)s
    **refinement
        Keys of the configuration's ``nhim.refinement`` block: ``tolerance``, ``rtol``, ``atol``,
        ``max_time``, ``zoom``, ...

    Returns
    -------
    xarray.Dataset
        The study's file (contract ``nhim``). It records the maps by their titles where the
        pipeline records their paths.

    Examples
    --------
    >>> points = ldpipe.nhim([m], references=[orbits], tolerance=1e-8)  # doctest: +SKIP
    """
    if not maps:
        raise ConfigError("ldpipe.nhim: argument 'maps': give at least one LD map")
    recorded = stage_parameters(open_stage_file(maps[0], stage=LD_GRID, only=True))
    with arguments_of("nhim", "nhim.refinement"):
        # the refinement block is validated in a configuration holding the maps' system
        config = validate_config({"systems": {recorded["system_name"]: copy.deepcopy(recorded["system_spec"])},
                                  "nhim": {"refinement": dict(refinement)}})
        families = [stage_parameters(open_stage_file(orbits, stage=UPO))["family"] for orbits in references]
        # the parameters config.parameters gives a study of these maps and families
        parameters = {"study": study, "refinement": config["nhim"]["refinement"], "references": families}
        return nhim_study_dataset(parameters, list(maps), list(references), threads=threads)


#: The name of a base map given by its keys (not an LD map), in the configuration built for it and in the file.
BASE_MAP = "base_map"


def _base_map_entry(function: str, base_map: xr.Dataset | dict, config: dict, system_name: str) -> tuple[str, dict]:
    """The ``ld_maps`` entry (name, keys) a study's ``base_map`` argument stands for, validated
    beside ``config`` (the configuration holding the study's system ``system_name``): an LD map
    (:func:`ld_map`), its entry as the file records it, under its name; or the keys of an entry
    (a map never computed), under the name :data:`BASE_MAP`."""
    if isinstance(base_map, xr.Dataset):
        name, map_system, map_spec, entry = recorded_map_entry(base_map)
        spec = config["systems"][system_name]
        if map_spec != {k: v for k, v in spec.items() if k != "equilibria"}:
            raise ConfigError(f"ldpipe.{function}: argument 'base_map': a map of system {map_system!r} "
                              f"{map_spec}, but the study is of {system_name!r} {spec}")
    elif isinstance(base_map, dict):
        name, entry = BASE_MAP, energy_shorthand(base_map)
    else:
        raise ConfigError(f"ldpipe.{function}: argument 'base_map': expected an LD map (ldpipe.ld_map) or the keys of "
                          f"an ld_maps entry, got {type(base_map).__name__}")
    entry = {"system": system_name, **copy.deepcopy(entry)}
    with arguments_of(function, "ld_maps"):  # a bad key of the map names the argument 'base_map.KEY'
        validate_config({**config, "ld_maps": {name: entry}})
    return name, entry


def refinement_argument(function: str, refinement: dict | None, config: dict) -> dict:
    """The ``nhim.refinement`` block, validated (a bad key names the argument 'refinement.KEY')."""
    refinement = copy.deepcopy(refinement or {})
    with arguments_of(function, "nhim"):
        validate_config({**config, "nhim": {"refinement": refinement}})
    return refinement


@api_function("$defs/nhim_orbit_validation", taken=("orbits", "base_map"))
def orbit_validation(orbits: xr.Dataset | Sequence[xr.Dataset], *, study: str = "study",
                     base_map: xr.Dataset | dict, equilibria: xr.Dataset | None = None, refinement: dict | None = None,
                     threads: int | None = None, **spec) -> xr.Dataset:
    """Every NHIM crossing of slices through points of periodic orbits, refined, each slice with
    its status (the NHIM orbit validation stage), from an ``nhim.orbit_validation:`` entry.

    A periodic orbit lies on the NHIM: a slice fixing every coordinate but two axes and a solved
    momentum at an orbit point's values has a NHIM point exactly there. A slice is ``ok`` (a
    refined crossing within ``tolerance`` of it), ``degenerate:...`` (recorded, not checked) or
    ``fail:...``.

    Parameters
    ----------
    orbits : xarray.Dataset or sequence of them
        Periodic-orbit families of one system (:func:`periodic_orbits`; the entry's ``orbits``
        names replaced by them), each with an orbit at every energy of ``energies``.
    study : str
        The study's name, recorded in the file (default ``"study"``).
    base_map : xarray.Dataset or dict
        The variable-time map whose saddle, saddle region, integrator and escape radius the slices
        use (the entry's ``base_map`` name replaced): an LD map (:func:`ld_map`), or the keys of an
        ``ld_maps`` entry of the families' system (``section``, ``energy``, ``time``, ``region``,
        ``saddle_near`` ...: the map is never computed), recorded as the map ``base_map``.
    equilibria : xarray.Dataset
        The equilibria of the families' system (:func:`equilibria`), where the saddle is read;
        required, since a family's file does not record the system's equilibrium-search settings.
    refinement : dict, optional
        Keys of the configuration's ``nhim.refinement`` block (``tolerance``, ``rtol``, ...).
    %(threads)s
    **spec
        The entry's keys: ``energies`` (``{"excess": [...]}``, ``{"total": [...]}``, or a list of
        total energies), ``phases``, ``slices``, ``half_width``, ``points``, ``boundary_cells``,
        ``min_transversality``, ``tolerance``.

    Returns
    -------
    xarray.Dataset
        The study's file (contract ``nhim_orbits``): per slice its ``status``, ``reason``,
        ``distance`` ...; the refined crossings along ``crossing``.

    %(raises)s

    Examples
    --------
    >>> v = ldpipe.orbit_validation(orbits, base_map=m, equilibria=eq, energies={"excess": [0.125]},
    ...                             slices=[["x", "px"], ["y", "py"]])  # doctest: +SKIP
    >>> v.status.values  # doctest: +SKIP
    """
    families = [orbits] if isinstance(orbits, xr.Dataset) else list(orbits)
    if not families:
        raise ConfigError("ldpipe.orbit_validation: argument 'orbits': give at least one periodic-orbit family")
    config = {"systems": {}, "periodic_orbits": {}}
    for family in families:
        _, family_part = family_config(family)
        if config["systems"] and config["systems"] != family_part["systems"]:
            raise ConfigError(f"ldpipe.orbit_validation: argument 'orbits': families of systems {config['systems']} "
                              f"and {family_part['systems']}; one system per study")
        config["systems"] = family_part["systems"]
        config["periodic_orbits"].update(family_part["periodic_orbits"])
    (system_name,) = config["systems"]
    with arguments_of("orbit_validation", f"nhim.orbit_validation.{study}"):
        equilibria = family_equilibria(families[0], equilibria)
    refinement = refinement_argument("orbit_validation", refinement, config)
    map_name, map_entry = _base_map_entry("orbit_validation", base_map, config, system_name)
    entry = {"base_map": map_name, "orbits": list(config["periodic_orbits"]), **energy_shorthand(spec)}
    with arguments_of("orbit_validation", f"nhim.orbit_validation.{study}"):
        config = validate_config({**config, "ld_maps": {map_name: map_entry},
                                  "nhim": {"refinement": refinement, "orbit_validation": {study: entry}}})
        return orbit_validation_dataset(parameters_from_config(config, "nhim_orbits", study), families, equilibria,
                                        threads=threads)


@api_function("$defs/nhim_sampling_study", taken=("base_map",))
def nhim_sampling(system: AnySystem, *, study: str = "study", base_map: xr.Dataset | dict,
                  equilibria: xr.Dataset | None = None, refinement: dict | None = None, threads: int | None = None,
                  **spec) -> xr.Dataset:
    """Points of the NHIM over a family of slices, found by continuation from slice to slice and
    refined (the NHIM sampling stage), from an ``nhim_sampling:`` entry.

    Parameters
    ----------
    %(system)s
    study : str
        The study's name, recorded in the file (default ``"study"``).
    base_map : xarray.Dataset or dict
        The variable-time map whose section (axes, solved momentum), energy, saddle region, tau, p
        and integrator every slice keeps (the entry's ``base_map`` name replaced): an LD map
        (:func:`ld_map`), or the keys of an ``ld_maps`` entry (the map is never computed),
        recorded as the map ``base_map``.
    equilibria : xarray.Dataset, optional
        The system's equilibria (:func:`equilibria`), where the saddle is read; default computed
        now with the system's ``equilibria`` settings, as the pipeline does.
    refinement : dict, optional
        Keys of the configuration's ``nhim.refinement`` block (``tolerance``, ``rtol``, ...).
    %(threads)s
    **spec
        The entry's keys: ``fixed`` (for every fixed coordinate of the base map's section,
        ``{"range": [low, high], "points": n}``), ``signs``, ``window``, ``seed_points``,
        ``min_angle``, ``min_momentum``, ``batch``.

    Returns
    -------
    xarray.Dataset
        The study's file (contract ``nhim_sampling``): every slice with its ``status`` (and the
        ``reason`` of a degenerate one), every point as a phase-space ``state``.

    %(raises)s

    Examples
    --------
    >>> bc = ldpipe.system(builtin="barbanis_contopoulos_3dof")
    >>> points = ldpipe.nhim_sampling(bc, base_map=fig5_map, fixed={"y": {"range": [5.0, 5.6], "points": 5},
    ...                               "z": {"range": [2.65, 2.65], "points": 1},
    ...                               "py": {"range": [0.0, 0.0], "points": 1}})  # doctest: +SKIP
    """
    config = system_config(system)
    refinement = refinement_argument("nhim_sampling", refinement, config)
    map_name, map_entry = _base_map_entry("nhim_sampling", base_map, config, system.name)
    entry = {"base_map": map_name, **copy.deepcopy(spec)}
    with arguments_of("nhim_sampling", f"nhim_sampling.{study}"):
        config = validate_config({**config, "ld_maps": {map_name: map_entry}, "nhim": {"refinement": refinement},
                                  "nhim_sampling": {study: entry}})
        return nhim_sampling_dataset(parameters_from_config(config, "nhim_sampling", study),
                                     equilibria_input(system, equilibria), threads=threads)
