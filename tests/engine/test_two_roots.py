"""The rule for a step whose velocity component has two roots in or beside it.

``special`` sends an item with two sign changes on its samples (0, the Gauss nodes, 1), no root
near either end outside and no zero end to ``two_roots`` (block_two_roots.py): both roots by
safeguarded Newton, the pieces [0, r1], [r1, r2], [r2, 1] by Gauss–Jacobi from the roots with
``_from_root``'s grading where the roots are close. So it does an item with one sign change and
a root within the window beyond an end (found by linear extrapolation, or where v moves away from
zero at the end and curves back), with the piece beyond the end taken away. Expected values are
int_0^1 |v|^p by mpmath at 30 digits (tanh-sinh cut at the roots and minima, graded:
``support.step_integral``), an independent method; the tolerance 1e-12 relative with 8 nodes is
that of the scalar rule's STEP_CASES in test_near_touch.py (a singularity one piece length beyond
a piece's end: rho = 3 + 2 sqrt 2, rho^-16 ~ 6e-13).
"""

from __future__ import annotations

import numpy as np
import pytest

from ldpipe.engine.gauss_rules import legendre_rule
from support.step_integral import from_roots, mpmath_step_integral
from support.step_rules import integrand_kind, rule_engine, rules


WINDOW = 0.1  # dop853's at loose tolerances, where two roots in a step are common
NODES = 8

# v on [0, 1] from its roots; the third root (or the complex pair) far outside. Each has exactly
# two sign changes on the 8-node sample grid (asserted below) and no root near an end outside.
TWO_ROOT_CASES = {
    "apart": from_roots(0.3, 0.7, 3.0),
    # the middle piece shorter than both outer ones: the graded rule on both sides (d = 0.11 / 0.5)
    "close, graded": from_roots(0.5, 0.61, -2.5),
    "near both ends": from_roots(0.01, 0.985, 2.0 + 1j, 2.0 - 1j),
    "near the start, graded": from_roots(0.004, 0.08, -1.5),
    "near the end": from_roots(0.55, 0.96, 1.7, 2.5),
}
# closer than the graded rule reaches (gap < 2^-GRADING_LEVELS of an outer piece): the scalar path
TOO_CLOSE = from_roots(0.58, 0.6, 3.0)
# one root inside and one within WINDOW beyond an end; "midpoint beyond" has m = (r1 + r2) / 2
# past the end, and v moving away from zero at that end (linear extrapolation finds no root)
ROOT_BESIDE_CASES = {
    "right": from_roots(0.4, 1.05, 3.0),
    "right, midpoint beyond": from_roots(0.97, 1.04, -2.0),
    "right, graded": from_roots(0.9, 1.02, 1.5, 2.5),
    "left": from_roots(-0.05, 0.6, 2.5),
    "left, midpoint beyond": from_roots(-0.04, 0.03, 2.0),
}


@pytest.fixture(scope="module")
def engine():
    return rule_engine()


def _two_roots(engine, polynomials, nodes=NODES, p=0.5):
    """``two_roots`` on items marked TWO_ROOTS: (values, handled there) per polynomial."""
    cb = np.zeros(engine.CB_ROWS * engine.CBS)
    item = np.arange(engine.NCOMP * engine.LANES)
    w = np.full(engine.SIZE, np.nan)  # FC of an item not handled stays NaN
    for t, coefficients in enumerate(polynomials):
        cb[np.arange(len(coefficients)) * engine.CBS + t] = coefficients
        cb[engine.R_OK * engine.CBS + t] = engine.TWO_ROOTS
    engine.two_roots(w, cb, item, len(polynomials), integrand_kind(engine, p), p, *rules(nodes, p))
    ok = cb[engine.R_OK * engine.CBS : engine.R_OK * engine.CBS + len(polynomials)]
    assert set(ok) <= {engine.KEEP_FAST, 0.0}
    return w[engine.OFC : engine.OFC + len(polynomials)], ok == engine.KEEP_FAST


def _special(engine, coefficients, nodes=NODES, p=0.5):
    """FC of one component flagged for the special path, through ``special``'s routing; its sign
    changes on the samples; whether ``two_roots`` did it (R_OK KEEP_FAST after it, where the
    scalar path leaves 0 and the one-root Jacobi pieces 1)."""
    w = np.zeros(engine.SIZE)
    for k, c in enumerate(coefficients):
        w[engine.OVC + k * engine.CS] = c  # component 0, lane 0
    sp = np.zeros((engine.NCOMP, engine.LANES), dtype=np.int8)
    sp[0, 0] = engine.SP_SPECIAL
    cb = np.zeros(engine.CB_ROWS * engine.CBS)
    item = np.zeros(engine.NCOMP * engine.LANES, dtype=np.int64)
    engine.special(w, sp, integrand_kind(engine, p), p, *rules(nodes, p), WINDOW, cb, item, np.zeros(200))
    return w[engine.OFC], cb[engine.R_NSC * engine.CBS], cb[engine.R_OK * engine.CBS] == engine.KEEP_FAST


@pytest.mark.parametrize("name", sorted(TWO_ROOT_CASES))
def test_two_roots_against_mpmath(engine, name):
    coefficients = TWO_ROOT_CASES[name]
    samples = np.r_[0.0, legendre_rule(NODES)[0], 1.0]
    values = np.polynomial.Polynomial(coefficients)(samples)
    assert np.sum(values[:-1] * values[1:] < 0.0) == 2  # the case this rule is for
    value, handled = _two_roots(engine, [coefficients])
    assert handled[0]
    expected = mpmath_step_integral(coefficients)
    assert abs(value[0] - expected) <= 1e-12 * expected
    # and through special's routing (the same rule: the same value)
    routed, nsc, _ = _special(engine, coefficients)
    assert nsc == 2.0
    assert routed == value[0]


def test_general_power_against_mpmath(engine):
    # p = 1/4: the KIND_POW loops; the Jacobi rule for that weight
    coefficients = TWO_ROOT_CASES["close, graded"]
    value, handled = _two_roots(engine, [coefficients], p=0.25)
    assert handled[0]
    expected = mpmath_step_integral(coefficients, 0.25)
    assert abs(value[0] - expected) <= 1e-12 * expected


def test_loose_rule_matches_scalar_path(engine):
    # With dop853's 4 nodes at rtol 1e-4 and 1e-5 the vectorized rule is the scalar path's rule
    # for these steps (same pieces, same grading), so both agree to rounding (an invariant of the
    # design, not an accuracy claim), and both are near mpmath to the 4-node rule's error
    # (rho^-8 ~ 7e-7 per piece, _from_root's docstring; five pieces at most).
    glx, glw, gjx, gjf = rules(4, 0.5)
    cases = [from_roots(0.3, 0.7, 3.0), from_roots(0.3, 0.36, -2.0), from_roots(0.02, 0.9, 1.5, 2.0)]
    values, handled = _two_roots(engine, cases, nodes=4)
    assert handled.all()
    for coefficients, value in zip(cases, values):
        vc = np.zeros((len(coefficients), 1, 1))
        vc[:, 0, 0] = coefficients
        scalar = engine.component_integral(vc, 0, 0, len(coefficients), 1.0, engine.KIND_HALF, 0.5, glx, glw, gjx,
                                           gjf, WINDOW, np.zeros(200))
        assert abs(value - scalar) <= 1e-13 * scalar
        expected = mpmath_step_integral(coefficients)
        assert abs(value - expected) <= 5.0 * 7e-7 * expected


def test_too_close_roots_go_to_the_scalar_path(engine):
    # gap 0.02 < 0.58 / 16: not handled here; special's scalar path then meets the mpmath value
    _, handled = _two_roots(engine, [TOO_CLOSE])
    assert not handled[0]
    routed, nsc, by_two_roots = _special(engine, TOO_CLOSE)
    assert nsc == 2.0 and not by_two_roots
    expected = mpmath_step_integral(TOO_CLOSE)
    assert abs(routed - expected) <= 1e-12 * expected


def test_a_root_just_outside_goes_to_the_scalar_path(engine):
    # a third root 0.05 beyond the end 1: near_right, not this rule's case; the scalar path's
    # value still meets mpmath's
    coefficients = from_roots(0.3, 0.7, 1.05)
    routed, nsc, by_two_roots = _special(engine, coefficients)
    assert nsc == 2.0 and not by_two_roots
    expected = mpmath_step_integral(coefficients)
    assert abs(routed - expected) <= 1e-12 * expected


def test_items_of_other_cases_are_left_alone(engine):
    # the rule picks its items out from among others by R_OK and each value lands on its own
    # item: the same value as the polynomial's alone (an invariant: the rule works item by item),
    # while the other items' R_OK and FC stay untouched
    polynomials = list(TWO_ROOT_CASES.values())
    alone = [_two_roots(engine, [c])[0][0] for c in polynomials]
    cb = np.zeros(engine.CB_ROWS * engine.CBS)
    item = np.arange(engine.NCOMP * engine.LANES)
    w = np.full(engine.SIZE, np.nan)
    other = 1.0  # an item of the Jacobi pieces' case
    m = 2 * len(polynomials) + 1
    for t in range(m):
        mine = t % 2 == 1
        coefficients = polynomials[t // 2] if mine else TOO_CLOSE
        cb[np.arange(len(coefficients)) * engine.CBS + t] = coefficients
        cb[engine.R_OK * engine.CBS + t] = engine.TWO_ROOTS if mine else other
    engine.two_roots(w, cb, item, m, integrand_kind(engine, 0.5), 0.5, *rules(NODES, 0.5))
    fc = w[engine.OFC : engine.OFC + m]
    ok = cb[engine.R_OK * engine.CBS : engine.R_OK * engine.CBS + m]
    assert list(fc[1::2]) == alone
    assert np.isnan(fc[0::2]).all()
    assert (ok[1::2] == engine.KEEP_FAST).all() and (ok[0::2] == other).all()


@pytest.mark.parametrize("name", sorted(ROOT_BESIDE_CASES))
def test_root_beside_an_end_against_mpmath(engine, name):
    coefficients = ROOT_BESIDE_CASES[name]
    value, nsc, by_two_roots = _special(engine, coefficients)
    assert nsc == 1.0 and by_two_roots
    expected = mpmath_step_integral(coefficients)
    assert abs(value - expected) <= 1e-12 * expected


def test_root_beside_an_end_general_power(engine):
    # p = 1/4: the general power (not the square root of p = 1/2), with the piece beyond the end
    # taken away
    coefficients = ROOT_BESIDE_CASES["right"]
    value, _, by_two_roots = _special(engine, coefficients, p=0.25)
    assert by_two_roots
    expected = mpmath_step_integral(coefficients, 0.25)
    assert abs(value - expected) <= 1e-12 * expected


@pytest.mark.parametrize("name", sorted(ROOT_BESIDE_CASES))
def test_root_beside_an_end_loose_rule(engine, name):
    # dop853's 4 nodes (rtol 1e-4, 1e-5): within the 4-node rule's error (rho^-8 ~ 7e-7 per
    # piece, _from_root's docstring; five pieces at most) of mpmath. Before the root beyond the
    # turn was looked for, "midpoint beyond" took the one-root pieces: 7e-5 off (Gauss–Jacobi from
    # r1 towards 0 with the other root 0.07 beyond r1, rho ~ 1.7).
    coefficients = ROOT_BESIDE_CASES[name]
    value, _, by_two_roots = _special(engine, coefficients, nodes=4)
    assert by_two_roots
    expected = mpmath_step_integral(coefficients)
    assert abs(value - expected) <= 5.0 * 7e-7 * expected


def test_no_root_beyond_the_end_goes_to_the_scalar_path(engine):
    # linear extrapolation from the end finds a root within the window, but v turns back before
    # zero (complex roots 1.05 +- 0.05i): no sign change over the search interval, so not this
    # rule's; the scalar path's value meets mpmath's
    coefficients = np.polynomial.Polynomial.fromroots([0.5, 1.05 + 0.05j, 1.05 - 0.05j, 2.0]).coef.real
    value, nsc, by_two_roots = _special(engine, coefficients)
    assert nsc == 1.0 and not by_two_roots
    expected = mpmath_step_integral(coefficients)
    assert abs(value - expected) <= 1e-12 * expected
