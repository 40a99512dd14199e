"""The reference LD (ldpipe.testing.reference_ld, used by the benchmarks) against closed forms.

The closed form of M_p for harmonic motion (support.closed_forms, through the Beta function) is
itself checked against a brute-force quadrature first.

The reference judges the engine down to 2e-13 (taylor at fixed times in test_taylor.py,
test_taylor_formulas.py and test_near_touch.py), so its own checks sit a few times above what it
achieves and below that: 5e-14 at fixed times (measured ~2e-14), 5e-13 where a box exit is
located (the event's root; measured ~2e-13), where the engine is judged to 1e-10 at best
(test_robustness.py).
"""

from __future__ import annotations

import numpy as np
import pytest

from ldpipe.testing import reference_ld as reference
from support.closed_forms import cos_power_antiderivative, harmonic_ld


def test_closed_form_sanity():
    # F = cos_power_antiderivative against a brute-force quadrature, so the test's own formula is checked too
    from scipy.integrate import quad

    for u in (0.3, 2.0, 7.5, 40.0):
        brute = sum(quad(lambda s: abs(np.cos(s)) ** 0.5, a, b, limit=200)[0]
                    for a, b in zip(np.arange(0, u, np.pi / 2), np.minimum(np.arange(0, u, np.pi / 2) + np.pi / 2, u)))
        assert cos_power_antiderivative(u, 0.5) == pytest.approx(brute, rel=1e-12)


@pytest.mark.parametrize("state0", [(0.7, -0.4, 0.3, 1.1), (2.0, 0.0, 0.0, 0.5), (-1.3, 0.9, -0.8, 0.0)])
def test_mp_half_harmonic_2dof(state0):
    omegas = (1.0, 1.3)  # V = (x^2 + 1.69 y^2) / 2
    tau = 20.0
    r = reference.reference_ld(np.array(state0), tau, 0.5, field=reference.harmonic_vector_field(omegas))
    exact = harmonic_ld(np.array(state0), omegas, tau, 0.5)
    assert r.ld == pytest.approx(exact, rel=5e-14, abs=0)  # measured 1.3e-14 to 1.8e-14
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
        assert r.arclength == pytest.approx(np.hypot(*s) * 17.3, rel=5e-14)  # measured 1.8e-14, 2.0e-14


def test_exit_time_box():
    # x = sin t, p = cos t leaves |x| <= 1/2 at t = pi/6
    field = reference.harmonic_vector_field((1.0,))
    r = reference.reference_ld(np.array([0.0, 1.0]), 50.0, 0.5, field=field, box={0: (-0.5, 0.5)})
    assert r.exited
    # measured: exit time 1.7e-13, M_1/2 2.0e-13, arc length 1.8e-13 (the located exit limits all three)
    assert r.t_end == pytest.approx(np.pi / 6, rel=5e-13)
    exact = harmonic_ld(np.array([0.0, 1.0]), (1.0,), np.pi / 6, 0.5)
    assert r.ld == pytest.approx(exact, rel=5e-13)
    assert r.arclength == pytest.approx(np.pi / 6, rel=5e-13)


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


def _touch_field(centre, a):
    """u' = 1, w' = (u - centre)^2 + a: w' dips to a at t = centre (a near-touch for small a > 0,
    a pair of roots 2 sqrt(-a) apart for a < 0)."""

    def field(state):
        u = np.asarray(state)[0]
        return np.array([np.ones_like(u), (u - centre) ** 2 + a])

    return field


def _sqrt_quadratic_integral(a, lo, hi):
    """int_lo^hi sqrt|s^2 + a| ds in closed form (antiderivatives of sqrt(s^2 + a) and sqrt(-a - s^2))."""
    if a > 0.0:
        def f(s):
            return 0.5 * (s * np.sqrt(s * s + a) + a * np.log(s + np.sqrt(s * s + a)))

        return f(hi) - f(lo)
    b = -a
    r = np.sqrt(b)

    def outer(s):  # s >= r
        return 0.5 * (s * np.sqrt(s * s - b) - b * np.log(s + np.sqrt(s * s - b)))

    inner = 0.5 * np.pi * b  # int_-r^r sqrt(b - s^2) ds
    return (outer(hi) - outer(r)) + (outer(-lo) - outer(r)) + inner  # lo < -r < r < hi


@pytest.mark.parametrize("a", [1e-2, 1e-6, 1e-10, 1e-14, -1e-2, -1e-6, -1e-10])
def test_near_touch_and_close_root_pair_closed_form(a):
    # M_1/2 over tau = 2 of u' = 1 (contributes tau) and w' = (t - 0.7)^2 + a, in closed form.
    # a > 0: |w'| dips to a without crossing (the minimum is located, no crossing); a < 0: two
    # crossings closer than the sampling of the steps (found from the minimum's sign).
    r = reference.reference_ld(np.array([0.0, 0.0]), 2.0, 0.5, field=_touch_field(0.7, a))
    exact = 2.0 + _sqrt_quadratic_integral(a, -0.7, 1.3)
    assert r.ld == pytest.approx(exact, rel=5e-14, abs=0)  # measured at most 2.4e-14 (a = 1e-14)
    assert (r.n_minima, r.n_crossings) == ((1, 0) if a > 0 else (0, 2))
