"""The rule for a step whose velocity component has a near-touch.

``special`` sends an item without a sign change on its samples, no root near either end and a
possible near-touch to ``one_dip`` (block_dips.py): the scalar path's search for the minimum
x_m of |v| (eps = sqrt(2 v(x_m) / v''(x_m))) and its sinh rule on the pieces next to it.
Expected values are int_0^1 |v|^p by mpmath at 30 digits (``support.step_integral``), an
independent method, to 1e-12 relative with 8 nodes as the scalar rule's STEP_CASES in
test_near_touch.py (the sinh rule's panels: singularities pi / 2 from a panel of width 1,
rho = pi + sqrt(pi^2 + 1) ~ 6.4, rho^-16 ~ 1e-13). What the rule does not take (a root pair, two
dips, a dip too narrow for its panels) goes to the scalar path, whose value meets mpmath too.
"""

from __future__ import annotations

import numpy as np
import pytest

from ldpipe.engine.gauss_rules import legendre_rule
from support.step_integral import from_roots, mpmath_step_integral
from support.step_rules import integrand_kind, rule_engine, rules

WINDOW = 0.2  # dop853's at tight tolerances: the dip width DIP_PER_WINDOW * WINDOW = 0.5
NODES = 8

# v on [0, 1] from its roots: a near-touch x_m +- i eps and a real root far outside (no sign
# change on the scan's samples over [-0.25, 1.25], no root near either end)
DIP_CASES = {
    "inside, narrow": from_roots(0.4 + 1e-3j, 0.4 - 1e-3j, 3.0),
    "inside, wide": from_roots(0.6 + 0.05j, 0.6 - 0.05j, -2.0),
    # eps larger than x_m: the piece [0, x_m] by Gauss–Legendre, [x_m, 1] by the sinh rule
    "near the start": from_roots(0.02 + 0.03j, 0.02 - 0.03j, 2.5),
    "just left": from_roots(-0.05 + 0.01j, -0.05 - 0.01j, 2.0),
    "just right": from_roots(1.1 + 0.02j, 1.1 - 0.02j, -1.5),
}
# for the scalar path: eps 1e-6 needs asinh(0.5 / 1e-6) ~ 14 panels (> MAX_SINH_PANELS); two
# near-touches; a root pair between two scan samples (the minimum reaches the other sign)
SCALAR_CASES = {
    "too narrow": from_roots(0.5 + 1e-6j, 0.5 - 1e-6j, 3.0),
    "two dips": from_roots(0.25 + 1e-3j, 0.25 - 1e-3j, 0.75 + 1e-3j, 0.75 - 1e-3j),
    "root pair": from_roots(0.53, 0.531, 3.0),
}
# Where the minimum of |v| lies and its eps are known from the roots: within the dip width 0.5
# and the scan's range [-0.25, 1.25] a dip is taken (here or by the scalar path); at least the
# width, or beyond the range, none (the Gauss–Legendre value stands)
TAKEN = {
    "narrow dip inside": from_roots(0.4 + 1e-4j, 0.4 - 1e-4j, 3.0),
    "dip of a negative v": -from_roots(0.8 + 0.04j, 0.8 - 0.04j),  # |v| min where v'' < 0
    "dip just right": from_roots(1.02 + 1e-3j, 1.02 - 1e-3j, -3.0),
    "eps 0.45 inside": from_roots(0.5 + 0.45j, 0.5 - 0.45j),
    "root pair beyond the step": from_roots(-0.2445, -0.2434, 3.0),
}
NO_DIP = {
    "eps 0.6 inside": from_roots(0.5 + 0.6j, 0.5 - 0.6j, 3.0),
    "eps 0.8 inside": from_roots(0.5 + 0.8j, 0.5 - 0.8j),
    "eps 0.55 inside": from_roots(0.3 + 0.55j, 0.3 - 0.55j, 4.0),
    "narrow dip beyond the range": from_roots(1.6 + 1e-3j, 1.6 - 1e-3j, -3.0),
}


@pytest.fixture(scope="module")
def engine():
    return rule_engine()


def _one_dip(engine, polynomials, nodes=NODES, p=0.5, window=WINDOW):
    """``one_dip`` on items marked ONE_DIP: (FC, R_OK after) per polynomial; FC stays NaN where
    ``one_dip`` writes nothing."""
    cb = np.zeros(engine.CB_ROWS * engine.CBS)
    item = np.arange(engine.NCOMP * engine.LANES)
    w = np.full(engine.SIZE, np.nan)
    for t, coefficients in enumerate(polynomials):
        cb[np.arange(len(coefficients)) * engine.CBS + t] = coefficients
        cb[engine.R_OK * engine.CBS + t] = engine.ONE_DIP
    glx, glw, _, _ = rules(nodes, p)
    engine.one_dip(w, cb, item, len(polynomials), integrand_kind(engine, p), p, glx, glw, window)
    ok = cb[engine.R_OK * engine.CBS : engine.R_OK * engine.CBS + len(polynomials)]
    assert set(ok) <= {engine.KEEP_FAST, 0.0}
    return w[engine.OFC : engine.OFC + len(polynomials)], ok


def _special(engine, coefficients, fast_value=0.0, nodes=NODES, p=0.5, window=WINDOW):
    """FC of one component flagged for the special path (FC preset to ``fast_value``), through
    ``special``'s routing; and the R_OK it gave the item."""
    w = np.zeros(engine.SIZE)
    for k, c in enumerate(coefficients):
        w[engine.OVC + k * engine.CS] = c  # component 0, lane 0
    w[engine.OFC] = fast_value
    sp = np.zeros((engine.NCOMP, engine.LANES), dtype=np.int8)
    sp[0, 0] = engine.SP_SPECIAL
    cb = np.zeros(engine.CB_ROWS * engine.CBS)
    item = np.zeros(engine.NCOMP * engine.LANES, dtype=np.int64)
    engine.special(w, sp, integrand_kind(engine, p), p, *rules(nodes, p), window, cb, item, np.zeros(200))
    return w[engine.OFC]


def _scalar(engine, coefficients, nodes=NODES, p=0.5, window=WINDOW):
    vc = np.zeros((len(coefficients), 1, 1))
    vc[:, 0, 0] = coefficients
    return engine.component_integral(vc, 0, 0, len(coefficients), 1.0, integrand_kind(engine, p), p, *rules(nodes, p),
                                     window, np.zeros(200))


def _legendre(coefficients, nodes=NODES, p=0.5):
    glx, glw = legendre_rule(nodes)
    return float(np.sum(glw * np.abs(np.polynomial.Polynomial(coefficients)(glx)) ** p))


@pytest.mark.parametrize("name", sorted(DIP_CASES))
def test_one_dip_against_mpmath(engine, name):
    coefficients = DIP_CASES[name]
    value, ok = _one_dip(engine, [coefficients])
    assert ok[0] == engine.KEEP_FAST and not np.isnan(value[0])  # a dip, integrated here
    expected = mpmath_step_integral(coefficients)
    assert abs(value[0] - expected) <= 1e-12 * expected
    # through special's routing (a dip just outside an end may look like a root near it to the
    # linear extrapolation there: the scalar path's rule, the same pieces) the value meets mpmath
    assert abs(_special(engine, coefficients) - expected) <= 1e-12 * expected


def test_general_power_against_mpmath(engine):
    # p = 1/4: the KIND_POW loop
    coefficients = DIP_CASES["inside, narrow"]
    value, ok = _one_dip(engine, [coefficients], p=0.25)
    assert ok[0] == engine.KEEP_FAST
    expected = mpmath_step_integral(coefficients, 0.25)
    assert abs(value[0] - expected) <= 1e-12 * expected


@pytest.mark.parametrize("name", sorted(SCALAR_CASES))
def test_what_it_cannot_take_goes_to_the_scalar_path(engine, name):
    coefficients = SCALAR_CASES[name]
    _, ok = _one_dip(engine, [coefficients])
    assert ok[0] == 0.0
    expected = mpmath_step_integral(coefficients)
    assert abs(_special(engine, coefficients) - expected) <= 1e-12 * expected


@pytest.mark.parametrize("name", sorted(TAKEN))
def test_a_dip_within_the_width_is_taken(engine, name):
    # integrated here or left to the scalar path, never the plain Gauss–Legendre value; either
    # way the value meets mpmath
    coefficients = TAKEN[name]
    value, ok = _one_dip(engine, [coefficients])
    assert ok[0] == 0.0 or not np.isnan(value[0])
    expected = mpmath_step_integral(coefficients)
    assert abs(_special(engine, coefficients) - expected) <= 1e-12 * expected


@pytest.mark.parametrize("name", sorted(NO_DIP))
def test_no_dip_keeps_the_gauss_legendre_value(engine, name):
    # one_dip writes nothing; the scalar path returns the same Gauss–Legendre sum (numpy, same nodes)
    coefficients = NO_DIP[name]
    value, ok = _one_dip(engine, [coefficients])
    assert ok[0] == engine.KEEP_FAST and np.isnan(value[0])
    fast = _legendre(coefficients)
    assert _special(engine, coefficients, fast_value=fast) == fast
    assert abs(_scalar(engine, coefficients) - fast) <= 1e-14 * fast


@pytest.mark.parametrize(("nodes", "window"), [(4, 0.1), (8, 0.2)])
def test_one_dip_is_the_scalar_rule(engine, nodes, window):
    # The vectorized rule does what component_integral does for these items (same minimum, same
    # pieces and panels; the sinh rule's exponentials by products), so both agree to rounding: an
    # invariant of the design on 300 random near-touches (x_m in [-0.4, 1.4], eps from 1e-4 to
    # 1, both signs and a cubic part, which often gives v a sign change: the scalar path), of
    # which many are integrated here (at least 20 %, so that the comparison is not empty).
    rng = np.random.default_rng(18)
    cases = []
    for _ in range(300):
        x_m, eps = rng.uniform(-0.4, 1.4), 10.0 ** rng.uniform(-4.0, 0.0)
        curvature = rng.choice([-1.0, 1.0]) * 10.0 ** rng.uniform(-1.0, 1.5)
        quadratic = np.polynomial.Polynomial([x_m**2 + eps**2, -2.0 * x_m, 1.0]) * (0.5 * curvature)
        coefficients = np.zeros(8)
        coefficients[:3] = quadratic.coef
        coefficients[3:6] = rng.normal(0.0, 0.05, 3) * abs(curvature)
        cases.append(coefficients)
    values = np.empty(len(cases))
    oks = np.empty(len(cases))
    for start in range(0, len(cases), engine.CBS):  # the buffer holds CBS items
        values[start : start + engine.CBS], oks[start : start + engine.CBS] = _one_dip(
            engine, cases[start : start + engine.CBS], nodes=nodes, window=window)
    taken = (oks == engine.KEEP_FAST) & ~np.isnan(values)
    assert taken.sum() >= 0.2 * len(cases)
    for coefficients, value, ok in zip(cases, values, oks):
        scalar = _scalar(engine, coefficients, nodes=nodes, window=window)
        if ok == 0.0:
            continue
        if np.isnan(value):  # no dip: the Gauss–Legendre value, as the scalar path's
            assert abs(scalar - _legendre(coefficients, nodes)) <= 1e-14 * scalar
        else:
            assert abs(value - scalar) <= 1e-13 * scalar


def test_a_case_taking_more_rows_than_the_buffer_has_is_refused(engine):
    # the case rows of CB are sized for the rule that gathers its items (one_dip's D_ROWS); a
    # larger one would write past the buffer, so ``gather_items`` refuses it
    assert engine.D_ROWS <= engine.CASE_ROWS
    cb = np.zeros(engine.CB_ROWS * engine.CBS)
    with pytest.raises(ValueError, match="CASE_ROWS"):
        engine.gather_items(cb, 0, engine.ONE_DIP, engine.CASE_ROWS + 1)
