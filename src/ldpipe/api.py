"""ldpipe in a notebook: one function per stage, whose keyword arguments are the configuration's keys.

A ``config.yaml`` entry and a call say the same thing::

    ld_maps:
      hh:
        system: henon_heiles
        section: {axes: [...], fixed: {px: 0.0}, solve: x, root: largest}
        energy: {total: 0.125}
        tau: 2.0

    hh = ldpipe.system(name="henon_heiles", formula="(x**2 + y**2)/2 + x**2*y - y**3/3", coordinates=["x", "y"])
    m = ldpipe.ld_map(hh, name="hh", section=ldpipe.section(...), energy=0.125, tau=2.0)

Where an entry names another entry (a map's ``system``, a manifold set's ``orbits``) the call
takes that object or Dataset instead. Each call builds the configuration the entry would sit in,
validates it with the configuration's own schema and rules (so a bad argument gets the message a
bad key gets, naming the argument), and runs the stage's own function (:mod:`ldpipe.stages`, as
Snakemake and the command line do) into a scratch folder; the Dataset returned is the stage file it
wrote, read back: equal, data and attributes, to the file the pipeline writes for the same entry
(but for ``history``, which says when and how a file was written).
"""

from __future__ import annotations

import contextlib
import copy
import dataclasses
import re
import tempfile
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path

import xarray as xr

from .config import validate_config
from .errors import ConfigError
from .io.contracts import (
    EQUILIBRIA,
    FLOW_EQUILIBRIA,
    LD_GRID,
    MANIFOLDS,
    NHIM,
    POINCARE,
    SADDLE_FLUX,
    TRANSPORT,
    UPO,
)
from .io.datafile import STAGE_ATTRIBUTE, open_stage_file, stage_parameters
from .stages.equilibria import run_equilibria
from .stages.ld import map_contract, run_ld_map
from .stages.plan import ld_map_tiles
from .stages.manifolds import run_manifolds
from .stages.nhim import run_nhim_study
from .stages.parameters import parameters_from_config
from .stages.poincare import run_poincare
from .stages.saddle_flux import run_saddle_flux
from .stages.transport import run_transport
from .stages.upo import run_upo
from .systems import SYSTEM_CLASSES, System, VectorFieldSystem, VelocityDataSystem, make_system, system_spec

__all__ = [
    "equilibria", "ld_map", "manifolds", "nhim", "open_dataset", "periodic_orbits", "plot", "poincare",
    "saddle_flux", "section", "system", "transport",
]

#: The keys of a section block besides its axes (:func:`section`).
SECTION_KEYS = ("fixed", "solve", "sign", "root", "search")

AnySystem = System | VectorFieldSystem | VelocityDataSystem

#: Each stage's function (the one Snakemake's script and the command line call) and its file's contract.
RUNS = {
    "ld": (run_ld_map, LD_GRID),
    "upo": (run_upo, UPO),
    "manifolds": (run_manifolds, MANIFOLDS),
    "poincare": (run_poincare, POINCARE),
    "saddle_flux": (run_saddle_flux, SADDLE_FLUX),
    "transport": (run_transport, TRANSPORT),
}


@contextlib.contextmanager
def _arguments_of(function: str, key: str) -> Iterator[None]:
    """Turn a ConfigError about the entry at config key ``key`` into one about the arguments of
    ``ldpipe.<function>``: the same message, naming the argument where it named the key."""
    try:
        yield
    except ConfigError as error:
        text = str(error).replace("invalid configuration:", "invalid arguments:")
        text = re.sub(rf"config key '{re.escape(key)}\.([^']*)'", r"argument '\1'", text)
        text = re.sub(rf"config key '{re.escape(key)}': unknown keys (\[[^]]*\]); allowed keys are",
                      r"unknown arguments \1; allowed are", text)
        text = re.sub(rf"config key '{re.escape(key)}'", "the arguments", text)
        raise ConfigError(f"ldpipe.{function}: {text}") from None


def _energy_shorthand(spec: dict) -> dict:
    """``energy=0.2`` for ``energy={"total": 0.2}``, ``energies=[...]`` for ``{"total": [...]}``:
    a bare number is a total energy (an excess one is always written ``{"excess": ...}``)."""
    spec = dict(spec)
    if isinstance(spec.get("energy"), (int, float)) and not isinstance(spec["energy"], bool):
        spec["energy"] = {"total": spec["energy"]}
    if isinstance(spec.get("energies"), (list, tuple)):
        spec["energies"] = {"total": list(spec["energies"])}
    return spec


def _system_entry(system: AnySystem) -> dict:
    if not isinstance(system, SYSTEM_CLASSES):
        raise ConfigError(f"expected a system (from ldpipe.system), got {type(system).__name__}")
    return copy.deepcopy(system.spec)


def _system_config(system: AnySystem) -> dict:
    """The configuration holding ``system`` alone, as its entry."""
    return {"systems": {system.name: _system_entry(system)}}


def _run_stage(function: str, stage: str, section: str, name: str, entry: dict, config: dict,
               inputs: Callable[[dict], dict]) -> xr.Dataset:
    """Run ``stage`` on ``entry``, put under ``section`` of ``config`` as the entry ``name``: the
    configuration validated (defaults filled), the stage's parameters taken from it, and its
    ``run_*`` function (:data:`RUNS`) given them and ``inputs(config)`` (the files it reads, threads
    ...), writing into a scratch folder; returns the file it wrote, read back. A ConfigError names
    the arguments of ``ldpipe.<function>``."""
    run, contract = RUNS[stage]
    with _arguments_of(function, f"{section}.{name}"):
        config = validate_config(copy.deepcopy({**config, section: {name: entry}}))
        parameters = parameters_from_config(config, stage, name)
        if stage == "ld":  # an LD map's file, or a vector field's flow map without its LD (ld: false)
            contract = map_contract(parameters, tile_file=False)
        with tempfile.TemporaryDirectory() as scratch:
            path = run(**parameters, **inputs(config), output=Path(scratch) / f"{stage}.nc")
            return open_stage_file(path, stage=contract)


def _equilibria_input(system: AnySystem, given: xr.Dataset | None) -> xr.Dataset | None:
    """The equilibria a stage reads: those given, none for a vector field, else computed now."""
    if given is not None:
        return given
    if not system.hamiltonian:
        return None
    return equilibria(system)


def system(*, name: str | None = None, **spec) -> AnySystem:
    """A model system, from the keys of a ``systems:`` entry.

    Parameters
    ----------
    name : str, optional
        The entry's name (recorded in every file); default the built-in's name, else ``"system"``.
    **spec
        The entry's keys: ``builtin`` (with ``parameters`` overriding the paper's values), or
        ``formula`` (a potential V(q)) or ``vector_field`` (dx/dt = f(x, t)) with ``coordinates``,
        or ``velocity_data`` (currents on a grid: a netCDF or zarr dataset and its variables);
        ``parameters``, ``masses`` or ``mass_matrix``, ``equilibria`` (the equilibrium search).

    Returns
    -------
    System, VectorFieldSystem or VelocityDataSystem
        The compiled system; its ``spec`` is the validated entry, defaults filled in.

    Raises
    ------
    ConfigError
        naming the argument, as the configuration names a bad key.

    Examples
    --------
    >>> import ldpipe
    >>> hh = ldpipe.system(name="henon_heiles", formula="(x**2 + y**2)/2 + x**2*y - y**3/3",
    ...                    coordinates=["x", "y"])
    >>> hh.coordinates
    ('x', 'y')
    """
    name = name or spec.get("builtin") or "system"
    with _arguments_of("system", f"systems.{name}"):
        config = validate_config({"systems": {name: copy.deepcopy(spec)}})
        built = make_system(name, system_spec(config, name))
    return dataclasses.replace(built, spec=config["systems"][name])


def section(*, fixed: dict | None = None, solve: str | None = None, sign: int | None = None,
            root: str | dict | None = None, search: Sequence[float] | None = None,
            **axes: tuple[float, float, int]) -> dict:
    """A section block (``ld_maps.*.section``, ``poincare_sections.*.initial_conditions``) in one call.

    Parameters
    ----------
    **axes : (low, high, points)
        The two axes, in order: ``y=(-0.45, 0.8, 41)`` is ``{name: y, range: [-0.45, 0.8], points: 41}``.
    fixed : dict, optional
        The fixed coordinates (a number, or ``"saddle"`` for the saddle's value).
    solve, sign, root, search : optional
        The coordinate solved from the energy, and how (the section block's keys of those names).

    Returns
    -------
    dict
        What an entry's ``section`` block holds (validated with the entry that takes it).

    Examples
    --------
    >>> import ldpipe
    >>> ldpipe.section(y=(-0.45, 0.8, 41), py=(-0.5, 0.5, 41), fixed={"px": 0.0}, solve="x", root="largest")
    ... # doctest: +NORMALIZE_WHITESPACE
    {'axes': [{'name': 'y', 'range': [-0.45, 0.8], 'points': 41}, {'name': 'py', 'range': [-0.5, 0.5], 'points': 41}],
     'fixed': {'px': 0.0}, 'solve': 'x', 'root': 'largest'}
    """
    block: dict = {"axes": []}
    for axis, value in axes.items():
        if not isinstance(value, (list, tuple)) or len(value) != 3:
            raise ConfigError(f"ldpipe.section: argument {axis!r}: expected (low, high, points), got {value!r}")
        low, high, points = value
        block["axes"].append({"name": axis, "range": [low, high], "points": points})
    options = {"fixed": fixed, "solve": solve, "sign": sign, "root": root,
               "search": list(search) if search is not None else None}
    block.update({key: value for key, value in options.items() if value is not None})
    block.setdefault("fixed", {})
    return block


def equilibria(system: AnySystem, **spec) -> xr.Dataset:
    """Every equilibrium of ``system`` in a box, with its energy, spectrum and type (the equilibria stage).

    Parameters
    ----------
    system : System or VectorFieldSystem
        From :func:`system`.
    **spec
        Keys of the system entry's ``equilibria`` block, overriding the system's own: ``box``
        (an interval per coordinate), ``default_interval``, ``seeds_per_axis``, ``tolerance``.

    Returns
    -------
    xarray.Dataset
        The stage file (contract ``equilibria``, or ``flow_equilibria`` for a vector field).

    Examples
    --------
    >>> import ldpipe
    >>> eq = ldpipe.equilibria(ldpipe.system(builtin="barbanis_2dof"))  # doctest: +SKIP
    >>> list(eq.type.values)  # doctest: +SKIP
    ['minimum', 'index-1 saddle', ...]
    """
    entry = _system_entry(system)
    entry["equilibria"] = {**entry.get("equilibria", {}), **spec}
    with _arguments_of("equilibria", f"systems.{system.name}.equilibria"):
        config = validate_config({"systems": {system.name: entry}})
        parameters = parameters_from_config(config, "equilibria", system.name)
        with tempfile.TemporaryDirectory() as scratch:
            path = run_equilibria(**parameters, output=Path(scratch) / "equilibria.nc")
            return open_stage_file(path, stage=EQUILIBRIA if system.hamiltonian else FLOW_EQUILIBRIA)


def ld_map(system: AnySystem, *, name: str = "map", equilibria: xr.Dataset | None = None, progress: bool = False,
           threads: int | None = None, **spec) -> xr.Dataset:
    """A Lagrangian-descriptor map, forward and backward (the LD stage), from an ``ld_maps:`` entry.

    Parameters
    ----------
    system : System or VectorFieldSystem
        The map's system (the entry's ``system`` name replaced by the object).
    name : str
        The entry's name, recorded in the file (default ``"map"``).
    equilibria : xarray.Dataset, optional
        The system's equilibria (:func:`equilibria`), where the saddle and an excess energy are
        read; default computed now with the system's ``equilibria`` settings, as the pipeline does.
    progress : bool
        Show a progress bar.
    threads : int, optional
        Threads of the engine (default every core).
    **spec
        The entry's keys: ``section`` (see :func:`section`), ``energy`` (``{"total": E}``,
        ``{"excess": dE}``, or a number for a total energy), ``tau``, ``p``, ``time``, ``region``,
        ``saddle_near``, ``integrator``, ``tiles``, ...

    Returns
    -------
    xarray.Dataset
        The map's file (contract ``ld_grid``): ``ld_forward``, ``ld_backward``, ``allowed`` ...;
        with ``ld=False`` (a vector field's fixed-time map with ``ftle=True``) the flow map and
        its FTLE alone (contract ``flow_map``).

    Raises
    ------
    ConfigError
        naming the argument, with the message a bad key of the entry gets.

    Examples
    --------
    >>> import ldpipe
    >>> hh = ldpipe.system(name="henon_heiles", formula="(x**2 + y**2)/2 + x**2*y - y**3/3",
    ...                    coordinates=["x", "y"])
    >>> m = ldpipe.ld_map(hh, section=ldpipe.section(y=(-0.45, 0.8, 41), py=(-0.5, 0.5, 41),
    ...                   fixed={"px": 0.0}, solve="x", root="largest"), energy=0.125, tau=2.0)  # doctest: +SKIP
    >>> m.ldpipe.plot()  # doctest: +SKIP
    """
    entry = {"system": system.name, **_energy_shorthand(spec)}
    return _run_stage("ld_map", "ld", "ld_maps", name, entry, _system_config(system), lambda config: {
        "equilibria": _equilibria_input(system, equilibria), "tiles": ld_map_tiles(config, name), "threads": threads,
        "show_progress": progress})


def periodic_orbits(system: AnySystem, *, name: str = "family", equilibria: xr.Dataset | None = None,
                    **spec) -> xr.Dataset:
    """A Lyapunov family of periodic orbits at target energies (the UPO stage), from a
    ``periodic_orbits:`` entry.

    Parameters
    ----------
    system : System
        The family's Hamiltonian system.
    name : str
        The family's name, recorded in the file (default ``"family"``).
    equilibria : xarray.Dataset, optional
        The system's equilibria (default computed now).
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
    entry = {"system": system.name, **_energy_shorthand(spec)}
    return _run_stage("periodic_orbits", "upo", "periodic_orbits", name, entry, _system_config(system),
                      lambda _: {"equilibria": _equilibria_input(system, equilibria)})


def _family_config(orbits: xr.Dataset) -> tuple[str, dict]:
    """The configuration a family file was computed from (its system and its entry), from the
    parameters it records."""
    orbits = open_stage_file(orbits, stage=UPO)
    recorded = stage_parameters(orbits)
    family, system_name = recorded["family"], recorded["system_name"]
    entry = {k: v for k, v in recorded.items() if k not in ("family", "system_name", "system_spec")}
    return family, {"systems": {system_name: recorded["system_spec"]},
                    "periodic_orbits": {family: {"system": system_name, **entry}}}


def manifolds(orbits: xr.Dataset, *, name: str = "manifolds", threads: int | None = None, **spec) -> xr.Dataset:
    """The stable and unstable manifolds of one orbit of a family, cut by a section (the
    manifolds stage), from a ``manifolds:`` entry.

    Parameters
    ----------
    orbits : xarray.Dataset
        The family (:func:`periodic_orbits`; the entry's ``orbits`` name replaced by it).
    name : str
        The entry's name (default ``"manifolds"``).
    threads : int, optional
        Threads (default every core).
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
    family, config = _family_config(orbits)
    entry = {"orbits": family, **_energy_shorthand(spec)}
    return _run_stage("manifolds", "manifolds", "manifolds", name, entry, config,
                      lambda _: {"upo": orbits, "threads": threads})


def poincare(system: AnySystem, *, name: str = "section", equilibria: xr.Dataset | None = None,
             threads: int | None = None, **spec) -> xr.Dataset:
    """A Poincaré surface of section from a grid of initial conditions (the Poincaré stage), from
    a ``poincare_sections:`` entry.

    Parameters
    ----------
    system : System or VectorFieldSystem
        The section's system.
    name : str
        The entry's name (default ``"section"``).
    equilibria : xarray.Dataset, optional
        The system's equilibria (default computed now; none for a vector field).
    threads : int, optional
        Threads (default every core).
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
    entry = {"system": system.name, **_energy_shorthand(spec)}
    return _run_stage("poincare", "poincare", "poincare_sections", name, entry, _system_config(system),
                      lambda _: {"equilibria": _equilibria_input(system, equilibria), "threads": threads})


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
    entry = {"system": system.name, **_energy_shorthand(spec)}
    return _run_stage("saddle_flux", "saddle_flux", "saddle_flux", name, entry, _system_config(system),
                      lambda _: {"equilibria": _equilibria_input(system, equilibria), "threads": threads})


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
    family, config = _family_config(orbits)
    entry = {"orbits": family, **_energy_shorthand(spec)}
    return _run_stage("transport", "transport", "transport", name, entry, config, lambda _: {
        "upo": orbits, "equilibria": _family_equilibria(orbits, equilibria), "threads": threads})


def _family_equilibria(orbits: xr.Dataset, given: xr.Dataset | None) -> xr.Dataset:
    """The equilibria given for a family's study, checked to be of the family's system (its spec
    as both files record it; the name a system goes by does not change its equilibria); required,
    since the family's file does not record the system's equilibrium-search settings that would
    find them again. A ConfigError here names the argument (``_arguments_of`` adds the function)."""
    if given is None:
        raise ConfigError("argument 'equilibria': required: give the equilibria of the family's system "
                          "(ldpipe.equilibria(system), found with the system's own 'equilibria' settings); "
                          "a family's file does not record those settings, so they cannot be found again here")
    family = stage_parameters(open_stage_file(orbits, stage=UPO))
    recorded = stage_parameters(open_stage_file(given, stage=EQUILIBRIA))
    if recorded["system_spec"] != family["system_spec"]:
        raise ConfigError(f"argument 'equilibria': equilibria of system {recorded['system_name']!r} "
                          f"{recorded['system_spec']}, but the family is of {family['system_name']!r} "
                          f"{family['system_spec']}")
    return given


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
    threads : int, optional
        Threads (default every core).
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
    with _arguments_of("nhim", "nhim.refinement"):
        # the refinement block is validated in a configuration holding the maps' system
        config = validate_config({"systems": {recorded["system_name"]: copy.deepcopy(recorded["system_spec"])},
                                  "nhim": {"refinement": dict(refinement)}})
        families = [stage_parameters(open_stage_file(orbits, stage=UPO))["family"] for orbits in references]
        with tempfile.TemporaryDirectory() as scratch:
            path = run_nhim_study(study=study, refinement=config["nhim"]["refinement"], maps=list(maps),
                                  references=families, reference_files=list(references), threads=threads,
                                  output=Path(scratch) / "nhim.nc")
            return open_stage_file(path, stage=NHIM)


def open_dataset(path: str | Path) -> xr.Dataset:
    """Any stage file, loaded into memory and checked to be one (its stage from its own attributes).

    Parameters
    ----------
    path : str or Path
        A file an ldpipe stage wrote.

    Returns
    -------
    xarray.Dataset
        As the stage that wrote it reads it (flags as booleans); ``ds.ldpipe.plot()`` draws it.

    Raises
    ------
    StageFileError
        naming the file, if it is missing, unreadable or not an ldpipe stage file.

    Examples
    --------
    >>> m = ldpipe.open_dataset("results/ld/fig3_dE0.125.nc")  # doctest: +SKIP
    """
    from .errors import StageFileError

    path = Path(path)
    if not path.is_file():
        raise StageFileError(f"{path}: no such file")
    with xr.open_dataset(path, engine="netcdf4") as handle:
        stage = handle.attrs.get(STAGE_ATTRIBUTE)
    if stage is None:
        raise StageFileError(f"{path}: not written by ldpipe (no {STAGE_ATTRIBUTE!r} attribute)")
    return open_stage_file(path, stage=str(stage))


def plot(dataset: xr.Dataset, ax=None, **options):
    """Draw what a stage file holds on ``ax`` (a new figure's if None); ``ds.ldpipe.plot()`` calls this.

    Parameters
    ----------
    dataset : xarray.Dataset
        A stage file: an LD map (``ld_grid``), a periodic-orbit family (``upo``), a Poincaré
        section (``poincare``), manifolds (``manifolds``) or equilibria (``equilibria``).
    ax : matplotlib Axes, optional
        Where to draw.
    **options
        For an LD map: ``descriptor`` (``"total"``, ``"forward"``, ``"backward"``),
        ``color_percentiles``, ``color_limits``, ``manifolds`` (manifold files drawn over it), the
        figure keys of those names; for a Poincaré section: ``point_size``.

    Returns
    -------
    matplotlib Axes

    Examples
    --------
    >>> m.ldpipe.plot(descriptor="forward")  # doctest: +SKIP
    """
    from .figures.dataset import draw_stage_file

    return draw_stage_file(dataset, ax, **options)
