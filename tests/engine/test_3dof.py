"""The engine on the Barbanis–Contopoulos 3 DoF model with the paper's saddle region q_s."""

import math

import numpy as np

from ldpipe.engine import LDSettings, compute_ld
from support.barbanis import PAPER_Q_S as Q_S  # the paper's q_s = [9,12] x [2.5,7.5] x [1,4]


def test_variable_time_3dof_invariants(barbanis_contopoulos):
    system = barbanis_contopoulos
    saddle = system.closed_form_equilibria()[1]
    energy = system.potential(saddle) + 0.1
    rng = np.random.default_rng(3)
    states = []
    while len(states) < 40:
        q = saddle + rng.uniform(-0.4, 0.4, 3)
        direction = rng.normal(size=3)
        kinetic = 2.0 * (energy - system.potential(q))
        if kinetic > 0:
            states.append(np.concatenate([q, math.sqrt(kinetic) * direction / np.linalg.norm(direction)]))
    states = np.array(states)
    settings = LDSettings(rtol=1e-11, atol=1e-11, tau=30.0, region_lower=Q_S[0], region_upper=Q_S[1])
    forward = compute_ld(system, states, +1, settings)
    # time reversal (H even in p): backward at (q, -p) equals forward at (q, p), exit times
    # included, bit for bit (measured on all 40): the backward run with h = -|h| is the forward
    # one's mirror image, negation being exact (see test_barbanis.py's test_time_reversal)
    backward = compute_ld(system, states * np.array([1, 1, 1, -1, -1, -1]), -1, settings)
    np.testing.assert_array_equal(forward.ld, backward.ld)
    np.testing.assert_array_equal(forward.time, backward.time)
    assert np.all(forward.time[forward.left_region] < 30.0)
    assert np.all(forward.time[~forward.left_region] == 30.0)
    assert forward.left_region.any() and not forward.failed.any()
    assert forward.energy_error.max() < 1e-8
