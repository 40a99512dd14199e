"""One stage file drawn on one axes: what ``ds.ldpipe.plot()`` and :func:`ldpipe.plot` draw.

An LD map with the paper's colour scale (the ``section_maps`` figure's panel), a periodic-orbit
family in the configuration plane, a Poincaré section with its energy boundary, the curves where
manifolds cut their section, the curves extracted from a map (a structures file), or the
equilibria (of a Hamiltonian or a vector field) in the plane of the first two coordinates. The
options an LD map takes are the figure keys of the same names, with their defaults from the
configuration schema.
"""

from __future__ import annotations

import copy

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr

from ..config.loading import shared_schema
from ..core.maps.grid import BOTH, require_directions
from ..errors import ConfigError
from ..io.contracts import EQUILIBRIA, FLOW_EQUILIBRIA, LD_GRID, MANIFOLDS, POINCARE, STRUCTURES, UPO
from ..io.datafile import STAGE_ATTRIBUTE, stage_parameters
from . import style
from .data import DESCRIPTORS, descriptor_directions, load_orbits
from .section_maps import draw_manifold_curves, draw_poincare, energy_title
from .structures import draw_structure_curves

#: The figure keys an LD map or a Poincaré section takes as options.
MAP_OPTIONS = ("descriptor", "color_percentiles", "color_limits")
POINCARE_OPTIONS = ("point_size",)
#: The matplotlib keywords a map's drawing passes on (xarray's pcolormesh takes them too).
MATPLOTLIB_OPTIONS = ("cmap", "vmin", "vmax", "norm", "add_colorbar", "x", "y")
#: The symbols of a map's fields in axis and colour-bar labels; other variables are named by their long name.
FIELD_SYMBOLS = {"ld_forward": style.LD_LABEL["forward"], "ld_backward": style.LD_LABEL["backward"],
                 "ftle_forward": r"FTLE $\Lambda^{f}$", "ftle_backward": r"FTLE $\Lambda^{b}$"}


def _figure_defaults(keys: tuple[str, ...]) -> dict:
    """The configuration schema's defaults of these keys of a ``figures:`` entry (their one home)."""
    properties = shared_schema()["$defs"]["figure"]["properties"]
    return {key: copy.deepcopy(properties[key]["default"]) for key in keys}  # the plot's own, to change


def _options(given: dict, keys: tuple[str, ...], stage: str) -> dict:
    unknown = sorted(set(given) - set(keys))
    if unknown:
        raise ConfigError(f"plot of a {stage!r} file: unknown options {unknown}; it takes {list(keys)}")
    return {**_figure_defaults(keys), **given}


def _with_units(text: str, attrs: dict) -> str:
    units = attrs.get("units")
    return f"{text} [{units}]" if units else text


def map_field(dataset: xr.Dataset, variable: str | None, descriptor: str) -> tuple[xr.DataArray, str]:
    """The field of an LD map file to draw and its colour-bar label: ``variable`` (any variable on
    the map's grid: an LD, an FTLE, a flag), or by default the LD ``descriptor`` (forward plus
    backward for ``total``). Missing points are NaN: never integrated, or not defined."""
    if variable is None:
        if descriptor not in DESCRIPTORS:
            raise ConfigError(f"plot option descriptor={descriptor!r}: expected one of {list(DESCRIPTORS)}")
        require_directions(dataset.attrs, descriptor_directions(descriptor), f"the plot of descriptor={descriptor!r}")
        if descriptor == "total":
            field = dataset.ld_forward + dataset.ld_backward
            field.attrs = {k: v for k, v in dataset.ld_forward.attrs.items() if k == "units"}
        else:
            field = dataset[f"ld_{descriptor}"]
        return field, _with_units(style.LD_LABEL[descriptor], field.attrs)
    if variable not in dataset.data_vars:
        grid = dataset.allowed.dims
        drawable = sorted(name for name, v in dataset.data_vars.items() if set(grid) <= set(v.dims))
        raise ConfigError(f"plot: this map has no variable {variable!r}; it has {drawable}")
    field = dataset[variable]
    if field.dtype.kind == "b":  # a flag: 0 or 1
        field = field.astype(np.int8)
    symbol = FIELD_SYMBOLS.get(variable, field.attrs.get("long_name", variable))
    return field, _with_units(symbol, field.attrs)


def _horizontal_vertical(dims: tuple, x: str | None, y: str | None) -> tuple[str, str]:
    """The coordinates drawn horizontally and vertically: the map's first axis (the section's
    first coordinate: ``lon``, ``x``, ``q1``) horizontal, as the workflow's figures draw it, unless
    ``x`` or ``y`` names one. (xarray's own ``.plot()`` draws the last dimension horizontally.)"""
    dims = tuple(str(d) for d in dims)
    for given, key in ((x, "x"), (y, "y")):
        if given is not None and given not in dims:
            raise ConfigError(f"plot option {key}={given!r}: expected one of the map's coordinates {list(dims)}")
    if x is None and y is None:
        return dims[0], dims[1]
    if x is None:
        return next(d for d in dims if d != y), y
    return x, y if y is not None else next(d for d in dims if d != x)


def _draw_ld_map(ax, dataset: xr.Dataset, variable: str | None = None, manifolds=(), structures=(),
                 **options) -> None:
    """A field of an LD map as xarray's ``dataset[variable].plot(x=first axis)`` draws it (the
    same cells), with missing points in the figures' neutral grey, the figures'
    robust colour scale unless ``vmin``, ``vmax`` or ``norm`` say otherwise, and the axes and
    colour bar labelled with the paper's symbols and their units."""
    passed = {key: options.pop(key) for key in MATPLOTLIB_OPTIONS if key in options}
    directions = str(dataset.attrs.get("directions", BOTH))
    if variable is None and "descriptor" not in options and directions != BOTH:  # one direction: its LD by default
        options = {**options, "descriptor": directions}
    settings = _options(options, MAP_OPTIONS, LD_GRID.stage)
    field, label = map_field(dataset, variable, settings["descriptor"])
    if field.ndim != 2:
        extra = [d for d in field.dims if d not in dataset.allowed.dims[-2:]]
        raise ConfigError(f"plot: {field.name or 'the LD'} has the dimensions {list(field.dims)}; select one "
                          f"value of {extra} first, e.g. ds.isel({extra[0]}=0).ldpipe.plot()")
    cmap = plt.get_cmap(passed.pop("cmap", style.LD_COLORMAP)).with_extremes(bad=style.FORBIDDEN_COLOR)
    if passed.get("norm") is None:
        passed.pop("norm", None)
        low, high = settings.get("color_limits") or style.color_limits(field.values, settings["color_percentiles"])
        passed.setdefault("vmin", low)
        passed.setdefault("vmax", high)
    add_colorbar = passed.pop("add_colorbar", True)
    horizontal, vertical = _horizontal_vertical(field.dims, passed.pop("x", None), passed.pop("y", None))
    field.plot.pcolormesh(ax=ax, x=horizontal, y=vertical, cmap=cmap, add_colorbar=add_colorbar, rasterized=True,
                          **({"cbar_kwargs": {"label": label}} if add_colorbar else {}), **passed)
    ax.set_xlabel(_with_units(style.symbol(horizontal), dataset[horizontal].attrs))
    ax.set_ylabel(_with_units(style.symbol(vertical), dataset[vertical].attrs))
    if manifolds:
        draw_manifold_curves(ax, list(manifolds), (horizontal, vertical))
    draw_structure_curves(ax, [structures] if isinstance(structures, xr.Dataset) else list(structures),
                          along=(horizontal, vertical))
    ax.set_title("")
    if "iterations" in dataset.attrs:  # a discrete map's: no time, N iterations each way
        ax.set_title(rf"$N = {int(dataset.attrs['iterations'])}$", loc="right")
        return
    where = (energy_title(float(dataset.attrs["excess_energy"]), float(dataset.attrs["energy"]))
             if "energy" in dataset.attrs else rf"$t_0 = {float(dataset.attrs.get('t0', 0.0)):g}$")
    ax.set_title(where + (rf", $\tau = {float(dataset.attrs['tau']):g}$" if "tau" in dataset.attrs else ""), loc="right")


def _draw_structures(ax, dataset: xr.Dataset) -> None:
    """The curves of a structures file alone, stable and unstable, over the map's window."""
    axes = draw_structure_curves(ax, [dataset])
    style.label_axes(ax, *axes)
    if dataset.sizes["curve"]:
        ax.legend(loc="best")
    ax.set_title(f"structures of {dataset.attrs.get('map_title', 'an LD map')}", loc="right")


def _draw_orbits(ax, dataset: xr.Dataset) -> None:
    """Each orbit of the family over one period in the configuration plane, coloured by energy."""
    orbits = load_orbits(dataset)
    first, second = orbits[0].phase[:2]
    energies = [orbit.energy for orbit in orbits]
    colors = plt.get_cmap("plasma")(np.linspace(0.0, 0.85, len(orbits)))
    for orbit, color in zip(orbits, colors):
        ax.plot(orbit.coordinate(first), orbit.coordinate(second), color=color, linewidth=1.0,
                label=rf"$E = {orbit.energy:.6g}$")
    style.label_axes(ax, first, second)
    if len(energies) <= 8:
        ax.legend(loc="best")
    ax.set_title(f"family {dataset.attrs.get('family', stage_parameters(dataset).get('family', ''))}", loc="right")


def _draw_manifolds(ax, dataset: xr.Dataset) -> None:
    """The stable and unstable manifolds' cuts by their section, on the two phase coordinates left
    when the section's coordinate and its conjugate are taken out."""
    surface = stage_parameters(dataset)["section"]["coordinate"]
    position = surface[1:] if surface.startswith("p") and surface[1:] in dataset.phase.values else surface
    axes = tuple(str(c) for c in dataset.phase.values if c not in (position, "p" + position))[:2]
    draw_manifold_curves(ax, [dataset], axes)
    style.label_axes(ax, *axes)


def _draw_equilibria(ax, dataset: xr.Dataset) -> None:
    """Every equilibrium in the plane of the first two coordinates, index-1 saddles as red crosses."""
    positions = dataset.position.values
    types = [str(t) for t in dataset.type.values]
    coordinates = [str(c) for c in dataset[dataset.position.dims[1]].values]
    for kind in dict.fromkeys(types):
        chosen = np.array([t == kind for t in types])
        saddle = "saddle" in kind and "1" in kind
        ax.plot(positions[chosen, 0], positions[chosen, 1] if positions.shape[1] > 1 else 0 * positions[chosen, 0],
                "x" if saddle else "o", color=style.SADDLE_COLOR if saddle else None, label=kind)
    style.label_axes(ax, coordinates[0], coordinates[1] if len(coordinates) > 1 else "")
    ax.legend(loc="best")


def draw_stage_file(dataset: xr.Dataset, ax=None, variable: str | None = None, **options):
    """Draw the stage file ``dataset`` on ``ax`` (a new figure's if None) and return the axes.

    An LD map draws ``variable`` (any variable on its grid: ``"ftle_forward"``, a flag ...; by
    default the LD ``descriptor``: the total, or for a map of one direction that direction's LD)
    as ``dataset[variable].plot()`` does, the same dimension horizontal, with missing points grey.
    It takes ``descriptor``, ``color_percentiles``, ``color_limits`` (the figure keys),
    ``manifolds`` (manifold files drawn over it), ``structures`` (structures files, or one, whose
    curves are drawn over it) and matplotlib's ``cmap``, ``vmin``, ``vmax``, ``norm``,
    ``add_colorbar``, and xarray's ``x``, ``y`` (which coordinate is horizontal, vertical). A
    Poincaré section takes ``point_size``.
    """
    stage = dataset.attrs.get(STAGE_ATTRIBUTE)
    if variable is not None and stage != LD_GRID.stage:
        raise ConfigError(f"plot: a {stage!r} file is drawn whole; only an LD map draws one variable ({variable!r})")
    drawings = {
        LD_GRID.stage: lambda: _draw_ld_map(ax, dataset, variable, **options),
        POINCARE.stage: lambda: draw_poincare(ax, dataset, **_options(options, POINCARE_OPTIONS, POINCARE.stage)),
        UPO.stage: lambda: _draw_orbits(ax, dataset, **options),
        MANIFOLDS.stage: lambda: _draw_manifolds(ax, dataset, **options),
        EQUILIBRIA.stage: lambda: _draw_equilibria(ax, dataset, **options),
        STRUCTURES.stage: lambda: _draw_structures(ax, dataset, **options),
        FLOW_EQUILIBRIA.stage: lambda: _draw_equilibria(ax, dataset, **options),
    }
    if stage not in drawings:
        raise ConfigError(f"ldpipe draws files of the stages {sorted(drawings)}; this Dataset is "
                          + (f"of the {stage!r} stage" if stage else "not a stage file (no 'ldpipe_stage' attribute)"))
    if ax is None:
        _, ax = plt.subplots()
    drawings[stage]()
    return ax
