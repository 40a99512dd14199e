"""LD of uncoupled harmonic oscillators in closed form, and the oscillator system the tests integrate.

For V = sum_i w_i^2 q_i^2 / 2 each coordinate is q(t) = A cos(w t + phi), so every velocity
component is of the form C cos(w t + psi): q' = A w cos(w t + phi + pi/2) and
p' = -w^2 q = A w^2 cos(w t + phi + pi). Hence

    int_t0^tau |C cos(w t + psi)|^p dt = |C|^p / w * (F(w tau + psi) - F(w t0 + psi)),
    F(theta) = int_0^theta |cos u|^p du,

and F is a closed form through the Beta function: over a half period
F(pi) = B(1/2, (p+1)/2), and for 0 <= u <= pi/2, int_0^u cos^p = B(sin^2 u; 1/2, (p+1)/2)/2
(the incomplete Beta function, substituting s = sin^2). F(theta + pi) = F(theta) + F(pi),
F(-theta) = -F(theta).

The engine's tests (tests/engine/test_closed_form.py checks F itself, tests/engine/test_reference_ld.py
against a brute-force quadrature) and the accuracy stage's tests integrate the two oscillators
of frequencies (WX, WY) built by :func:`oscillator_system` (conftest.py's ``oscillator`` fixture).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.special import beta, betainc

from ldpipe.systems import System, make_system

WX, WY = 1.0, 1.3
OSCILLATOR_SPEC = {"formula": "(wx**2*x**2 + wy**2*y**2)/2", "coordinates": ["x", "y"], "parameters": {"wx": WX, "wy": WY}}

# Generic states (x, y, px, py) of the oscillators: every velocity component crosses zero in tau.
STATES = np.array([[1.0, 0.5, 0.3, -0.2], [-0.7, 0.1, 1.1, 0.9], [0.2, -1.3, -0.4, 0.05], [0.0, 0.8, 1.0, 0.0]])


def oscillator_system() -> System:
    """The two uncoupled oscillators of frequencies (WX, WY), a formula system (make_system caches it)."""
    return make_system("ho", OSCILLATOR_SPEC)


def cos_power_antiderivative(theta: float, p: float) -> float:
    """F(theta) = int_0^theta |cos u|^p du, from the (incomplete) Beta function."""
    if theta < 0.0:
        return -cos_power_antiderivative(-theta, p)
    half = beta(0.5, (p + 1.0) / 2.0)
    k, u = divmod(theta, math.pi)

    def quarter(v):  # int_0^v cos^p, 0 <= v <= pi/2
        return 0.5 * half * betainc(0.5, (p + 1.0) / 2.0, math.sin(v) ** 2)

    inner = quarter(u) if u <= math.pi / 2 else half - quarter(math.pi - u)
    return k * half + inner


def harmonic_ld(state, omegas, tau: float, p: float, t0: float = 0.0) -> float:
    """Closed-form M_p over [t0, tau] of uncoupled oscillators of frequencies ``omegas``; state (q..., p...)."""
    n = len(omegas)
    total = 0.0
    for q0, p0, w in zip(state[:n], state[n:], omegas):
        amplitude = math.hypot(q0, p0 / w)
        if amplitude == 0.0:
            continue
        phase = math.atan2(-p0 / w, q0)  # q = A cos(w t + phase)
        for c, psi in ((amplitude * w, phase + math.pi / 2), (amplitude * w * w, phase + math.pi)):
            total += c**p / w * (cos_power_antiderivative(w * tau + psi, p) - cos_power_antiderivative(w * t0 + psi, p))
    return total


def oscillator_ld(state, tau: float, p: float) -> float:
    """Closed-form M_p over [0, tau] of the two oscillators of :func:`oscillator_system`."""
    return harmonic_ld(state, (WX, WY), tau, p)


def linear_saddle_ld(x0: float, y0: float, lam: float, tau: float, p: float, direction: int = 1) -> float:
    """M_p of dx/dt = lam x, dy/dt = -lam y from (x0, y0) over |t| <= tau, direction +1 or -1.

    x(t) = x0 e^(lam t), so |dx/dt|^p = |lam x0|^p e^(p lam t), and
    int_0^tau e^(p lam t) dt = (e^(p lam tau) - 1) / (p lam); y the same with -lam; backward
    the two exchange.
    """
    grow = (math.exp(p * lam * tau) - 1.0) / (p * lam)
    shrink = (1.0 - math.exp(-p * lam * tau)) / (p * lam)
    fx, fy = (grow, shrink) if direction == 1 else (shrink, grow)
    return abs(lam * x0) ** p * fx + abs(lam * y0) ** p * fy


def forced_growth_solution(x0: float, t0: float, t: float) -> float:
    """x(t) of dx/dt = (1 + cos t) x with x(t0) = x0: x0 exp(t - t0 + sin t - sin t0)."""
    return x0 * math.exp(t - t0 + math.sin(t) - math.sin(t0))


def massive_harmonic_ld(state, stiffnesses, masses, tau: float, p: float) -> float:
    """Closed-form M_p over [0, tau] of uncoupled oscillators V = sum k_i q_i^2 / 2 with masses m_i.

    H = sum p_i^2 / (2 m_i) + k_i q_i^2 / 2: q = A cos(w t + phase) with w = sqrt(k / m) and
    q'(0) = p0 / m, so A = hypot(q0, p0 / (m w)); the velocity components are q' = A w cos(w t +
    phase + pi/2) and p' = -k q = A k cos(w t + phase + pi), each of the form C cos(w t + psi).
    With every m = 1 this is :func:`harmonic_ld`.
    """
    n = len(stiffnesses)
    total = 0.0
    for q0, p0, k, m in zip(state[:n], state[n:], stiffnesses, masses):
        w = math.sqrt(k / m)
        v0 = p0 / m
        amplitude = math.hypot(q0, v0 / w)
        if amplitude == 0.0:
            continue
        phase = math.atan2(-v0 / w, q0)
        for c, psi in ((amplitude * w, phase + math.pi / 2), (amplitude * k, phase + math.pi)):
            total += c**p / w * (cos_power_antiderivative(w * tau + psi, p) - cos_power_antiderivative(psi, p))
    return total
