"""The Hamiltonian H = pᵀM⁻¹p/2 + V(q) about an equilibrium, and the symplectic change to its normal modes.

The Taylor coefficients of V are computed once, before any normal-form arithmetic: a polynomial
potential is expanded exactly by sympy; any other one (exp, log, sin, cos, powers) by truncated
power-series arithmetic (:mod:`ldpipe.core.normal_form.taylor`).

The linear change is built from the generalized eigenproblem Hess V u = h M u (u M-orthonormal),
which needs no symplectic Gram–Schmidt even for equal frequencies:

* a centre mode, h = ω² > 0: δq = u Q/√ω, δp = M u √ω P, so that H₂ = ω (Q² + P²)/2;
* the saddle's reaction mode, h = −λ² < 0: with x = (Q − P)/√2 and pₓ = (Q + P)/√2,
  δq = u x/√λ, δp = M u √λ pₓ, so that H₂ = λ (pₓ² − x²)/2 = λ Q P, Q growing as e^(λt) along +u.

Both are symplectic (the columns' pairings are uᵢᵀ M uⱼ = δᵢⱼ). The complex coordinates that
diagonalise a centre are Q = (q + i p)/√2, P = (i q + p)/√2 (dQ∧dP = dq∧dp), where
ω (Q² + P²)/2 = i ω q p; the saddle pair is already diagonal (q = Q, p = P). So in the complex
coordinates y, H₂ = Σ_k η_k q_k p_k with η = (λ, i ω₂, …), and {q^a p^b, H₂} = ⟨η, a − b⟩ q^a p^b.
The centre action is J = (Q² + P²)/2 = i q p; the saddle's I = Q P = q p.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg
import sympy

from .polynomials import MonomialBasis
from .taylor import potential_coefficients


@dataclass(frozen=True)
class NormalModes:
    """The linear symplectic change at an equilibrium: δx = ``real_matrix`` X = ``complex_matrix`` y.

    X = (Q₁..Qₙ, P₁..Pₙ) are real normal-mode coordinates, y = (q, p) the complex ones
    (``to_complex`` maps X = to_complex y). Modes are ordered saddle first, then centres by
    increasing frequency; ``eta`` are the eigenvalues of ad_H₂ on q_k p_k (λ or i ω).
    """

    real_matrix: np.ndarray
    to_complex: np.ndarray
    eta: np.ndarray
    hyperbolic: np.ndarray

    @property
    def complex_matrix(self) -> np.ndarray:
        return self.real_matrix @ self.to_complex

    @property
    def saddle_rate(self) -> float | None:
        rates = self.eta[self.hyperbolic].real
        return float(rates[0]) if len(rates) else None

    @property
    def frequencies(self) -> np.ndarray:
        return self.eta[~self.hyperbolic].imag


def normal_modes(hessian: np.ndarray, mass: np.ndarray | None = None, *, tolerance: float = 1e-12) -> NormalModes:
    """The change of the module docstring from Hess V and M (the identity if None).

    Raises ValueError for a zero eigenvalue (a degenerate equilibrium) or more than one
    hyperbolic pair.
    """
    hessian = np.asarray(hessian, dtype=np.float64)
    n = len(hessian)
    mass = np.eye(n) if mass is None else np.asarray(mass, dtype=np.float64)
    values, vectors = scipy.linalg.eigh(hessian, mass)
    scale = max(1.0, float(np.max(np.abs(values))))
    if np.any(np.abs(values) <= tolerance * scale):
        raise ValueError(f"degenerate equilibrium: Hess V u = h M u has h = {values}")
    if np.sum(values < 0) > 1:
        raise ValueError(f"more than one hyperbolic pair (h = {values}): only index-1 saddles and minima are handled")
    real = np.zeros((2 * n, 2 * n))
    to_complex = np.eye(2 * n, dtype=np.complex128)
    eta = np.zeros(n, dtype=np.complex128)
    r2 = np.sqrt(2.0)
    for k in range(n):
        u, h = vectors[:, k], values[k]
        mu = mass @ u
        if h < 0:
            lam = np.sqrt(-h)
            # δq = u (Q − P)/√(2λ), δp = M u √λ (Q + P)/√2
            real[:n, k], real[:n, n + k] = u / np.sqrt(2 * lam), -u / np.sqrt(2 * lam)
            real[n:, k], real[n:, n + k] = mu * np.sqrt(lam / 2), mu * np.sqrt(lam / 2)
            eta[k] = lam
        else:
            omega = np.sqrt(h)
            real[:n, k] = u / np.sqrt(omega)
            real[n:, n + k] = mu * np.sqrt(omega)
            eta[k] = 1j * omega
            # Q = (q + i p)/√2, P = (i q + p)/√2
            to_complex[k, k], to_complex[k, n + k] = 1 / r2, 1j / r2
            to_complex[n + k, k], to_complex[n + k, n + k] = 1j / r2, 1 / r2
    return NormalModes(real_matrix=real, to_complex=to_complex, eta=eta, hyperbolic=np.real(values) < 0)


def symplectic_defect(matrix: np.ndarray) -> float:
    """max |Aᵀ J A − J|: zero for a symplectic matrix (J = [[0, I], [−I, 0]])."""
    n = len(matrix) // 2
    j = np.block([[np.zeros((n, n)), np.eye(n)], [-np.eye(n), np.zeros((n, n))]])
    return float(np.max(np.abs(matrix.T @ j @ matrix - j)))


def potential_taylor(expression: sympy.Expr, symbols, point, max_degree: int) -> dict[tuple[int, ...], float]:
    """Taylor coefficients of V(point + d) up to ``max_degree`` as {exponents of d: coefficient}.

    A polynomial V is expanded exactly by sympy; any other by truncated series arithmetic
    (:mod:`ldpipe.core.normal_form.taylor`).
    """
    d = sympy.symbols(f"d0:{len(symbols)}", real=True)
    if all(expression.is_polynomial(s) for s in symbols):
        shifted = expression.subs({s: sympy.Float(float(x), 17) + di for s, x, di in zip(symbols, point, d)},
                                  simultaneous=True)
        polynomial = sympy.Poly(sympy.expand(shifted), *d)
        return {tuple(int(e) for e in exps): float(sympy.N(c, 17))
                for exps, c in polynomial.terms() if sum(exps) <= max_degree}
    return potential_coefficients(expression, symbols, point, max_degree)


def hamiltonian_taylor(basis: MonomialBasis, potential: dict[tuple[int, ...], float],
                       inverse_mass: np.ndarray | None = None) -> list[np.ndarray]:
    """H(x_s + δx) − H(x_s) as a polynomial in δx = (δq, p), from V's Taylor coefficients."""
    n = basis.n_dof
    h = basis.zeros()
    for exponents, value in potential.items():
        degree = sum(exponents)
        if 1 <= degree <= basis.max_degree:
            h[degree][basis.index(degree, list(exponents) + [0] * n)] += value
    inverse = np.eye(n) if inverse_mass is None else np.asarray(inverse_mass)
    for i in range(n):
        for j in range(n):
            e = np.zeros(2 * n, dtype=np.int64)
            e[n + i] += 1
            e[n + j] += 1
            h[2][basis.index(2, e)] += 0.5 * inverse[i, j]
    return h


def hessian_of(potential: dict[tuple[int, ...], float], n: int) -> np.ndarray:
    """Hess V at the expansion point, from the degree-2 Taylor coefficients."""
    hessian = np.zeros((n, n))
    for exponents, value in potential.items():
        if sum(exponents) == 2:
            idx = [k for k, e in enumerate(exponents) for _ in range(e)]
            i, j = idx
            if i == j:
                hessian[i, i] = 2 * value
            else:
                hessian[i, j] = hessian[j, i] = value
    return hessian
