"""The engine with a kinetic matrix: H = p^T M^-1 p / 2 + V.

Expected values:

- oscillators with masses: the LD in closed form (support.closed_forms.massive_harmonic_ld,
  w = sqrt(k / m)) and the end state q = A cos(w t + phase), p = m q';
- a coupled system with a non-diagonal M: scipy's DOP853 at rtol = atol = 1e-13 on Hamilton's
  equations q' = M^-1 p, p' = -grad V written out by hand here (support.scipy_reference: M_1 as
  total variations, the arc length as a fifth state), and the energy, conserved;
- diagonal masses against the hand-rescaled system q' = sqrt(m) q, p' = p / sqrt(m) (unit
  masses, V'(q') = V(q' / sqrt(m))): the same trajectory in the mapped variables;
- unit masses given explicitly: no kinetic matrix at all (the unit-mass code paths).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from ldpipe.core import trajectories
from ldpipe.engine import LDSettings, compute_ld
from ldpipe.engine.codegen import engine_source
from ldpipe.systems import make_system
from support.closed_forms import massive_harmonic_ld
from support.scipy_reference import m1_and_arclength

# Eight engines of systems with masses that no other test loads (and barbanis_m8's, which test_ld.py loads too).
pytestmark = pytest.mark.compiles

STIFFNESS = (2.0, 1.5)
MASSES = (8.0, 0.5)
OSCILLATOR = {"formula": "(kx*x**2 + ky*y**2)/2", "coordinates": ["x", "y"], "parameters": {"kx": 2.0, "ky": 1.5},
              "masses": {"x": 8.0, "y": 0.5}}
# Generic states: every velocity component crosses zero within TAU.
STATES = np.array([[1.0, 0.5, 0.3, -0.2], [-0.7, 0.1, 1.1, 0.9], [0.2, -1.3, -0.4, 0.05]])
TAU = 23.7

# Barbanis' potential with a coupled kinetic matrix (symmetric, eigenvalues 1.5 +- 0.5: positive definite).
COUPLED_MATRIX = [[1.5, 0.5], [0.5, 1.5]]
COUPLED = {"builtin": "barbanis_2dof", "mass_matrix": COUPLED_MATRIX}


@pytest.fixture(scope="module")
def oscillator():
    return make_system("ho_masses", OSCILLATOR)


def exact_state(state, t):
    """Closed-form (x, y, px, py) at time t of the oscillators with masses."""
    out = np.empty(4)
    for i, (k, m) in enumerate(zip(STIFFNESS, MASSES)):
        w = math.sqrt(k / m)
        q0, v0 = state[i], state[2 + i] / m
        out[i] = q0 * math.cos(w * t) + v0 / w * math.sin(w * t)
        out[2 + i] = m * (-q0 * w * math.sin(w * t) + v0 * math.cos(w * t))
    return out


@pytest.mark.parametrize("p", [0.5, 1.0])
def test_dop853_ld_and_end_state_match_the_closed_form(oscillator, p):
    result = compute_ld(oscillator, STATES, +1, LDSettings(rtol=1e-12, atol=1e-12, p=p, tau=TAU))
    exact = np.array([massive_harmonic_ld(s, STIFFNESS, MASSES, TAU, p) for s in STATES])
    assert np.max(np.abs(result.ld - exact) / exact) < 1e-10
    ends = np.array([exact_state(s, TAU) for s in STATES])
    assert np.max(np.abs(result.end_state - ends)) < 1e-9
    # the energy H = sum p^2 / (2 m) + V is conserved (and is what the engine measures)
    assert result.energy_error.max() < 1e-10


@pytest.mark.parametrize("scheme,dt,bound", [("rk4", 0.01, 1e-7), ("sym4", 0.01, 1e-7), ("sym6", 0.02, 1e-8)])
def test_fixed_step_schemes_match_the_closed_form(oscillator, scheme, dt, bound):
    result = compute_ld(oscillator, STATES, +1, LDSettings(scheme=scheme, dt=dt, p=0.5, tau=TAU))
    exact = np.array([massive_harmonic_ld(s, STIFFNESS, MASSES, TAU, 0.5) for s in STATES])
    assert np.max(np.abs(result.ld - exact) / exact) < bound
    ends = np.array([exact_state(s, TAU) for s in STATES])
    assert np.max(np.abs(result.end_state - ends)) < 100 * bound


def test_taylor_matches_the_closed_form(oscillator):
    result = compute_ld(oscillator, STATES, +1, LDSettings(scheme="taylor", rtol=1e-12, atol=1e-12, p=0.5, tau=TAU))
    exact = np.array([massive_harmonic_ld(s, STIFFNESS, MASSES, TAU, 0.5) for s in STATES])
    assert np.max(np.abs(result.ld - exact) / exact) < 1e-10
    ends = np.array([exact_state(s, TAU) for s in STATES])
    assert np.max(np.abs(result.end_state - ends)) < 1e-9


def test_sym4_is_symplectic_with_masses(oscillator):
    # A symplectic scheme keeps the energy error bounded (no drift) over many periods: the error
    # at tau = 2000 is no larger than a few times the one at tau = 100 (a non-symplectic method
    # of the same order drifts linearly in time).
    state = STATES[:1]
    short = compute_ld(oscillator, state, +1, LDSettings(scheme="sym4", dt=0.2, p=0.5, tau=100.0))
    long = compute_ld(oscillator, state, +1, LDSettings(scheme="sym4", dt=0.2, p=0.5, tau=2000.0))
    assert long.energy_error[0] < 3.0 * max(short.energy_error[0], 1e-12)
    assert long.energy_error[0] < 1e-3


def coupled_field(s):
    """Hamilton's equations of Barbanis' potential (paper values) with M = COUPLED_MATRIX, by hand."""
    wx2, wy2, delta = 1.0, 1.21, -0.11
    x, y, px, py = s
    inverse = np.linalg.inv(np.array(COUPLED_MATRIX))
    vx, vy = inverse @ np.array([px, py])
    return np.array([vx, vy, -(wx2 * x + delta * y * y), -(wy2 * y + 2.0 * delta * x * y)])


def test_coupled_kinetic_matrix_against_scipy():
    system = make_system("barbanis_coupled", COUPLED)
    states = np.array([[0.3, 0.1, 0.2, -0.4], [-0.5, 0.6, 0.1, 0.3]])
    tau = 10.0
    m1 = compute_ld(system, states, +1, LDSettings(rtol=1e-12, atol=1e-12, p=1.0, tau=tau))
    arc = compute_ld(system, states, +1, LDSettings(rtol=1e-12, atol=1e-12, p="arclength", tau=tau))
    for k, state in enumerate(states):
        ref_m1, ref_arc = m1_and_arclength(coupled_field, state, tau)
        assert abs(m1.ld[k] - ref_m1) / ref_m1 < 1e-9
        assert abs(arc.ld[k] - ref_arc) / ref_arc < 1e-9
        assert abs(system.energy(m1.end_state[k]) - system.energy(state)) < 1e-11
    assert m1.energy_error.max() < 1e-11


def test_flow_samples_and_momentum_crossings_with_masses(oscillator):
    # Samples are (q, p) with p = m q'; the crossings of px = 0 (decreasing) are the turning points of x,
    # at x = +A, every period 2 pi sqrt(m / k) = 4 pi.
    state = np.array([[1.0, 0.3, 2.0, 0.0]])
    period = 2.0 * math.pi * math.sqrt(MASSES[0] / STIFFNESS[0])
    settings = trajectories.FlowSettings(rtol=1e-12, atol=1e-12)
    run = trajectories.integrate(oscillator, state, 2.5 * period, settings, sample_times=np.array([0.0, 1.3, 7.7]),
                         section=("px", 0.0, -1), max_crossings=2)
    for s, t in zip(run.samples[0], (0.0, 1.3, 7.7)):
        assert np.max(np.abs(s - exact_state(state[0], t))) < 1e-10
    assert run.crossing_count[0] == 2
    w = math.sqrt(STIFFNESS[0] / MASSES[0])
    amplitude = math.hypot(1.0, 2.0 / MASSES[0] / w)
    first = math.atan2(2.0 / MASSES[0] / w, 1.0) / w  # x = A cos(w (t - t1)): px = 0 decreasing at t1
    assert np.allclose(run.crossing_times[0], [first, first + period], atol=1e-10, rtol=0)
    assert np.allclose(run.crossings[0, :, 0], amplitude, atol=1e-10, rtol=0)


RESCALED_FORMULA = "wx**2*(x/r)**2/2 + wy**2*(y/r)**2/2 + d*(x/r)*(y/r)**2"
M8 = 8.0


def rescaled_barbanis(name: str, r: float, masses: dict | None = None):
    """Barbanis' potential (paper values) rescaled, V(q / r), as a formula; unit masses without ``masses``."""
    spec = {"formula": RESCALED_FORMULA, "coordinates": ["x", "y"],
            "parameters": {"wx": 1.0, "wy": 1.1, "d": -0.11, "r": r}}
    return make_system(name, {**spec, "masses": masses} if masses else spec)


@pytest.fixture(scope="module")
def barbanis_m8():
    """Barbanis with m_x = m_y = 8, the builtin potential (test_ld.py loads its dop853 engine too)."""
    return make_system("barbanis_m8", {"builtin": "barbanis_2dof", "masses": {"x": M8, "y": M8}})


@pytest.fixture(scope="module")
def barbanis_rescaled():
    """The unit-mass image of barbanis_m8 under q' = sqrt(8) q: V(q' / sqrt(8)), no masses."""
    return rescaled_barbanis("barbanis_rescaled", math.sqrt(M8))


def test_diagonal_masses_equal_the_hand_rescaled_system(barbanis_m8, barbanis_rescaled):
    # q' = sqrt(m) q, p' = p / sqrt(m) maps H = p^2 / (2 m) + V(q) onto |p'|^2 / 2 + V(q' / sqrt(m)):
    # the same trajectories, so the end state of one maps onto the other's.
    m = M8
    massive, rescaled = barbanis_m8, barbanis_rescaled
    states = np.array([[0.3, 0.1, 0.8, -1.2], [-0.5, 0.6, 0.4, 0.9]])
    scale = np.array([math.sqrt(m)] * 2 + [1.0 / math.sqrt(m)] * 2)
    settings = LDSettings(rtol=1e-12, atol=1e-12, p=0.5, tau=15.0)
    a = compute_ld(massive, states, +1, settings)
    b = compute_ld(rescaled, states * scale, +1, settings)
    assert np.max(np.abs(a.end_state * scale - b.end_state)) < 1e-9
    assert abs(massive.energy(states[0]) - rescaled.energy(states[0] * scale)) < 1e-15


def test_p_norm_ld_scales_by_component_under_the_rescaling(barbanis_m8, barbanis_rescaled):
    # Under q' = s q, p' = p / s (H = |p|^2 / (2 m) + V becomes |p'|^2 s^2 / (2 m) + V(q' / s): masses
    # m / s^2) the trajectory is the same and each velocity component scales: dq'/dt = s dq/dt,
    # dp'/dt = (dp/dt) / s. So M_p = s^p A + s^-p B with A, B the position and momentum parts of the
    # unscaled LD. Two runs (m = 8 at s = 1, and the unit-mass system at s = sqrt(8)) give A and B; a
    # third (masses 2 at s = 2) must equal 2^p A + 2^-p B. The first two runs are on the test above's
    # systems, so they share its engines: at s = 1 the builtin Barbanis potential is the formula's
    # V(q / 1), and at s = sqrt(8) the masses m / s^2 are 1 to 2e-16 in floating point, given as
    # exactly 1 (no kinetic matrix), which moves the LD by ~1e-16 relative, far below the rtol 1e-9.
    m, p = M8, 0.5
    systems = {1.0: barbanis_m8, math.sqrt(m): barbanis_rescaled,
               2.0: rescaled_barbanis("barbanis_scaled_2", 2.0, {"x": m / 4.0, "y": m / 4.0})}
    states = np.array([[0.3, 0.1, 0.8, -1.2], [-0.5, 0.6, 0.4, 0.9], [1.0, -0.4, -0.7, 0.2]])
    settings = LDSettings(rtol=1e-12, atol=1e-12, p=p, tau=12.0)
    lds = {}
    for s, system in systems.items():
        scale = np.array([s, s, 1.0 / s, 1.0 / s])
        lds[s] = compute_ld(system, states * scale, +1, settings).ld
    root = m ** (p / 2)
    # A + B = L(1), root A + B / root = L(sqrt m)
    a = (lds[math.sqrt(m)] - lds[1.0] / root) / (root - 1.0 / root)
    b = lds[1.0] - a
    assert np.all(a > 0) and np.all(b > 0)
    np.testing.assert_allclose(lds[2.0], 2.0**p * a + 2.0**-p * b, rtol=1e-9)


def test_unit_masses_are_no_kinetic_matrix():
    # masses of 1 are the identity: no kinetic section in the generated code, the same system as without
    plain = make_system("ho_plain", {"formula": "x**2/2 + y**2", "coordinates": ["x", "y"]})
    unit = make_system("ho_unit", {"formula": "x**2/2 + y**2", "coordinates": ["x", "y"], "masses": {"x": 1, "y": 1.0}})
    assert unit.mass_matrix is None
    assert engine_source(unit, "dop853", 8) == engine_source(plain, "dop853", 8)
    assert "kinetic matrix" not in engine_source(plain, "rk4", 8)
    massive = make_system("ho_m2", {"formula": "x**2/2 + y**2", "coordinates": ["x", "y"], "masses": {"x": 2}})
    assert "kinetic matrix (generated by ldpipe.engine.kinetic)" in engine_source(massive, "rk4", 8)
