"""The Gauss rules of the LD quadrature (Legendre, and Jacobi for the cusps), built once per order.

The integrand kinds are in :mod:`ldpipe.engine.integrands`.

The compiled quadrature (cusp-aware integration of |v_c|^p over a step, fast and special
paths) is in ``templates/quadrature.py`` and ``templates/block_quadrature.py``, whose
docstrings describe the method; this module holds what Python needs to call it.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np


def _fresh(rule: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Copies of a cached rule: callers own their arrays (read-only views would be another numba type)."""
    return rule[0].copy(), rule[1].copy()


@lru_cache(maxsize=None)
def _legendre(n: int) -> tuple[np.ndarray, np.ndarray]:
    from scipy.special import roots_legendre  # here: only jobs that integrate an LD pay for scipy.special

    x, w = roots_legendre(n)
    return 0.5 * (x + 1.0), 0.5 * w


@lru_cache(maxsize=None)
def _jacobi(n: int, p: float) -> tuple[np.ndarray, np.ndarray]:
    from scipy.special import roots_jacobi

    x, w = roots_jacobi(n, 0.0, p)  # weight (1 - x)^0 (1 + x)^p on [-1, 1]
    return 0.5 * (x + 1.0), w * 0.5 ** (1.0 + p)


def legendre_rule(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss–Legendre nodes and weights on [0, 1] (weights sum to 1).

    Built once per order: every engine call asks for its rule, and thousands of small calls (the
    NHIM bisections) would otherwise spend more time in the eigensolver than in the flow."""
    return _fresh(_legendre(int(n)))


def jacobi_rule(n: int, p: float) -> tuple[np.ndarray, np.ndarray]:
    """Nodes and weights on [0, 1] for the weight s^p: int_0^1 s^p f(s) ds ~ sum w f(x) (built once per n, p)."""
    return _fresh(_jacobi(int(n), float(p)))


def folded_jacobi_rule(n: int, p: float) -> tuple[np.ndarray, np.ndarray]:
    """Gauss–Jacobi nodes x and weights w x^-p on [0, 1], for integrands that carry the cusp.

    For v(s) = s g(s) with g smooth and nonzero on [0, 1],
    int_0^1 |v(s)|^p ds = int_0^1 s^p |g(s)|^p ds ~ sum_g w_g |g(x_g)|^p = sum_g (w_g x_g^-p) |v(x_g)|^p:
    the compiled quadrature evaluates |v|^p at the nodes with these weights, without dividing
    by the cusp factor.
    """
    x, w = jacobi_rule(n, p)
    return x, w * x ** (-p)
