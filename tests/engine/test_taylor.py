"""The ``taylor`` scheme of the LD engine (Taylor series, Jorba–Zou steps; ldpipe.engine.schemes.taylor).

Every expected value is a closed form, an invariant or an independent integration:

- uncoupled harmonic oscillators: the LD for p = 1/2 from the Beta function
  (support.closed_forms), the arc length from the incomplete elliptic integral E, and the
  Taylor coefficients, hence the steps the Jorba–Zou rule must take, from cos and sin;
- the Barbanis 2 DoF on the paper's section: dop853 at rtol 1e-13 (the engine's other
  adaptive scheme), energy, time reversal, escapes and region exits; and, since dop853 shares
  the LD quadrature with taylor, the independent reference LD (ldpipe.testing.reference_ld:
  scipy only) at a few points;
- a quartic potential with a constant force (cubic monomials, chained series products, a
  constant term): scipy's DOP853 at rtol 1e-13, energy, and the hand-derived acceleration;
- the settings: the order rule and the validation of ``taylor_order``.

A double root of a velocity component at a step's start has its test
(``test_double_root_at_the_start``): taken as a root it leaves an LD error of ~1e-8 that no
tolerance removes, so the quadrature takes it as a dip (a near-touch of width 0).

Engines are compiled per (system, scheme, order, lanes), ~15 s each: this file uses order 14
for the formula systems and 13 for the Barbanis system (the default at rtol 1e-12 for |v|^p),
and 64 lanes for every integrand.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.special import ellipeinc

from ldpipe.engine import LDSettings, compute_ld
from ldpipe.engine.schemes.taylor import MAX_ORDER, MIN_ORDER, SAFETY, acceleration_of
from ldpipe.core.sections import Section, section_states
from ldpipe.systems import make_system
from ldpipe.testing.reference_ld import reference_ld
from support.barbanis import E_C, escaping_states
from support.closed_forms import STATES, WX, WY, oscillator_ld
from support.scipy_reference import m1_and_arclength

# Taylor engines of its own orders and systems (see the module docstring).
pytestmark = pytest.mark.compiles

FORMULA_ORDER = 14  # the oscillator and the quartic system
BARBANIS_ORDER = 13  # = LDSettings(scheme="taylor", rtol=1e-12, p=0.5).order
RESULT_FIELDS = ("ld", "time", "energy_error", "steps")


# One block size for both integrands (|v|^p's default; the arc length's is 32), so the file compiles
# one engine per system and order, not two. Lanes are independent: the block size changes no
# result bit (the arc-length LDs here are the same bits at 32 lanes). test_taylor_formulas.py runs 32.
LANES = 64


def taylor(order: int, tolerance: float, **settings) -> LDSettings:
    return LDSettings(scheme="taylor", taylor_order=order, rtol=tolerance, atol=tolerance, block=LANES, **settings)


def relative(values, reference) -> np.ndarray:
    return np.abs(np.asarray(values) - reference) / np.abs(reference)


def assert_finite(result) -> None:
    for name in RESULT_FIELDS:
        assert np.isfinite(getattr(result, name)).all(), name


# --- 1. harmonic oscillator against closed forms -------------------------------------------------
@pytest.mark.parametrize("direction", [+1, -1])
def test_oscillator_half_power_ld_meets_the_closed_form(oscillator, direction):
    # Closed form through the Beta function (support.closed_forms.oscillator_ld). Backward
    # time: the LD over [-tau, 0] of (q, p) is the forward LD of (q, -p), also in closed form.
    # Measured: relative error 6e-15 both ways with the default 16 Gauss nodes (1e-10 with 8).
    rng = np.random.default_rng(12)
    states = np.vstack([STATES, rng.normal(size=(12, 4))])
    tau = 23.7  # no whole number of periods of either frequency
    result = compute_ld(oscillator, states, direction, taylor(FORMULA_ORDER, 1e-12, p=0.5, tau=tau))
    assert not (result.failed | result.escaped).any() and np.all(result.time == tau)
    reference_states = states if direction == 1 else states * np.array([1, 1, -1, -1])
    exact = np.array([oscillator_ld(state, tau, 0.5) for state in reference_states])
    assert relative(result.ld, exact).max() < 1e-11


def oscillator_arclength(amplitude: float, omega: float, phase: float, tau: float) -> float:
    """Phase-space arc length over [0, tau] of one oscillator q = A cos(w t + phase).

    ||x'||^2 = q'^2 + (w^2 q)^2 = A^2 w^2 (sin^2 u + w^2 cos^2 u) = A^2 w^4 (1 - m sin^2 u),
    m = 1 - 1/w^2, u = w t + phase; so the arc length is A w (E(u_1 | m) - E(u_0 | m)) with
    E the incomplete elliptic integral of the second kind.
    """
    m = 1.0 - 1.0 / omega**2
    return amplitude * omega * (ellipeinc(omega * tau + phase, m) - ellipeinc(phase, m))


def test_oscillator_arclength_meets_the_closed_form(oscillator):
    # One oscillator moving at a time: x with wx = 1 (constant speed, arc length sqrt(2E) tau)
    # and y with wy = 1.3 (an elliptic integral). Measured: 7e-15, 2e-14 and 3e-13.
    assert WX == 1.0
    states = np.array([[0.6, 0.0, -1.2, 0.0], [0.0, 0.7, 0.0, -0.4], [0.0, -1.1, 0.0, 0.9]])
    tau = 23.7
    result = compute_ld(oscillator, states, +1, taylor(FORMULA_ORDER, 1e-12, p="arclength", tau=tau))
    exact = [math.hypot(0.6, 1.2) * tau]
    for y, py in states[1:, [1, 3]]:
        amplitude = math.hypot(y, py / WY)
        exact.append(oscillator_arclength(amplitude, WY, math.atan2(-py / WY, y), tau))
    assert oscillator_arclength(1.0, 1.0, 0.3, 2.0) == pytest.approx(2.0, rel=1e-15)  # the helper, w = 1
    assert relative(result.ld, np.array(exact)).max() < 2e-12


# --- 6. the step rule ----------------------------------------------------------------------------
def step_bounds(order: int, tolerance: float, amplitude: float) -> tuple[float, float]:
    """Smallest and largest step the Jorba–Zou rule takes on q = A cos(t + phase), any phase.

    The k-th Taylor coefficients are q_k = A cos^(k)(phase) / k! and (k+1) q_{k+1} (those of p)
    = A cos^(k+1)(phase) / k!: one of them is A |cos| / k!, the other A |sin| / k!. With the
    scales atol + rtol |x| in [tol, tol (1 + A)] and max(|cos|, |sin|) >= 1/sqrt(2),

        A / (sqrt(2) (1 + A) k! tol) <= rho_k <= A / (k! tol),

    and h = SAFETY min(rho_m^(-1/m), rho_{m-1}^(-1/(m-1))) is bounded accordingly.
    """
    m = order

    def h(k: int, factor: float) -> float:
        return SAFETY * (factor * math.factorial(k) * tolerance / amplitude) ** (1.0 / k)

    spread = math.sqrt(2.0) * (1.0 + amplitude)
    return min(h(m, 1.0), h(m - 1, 1.0)), min(h(m, spread), h(m - 1, spread))


def test_step_rule_takes_the_steps_the_series_dictate(oscillator):
    # x-only motion with wx = 1, amplitude 1: the series are cos and sin (closed form), so the
    # number of steps over tau lies in [tau / h_max, tau / h_min + startup] (step_bounds).
    # Startup: the first step (Hairer's starting step, >= 1e-6 here) grows tenfold per step
    # until the rule limits it: at most 7 steps, plus the shortened last one. The scheme
    # chooses each step before taking it, so any rejected attempt would add to the count.
    # Measured: 149, 213 and 303 steps at 1e-8, 1e-10 and 1e-12.
    assert WX == 1.0
    phase, tau = 0.4, 200.0
    state = np.array([[math.cos(phase), 0.0, -math.sin(phase), 0.0]])
    errors, energy_errors, steps = [], [], []
    for tolerance in (1e-8, 1e-10, 1e-12):
        result = compute_ld(oscillator, state, +1, taylor(FORMULA_ORDER, tolerance, p="arclength", tau=tau))
        assert result.time[0] == tau and not result.failed[0]
        h_min, h_max = step_bounds(FORMULA_ORDER, tolerance, 1.0)
        assert math.ceil(tau / h_max) <= result.steps[0] <= math.ceil(tau / h_min) + 8
        errors.append(abs(result.ld[0] - tau) / tau)  # ||x'||^2 = 2E = 1: arc length = tau
        energy_errors.append(result.energy_error[0])
        steps.append(result.steps[0])
    # Errors follow the tolerance down (measured LD 2.5e-9, 1.4e-11, 7e-14; energy 5e-9,
    # 3e-11, 1.4e-13): each 100x tighter tolerance gains at least 30x.
    for coarse, fine in zip(errors, errors[1:]):
        assert fine < coarse / 30.0
    for coarse, fine in zip(energy_errors, energy_errors[1:]):
        assert fine < coarse / 30.0
    assert errors[0] < 1e-8 and energy_errors[0] < 1e-7
    assert steps[0] < steps[1] < steps[2]


# --- 2. Barbanis 2 DoF against dop853 -------------------------------------------------------------
@pytest.fixture(scope="module")
def barbanis_section(barbanis):
    """48 allowed points of the paper's U_xpx (y = 0, p_y > 0) at E_c - 0.125, an 8 x 8 grid."""
    section = Section(axes=("x", "px"), ranges=((-5.0, 5.4), (-5.0, 5.0)), shape=(8, 8), fixed={"y": 0.0}, solve="py")
    states, _, _ = section_states(barbanis, section, E_C - 0.125)
    assert 40 <= len(states) <= 64
    return states


@pytest.mark.parametrize("p", [0.5, "arclength"])
@pytest.mark.parametrize("direction", [+1, -1])
def test_barbanis_section_agrees_with_dop853(barbanis, barbanis_section, p, direction):
    # Independent method: the engine's DOP853 at rtol 1e-13 (its error there is ~1e-12).
    # Measured: relative LD difference at most 6.1e-12 (p = 1/2) and 1.2e-12 (arc length);
    # energy error at most 2.3e-12 (E ~ 15, tau = 50).
    result = compute_ld(barbanis, barbanis_section, direction, taylor(BARBANIS_ORDER, 1e-12, p=p, tau=50.0))
    reference = compute_ld(barbanis, barbanis_section, direction, LDSettings(rtol=1e-13, atol=1e-13, p=p, tau=50.0))
    assert not (result.failed | result.escaped | result.left_region).any()
    assert np.all(result.time == 50.0)
    assert relative(result.ld, reference.ld).max() < 5e-11
    assert result.energy_error.max() < 2e-11
    # Work: the order-13 series takes longer steps than the 8th-order dop853 at the same
    # tolerance: at most 3/4 of its steps on every trajectory (measured: at most 0.58 of
    # them, 225 against 397 on average).
    dop853 = LDSettings(rtol=1e-12, atol=1e-12, p=p, tau=50.0)
    same_tolerance = compute_ld(barbanis, barbanis_section, direction, dop853)
    assert np.all(result.steps < 0.75 * same_tolerance.steps)


def test_barbanis_section_half_power_ld_meets_the_reference(barbanis, barbanis_section):
    # Independent of the engine (whose dop853 shares the cusp and near-touch rules with taylor):
    # the reference LD, on every tenth point over tau = 10 (12-13 crossings and 1-2 near-touches
    # each; 0.6 s for the five). Measured: at most 5.1e-14 (dop853 at rtol 1e-13: 8e-12).
    states = barbanis_section[::10]
    result = compute_ld(barbanis, states, +1, taylor(BARBANIS_ORDER, 1e-12, p=0.5, tau=10.0))
    expected = np.array([reference_ld(state, 10.0, 0.5).ld for state in states])
    assert relative(result.ld, expected).max() < 2e-13


def test_barbanis_time_reversal(barbanis, barbanis_section):
    # H is even in p: the backward trajectory of (q, -p) is the forward one of (q, p) run
    # backwards, so its LD is the same (invariant).
    settings = taylor(BARBANIS_ORDER, 1e-12, p=0.5, tau=50.0)
    forward = compute_ld(barbanis, barbanis_section, +1, settings)
    backward = compute_ld(barbanis, barbanis_section * np.array([1, 1, -1, -1]), -1, settings)
    np.testing.assert_allclose(backward.ld, forward.ld, rtol=1e-12, atol=0)
    np.testing.assert_array_equal(backward.time, forward.time)


# --- 5. escapes and region exits ---------------------------------------------------------------------
@pytest.mark.parametrize("p", [0.5, "arclength"])
def test_escapes_stop_at_the_radius_like_dop853(barbanis, p):
    # Beyond the top saddle above E_c, the cubic term sends every trajectory to infinity in
    # finite time (test_hard_cases.py): each must stop where max|q_i| reaches the radius, flagged.
    # Independent method: dop853 at rtol 1e-13. Measured: escape times agree to 1.3e-15,
    # LDs to 1.9e-12 (p = 1/2) and 5e-14 (arc length); energy error 1.1e-9 (|V| ~ 1e5 there).
    states = escaping_states(barbanis, count=7)
    with np.errstate(all="raise"):
        result = compute_ld(barbanis, states, +1, taylor(BARBANIS_ORDER, 1e-12, p=p, tau=50.0, escape_radius=100.0))
    reference = compute_ld(barbanis, states, +1, LDSettings(rtol=1e-13, atol=1e-13, p=p, tau=50.0, escape_radius=100.0))
    assert reference.escaped.all()
    np.testing.assert_array_equal(result.escaped, reference.escaped)
    assert not (result.failed | result.left_region).any()
    assert_finite(result)
    assert relative(result.time, reference.time).max() < 1e-8
    assert relative(result.ld, reference.ld).max() < 1e-9
    assert result.energy_error.max() < 1e-7


def saddle_region_states(system) -> np.ndarray:
    """Starts on y = 7 near the top saddle at E_c + 0.2, both signs of p_y (as in test_barbanis.py)."""
    energy = E_C + 0.2
    rows = []
    for x in (5.0, 5.3, 5.9):
        for px in (-0.4, 0.1, 0.3):
            kinetic = 2.0 * (energy - system.potential(np.array([x, 7.0]))) - px * px
            if kinetic > 0.0:
                rows += [(x, 7.0, px, math.sqrt(kinetic)), (x, 7.0, px, -math.sqrt(kinetic))]
    return np.array(rows)


@pytest.mark.parametrize("p", [0.5, "arclength"])
@pytest.mark.parametrize("direction", [+1, -1])
def test_region_exits_like_dop853(barbanis, p, direction):
    # Variable time: a box around the top saddle; every start leaves it (over the saddle or
    # back into the well). Independent method: dop853 at rtol 1e-13, exit located on its
    # interpolant; the Taylor scheme locates the exit on its own series.
    lower, upper = (4.0, 5.5), (7.0, 8.5)
    states = saddle_region_states(barbanis)
    assert len(states) >= 12
    common = dict(p=p, tau=20.0, region_lower=lower, region_upper=upper)
    result = compute_ld(barbanis, states, direction, taylor(BARBANIS_ORDER, 1e-12, **common))
    reference = compute_ld(barbanis, states, direction, LDSettings(rtol=1e-13, atol=1e-13, **common))
    assert reference.left_region.all()
    np.testing.assert_array_equal(result.left_region, reference.left_region)
    assert not (result.failed | result.escaped).any()
    assert_finite(result)
    assert np.all(result.time < 20.0)
    assert relative(result.time, reference.time).max() < 1e-8
    assert relative(result.ld, reference.ld).max() < 1e-9


# --- 3. cubic monomials and a constant force ------------------------------------------------------
QUARTIC_G = 0.7
QUARTIC_FORMULA = "(x**2 + y**2)/2 + x**2*y**2/2 + x**4/4 + g*y"


@pytest.fixture(scope="module")
def quartic():
    # V >= (x^2 + y^2)/2 - g |y| grows without bound: every orbit is bounded.
    spec = {"formula": QUARTIC_FORMULA, "coordinates": ["x", "y"], "parameters": {"g": QUARTIC_G}}
    return make_system("quartic_force", spec)


def quartic_field(state):
    """Hamilton's equations of QUARTIC_FORMULA, derived by hand (independent of sympy)."""
    x, y, px, py = state
    return np.array([px, py, -(x + x * y * y + x**3), -(y + x * x * y + QUARTIC_G)])


def quartic_energy(state):
    x, y, px, py = state
    return 0.5 * (px * px + py * py) + 0.5 * (x * x + y * y) + 0.5 * x * x * y * y + 0.25 * x**4 + QUARTIC_G * y


def quartic_reference(state, tau):
    """M_1 and the arc length over [0, tau] by scipy (see support.scipy_reference)."""
    return m1_and_arclength(quartic_field, state, tau)


def test_quartic_acceleration_is_the_hand_derivative(quartic):
    # -grad V by hand: a_x = -x - x y^2 - x^3, a_y = -y - x^2 y - g. The cubic monomials need
    # products of products (x y then x y y; x x then x x x and x x y), and a_y has a constant.
    acceleration = acceleration_of(quartic)
    terms = [dict(component) for component in acceleration.terms]
    assert terms[0] == {(1, 0): -1.0, (1, 2): -1.0, (3, 0): -1.0}
    assert terms[1] == {(0, 1): -1.0, (2, 1): -1.0, (0, 0): -QUARTIC_G}
    assert any(kind == "product" for left, right in acceleration.products for kind, _ in (left, right))
    assert set(acceleration.monomials) == {(1, 2), (3, 0), (2, 1)}


@pytest.mark.parametrize("direction", [+1, -1])
def test_quartic_with_constant_force_agrees_with_solve_ivp(quartic, direction):
    # Independent method: scipy's DOP853 at rtol 1e-13 on the hand-derived field (a dropped
    # constant term or a wrong Cauchy product would change every trajectory). Backward: the
    # forward reference of (q, -p) (time reversal). Measured forward: M_1 and arc length to
    # 3e-13, energy error 2.2e-12 (E = 3, tau = 20).
    rng = np.random.default_rng(5)
    energy, rows = 3.0, []
    while len(rows) < 8:
        x, y = rng.uniform(-1.5, 1.5, 2)
        kinetic = 2.0 * (energy - quartic_energy((x, y, 0.0, 0.0)))
        if kinetic > 0.0:
            angle = rng.uniform(0.0, 2.0 * math.pi)
            rows.append((x, y, math.sqrt(kinetic) * math.cos(angle), math.sqrt(kinetic) * math.sin(angle)))
    states = np.array(rows)
    tau = 20.0
    m1 = compute_ld(quartic, states, direction, taylor(FORMULA_ORDER, 1e-12, p=1.0, tau=tau))
    arc = compute_ld(quartic, states, direction, taylor(FORMULA_ORDER, 1e-12, p="arclength", tau=tau))
    flip = np.array([1, 1, direction, direction])
    reference = np.array([quartic_reference(state * flip, tau) for state in states])
    for result in (m1, arc):
        assert not (result.failed | result.escaped).any() and np.all(result.time == tau)
        assert result.energy_error.max() < 2e-11
    assert relative(m1.ld, reference[:, 0]).max() < 5e-12
    assert relative(arc.ld, reference[:, 1]).max() < 5e-12


# --- 4. potentials that are not polynomials: tests/engine/test_taylor_formulas.py ------------------


# --- 7. settings -------------------------------------------------------------------------------------
@pytest.mark.parametrize("value", [MIN_ORDER - 1, MAX_ORDER + 1, 0, -5, 12.0, True, "12"])
def test_taylor_order_is_validated(value):
    with pytest.raises(ValueError, match="taylor_order"):
        LDSettings(scheme="taylor", taylor_order=value)


def test_taylor_order_limits_are_accepted():
    assert LDSettings(scheme="taylor", taylor_order=MIN_ORDER).order == MIN_ORDER == 4
    assert LDSettings(scheme="taylor", taylor_order=MAX_ORDER).order == MAX_ORDER == 40


def test_default_order_follows_jorba_zou():
    # ceil(-ln(tol) / 2) + 1 with tol = min(rtol, atol) (Jorba & Zou), worked by hand:
    # -ln 1e-8 = 18.42 -> 10 + 1; -ln 1e-10 = 23.03 -> 12 + 1; -ln 1e-12 = 27.63 -> 14 + 1;
    # -ln 1e-14 = 32.24 -> 17 + 1. The arc length takes five orders more, |v|^p two less
    # (the measured optima documented in LDSettings.order).
    for tolerance, jorba_zou in ((1e-8, 11), (1e-10, 13), (1e-12, 15), (1e-14, 18)):
        assert jorba_zou == math.ceil(-math.log(tolerance) / 2.0) + 1
        assert LDSettings(scheme="taylor", rtol=tolerance, atol=tolerance, p="arclength").order == jorba_zou + 5
        assert LDSettings(scheme="taylor", rtol=tolerance, atol=tolerance, p=0.5).order == jorba_zou - 2
    # the smaller of the two tolerances decides
    assert LDSettings(scheme="taylor", rtol=1e-6, atol=1e-12, p="arclength").order == 20
    assert LDSettings(scheme="taylor", rtol=1e-12, atol=1e-6, p="arclength").order == 20
    # clipped to [MIN_ORDER, MAX_ORDER]: -ln 0.5 / 2 -> 1 + 1 = 2, so 7 for the arc length and
    # 0 -> 4 for |v|^p; -ln 1e-300 / 2 -> 347 -> 40
    assert LDSettings(scheme="taylor", rtol=0.5, atol=0.5, p="arclength").order == 7
    assert LDSettings(scheme="taylor", rtol=0.5, atol=0.5, p=0.5).order == MIN_ORDER
    assert LDSettings(scheme="taylor", rtol=1e-10, atol=1e-300, p="arclength").order == MAX_ORDER
    # an explicit order wins; the other schemes have none
    assert LDSettings(scheme="taylor", rtol=1e-12, atol=1e-12, taylor_order=9).order == 9
    assert LDSettings(scheme="dop853").order is None
    assert LDSettings(scheme="rk4").order is None


def test_polynomial_with_symbolic_constant_is_accepted():
    # V = pi x^2 / 2 + y^2 / 2 is a polynomial; a_x = -pi x by hand.
    system = make_system("pi_oscillator", {"formula": "pi*x**2/2 + y**2/2", "coordinates": ["x", "y"]})
    terms = [dict(component) for component in acceleration_of(system).terms]
    assert terms[0] == pytest.approx({(1, 0): -math.pi}) and terms[1] == {(0, 1): -1.0}


# --- a double root at a step's start: a near-touch of width 0 --------------------------------------


def test_double_root_at_the_start(barbanis):
    # At x = 5.5 a_y = 0.22 y (x - 5.5) vanishes, and with p_x = 0 x - 5.5 ~ -0.055 t^2: the
    # velocity component p_y' has a double root at t = 0. Reference: dop853 at rtol 1e-13
    # (within 5e-13 of an mpmath Taylor integration at 30 digits, tanh-sinh quadrature cut at
    # the roots). Taken as a root instead of a dip: Taylor 1.7e-8 over its one step of 0.05; over
    # tau = 0.3, 2.3e-8 at rtol 1e-10 and 1.2e-8 at 1e-12 (not following the tolerance). The
    # same case against the independent reference: tests/engine/test_near_touch.py.
    kinetic = 2.0 * (E_C + 0.2 - barbanis.potential(np.array([5.5, 7.0])))
    state = np.array([[5.5, 7.0, 0.0, math.sqrt(kinetic)]])
    result = compute_ld(barbanis, state, +1, taylor(BARBANIS_ORDER, 1e-12, p=0.5, tau=0.05))
    reference = compute_ld(barbanis, state, +1, LDSettings(rtol=1e-13, atol=1e-13, p=0.5, tau=0.05))
    assert relative(result.ld, reference.ld)[0] < 1e-10
