"""The vectorized check that spares the scalar path a root-pair flag that holds no pair.

``fast`` flags a component whose samples (0, the Gauss nodes, 1) have one sign where
``pair_possible`` with a bound of |v''| over the whole step allows two roots between two
samples. ``pair_check`` repeats the test with a bound over each sample interval; where it
clears the flag the Gauss–Legendre value stands. The bound is a Taylor remainder bound, so a
cleared polynomial has no real root in [0, 1]: checked against numpy's roots (an independent
method) on polynomials built from their roots, and a cleared case's scalar-path value against
the Gauss–Legendre sum in numpy.
"""

from __future__ import annotations

import numpy as np
import pytest

from ldpipe.engine.gauss_rules import folded_jacobi_rule, legendre_rule
from support.step_rules import rule_engine

NODES = 4  # dop853's rule at rtol 1e-4 and 1e-5, where these flags are common


@pytest.fixture(scope="module")
def engine():
    return rule_engine()


def _cleared(engine, polynomials) -> np.ndarray:
    """pair_check's answer per polynomial (coefficients, lowest first): True where it clears the flag."""
    nc = engine.NC
    cb = np.zeros(engine.CB_ROWS * engine.CBS)
    for t, coefficients in enumerate(polynomials):
        cb[np.arange(len(coefficients)) * engine.CBS + t] = coefficients
        cb[engine.R_OK * engine.CBS + t] = engine.PAIR_CHECK
    assert all(len(c) <= nc for c in polynomials)
    glx, _ = legendre_rule(NODES)
    engine.pair_check(cb, len(polynomials), glx)
    ok = cb[engine.R_OK * engine.CBS : engine.R_OK * engine.CBS + len(polynomials)]
    assert set(ok) <= {engine.KEEP_FAST, 0.0}
    return ok == engine.KEEP_FAST


def _from_roots(*roots) -> np.ndarray:
    return np.polynomial.Polynomial.fromroots(roots).coef.real


def _flagged_by_fast(coefficients) -> bool:
    """``fast``'s test, written out: some sample interval where the convex quadratic below v
    with |v''| <= sum k (k - 1) |c_k| reaches zero (the docstring of ``pair_possible``)."""
    glx, _ = legendre_rule(NODES)
    samples = np.r_[0.0, glx, 1.0]
    k = np.arange(len(coefficients))
    bound = float(np.sum(k * (k - 1.0) * np.abs(coefficients)))
    values = np.polynomial.Polynomial(coefficients)(samples)
    for a, b, va, vb in zip(samples[:-1], samples[1:], values[:-1], values[1:]):
        gap = b - a
        s = abs(vb) - abs(va)
        slope = s / gap - 0.5 * bound * gap
        if va * vb > 0.0 and abs(s) < 0.5 * bound * gap**2 and 2.0 * bound * abs(va) < slope**2:
            return True
    return False


def test_a_root_pair_between_two_nodes_is_kept(engine):
    glx, _ = legendre_rule(NODES)
    # roots at 0.5 +- 0.05, between the nodes 0.33 and 0.67, where v < 0; v > 0 at every sample
    pair = _from_roots(0.45, 0.55, 3.0, -2.5)
    assert np.all(np.polynomial.Polynomial(pair)(np.r_[0.0, glx, 1.0]) * pair[0] > 0.0)
    assert not _cleared(engine, [pair])[0]


def test_a_cleared_flag_has_no_root_in_the_step(engine):
    # Polynomials of degree 7 with one sign on the samples and a minimum of |v| between them, of
    # every depth: complex root pairs near [0, 1] (no real root there) and real pairs between
    # two samples. Every cleared one must have no real root in [0, 1] (numpy.roots).
    rng = np.random.default_rng(18)
    glx, _ = legendre_rule(NODES)
    samples = np.r_[0.0, glx, 1.0]
    polynomials, real_roots_inside = [], []
    while len(polynomials) < 256:
        centre = rng.uniform(0.0, 1.0)
        half = rng.choice([1.0, 1.0j]) * 10.0 ** rng.uniform(-3.0, -0.3)
        others = rng.uniform(1.5, 4.0, size=5) * rng.choice([-1.0, 1.0], size=5)
        coefficients = _from_roots(centre + half, centre - half, *others) * rng.uniform(0.1, 10.0)
        values = np.polynomial.Polynomial(coefficients)(samples)
        if not (np.all(values > 0.0) or np.all(values < 0.0)):
            continue  # a sign change on the samples: not this check's case
        roots = np.roots(coefficients[::-1])
        real = roots[np.abs(roots.imag) < 1e-12].real
        polynomials.append(coefficients)
        real_roots_inside.append(bool(np.any((real >= 0.0) & (real <= 1.0))))
    cleared = _cleared(engine, polynomials)
    real_roots_inside = np.array(real_roots_inside)
    assert not np.any(cleared & real_roots_inside)
    # not vacuous: both answers occur, and real pairs were among the cases
    assert cleared.sum() > 20 and (~cleared).sum() > 20 and real_roots_inside.sum() > 5


def test_a_cleared_flag_keeps_the_scalar_paths_value(engine):
    # a shallow minimum (complex roots 0.5 +- 0.4i; eps 0.4 above the dip width 0.25 at the
    # window 0.1): the step-wide bound flags it, the interval bound clears it; the scalar path
    # returns the plain Gauss–Legendre sum there too
    coefficients = _from_roots(0.5 + 0.4j, 0.5 - 0.4j, 2.0, 3.0)
    assert _flagged_by_fast(coefficients)
    assert _cleared(engine, [coefficients])[0]
    glx, glw = legendre_rule(NODES)
    gjx, gjf = folded_jacobi_rule(NODES, 0.5)
    vc = np.asarray(coefficients, dtype=float)[:, None, None].copy()
    scalar = engine.component_integral(vc, 0, 0, vc.shape[0], 1.0, engine.KIND_HALF, 0.5, glx, glw, gjx, gjf,
                                       0.1, np.zeros(200))
    legendre = float(np.sum(glw * np.sqrt(np.abs(np.polynomial.Polynomial(coefficients)(glx)))))
    assert scalar == pytest.approx(legendre, rel=1e-14)
