"""The FTLE on an energy surface's section, whose third coordinate is solved from the energy.

H = (px^2 + py^2)/2 + (y^2 - x^2)/2, a saddle (x, px) times a centre (y, py), both of rate 1:
its flow over T is linear, Phi = hyperbolic block [[cosh T, sinh T], [sinh T, cosh T]] on (x, px)
times a rotation on (y, py). On the section y = 0 with axes (x, px) and py solved from
H = E, a step v = (dx, dpx) across the grid moves the start state by G v = (v, s.v), s the slope
of py = S(x, px) = sqrt(2E + x^2 - px^2). Closed forms:

- the largest squared stretching is max_v (|B v|^2 + (s.v)^2) / (|v|^2 + (s.v)^2), B the
  hyperbolic block (the rotation keeps (s.v)^2): the largest root of
  det(B^T B + s s^T - lambda (I + s s^T)) = 0 with s = (x/S, -px/S);
- whatever s is, it is at most the largest eigenvalue of Phi^T Phi, e^(2T): the FTLE is at most 1,
  the saddle's rate, everywhere, also at the rim of the allowed region where S -> 0 and the
  slope diverges (measured in the section's coordinates alone it is not: the chart's rim).
"""

import math

import numpy as np
import pytest

import ldpipe

SADDLE_CENTRE = {"formula": "(y**2 - x**2)/2", "coordinates": ["x", "y"]}
ENERGY, TAU = 0.5, 2.0


@pytest.fixture(scope="module")
def chart_map():
    system = ldpipe.system(name="saddle_centre", **SADDLE_CENTRE)
    section = ldpipe.section(x=(-0.5, 0.5, 41), px=(-1.5, 1.5, 121), fixed={"y": 0.0}, solve="py")
    return ldpipe.ld_map(system, section=section, energy=ENERGY, tau=TAU, ftle=True, progress=False,
                         integrator={"rtol": 1e-12, "atol": 1e-12})


def closed_form_ftle(x, px):
    s = np.sqrt(2 * ENERGY + x**2 - px**2)
    slope = np.stack([x / s, -px / s], axis=-1)
    block = np.array([[math.cosh(TAU), math.sinh(TAU)], [math.sinh(TAU), math.cosh(TAU)]])
    # C = B^T B + s s^T, M = I + s s^T (the rotation's part of |Phi G v|^2 is (s.v)^2); numpy's roots
    c = block.T @ block
    c00, c11, c01 = c[0, 0] + slope[..., 0] ** 2, c[1, 1] + slope[..., 1] ** 2, c[0, 1] + slope[..., 0] * slope[..., 1]
    m00, m11, m01 = 1 + slope[..., 0] ** 2, 1 + slope[..., 1] ** 2, slope[..., 0] * slope[..., 1]
    roots = [np.roots([m00 * m11 - m01**2, -(c00 * m11 + c11 * m00 - 2 * c01 * m01), c00 * c11 - c01**2]).real.max()
             for c00, c11, c01, m00, m11, m01 in zip(*(np.ravel(a) for a in (c00, c11, c01, m00, m11, m01)))]
    return np.log(np.reshape(roots, x.shape)) / (2 * TAU)


def test_the_ftle_at_the_rim_of_the_allowed_region_is_bounded_by_the_saddle_rate(chart_map):
    for label in ("forward", "backward"):
        defined = chart_map[f"ftle_defined_{label}"].values
        values = chart_map[f"ftle_{label}"].values[defined]
        assert defined.sum() > 0.5 * chart_map.allowed.values.sum()
        # Rounding of the differences only: the largest squared stretching is e^(2T) to ~1e-9.
        assert values.max() <= 1.0 + 1e-9, label


def test_near_the_rim_the_ftle_is_the_closed_form_with_the_chart_slope(chart_map):
    """Where the slope is large (within a few cells of the rim) and where it is small, the map's
    FTLE (slopes by grid differences) against the closed form with the exact slope: the flow map
    is linear, so J's differences are exact and the difference is the slope's truncation error,
    O(h^2) times S's third derivative, which grows towards the rim (measured: 5e-4 where S >= 0.5,
    6e-2 where S < 0.5, the defined points nearest the rim having S ~ 0.2)."""
    x, px = np.meshgrid(chart_map.x.values, chart_map.px.values, indexing="ij")
    defined = chart_map.ftle_defined_forward.values
    reference = closed_form_ftle(x[defined], px[defined])
    values = chart_map.ftle_forward.values[defined]
    s = np.sqrt(2 * ENERGY + x[defined] ** 2 - px[defined] ** 2)
    steep = s < 0.5
    assert steep.sum() > 20 and (~steep).sum() > 20
    np.testing.assert_allclose(values[~steep], reference[~steep], rtol=1.5e-3)
    np.testing.assert_allclose(values[steep], reference[steep], rtol=0.1)

