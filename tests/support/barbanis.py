"""The paper's Barbanis systems for tests in several folders: parameters, saddles and regions, escaping states."""

from __future__ import annotations

import math

import numpy as np

# Barbanis 2 DoF: V = x^2/2 + wy2 y^2/2 + delta x y^2 (omega_x = 1, omega_y = 1.1, delta = -0.11).
WY2 = 1.1**2
DELTA = -0.11
E_C = 15.125  # critical energy of both index-1 saddles
TOP_SADDLE = (5.5, math.sqrt(50.0))
BOTTOM_REGION = ((4.5, -8.5), (6.5, -5.5))  # the config's 2 DoF saddle region (lower, upper corner)
# Barbanis–Contopoulos 3 DoF: the paper's saddle region q_s = [9,12] x [2.5,7.5] x [1,4].
PAPER_Q_S = ((9.0, 2.5, 1.0), (12.0, 7.5, 4.0))


def escaping_states(system, excess=1.0, count=5):
    """At the top saddle, above E_c, heading out of the well: every one escapes to infinity."""
    x, y = TOP_SADDLE
    speed = math.sqrt(2.0 * (E_C + excess - system.potential(np.array([x, y]))))
    angles = np.linspace(-0.6, 0.6, count)
    return np.array([(x, y, speed * math.sin(a) * 0.3 + 0.4, speed * math.cos(a)) for a in angles])
