"""The cheap test that spares the scalar path a near-touch flag that is no dip (issue 18).

``touch_matters`` decides, for a component flagged only because a near-touch may be close,
whether ``component_integral`` would take a dip there (True) or return the plain Gauss–Legendre
value (False). Its cases are polynomials built from their roots, so where each minimum of |v|
lies and its width eps (half the distance of the complex root pair) are known exactly; a False
is checked against the independent Gauss–Legendre sum over the same nodes in numpy.
"""

from __future__ import annotations

import numpy as np
import pytest

from ldpipe.engine.codegen import load_engine
from ldpipe.engine.quadrature import folded_jacobi_rule, legendre_rule
from ldpipe.systems import make_system

WINDOW = 0.2  # the dip width is DIP_PER_WINDOW * 0.2 = 0.5 step lengths; the scalar range [-0.25, 1.25]


def _from_roots(*roots) -> np.ndarray:
    return np.polynomial.Polynomial.fromroots(roots).coef.real


@pytest.fixture(scope="module")
def engine():
    return load_engine(make_system("barbanis_2dof", {"builtin": "barbanis_2dof"}), "dop853", 64)


def _check(engine, coefficients, beside_root=False, ends=0):
    vc = np.asarray(coefficients, dtype=float)[:, None, None].copy()
    glx, _ = legendre_rule(8)
    return engine.touch_matters(vc, 0, 0, vc.shape[0], glx, ends, WINDOW, beside_root)


MATTERS = {
    # minima with eps below the width 0.5, inside the step or within the scalar range
    "narrow dip inside": _from_roots(0.4 + 1e-4j, 0.4 - 1e-4j, 3.0),
    "dip of a negative v": -_from_roots(0.8 + 0.04j, 0.8 - 0.04j),  # |v| min where v'' < 0 (a sign slip once missed it)
    "dip just right": _from_roots(1.02 + 1e-3j, 1.02 - 1e-3j, -3.0),
    "dip just left": _from_roots(-0.03 + 1e-3j, -0.03 - 1e-3j, 3.0),
    "eps 0.45 inside": _from_roots(0.5 + 0.45j, 0.5 - 0.45j),
    "root pair beyond the step": _from_roots(-0.2445, -0.2434, 3.0),
}
NO_DIP = {
    # eps at least the width, or the minimum beyond the scalar range: component_integral takes no dip
    "eps 0.8 inside": _from_roots(0.5 + 0.8j, 0.5 - 0.8j),
    "eps 0.55 inside": _from_roots(0.3 + 0.55j, 0.3 - 0.55j, 4.0),
    "narrow dip beyond the range": _from_roots(1.6 + 1e-3j, 1.6 - 1e-3j, -3.0),
}


@pytest.mark.parametrize("name", sorted(MATTERS))
def test_a_dip_within_the_width_goes_to_the_scalar_path(engine, name):
    assert _check(engine, MATTERS[name], ends=3)


@pytest.mark.parametrize("name", sorted(NO_DIP))
def test_no_dip_keeps_the_gauss_legendre_value(engine, name):
    coefficients = NO_DIP[name]
    assert not _check(engine, coefficients, ends=3)
    # and the scalar path agrees: it returns the Gauss–Legendre sum (numpy, same 8 nodes)
    glx, glw = legendre_rule(8)
    gjx, gjf = folded_jacobi_rule(8, 0.5)
    vc = np.asarray(coefficients, dtype=float)[:, None, None].copy()
    scalar = engine.component_integral(vc, 0, 0, vc.shape[0], 1.0, engine.KIND_HALF, 0.5, glx, glw, gjx, gjf,
                                       WINDOW, np.zeros(200))
    legendre = float(np.sum(glw * np.sqrt(np.abs(np.polynomial.Polynomial(coefficients)(glx)))))
    assert scalar == pytest.approx(legendre, rel=1e-14)


def test_beside_a_root_a_narrow_dip_still_matters(engine):
    # a root 0.05 left of the step (the left case, Jacobi pieces) and a near-touch at 0.7, eps 1e-3
    coefficients = _from_roots(-0.05, 0.7 + 1e-3j, 0.7 - 1e-3j)
    assert _check(engine, coefficients, beside_root=True, ends=1)
    # without it (roots at 2 and 3: a maximum of |v| at 0.75 on the step's side, no minimum) nothing to add
    assert not _check(engine, _from_roots(-0.05, 2.0, 3.0), beside_root=True, ends=1)
    # a second root beyond the first (a root pair outside the step, a maximum of |v| between): the scalar path
    assert _check(engine, _from_roots(-0.05, -0.07, 3.0), beside_root=True, ends=1)
