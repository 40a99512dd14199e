"""The cheap test that spares the scalar path a near-touch flag beside a root that is no dip.

``touch_matters`` decides, for a component with a root just outside an end (the Jacobi pieces
from it) flagged also because a near-touch may be close, whether ``component_integral`` would
take a dip there too (True) or not (False). Its cases are polynomials built from their roots, so
where each minimum of |v| lies and its width eps (half the distance of the complex root pair)
are known exactly. (A near-touch with no root near either end is ``one_dip``'s: test_one_dip.py.)
"""

from __future__ import annotations

import numpy as np
import pytest

from ldpipe.engine.gauss_rules import legendre_rule
from support.step_integral import from_roots
from support.step_rules import rule_engine

WINDOW = 0.2  # the dip width is DIP_PER_WINDOW * 0.2 = 0.5 step lengths; the scalar range [-0.25, 1.25]


@pytest.fixture(scope="module")
def engine():
    return rule_engine()


def _check(engine, coefficients, ends):
    vc = np.asarray(coefficients, dtype=float)[:, None, None].copy()
    glx, _ = legendre_rule(8)
    return engine.touch_matters(vc, 0, 0, vc.shape[0], glx, ends, WINDOW)


def test_beside_a_root_a_narrow_dip_still_matters(engine):
    # a root 0.05 left of the step (the left case, Jacobi pieces) and a near-touch at 0.7, eps 1e-3
    coefficients = from_roots(-0.05, 0.7 + 1e-3j, 0.7 - 1e-3j)
    assert _check(engine, coefficients, ends=1)
    # without it (roots at 2 and 3: a maximum of |v| at 0.75 on the step's side, no minimum) nothing to add
    assert not _check(engine, from_roots(-0.05, 2.0, 3.0), ends=1)
    # a second root beyond the first (a root pair outside the step, a maximum of |v| between): the scalar path
    assert _check(engine, from_roots(-0.05, -0.07, 3.0), ends=1)
