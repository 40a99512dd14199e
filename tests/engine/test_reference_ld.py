"""The benchmark's reference LD (benchmarks/reference.py) against closed forms.

Closed form of M_p for harmonic motion.  With G(u) = int_0^u |cos s|^p ds:
  * |cos|^p has period pi and int_0^pi |cos s|^p ds = B(1/2, (p+1)/2)  (Beta function);
  * for 0 <= u <= pi/2, substituting w = sin^2 s (ds = dw / (2 sqrt(w) sqrt(1-w))):
        int_0^u cos^p s ds = 1/2 int_0^{sin^2 u} w^{-1/2} (1-w)^{(p-1)/2} dw
                           = 1/2 B(1/2, (p+1)/2) I_{sin^2 u}(1/2, (p+1)/2),
    I the regularized incomplete Beta function (scipy.special.betainc);
  * on [pi/2, pi] use the symmetry G(u) = B - G(pi - u); G(u + k pi) = k B + G(u); G odd.
Then int_0^tau |A cos(w t + phi)|^p dt = A^p (G(w tau + phi) - G(phi)) / w, and |sin x| = |cos(x - pi/2)|.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.special import beta as beta_fn
from scipy.special import betainc

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import reference  # noqa: E402


def _G(u: float, p: float) -> float:
    """int_0^u |cos s|^p ds, via the (incomplete) Beta function."""
    if u < 0:
        return -_G(-u, p)
    full = beta_fn(0.5, 0.5 * (p + 1.0))
    k, r = divmod(u, np.pi)

    def half(v):  # 0 <= v <= pi/2
        return 0.5 * full * betainc(0.5, 0.5 * (p + 1.0), np.sin(v) ** 2)

    part = half(r) if r <= 0.5 * np.pi else full - half(np.pi - r)
    return k * full + part


def _int_abs_cos(amplitude, omega, phase, t0, t1, p):
    """int_t0^t1 |amplitude cos(omega t + phase)|^p dt, omega > 0."""
    return abs(amplitude) ** p * (_G(omega * t1 + phase, p) - _G(omega * t0 + phase, p)) / omega


def _harmonic_mp(state0, omegas, tau, p, t0=0.0):
    """Closed-form M_p over [t0, tau] for uncoupled oscillators; state (q..., p...)."""
    n = len(omegas)
    total = 0.0
    for q0, p0, w in zip(state0[:n], state0[n:], omegas):
        # q = A cos(w t + phi), dq/dt = -A w sin(w t + phi), dp/dt = -A w^2 cos(w t + phi)
        amplitude = np.hypot(q0, p0 / w)
        phase = np.arctan2(-p0 / w, q0)
        total += _int_abs_cos(amplitude * w, w, phase - 0.5 * np.pi, t0, tau, p)  # |sin| part
        total += _int_abs_cos(amplitude * w * w, w, phase, t0, tau, p)
    return total


def test_closed_form_sanity():
    # G against a brute-force quadrature, so the test's own formula is checked too
    from scipy.integrate import quad

    for u in (0.3, 2.0, 7.5, 40.0):
        brute = sum(quad(lambda s: abs(np.cos(s)) ** 0.5, a, b, limit=200)[0]
                    for a, b in zip(np.arange(0, u, np.pi / 2), np.minimum(np.arange(0, u, np.pi / 2) + np.pi / 2, u)))
        assert _G(u, 0.5) == pytest.approx(brute, rel=1e-12)


@pytest.mark.parametrize("state0", [(0.7, -0.4, 0.3, 1.1), (2.0, 0.0, 0.0, 0.5), (-1.3, 0.9, -0.8, 0.0)])
def test_mp_half_harmonic_2dof(state0):
    omegas = (1.0, 1.3)  # V = (x^2 + 1.69 y^2) / 2
    tau = 20.0
    r = reference.reference_ld(np.array(state0), tau, 0.5, field=reference.harmonic_vector_field(omegas))
    exact = _harmonic_mp(np.array(state0), omegas, tau, 0.5)
    assert r.ld == pytest.approx(exact, rel=1e-9, abs=0)
    assert r.n_crossings > 20


def test_mp_backward_equals_forward_for_reversible_flow():
    # time reversal (q, p) -> (q, -p): backward LD from (q, p) equals forward LD from (q, -p)
    field = reference.harmonic_vector_field((1.0, 1.3))
    s = np.array([0.7, -0.4, 0.3, 1.1])
    back = reference.reference_ld(s, 10.0, 0.5, field=field, direction=-1)
    fwd = reference.reference_ld(s * np.array([1, 1, -1, -1]), 10.0, 0.5, field=field)
    assert back.ld == pytest.approx(fwd.ld, rel=1e-11)


def test_arclength_1dof_circle():
    # omega = 1: the phase-space orbit is a circle of radius r traversed at speed r
    field = reference.harmonic_vector_field((1.0,))
    for s in ([1.5, 0.0], [0.3, -2.0]):
        r = reference.reference_ld(np.array(s), 17.3, 0.5, field=field)
        assert r.arclength == pytest.approx(np.hypot(*s) * 17.3, rel=1e-10)


def test_exit_time_box():
    # x = sin t, p = cos t leaves |x| <= 1/2 at t = pi/6
    field = reference.harmonic_vector_field((1.0,))
    r = reference.reference_ld(np.array([0.0, 1.0]), 50.0, 0.5, field=field, box={0: (-0.5, 0.5)})
    assert r.exited
    assert r.t_end == pytest.approx(np.pi / 6, rel=1e-12)
    exact = _harmonic_mp(np.array([0.0, 1.0]), (1.0,), np.pi / 6, 0.5)
    assert r.ld == pytest.approx(exact, rel=1e-9)
    assert r.arclength == pytest.approx(np.pi / 6, rel=1e-10)


def test_no_exit_when_box_contains_orbit():
    field = reference.harmonic_vector_field((1.0,))
    r = reference.reference_ld(np.array([0.0, 1.0]), 5.0, 0.5, field=field, box={0: (-2.0, 2.0)})
    assert not r.exited and r.t_end == 5.0


def test_barbanis_quadratures_agree():
    # the fast Gauss-Jacobi path and the adaptive QUADPACK QAWS path on the real problem
    s, ok = reference.section_state(1.0, 0.5, reference.E_SADDLE - 0.125)
    assert ok
    a = reference.reference_ld(s, 10.0)
    b = reference.reference_ld(s, 10.0, quadrature="qaws")
    assert a.ld == pytest.approx(b.ld, rel=1e-12)
    assert a.arclength == pytest.approx(b.arclength, rel=1e-12)
