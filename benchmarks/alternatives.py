"""What a user would pick instead of ldpipe's engine, for the Barbanis 2 DoF LD.

Every method takes initial states, shape (N, 4) = (x, y, px, py), and returns a ``MethodResult``:
the LD values (N,) and the trajectory time units integrated (N * tau for fixed time).

a. ``scipy_per_trajectory``: scipy ``solve_ivp`` (DOP853) one trajectory at a time, the LD as a
   5th state component.
b. ``scipy_flattened``: the whole set flattened into one ``solve_ivp`` system of 5N components
   (RK45), as the ``ldds`` package does: one shared adaptive step for all trajectories.
c. ``heyoka_batch``: heyoka's SIMD batch Taylor integrator, the *arc-length* LD as a 5th state.
   ``heyoka_p_half_attempt`` shows what happens with the p = 1/2 integrand.

All of them run in this one process.  Timings are taken by the caller (compare.py); the
functions only report counters.  Independent of ldpipe's engine (the vector field is written out
here; its parameters come from ldpipe.testing.reference_ld, which imports only numpy and scipy).
"""

from __future__ import annotations

import time
from typing import NamedTuple

import numpy as np
from scipy.integrate import solve_ivp

from ldpipe.testing.reference_ld import DELTA, OMEGA_X, OMEGA_Y

WX2 = OMEGA_X**2
WY2 = OMEGA_Y**2


class MethodResult(NamedTuple):
    ld: np.ndarray  # (N,)
    time_units: float  # trajectory time integrated, summed over trajectories
    info: dict  # method-specific counters (nfev, steps, compile time, failures, ...)


def _field(x, y, px, py):
    return px, py, -(WX2 * x + DELTA * y * y), -(WY2 * y + 2.0 * DELTA * x * y)


# --------------------------------------------------------------------------------------------
# a. scipy solve_ivp, one trajectory at a time
# --------------------------------------------------------------------------------------------
def _rhs_single(p):
    if p == "arclength":
        def rhs(t, s):
            v = _field(s[0], s[1], s[2], s[3])
            return np.array([*v, np.sqrt(v[0] ** 2 + v[1] ** 2 + v[2] ** 2 + v[3] ** 2)])
    elif p == 0.5:
        def rhs(t, s):
            v = _field(s[0], s[1], s[2], s[3])
            return np.array([*v, np.sqrt(abs(v[0])) + np.sqrt(abs(v[1])) + np.sqrt(abs(v[2])) + np.sqrt(abs(v[3]))])
    else:
        def rhs(t, s):
            v = _field(s[0], s[1], s[2], s[3])
            return np.array([*v, sum(abs(c) ** p for c in v)])
    return rhs


def scipy_per_trajectory(states, tau=50.0, p=0.5, rtol=1e-8, atol=1e-10, method="DOP853") -> MethodResult:
    """solve_ivp per trajectory, LD as an extra state component."""
    states = np.atleast_2d(states)
    rhs = _rhs_single(p)
    ld = np.empty(len(states))
    nfev = 0
    failed = 0
    for k, s in enumerate(states):
        sol = solve_ivp(rhs, (0.0, tau), np.append(s, 0.0), method=method, rtol=rtol, atol=atol, t_eval=[tau])
        nfev += sol.nfev
        if sol.status != 0:
            failed += 1
            ld[k] = np.nan
        else:
            ld[k] = sol.y[4, -1]
    return MethodResult(ld, tau * len(states), {"nfev": nfev, "failed": failed, "rtol": rtol, "atol": atol})


# --------------------------------------------------------------------------------------------
# b. the whole grid as one vectorized solve_ivp system (what ldds does)
# --------------------------------------------------------------------------------------------
def scipy_flattened(states, tau=50.0, p=0.5, rtol=1e-6, atol=None, method="RK45") -> MethodResult:
    """One solve_ivp system of 5N components: (x, y, px, py, LD) blocks, one shared step.

    atol defaults to rtol (ldds passes only rtol and keeps scipy's atol = 1e-6, which would
    cap the accuracy of the tighter runs).
    """
    states = np.atleast_2d(states)
    n = len(states)
    atol = rtol if atol is None else atol
    y0 = np.concatenate([states.T.ravel(), np.zeros(n)])

    def rhs(t, y):
        x, yy, px, py = y[:n], y[n:2 * n], y[2 * n:3 * n], y[3 * n:4 * n]
        ax = -(WX2 * x + DELTA * yy * yy)
        ay = -(WY2 * yy + 2.0 * DELTA * x * yy)
        if p == "arclength":
            m = np.sqrt(px * px + py * py + ax * ax + ay * ay)
        elif p == 0.5:
            m = np.sqrt(np.abs(px)) + np.sqrt(np.abs(py)) + np.sqrt(np.abs(ax)) + np.sqrt(np.abs(ay))
        else:
            m = np.abs(px) ** p + np.abs(py) ** p + np.abs(ax) ** p + np.abs(ay) ** p
        return np.concatenate([px, py, ax, ay, m])

    sol = solve_ivp(rhs, (0.0, tau), y0, method=method, rtol=rtol, atol=atol, t_eval=[tau])
    if sol.status != 0:
        return MethodResult(np.full(n, np.nan), tau * n, {"nfev": sol.nfev, "failed": n, "message": sol.message})
    return MethodResult(sol.y[4 * n:, -1].copy(), tau * n,
                        {"nfev": sol.nfev, "steps_approx": sol.nfev // 6, "failed": 0, "rtol": rtol, "atol": atol})


# --------------------------------------------------------------------------------------------
# c. heyoka batch Taylor integrator
# --------------------------------------------------------------------------------------------
def _heyoka_system(integrand: str):
    import heyoka as hy

    x, y, px, py, L = hy.make_vars("x", "y", "px", "py", "L")
    ax = -(WX2 * x + DELTA * y * y)
    ay = -(WY2 * y + 2.0 * DELTA * x * y)
    if integrand == "arclength":
        m = hy.sqrt(px * px + py * py + ax * ax + ay * ay)
    elif integrand == "sqrt_abs":  # |v|^(1/2) written as sqrt(sqrt(v^2)) (heyoka has no abs())
        m = sum(hy.sqrt(hy.sqrt(v * v)) for v in (px, py, ax, ay))
    elif integrand == "pow_quarter":  # (v^2)^(1/4)
        m = sum((v * v) ** 0.25 for v in (px, py, ax, ay))
    else:
        raise ValueError(integrand)
    return [(x, px), (y, py), (px, ax), (py, ay), (L, m)]


def heyoka_build(tol=1e-10, integrand="arclength", batch_size=None):
    """Build (JIT-compile) a taylor_adaptive_batch; returns (ta, compile_seconds)."""
    import heyoka as hy

    batch_size = batch_size or hy.recommended_simd_size()
    t0 = time.perf_counter()
    ta = hy.taylor_adaptive_batch(_heyoka_system(integrand), np.zeros((5, batch_size)), tol=tol)
    return ta, time.perf_counter() - t0


def heyoka_batch(states, tau=50.0, tol=1e-10, ta=None, integrand="arclength") -> MethodResult:
    """heyoka batch Taylor integration, batch after batch in this thread; arc-length LD."""
    import heyoka as hy

    states = np.atleast_2d(states)
    n = len(states)
    compile_s = 0.0
    if ta is None:
        ta, compile_s = heyoka_build(tol, integrand)
    b = ta.batch_size
    padded = np.concatenate([states, np.repeat(states[-1:], (-n) % b, axis=0)])
    ld = np.empty(len(padded))
    steps = 0
    outcomes = {}
    for start in range(0, len(padded), b):
        ta.state[:4, :] = padded[start:start + b].T
        ta.state[4, :] = 0.0
        ta.set_time(0.0)
        ta.propagate_until(tau)
        for outcome, _min_h, _max_h, nsteps in ta.propagate_res:
            steps += nsteps
            outcomes[str(outcome)] = outcomes.get(str(outcome), 0) + 1
        ld[start:start + b] = ta.state[4, :]
    return MethodResult(ld[:n], tau * n, {"steps": steps, "batch_size": b, "compile_s": compile_s,
                                          "outcomes": outcomes, "order": ta.order,
                                          "heyoka_threads": hy.get_nthreads(), "tol": tol})


def heyoka_ensemble(states, tau=50.0, tol=1e-10, ta=None, max_workers=None) -> MethodResult:
    """Arc-length LD with heyoka's thread-parallel ensemble (ensemble_propagate_until_batch).

    One batch of ``batch_size`` trajectories per ensemble iteration; heyoka copies the
    integrator per iteration and runs them on a ThreadPoolExecutor of ``max_workers`` threads.
    """
    import heyoka as hy

    states = np.atleast_2d(states)
    n = len(states)
    compile_s = 0.0
    if ta is None:
        ta, compile_s = heyoka_build(tol, "arclength")
    b = ta.batch_size
    padded = np.concatenate([states, np.repeat(states[-1:], (-n) % b, axis=0)])
    n_iter = len(padded) // b

    def gen(ta_copy, i):
        ta_copy.state[:4, :] = padded[i * b:(i + 1) * b].T
        ta_copy.state[4, :] = 0.0
        ta_copy.set_time(0.0)
        return ta_copy

    results = hy.ensemble_propagate_until_batch(ta, tau, n_iter, gen, algorithm="thread", max_workers=max_workers)
    ld = np.concatenate([r[0].state[4, :] for r in results])
    return MethodResult(ld[:n], tau * n, {"batch_size": b, "compile_s": compile_s, "max_workers": max_workers,
                                          "tol": tol})


def heyoka_p_half_offset(states, tau=50.0, tol=1e-10, eps=1e-6, ta_plain=None, ta_half=None) -> MethodResult:
    """heyoka batch with the p = 1/2 integrand, started at t = eps instead of t = 0.

    Every point of U_xpx has y = 0, hence dp_y/dt = -(wy^2 y + 2 delta x y) = 0 exactly at t = 0,
    and heyoka's Taylor coefficients of sqrt(sqrt(v^2)) are NaN there (see
    ``heyoka_p_half_attempt``).  Workaround: move the state to t = eps with the arc-length
    integrator, add int_0^eps sum |v_i|^(1/2) dt from the linear model v_i(0) + v_i'(0) t (exact
    antiderivative (2/3) sgn(u)|u|^(3/2) / v_i'(0); error O(eps^2)), then continue with the p = 1/2
    system.  Away from t = 0 a crossing never falls exactly on a Taylor expansion point, and the
    error control shrinks the steps around each crossing instead of failing.
    """
    import heyoka as hy

    states = np.atleast_2d(states)
    n = len(states)
    compile_s = 0.0
    if ta_plain is None:
        ta_plain, c = heyoka_build(tol, "arclength")
        compile_s += c
    if ta_half is None:
        ta_half, c = heyoka_build(tol, "sqrt_abs")
        compile_s += c
    b = ta_half.batch_size
    padded = np.concatenate([states, np.repeat(states[-1:], (-n) % b, axis=0)])
    x, y, px, py = padded.T
    v0 = np.array(_field(x, y, px, py))
    ax, ay = v0[2], v0[3]
    v1 = np.array([ax, ay, -(WX2 * px + 2.0 * DELTA * y * py), -(WY2 * py + 2.0 * DELTA * (px * y + x * py))])
    u1 = v0 + v1 * eps
    g = lambda u: (2.0 / 3.0) * np.sign(u) * np.abs(u) ** 1.5  # noqa: E731
    with np.errstate(divide="ignore", invalid="ignore"):
        head = np.where(v1 != 0.0, (g(u1) - g(v0)) / v1, np.sqrt(np.abs(v0)) * eps).sum(axis=0)
    ld = np.empty(len(padded))
    steps = 0
    outcomes = {}
    for start in range(0, len(padded), b):
        sl = slice(start, start + b)
        ta_plain.state[:4, :] = padded[sl].T
        ta_plain.state[4, :] = 0.0
        ta_plain.set_time(0.0)
        ta_plain.propagate_until(eps)
        ta_half.state[:4, :] = ta_plain.state[:4, :]
        ta_half.state[4, :] = head[sl]
        ta_half.set_time(eps)
        ta_half.propagate_until(tau)
        for outcome, _min_h, _max_h, nsteps in ta_half.propagate_res:
            steps += nsteps
            outcomes[str(outcome)] = outcomes.get(str(outcome), 0) + 1
        ld[sl] = ta_half.state[4, :]
    return MethodResult(ld[:n], tau * n, {"steps": steps, "batch_size": b, "compile_s": compile_s,
                                          "outcomes": outcomes, "eps": eps, "tol": tol,
                                          "heyoka_threads": hy.get_nthreads()})


def heyoka_p_half_attempt(section_point, tau=50.0, tol=1e-10, generic_point=(1.0, 0.5, 0.7, 1.2)) -> list[dict]:
    """Try the p = 1/2 integrand in heyoka (scalar integrator); return what happened, as data.

    Two spellings (heyoka has no abs()): sqrt(sqrt(v^2)) and (v^2)^(1/4), each from a point of the
    section U_xpx (where dp_y/dt = 0 exactly at t = 0) and from a generic point off the section
    (no velocity component zero at t = 0).  The arc-length system from the same points is the
    step-count baseline.
    """
    import heyoka as hy

    out = []
    for label, point in (("section", section_point), ("generic", generic_point)):
        point = np.asarray(point, float)
        for integrand in ("sqrt_abs", "pow_quarter", "arclength"):
            record = {"start": label, "state0": [float(v) for v in point],
                      "velocity0": [float(v) for v in _field(*point)], "integrand": integrand}
            try:
                ta = hy.taylor_adaptive(_heyoka_system(integrand), np.append(point, 0.0), tol=tol)
                res = ta.propagate_until(tau)
                record.update(outcome=str(res[0]), min_h=float(res[1]), max_h=float(res[2]),
                              n_steps=int(res[3]), t_reached=float(ta.time), ld=float(ta.state[4]),
                              finite=bool(np.all(np.isfinite(ta.state))))
                # first single step from t = 0, to show where the NaN comes from
                ta2 = hy.taylor_adaptive(_heyoka_system(integrand), np.append(point, 0.0), tol=tol)
                step = ta2.step()
                record["first_step"] = {"outcome": str(step[0]), "h": float(step[1]),
                                        "state_after": [float(v) for v in ta2.state]}
            except Exception as exc:  # noqa: BLE001 -- the failure is the data we want
                record["error"] = f"{type(exc).__name__}: {exc}"
            out.append(record)
    return out


if __name__ == "__main__":
    import json

    import heyoka as hy

    from ldpipe.testing.reference_ld import E_SADDLE, section_state

    s, _ = section_state(1.0, 0.5, E_SADDLE - 0.125)
    print("heyoka", hy.__version__, "simd", hy.recommended_simd_size())
    print(json.dumps(heyoka_p_half_attempt(s), indent=1))
    print(scipy_per_trajectory(s[None]).ld, scipy_flattened(s[None], rtol=1e-10).ld, heyoka_batch(s[None]).ld,
          heyoka_p_half_offset(s[None]).ld)
