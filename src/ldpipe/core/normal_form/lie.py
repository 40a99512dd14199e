"""Normalization by Lie series, one degree at a time, and the coordinate changes it defines.

With L_W f = {f, W}, exp(L_W) f = f ∘ φ_W, φ_W the time-1 flow of the Hamiltonian W. At degree s
the generator W_s solves the homological equation H_s + {H₂, W_s} = K_s: since
{H₂, q^a p^b} = −⟨η, a − b⟩ q^a p^b (expansion's docstring), a removed monomial's coefficient
is divided by its divisor ⟨η, a − b⟩. Then H ← exp(L_{W_s}) H changes only degrees ≥ s, so after
s = 3..N the Hamiltonian is normalized to degree N: H ∘ φ_3 ∘ … ∘ φ_N = K + O(N + 1).

Which monomials are removed is the form asked for:

* ``partial``: every one unbalanced in a saddle pair (a_1 ≠ b_1). The divisors have real part
  λ (a_1 − b_1), so none is small whatever the centre frequencies; K then depends on the saddle
  pair only through I = q_1 p_1, which decouples the reactive motion.
* ``full`` (Birkhoff–Gustavson): every one with a ≠ b, except exact resonances |⟨η, a − b⟩| ≤
  ``resonance_tolerance``, which are kept (the resonant normal form); K is then a function of
  the I and J alone when the frequencies are non-resonant to the order asked.

The old complex coordinates as functions of the new ones are y = φ_3 ∘ … ∘ φ_N (Y), i.e.
y_i(Y) = exp(L_{W_N}) … exp(L_{W_3}) Y_i (W_3 applied first); the inverse applies −W_N first.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .polynomials import MonomialBasis

FORMS = ("partial", "full")


def lie_series(basis: MonomialBasis, f: list[np.ndarray], w: np.ndarray, s: int, top: int) -> list[np.ndarray]:
    """exp(L_w) f = Σ_j L_w^j f / j! truncated at degree ``top``, for w homogeneous of degree s ≥ 3."""
    result = [np.array(c, copy=True) for c in f] + [basis.zero(d) for d in range(len(f), top + 1)]
    result = result[: top + 1]
    term = {d: c for d, c in enumerate(f[: top + 1]) if np.any(c)}
    j = 1
    while term:
        following = {}
        for d, coefficients in term.items():
            target = d + s - 2
            if target <= top:
                bracket = basis.bracket(coefficients, d, w, s) / j
                if np.any(bracket):
                    following[target] = following.get(target, 0) + bracket
        for d, coefficients in following.items():
            result[d] = result[d] + coefficients
        term = following
        j += 1
    return result


@dataclass
class Normalization:
    """The normalized Hamiltonian K (complex coordinates, degrees 0..order), its generators and divisors.

    ``smallest_divisor[s]`` is the smallest |⟨η, a − b⟩| divided by at degree s (inf if none);
    ``resonant_terms[s]`` counts the monomials kept as resonant at degree s.
    """

    basis: MonomialBasis
    order: int
    form: str
    eta: np.ndarray
    hamiltonian: list[np.ndarray]
    generators: dict[int, np.ndarray] = field(default_factory=dict)
    smallest_divisor: dict[int, float] = field(default_factory=dict)
    resonant_terms: dict[int, int] = field(default_factory=dict)

    def transform(self, functions: list[list[np.ndarray]], *, inverse: bool, top: int | None = None) -> list[list[np.ndarray]]:
        """Each function composed with the change: f(y(Y)) (``inverse`` False) or f(Y(y))."""
        top = self.order - 1 if top is None else top
        degrees = sorted(self.generators)
        sequence = [(s, -self.generators[s]) for s in reversed(degrees)] if inverse else [(s, self.generators[s]) for s in degrees]
        out = []
        for f in functions:
            for s, w in sequence:
                f = lie_series(self.basis, f, w, s, top)
            out.append(f)
        return out

    def coordinates(self, *, inverse: bool) -> list[list[np.ndarray]]:
        """Old complex coordinates as polynomials in the new ones (or the new in the old, ``inverse``)."""
        top = self.order - 1
        identity = [self.basis.variable(k, top) for k in range(self.basis.n_variables)]
        return self.transform(identity, inverse=inverse, top=top)


def removed_mask(basis: MonomialBasis, degree: int, eta: np.ndarray, form: str, resonance_tolerance: float) -> tuple[np.ndarray, np.ndarray]:
    """Which monomials of ``degree`` the form removes, and their divisors ⟨η, a − b⟩."""
    n = basis.n_dof
    exponents = basis.exponents[degree]
    difference = exponents[:, :n] - exponents[:, n:]
    divisors = difference @ eta
    hyperbolic = np.abs(eta.real) > 0
    if form == "partial":
        removed = np.any(difference[:, hyperbolic] != 0, axis=1)
    elif form == "full":
        removed = np.any(difference != 0, axis=1) & (np.abs(divisors) > resonance_tolerance)
    else:
        raise ValueError(f"form must be one of {FORMS}, got {form!r}")
    return removed, divisors


def normalize(basis: MonomialBasis, hamiltonian: list[np.ndarray], eta: np.ndarray, order: int, *,
              form: str = "full", resonance_tolerance: float = 1e-9) -> Normalization:
    """Normalize H (complex coordinates, H₂ = Σ η_k q_k p_k, degrees 0..order) to degree ``order``."""
    if order > basis.max_degree:
        raise ValueError(f"order {order} exceeds the basis' degree {basis.max_degree}")
    eta = np.asarray(eta, dtype=np.complex128)
    h = [np.array(c, dtype=np.complex128, copy=True) for c in hamiltonian[: order + 1]]
    h[0][:] = 0.0
    h[1][:] = 0.0
    result = Normalization(basis=basis, order=order, form=form, eta=eta, hamiltonian=h)
    for s in range(3, order + 1):
        removed, divisors = removed_mask(basis, s, eta, form, resonance_tolerance)
        targets = removed & (h[s] != 0)
        unbalanced = np.any(basis.exponents[s][:, : basis.n_dof] != basis.exponents[s][:, basis.n_dof:], axis=1)
        result.resonant_terms[s] = int(np.sum(unbalanced & ~removed & (h[s] != 0)))
        result.smallest_divisor[s] = float(np.min(np.abs(divisors[targets]))) if targets.any() else float("inf")
        if not targets.any():
            continue
        w = np.zeros_like(h[s])
        w[targets] = h[s][targets] / divisors[targets]
        result.generators[s] = w
        h = lie_series(basis, h, w, s, order)
        h[s][removed] = 0.0  # what is left there is rounding
    result.hamiltonian = h
    return result
