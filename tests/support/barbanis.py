"""The paper's Barbanis systems for tests in several folders: parameters, saddles and regions, escaping states,
and the Barbanis–Contopoulos x-p_x slice through the saddle that NHIM points are refined on."""

from __future__ import annotations

import math

import numpy as np

from ldpipe.engine import LDSettings
from ldpipe.core.nhim import make_slice_problem
from ldpipe.core.sections import Section

# Barbanis 2 DoF: V = x^2/2 + wy2 y^2/2 + delta x y^2 (omega_x = 1, omega_y = 1.1, delta = -0.11).
WY2 = 1.1**2
DELTA = -0.11
E_C = 15.125  # critical energy of both index-1 saddles
TOP_SADDLE = (5.5, math.sqrt(50.0))
BOTTOM_REGION = ((4.5, -8.5), (6.5, -5.5))  # the config's 2 DoF saddle region (lower, upper corner)
# Barbanis–Contopoulos 3 DoF: the paper's saddle region q_s = [9,12] x [2.5,7.5] x [1,4].
PAPER_Q_S = ((9.0, 2.5, 1.0), (12.0, 7.5, 4.0))
#: Its saddle (closed form, as tests/stages/test_upo.py) and the paper's energy.
BC_SADDLE = np.array([10.289915108550531, 5.294117647058823, 2.6470588235294117])
BC_ENERGY = 24.0


def escaping_states(system, excess=1.0, count=5):
    """At the top saddle, above E_c, heading out of the well: every one escapes to infinity."""
    x, y = TOP_SADDLE
    speed = math.sqrt(2.0 * (E_C + excess - system.potential(np.array([x, y]))))
    angles = np.linspace(-0.6, 0.6, count)
    return np.array([(x, y, speed * math.sin(a) * 0.3 + 0.4, speed * math.cos(a)) for a in angles])


def fig5_slice_problem(system):
    """The config's fig5_xpx map as a slice problem (the base of a slice family through the saddle):
    the x-p_x section at the saddle's y, z and p_y = 0, p_z solved (> 0), over the paper's saddle
    region q_s, tau = 50, p = 1/2, DOP853 at 1e-8. Every test that refines NHIM points of
    Barbanis–Contopoulos uses these settings, so they share one compiled engine."""
    section = Section(axes=("x", "px"), ranges=((9.0, 12.0), (-0.6, 0.6)), shape=(1000, 1000),
                      fixed={"y": BC_SADDLE[1], "z": BC_SADDLE[2], "py": 0.0}, solve="pz", sign=1)
    settings = LDSettings(rtol=1e-8, atol=1e-8, p=0.5, tau=50.0, region_lower=PAPER_Q_S[0], region_upper=PAPER_Q_S[1])
    return make_slice_problem("fig5_xpx", system, section, BC_ENERGY, system.potential(BC_SADDLE), BC_SADDLE, settings)
