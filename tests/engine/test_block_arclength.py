"""The arc-length pass of the block quadrature and the taylor step rule's root, against numpy.

``arclength_fast`` (templates/block_arclength.py) evaluates four Gauss nodes per pass; its
value must be the Gauss–Legendre sum of sqrt(sum_c v_c(x)^2) over the same nodes, here
computed independently by numpy's polynomial evaluation, for node counts that fill the last
group of four and for one that does not. ``inverse_root`` (templates/roots.py) must agree with
libm's pow, x ** (-1/m), over the whole float range, subnormals included.
"""

from __future__ import annotations

import numpy as np
import pytest

from ldpipe.engine.codegen import load_engine
from ldpipe.engine.gauss_rules import legendre_rule
from ldpipe.systems import make_system

ORDER = 18


@pytest.fixture(scope="module")
def engine():
    return load_engine(make_system("barbanis_2dof", {"builtin": "barbanis_2dof"}), "taylor", 64, ORDER)


@pytest.mark.parametrize("n_nodes", [8, 6, 5])
def test_arclength_fast_is_the_gauss_legendre_sum(engine, n_nodes):
    e = engine
    rng = np.random.default_rng(n_nodes)
    # coefficients decaying like a step's series (ratio 0.4), signs random
    vc = rng.standard_normal((e.NC, e.NCOMP, e.LANES)) * 0.4 ** np.arange(e.NC)[:, None, None]
    W = np.zeros(e.SIZE)
    W[e.OVC : e.OVC + vc.size] = vc.ravel()
    glx, glw = legendre_rule(n_nodes)
    e.arclength_fast(W, glx, glw)
    # numpy: v_c(x) at every node, then the weighted sum of |v|
    values = np.polynomial.polynomial.polyval(glx, vc)  # (component, lane, node)
    expected = (glw * np.sqrt((values**2).sum(axis=0))).sum(axis=-1)
    assert np.allclose(W[e.OFC : e.OFC + e.LANES], expected, rtol=1e-14, atol=0.0)


def test_inverse_root_agrees_with_pow(engine):
    rng = np.random.default_rng(7)
    x = np.concatenate([
        10.0 ** rng.uniform(-323, 308, 4000),
        [5e-324, 1e-310, 2.2250738585072014e-308, 0.5, 1.0, 2.0, np.sqrt(2.0), np.nextafter(np.sqrt(2.0), 2.0), 1.7e308],
    ])
    for m in (4, 13, 18, 20, 40):
        got = np.array([engine.inverse_root(v, 1.0 / m) for v in x])
        expected = x ** (-1.0 / m)  # libm's pow
        assert np.max(np.abs(got / expected - 1.0)) < 1e-10, m
