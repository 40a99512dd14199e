"""Near-touches: a velocity component that comes close to zero without crossing it.

There |v|^p ~ (a + b (t - t_m)^2)^p has its singularities at t_m +- i sqrt(a / b), close to the
real axis, and a Gauss–Legendre rule over the step stalls: with it alone the LD error on these
points does not fall with rtol (dop853: 8.9e-6 worst at rtol 1e-8, 1.5e-7 at 1e-12).

Expected values come from the independent reference (ldpipe.testing.reference_ld: scipy DOP853 at
rtol 1e-13, every crossing and every minimum of each |f_i| located, each piece integrated
separately; checked against closed forms of sqrt|t^2 + a| in test_reference_ld.py), with the
Hénon–Heiles and Barbanis vector fields written out here by hand.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from ldpipe.testing import reference_ld as reference
from ldpipe.engine import LDSettings, compute_ld
from ldpipe.systems import make_system
from support.barbanis import E_C
from support.henon_heiles import HENON_HEILES
from support.step_integral import from_roots, mpmath_step_integral
from support.step_rules import rule_engine, rules

# Hénon–Heiles' Taylor engines of two orders, which only these tests load.
pytestmark = pytest.mark.compiles

ENERGY = 0.2  # Hénon–Heiles, above the escape energy 1/6 (as ldds's tutorial map)
TAU = 10.0
# Near-touch points of a 50 x 50 scan of the section x = 0 (p_x > 0) at E = 1/5, tau = 10:
# indices into y = linspace(-0.45, 0.7, 50), p_y = linspace(-0.6, 0.6, 50), for the bounded
# trajectories where |x'| or |p_x'| dips below 3e-4 without crossing (from 3e-6 to 2.6e-4).
SCAN_Y = np.linspace(-0.45, 0.7, 50)
SCAN_PY = np.linspace(-0.6, 0.6, 50)
TOUCH_POINTS = [(1, 22), (40, 23), (30, 43), (2, 10), (10, 42), (10, 24), (26, 44), (29, 18), (49, 20),
                (35, 22), (12, 43), (38, 21), (29, 27), (6, 39), (16, 25), (29, 24), (11, 25)]


def henon_heiles_field(state):
    """V = (x^2 + y^2) / 2 + x^2 y - y^3 / 3: Hamilton's equations by hand."""
    x, y, px, py = state[0], state[1], state[2], state[3]
    return np.array([px, py, -x - 2.0 * x * y, -y - x * x + y * y])


def barbanis_field(state):
    """Barbanis 2 DoF, V = x^2 / 2 + 1.21 y^2 / 2 - 0.11 x y^2, by hand."""
    x, y, px, py = state[0], state[1], state[2], state[3]
    return np.array([px, py, -(x - 0.11 * y * y), -(1.21 * y - 0.22 * x * y)])


def touch_states() -> np.ndarray:
    rows = []
    for i, k in TOUCH_POINTS:
        y, py = SCAN_Y[i], SCAN_PY[k]
        potential = 0.5 * y * y - y**3 / 3.0
        rows.append([0.0, y, math.sqrt(2.0 * (ENERGY - potential) - py * py), py])
    return np.array(rows)


@pytest.fixture(scope="module")
def henon_heiles():
    # The system's text of support.henon_heiles, whose dop853 engine test_ld.py and the docs' tests load too.
    return make_system("henon_heiles", dict(HENON_HEILES))


@pytest.fixture(scope="module")
def touches():
    states = touch_states()
    refs = [reference.reference_ld(s, TAU, 0.5, field=henon_heiles_field) for s in states]
    return states, refs


def test_the_points_are_near_touches(touches):
    # each trajectory stays bounded and has a velocity component dipping below 3e-4 (of a scale
    # ~0.6) without crossing
    _, refs = touches
    for r in refs:
        assert not r.exited and r.n_minima >= 1
        assert r.deepest_minimum < 3e-4


# Bounds a few times the worst relative error measured over the points (the reference agrees with
# taylor to 4.9e-14 at rtol 1e-12, so it resolves all four): dop853 7.2e-8 at rtol 1e-8 and
# 1.5e-11 at 1e-12, taylor 3.5e-10 and 4.9e-14.
@pytest.mark.parametrize(
    "scheme, rtol, bound",
    [("dop853", 1e-8, 3e-7), ("dop853", 1e-12, 5e-11), ("taylor", 1e-8, 1.5e-9), ("taylor", 1e-12, 2e-13)],
)
def test_near_touch_error_meets_the_bound(henon_heiles, touches, scheme, rtol, bound):
    states, refs = touches
    expected = np.array([r.ld for r in refs])
    result = compute_ld(henon_heiles, states, +1, LDSettings(scheme=scheme, rtol=rtol, atol=rtol, p=0.5, tau=TAU))
    error = np.abs(result.ld - expected) / expected
    assert error.max() <= bound


def test_near_touch_error_falls_with_rtol(henon_heiles, touches):
    # dop853, worst over the points, a factor 10 at least per two decades of rtol
    states, refs = touches
    expected = np.array([r.ld for r in refs])
    worst = []
    for rtol in (1e-8, 1e-10, 1e-12):
        result = compute_ld(henon_heiles, states, +1, LDSettings(scheme="dop853", rtol=rtol, atol=rtol, p=0.5, tau=TAU))
        worst.append(np.max(np.abs(result.ld - expected) / expected))
    assert worst[1] < worst[0] / 10.0 and worst[2] < worst[1] / 10.0


@pytest.mark.parametrize(
    "scheme, tau, rtols",
    [("taylor", 0.05, (1e-10, 1e-12)), ("taylor", 0.3, (1e-10, 1e-12)), ("dop853", 0.3, (1e-10,))],
)
def test_double_root_at_the_start(scheme, tau, rtols):
    # At x = 5.5 a_y = 0.22 y (x - 5.5) vanishes, and with p_x = 0 x - 5.5 ~ -0.055 t^2: the
    # velocity component p_y' has a double root at t = 0, where a Gauss–Jacobi weight t^p is
    # wrong (|p_y'|^p ~ t^(2p)). Taken as a root: taylor 1.7e-8 over its one step of 0.05, and over
    # tau = 0.3 2.3e-8 at rtol 1e-10, 1.2e-8 at 1e-12 (not following the tolerance); as a dip ~2e-14.
    # dop853 at rtol 1e-12 is left out: 1.1e-10 there either way, from another step (8.5e-12
    # with 16 quadrature nodes), not from the double root. Taylor runs at order 13 at both
    # tolerances (the default at 1e-12; 11 would be at 1e-10): the double root, not the order, is
    # what is checked, and test_taylor.py compiles Barbanis' order-13 engine too.
    barbanis = make_system("barbanis_2dof", {"builtin": "barbanis_2dof"})
    kinetic = 2.0 * (E_C + 0.2 - barbanis.potential(np.array([5.5, 7.0])))
    state = np.array([5.5, 7.0, 0.0, math.sqrt(kinetic)])
    expected = reference.reference_ld(state, tau, 0.5, field=barbanis_field).ld
    order = {"taylor_order": 13} if scheme == "taylor" else {}
    for rtol in rtols:
        settings = LDSettings(scheme=scheme, rtol=rtol, atol=rtol, p=0.5, tau=tau, **order)
        result = compute_ld(barbanis, state[None, :], +1, settings)
        assert abs(result.ld[0] - expected) / expected <= 5.0 * rtol  # scaled by the tolerance asked for


# --- the scalar rule on one step, against mpmath -----------------------------------------------------
STEP_CASES = {
    # v on [0, 1] in monomial coefficients: a double root at the start (alone, and with a simple
    # root inside); a dip of |v| to 1e-8 inside, to 1e-10 exactly at the end, and 1e-6 just
    # outside either end; a dip next to a simple root; two roots 1e-3 apart outside the step;
    # two roots much closer than the step inside it (Gauss–Jacobi at one alone left the other's
    # cusp just beyond its anchor: 4e-5), one of them exactly on a sample of the scan (the other
    # was missed: no sign change between the zero sample and its neighbours), near the start
    "double root at 0": [0.0, 0.0, 1.0, 0.3],
    "double root at 0, root inside": [0.0, 0.0, 1.0, -2.0],
    "dip inside": from_roots(0.4 + 1e-4j, 0.4 - 1e-4j),
    "dip at the end": from_roots(1.0 + 1e-5j, 1.0 - 1e-5j),
    "dip just right": from_roots(1.02 + 1e-3j, 1.02 - 1e-3j),
    "dip just left": from_roots(-0.03 + 1e-3j, -0.03 - 1e-3j, 3.0),
    "dip and a root": from_roots(0.3 + 1e-4j, 0.3 - 1e-4j, 0.7),
    "root pair outside": from_roots(-0.2445, -0.2434, 3.0),
    "close root pair inside": from_roots(0.3, 0.3 + 1e-6, 3.0),
    "close root pair on a sample": from_roots(0.5, 0.5 + 1e-6, -2.0),
    "close root pair near the start": from_roots(0.05, 0.05 + 1e-5, 0.9),
}


@pytest.mark.parametrize("name", sorted(STEP_CASES))
def test_step_rule_against_mpmath(name):
    engine = rule_engine()
    coefficients = np.asarray(STEP_CASES[name], dtype=float)
    vc = np.zeros((coefficients.size, 1, 1))
    vc[:, 0, 0] = coefficients
    value = engine.component_integral(vc, 0, 0, coefficients.size, 1.0, engine.KIND_HALF, 0.5, *rules(8, 0.5),
                                      0.2, np.zeros(200))
    expected = mpmath_step_integral(coefficients)
    assert abs(value - expected) <= 1e-12 * expected
