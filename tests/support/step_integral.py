"""The LD integral of one step, int_0^1 |v(x)|^p dx for a polynomial v, by an independent method.

mpmath at 30 digits: tanh-sinh on pieces cut at the real roots and the real minima of |v| in
(0, 1) (numpy's roots of v and v'), graded geometrically towards each cut and towards the ends
(points 10^-1 ... 10^-12 away), so that the cusps at the roots and the near-singularities of a
near-touch (complex roots x_m +- i eps) lie at the end of a piece no longer than their distance.
Used by the engine's step-rule tests (tests/engine: near touches, two roots, one dip), which
build their polynomials from roots (``from_roots``).
"""

from __future__ import annotations

import numpy as np


def from_roots(*roots) -> np.ndarray:
    """Monomial coefficients (lowest first) of the monic polynomial with these roots (complex
    ones in conjugate pairs: a near-touch x_m +- i eps)."""
    return np.polynomial.Polynomial.fromroots(roots).coef.real


def mpmath_step_integral(coefficients, p: float = 0.5) -> float:
    """int_0^1 |v|^p for v = sum_k coefficients[k] x^k, at 30 digits (see the module docstring)."""
    import mpmath

    mpmath.mp.dps = 30
    poly = np.polynomial.Polynomial(np.asarray(coefficients, dtype=float))
    cuts = [0.0, 1.0] + [float(r.real) for r in np.concatenate([poly.roots(), poly.deriv().roots()])
                         if abs(r.imag) < 1e-6 and 0.0 < r.real < 1.0]
    points = set(cuts)
    for s in cuts:
        for k in range(1, 13):
            for q in (s - 10.0**-k, s + 10.0**-k):
                if 0.0 < q < 1.0:
                    points.add(q)
    c = [mpmath.mpf(float(x)) for x in poly.coef[::-1]]
    power = mpmath.mpf(p)
    return float(mpmath.quad(lambda x: abs(mpmath.polyval(c, x)) ** power, sorted(points)))
