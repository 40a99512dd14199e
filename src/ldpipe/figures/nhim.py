"""The NHIM validation figure: detected, refined and reference points on the LD maps, and the numbers.

Top row: each 2 DoF map of the first study that lists maps, cropped around its NHIM point, with
the plain argmax of ld_forward + ld_backward, the detection criterion's grid point, the refined
point and the periodic orbit's crossing. Bottom: distances from the reference of every 2 DoF
slice of every study (log scale, with the validation tolerance), and the residence times of the
refined points of higher-DoF slices against their grid neighbours'.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..io.contracts import NHIM
from ..io.datafile import open_stage_file
from . import style
from .data import load_ld_map

#: Markers of the points (face colour, marker, label).
MARKERS = {
    "argmax_sum_point": ("white", "x", r"argmax $\mathcal{L}^f + \mathcal{L}^b$"),
    "detected_point": ("white", "s", r"argmax $\min(\mathcal{L}^f/\mathcal{L}^f_r, \mathcal{L}^b/\mathcal{L}^b_r)$"),
    "refined_point": ("red", "o", "refined (fates)"),
}


def _studies(paths: list[str | Path]) -> list:
    return [open_stage_file(path, stage=NHIM) for path in paths]


def _map_panel(ax, map_path: str | Path, study, index: int) -> None:
    ld = load_ld_map(map_path)
    k = list(study.slice.values).index(ld.name)
    refined = study.refined_point.values[k]
    others = [study[name].values[k] for name in ("argmax_sum_point", "detected_point", "reference_point")]
    # A window that shows every marker, at least 30 grid cells wide.
    spacing = study.grid_spacing.values[k]
    half = np.maximum(np.max(np.abs(np.array(others) - refined), axis=0) * 1.3, 15 * spacing)
    keep = [(axis >= c - h) & (axis <= c + h) for axis, c, h in zip((ld.first, ld.second), refined, half)]
    values = ld.values[np.ix_(keep[0], keep[1])]
    style.draw_map(ax, ld.first[keep[0]], ld.second[keep[1]], values,
                   limits=style.color_limits(values, (2, 99.5)), colorbar_label=style.LD_LABEL["total"])
    for name, (color, marker, label) in MARKERS.items():
        point = study[name].values[k]
        ax.plot(*point, marker=marker, markersize=6, markerfacecolor="none" if marker == "s" else color,
                markeredgecolor=color, linestyle="none", label=label)
    if str(study.reference_kind.values[k]) == "orbit_crossing":
        ax.plot(*study.reference_point.values[k], marker="o", markersize=11, markerfacecolor="none",
                markeredgecolor=style.ORBIT_COLOR, linestyle="none", label="periodic orbit crossing")
    style.label_axes(ax, *ld.axes)
    # The numbers the map's spec fixes (coordinates fixed at the saddle are left out of the title).
    spec = ld.parameters["section"]["fixed"]
    fixed = ", ".join(f"{style.symbol(n)} = {v:g}" for n, v in spec.items() if v != "saddle")
    style.panel_letter(ax, index, f"{ld.name}: {fixed}, $\\Delta E$ = {float(ld.attrs['excess_energy']):g}")


def draw_nhim_validation(
    *, studies: list[str | Path], maps: list[str | Path], tolerance: float, png: str | Path, pdf: str | Path | None = None,
) -> list[Path]:
    """Draw the validation figure from study files (stage ``nhim``) and the LD map files of the top row.

    Parameters
    ----------
    studies : list of paths
        Study files; every slice with an orbit-crossing reference goes into the distance panel.
    maps : list of paths
        LD maps (stage ``ld_grid``) drawn in the top row; each must be a slice of one of the studies.
    tolerance : float
        The validation tolerance, drawn as a line.
    """
    import matplotlib.pyplot as plt

    data = _studies(studies)
    columns = max(len(maps), 2)
    with style.figure_style():
        figure = plt.figure(figsize=(4.2 * columns, 7.6), layout="constrained")
        grid = figure.add_gridspec(2, columns)
        index = 0
        for path in maps:
            name = Path(path).stem
            study = next((s for s in data if name in list(s.slice.values)), None)
            if study is None:
                raise ValueError(f"{path}: map {name} is in none of the studies {[str(s) for s in studies]}")
            ax = figure.add_subplot(grid[0, index])
            _map_panel(ax, path, study, index)
            if index == 0:
                ax.legend(loc="lower left", framealpha=0.8)
            index += 1
        half = columns // 2
        ax = figure.add_subplot(grid[1, :half] if half else grid[1, 0])
        labels, rows = [], []
        for study in data:
            for k, name in enumerate(study.slice.values):
                if str(study.reference_kind.values[k]) == "orbit_crossing":
                    labels.append(f"{study.attrs['study']}/{name}")
                    rows.append([study[f"distance_{m}"].values[k] for m in ("argmax_sum", "detected", "refined")]
                                + [study.distance_zoom.values[k] if study.zoom_converged.values[k] else np.nan])
        if rows:
            rows = np.array(rows)
            position = np.arange(len(rows))
            floor = 1e-13  # distances of exactly 0 drawn at the bottom of the log axis
            for column, (label, marker, color) in enumerate((
                    (MARKERS["argmax_sum_point"][2], "x", "0.3"), (MARKERS["detected_point"][2], "s", "tab:blue"),
                    ("refined (fates)", "o", "red"), ("refined (zoomed LD)", "^", "tab:green"))):
                ax.semilogy(position, np.maximum(rows[:, column], floor), marker=marker, linestyle="none",
                            markerfacecolor="none" if marker in "s^" else color, color=color, label=label)
            ax.axhline(tolerance, color="black", linestyle="--", linewidth=0.8, label=f"tolerance {tolerance:g}")
            ax.set_xticks(position, labels, rotation=70, ha="right", fontsize=6)
            ax.set_ylabel("distance from the orbit's crossing")
            ax.set_ylim(floor / 3, 1e5)  # room above the points for the legend
            ax.legend(loc="upper right", ncols=2)
        style.panel_letter(ax, index, "2 DoF: distance from the periodic orbit")
        index += 1
        ax = figure.add_subplot(grid[1, half:])
        labels, values = [], []
        for study in data:
            for k, name in enumerate(study.slice.values):
                if str(study.reference_kind.values[k]) != "orbit_crossing":
                    labels.append(f"{study.attrs['study']}/{name}")
                    values.append([study.residence_forward.values[k], study.residence_backward.values[k],
                                   study.neighbour_residence_max.values[k]])
        if values:
            values = np.array(values)
            position = np.arange(len(values))
            width = 0.27
            for column, (label, color) in enumerate((("refined, forward", "tab:red"), ("refined, backward", "tab:blue"),
                                                     ("grid neighbours, longest", "0.5"))):
                ax.bar(position + (column - 1) * width, values[:, column], width, color=color, label=label)
            ax.set_xticks(position, labels, rotation=30, ha="right", fontsize=7)
            ax.set_ylabel("time in the saddle region")
            ax.legend(loc="lower right")
        style.panel_letter(ax, index, "higher DoF: residence in the saddle region")
        return style.save_figure(figure, png, pdf)
