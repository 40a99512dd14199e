"""LD of uncoupled harmonic oscillators against closed forms.

The closed form (Beta functions, derived in tests/support/closed_forms.py) is itself checked
here, and the engine's schemes and settings are measured against it.
"""

import math

import numpy as np
import pytest
from scipy.special import beta

from ldpipe.engine import LDSettings, compute_ld
from support.closed_forms import STATES, WX, cos_power_antiderivative, oscillator_ld


def relative_errors(result, states, tau, p):
    exact = np.array([oscillator_ld(s, tau, p) for s in states])
    return np.abs(result.ld - exact) / exact


def test_antiderivative_matches_half_periods():
    # Independent check of the helper: a whole number of half periods is k * B(1/2, (p+1)/2), and
    # for p = 1 the integral of |cos| over [0, theta] is elementary.
    for p in (0.5, 0.25, 1.0):
        assert cos_power_antiderivative(7 * math.pi, p) == pytest.approx(7 * beta(0.5, (p + 1) / 2), rel=1e-14)
    assert cos_power_antiderivative(2.0, 1.0) == pytest.approx(1.0 + (1.0 - math.sin(2.0)), rel=1e-14)


def test_whole_half_periods_single_oscillator(oscillator):
    # Motion in x only (y = py = 0), tau = 12 half periods of wx = 1: each of the two nonzero
    # components contributes 12 * |C|^p * B(1/2, (p+1)/2) / w (closed form, no phases involved).
    state = np.array([[0.6, 0.0, 0.8, 0.0]])  # amplitude 1
    tau = 12 * math.pi / WX
    for p in (0.5, 1.0):
        exact = 12 * (1.0**p + (WX * 1.0) ** p) * beta(0.5, (p + 1) / 2) / WX
        result = compute_ld(oscillator, state, +1, LDSettings(rtol=1e-12, atol=1e-12, p=p, tau=tau))
        assert abs(result.ld[0] - exact) / exact < 1e-10
        assert result.time[0] == tau and not result.escaped[0] and not result.failed[0]


def test_arclength_single_oscillator(oscillator):
    # With wx = 1 and y = py = 0, ||x'||^2 = px^2 + x^2 = 2E is constant: arc length = sqrt(2E) tau.
    state = np.array([[0.6, 0.0, -1.2, 0.0]])
    tau = 17.3
    result = compute_ld(oscillator, state, +1, LDSettings(rtol=1e-12, atol=1e-12, p="arclength", tau=tau))
    exact = math.hypot(0.6, 1.2) * tau
    assert abs(result.ld[0] - exact) / exact < 1e-11


@pytest.mark.parametrize("p", [0.5, 1.0])
def test_dop853_converges_with_tolerance(oscillator, p):
    # Generic tau (no whole number of periods of either frequency): closed form via F.
    tau = 23.7
    errors = []
    for tol in (1e-6, 1e-8, 1e-10, 1e-12):
        result = compute_ld(oscillator, STATES, +1, LDSettings(rtol=tol, atol=tol, p=p, tau=tau))
        assert not result.failed.any()
        errors.append(relative_errors(result, STATES, tau, p).max())
    # the error follows the tolerance down to the 1e-8 target and below
    assert errors[0] < 1e-4
    assert errors[2] < 1e-8
    assert errors[3] < 1e-10
    assert errors[3] < errors[1] < errors[0]


def test_dop853_general_exponent(oscillator):
    # p = 0.3 takes the general |v|**p path (Gauss–Jacobi with weight s^0.3 at the cusps).
    tau = 9.1
    result = compute_ld(oscillator, STATES, -1, LDSettings(rtol=1e-12, atol=1e-12, p=0.3, tau=tau))
    # backward time: the LD over [-tau, 0] of the state equals the forward LD of the
    # time-reversed state (q, -p), here in closed form.
    reversed_states = STATES * np.array([1, 1, -1, -1])
    assert relative_errors(result, reversed_states, tau, 0.3).max() < 1e-9


@pytest.mark.parametrize("scheme,order", [("rk4", 4), ("sym4", 4)])
def test_fixed_step_order(oscillator, scheme, order):
    # Halving dt divides the LD error by about 2^order (4th-order schemes, 5th-order Hermite
    # dense output, cusp-aware quadrature: no h^(3/2) floor).
    tau = 23.7
    errors = []
    for dt in (0.1, 0.05, 0.025):
        result = compute_ld(oscillator, STATES, +1, LDSettings(scheme=scheme, dt=dt, p=0.5, tau=tau))
        assert (result.steps == math.ceil(tau / dt)).all()  # work: exactly ceil(tau/dt) steps
        errors.append(relative_errors(result, STATES, tau, 0.5).max())
    assert errors[2] < 2e-8
    for coarse, fine in zip(errors, errors[1:]):
        assert coarse / fine > 0.75 * 2**order


def test_sym6_reaches_tight_accuracy(oscillator):
    result = compute_ld(oscillator, STATES, +1, LDSettings(scheme="sym6", dt=0.02, p=0.5, tau=23.7))
    assert relative_errors(result, STATES, 23.7, 0.5).max() < 1e-8


def test_equilibrium_and_zero_velocity_start(oscillator):
    # At the equilibrium every velocity vanishes for all time: M_p = 0. A start with p = 0
    # (a turning point) has |v|^p non-smooth at t = 0; the closed form still holds.
    states = np.array([[0.0, 0.0, 0.0, 0.0], [0.9, -0.4, 0.0, 0.0]])
    result = compute_ld(oscillator, states, +1, LDSettings(rtol=1e-12, atol=1e-12, p=0.5, tau=8.0))
    assert result.ld[0] == 0.0
    exact = oscillator_ld(states[1], 8.0, 0.5)
    assert abs(result.ld[1] - exact) / exact < 1e-10
    assert np.isfinite(result.ld).all() and not result.failed.any()


@pytest.mark.parametrize("p", [0.5, 0.3])
def test_default_quadrature_follows_the_tolerance(oscillator, p):
    # The default node count and cusp window depend on rtol (LDSettings.nodes,
    # LDSettings.quadrature_window); at every tolerance the closed form is met to a few rtol
    # (scaled error < 5, as in scipy's tests), so the cheaper quadrature at loose tolerances
    # costs no accuracy that the integration keeps.
    rng = np.random.default_rng(3)
    states = np.vstack([STATES, rng.normal(size=(12, 4))])
    for tol in (1e-4, 1e-5, 1e-6, 1e-10):
        result = compute_ld(oscillator, states, +1, LDSettings(rtol=tol, atol=tol, p=p, tau=23.7))
        assert relative_errors(result, states, 23.7, p).max() / tol < 5.0


@pytest.mark.parametrize("window", [0.2, 0.5, 1.0])
def test_cusp_window_paths(oscillator, window):
    # Larger windows send more steps through the cusp path with a root outside the step
    # (Gauss–Jacobi from the extrapolated root, or the Gauss–Legendre value kept when the
    # extrapolated root does not exist); every window meets the closed form at rtol 1e-10.
    rng = np.random.default_rng(4)
    states = np.vstack([STATES, rng.normal(size=(12, 4))])
    settings = LDSettings(rtol=1e-10, atol=1e-10, p=0.5, tau=23.7, window=window)
    assert settings.quadrature_window == window
    result = compute_ld(oscillator, states, +1, settings)
    assert relative_errors(result, states, 23.7, 0.5).max() < 2e-10
