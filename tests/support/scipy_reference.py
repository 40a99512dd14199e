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
