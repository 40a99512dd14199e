"""The systems of the Python API, and the sections and equilibria of them."""

from __future__ import annotations

import copy
import dataclasses
from collections.abc import Sequence

import xarray as xr

from ..config import validate_config
from ..config.parameters import parameters_from_config
from ..core.equilibria.study import equilibria_dataset
from ..errors import ConfigError
from ..systems import make_system, system_spec
from ..systems.velocity_data import DEFAULTS as VELOCITY_DEFAULTS, is_in_memory, memory_entry
from .arguments import AnySystem, api_function, arguments_of, entry_key, equilibria_of, system_entry

#: The keys of a section block besides its axes (:func:`section`).
SECTION_KEYS = ("fixed", "solve", "sign", "root", "search")


@api_function("$defs/system")
def system(*, name: str | None = None, **spec) -> AnySystem:
    """A model system, from the keys of a ``systems:`` entry.

    Parameters
    ----------
    name : str, optional
        The entry's name (recorded in every file); default the built-in's name, else ``"system"``.
    **spec
        The entry's keys: ``builtin`` (with ``parameters`` overriding the paper's values), or
        ``formula`` (a potential V(q)) or ``vector_field`` (dx/dt = f(x, t)) with ``coordinates``,
        or ``velocity_data`` (currents on a grid: a netCDF or zarr dataset and its variables; or, in
        memory, an ``xarray.Dataset``, lazy or not, a mapping ``{"dataset": ds, "u": "uo", ...}``
        with the entry's other keys, or the DataArrays ``(u, v)``, ``(u, v, w)``, or
        ``{"u": u, "v": v, "coordinates": "sphere"}``; the grid's coordinates not named are read
        from u's dimensions (time, [z,] y, x));
        or ``map`` (a discrete map x_{n+1} = f(x_n): ``"henon"``, ``"standard"``, or formulas with
        ``coordinates``, an ``inverse`` and ``periodic`` coordinates);
        ``parameters``, ``masses`` or ``mass_matrix``, ``equilibria`` (the equilibrium search).

    Returns
    -------
    System, VectorFieldSystem, VelocityDataSystem or DiscreteMapSystem
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
    builtin = spec.get("builtin", spec.get("map"))
    # a built-in's name names its entry, unless it is no name at all (then the entry's error says so)
    name = name or (builtin if isinstance(builtin, str) and builtin.isidentifier() else None) or "system"
    with arguments_of("system", entry_key("system", "systems", name)):
        if is_in_memory(spec.get("velocity_data")):  # the data stay in this process, the entry records their hash
            spec = {**spec, "velocity_data": memory_entry(spec["velocity_data"], f"systems.{name}.velocity_data",
                                                          VELOCITY_DEFAULTS)}
        config = validate_config({"systems": {name: copy.deepcopy(spec)}})
        built = make_system(name, system_spec(config, name))
    return dataclasses.replace(built, spec=config["systems"][name])


@api_function()
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


@api_function("$defs/system/properties/equilibria")
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
    entry = system_entry(system)
    entry["equilibria"] = {**entry.get("equilibria", {}), **spec}
    with arguments_of("equilibria", f"systems.{system.name}.equilibria"):
        config = validate_config({"systems": {system.name: entry}})
        return equilibria_dataset(parameters_from_config(config, "equilibria", system.name))


def equilibria_input(system: AnySystem, given: xr.Dataset | None) -> xr.Dataset | None:
    """The equilibria a stage reads: those given (checked to be ``system``'s; a ConfigError names
    the argument), none for a vector field, else computed now."""
    if given is not None:
        return equilibria_of(given, system.name, system_entry(system), "the system given")
    if not system.hamiltonian:
        return None
    return equilibria(system)
