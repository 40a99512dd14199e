"""The work–precision diagram of the accuracy–cost stage's file (:data:`ldpipe.io.contracts.ACCURACY_COST`).

One column per sampled LD map, one for the periodic orbit and one for the NHIM point (each
when measured), log–log throughout, error against wall time:

* LD maps, top: the median relative LD error (solid) and its 99th percentile (dotted) against
  the wall time of the whole map at the sample's time per point, one line per scheme, each
  point labelled by its tolerance or step; the dashed grey line is the reference check's
  median (errors below it are not resolved). Bottom: the median energy drift |H(end) - H(0)|.
* Periodic orbit, top: the closure error ||x(T) - x(0)|| (re-measured) against the wall time
  of one orbit, one line per integrator rtol, points labelled by the correction tolerance.
  Bottom: the period difference to the reference orbit.
* NHIM point (2 DoF slice), top: the distance of the detected grid cell from the periodic
  orbit's crossing against the cost of the LD grid, points labelled by the grid size, with the
  plain LD maximum and the cell diagonal for comparison. Bottom: the distance of the refined
  point against the refinement's wall time, one line per method, points labelled by tolerance.

The map's own (the configured default) setting is ringed in every panel.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

from ..io.contracts import ACCURACY_COST
from ..io.datafile import open_stage_file
from ..engine.schemes import SCHEMES
from ..logs import get_logger
from ..text import short_number
from . import style

log = get_logger(__name__)

#: Colours and markers handed to the schemes in the registry's order (a new scheme takes the next).
SCHEME_COLORS = ("tab:blue", "tab:purple", "tab:orange", "tab:green", "tab:red", "tab:brown", "tab:pink",
                 "tab:olive", "tab:cyan", "tab:gray")
SCHEME_MARKERS = ("o", "P", "s", "^", "D", "v", "X", "<", ">", "h")
SCHEME_STYLE = {name: {"color": SCHEME_COLORS[k % len(SCHEME_COLORS)], "marker": SCHEME_MARKERS[k % len(SCHEME_MARKERS)]}
                for k, name in enumerate(SCHEMES)}
ORBIT_COLORS = ("tab:purple", "tab:brown", "tab:cyan", "tab:olive", "tab:pink", "tab:gray")
#: Errors are drawn no lower than this on the log axes (an exact 0 has no logarithm).
ERROR_FLOOR = 1e-16
DEFAULT_RING = {"s": 140, "facecolors": "none", "edgecolors": "black", "linewidths": 1.2, "zorder": 5}


def _label_points(ax, xs, ys, labels, color) -> None:
    for x, y, text in zip(xs, ys, labels):
        ax.annotate(text, (x, y), textcoords="offset points", xytext=(3, 3), fontsize=6, color=color)


def _floor(values: np.ndarray) -> np.ndarray:
    return np.maximum(np.asarray(values, dtype=float), ERROR_FLOOR)


def draw_map_column(ax_error, ax_energy, data: xr.Dataset, map_index: int, column: int, rows_offset: int) -> None:
    """The LD error and energy drift panels of one map, one line per scheme."""
    d = data.isel(map=map_index)
    quantiles = list(np.round(data["quantile"].values, 6))
    median, p99 = quantiles.index(0.5), quantiles.index(0.99)
    wall = d.map_wall_time_estimate.values
    for scheme in dict.fromkeys(d.scheme.values.tolist()):
        chosen = np.flatnonzero(d.scheme.values == scheme)
        # Along the ladder, loosest first (not by time, which a busy machine can reorder).
        setting = np.where(d.rtol.values > 0, d.rtol.values, d.dt.values)
        chosen = chosen[np.argsort(-setting[chosen], kind="stable")]
        look = SCHEME_STYLE.get(scheme, {"color": "black", "marker": "x"})
        steps = setting[chosen]
        labels = [short_number(v) for v in steps]
        error = _floor(d.ld_error_quantile.values[chosen, median])
        ax_error.loglog(wall[chosen], error, "-", label=scheme, markersize=4, **look)
        ax_error.loglog(wall[chosen], _floor(d.ld_error_quantile.values[chosen, p99]), ":", color=look["color"],
                        linewidth=0.8)
        _label_points(ax_error, wall[chosen], error, labels, look["color"])
        drift = _floor(d.energy_error_quantile.values[chosen, median])
        ax_energy.loglog(wall[chosen], drift, "-", markersize=4, **look)
        _label_points(ax_energy, wall[chosen], drift, labels, look["color"])
    default = np.flatnonzero(d.is_default.values.astype(bool))
    if default.size:
        ax_error.scatter(wall[default], _floor(d.ld_error_quantile.values[default, median]), label="default",
                         **DEFAULT_RING)
        ax_energy.scatter(wall[default], _floor(d.energy_error_quantile.values[default, median]), **DEFAULT_RING)
    check = float(d.reference_check_quantile.values[median])
    ax_error.axhline(max(check, ERROR_FLOOR), color="0.5", linestyle="--", linewidth=0.8,
                     label="reference check")
    mode = "variable" if bool(d.variable_time) else "fixed"
    name = str(data["map"].values[map_index])
    style.panel_letter(ax_error, column, f"{name}: LD error ({mode} time, ΔE = {float(d.excess_energy):g})")
    style.panel_letter(ax_energy, column + rows_offset, f"{name}: energy drift")
    ax_error.set_ylabel("relative LD error (median; 99%: dotted)")
    ax_energy.set_ylabel(r"median $|H(\mathrm{end}) - H(0)|$")
    cores = data.attrs.get("machine_threads_used", "?")
    ax_energy.set_xlabel(f"wall time of the whole map, s ({cores} threads)")
    ax_error.legend(loc="best", fontsize=6)


def draw_orbit_column(ax_closure, ax_period, data: xr.Dataset, column: int, rows_offset: int) -> None:
    """The closure error and period error panels of the orbit ladder, one line per integrator rtol."""
    converged = data.orbit_converged.values.astype(bool)
    wall = data.orbit_wall_time.values
    rtols = data.orbit_rtol.values
    for k, rtol in enumerate(dict.fromkeys(rtols.tolist())):
        chosen = np.flatnonzero((rtols == rtol) & converged)
        chosen = chosen[np.argsort(-data.orbit_tolerance.values[chosen], kind="stable")]
        color = ORBIT_COLORS[k % len(ORBIT_COLORS)]
        labels = [short_number(v) for v in data.orbit_tolerance.values[chosen]]
        closure = _floor(data.orbit_closure_error.values[chosen])
        period = _floor(data.orbit_period_error.values[chosen])
        ax_closure.loglog(wall[chosen], closure, "-o", color=color, markersize=4, label=f"rtol {short_number(rtol)}")
        ax_period.loglog(wall[chosen], period, "-o", color=color, markersize=4)
        _label_points(ax_closure, wall[chosen], closure, labels, color)
        _label_points(ax_period, wall[chosen], period, labels, color)
    default = np.flatnonzero(data.orbit_is_default.values.astype(bool) & converged)
    if default.size:
        ax_closure.scatter(wall[default], _floor(data.orbit_closure_error.values[default]), label="default",
                           **DEFAULT_RING)
        ax_period.scatter(wall[default], _floor(data.orbit_period_error.values[default]), **DEFAULT_RING)
    failed = int((~converged).sum())
    note = f" ({failed} did not converge)" if failed else ""
    style.panel_letter(ax_closure, column, f"periodic orbit, ΔE = {data.attrs['orbit_excess_energy']:g}: closure{note}")
    style.panel_letter(ax_period, column + rows_offset, "periodic orbit: period error")
    ax_closure.set_ylabel(r"$\|x(T) - x(0)\|$ (points: correction tolerance)")
    ax_period.set_ylabel(r"$|T - T_\mathrm{ref}|$")
    ax_period.set_xlabel("wall time of one orbit, s")
    ax_closure.legend(loc="best", fontsize=6)


def draw_nhim_column(ax_detect, ax_refine, data: xr.Dataset, column: int, rows_offset: int) -> None:
    """NHIM detection error against the LD grid's cost, and refinement error against its cost."""
    wall = data.nhim_grid_wall_time.values
    labels = [str(int(n)) for n in data.nhim_grid_points.values]
    for name, label, color in (("nhim_detection_error", "both ridges (ldpipe)", "tab:blue"),
                               ("nhim_argmax_error", "plain LD maximum", "tab:gray")):
        error = _floor(data[name].values)
        ax_detect.loglog(wall, error, "-o", color=color, markersize=4, label=label)
        _label_points(ax_detect, wall, error, labels, color)
    ax_detect.loglog(wall, data.nhim_grid_diagonal.values, "--", color="0.5", linewidth=0.8, label="grid cell diagonal")
    default = np.flatnonzero(data.nhim_grid_is_default.values.astype(bool))
    if default.size:
        ax_detect.scatter(wall[default], _floor(data.nhim_detection_error.values[default]), label="default",
                          **DEFAULT_RING)
    for m, method in enumerate(data.nhim_method.values):
        ok = data.nhim_refinement_converged.values[m].astype(bool)
        color = {"fates": "tab:red", "ld_zoom": "tab:green"}.get(str(method), "black")
        refine_wall = data.nhim_refinement_wall_time.values[m][ok]
        error = _floor(data.nhim_refinement_error.values[m][ok])
        label = {"fates": "bisection on fates", "ld_zoom": "zoomed LD grids"}.get(str(method), str(method))
        ax_refine.loglog(refine_wall, error, "-o", color=color, markersize=4, label=label)
        _label_points(ax_refine, refine_wall, error, [short_number(v) for v in data.nhim_tolerance.values[ok]], color)
        default = np.flatnonzero(data.nhim_refinement_is_default.values.astype(bool) & ok)
        if default.size:
            ax_refine.scatter(data.nhim_refinement_wall_time.values[m][default],
                              _floor(data.nhim_refinement_error.values[m][default]),
                              label="default" if m == 0 else None, **DEFAULT_RING)
    style.panel_letter(ax_detect, column, f"NHIM detection on {data.attrs['nhim_map']}")
    style.panel_letter(ax_refine, column + rows_offset, "NHIM refinement (points: tolerance)")
    ax_detect.set_ylabel("distance from the orbit's crossing (points: grid n)")
    ax_refine.set_ylabel("distance from the orbit's crossing")
    ax_detect.set_xlabel("wall time of the LD grid and detection, s")
    ax_refine.set_xlabel("wall time of the refinement, s")
    ax_detect.legend(loc="best", fontsize=6)
    ax_refine.legend(loc="best", fontsize=6)


def accuracy_cost_figure(data: xr.Dataset):
    """The figure of an ``accuracy_cost`` dataset (either part may be absent)."""
    maps = data.sizes.get("map", 0)
    orbit = "orbit_setting" in data.dims
    nhim = "nhim_grid" in data.dims
    columns = maps + int(orbit) + int(nhim)
    with style.figure_style():
        figure, axes = plt.subplots(2, columns, figsize=(4.2 * columns, 6.6), squeeze=False, constrained_layout=True)
        for m in range(maps):
            draw_map_column(axes[0, m], axes[1, m], data, m, m, columns)
        if orbit:
            draw_orbit_column(axes[0, maps], axes[1, maps], data, maps, columns)
        if nhim:
            column = maps + int(orbit)
            draw_nhim_column(axes[0, column], axes[1, column], data, column, columns)
        for ax in axes.ravel():
            ax.grid(True, which="major", linewidth=0.3, alpha=0.5)
            # Times as plain numbers at 1, 2, 5 per decade: 2x10^0, 3x10^0 ... labels collide.
            ax.xaxis.set_major_locator(LogLocator(base=10.0, subs=(1.0, 2.0, 5.0)))
            ax.xaxis.set_major_formatter(FuncFormatter(lambda value, _: f"{value:g}"))
            ax.xaxis.set_minor_formatter(NullFormatter())
    return figure


def draw_accuracy_cost(path: str | Path, *, png: str | Path, pdf: str | Path | None = None) -> list[Path]:
    """Draw the work–precision diagram of the stage file ``path`` to ``png`` (and ``pdf``)."""
    data = open_stage_file(path, stage=ACCURACY_COST, variables=())  # each part optional: drawn if its dimension is there
    if not {"map", "orbit_setting", "nhim_grid"} & set(data.dims):
        raise ValueError(f"{path}: holds no LD, orbit or NHIM ladder; nothing to draw")
    figure = accuracy_cost_figure(data)
    written = style.save_figure(figure, png, pdf)
    log.info("wrote %s", ", ".join(str(p) for p in written))
    return written
