"""The orbit ladder: correction and integrator tolerances measured on one periodic orbit."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import xarray as xr

from ...logs import get_logger
from ..orbits.periodic import BrakeOrbit, CorrectionFailed, CorrectorSettings, LyapunovFamily, SaddleLinearization
from ...systems import System
from ..variational import propagate
from .timing import RepeatRule, repeat_timed

log = get_logger(__package__)  # the package's name, as before the split, in the log lines


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


def timed_orbit(system, saddle, mode, energy, step, continuation, rule: RepeatRule, max_iterations=20):
    """:func:`compute_orbit` timed as ``rule`` says: (orbit, members, smallest wall time, runs), or
    (None, 0, wall time of the failed attempt, 1) when the correction fails (it fails on every run)."""
    start = time.perf_counter()
    try:
        timed = repeat_timed(lambda: compute_orbit(system, saddle, mode, energy, step, continuation, max_iterations),
                             rule)
    except CorrectionFailed as error:
        log.info("%s: correction failed (%s)", step.label, error)
        return None, 0, time.perf_counter() - start, 1
    orbit, members = timed.result
    return orbit, members, timed.wall_time, timed.runs


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
    rule: RepeatRule = RepeatRule(),
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
        setting that did not converge are 0. Each setting is timed as ``rule`` says (:class:`~ldpipe.core.accuracy.timing.RepeatRule`).
    """
    ref, _, ref_wall, _ = timed_orbit(system, saddle, mode, energy, reference, continuation, RepeatRule(),
                                      max_iterations)
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
    runs = np.zeros(n, dtype=np.int64)
    for k, step in enumerate(steps):
        orbit, count, wall, runs[k] = timed_orbit(system, saddle, mode, energy, step, continuation, rule, max_iterations)
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
                "units": "s", "long_name": f"continuation, bracketing, correction and monodromy; {rule.description()} "
                                           "(of the failed attempt where it did not converge)"}),
            "orbit_timed_runs": ("orbit_setting", runs, RepeatRule.runs_attributes("orbit_wall_time")),
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
        "orbit_check_rtol": check_rtol, "orbit_target_energy": energy, "orbit_repeats": rule.repeats,
        "orbit_repeat_budget": rule.budget,
    })
    return data
