"""The DOP853 step in Nyström form against the first-order formulation, its tableau against scipy's,
and the folded Gauss–Jacobi rule.

The engine forms no stage momenta (ldpipe.engine.schemes.dop853.nystrom_form): its step must equal,
up to rounding, DOP853 written for the first-order system y' = f(y) straight from the tableau
(independent code here, numpy), and its dense output must close on the step's end.
"""

import numpy as np
import pytest
from scipy.integrate._ivp import dop853_coefficients as scipy_dop853

from ldpipe.engine.schemes import tableaux
from ldpipe.engine.codegen import load_engine
from ldpipe.engine.gauss_rules import folded_jacobi_rule, jacobi_rule, legendre_rule
from ldpipe.engine.schemes import scheme_source
from ldpipe.engine.schemes.dop853 import nystrom_form

LANES = 64



def first_order_dop853(f, y0, h, rtol, atol):
    """One DOP853 step of y' = f(y) from the tableau: (y1, Hairer's scaled error estimate)."""
    K = np.zeros((16, len(y0)))
    K[0] = f(y0)
    for m in range(1, 16):
        K[m] = f(y0 + h * (tableaux.A[m, :m] @ K[:m]))
    y1 = y0 + h * (tableaux.B @ K[:12])
    scale = atol + rtol * np.maximum(np.abs(y0), np.abs(y1))
    e5 = np.sum(((tableaux.E5 @ K[:13]) / scale) ** 2)
    e3 = np.sum(((tableaux.E3 @ K[:13]) / scale) ** 2)
    return y1, abs(h) * e5 / np.sqrt((e5 + 0.01 * e3) * len(y0)), K


def test_nystrom_step_equals_first_order_step(barbanis):
    module = load_engine(barbanis, "dop853", LANES)
    layout = scheme_source("dop853", barbanis, LANES).layout
    NB = 2 * LANES
    rng = np.random.default_rng(7)
    q0 = rng.uniform(-4.0, 4.0, size=(2, LANES))
    p0 = rng.uniform(-3.0, 3.0, size=(2, LANES))
    h = rng.uniform(0.05, 0.8, size=LANES) * rng.choice([-1.0, 1.0], size=LANES)
    acc = np.array([-barbanis.gradient(q0[:, j]) for j in range(LANES)]).T
    W = np.zeros(layout.size)
    W[layout.OQ : layout.OQ + NB] = q0.ravel()
    W[layout.OP : layout.OP + NB] = p0.ravel()
    W[layout.OA : layout.OA + NB] = acc.ravel()
    W[layout.OH : layout.OH + LANES] = h
    rtol = atol = 1e-8
    module.attempt(W, rtol, atol)
    module.qpoly(W)
    qn = W[layout.OQN : layout.OQN + NB].reshape(2, LANES)
    pn = W[layout.OPN : layout.OPN + NB].reshape(2, LANES)
    err = W[layout.OERR : layout.OERR + LANES]
    QC = W[layout.OQC : layout.OQC + 8 * NB].reshape(8, 2, LANES)
    VC = W[layout.OVC : layout.OVC + 8 * 2 * NB].reshape(8, 4, LANES)

    def field(y):
        return np.concatenate([y[2:], -barbanis.gradient(y[:2])])

    for j in range(LANES):
        y0 = np.concatenate([q0[:, j], p0[:, j]])
        y1, e, K = first_order_dop853(field, y0, h[j], rtol, atol)
        assert np.allclose(np.concatenate([qn[:, j], pn[:, j]]), y1, rtol=1e-13, atol=1e-13)
        # the estimate is a difference of nearly equal sums; the first-order form cancels the
        # O(|p|) parts of its stage momenta in rounding, hence the looser match
        assert e == pytest.approx(err[j], rel=1e-4)
        # dense output closes: q(x = 1) = qn, velocities (p, a) at both ends
        # (to rounding of the dense coefficients, some of which are ~500)
        assert np.allclose(QC[:, :, j].sum(axis=0), qn[:, j], rtol=1e-12, atol=1e-12)
        assert np.allclose(VC[0, :, j], field(y0), rtol=1e-15, atol=0.0)
        # (the acceleration polynomial is the derivative of the momentum's: coefficients k G A)
        assert np.allclose(VC[:, :, j].sum(axis=0), K[12], rtol=1e-11, atol=3e-11)


def test_tableau_is_scipys_element_by_element():
    # The stated source of the coefficients: scipy's dop853_coefficients (Hairer's dop853.f).
    # Exact equality, not 1 ulp: both modules write the same 30-digit decimal literals, which
    # Python rounds correctly to the same doubles, and form B (a row of A) and E3 (B minus the same
    # three literals, in the same order) by the same IEEE operations. The order conditions
    # (test_settings.py) hold only to ~1e-14, so a digit wrong past the 14th would pass them, and
    # none of them sees D (its terms vanish at both ends of the step).
    assert tableaux.DOP853_STAGES == scipy_dop853.N_STAGES
    assert tableaux.DOP853_STAGES_EXTENDED == scipy_dop853.N_STAGES_EXTENDED
    for name in ("A", "B", "C", "E3", "E5", "D"):
        np.testing.assert_array_equal(getattr(tableaux, name), getattr(scipy_dop853, name), err_msg=name)


def test_nystrom_form_refuses_a_tableau_whose_sums_break_the_rewrite():
    # The rewrite needs the row sums of A to be C and drops the p terms because the estimator
    # weights sum to zero; a tableau where that fails must not be rewritten silently.
    nystrom_form(tableaux.A, tableaux.C, tableaux.E3, tableaux.E5)
    bad_e5 = tableaux.E5.copy()
    bad_e5[0] += 1e-6
    with pytest.raises(ValueError, match="E5"):
        nystrom_form(tableaux.A, tableaux.C, tableaux.E3, bad_e5)
    bad_c = tableaux.C.copy()
    bad_c[3] += 1e-9
    with pytest.raises(ValueError, match="row sums"):
        nystrom_form(tableaux.A, bad_c, tableaux.E3, tableaux.E5)


@pytest.mark.parametrize("p", [0.5, 0.3, 1.0])
@pytest.mark.parametrize("n", [4, 8])
def test_folded_jacobi_rule_moments(p, n):
    # Closed form: int_0^1 s^p s^k ds = 1/(p + k + 1), exact for k <= 2n - 1 with n Gauss–Jacobi
    # nodes; the folded weights w x^-p applied to |v| = x^(p + k) must give the same.
    x, folded = folded_jacobi_rule(n, p)
    _, weights = jacobi_rule(n, p)
    for k in range(2 * n):
        exact = 1.0 / (p + k + 1.0)
        assert np.dot(folded, x ** (p + k)) == pytest.approx(exact, rel=1e-13)
        assert np.dot(weights, x**k) == pytest.approx(exact, rel=1e-13)


def test_legendre_rule_is_built_once_and_handed_out_as_copies():
    # Closed form: the 2-node Gauss–Legendre rule on [0, 1] has nodes 1/2 -+ 1/(2 sqrt 3), weights 1/2.
    nodes, weights = legendre_rule(2)
    expected = np.array([0.5 - 0.5 / np.sqrt(3.0), 0.5 + 0.5 / np.sqrt(3.0)])
    np.testing.assert_allclose(nodes, expected, rtol=0, atol=1e-15)
    np.testing.assert_allclose(weights, [0.5, 0.5], rtol=0, atol=1e-15)
    nodes[:] = 0.0  # a caller's change must not reach the next caller of the cached rule
    weights[:] = 0.0
    again, again_weights = legendre_rule(2)
    np.testing.assert_allclose(again, expected, rtol=0, atol=1e-15)
    np.testing.assert_allclose(again_weights, [0.5, 0.5], rtol=0, atol=1e-15)
    x, w = jacobi_rule(3, 0.5)
    x[:], w[:] = 0.0, 0.0
    assert np.all(jacobi_rule(3, 0.5)[0] > 0) and np.all(jacobi_rule(3, 0.5)[1] > 0)
