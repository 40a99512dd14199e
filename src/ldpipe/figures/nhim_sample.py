"""Figure kind ``nhim_sample``: the points of an NHIM sampling study, with the Lyapunov orbits.

In 3 DoF the NHIM is a 3-sphere in the energy surface and both Lyapunov orbits lie on it. The
figure draws the sampled points (full phase-space states) in 3D projections (by default (x, y, z)
and (y, z, p_z)), coloured by the sign of the solved momentum, with the Lyapunov orbits of the
named families at the study's energy drawn over them; and the slice family's coverage: every
slice of the grid of fixed values, marked by what it gave (a point, or which degeneracy), in the
plane of the first two fixed coordinates, one panel column per sign.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.ticker import MaxNLocator

from ..io.contracts import NHIM_SAMPLING
from ..io.datafile import open_stage_file
from . import style
from .data import load_orbits

#: Marker and colour of each slice status in the coverage panels.
STATUS_STYLE = {
    "ok": ("o", "tab:green"),
    "forbidden": ("s", "0.6"),
    "no_crossing": ("x", "tab:red"),
    "tangent": ("^", "tab:orange"),
    "momentum_vanishes": ("D", "tab:purple"),
}
#: Colours of the two signs of the solved momentum.
SIGN_COLOURS = {1: "tab:blue", -1: "tab:cyan"}
ORBIT_COLOURS = ("black", "tab:red", "tab:brown", "tab:pink")


def draw_nhim_sample(settings: dict, *, sampling: str | Path, upo: list[str | Path] = ()) -> plt.Figure:
    """The sampled NHIM in 3D projections with the Lyapunov orbits, and the family's coverage.

    Parameters
    ----------
    settings : dict
        The figure's entry: ``projections`` (lists of three phase coordinates), ``view``.
    sampling : path
        The study file (stage ``nhim_sampling``).
    upo : list of paths
        Periodic-orbit family files; each family's orbit at the study's energy is drawn.
    """
    data = open_stage_file(sampling, stage=NHIM_SAMPLING)
    phase = [str(p) for p in data.phase.values]
    energy = float(data.attrs["energy"])
    orbits = [(Path(path).stem, load_orbits(path, [{"total": energy}])[0]) for path in upo]
    states = data.state.values
    point_signs = data.sign.values[data.slice_of_point.values]
    flags = data.status.attrs["flag_meanings"].split()
    status = np.array([flags[list(data.status.attrs["flag_values"]).index(v)] for v in data.status.values])
    signs = sorted({int(s) for s in data.sign.values}, reverse=True)
    projections = settings.get("projections", [["x", "y", "z"], ["y", "z", "pz"]])
    figure = plt.figure(figsize=(5.2 * len(projections), 9.0))
    grid = figure.add_gridspec(2, max(len(projections), len(signs)))
    elevation, azimuth = settings.get("view", (20.0, -60.0))
    for index, axes3 in enumerate(projections):
        ax = figure.add_subplot(grid[0, index], projection="3d")
        columns = [phase.index(c) for c in axes3]
        for sign in signs:
            chosen = point_signs == sign
            ax.scatter(*(states[chosen, c] for c in columns), s=6, color=SIGN_COLOURS[sign], depthshade=False,
                       label=f"NHIM points, {style.symbol(str(data.attrs['solved']))} {'>' if sign > 0 else '<'} 0")
        for (name, orbit), colour in zip(orbits, ORBIT_COLOURS):
            ax.plot(*(orbit.coordinate(c) for c in axes3), color=colour, lw=1.2, label=f"Lyapunov orbit {name}")
        # Equal units on the three axes, so the NHIM's shape is not distorted by the axes' ranges.
        spans = [np.ptp(np.concatenate([states[:, c], *(o.coordinate(a) for _, o in orbits)])) for c, a in zip(columns, axes3)]
        ax.set_box_aspect([max(span, 1e-6) for span in spans])
        ax.set_xlabel(style.symbol(axes3[0]))
        ax.set_ylabel(style.symbol(axes3[1]))
        ax.set_zlabel(style.symbol(axes3[2]))
        # Equal units leave a short axis where the NHIM is thin: three ticks keep its labels apart.
        for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
            axis.set_major_locator(MaxNLocator(3))
        ax.view_init(elevation, azimuth)
        style.panel_letter(ax, index, f"({', '.join(style.symbol(c) for c in axes3)})")
        if index == 0:
            handles, labels = ax.get_legend_handles_labels()
    # One legend for the projections, above them, clear of the 3D axes' tick labels.
    figure.legend(handles, labels, loc="upper center", ncol=2, fontsize="small", frameon=False)
    fixed = [str(f) for f in data.fixed.values]
    values = data.fixed_values.values
    for column, sign in enumerate(signs):
        ax = figure.add_subplot(grid[1, column])
        on_sign = data.sign.values == sign
        for name, (marker, colour) in STATUS_STYLE.items():
            chosen = on_sign & (status == name)
            if not chosen.any():
                continue
            # Slices differing only in the later fixed coordinates overlap here; a small offset by
            # the third coordinate's index keeps each visible.
            offset = _third_offset(values[chosen], values, len(fixed))
            ax.scatter(values[chosen, 0] + offset, values[chosen, 1], marker=marker, color=colour, s=22,
                       label=f"{name} ({int(chosen.sum())})")
        style.label_axes(ax, fixed[0], fixed[1] if len(fixed) > 1 else fixed[0])
        rest = f", each node split by {style.symbol(fixed[2])}" if len(fixed) > 2 and len(np.unique(values[:, 2])) > 1 else ""
        style.panel_letter(ax, len(projections) + column,
                           f"slices, {style.symbol(str(data.attrs['solved']))} {'>' if sign > 0 else '<'} 0{rest}")
        ax.legend(fontsize="small")
    figure.tight_layout(rect=(0.0, 0.0, 1.0, 0.95))  # the top strip is the legend's
    return figure


def _third_offset(chosen: np.ndarray, every: np.ndarray, count: int) -> np.ndarray:
    """Horizontal offsets (a fraction of the first coordinate's spacing) by the index of the third
    fixed coordinate's value, so slices at one (first, second) node stay apart."""
    if count < 3:
        return np.zeros(len(chosen))
    first = np.unique(every[:, 0])
    third = np.unique(every[:, 2])
    spacing = np.min(np.diff(first)) if len(first) > 1 else 1.0
    position = np.searchsorted(third, chosen[:, 2])
    return (position - (len(third) - 1) / 2) * 0.6 * spacing / max(len(third), 1)
