"""Independent references by scipy: M_1 and the arc length of one trajectory of a first-order field."""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp


def m1_and_arclength(velocity, state, tau: float) -> tuple[float, float]:
    """M_1 and the arc length over [0, tau] by scipy's DOP853 at rtol = atol = 1e-13.

    ``velocity(s)`` is the phase-space velocity at the state ``s`` (shape (4,)). The arc length is
    a fifth state. M_1 needs no quadrature: between consecutive zeros of a velocity component
    (located by events) its phase coordinate is monotone, so the integral of |velocity| is the
    coordinate's total variation.
    """

    def rhs(_t, s):
        v = velocity(s[:4])
        return [*v, math.sqrt(v @ v)]

    zeros = [lambda _t, s, c=c: velocity(s[:4])[c] for c in range(4)]
    solution = solve_ivp(rhs, (0.0, tau), [*state, 0.0], method="DOP853", rtol=1e-13, atol=1e-13, events=zeros)
    end = solution.y[:, -1]
    m1 = 0.0
    for c in range(4):
        turning = np.reshape(solution.y_events[c], (-1, 5))[:, c]
        m1 += np.abs(np.diff([state[c], *turning, end[c]])).sum()
    return m1, end[4]


def flow_m1_and_arclength(field, state, t0: float, t1: float) -> tuple[float, float, np.ndarray]:
    """M_1, the arc length and the end state of dx/dt = field(t, x) over [t0, t1] (t1 < t0: backward),
    by scipy's DOP853 at rtol = atol = 1e-13, any dimension.

    As :func:`m1_and_arclength`: M_1 is the total variation of each coordinate, summed over the
    pieces between the zeros of its velocity (located by events); the arc length is an extra
    state (its rate is |dt| ||f||, so it grows backward too).
    """
    state = np.asarray(state, dtype=float)
    n = len(state)
    sign = 1.0 if t1 >= t0 else -1.0

    def rhs(t, s):
        v = np.asarray(field(t, s[:n]), dtype=float)
        return [*v, sign * math.sqrt(v @ v)]

    zeros = [lambda t, s, c=c: field(t, s[:n])[c] for c in range(n)]
    solution = solve_ivp(rhs, (t0, t1), [*state, 0.0], method="DOP853", rtol=1e-13, atol=1e-13, events=zeros)
    end = solution.y[:, -1]
    m1 = 0.0
    for c in range(n):
        turning = np.reshape(solution.y_events[c], (-1, n + 1))[:, c]
        m1 += np.abs(np.diff([state[c], *turning, end[c]])).sum()
    return m1, end[n], end[:n]


def flow_state_quadrature_ld(field, state, t0: float, t1: float, p: float, rtol: float = 1e-12) -> float:
    """M_p = int sum_c |f_c|^p dt of dx/dt = field(t, x) over [t0, t1] as an extra state of the ODE
    (the state quadrature of ldds), by scipy's DOP853 at rtol = atol = ``rtol``. Its integrand has
    cusps at the zeros of each f_c, which the step control resolves only to ~|t - r|^(1 + p)."""
    state = np.asarray(state, dtype=float)
    n = len(state)
    sign = 1.0 if t1 >= t0 else -1.0

    def rhs(t, s):
        v = np.asarray(field(t, s[:n]), dtype=float)
        return [*v, sign * float(np.sum(np.abs(v) ** p))]

    solution = solve_ivp(rhs, (t0, t1), [*state, 0.0], method="DOP853", rtol=rtol, atol=rtol)
    return solution.y[n, -1]
