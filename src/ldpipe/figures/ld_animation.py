"""Figure kind ``ld_animation``: an LD map over its start times, as small multiples and a GIF.

A map whose ``t0`` is a list or a range has a start-time dimension ``t0``: the LD (``descriptor``)
at each start time is a frame. The still figure (PNG, PDF) shows every frame side by side; the
GIF (matplotlib's PillowWriter) plays them in order of start time, one colour scale for all
frames (the percentiles over every frame's points) so that the changes seen are the flow's.
A map with one start time gives one frame.
"""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib.animation import PillowWriter

from ..core.maps.grid import open_map_file
from ..io.atomic import atomic_path
from . import style
from .data import descriptor_directions

#: Frames shown per row of the still figure.
COLUMNS = 4


def ld_frames(path: str | Path, descriptor: str) -> tuple[xr.Dataset, np.ma.MaskedArray, list[float]]:
    """(dataset, frames (n, n0, n1) masked where not integrated, start times) of an ``ld_grid`` file."""
    dataset = open_map_file(path, f"an animation of descriptor {descriptor!r}", descriptor_directions(descriptor),
                            only=False)
    stacked = "t0" in dataset.allowed.dims
    if descriptor == "total":
        values = dataset.ld_forward.values + dataset.ld_backward.values
    else:
        values = dataset[f"ld_{descriptor}"].values
    allowed = dataset.allowed.values.astype(bool)
    starts = ([float(v) for v in dataset.t0.values] if stacked else [float(dataset.attrs.get("t0", 0.0))])
    if not stacked:
        values, allowed = values[None], allowed[None]
    return dataset, np.ma.masked_array(values, mask=~allowed), starts


def draw_ld_animation(settings: dict, *, ld_maps: list[str | Path]) -> plt.Figure:
    """Every frame of the map ``ld_maps[0]`` side by side, in order of start time."""
    dataset, frames, starts = ld_frames(ld_maps[0], settings["descriptor"])
    axes_names = dataset.allowed.dims[-2:]
    rows = math.ceil(len(starts) / COLUMNS)
    columns = min(len(starts), COLUMNS)
    figure, grid = plt.subplots(rows, columns, figsize=(3.6 * columns, 2.9 * rows), squeeze=False)
    limits = style.color_limits(frames, settings["color_percentiles"])
    for k, start in enumerate(starts):
        ax = grid[k // COLUMNS][k % COLUMNS]
        style.draw_map(ax, dataset[axes_names[0]].values, dataset[axes_names[1]].values, frames[k], limits=limits,
                       colorbar_label=style.LD_LABEL[settings["descriptor"]])
        style.label_axes(ax, *axes_names)
        ax.set_title(rf"$t_0 = {start:g}$", loc="right")
    for k in range(len(starts), rows * columns):
        grid[k // COLUMNS][k % COLUMNS].set_visible(False)
    figure.tight_layout()
    return figure


def write_ld_animation(settings: dict, ld_map: str | Path, gif: str | Path) -> int:
    """Write the GIF of ``ld_map``'s frames (``settings['fps']`` a second) to ``gif``; the frame count."""
    dataset, frames, starts = ld_frames(ld_map, settings["descriptor"])
    axes_names = dataset.allowed.dims[-2:]
    limits = style.color_limits(frames, settings["color_percentiles"])
    figure, ax = plt.subplots(figsize=(6.0, 4.2))
    image = style.draw_map(ax, dataset[axes_names[0]].values, dataset[axes_names[1]].values, frames[0],
                           limits=limits, colorbar_label=style.LD_LABEL[settings["descriptor"]])
    style.label_axes(ax, *axes_names)
    title = ax.set_title("", loc="right")
    writer = PillowWriter(fps=settings["fps"])
    try:
        with atomic_path(gif, keep_suffix=True) as temporary, writer.saving(figure, str(temporary), dpi=style.DPI):
            for k, start in enumerate(starts):
                image.set_array(np.ma.transpose(frames[k]))  # as draw_map draws it: the first axis horizontal
                title.set_text(rf"$t_0 = {start:g}$")
                writer.grab_frame()
    finally:
        plt.close(figure)
    return len(starts)
