"""Figure kind ``potential``: the potential on a configuration plane and its Hill's regions.

The paper's Fig. 1 (Barbanis 2 DoF: contours with the saddles, the surface, the Hill's regions
below and above E_c) and Fig. 2 (Barbanis-Contopoulos 3 DoF at z = z_eq, the Hill's region
for ΔE = 6 on that plane) are both this kind.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from ..logs import get_logger
from ..core.sections import fixed_values
from ..systems import make_system
from . import style
from .data import potential_on_plane, saddles

log = get_logger(__name__)


def _energies(settings: dict, critical_energy: float) -> list[tuple[float, float]]:
    """(total, excess) energy pairs of the Hill's regions."""
    (kind, values), = settings["energies"].items()
    if kind == "excess":
        return [(critical_energy + v, v) for v in values]
    return [(v, v - critical_energy) for v in values]


def draw_potential(settings: dict, *, equilibria: str | Path) -> plt.Figure:
    """Contours (and optionally the surface) of V on a plane, saddles marked, and Hill's regions.

    Parameters
    ----------
    settings : dict
        The figure's entry under ``figures:`` (kind ``potential``), defaults filled.
    equilibria : path
        The system's ``equilibria`` stage file (saddles, critical energies, the system's spec).
    """
    positions, saddle, critical_energy, coordinates, parameters = saddles(equilibria, settings.get("saddle_near"))
    system = make_system(parameters["system_name"], parameters["system_spec"])
    axes = tuple(settings["plane"])
    ranges = [settings["plane"][a] for a in axes]
    fixed = fixed_values(settings.get("fixed", {}), system, saddle, key="figures.<potential>.fixed")
    first, second, potential = potential_on_plane(system, axes, ranges, settings["points"], fixed)
    log.info("V of %s on (%s, %s), fixed %s: E_c = %.10g at %s", system.name, *axes, fixed, critical_energy, saddle)

    # Display range: the potential falls to -inf beyond the saddles; show it from its lowest
    # value in the plane (or the configured range) up to as far above E_c as E_c is above that.
    low, high = settings.get("potential_range") or (float(potential.min()), 2 * critical_energy - float(potential.min()))
    shown = np.clip(potential, low, high)
    levels = np.linspace(low, high, settings["levels"])
    # Saddles lying on the plane (the fixed coordinates at their values) are marked.
    on_plane = [
        p for p in positions
        if all(abs(p[coordinates.index(name)] - value) <= 1e-6 * max(1.0, abs(value)) for name, value in fixed.items())
    ]
    marks = np.array([[p[coordinates.index(axes[0])], p[coordinates.index(axes[1])]] for p in on_plane]).reshape(-1, 2)
    energies = _energies(settings, critical_energy)

    panels = 1 + bool(settings["surface"]) + len(energies)
    figure = plt.figure(figsize=(3.4 * panels, 3.2))
    index = 0
    ax = figure.add_subplot(1, panels, 1)
    contours = ax.contour(first, second, shown.T, levels=levels, cmap="viridis", linewidths=0.7)
    colorbar = figure.colorbar(contours, ax=ax, fraction=0.046, pad=0.03)
    colorbar.set_label(r"$V$")
    ax.plot(marks[:, 0], marks[:, 1], "x", color=style.SADDLE_COLOR, markersize=8, mew=2, label="index-1 saddles")
    style.label_axes(ax, *axes)
    style.panel_letter(ax, index)
    ax.set_aspect("equal", adjustable="box")
    if fixed:
        ax.set_title(", ".join(f"{style.symbol(k)} = {v:.4g}" for k, v in fixed.items()), loc="right")
    if settings["surface"]:
        index += 1
        ax3 = figure.add_subplot(1, panels, 2, projection="3d")
        step = max(1, len(first) // 120)  # a surface of ~120 x 120 facets is plenty to see
        grid_first, grid_second = np.meshgrid(first[::step], second[::step], indexing="ij")
        # Facets outside the display range are left out (NaN), not flattened onto its edges.
        heights = np.where((potential >= low) & (potential <= high), potential, np.nan)[::step, ::step]
        surface = ax3.plot_surface(grid_first, grid_second, heights, cmap="viridis",
                                   vmin=low, vmax=high, linewidth=0, antialiased=False, rasterized=True)
        surface.set_rasterized(True)
        marks_v = [system.potential(p) for p in on_plane]
        ax3.scatter(marks[:, 0], marks[:, 1], marks_v, color=style.SADDLE_COLOR, marker="x", s=50, depthshade=False)
        ax3.set_xlabel(style.symbol(axes[0]))
        ax3.set_ylabel(style.symbol(axes[1]))
        ax3.set_zlabel(r"$V$")
        ax3.set_zlim(low, high)
        style.panel_letter(ax3, index)
    for energy, excess in energies:
        index += 1
        ax = figure.add_subplot(1, panels, index + 1)
        allowed = (potential <= energy).astype(float)
        ax.contourf(first, second, allowed.T, levels=[0.5, 1.5], colors=[style.HILL_COLOR])
        ax.contour(first, second, potential.T, levels=[energy], colors="black", linewidths=0.8)
        ax.plot(marks[:, 0], marks[:, 1], "x", color=style.SADDLE_COLOR, markersize=7, mew=2)
        ax.set_xlim(first[0], first[-1])
        ax.set_ylim(second[0], second[-1])
        ax.set_aspect("equal", adjustable="box")
        style.label_axes(ax, *axes)
        style.panel_letter(ax, index)
        ax.set_title(rf"$\Delta E = {excess:.3f}$", loc="right")
    figure.suptitle(f"{system.name}: $E_c$ = {critical_energy:.6g}; Hill's region $V \\leq E$ in grey", fontsize=9)
    figure.tight_layout()
    return figure
