"""The paper's Barbanis 2 DoF for tests in several folders: its critical energy and states that escape."""

from __future__ import annotations

import math

import numpy as np

E_C = 15.125  # critical energy of both index-1 saddles
TOP_SADDLE = (5.5, math.sqrt(50.0))


def escaping_states(system, excess=1.0, count=5):
    """At the top saddle, above E_c, heading out of the well: every one escapes to infinity."""
    x, y = TOP_SADDLE
    speed = math.sqrt(2.0 * (E_C + excess - system.potential(np.array([x, y]))))
    angles = np.linspace(-0.6, 0.6, count)
    return np.array([(x, y, speed * math.sin(a) * 0.3 + 0.4, speed * math.cos(a)) for a in angles])
