"""Sampling the NHIM over a family of slices, by continuation from slice to slice.

In n DoF the NHIM of an index-1 saddle is a (2n - 3)-sphere in the (2n - 1)-dimensional energy
surface; a two-dimensional slice (2n - 3 phase coordinates fixed, one momentum solved from the
energy with a sign) meets it in isolated points. A *slice family* is a grid of the fixed values
(for the 3 DoF x-p_x slices: y, z, p_y) and a sign of the solved momentum; each slice of it
yields its NHIM point, where the forward and backward fates both switch
(:func:`ldpipe.core.nhim.refine_by_fates`).

A full LD map per slice would cost a map per point. Instead the family is walked from its middle
outwards in waves (:func:`walk_order`), so each slice has a grid neighbour done before it, the
slices of a wave searched together (:mod:`ldpipe.core.nhim.batched`), and a slice's point is
*predicted* from its refined neighbours (:func:`predict`: linear extrapolation along each grid
axis where two neighbours in a row are known, the neighbour itself where one is); both LDs are
computed on a small grid around the prediction (``window_points``^2 points,
``window_half_width`` wide), the NHIM cell detected on it (:func:`ldpipe.core.nhim.detect_nhim_cell`)
and refined by fates with the window's spacing as the stencil's
(:func:`ldpipe.core.nhim.refinement.refine_by_fates_task`, the algorithm of
:func:`ldpipe.core.nhim.refine_by_fates`). When that fails (no allowed point, the detection on the
window's edge, no fate switch) the window widens by ``widen``, up to ``max_widenings`` times. A
slice with no neighbour to predict from (the first, the seed) is searched on the base map's whole
window on a ``seed_points``^2 grid.

A slice yields a point only if it is not degenerate; otherwise it is recorded with a reason
(:data:`STATUS`) and never written as a point:

* ``forbidden``: no point of any window tried is energetically allowed on this slice;
* ``no_crossing``: no window gave a detection the fates confirm, or no neighbour gave a point
  (the slice misses the NHIM, which only reaches fixed values inside its projection). Near the
  edge of that projection the solved momentum at the NHIM point tends to 0 and the allowed region
  of the slice pinches around the point, along the stable and unstable curves; refinements there
  fail before a point can be classified, and the slice is recorded here with their messages;
* ``tangent``: the stable and unstable curves cross at less than ``min_angle`` (the slice is
  nearly tangent to the NHIM, and the crossing is ill-conditioned);
* ``momentum_vanishes``: the solved momentum at the point is below ``min_momentum`` times
  sqrt(2 dE) (the slice's own coordinates stop being a chart of the energy surface there: the
  flow is tangent to the slice's momentum level, and the sign of the solved momentum stops
  telling the two NHIM points apart).

:func:`nhim_sampling_dataset` is the NHIM sampling stage's product: a study's family, from its
base map's parameters and the system's equilibria, as the stage's file holds it.
"""

from __future__ import annotations

import itertools
import os
import time
from dataclasses import dataclass, field, replace

import numpy as np
import xarray as xr

from ...engine import use_threads
from ...errors import ConfigError
from ...io.contracts import EQUILIBRIA, NHIM_SAMPLING
from ...io.datafile import open_stage_file, stage_dataset
from ...logs import get_logger
from ..maps.assembly import resolve_map
from .batched import run_tasks
from .detection import detect_nhim_cell
from .fates import Cost, RefinementFailed, RefinementSettings
from .refinement import refine_by_fates_task
from .slices import SliceProblem, make_slice_problem, section_point_states

log = get_logger(__name__)

#: Status codes of a slice (the file's ``status`` variable; flag_values / flag_meanings).
STATUS = {"ok": 0, "forbidden": 1, "no_crossing": 2, "tangent": 3, "momentum_vanishes": 4}


@dataclass(frozen=True)
class SamplingSettings:
    """How each slice's point is looked for; every value is recorded in the output file.

    window_points : int
        Points per axis of the zoomed detection grid around a prediction (odd).
    window_half_width : tuple of float
        Half-widths of that grid along the two section axes, in section units.
    widen : float
        Factor by which the window widens after a failure.
    max_widenings : int
        Widenings before the slice is given up.
    seed_points : int
        Points per axis of the whole-window detection grid of a slice without a prediction.
    min_angle : float
        Smallest angle (radians) between the stable and unstable curves of a point; below it the
        slice is ``tangent``.
    min_momentum : float
        Smallest |solved momentum| / sqrt(2 dE) of a point; below it the slice is
        ``momentum_vanishes``.
    batch : int
        Most slices searched together (their trajectories integrated in the same engine calls).
    """

    window_points: int = 11
    window_half_width: tuple[float, float] = (0.02, 0.02)
    widen: float = 4.0
    max_widenings: int = 2
    seed_points: int = 41
    min_angle: float = 0.05
    min_momentum: float = 1e-3
    batch: int = 256

    def __post_init__(self):
        if self.window_points < 5 or self.window_points % 2 == 0:
            raise ValueError(f"window_points: expected an odd integer >= 5, got {self.window_points!r}")
        if self.seed_points < 5:
            raise ValueError(f"seed_points: expected an integer >= 5, got {self.seed_points!r}")
        if len(self.window_half_width) != 2 or not all(np.isfinite(w) and w > 0 for w in self.window_half_width):
            raise ValueError(f"window_half_width: expected two finite numbers > 0, got {self.window_half_width!r}")
        if not (np.isfinite(self.widen) and self.widen > 1):
            raise ValueError(f"widen: expected a number > 1, got {self.widen!r}")
        if self.max_widenings < 0:
            raise ValueError(f"max_widenings: expected an integer >= 0, got {self.max_widenings!r}")
        if self.batch < 1:
            raise ValueError(f"batch: expected an integer >= 1, got {self.batch!r}")
        if not (0 <= self.min_angle < np.pi / 2 and 0 <= self.min_momentum < 1):
            raise ValueError("min_angle: expected [0, pi/2); min_momentum: expected [0, 1)")


@dataclass
class SliceSample:
    """What one slice of the family gave: a point with its evidence, or a degeneracy with its reason.

    ``point``, ``state`` and the evidence are set only when ``status == "ok"``.
    """

    fixed: dict[str, float]
    sign: int
    status: str
    reason: str = ""
    point: np.ndarray | None = None
    state: np.ndarray | None = None
    uncertainty: float = 0.0
    angle: float = 0.0
    detected_point: np.ndarray | None = None
    detected_score: float = 0.0
    detected_ld_forward: float = 0.0
    detected_ld_backward: float = 0.0
    window_half_width: np.ndarray = field(default_factory=lambda: np.zeros(2))
    widenings: int = 0
    whole_window: bool = False
    predicted: bool = False
    prediction_error: float = 0.0
    residence_forward: float = 0.0
    residence_backward: float = 0.0
    neighbour_residence_max: float = 0.0


def slice_problem(base: SliceProblem, fixed: dict[str, float], sign: int, centre: np.ndarray,
                  half_width: np.ndarray, points: int) -> SliceProblem:
    """The base problem on another slice of its family (``fixed``, ``sign``), windowed: a grid of
    ``points``^2 around ``centre`` with ``half_width`` along each axis (its spacing is the
    refinement's stencil unit)."""
    ranges = tuple((float(c - w), float(c + w)) for c, w in zip(centre, half_width))
    section = replace(base.section, fixed={**base.section.fixed, **fixed}, sign=int(sign), ranges=ranges,
                      shape=(points, points))
    label = ", ".join(f"{k} = {v:.6g}" for k, v in fixed.items())
    return replace(base, section=section, name=f"{base.name} [{label}, sign {sign:+d}]")


def walk_order(shape: tuple[int, ...]) -> list[tuple[int, ...]]:
    """Every index of a grid of ``shape``, from the middle node outwards (by the number of grid steps
    from it, ties in C order). Each node after the first has a neighbour one step nearer the middle
    earlier in the order, so continuation has a neighbour wherever the NHIM reaches; the middle
    of a family centred on the saddle is the slice most likely to meet the NHIM, the seed."""
    middle = tuple((n - 1) // 2 for n in shape)
    nodes = list(itertools.product(*(range(n) for n in shape)))
    return sorted(nodes, key=lambda node: sum(abs(a - b) for a, b in zip(node, middle)))


def predict(index: tuple[int, ...], known: dict[tuple[int, ...], np.ndarray]) -> np.ndarray | None:
    """The predicted section point of slice ``index`` from refined neighbours (``known``, by index).

    Along each grid axis and each side: the linear extrapolation 2 p1 - p2 where the neighbours at
    distances 1 and 2 are both known, the neighbour p1 where only it is. The prediction is the mean
    of the extrapolations if there are any, else of the neighbours; None if no neighbour is known.
    """
    extrapolated, nearest = [], []
    for axis, step in itertools.product(range(len(index)), (-1, 1)):
        one = tuple(i + step * (a == axis) for a, i in enumerate(index))
        two = tuple(i + 2 * step * (a == axis) for a, i in enumerate(index))
        if one in known:
            if two in known:
                extrapolated.append(2 * known[one] - known[two])
            else:
                nearest.append(known[one])
    chosen = extrapolated or nearest
    return np.mean(chosen, axis=0) if chosen else None


def _base_window(base: SliceProblem) -> tuple[np.ndarray, np.ndarray]:
    (a0, a1), (b0, b1) = base.section.ranges
    return np.array([(a0 + a1) / 2, (b0 + b1) / 2]), np.array([(a1 - a0) / 2, (b1 - b0) / 2])


def _windows(base: SliceProblem, prediction: np.ndarray | None, settings: SamplingSettings):
    """(centre, half-width, points, widenings, whole) of each window to try, in order: around a
    prediction, widening; without one, the base map's whole window."""
    if prediction is None:
        centre, half = _base_window(base)
        yield centre, half, settings.seed_points, 0, True
        return
    half = np.array(settings.window_half_width, dtype=np.float64)
    for k in range(settings.max_widenings + 1):
        yield prediction, half * settings.widen**k, settings.window_points, k, False


def _is_tangent_failure(error: RefinementFailed) -> bool:
    # refinement.py reports near-parallel curves only in its messages (no code); these are its two.
    text = str(error)
    return "parallel" in text or "cross at" in text


def slice_task(
    base: SliceProblem, fixed: dict[str, float], sign: int, prediction: np.ndarray | None,
    settings: SamplingSettings, refinement: RefinementSettings,
):
    """The search of one slice of the family as a task (:mod:`ldpipe.core.nhim.batched`): detected on zoomed
    windows around ``prediction`` (widening on failure, the whole base window last), refined by
    fates; returns its :class:`SliceSample`, a point or a degeneracy."""
    sample = SliceSample(fixed=dict(fixed), sign=int(sign), status="no_crossing", predicted=prediction is not None)
    any_allowed = False
    tangent = False
    reasons = []
    for centre, half, points, widenings, whole in _windows(base, prediction, settings):
        problem = slice_problem(base, fixed, sign, centre, half, points)
        label = "whole window" if whole else f"window {widenings}"
        axes = tuple(np.linspace(c - w, c + w, points) for c, w in zip(centre, half))
        grid = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 2)
        _, allowed = section_point_states(problem, grid)
        if not allowed.any():
            reasons.append(f"{label}: no allowed point")
            continue
        any_allowed = True
        values = yield problem, "ld", grid, 0
        shape = (points, points)
        try:
            detected = detect_nhim_cell(values["ld_forward"].reshape(shape), values["ld_backward"].reshape(shape),
                                        allowed.reshape(shape), axes)
        except ValueError as error:
            reasons.append(f"{label}: {error}")
            continue
        i, j = detected.index
        if not whole and (i in (0, points - 1) or j in (0, points - 1)):
            reasons.append(f"{label}: the detected cell is on the window's edge")
            continue
        try:
            refined = yield from refine_by_fates_task(problem, detected.point, refinement)
        except RefinementFailed as error:
            tangent = tangent or _is_tangent_failure(error)
            reasons.append(f"{label}: {error}")
            continue
        k = i * points + j
        sample.detected_point = detected.point
        sample.detected_score = detected.score
        sample.detected_ld_forward = float(values["ld_forward"][k])
        sample.detected_ld_backward = float(values["ld_backward"][k])
        sample.window_half_width = np.asarray(half, dtype=np.float64)
        sample.widenings, sample.whole_window = int(widenings), bool(whole)
        sample.prediction_error = float(np.linalg.norm(refined.point - prediction)) if prediction is not None else 0.0
        sample.angle = refined.angle
        state = section_point_states(problem, refined.point[None, :])[0][0]
        momentum = abs(state[problem.system.phase_coordinates.index(problem.section.solve)])
        scale = np.sqrt(2.0 * max(problem.excess_energy, 0.0))
        if refined.angle < settings.min_angle:
            sample.status, sample.reason = "tangent", (
                f"stable and unstable curves cross at {refined.angle:.3g} rad < min_angle {settings.min_angle:g}")
        elif momentum < settings.min_momentum * scale:
            sample.status, sample.reason = "momentum_vanishes", (
                f"|{problem.section.solve}| = {momentum:.3g} < min_momentum x sqrt(2 dE) = "
                f"{settings.min_momentum * scale:.3g}")
        else:
            # Residence evidence as ldpipe.core.nhim.residence_evidence takes it: the point and the 8 points
            # one window cell away, DOP853 at the refinement's tolerances, tau = max_time.
            offsets = np.array([(a, b) for a in (-1, 0, 1) for b in (-1, 0, 1) if (a, b) != (0, 0)], dtype=float)
            around = np.vstack([refined.point, refined.point + offsets * problem.spacing])
            times = yield problem, "residence", around, 0
            both = np.minimum(times["exit_time_forward"], times["exit_time_backward"])
            sample.status = "ok"
            sample.point, sample.state = refined.point, state
            sample.uncertainty = refined.uncertainty
            sample.residence_forward = float(times["exit_time_forward"][0])
            sample.residence_backward = float(times["exit_time_backward"][0])
            sample.neighbour_residence_max = float(both[1:].max())
        break
    else:
        if not any_allowed:
            sample.status, sample.reason = "forbidden", "no energetically allowed point in the base window"
        elif tangent:
            sample.status, sample.reason = "tangent", "; ".join(reasons)
        else:
            sample.status, sample.reason = "no_crossing", "; ".join(reasons)
    return sample


def sample_slice(
    base: SliceProblem, fixed: dict[str, float], sign: int, prediction: np.ndarray | None,
    settings: SamplingSettings, refinement: RefinementSettings,
) -> SliceSample:
    """One slice alone (:func:`slice_task` run by itself)."""
    (sample,) = run_tasks([slice_task(base, fixed, sign, prediction, settings, refinement)], refinement)
    return sample


def sample_family(
    base: SliceProblem, fixed_grid: dict[str, np.ndarray], signs: tuple[int, ...], settings: SamplingSettings,
    refinement: RefinementSettings, progress=None, cost: Cost | None = None,
) -> list[SliceSample]:
    """Every slice of a family: the grid of fixed values ``fixed_grid`` (name -> values, the base
    section's fixed coordinates) for each sign of the solved momentum, by continuation.

    The slices run in waves: the nodes ``k`` grid steps from the middle (:func:`walk_order`), of
    every sign, together (:func:`ldpipe.core.nhim.batched.run_tasks`, at most ``settings.batch`` slices
    at a time), each predicted from the refined nodes of the earlier waves (:func:`predict`). Until
    a sign has a point, slices without a prediction are searched on the whole base window (the
    seeds); afterwards such a slice has only failed neighbours nearer the middle, lies beyond the
    NHIM's reach, and is recorded as ``no_crossing`` unsearched.
    ``progress`` is called with each sample as its wave ends; ``cost`` (optional) adds up the work.

    Returns the samples in the grid's C order (sign slowest, then the grid axes in the order of
    ``fixed_grid``), whatever the walking order.
    """
    missing = sorted(set(base.section.fixed) ^ set(fixed_grid))
    if missing:
        raise ValueError(f"the family's fixed coordinates {sorted(fixed_grid)} are not the base section's "
                         f"{sorted(base.section.fixed)} (differ in {missing})")
    names = list(fixed_grid)
    values = [np.atleast_1d(np.asarray(fixed_grid[name], dtype=np.float64)) for name in names]
    shape = tuple(len(v) for v in values)
    middle = tuple((n - 1) // 2 for n in shape)
    waves: dict[int, list[tuple[int, ...]]] = {}
    for index in walk_order(shape):
        waves.setdefault(sum(abs(a - b) for a, b in zip(index, middle)), []).append(index)
    samples: dict[tuple, SliceSample] = {}
    known: dict[int, dict[tuple[int, ...], np.ndarray]] = {sign: {} for sign in signs}
    for _, nodes in sorted(waves.items()):
        jobs = [(sign, index) for sign in signs for index in nodes]
        for start in range(0, len(jobs), settings.batch):
            chunk = jobs[start:start + settings.batch]
            tasks, searched = [], []
            for sign, index in chunk:
                fixed = {n: float(v[i]) for n, v, i in zip(names, values, index)}
                prediction = predict(index, known[sign])
                if prediction is None and known[sign]:
                    # The NHIM was found, but not next to this slice: it ends before it (its projection
                    # onto the fixed values is one connected region), so no search.
                    samples[(sign, index)] = SliceSample(fixed=fixed, sign=sign, status="no_crossing",
                                                         reason="no neighbour nearer the middle gave a point")
                    continue
                tasks.append(slice_task(base, fixed, sign, prediction, settings, refinement))
                searched.append((sign, index))
            for key, sample in zip(searched, run_tasks(tasks, refinement, cost)):
                samples[key] = sample
            if progress is not None:
                for key in chunk:
                    progress(samples[key])
        for sign, index in jobs:  # after the wave: a wave's slices predict only from earlier waves
            if samples[(sign, index)].status == "ok":
                known[sign][index] = samples[(sign, index)].point
    return [samples[(sign, index)] for sign in signs for index in itertools.product(*(range(n) for n in shape))]


def family_grid(fixed: dict, key: str) -> dict[str, np.ndarray]:
    """The values of each fixed coordinate: ``points`` evenly spaced over ``range`` (one point: its middle)."""
    grid = {}
    for name, spec in fixed.items():
        (low, high), points = spec["range"], spec["points"]
        if not (np.isfinite(low) and np.isfinite(high) and low <= high):
            raise ConfigError(f"config key '{key}.fixed.{name}.range': expected [low, high] with low <= high, "
                              f"got {spec['range']}")
        grid[name] = np.linspace(low, high, points) if points > 1 else np.array([(low + high) / 2])
    return grid


def nhim_sampling_dataset(parameters: dict, equilibria: str | os.PathLike | xr.Dataset, *,
                          threads: int | None = None) -> xr.Dataset:
    """Sample the NHIM over a study's slice family: the NHIM sampling stage's file (contract
    NHIM_SAMPLING), every slice with its status (and the reason for a degenerate one), and every
    point (non-degenerate slices only) as a full phase-space state with its uncertainty, energy
    residual, residence times and detection evidence.

    Parameters
    ----------
    parameters : dict
        The stage's (``parameters_from_config(config, "nhim_sampling", study)``): ``study``,
        ``base_map`` (the base map's parameters), ``fixed`` (``{coordinate: {range: [low, high],
        points: n}}`` for every fixed coordinate of the base section), ``signs`` (of the solved
        momentum), ``sampling`` and ``refinement`` (:class:`SamplingSettings` and
        :class:`ldpipe.core.nhim.RefinementSettings` keywords).
    equilibria : path or xarray.Dataset
        The system's equilibria (the saddle the base map's ``saddle_near`` selects).
    threads : int, optional
        Threads of the engine (default every core).
    """
    use_threads(threads)
    study, base_map, fixed, signs = parameters["study"], parameters["base_map"], parameters["fixed"], parameters["signs"]
    sampling, refinement = parameters["sampling"], parameters["refinement"]
    key = f"nhim_sampling.{study}"
    system, section, ld_settings, info = resolve_map(base_map, open_stage_file(equilibria, stage=EQUILIBRIA))
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
    grid = family_grid(fixed, key)
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
    dataset = _sampling_variables(samples, list(grid), system.phase_coordinates, section.axes, info["energy"], system)
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
    log.info("study %s: %s; %d trajectories, %.1f s (%.3g points per second)", study, counts, cost.trajectories,
             cost.wall_time, counts["ok"] / max(cost.wall_time, 1e-9))
    recorded = {"study": study, "base_map": base_map, "fixed": fixed, "signs": signs, "sampling": sampling,
                "refinement": refinement}
    return stage_dataset(dataset, stage=NHIM_SAMPLING, title=f"NHIM sampled over the slices of study {study}",
                         parameters=recorded)


def _sampling_variables(samples: list[SliceSample], names: list[str], phase: tuple[str, ...], axes: tuple[str, str],
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
