"""NHIM sampling stage: points of the NHIM over a family of slices, by continuation.

A study is declared under ``nhim_sampling`` in the configuration (see the schema): a variable-time
LD map whose section, energy, saddle region, tau and integrator every slice keeps (``base_map``;
the map itself is not computed), a grid of the section's fixed values (``fixed``: a range and a
number of points per fixed coordinate), the signs of the solved momentum, and how each slice's
point is looked for (``window``, ``seed_points``, ``min_angle``, ``min_momentum``); the refinement
is ``nhim.refinement``'s. :func:`ldpipe.core.nhim.sampling.sample_family` does the science; this module
writes the study file: every slice with its status (and the reason for a degenerate one), and every
point (non-degenerate slices only) as a full phase-space state with its uncertainty, energy
residual, residence times and detection evidence.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import xarray as xr

from ..io.atomic import check_writable
from ..io.contracts import EQUILIBRIA, NHIM_SAMPLING
from ..io.datafile import open_stage_file, write_stage_file
from ..errors import ConfigError
from ..logs import get_logger
from ..core.nhim import Cost, RefinementSettings, make_slice_problem
from ..core.nhim.sampling import STATUS, SamplingSettings, SliceSample, sample_family
from ..core.maps import assembly

log = get_logger(__name__)


def fixed_grid(fixed: dict, key: str) -> dict[str, np.ndarray]:
    """The values of each fixed coordinate: ``points`` evenly spaced over ``range`` (one point: its middle)."""
    grid = {}
    for name, spec in fixed.items():
        (low, high), points = spec["range"], spec["points"]
        if not (np.isfinite(low) and np.isfinite(high) and low <= high):
            raise ConfigError(f"config key '{key}.fixed.{name}.range': expected [low, high] with low <= high, "
                              f"got {spec['range']}")
        grid[name] = np.linspace(low, high, points) if points > 1 else np.array([(low + high) / 2])
    return grid


def _dataset(samples: list[SliceSample], names: list[str], phase: tuple[str, ...], axes: tuple[str, str],
             energy: float, system) -> xr.Dataset:
    ok = [k for k, s in enumerate(samples) if s.status == "ok"]
    points = [samples[k] for k in ok]
    index_of_point = np.full(len(samples), -1, dtype=np.int64)
    index_of_point[ok] = np.arange(len(ok))
    states = np.array([s.state for s in points]).reshape(len(points), len(phase))
    energies = np.array([system.energy(state) for state in states])

    def per_point(attribute, dtype=np.float64, width=None):
        values = np.array([getattr(s, attribute) for s in points], dtype=dtype)
        return values.reshape(len(points), width) if width else values

    flags = {"flag_values": np.array(list(STATUS.values()), dtype=np.int8), "flag_meanings": " ".join(STATUS)}
    data = xr.Dataset(
        {
            "fixed_values": (("slice", "fixed"), np.array([[s.fixed[n] for n in names] for s in samples]),
                             {"long_name": "values of the slice's fixed coordinates"}),
            "sign": ("slice", np.array([s.sign for s in samples], dtype=np.int8),
                     {"long_name": "sign of the solved momentum on the slice"}),
            "status": ("slice", np.array([STATUS[s.status] for s in samples], dtype=np.int8),
                       {"long_name": "ok, or why the slice gave no point", **flags}),
            "reason": ("slice", np.array([s.reason for s in samples], dtype=str),
                       {"long_name": "what made a slice degenerate (empty when ok)"}),
            "point_of_slice": ("slice", index_of_point, {"long_name": "index of the slice's point, -1 if none"}),
            "slice_of_point": ("point", np.array(ok, dtype=np.int64), {"long_name": "the point's slice"}),
            "state": (("point", "phase"), states,
                      {"long_name": "phase-space state of the NHIM point (solved momentum from the energy)"}),
            "section_point": (("point", "axis"), per_point("point", width=2),
                              {"long_name": "the point in the slice's axes, refined by bisection on fates"}),
            "uncertainty": ("point", per_point("uncertainty"),
                            {"long_name": "bound on the error of section_point (Euclidean, section units)"}),
            "energy_residual": ("point", energies - energy, {"long_name": "H(state) - E"}),
            "manifold_angle": ("point", per_point("angle"),
                               {"long_name": "angle between the stable and unstable curves", "units": "rad"}),
            "detected_point": (("point", "axis"), per_point("detected_point", width=2),
                               {"long_name": "grid point of the detection window chosen by ldpipe.core.nhim.nhim_score"}),
            "detected_score": ("point", per_point("detected_score")),
            "detected_ld_forward": ("point", per_point("detected_ld_forward")),
            "detected_ld_backward": ("point", per_point("detected_ld_backward")),
            "window_half_width": (("point", "axis"), per_point("window_half_width", width=2),
                                  {"long_name": "half-widths of the detection window that gave the point"}),
            "widenings": ("point", per_point("widenings", np.int64)),
            "whole_window": ("point", per_point("whole_window", bool),
                             {"long_name": "detected on the base map's whole window (no neighbour, or continuation failed)"}),
            "predicted": ("point", per_point("predicted", bool),
                          {"long_name": "a prediction from refined neighbours was available"}),
            "prediction_error": ("point", per_point("prediction_error"),
                                 {"long_name": "distance of the refined point from the prediction (0 if none)"}),
            "residence_forward": ("point", per_point("residence_forward"),
                                  {"long_name": "time in the saddle region forward (tau = refinement max_time)"}),
            "residence_backward": ("point", per_point("residence_backward")),
            "neighbour_residence_max": ("point", per_point("neighbour_residence_max"),
                                        {"long_name": "largest min(forward, backward) residence of the 8 points "
                                                      "one window cell away"}),
        },
        coords={"slice": np.arange(len(samples)), "point": np.arange(len(points)), "fixed": names,
                "phase": list(phase), "axis": list(axes)},
    )
    return data


def run_nhim_sampling(
    *,
    study: str,
    base_map: dict,
    fixed: dict,
    signs: list[int],
    sampling: dict,
    refinement: dict,
    equilibria: str | Path,
    output: str | Path,
    threads: int | None = None,
) -> Path:
    """Sample the NHIM over a study's slice family and write the study file.

    Parameters
    ----------
    base_map : dict
        The base map's parameters (``parameters_from_config(config, "ld", name)``).
    fixed : dict
        ``{coordinate: {range: [low, high], points: n}}`` for every fixed coordinate of the base section.
    signs : list of {+1, -1}
        Signs of the solved momentum.
    sampling, refinement : dict
        :class:`ldpipe.core.nhim.sampling.SamplingSettings` and :class:`ldpipe.core.nhim.RefinementSettings` keywords.
    equilibria : path
        The system's equilibria file (the saddle the base map's ``saddle_near`` selects).
    """
    check_writable(output)  # before any work: never lose a run to a bad path
    import numba

    if threads:
        numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
    key = f"nhim_sampling.{study}"
    system, section, ld_settings, info = assembly.resolve_map(base_map, open_stage_file(equilibria, stage=EQUILIBRIA))
    if set(fixed) != set(section.fixed):
        raise ConfigError(f"config key '{key}.fixed': expected exactly the fixed coordinates {sorted(section.fixed)} "
                          f"of map {base_map['map_name']}'s section, got {sorted(fixed)}")
    if section.solve not in system.phase_coordinates[system.n_dof:]:
        raise ConfigError(f"config key '{key}.base_map': map {base_map['map_name']}'s section solves a position "
                          f"({section.solve}); NHIM sampling needs a solved momentum")
    if not ld_settings.variable_time:
        raise ConfigError(f"config key '{key}.base_map': map {base_map['map_name']} is fixed time; NHIM sampling "
                          f"needs a variable-time map (a saddle region)")
    try:
        settings = SamplingSettings(**{**sampling, "window_half_width": tuple(sampling["window_half_width"])})
        refine = RefinementSettings(**refinement)
    except ValueError as error:
        raise ConfigError(f"config key '{key}': {error}") from None
    grid = fixed_grid(fixed, key)
    saddle = np.asarray(info["saddle"], dtype=np.float64)
    base = make_slice_problem(base_map["map_name"], system, section, info["energy"], info["critical_energy"], saddle,
                              ld_settings)
    count = int(np.prod([len(v) for v in grid.values()])) * len(signs)
    log.info("study %s: %d slices (%s, signs %s) of %s at E = %.12g (dE = %.6g)", study, count,
             ", ".join(f"{n}: {len(v)} in [{v[0]:.6g}, {v[-1]:.6g}]" for n, v in grid.items()), signs,
             base_map["map_name"], info["energy"], info["excess_energy"])

    def progress(sample: SliceSample) -> None:
        text = ", ".join(f"{n} = {v:.6g}" for n, v in sample.fixed.items())
        if sample.status == "ok":
            log.info("[%s, %+d] point %s +- %.2g (window %d)", text, sample.sign, sample.point,
                     sample.uncertainty, sample.widenings)
        else:
            log.warning("[%s, %+d] degenerate slice, %s: %s", text, sample.sign, sample.status, sample.reason)

    cost = Cost()
    started = time.perf_counter()
    samples = sample_family(base, grid, tuple(signs), settings, refine, progress=progress, cost=cost)
    cost.wall_time = time.perf_counter() - started
    dataset = _dataset(samples, list(grid), system.phase_coordinates, section.axes, info["energy"], system)
    counts = {status: sum(s.status == status for s in samples) for status in STATUS}
    if counts["ok"] == 0:
        log.warning("study %s: no slice gave a point (%s); the file records only the degenerate slices", study, counts)
    dataset.attrs.update({
        "study": study, "base_map": base_map["map_name"], "system": system.name, "energy": info["energy"],
        "excess_energy": info["excess_energy"], "critical_energy": info["critical_energy"], "saddle_position": saddle,
        "solved": section.solve, **{f"count_{k}": v for k, v in counts.items()},
        "trajectories": cost.trajectories, "time_units": cost.time_units, "steps": cost.steps,
        "wall_time": cost.wall_time,
        **{f"sampling_{k}": (np.asarray(v, dtype=np.float64) if isinstance(v, (list, tuple)) else v)
           for k, v in sampling.items()},
        **{f"refinement_{k}": v for k, v in refinement.items()},
    })
    recorded = {"study": study, "base_map": base_map, "fixed": fixed, "signs": signs, "sampling": sampling,
                "refinement": refinement}
    path = write_stage_file(dataset, output, stage=NHIM_SAMPLING, title=f"NHIM sampled over the slices of study {study}",
                            parameters=recorded)
    log.info("wrote %s: %s; %d trajectories, %.1f s (%.3g points per second)", path, counts, cost.trajectories,
             cost.wall_time, counts["ok"] / max(cost.wall_time, 1e-9))
    return path
