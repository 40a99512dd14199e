"""The NHIM ladders: detection error against grid resolution, location error against refinement depth."""

from __future__ import annotations

import dataclasses

import numpy as np
import xarray as xr

from ..maps.grid import ld_grid_dataset
from ...logs import get_logger
from ..nhim import (
    RefinementFailed, RefinementSettings, SliceProblem, detect_global_argmax, detect_nhim_cell, refine_by_fates,
    refine_by_ld_zoom,
)
from .timing import RepeatRule, repeat_timed

log = get_logger(__package__)  # the package's name, as before the split, in the log lines


#: The refinement methods of :mod:`ldpipe.core.nhim` the refinement ladder measures.
REFINEMENT_METHODS = ("fates", "ld_zoom")


def nhim_grid_dataset(
    problem: SliceProblem,
    crossing: np.ndarray,
    grid_points: list[int],
    *,
    rule: RepeatRule = RepeatRule(),
) -> xr.Dataset:
    """Detection error against grid resolution: the LD map at n x n points, its NHIM cell, the distance.

    Parameters
    ----------
    problem : ldpipe.core.nhim.SliceProblem
        The slice (its section's ranges and LD settings are kept; the grid changes).
    crossing : ndarray, shape (2,)
        The periodic orbit's crossing of the slice (section coordinates), the exact NHIM point.
    grid_points : list of int, length G
        Points per axis.

    Returns
    -------
    xarray.Dataset
        Dimension ``nhim_grid`` (G): points per axis, cell diagonal, wall time (LD grid forward
        and backward plus detection, smallest of the runs ``rule`` allows,
        :class:`~ldpipe.core.accuracy.timing.RepeatRule`), the distance of the detected cell
        (``nhim.detect_nhim_cell``) and of the plain LD maximum (``nhim.detect_global_argmax``)
        from the crossing.
    """
    n = len(grid_points)
    wall = np.zeros(n)
    runs = np.zeros(n, dtype=np.int64)
    error, argmax_error, diagonal = np.zeros(n), np.zeros(n), np.zeros(n)
    for k, points in enumerate(grid_points):
        section = dataclasses.replace(problem.section, shape=(int(points), int(points)))

        def detect():
            grid = ld_grid_dataset(problem.system, section, problem.energy, problem.ld_settings)
            axes = (grid[section.axes[0]].values, grid[section.axes[1]].values)
            fields = (grid.ld_forward.values, grid.ld_backward.values, grid.allowed.values)
            return axes, fields, detect_nhim_cell(*fields, axes)

        timed = repeat_timed(detect, rule)
        (axes, fields, detected), wall[k], runs[k] = timed.result, timed.wall_time, timed.runs
        error[k] = float(np.linalg.norm(detected.point - crossing))
        argmax_error[k] = float(np.linalg.norm(detect_global_argmax(*fields, axes).point - crossing))
        diagonal[k] = float(np.hypot(*[(hi - lo) / (points - 1) for lo, hi in section.ranges]))
        log.info("NHIM detection on %4d x %-4d: %.3f s, distance %.2e (plain maximum %.2e), cell diagonal %.2e",
                 points, points, wall[k], error[k], argmax_error[k], diagonal[k])
    return xr.Dataset(
        {
            "nhim_grid_points": ("nhim_grid", np.asarray(grid_points, dtype=np.int64),
                                 {"long_name": "grid points per axis of the LD map"}),
            "nhim_grid_diagonal": ("nhim_grid", diagonal, {"long_name": "diagonal of one grid cell (section units)"}),
            "nhim_grid_wall_time": ("nhim_grid", wall, {
                "units": "s", "long_name": f"LD grid (forward and backward) and detection; {rule.description()}"}),
            "nhim_grid_timed_runs": ("nhim_grid", runs, RepeatRule.runs_attributes("nhim_grid_wall_time")),
            "nhim_detection_error": ("nhim_grid", error, {
                "long_name": "distance of the detected cell (largest min(F/F_ridge, B/B_ridge)) from the orbit's crossing"}),
            "nhim_argmax_error": ("nhim_grid", argmax_error, {
                "long_name": "distance of the plain maximum of forward plus backward LD from the orbit's crossing"}),
        },
        coords={"nhim_grid": np.arange(n)},
    )


def nhim_refinement_dataset(
    problem: SliceProblem,
    guess: np.ndarray,
    crossing: np.ndarray,
    tolerances: list[float],
    base: RefinementSettings,
    *,
    precision_ratio: float,
    rule: RepeatRule = RepeatRule(),
) -> xr.Dataset:
    """Location error against refinement depth, for both refinement methods of :mod:`ldpipe.core.nhim`.

    Each tolerance t refines ``guess`` with ``base`` at tolerance t and bisection precision
    ``precision_ratio`` x t, by fates (``refine_by_fates``) and by zoomed LD re-gridding
    (``refine_by_ld_zoom``).

    Returns
    -------
    xarray.Dataset
        Dimensions ``nhim_method`` (fates, ld_zoom) and ``nhim_refinement`` (len(tolerances)):
        wall time (smallest of the runs ``rule`` allows, :class:`~ldpipe.core.accuracy.timing.RepeatRule`), the runs timed, trajectories integrated, iterations, the method's own
        uncertainty, the distance from the crossing, and whether it converged (0 elsewhere).
    """
    methods = {"fates": refine_by_fates, "ld_zoom": refine_by_ld_zoom}
    shape = (len(REFINEMENT_METHODS), len(tolerances))
    out = {name: np.zeros(shape) for name in ("wall_time", "error", "uncertainty")}
    trajectories = np.zeros(shape, dtype=np.int64)
    iterations = np.zeros(shape, dtype=np.int64)
    runs = np.zeros(shape, dtype=np.int64)
    converged = np.zeros(shape, dtype=bool)
    for m, method in enumerate(REFINEMENT_METHODS):
        for k, tolerance in enumerate(tolerances):
            settings = dataclasses.replace(base, tolerance=float(tolerance),
                                           bisection_precision=float(tolerance) * precision_ratio)
            try:
                timed = repeat_timed(lambda: methods[method](problem, guess, settings), rule)
            except RefinementFailed as error:
                log.info("NHIM refinement by %s at tolerance %g failed: %s", method, tolerance, error)
                continue
            refined, best = timed.result, timed.wall_time
            converged[m, k] = True
            out["wall_time"][m, k] = best
            runs[m, k] = timed.runs
            out["error"][m, k] = float(np.linalg.norm(refined.point - crossing))
            out["uncertainty"][m, k] = refined.uncertainty
            trajectories[m, k] = refined.cost.trajectories
            iterations[m, k] = refined.iterations
            log.info("NHIM refinement by %-7s tolerance %.0e: %.3f s, %5d trajectories, distance %.2e",
                     method, tolerance, best, trajectories[m, k], out["error"][m, k])
    zero_note = "0 where the refinement did not converge"
    return xr.Dataset(
        {
            "nhim_tolerance": ("nhim_refinement", np.asarray(tolerances, dtype=float),
                               {"long_name": "refinement tolerance (section units)"}),
            "nhim_refinement_converged": (("nhim_method", "nhim_refinement"), converged),
            "nhim_refinement_wall_time": (("nhim_method", "nhim_refinement"), out["wall_time"], {
                "units": "s", "long_name": f"refinement from the detected cell; {rule.description()}",
                "comment": zero_note}),
            "nhim_refinement_timed_runs": (("nhim_method", "nhim_refinement"), runs, {
                **RepeatRule.runs_attributes("nhim_refinement_wall_time"), "comment": zero_note}),
            "nhim_refinement_trajectories": (("nhim_method", "nhim_refinement"), trajectories, {"comment": zero_note}),
            "nhim_refinement_iterations": (("nhim_method", "nhim_refinement"), iterations, {"comment": zero_note}),
            "nhim_refinement_uncertainty": (("nhim_method", "nhim_refinement"), out["uncertainty"], {
                "long_name": "the method's own error bound (last update, or the final grid spacing)",
                "comment": zero_note}),
            "nhim_refinement_error": (("nhim_method", "nhim_refinement"), out["error"], {
                "long_name": "distance of the refined point from the orbit's crossing", "comment": zero_note}),
        },
        coords={"nhim_method": list(REFINEMENT_METHODS), "nhim_refinement": np.arange(len(tolerances))},
    )
