"""Figure kind ``ld_slices``: LD maps with one-dimensional slices through them, and optionally
the periodic orbit they detect.

The paper's Fig. 4 (variable-time LD on U_xpx^+(k) for three k near the bottom saddle, each
with slices at fixed p_x above the map; the configuration space with the slices, the orbit and
the Hill's region; the orbit threading the slices in (x, p_x, y)) and Fig. 5 (3 DoF maps on
U_xpx^+, U_ypy^+, U_zpz^+ with slices) are both this kind. Where an orbit is given, the points
where it pierces each section are marked on the maps and slices: the LD maxima should sit there.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.colors import Normalize

from ..logs import get_logger
from . import style
from .data import (
    LDMap, Orbit, load_ld_map, load_orbits, nearest_index, orbit_section_points, plane_view, potential_on_plane,
)

log = get_logger(__name__)

#: Facets per side of an LD map drawn on a plane of the 3D view (more only slows rendering).
SURFACE_FACETS = 90
#: Grid of the potential in the configuration-space view.
POTENTIAL_POINTS = 300


def section_points(ld_map: LDMap, orbit: Orbit) -> np.ndarray:
    """States (k, 2 n_dof) where the orbit pierces the map's section, or none (shape (0, 2 n_dof)).

    Only a section fixing a single configuration coordinate (and any momenta the orbit does not
    need to match) is pierced by a periodic orbit at isolated points; for others none are returned.
    """
    n_dof = len(orbit.phase) // 2
    configuration = orbit.phase[:n_dof]
    section = ld_map.section
    fixed_positions = [name for name in section.fixed if name in configuration]
    if len(fixed_positions) != 1 or len(section.fixed) != 1:
        return np.zeros((0, len(orbit.phase)))
    name = fixed_positions[0]
    return orbit_section_points(orbit, name, section.fixed[name], section.solve, section.sign)


def _map_title(ld_map: LDMap) -> str:
    """The section's symbol and its fixed coordinates, 'saddle' values resolved."""
    parts = [f"{style.symbol(name)} = {value:.4g}" for name, value in ld_map.section.fixed.items()]
    parts.append(rf"$\Delta E$ = {float(ld_map.attrs['excess_energy']):.3f}")
    return style.section_symbol(ld_map.axes, ld_map.section.sign) + ": " + ", ".join(parts)


def draw_map_with_slices(ax_curve, ax_map, ld_map: LDMap, settings: dict, pierce: np.ndarray, phase) -> None:
    """Slices at fixed values of the map's second axis (curves above), the map below."""
    limits = settings.get("color_limits") or style.color_limits(ld_map.values, settings["color_percentiles"])
    image = style.draw_map(ax_map, ld_map.first, ld_map.second, ld_map.values, limits=limits)
    colorbar_axes = ax_map.inset_axes([1.03, 0.0, 0.05, 1.0])  # keeps the map aligned with its curves
    ax_map.figure.colorbar(image, cax=colorbar_axes).set_label(style.LD_LABEL[settings["descriptor"]])
    style.label_axes(ax_map, *ld_map.axes)
    slices = [(value, style.SLICE_COLORS[i % len(style.SLICE_COLORS)], "") for i, value in enumerate(settings["slices"])]
    if settings["slice_through_orbit"]:
        slices += [(point[phase.index(ld_map.axes[1])], style.ORBIT_COLOR, " (orbit)") for point in pierce]
    for value, color, note in slices:
        row = nearest_index(ld_map.second, value)
        ax_curve.plot(ld_map.first, ld_map.values[:, row], color=color, linewidth=0.9,
                      label=f"{style.symbol(ld_map.axes[1])} = {np.round(ld_map.second[row], 3) + 0.0:.3f}{note}")
        ax_map.axhline(ld_map.second[row], color=color, linestyle="--", linewidth=0.8)
    for point in pierce:
        ax_map.plot(point[phase.index(ld_map.axes[0])], point[phase.index(ld_map.axes[1])], "o", markersize=7,
                    markerfacecolor="none", markeredgecolor="white", markeredgewidth=1.5)
        ax_curve.axvline(point[phase.index(ld_map.axes[0])], color=style.ORBIT_COLOR, linestyle=":", linewidth=0.9)
    ax_curve.set_ylabel(style.LD_LABEL[settings["descriptor"]])
    ax_curve.tick_params(labelbottom=False)
    ax_curve.legend(loc="upper left", frameon=False)
    ax_curve.set_xlim(ld_map.first[0], ld_map.first[-1])


def _distinct(orbits: list[Orbit]) -> list[Orbit]:
    """The orbits without repeats (one per energy), in order."""
    return list({round(orbit.energy, 10): orbit for orbit in orbits}.values())


def draw_configuration_view(ax, maps: list[LDMap], orbits: list[Orbit], settings: dict) -> None:
    """Configuration space: the Hill's region (grey) of the highest energy, the isopotentials
    V = E, the slices (orange), the saddle region (dashed), the orbits (black) and the saddle (red cross)."""
    system = maps[0].system()
    energies = sorted({round(float(m.attrs["energy"]), 10) for m in maps})
    orbits = _distinct(orbits)
    coordinates = system.coordinates
    segments = []
    for ld_map in maps:
        fixed = {k: v for k, v in ld_map.section.fixed.items() if k in coordinates}
        axis = ld_map.axes[0]
        if axis not in coordinates or len(fixed) != 1:
            continue
        (name, value), = fixed.items()
        ends = {axis: (ld_map.first[0], ld_map.first[-1]), name: (value, value)}
        segments.append((ends[coordinates[0]], ends[coordinates[1]]))
    q0 = np.concatenate([orbit.coordinate(coordinates[0]) for orbit in orbits])
    q1 = np.concatenate([orbit.coordinate(coordinates[1]) for orbit in orbits])
    ranges = plane_view(settings.get("configuration"), coordinates[:2], np.concatenate([q0, *[s[0] for s in segments]]),
                        np.concatenate([q1, *[s[1] for s in segments]]), margin=0.5)
    saddle = np.asarray(maps[0].attrs["saddle_position"])
    fixed_rest = {c: float(saddle[i]) for i, c in enumerate(coordinates[2:], start=2)}
    first, second, potential = potential_on_plane(system, coordinates[:2], ranges, POTENTIAL_POINTS, fixed_rest)
    ax.contourf(first, second, (potential <= energies[-1]).T.astype(float), levels=[0.5, 1.5], colors=[style.HILL_COLOR])
    ax.contour(first, second, potential.T, levels=energies, colors="black", linewidths=0.8)
    lower = np.asarray(maps[0].attrs.get("region_lower", []))
    upper = np.asarray(maps[0].attrs.get("region_upper", []))
    if lower.size >= 2:
        ax.add_patch(plt.Rectangle((lower[0], lower[1]), upper[0] - lower[0], upper[1] - lower[1], fill=False,
                                   linestyle="--", edgecolor="0.3", linewidth=0.8, label="saddle region $q_s$"))
    for index, (xs, ys) in enumerate(segments):
        ax.plot(xs, ys, color=style.SLICE_COLOR, linewidth=2.0, label="slices" if index == 0 else None)
    for index, orbit in enumerate(orbits):
        label = "periodic orbit" + ("s" if len(orbits) > 1 else "") + ", $\\Delta E$ = " + ", ".join(
            f"{o.excess_energy:.3f}" for o in orbits)
        ax.plot(orbit.coordinate(coordinates[0]), orbit.coordinate(coordinates[1]), color=style.ORBIT_COLOR,
                linewidth=1.2, label=label if index == 0 else None)
    ax.plot(saddle[0], saddle[1], "x", color=style.SADDLE_COLOR, markersize=8, mew=2)
    ax.set_xlim(ranges[0])
    ax.set_ylim(ranges[1])
    ax.set_aspect("equal", adjustable="box")
    style.label_axes(ax, *coordinates[:2])
    ax.legend(loc="upper right", frameon=True, framealpha=0.8)


def draw_3d_view(ax, maps: list[LDMap], orbits: list[Orbit], pierce: list[np.ndarray], settings: dict) -> None:
    """The maps on their planes in (first axis, second axis, fixed coordinate) and the orbits
    threading them (2 DoF sections that fix one configuration coordinate)."""
    phase = orbits[0].phase
    ax.computed_zorder = False  # draw in the order given: the orbit over the planes it threads
    for ld_map, points in zip(maps, pierce):
        fixed = ld_map.section.fixed
        if len(fixed) != 1:
            continue
        (name, value), = fixed.items()
        step_first = max(1, len(ld_map.first) // SURFACE_FACETS)
        step_second = max(1, len(ld_map.second) // SURFACE_FACETS)
        values = ld_map.values[::step_first, ::step_second]
        limits = settings.get("color_limits") or style.color_limits(ld_map.values, settings["color_percentiles"])
        colors = style.ld_colormap()(Normalize(*limits)(values))
        colors[np.ma.getmaskarray(values)] = (0, 0, 0, 0)  # forbidden points transparent here
        grid_first, grid_second = np.meshgrid(ld_map.first[::step_first], ld_map.second[::step_second], indexing="ij")
        ax.plot_surface(grid_first, grid_second, np.full(grid_first.shape, float(value)), facecolors=colors,
                        shade=False, linewidth=0, antialiased=False, rasterized=True)
        if len(points):
            ax.scatter(points[:, phase.index(ld_map.axes[0])], points[:, phase.index(ld_map.axes[1])],
                       points[:, phase.index(name)], color="white", edgecolor="black", s=25, depthshade=False,
                       zorder=4)
        axes3 = (ld_map.axes[0], ld_map.axes[1], name)
    for orbit in _distinct(orbits):
        ax.plot(orbit.coordinate(axes3[0]), orbit.coordinate(axes3[1]), orbit.coordinate(axes3[2]),
                color=style.ORBIT_COLOR, linewidth=1.5, zorder=3)
    ax.set_xlabel(style.symbol(axes3[0]))
    ax.set_ylabel(style.symbol(axes3[1]))
    ax.set_zlabel(style.symbol(axes3[2]))
    ax.view_init(elev=settings["view"][0], azim=settings["view"][1])


def draw_ld_slices(settings: dict, *, ld_maps: list[str | Path], upo: str | Path | None = None) -> plt.Figure:
    """LD maps with slices (curves above, map below); with an orbit, also the configuration-space
    view and the 3D view of the orbit threading the sections.

    Parameters
    ----------
    settings : dict
        The figure's entry under ``figures:`` (kind ``ld_slices``), defaults filled.
    ld_maps : list of paths
        ``ld_grid`` stage files, one column each, in order.
    upo : path, optional
        The ``upo`` family file of ``settings['orbit']['family']``; its orbit at
        ``settings['orbit']['energy']``, or without one at each map's own excess energy, is drawn.
    """
    maps = [load_ld_map(path, settings["descriptor"]) for path in ld_maps]
    orbits = []
    if upo is not None:
        energy = settings["orbit"].get("energy")
        requested = [energy] * len(maps) if energy else [{"excess": float(m.attrs["excess_energy"])} for m in maps]
        orbits = load_orbits(upo, requested)
    phase = orbits[0].phase if orbits else None
    pierce = [section_points(m, o) for m, o in zip(maps, orbits)] or [np.zeros((0, 1))] * len(maps)
    columns = len(maps)
    extra = bool(orbits) and len(phase) == 4
    figure = plt.figure(figsize=(max(3.9 * columns, 8.5), 4.8 + (4.4 if extra else 0.0)))
    outer = figure.add_gridspec(2 if extra else 1, 1, height_ratios=[4.8, 4.4] if extra else [1], hspace=0.28)
    top = outer[0].subgridspec(2, columns, height_ratios=[1.0, 2.2], hspace=0.06, wspace=0.75)
    for index, ld_map in enumerate(maps):
        ax_curve = figure.add_subplot(top[0, index])
        ax_map = figure.add_subplot(top[1, index], sharex=ax_curve)
        draw_map_with_slices(ax_curve, ax_map, ld_map, settings, pierce[index], phase)
        style.panel_letter(ax_curve, index, _map_title(ld_map))
        for point in pierce[index]:
            log.info("map %s: orbit pierces it at %s", ld_map.name, np.round(point, 6).tolist())
    if extra:
        bottom = outer[1].subgridspec(1, 2, wspace=0.15)
        ax = figure.add_subplot(bottom[0, 0])
        draw_configuration_view(ax, maps, orbits, settings)
        style.panel_letter(ax, columns)
        ax3 = figure.add_subplot(bottom[0, 1], projection="3d")
        draw_3d_view(ax3, maps, orbits, pierce, settings)
        style.panel_letter(ax3, columns + 1)
    return figure
