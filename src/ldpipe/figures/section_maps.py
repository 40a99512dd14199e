"""Figure kind ``section_maps``: Poincaré sections above LD maps on the same section.

The paper's Fig. 3: (a-c) Poincaré sections of U_xpx at three energies with the energy
boundary in green; (d-f) fixed-time LD maps on the same section and energies, with the curves
where the stable (cyan) and unstable (magenta) manifolds of the periodic orbits cut it.
Either row may be left out.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import matplotlib.pyplot as plt
import xarray as xr

from ..io.contracts import POINCARE
from ..io.datafile import input_name, open_stage_file, stage_parameters
from ..logs import get_logger
from ..core.sections import Section
from ..systems import make_system
from . import style
from .data import allowed_mask, load_ld_map, load_manifold_curves

log = get_logger(__name__)

#: Grid on which the energy boundary of a Poincaré section is traced (a contour of the allowed mask).
BOUNDARY_POINTS = 600


def energy_title(excess: float, energy: float) -> str:
    return rf"$\Delta E = {excess:.3f}$ ($E = {energy:.4g}$)"


def draw_poincare(ax, path: str | Path | xr.Dataset, *, point_size: float) -> None:
    """One Poincaré section: every located crossing, and the section's energy boundary in green."""
    dataset = open_stage_file(path, stage=POINCARE, variables=("crossing_state", "crossing_valid"))
    parameters = stage_parameters(dataset)
    start = parameters["initial_conditions"]
    axes = (start["axes"][0]["name"], start["axes"][1]["name"])
    phase = [str(p) for p in dataset.phase.values]
    valid = dataset.crossing_valid.values.astype(bool)
    states = dataset.crossing_state.values[valid]
    ax.plot(states[:, phase.index(axes[0])], states[:, phase.index(axes[1])], ".", color="black",
            markersize=point_size, markeredgewidth=0, rasterized=True)
    system = make_system(parameters["system_name"], parameters["system_spec"])
    if "energy" not in dataset.attrs:  # a vector field's: no energy boundary
        style.label_axes(ax, *axes)
        ax.set_title(rf"$t_0 = {float(dataset.attrs.get('t0', 0.0)):g}$", loc="right")
        log.info("Poincaré section %s: %d crossings", input_name(path), len(states))
        return
    # The energy boundary: where the solved momentum of the section vanishes.
    energy = float(dataset.attrs["energy"])
    name = parameters["name"] if "name" in parameters else Path(path).stem
    section = Section.from_spec(start, system, key=f"poincare_sections.{name}.initial_conditions")
    section = dataclasses.replace(section, shape=(BOUNDARY_POINTS, BOUNDARY_POINTS))
    first, second, allowed = allowed_mask(system, section, energy)
    ax.contour(first, second, allowed.T.astype(float), levels=[0.5], colors=style.BOUNDARY_COLOR, linewidths=1.0)
    ax.set_xlim(section.ranges[0])
    ax.set_ylim(section.ranges[1])
    style.label_axes(ax, *axes)
    ax.set_title(energy_title(float(dataset.attrs["excess_energy"]), energy), loc="right")
    log.info("Poincaré section %s: %d crossings", input_name(path), len(states))


def draw_manifold_curves(ax, paths: list[str | Path | xr.Dataset], axes: tuple[str, str]) -> None:
    """The curves where manifolds cut the section, projected on the map's axes."""
    for path in paths:
        curves = load_manifold_curves(path)
        for kind, color in (("stable", style.STABLE_COLOR), ("unstable", style.UNSTABLE_COLOR)):
            for piece in curves.curves.get(kind, []):
                ax.plot(piece[:, curves.phase.index(axes[0])], piece[:, curves.phase.index(axes[1])],
                        color=color, linewidth=0.9)


def draw_ld_panel(ax, path: str | Path | xr.Dataset, settings: dict,
                  manifolds: list[str | Path | xr.Dataset] = ()) -> None:
    """One LD map with its colour bar, the forbidden region grey, optional manifold curves."""
    ld_map = load_ld_map(path, settings["descriptor"])
    limits = settings.get("color_limits") or style.color_limits(ld_map.values, settings["color_percentiles"])
    style.draw_map(ax, ld_map.first, ld_map.second, ld_map.values, limits=limits,
                   colorbar_label=style.LD_LABEL[settings["descriptor"]])
    if manifolds:
        draw_manifold_curves(ax, manifolds, ld_map.axes)
    ax.set_xlim(ld_map.first[0], ld_map.first[-1])  # the grid's range, as the Poincaré panels above
    ax.set_ylim(ld_map.second[0], ld_map.second[-1])
    style.label_axes(ax, *ld_map.axes)
    mode = ld_map.attrs.get("time_mode", "fixed")
    if "iterations" in ld_map.attrs:  # a discrete map's: no time, N iterations each way
        ax.set_title(rf"$N = {int(ld_map.attrs['iterations'])}$", loc="right")
    else:
        where = (energy_title(float(ld_map.attrs["excess_energy"]), float(ld_map.attrs["energy"]))
                 if "energy" in ld_map.attrs else rf"$t_0 = {float(ld_map.attrs.get('t0', 0.0)):g}$")  # a vector field's
        ax.set_title(where + rf", $\tau = {float(ld_map.attrs['tau']):g}$" + ("" if mode == "fixed" else f" ({mode})"),
                     loc="right")
    log.info("LD map %s: colour range %s", input_name(path), limits)


def draw_section_maps(settings: dict, *, poincare: list[str | Path] = (), ld_maps: list[str | Path] = (),
                      manifolds: dict[str, list[str | Path]] | None = None) -> plt.Figure:
    """Poincaré sections (top row) over LD maps (bottom row).

    Parameters
    ----------
    settings : dict
        The figure's entry under ``figures:`` (kind ``section_maps``), defaults filled.
    poincare : list of paths
        ``poincare`` stage files, one panel each, in order.
    ld_maps : list of paths
        ``ld_grid`` stage files, one panel each, in order.
    manifolds : dict, optional
        For an LD map's name (as in ``settings['ld_maps']``), the ``manifolds`` stage files
        whose section curves are drawn on it.
    """
    manifolds = manifolds or {}
    rows = [row for row in (list(poincare), list(ld_maps)) if row]
    columns = max(len(row) for row in rows)
    figure, grid = plt.subplots(len(rows), columns, figsize=(3.6 * columns, 3.2 * len(rows)), squeeze=False)
    letter = 0
    for row, files in enumerate(rows):
        for column, path in enumerate(files):
            ax = grid[row][column]
            if files is rows[0] and poincare:
                draw_poincare(ax, path, point_size=settings["point_size"])
            else:
                name = settings["ld_maps"][column]
                draw_ld_panel(ax, path, settings, manifolds.get(name, []))
            style.panel_letter(ax, letter)
            letter += 1
        for column in range(len(files), columns):
            grid[row][column].set_visible(False)
    figure.tight_layout()
    return figure
