"""Figure kind ``ld_ftle``: each LD map beside its forward and backward FTLE fields.

One row per map (a map computed with ``ftle: true``): the LD (``descriptor``), the forward FTLE
and the backward FTLE, on the map's grid (a map of one direction, ``directions``: its FTLE alone). Ridges of the forward FTLE mark repelling
Lagrangian coherent structures, of the backward FTLE attracting ones (Shadden et al. 2005); the
LD's singular features lie along the same stable and unstable manifolds. Points where the
FTLE is not defined (a trajectory stopped early, or the grid neighbours its differences need
did: land, the data's edge, a region exit) are grey, as are the LD's points that start on land.
The FTLE's colour bars carry its units (``1/day`` on data counted in days).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from ..core.maps.grid import computed_directions, open_map_file
from ..errors import ConfigError
from ..logs import get_logger
from . import style
from .data import descriptor_directions, load_ld_map

log = get_logger(__name__)


def draw_ld_ftle(settings: dict, *, ld_maps: list[str | Path]) -> plt.Figure:
    """LD, forward FTLE and backward FTLE of each map in ``ld_maps`` (``ld_grid`` files), a row each."""
    figure, grid = plt.subplots(len(ld_maps), 3, figsize=(11.5, 3.3 * len(ld_maps)), squeeze=False)
    for row, path in enumerate(ld_maps):
        ld_map = load_ld_map(path, settings["descriptor"])
        dataset = open_map_file(path, "figure kind 'ld_ftle'", descriptor_directions(settings["descriptor"]),
                                only=False)
        labels = computed_directions(dataset)
        if f"ftle_{labels[0]}" not in dataset:
            raise ConfigError(f"figure kind 'ld_ftle': map {ld_map.name!r} ({path}) has no FTLE; "
                              f"compute it with ftle: true (config key ld_maps.{ld_map.name}.ftle)")
        # the LD is missing where a point starts on land (a trajectory that reached land keeps its LD)
        panels = [(ld_map.values, style.LD_LABEL[settings["descriptor"]])]
        for label in labels:
            field = dataset[f"ftle_{label}"]
            units = field.attrs.get("units")  # per the data's time unit (1/day), where the system names it
            values = np.ma.masked_invalid(field.values)  # missing where not defined
            panels.append((values, f"FTLE, {label}" + (f" [{units}]" if units else "")))
        for column in range(3):
            ax = grid[row][column]
            if column >= len(panels):  # a map of one direction: no other direction's FTLE
                ax.set_axis_off()
                continue
            values, label = panels[column]
            limits = style.color_limits(values, settings["color_percentiles"])
            style.draw_map(ax, ld_map.first, ld_map.second, values, limits=limits, colorbar_label=label)
            style.label_axes(ax, *ld_map.axes)
            style.panel_letter(ax, 3 * row + column)
        grid[row][0].set_title(rf"$t_0 = {float(ld_map.attrs.get('t0', 0.0)):g}$, $\tau = {float(ld_map.attrs['tau']):g}$",
                               loc="right")
        log.info("LD and FTLE of map %s", path)
    figure.tight_layout()
    return figure
