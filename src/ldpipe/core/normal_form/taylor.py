"""Taylor coefficients of a potential about a point, by truncated power-series arithmetic.

The potential's sympy expression is walked once: sums and products of series are done on the
dense arrays of :class:`~ldpipe.core.normal_form.polynomials.MonomialBasis` (the momenta's exponents
stay zero), and every function of one argument φ (exp, log, sin, cos, the hyperbolic ones,
powers, anything sympy can differentiate) is composed through its own Taylor series at the
argument's value: φ(f₀ + g) = Σ_k φ⁽ᵏ⁾(f₀)/k! g^k, g without constant term, so g^k starts at
degree k and the sum stops at the order asked. sympy only differentiates φ in one variable; no
multivariate symbolic series (which does not survive float coefficients) is needed.
"""

from __future__ import annotations

import math

import numpy as np
import sympy

from .polynomials import MonomialBasis

Series = list[np.ndarray]


def _constant(basis: MonomialBasis, value: complex) -> Series:
    series = basis.zeros()
    series[0][0] = value
    return series


def _add(f: Series, g: Series) -> Series:
    return [a + b for a, b in zip(f, g)]


def _multiply(basis: MonomialBasis, f: Series, g: Series) -> Series:
    out = basis.zeros()
    live_f = [d for d, c in enumerate(f) if np.any(c)]
    live_g = [d for d, c in enumerate(g) if np.any(c)]
    for i in live_f:
        for j in live_g:
            if i + j <= basis.max_degree:
                out[i + j] += basis.multiply(f[i], i, g[j], j)
    return out


def _compose(basis: MonomialBasis, function, f: Series) -> Series:
    """φ(f) for φ = ``function`` (a one-argument sympy callable), by φ's Taylor series at f₀."""
    x = sympy.Symbol("x")
    centre = complex(f[0][0])
    centre = centre.real if centre.imag == 0 else centre
    derivative = function(x)
    coefficients = []
    for k in range(basis.max_degree + 1):
        value = complex(sympy.N(derivative.subs(x, centre), 17))
        if not np.isfinite(value):
            raise ValueError(f"{function(x)} is not analytic at {centre}: no Taylor series there")
        coefficients.append(value / math.factorial(k))
        derivative = sympy.diff(derivative, x)
    g = [np.array(c, copy=True) for c in f]
    g[0] = np.zeros_like(g[0])
    out = _constant(basis, coefficients[0])
    power = _constant(basis, 1.0)
    for k in range(1, basis.max_degree + 1):
        power = _multiply(basis, power, g)
        out = _add(out, [coefficients[k] * c for c in power])
    return out


def taylor_series(expression: sympy.Expr, symbols, point, basis: MonomialBasis) -> Series:
    """V(point + d) as a truncated series in d = (δq₁..δqₙ) (the basis' first n variables)."""
    shift = {s: k for k, s in enumerate(symbols)}

    def walk(node) -> Series:
        if node in shift:
            k = shift[node]
            series = _constant(basis, float(point[k]))
            series[1] += basis.variable(k)[1]
            return series
        if node.is_number:
            return _constant(basis, complex(sympy.N(node, 17)))
        if isinstance(node, sympy.Add):
            parts = [walk(a) for a in node.args]
            total = parts[0]
            for part in parts[1:]:
                total = _add(total, part)
            return total
        if isinstance(node, sympy.Mul):
            parts = [walk(a) for a in node.args]
            total = parts[0]
            for part in parts[1:]:
                total = _multiply(basis, total, part)
            return total
        if isinstance(node, sympy.Pow):
            base, exponent = node.args
            if exponent.is_Integer and int(exponent) >= 0:
                total = _constant(basis, 1.0)
                factor = walk(base)
                for _ in range(int(exponent)):
                    total = _multiply(basis, total, factor)
                return total
            if exponent.is_number:
                return _compose(basis, lambda x: x**exponent, walk(base))
            return walk(sympy.exp(exponent * sympy.log(base)))
        if isinstance(node, sympy.Function) and len(node.args) == 1:
            return _compose(basis, node.func, walk(node.args[0]))
        raise ValueError(f"no Taylor series for {node!r} ({type(node).__name__})")

    return walk(expression)


def potential_coefficients(expression: sympy.Expr, symbols, point, max_degree: int) -> dict[tuple[int, ...], float]:
    """{exponents of d: coefficient} of V(point + d) up to ``max_degree``, real parts (V is real)."""
    n = len(symbols)
    basis = MonomialBasis(n, max_degree)
    series = taylor_series(expression, symbols, point, basis)
    out = {}
    for degree, coefficients in enumerate(series):
        for i in np.flatnonzero(coefficients):
            out[tuple(int(e) for e in basis.exponents[degree][i][:n])] = float(coefficients[i].real)
    return out
