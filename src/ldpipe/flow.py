"""Many trajectories at once: adaptive DOP853 in numba, with samples, section crossings and escapes.

Each trajectory is integrated by the Dormand-Prince 8(5,3) pair (scipy's
coefficients and error norm, per-trajectory step control), in parallel over
trajectories. Along the way it

* records the state at requested times (steps are shortened to land on them),
* records crossings of a surface q_i = c (or p_i = c) in a chosen direction,
  located by Newton iteration on the length of a single DOP853 step from the
  last accepted state (so a crossing is as accurate as the integration), and
* stops, flagged *escaped*, when a coordinate's magnitude exceeds the escape
  radius or the state stops being finite.

The integrator is generated per system from its kernel source and cached on
disk (:mod:`ldpipe.jitcache`), so later processes reuse the machine code.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from . import tableaux
from .engine.settings import DEFAULT_ESCAPE_RADIUS
from .jitcache import load_generated_module
from .systems import System

COMPLETED, ESCAPED, CROSSINGS_FULL, STEP_UNDERFLOW = 0, 1, 2, 3
STATUS_MEANINGS = "completed escaped crossings_full step_underflow"


def _coefficients() -> str:
    c = tableaux
    stages = c.DOP853_STAGES
    arrays = {"A": c.A[:stages, :stages], "B": c.B, "C": c.C[:stages], "E3": c.E3, "E5": c.E5}
    return "".join(f"{name} = _np.array({np.asarray(value).tolist()!r})\n" for name, value in arrays.items())


_TEMPLATE = r'''

import math as _math
from numba import njit as _njit, prange as _prange

gradient = _njit(cache=True)(gradient)
N = N_DOF
M = 2 * N_DOF


@_njit(cache=True)
def rhs(y, out, g):
    gradient(y[:N], g)
    for i in range(N):
        out[i] = y[N + i]
        out[N + i] = -g[i]


@_njit(cache=True)
def step(y, f0, h, K, ytmp, ynew, g):
    """One DOP853 step of size h from (y, f0); ynew and K[12] = f(ynew) written; returns nothing."""
    for i in range(M):
        K[0, i] = f0[i]
    for s in range(1, 12):
        for i in range(M):
            acc = 0.0
            for j in range(s):
                acc += A[s, j] * K[j, i]
            ytmp[i] = y[i] + h * acc
        rhs(ytmp, K[s], g)
    for i in range(M):
        acc = 0.0
        for j in range(12):
            acc += B[j] * K[j, i]
        ynew[i] = y[i] + h * acc
    rhs(ynew, K[12], g)


@_njit(cache=True)
def error_norm(y, ynew, h, K, rtol, atol):
    e5 = 0.0
    e3 = 0.0
    for i in range(M):
        scale = atol + max(abs(y[i]), abs(ynew[i])) * rtol
        a5 = 0.0
        a3 = 0.0
        for j in range(13):
            a5 += E5[j] * K[j, i]
            a3 += E3[j] * K[j, i]
        e5 += (a5 / scale) ** 2
        e3 += (a3 / scale) ** 2
    if e5 == 0.0 and e3 == 0.0:
        return 0.0
    return abs(h) * e5 / _math.sqrt((e5 + 0.01 * e3) * M)


@_njit(cache=True)
def integrate_one(y0, t_end, rtol, atol, sample_times, samples, sec_index, sec_value, sec_direction,
                  cross_states, cross_times, escape_radius, max_steps):
    """Integrate one trajectory; returns (status, crossings, samples written, final time, steps)."""
    direction = 1.0 if t_end >= 0 else -1.0
    y = y0.copy()
    f = _np.empty(M)
    g = _np.empty(N)
    K = _np.empty((13, M))
    K2 = _np.empty((13, M))
    ytmp = _np.empty(M)
    ynew = _np.empty(M)
    ycross = _np.empty(M)
    rhs(y, f, g)
    n_samples = sample_times.shape[0]
    max_cross = cross_times.shape[0]
    js = 0
    while js < n_samples and sample_times[js] == 0.0:
        samples[js] = y
        js += 1
    t = 0.0
    h_free = direction * min(0.01, abs(t_end)) if t_end != 0 else 0.0
    g_prev = y[sec_index] - sec_value
    crossing_sign = sec_direction * direction  # the sign change seen in integration order
    n_cross = 0
    status = 0
    rejected = False
    steps = 0
    while direction * (t_end - t) > 0.0:
        if steps >= max_steps:
            status = 3
            break
        target = sample_times[js] if js < n_samples else t_end
        h = h_free
        clipped = False
        if direction * (t + h - target) >= 0.0:
            h = target - t
            clipped = True
        if abs(h) < 1e-14 * (1.0 + abs(t)) and not clipped:
            status = 3
            break
        step(y, f, h, K, ytmp, ynew, g)
        steps += 1
        err = error_norm(y, ynew, h, K, rtol, atol)
        if not _math.isfinite(err):
            err = 1e300
        if err < 1.0:
            factor = 10.0 if err == 0.0 else min(10.0, 0.9 * err ** (-0.125))
            if rejected:
                factor = min(1.0, factor)
            rejected = False
            g_new = ynew[sec_index] - sec_value
            hit = (crossing_sign > 0 and g_prev < 0.0 and g_new >= 0.0) or (
                crossing_sign < 0 and g_prev > 0.0 and g_new <= 0.0)
            if hit and max_cross > 0:
                # Newton on the step length tau in (0, h): component(step(y, tau)) = value.
                lo = 0.0
                hi = h
                tau = h * g_prev / (g_prev - g_new)
                for _ in range(30):
                    step(y, f, tau, K2, ytmp, ycross, g)
                    gt = ycross[sec_index] - sec_value
                    if abs(gt) <= 1e-15 * (1.0 + abs(sec_value)):
                        break
                    if (gt < 0.0) == (g_prev < 0.0):
                        lo = tau
                    else:
                        hi = tau
                    slope = K2[12, sec_index]
                    new_tau = tau - gt / slope if slope != 0.0 else 0.5 * (lo + hi)
                    if not (min(lo, hi) < new_tau < max(lo, hi)):
                        new_tau = 0.5 * (lo + hi)
                    if abs(new_tau - tau) <= 1e-15 * (1.0 + abs(t)):
                        tau = new_tau
                        step(y, f, tau, K2, ytmp, ycross, g)
                        break
                    tau = new_tau
                cross_states[n_cross] = ycross
                cross_times[n_cross] = t + tau
                n_cross += 1
            t = target if clipped else t + h
            for i in range(M):
                y[i] = ynew[i]
                f[i] = K[12, i]
            g_prev = g_new
            if clipped and js < n_samples:
                samples[js] = y
                js += 1
            if not clipped:
                h_free = h * factor
            elif factor < 1.0:
                h_free = h_free * factor
            escaped = False
            for i in range(M):
                if not _math.isfinite(y[i]):
                    escaped = True
            for i in range(N):
                if abs(y[i]) > escape_radius:
                    escaped = True
            if escaped:
                status = 1
                break
            if hit and max_cross > 0 and n_cross >= max_cross:
                status = 2
                break
        else:
            rejected = True
            h_free = h * max(0.2, 0.9 * err ** (-0.125))
    for k in range(js, n_samples):
        samples[k] = y
    return status, n_cross, js, t, steps


@_njit(cache=True, parallel=True)
def integrate_many(states, t_end, rtol, atol, sample_times, samples, sec_index, sec_value, sec_direction,
                   cross_states, cross_times, escape_radius, max_steps, status, n_cross, n_samples, t_final, steps):
    for k in _prange(states.shape[0]):
        s, c, js, t, nst = integrate_one(
            states[k], t_end, rtol, atol, sample_times, samples[k], sec_index, sec_value, sec_direction,
            cross_states[k], cross_times[k], escape_radius, max_steps)
        status[k] = s
        n_cross[k] = c
        n_samples[k] = js
        t_final[k] = t
        steps[k] = nst
'''


def _integrator(system: System):
    source = (
        system.kernel_source
        + "\n\nimport numpy as _np\n"
        + f"N_DOF = {system.n_dof}\n"
        + _coefficients()
        + _TEMPLATE
    )
    return load_generated_module(source, prefix=f"flow_{system.name}")


@dataclass(frozen=True)
class FlowSettings:
    """DOP853 tolerances, escape radius (on every coordinate) and a cap on steps per trajectory."""

    rtol: float = 1e-10
    atol: float = 1e-10
    escape_radius: float = DEFAULT_ESCAPE_RADIUS
    max_steps: int = 10_000_000


@dataclass
class Trajectories:
    """What :func:`integrate` returns, for ``k`` trajectories.

    ``samples`` (k, s, 2n) at ``sample_times`` (padded with the last state after an
    early end; ``sample_count`` says how many are real), ``crossings`` (k, c, 2n) at
    ``crossing_times`` (k, c), ``crossing_count`` (k), ``status`` (k; see
    ``STATUS_MEANINGS``), ``final_time`` (k), ``steps`` (k).
    """

    sample_times: np.ndarray
    samples: np.ndarray
    sample_count: np.ndarray
    crossings: np.ndarray
    crossing_times: np.ndarray
    crossing_count: np.ndarray
    status: np.ndarray
    final_time: np.ndarray
    steps: np.ndarray


def integrate(
    system: System,
    states: np.ndarray,
    duration: float,
    settings: FlowSettings,
    *,
    sample_times: np.ndarray | None = None,
    section: tuple[str, float, int] | None = None,
    max_crossings: int = 0,
    threads: int | None = None,
) -> Trajectories:
    """Integrate every row of ``states`` for ``duration`` (negative: backward in time).

    ``sample_times`` lie between 0 and ``duration`` (same sign), ordered from 0.
    ``section`` is (phase coordinate, value, direction): crossings where the
    coordinate passes ``value`` increasing (+1) or decreasing (-1) *in forward
    time*, whichever way the integration runs; at most ``max_crossings`` are kept
    and the trajectory stops at the last (status ``crossings_full``).
    """
    module = _integrator(system)
    states = np.ascontiguousarray(states, dtype=np.float64)
    count, m = states.shape
    if m != 2 * system.n_dof:
        raise ValueError(f"states have {m} columns; {system.name} has {2 * system.n_dof} phase coordinates")
    sample_times = np.zeros(0) if sample_times is None else np.ascontiguousarray(sample_times, dtype=np.float64)
    if len(sample_times) and (np.any(np.diff(np.abs(sample_times)) < 0) or np.any(sample_times * duration < 0)
                              or abs(sample_times[-1]) > abs(duration)):
        raise ValueError("sample_times must run from 0 towards duration, within it")
    if section is None:
        index, value, direction = 0, 0.0, 1
        max_crossings = 0
    else:
        name, value, direction = section
        index = system.phase_coordinates.index(name)
    samples = np.zeros((count, len(sample_times), m))
    crossings = np.zeros((count, max_crossings, m))
    crossing_times = np.zeros((count, max_crossings))
    status = np.zeros(count, dtype=np.int64)
    n_cross = np.zeros(count, dtype=np.int64)
    n_samples = np.zeros(count, dtype=np.int64)
    final_time = np.zeros(count)
    steps = np.zeros(count, dtype=np.int64)
    previous = numba.get_num_threads()
    if threads:
        numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
    try:
        module.integrate_many(
            states, float(duration), settings.rtol, settings.atol, sample_times, samples, index, float(value),
            float(direction), crossings, crossing_times, settings.escape_radius, settings.max_steps,
            status, n_cross, n_samples, final_time, steps,
        )
    finally:
        numba.set_num_threads(previous)
    return Trajectories(sample_times, samples, n_samples, crossings, crossing_times, n_cross, status, final_time, steps)
