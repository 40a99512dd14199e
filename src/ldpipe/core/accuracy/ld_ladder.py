"""The LD ladder: integrator settings measured on a sample of a map's points against a reference."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import xarray as xr

from ...engine import IntegratorSettings, LDSettings, compute_ld
from ...engine.api import LDResult
from ...logs import get_logger
from ...systems import System
from .timing import RepeatRule, repeat_timed

log = get_logger(__package__)  # the package's name, as before the split, in the log lines

#: Quantiles of the per-trajectory errors stored for every setting (1.0 is the worst).
QUANTILES = (0.5, 0.9, 0.99, 1.0)
#: Why a trajectory stopped, as stored in ``stop_reason``.
STOP_REASONS = ("reached tau", "left the saddle region", "escaped", "failed")


def same_number(a: float, b: float) -> bool:
    """Equal to 1e-9 relative: a tolerance or step read back from a file or a config is the same setting."""
    return bool(np.isclose(a, b, rtol=1e-9, atol=0.0))


#: One integrator setting of the LD ladder: the engine's :class:`~ldpipe.engine.IntegratorSettings`
#: (built from a ladder entry with :meth:`~ldpipe.engine.IntegratorSettings.from_spec`; its
#: ``label``, ``numbers``, ``apply`` and ``matches`` serve the ladder).
IntegratorStep = IntegratorSettings


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
    runs: int = 1

    @property
    def directions(self) -> tuple[LDResult, LDResult]:
        return self.forward, self.backward


def warm_up(system: System, states: np.ndarray, settings: LDSettings) -> None:
    """Compile (or load from numba's cache) the engine for this scheme, outside any timing."""
    count = min(len(states), settings.lanes)
    if count:
        compute_ld(system, states[:count], 1, settings)


def timed_ld(system: System, states: np.ndarray, settings: LDSettings, rule: RepeatRule) -> TimedLD:
    """Forward and backward LD of ``states`` (shape (N, 2 n_dof)), timed as ``rule`` says.

    The engine is deterministic, so every run gives the same numbers; the smallest wall time
    is the one least disturbed by other work on the machine. CPU time is the process's (all
    threads).
    """
    timed = repeat_timed(lambda: (compute_ld(system, states, 1, settings), compute_ld(system, states, -1, settings)),
                         rule)
    return TimedLD(*timed.result, timed.wall_time, timed.cpu_time, timed.runs)


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
    rule: RepeatRule = RepeatRule(),
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
    rule : RepeatRule
        How often each setting is timed (the smallest time is kept): at most ``rule.repeats``
        runs, fewer once their wall times total ``rule.budget`` seconds.

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
    # One warm-up per engine module (the Taylor scheme has one per order), so that no timed run loads one.
    modules = {}
    for step in (reference, reference_check, *steps):
        settings = step.apply(base)
        modules.setdefault((settings.record.variant(settings.order), settings.lanes), settings)
    for settings in modules.values():
        warm_up(system, states, settings)
    log.info("reference %s on %d points", reference.label, len(states))
    ref = timed_ld(system, states, reference.apply(base), RepeatRule())
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
    check = timed_ld(system, states, reference_check.apply(base), RepeatRule())
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
              for name in ("stop_mismatches", "failed_trajectories", "nonfinite_ld", "nonfinite_energy_errors", "timed_runs")}
    ld_error = np.zeros((n_steps, 2, n))
    ld_error_q = np.zeros((n_steps, len(quantiles)))
    energy_error_q = np.zeros((n_steps, len(quantiles)))
    for k, step in enumerate(steps):
        timed = timed_ld(system, states, step.apply(base), rule)
        error = relative_error(_stack(timed, "ld"), ref_ld)
        ld_error_q[k], counts["nonfinite_ld"][k] = finite_quantiles(error[resolved], quantiles)
        ld_error[k] = np.where(np.isfinite(error), error, 0.0)
        energy_error_q[k], counts["nonfinite_energy_errors"][k] = finite_quantiles(
            _stack(timed, "energy_error"), quantiles)
        fields["wall_time"][k] = timed.wall_time
        fields["cpu_time"][k] = timed.cpu_time
        counts["timed_runs"][k] = timed.runs
        fields["trajectory_time"][k] = float(_stack(timed, "time").sum())
        fields["mean_steps"][k] = float(_stack(timed, "steps").mean())
        reasons = np.stack([stop_reason(r) for r in timed.directions])
        counts["stop_mismatches"][k] = int(np.sum(reasons != ref_reason))
        counts["failed_trajectories"][k] = int(np.sum(reasons == 3))
        log.info("%-22s wall %8.4f s (%d runs)  LD error median %.2e max %.2e  energy drift median %.2e  mismatches %d",
                 step.label, timed.wall_time, timed.runs, ld_error_q[k, 0], ld_error_q[k, -1], energy_error_q[k, 0],
                 counts["stop_mismatches"][k])

    throughput = np.divide(fields["trajectory_time"], fields["wall_time"], out=np.zeros(n_steps),
                           where=fields["wall_time"] > 0)
    per_core = np.divide(fields["trajectory_time"], fields["cpu_time"], out=np.zeros(n_steps),
                         where=fields["cpu_time"] > 0)
    numbers = [s.numbers() for s in steps]  # 0 where the scheme does not use the number
    data = xr.Dataset(
        {
            "wall_time": ("setting", fields["wall_time"], {
                "units": "s", "long_name": f"wall time of the sample, forward and backward, {rule.description()}"}),
            "cpu_time": ("setting", fields["cpu_time"], {
                "units": "s", "long_name": "CPU time of the process (all threads) in the run of smallest CPU time"}),
            "timed_runs": ("setting", counts["timed_runs"], RepeatRule.runs_attributes("wall_time and cpu_time")),
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
        "reference_wall_time": ref.wall_time, "reference_check_wall_time": check.wall_time, "repeats": rule.repeats,
        "repeat_budget": rule.budget,
        "reference_escapes": int((~resolved).sum()),
    })
    return data
