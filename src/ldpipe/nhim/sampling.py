"""Sampling the NHIM over a family of slices, by continuation from slice to slice.

In n DoF the NHIM of an index-1 saddle is a (2n - 3)-sphere in the (2n - 1)-dimensional energy
surface; a two-dimensional slice (2n - 3 phase coordinates fixed, one momentum solved from the
energy with a sign) meets it in isolated points. A *slice family* is a grid of the fixed values
(for the 3 DoF x-p_x slices: y, z, p_y) and a sign of the solved momentum; each slice of it
yields its NHIM point, where the forward and backward fates both switch
(:func:`ldpipe.nhim.refine_by_fates`).

A full LD map per slice would cost a map per point. Instead the family is walked from its middle
outwards (:func:`walk_order`), so each slice has a grid neighbour done before it, and a slice's point is
*predicted* from its refined neighbours (:func:`predict`: linear extrapolation along each grid
axis where two neighbours in a row are known, the neighbour itself where one is); both LDs are
computed on a small grid around the prediction (``window_points``^2 points,
``window_half_width`` wide), the NHIM cell detected on it (:func:`ldpipe.nhim.detect_nhim_cell`)
and refined by fates with the window's spacing as the stencil's. When that fails (no allowed
point, the detection on the window's edge, no fate switch) the window widens by ``widen``, up to
``max_widenings`` times, and last the base map's whole window on a ``seed_points``^2 grid is
used (as for the first slice, which has no neighbour).

A slice yields a point only if it is not degenerate; otherwise it is recorded with a reason
(:data:`STATUS`) and never written as a point:

* ``forbidden``: no point of the base window is energetically allowed on this slice;
* ``no_crossing``: no window, however wide, gave a detection the fates confirm (the slice misses
  the NHIM, which only reaches fixed values inside its projection);
* ``tangent``: the stable and unstable curves cross at less than ``min_angle`` (the slice is
  nearly tangent to the NHIM, and the crossing is ill-conditioned);
* ``momentum_vanishes``: the solved momentum at the point is below ``min_momentum`` times
  sqrt(2 dE) (the slice's own coordinates stop being a chart of the energy surface there: the
  flow is tangent to the slice's momentum level, and the sign of the solved momentum stops
  telling the two NHIM points apart).
"""

from __future__ import annotations

import itertools
import time
from dataclasses import dataclass, field, replace

import numpy as np

from .detection import detect_nhim_cell
from .evidence import residence_evidence
from .fates import Cost, RefinementFailed, RefinementSettings
from .refinement import ld_at_points, refine_by_fates
from .slices import SliceProblem, section_point_states

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
        Widenings before the base map's whole window is used.
    seed_points : int
        Points per axis of the whole-window detection grid (first slice, last resort).
    min_angle : float
        Smallest angle (radians) between the stable and unstable curves of a point; below it the
        slice is ``tangent``.
    min_momentum : float
        Smallest |solved momentum| / sqrt(2 dE) of a point; below it the slice is
        ``momentum_vanishes``.
    """

    window_points: int = 11
    window_half_width: tuple[float, float] = (0.02, 0.02)
    widen: float = 4.0
    max_widenings: int = 2
    seed_points: int = 41
    min_angle: float = 0.05
    min_momentum: float = 1e-3

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
    cost: Cost = field(default_factory=Cost)


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
    """(centre, half-width, points, widenings, whole) of each window to try, in order."""
    if prediction is not None:
        half = np.array(settings.window_half_width, dtype=np.float64)
        for k in range(settings.max_widenings + 1):
            yield prediction, half * settings.widen**k, settings.window_points, k, False
    centre, half = _base_window(base)
    yield centre, half, settings.seed_points, settings.max_widenings + (prediction is not None), True


def _is_tangent_failure(error: RefinementFailed) -> bool:
    # refinement.py reports near-parallel curves only in its messages (no code); these are its two.
    text = str(error)
    return "parallel" in text or "cross at" in text


def sample_slice(
    base: SliceProblem, fixed: dict[str, float], sign: int, prediction: np.ndarray | None,
    settings: SamplingSettings, refinement: RefinementSettings,
) -> SliceSample:
    """The NHIM point of one slice of the family: detected on zoomed windows around ``prediction``
    (widening on failure, the whole base window last), refined by fates; or its degeneracy."""
    started = time.perf_counter()
    sample = SliceSample(fixed=dict(fixed), sign=int(sign), status="no_crossing")
    cost = sample.cost
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
        values = ld_at_points(problem, grid, problem.ld_settings, cost)
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
            refined = refine_by_fates(problem, detected.point, refinement)
        except RefinementFailed as error:
            tangent = tangent or _is_tangent_failure(error)
            reasons.append(f"{label}: {error}")
            continue
        cost.add(refined.cost.trajectories, refined.cost.time_units, refined.cost.steps)
        k = i * points + j
        sample.detected_point = detected.point
        sample.detected_score = detected.score
        sample.detected_ld_forward = float(values["ld_forward"][k])
        sample.detected_ld_backward = float(values["ld_backward"][k])
        sample.window_half_width = np.asarray(half, dtype=np.float64)
        sample.widenings, sample.whole_window = int(widenings), bool(whole)
        sample.predicted = prediction is not None
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
            evidence = residence_evidence(problem, refined.point, refinement, cost)
            sample.status = "ok"
            sample.point, sample.state = refined.point, state
            sample.uncertainty = refined.uncertainty
            sample.residence_forward = evidence["residence_forward"]
            sample.residence_backward = evidence["residence_backward"]
            sample.neighbour_residence_max = evidence["neighbour_residence_max"]
        break
    else:
        if not any_allowed:
            sample.status, sample.reason = "forbidden", "no energetically allowed point in the base window"
        elif tangent:
            sample.status, sample.reason = "tangent", "; ".join(reasons)
        else:
            sample.status, sample.reason = "no_crossing", "; ".join(reasons)
    cost.wall_time = time.perf_counter() - started
    return sample


def sample_family(
    base: SliceProblem, fixed_grid: dict[str, np.ndarray], signs: tuple[int, ...], settings: SamplingSettings,
    refinement: RefinementSettings, progress=None,
) -> list[SliceSample]:
    """Every slice of a family: the grid of fixed values ``fixed_grid`` (name -> values, the base
    section's fixed coordinates) for each sign of the solved momentum, walked by continuation from
    the middle outwards (:func:`walk_order`).

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
    samples: dict[tuple, SliceSample] = {}
    for sign in signs:
        known: dict[tuple[int, ...], np.ndarray] = {}
        for index in walk_order(shape):
            fixed = {name: float(v[i]) for name, v, i in zip(names, values, index)}
            sample = sample_slice(base, fixed, sign, predict(index, known), settings, refinement)
            if sample.status == "ok":
                known[index] = sample.point
            samples[(sign, index)] = sample
            if progress is not None:
                progress(sample)
    return [samples[(sign, index)] for sign in signs for index in itertools.product(*(range(n) for n in shape))]
