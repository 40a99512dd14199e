"""One stage file drawn on one axes: what ``ds.ldpipe.plot(ax)`` and :func:`ldpipe.plot` draw.

An LD map with the paper's colour scale (the ``section_maps`` figure's panel), a periodic-orbit
family in the configuration plane, a Poincaré section with its energy boundary, the curves where
manifolds cut their section, the curves extracted from a map (a structures file), or the
equilibria (of a Hamiltonian or a vector field) in the plane of the first two coordinates. The
options an LD map takes are the figure keys of the same names, with their defaults from the
configuration schema.
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr

from ..config import load_schema
from ..core.maps.grid import BOTH
from ..errors import ConfigError
from ..io.contracts import EQUILIBRIA, FLOW_EQUILIBRIA, LD_GRID, MANIFOLDS, POINCARE, STRUCTURES, UPO
from ..io.datafile import STAGE_ATTRIBUTE, stage_parameters
from . import style
from .data import load_orbits
from .section_maps import draw_ld_panel, draw_manifold_curves, draw_poincare
from .structures import draw_structure_curves

#: The figure keys an LD map or a Poincaré section takes as options.
MAP_OPTIONS = ("descriptor", "color_percentiles", "color_limits")
POINCARE_OPTIONS = ("point_size",)


def _figure_defaults(keys: tuple[str, ...]) -> dict:
    """The configuration schema's defaults of these keys of a ``figures:`` entry (their one home)."""
    properties = load_schema()["$defs"]["figure"]["properties"]
    return {key: properties[key]["default"] for key in keys}


def _options(given: dict, keys: tuple[str, ...], stage: str) -> dict:
    unknown = sorted(set(given) - set(keys))
    if unknown:
        raise ConfigError(f"plot of a {stage!r} file: unknown options {unknown}; it takes {list(keys)}")
    return {**_figure_defaults(keys), **given}


def _draw_ld_map(ax, dataset: xr.Dataset, manifolds=(), structures=(), **options) -> None:
    directions = str(dataset.attrs.get("directions", BOTH))
    if "descriptor" not in options and directions != BOTH:  # a map of one direction: its LD by default
        options = {**options, "descriptor": directions}
    settings = _options(options, MAP_OPTIONS, LD_GRID.stage)
    draw_ld_panel(ax, dataset, settings, list(manifolds))
    draw_structure_curves(ax, [structures] if isinstance(structures, xr.Dataset) else list(structures))


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


def draw_stage_file(dataset: xr.Dataset, ax=None, **options):
    """Draw the stage file ``dataset`` on ``ax`` (a new figure's if None) and return the axes.

    Options: an LD map takes ``descriptor`` (default its total, or for a map of one direction that
    direction's LD), ``color_percentiles``, ``color_limits`` (the figure keys), ``manifolds``
    (manifold files drawn over it) and ``structures`` (structures files, or one, whose curves are
    drawn over it); a Poincaré section ``point_size``.
    """
    stage = dataset.attrs.get(STAGE_ATTRIBUTE)
    drawings = {
        LD_GRID.stage: lambda: _draw_ld_map(ax, dataset, **options),
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
