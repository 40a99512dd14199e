"""Accuracy against cost: work–precision measurements of the LD engine and the orbit corrector.

Two ladders of numerical settings, each measured against a tight reference computed in the
same run:

* **LD ladder.** A sample of the allowed points of one LD map (a seeded random subset of the
  map's own grid points) is integrated forward and backward with every setting of the ladder
  (integrator scheme and tolerance or step). Per setting: the wall time and CPU time (the
  smallest of ``repeats`` runs, the usual guard against a busy machine), the trajectory time
  integrated per wall second, the relative LD error against the reference per trajectory and
  its quantiles, the energy drift |H(end) - H(0)| the engine reports, and how many
  trajectories stopped for another reason than the reference's (reached tau, left the saddle
  region, escaped, failed). The reference is itself checked against a second setting (by
  default the same scheme at half the step), and that agreement is stored: it bounds how small
  an error the ladder can resolve.
* **Orbit ladder.** The Lyapunov orbit at one energy is computed from scratch (continuation
  from the saddle, bracketing, correction, one period with the monodromy matrix: what the
  ``upo`` stage does per orbit) with every pair (correction tolerance, integrator rtol). Per
  pair: wall time, the closure error ||x(T) - x(0)|| re-measured with a separate tight
  integration, the energy error |E - E_target|, and the period and initial-state differences
  to a tight reference orbit.
* **NHIM ladders** (2 DoF, where the periodic orbit's crossing of a variable-time slice is the
  exact NHIM point). Grid resolution: the LD map at n x n points and the detected cell
  (:func:`ldpipe.nhim.detect_nhim_cell`, and the plain LD maximum for comparison); per n the
  wall time and the distance from the crossing. Refinement depth: from one detected cell, both
  refinements of :mod:`ldpipe.nhim` (bisection on fates, zoomed LD grids) at each tolerance;
  per tolerance the wall time, trajectories integrated and the distance from the crossing.

Timing is wall clock by design: it is the measurement. Everything else is deterministic (the
engine integrates every trajectory independently, with the same steps on every run); the
machine and its load average go into the file with the times.
"""

from __future__ import annotations

import dataclasses
import os
import platform
import time
from dataclasses import dataclass

import numba
import numpy as np
import scipy
import xarray as xr

from .engine import IntegratorSettings, LDSettings, compute_ld
from .engine.api import LDResult
from .engine.schemes import get_scheme
from .ld_grid import ld_grid_dataset
from .logs import get_logger
from .nhim import (
    RefinementFailed, RefinementSettings, SliceProblem, detect_global_argmax, detect_nhim_cell, refine_by_fates,
    refine_by_ld_zoom,
)
from .periodic_orbits import BrakeOrbit, CorrectionFailed, CorrectorSettings, LyapunovFamily, SaddleLinearization
from .systems import System
from .variational import propagate

log = get_logger(__name__)

#: Quantiles of the per-trajectory errors stored for every setting (1.0 is the worst).
QUANTILES = (0.5, 0.9, 0.99, 1.0)
#: Why a trajectory stopped, as stored in ``stop_reason``.
STOP_REASONS = ("reached tau", "left the saddle region", "escaped", "failed")


# -- the machine --------------------------------------------------------------------------------
def cpu_model() -> str:
    """The CPU model named in /proc/cpuinfo, or the platform's processor string."""
    try:
        with open("/proc/cpuinfo") as handle:
            for line in handle:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def machine_attributes() -> dict:
    """What a timing depends on, as netCDF attributes: CPU, cores, threads used, load, versions."""
    return {
        "machine_cpu_model": cpu_model(),
        "machine_cores": os.cpu_count() or 0,
        "machine_threads_used": numba.get_num_threads(),
        "machine_platform": platform.platform(),
        "python_version": platform.python_version(),
        "numba_version": numba.__version__,
        "numpy_version": np.__version__,
        "scipy_version": scipy.__version__,
    }


def load_average() -> np.ndarray:
    """The 1, 5 and 15 minute load averages (zeros where the platform has none)."""
    try:
        return np.array(os.getloadavg())
    except OSError:
        return np.zeros(3)


def same_number(a: float, b: float) -> bool:
    """Equal to 1e-9 relative: a tolerance or step read back from a file or a config is the same setting."""
    return bool(np.isclose(a, b, rtol=1e-9, atol=0.0))


# -- LD ladder -----------------------------------------------------------------------------------
#: One integrator setting of the LD ladder: the engine's :class:`~ldpipe.engine.IntegratorSettings`
#: (built from a ladder entry with :meth:`~ldpipe.engine.IntegratorSettings.from_spec`; its
#: ``label``, ``numbers``, ``apply`` and ``matches`` serve the ladder).
IntegratorStep = IntegratorSettings


def integrator_ladder(spec: dict) -> list[IntegratorSettings]:
    """The ladder ``{scheme: {rtol: [...]} or {dt: [...]}}`` as settings, scheme by scheme in order.

    The values listed are those of the scheme's step parameter (``rtol`` of an adaptive scheme,
    ``dt`` of a fixed-step one; the registry's ``parameters``). For an adaptive scheme ``atol``
    equals ``rtol`` (the LD maps' convention) unless the entry gives an ``atol`` list of the
    same length.
    """
    steps = []
    for scheme, values in spec.items():
        if get_scheme(scheme).adaptive:
            rtols = values["rtol"]
            atols = values.get("atol", rtols)
            if len(atols) != len(rtols):
                raise ValueError(f"{scheme}: {len(rtols)} rtol values but {len(atols)} atol values")
            steps += [IntegratorSettings.from_spec({"scheme": scheme, "rtol": float(r), "atol": float(a)})
                      for r, a in zip(rtols, atols)]
        else:
            steps += [IntegratorSettings.from_spec({"scheme": scheme, "dt": float(dt)}) for dt in values["dt"]]
    return steps


def sample_indices(n_allowed: int, points: int, seed: int, multiple_of: int = 1) -> np.ndarray:
    """Distinct indices into the allowed points, random (seeded), sorted.

    ``min(points, n_allowed)`` of them, rounded down to a multiple of ``multiple_of`` when that
    leaves at least one multiple. The stage passes the engine's block size: a map integrates
    tens of thousands of points per engine call, so its blocks are full, and a sample whose
    last block is part-empty would be timed at a cost per trajectory the map never pays (the
    engine is several times slower per trajectory in a block it cannot fill).
    """
    rng = np.random.default_rng(seed)
    count = min(points, n_allowed)
    if count >= multiple_of:
        count -= count % multiple_of
    return np.sort(rng.choice(n_allowed, size=count, replace=False))


@dataclass
class TimedLD:
    """Forward and backward LD of the same states, with the smallest wall and CPU time of the runs."""

    forward: LDResult
    backward: LDResult
    wall_time: float
    cpu_time: float

    @property
    def directions(self) -> tuple[LDResult, LDResult]:
        return self.forward, self.backward


def warm_up(system: System, states: np.ndarray, settings: LDSettings) -> None:
    """Compile (or load from numba's cache) the engine for this scheme, outside any timing."""
    count = min(len(states), settings.block)
    if count:
        compute_ld(system, states[:count], 1, settings)


def timed_ld(system: System, states: np.ndarray, settings: LDSettings, repeats: int) -> TimedLD:
    """Forward and backward LD of ``states`` (shape (N, 2 n_dof)), timed ``repeats`` times.

    The engine is deterministic, so every repeat gives the same numbers; the smallest wall time
    is the one least disturbed by other work on the machine. CPU time is the process's (all
    threads).
    """
    if repeats < 1:
        raise ValueError(f"repeats: expected an integer >= 1, got {repeats!r}")
    best_wall = best_cpu = np.inf
    forward = backward = None
    for _ in range(repeats):
        wall, cpu = time.perf_counter(), time.process_time()
        forward = compute_ld(system, states, 1, settings)
        backward = compute_ld(system, states, -1, settings)
        best_wall = min(best_wall, time.perf_counter() - wall)
        best_cpu = min(best_cpu, time.process_time() - cpu)
    return TimedLD(forward, backward, float(best_wall), float(best_cpu))


def relative_error(values: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """|values - reference| / |reference| elementwise; the absolute difference where the reference is 0.

    Shapes must agree; an LD is 0 only for a trajectory at rest (an equilibrium on the section).
    """
    values, reference = np.asarray(values, dtype=float), np.asarray(reference, dtype=float)
    scale = np.abs(reference)
    difference = np.abs(values - reference)
    return np.divide(difference, scale, out=difference.copy(), where=scale > 0)


def stop_reason(result: LDResult) -> np.ndarray:
    """Why each trajectory stopped, an index into :data:`STOP_REASONS` (failed wins over the rest)."""
    reason = np.zeros(len(result.ld), dtype=np.int8)
    reason[result.left_region] = 1
    reason[result.escaped] = 2
    reason[result.failed] = 3
    return reason


def finite_quantiles(values: np.ndarray, quantiles) -> tuple[np.ndarray, int]:
    """Quantiles of the finite values (zeros if there is none), and how many were not finite.

    The engine can report an overflowing energy error for a trajectory that escapes within one
    large fixed step; it is counted, not allowed to turn every quantile into inf.
    """
    values = np.asarray(values, dtype=float).ravel()
    finite = np.isfinite(values)
    if not finite.any():
        return np.zeros(len(quantiles)), int(values.size)
    return np.quantile(values[finite], quantiles), int((~finite).sum())


def _stack(timed: TimedLD, name: str) -> np.ndarray:
    """A field of both directions, shape (2, N)."""
    return np.stack([getattr(result, name) for result in timed.directions])


def ld_ladder_dataset(
    system: System,
    states: np.ndarray,
    base: LDSettings,
    steps: list[IntegratorSettings],
    reference: IntegratorSettings,
    reference_check: IntegratorSettings,
    *,
    repeats: int = 1,
) -> xr.Dataset:
    """Measure every step of the ladder on ``states`` against the reference.

    Parameters
    ----------
    system : System
    states : ndarray, shape (N, 2 n_dof)
        The sampled initial conditions.
    base : LDSettings
        The map's settings (LD, tau, time mode, region, escape radius); each step replaces the
        integrator only.
    steps : list of IntegratorSettings, length S
    reference, reference_check : IntegratorSettings
        The reference, and a second setting whose agreement with it is stored as a check.
    repeats : int
        Timed runs per setting (the smallest time is kept).

    Returns
    -------
    xarray.Dataset
        Dimensions ``setting`` (S), ``direction`` (forward, backward), ``point`` (N) and
        ``quantile``: per-setting times, throughput, error quantiles, energy drift, stop-reason
        mismatches and failures; per-point errors; the reference's LD, stop reasons and check.
    """
    states = np.ascontiguousarray(states, dtype=np.float64)
    if states.ndim != 2 or states.shape[1] != 2 * system.n_dof or len(states) == 0:
        raise ValueError(f"states: expected shape (N > 0, {2 * system.n_dof}), got {states.shape}")
    for scheme in dict.fromkeys([reference.scheme, reference_check.scheme, *(s.scheme for s in steps)]):
        warm_up(system, states, dataclasses.replace(base, scheme=scheme))
    log.info("reference %s on %d points", reference.label, len(states))
    ref = timed_ld(system, states, reference.apply(base), 1)
    ref_ld = _stack(ref, "ld")
    if not np.all(np.isfinite(ref_ld)) or not np.all(np.isfinite(_stack(ref, "energy_error"))):
        raise ValueError(f"the reference {reference.label} gave a non-finite LD or energy error; choose a smaller step "
                         "or a tighter tolerance for accuracy_cost.ld.reference")
    ref_reason = np.stack([stop_reason(r) for r in ref.directions])
    # A fixed-step reference stops an escaping trajectory at the start of the step that leaves
    # the escape radius, so its LD there is short by up to one step of a fast integrand (~1e-3
    # of the LD at dt 0.005, measured); the error statistics leave those trajectories out (their
    # per-point errors are kept, with the reference's stop reason beside them).
    resolved = ref_reason != STOP_REASONS.index("escaped")
    check = timed_ld(system, states, reference_check.apply(base), 1)
    check_error = relative_error(_stack(check, "ld"), ref_ld)
    if not np.all(np.isfinite(check_error)):
        raise ValueError(f"the reference check {reference_check.label} gave a non-finite LD; choose a smaller step or a "
                         "tighter tolerance for accuracy_cost.ld.reference_check")
    log.info("reference check %s: relative difference median %.3g, max %.3g", reference_check.label,
             np.median(check_error), check_error.max())

    n_steps, n = len(steps), len(states)
    quantiles = np.array(QUANTILES)
    fields = {name: np.zeros(n_steps) for name in ("wall_time", "cpu_time", "trajectory_time", "mean_steps")}
    counts = {name: np.zeros(n_steps, dtype=np.int64)
              for name in ("stop_mismatches", "failed_trajectories", "nonfinite_ld", "nonfinite_energy_errors")}
    ld_error = np.zeros((n_steps, 2, n))
    ld_error_q = np.zeros((n_steps, len(quantiles)))
    energy_error_q = np.zeros((n_steps, len(quantiles)))
    for k, step in enumerate(steps):
        timed = timed_ld(system, states, step.apply(base), repeats)
        error = relative_error(_stack(timed, "ld"), ref_ld)
        ld_error_q[k], counts["nonfinite_ld"][k] = finite_quantiles(error[resolved], quantiles)
        ld_error[k] = np.where(np.isfinite(error), error, 0.0)
        energy_error_q[k], counts["nonfinite_energy_errors"][k] = finite_quantiles(
            _stack(timed, "energy_error"), quantiles)
        fields["wall_time"][k] = timed.wall_time
        fields["cpu_time"][k] = timed.cpu_time
        fields["trajectory_time"][k] = float(_stack(timed, "time").sum())
        fields["mean_steps"][k] = float(_stack(timed, "steps").mean())
        reasons = np.stack([stop_reason(r) for r in timed.directions])
        counts["stop_mismatches"][k] = int(np.sum(reasons != ref_reason))
        counts["failed_trajectories"][k] = int(np.sum(reasons == 3))
        log.info("%-22s wall %8.4f s  LD error median %.2e max %.2e  energy drift median %.2e  mismatches %d",
                 step.label, timed.wall_time, ld_error_q[k, 0], ld_error_q[k, -1], energy_error_q[k, 0],
                 counts["stop_mismatches"][k])

    throughput = np.divide(fields["trajectory_time"], fields["wall_time"], out=np.zeros(n_steps),
                           where=fields["wall_time"] > 0)
    per_core = np.divide(fields["trajectory_time"], fields["cpu_time"], out=np.zeros(n_steps),
                         where=fields["cpu_time"] > 0)
    numbers = [s.numbers() for s in steps]  # 0 where the scheme does not use the number
    data = xr.Dataset(
        {
            "wall_time": ("setting", fields["wall_time"], {
                "units": "s", "long_name": f"wall time of the sample, forward and backward, smallest of {repeats} runs"}),
            "cpu_time": ("setting", fields["cpu_time"], {
                "units": "s", "long_name": "CPU time of the process (all threads) in the run of smallest CPU time"}),
            "trajectory_time": ("setting", fields["trajectory_time"], {
                "long_name": "time units integrated, summed over the trajectories and both directions"}),
            "throughput": ("setting", throughput, {"units": "1", "long_name": "trajectory time units per wall second"}),
            "throughput_per_core": ("setting", per_core, {"long_name": "trajectory time units per CPU second"}),
            "mean_steps": ("setting", fields["mean_steps"], {"long_name": "step attempts per trajectory and direction"}),
            "ld_error_quantile": (("setting", "quantile"), ld_error_q, {
                "long_name": "quantiles of |LD - LD_reference| / LD_reference over the points and both directions "
                             "where the reference did not escape"}),
            "energy_error_quantile": (("setting", "quantile"), energy_error_q, {
                "long_name": "quantiles of |H(end) - H(start)| over the points and both directions"}),
            "stop_mismatches": ("setting", counts["stop_mismatches"], {
                "long_name": "trajectories (both directions) that stopped for another reason than the reference's"}),
            "failed_trajectories": ("setting", counts["failed_trajectories"], {
                "long_name": "trajectories (both directions) stopped by a safety limit of the engine"}),
            "nonfinite_ld": ("setting", counts["nonfinite_ld"], {
                "long_name": "trajectories (both directions, where the reference did not escape) whose LD was not "
                             "finite (left out of the quantiles; their ld_relative_error is stored as 0)"}),
            "nonfinite_energy_errors": ("setting", counts["nonfinite_energy_errors"], {
                "long_name": "trajectories (both directions) whose reported energy error was not finite (an escape "
                             "within one large fixed step); left out of energy_error_quantile"}),
            "ld_relative_error": (("setting", "direction", "point"), ld_error, {
                "long_name": "|LD - LD_reference| / LD_reference"}),
            "reference_ld": (("direction", "point"), ref_ld, {"long_name": "LD of the reference setting"}),
            "reference_time": (("direction", "point"), _stack(ref, "time"), {
                "long_name": "|t| the reference integrated (tau, exit or escape time)"}),
            "reference_stop_reason": (("direction", "point"), ref_reason, {
                "flag_values": np.arange(len(STOP_REASONS), dtype=np.int8),
                "flag_meanings": " ".join(r.replace(" ", "_") for r in STOP_REASONS)}),
            "reference_energy_error": (("direction", "point"), _stack(ref, "energy_error"), {
                "long_name": "|H(end) - H(start)| of the reference"}),
            "reference_check_error": (("direction", "point"), check_error, {
                "long_name": "|LD_check - LD_reference| / LD_reference: the reference check setting against the reference"}),
            "reference_check_quantile": ("quantile", finite_quantiles(check_error[resolved], quantiles)[0], {
                "long_name": "quantiles of reference_check_error where the reference did not escape: errors below "
                             "these are not resolved"}),
        },
        coords={
            "setting": np.arange(n_steps), "direction": ["forward", "backward"], "point": np.arange(n),
            "quantile": quantiles,
            # The ladder describes the settings, so it is a coordinate: maps measured with one ladder share it.
            "scheme": ("setting", [s.scheme for s in steps]),
            "rtol": ("setting", [v["rtol"] for v in numbers], {"long_name": "relative tolerance (0: a fixed-step scheme)"}),
            "atol": ("setting", [v["atol"] for v in numbers], {"long_name": "absolute tolerance (0: a fixed-step scheme)"}),
            "dt": ("setting", [v["dt"] for v in numbers], {"long_name": "step (0: an adaptive scheme)"}),
            "label": ("setting", [s.label for s in steps]),
        },
    )
    data.attrs.update({
        "reference": reference.label, "reference_check": reference_check.label,
        "reference_wall_time": ref.wall_time, "reference_check_wall_time": check.wall_time, "repeats": repeats,
        "reference_escapes": int((~resolved).sum()),
    })
    return data


# -- orbit ladder --------------------------------------------------------------------------------
@dataclass(frozen=True)
class CorrectorStep:
    """One setting of the orbit ladder: correction tolerance, energy tolerance, integrator tolerances."""

    tolerance: float
    energy_tolerance: float
    rtol: float
    atol: float

    @property
    def label(self) -> str:
        return f"tolerance {self.tolerance:g}, rtol {self.rtol:g}"

    def settings(self, max_iterations: int) -> CorrectorSettings:
        return CorrectorSettings(tolerance=self.tolerance, max_iterations=max_iterations, rtol=self.rtol, atol=self.atol)


def corrector_ladder(tolerances: list[float], rtols: list[float], energy_tolerance_ratio: float) -> list[CorrectorStep]:
    """Every (tolerance, rtol) pair, rtol-major; energy tolerance = ratio x tolerance, atol = rtol."""
    return [CorrectorStep(float(t), float(t) * energy_tolerance_ratio, float(r), float(r))
            for r in rtols for t in tolerances]


def compute_orbit(
    system: System,
    saddle: SaddleLinearization,
    mode: int,
    energy: float,
    step: CorrectorStep,
    continuation: dict,
    max_iterations: int = 20,
) -> tuple[BrakeOrbit, int]:
    """The orbit at ``energy`` from scratch, as the upo stage computes it; and the family members used.

    Raises
    ------
    CorrectionFailed
        When the correction does not reach the tolerance (e.g. below the integrator's floor).
    """
    family = LyapunovFamily(system, saddle, mode, step.settings(max_iterations))
    family.continue_to(energy, initial_amplitude=continuation["initial_amplitude"],
                       max_step=continuation["max_step"], max_members=continuation["max_members"])
    orbit = family.at_energy(energy, energy_tolerance=step.energy_tolerance)
    if orbit.monodromy is None:
        orbit = family.finish(orbit)
    return orbit, len(family.members)


def timed_orbit(system, saddle, mode, energy, step, continuation, repeats, max_iterations=20):
    """:func:`compute_orbit` ``repeats`` times: (orbit, members, smallest wall time), or
    (None, 0, wall time of the failed attempt) when the correction fails."""
    best = np.inf
    orbit, members = None, 0
    for _ in range(repeats):
        start = time.perf_counter()
        try:
            orbit, members = compute_orbit(system, saddle, mode, energy, step, continuation, max_iterations)
        except CorrectionFailed as error:
            log.info("%s: correction failed (%s)", step.label, error)
            return None, 0, time.perf_counter() - start
        best = min(best, time.perf_counter() - start)
    return orbit, members, float(best)


def closure_error(system: System, orbit: BrakeOrbit, rtol: float) -> float:
    """||x(T) - x(0)|| over one period, integrated anew (no variational equations) at ``rtol`` = atol."""
    end = propagate(system, orbit.initial_state, orbit.period, rtol=rtol, atol=rtol, stm=False)
    return float(np.linalg.norm(end.state - orbit.initial_state))


def orbit_ladder_dataset(
    system: System,
    saddle: SaddleLinearization,
    mode: int,
    energy: float,
    steps: list[CorrectorStep],
    reference: CorrectorStep,
    *,
    continuation: dict,
    check_rtol: float,
    repeats: int = 1,
    max_iterations: int = 20,
) -> xr.Dataset:
    """Measure every corrector setting on the orbit at total ``energy`` against a tight reference orbit.

    Returns
    -------
    xarray.Dataset
        Dimension ``orbit_setting`` (len(steps)): the settings, ``converged``, ``wall_time``,
        ``closure_error`` (re-measured at ``check_rtol``), ``reported_closure_error``,
        ``energy_error``, ``period_error``, ``initial_state_error``, ``family_members``; the
        reference orbit's period, initial state and closure error as attributes. Fields of a
        setting that did not converge are 0.
    """
    ref, _, ref_wall = timed_orbit(system, saddle, mode, energy, reference, continuation, 1, max_iterations)
    if ref is None:
        raise CorrectionFailed(f"the reference orbit ({reference.label}) did not converge at energy {energy:.12g}")
    ref_closure = closure_error(system, ref, check_rtol)
    log.info("reference orbit (%s): period %.15g, closure %.3g, %.3f s", reference.label, ref.period, ref_closure,
             ref_wall)
    n = len(steps)
    out = {name: np.zeros(n) for name in (
        "wall_time", "closure_error", "reported_closure_error", "energy_error", "period_error", "initial_state_error")}
    converged = np.zeros(n, dtype=bool)
    members = np.zeros(n, dtype=np.int64)
    for k, step in enumerate(steps):
        orbit, count, wall = timed_orbit(system, saddle, mode, energy, step, continuation, repeats, max_iterations)
        out["wall_time"][k] = wall
        if orbit is None:
            continue
        converged[k] = True
        members[k] = count
        out["closure_error"][k] = closure_error(system, orbit, check_rtol)
        out["reported_closure_error"][k] = orbit.closure_error
        out["energy_error"][k] = abs(orbit.energy - energy)
        out["period_error"][k] = abs(orbit.period - ref.period)
        out["initial_state_error"][k] = float(np.linalg.norm(orbit.initial_state - ref.initial_state))
        log.info("%-32s wall %.4f s closure %.2e period error %.2e energy error %.2e", step.label, wall,
                 out["closure_error"][k], out["period_error"][k], out["energy_error"][k])
    zero_note = "0 where the correction did not converge"
    data = xr.Dataset(
        {
            "orbit_tolerance": ("orbit_setting", [s.tolerance for s in steps], {
                "long_name": "correction tolerance (closure error bound, half-period residual of family members)"}),
            "orbit_energy_tolerance": ("orbit_setting", [s.energy_tolerance for s in steps]),
            "orbit_rtol": ("orbit_setting", [s.rtol for s in steps], {"long_name": "integrator relative tolerance"}),
            "orbit_atol": ("orbit_setting", [s.atol for s in steps], {"long_name": "integrator absolute tolerance"}),
            "orbit_label": ("orbit_setting", [s.label for s in steps]),
            "orbit_converged": ("orbit_setting", converged),
            "orbit_wall_time": ("orbit_setting", out["wall_time"], {
                "units": "s", "long_name": f"continuation, bracketing, correction and monodromy; smallest of {repeats} runs "
                                           "(of the failed attempt where it did not converge)"}),
            "orbit_closure_error": ("orbit_setting", out["closure_error"], {
                "long_name": "||x(T) - x(0)|| re-measured by a separate integration at check_rtol", "comment": zero_note}),
            "orbit_reported_closure_error": ("orbit_setting", out["reported_closure_error"], {
                "long_name": "||x(T) - x(0)|| as the corrector measured it with its own integrator", "comment": zero_note}),
            "orbit_energy_error": ("orbit_setting", out["energy_error"], {
                "long_name": "|E(orbit) - E_target|", "comment": zero_note}),
            "orbit_period_error": ("orbit_setting", out["period_error"], {
                "long_name": "|T - T_reference|", "comment": zero_note}),
            "orbit_initial_state_error": ("orbit_setting", out["initial_state_error"], {
                "long_name": "||x(0) - x_reference(0)||", "comment": zero_note}),
            "orbit_family_members": ("orbit_setting", members, {"long_name": "family members continued to reach the energy"}),
        },
        coords={"orbit_setting": np.arange(n)},
    )
    data.attrs.update({
        "orbit_reference": reference.label, "orbit_reference_energy_tolerance": reference.energy_tolerance,
        "orbit_reference_period": ref.period, "orbit_reference_initial_state": ref.initial_state,
        "orbit_reference_closure_error": ref_closure, "orbit_reference_wall_time": ref_wall,
        "orbit_check_rtol": check_rtol, "orbit_target_energy": energy, "orbit_repeats": repeats,
    })
    return data


# -- NHIM ladders --------------------------------------------------------------------------------
#: The refinement methods of :mod:`ldpipe.nhim` the refinement ladder measures.
REFINEMENT_METHODS = ("fates", "ld_zoom")


def nhim_grid_dataset(
    problem: SliceProblem,
    crossing: np.ndarray,
    grid_points: list[int],
    *,
    repeats: int = 1,
) -> xr.Dataset:
    """Detection error against grid resolution: the LD map at n x n points, its NHIM cell, the distance.

    Parameters
    ----------
    problem : ldpipe.nhim.SliceProblem
        The slice (its section's ranges and LD settings are kept; the grid changes).
    crossing : ndarray, shape (2,)
        The periodic orbit's crossing of the slice (section coordinates), the exact NHIM point.
    grid_points : list of int, length G
        Points per axis.

    Returns
    -------
    xarray.Dataset
        Dimension ``nhim_grid`` (G): points per axis, cell diagonal, wall time (LD grid forward
        and backward plus detection, smallest of ``repeats``), the distance of the detected cell
        (``nhim.detect_nhim_cell``) and of the plain LD maximum (``nhim.detect_global_argmax``)
        from the crossing.
    """
    n = len(grid_points)
    wall = np.full(n, np.inf)
    error, argmax_error, diagonal = np.zeros(n), np.zeros(n), np.zeros(n)
    for k, points in enumerate(grid_points):
        section = dataclasses.replace(problem.section, shape=(int(points), int(points)))
        for _ in range(repeats):
            start = time.perf_counter()
            grid = ld_grid_dataset(problem.system, section, problem.energy, problem.ld_settings)
            axes = (grid[section.axes[0]].values, grid[section.axes[1]].values)
            fields = (grid.ld_forward.values, grid.ld_backward.values, grid.allowed.values)
            detected = detect_nhim_cell(*fields, axes)
            wall[k] = min(wall[k], time.perf_counter() - start)
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
                "units": "s", "long_name": f"LD grid (forward and backward) and detection; smallest of {repeats} run(s)"}),
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
    repeats: int = 1,
) -> xr.Dataset:
    """Location error against refinement depth, for both refinement methods of :mod:`ldpipe.nhim`.

    Each tolerance t refines ``guess`` with ``base`` at tolerance t and bisection precision
    ``precision_ratio`` x t, by fates (``refine_by_fates``) and by zoomed LD re-gridding
    (``refine_by_ld_zoom``).

    Returns
    -------
    xarray.Dataset
        Dimensions ``nhim_method`` (fates, ld_zoom) and ``nhim_refinement`` (len(tolerances)):
        wall time (smallest of ``repeats``), trajectories integrated, iterations, the method's own
        uncertainty, the distance from the crossing, and whether it converged (0 elsewhere).
    """
    methods = {"fates": refine_by_fates, "ld_zoom": refine_by_ld_zoom}
    shape = (len(REFINEMENT_METHODS), len(tolerances))
    out = {name: np.zeros(shape) for name in ("wall_time", "error", "uncertainty")}
    trajectories = np.zeros(shape, dtype=np.int64)
    iterations = np.zeros(shape, dtype=np.int64)
    converged = np.zeros(shape, dtype=bool)
    for m, method in enumerate(REFINEMENT_METHODS):
        for k, tolerance in enumerate(tolerances):
            settings = dataclasses.replace(base, tolerance=float(tolerance),
                                           bisection_precision=float(tolerance) * precision_ratio)
            best = np.inf
            try:
                for _ in range(repeats):
                    start = time.perf_counter()
                    refined = methods[method](problem, guess, settings)
                    best = min(best, time.perf_counter() - start)
            except RefinementFailed as error:
                log.info("NHIM refinement by %s at tolerance %g failed: %s", method, tolerance, error)
                continue
            converged[m, k] = True
            out["wall_time"][m, k] = best
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
                "units": "s", "long_name": f"refinement from the detected cell; smallest of {repeats} run(s)",
                "comment": zero_note}),
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
