"""The normal form of an equilibrium of H = pᵀM⁻¹p/2 + V, with its coordinate changes and actions.

:func:`equilibrium_normal_form` chains the steps: V's Taylor coefficients (sympy, once), the
symplectic change to normal modes, the complex diagonal coordinates, the Lie-series
normalization to the order asked, and the changes to and from the original coordinates as real
polynomials in the real normal-form coordinates X = (Q₁..Qₙ, P₁..Pₙ) (``to_original``:
δx(X); ``from_original``: X(δx), δx = x − x_s). In X the saddle pair is H₂ = λ Q₁ P₁, the NHIM
is Q₁ = P₁ = 0 and the dividing surface Q₁ = P₁ (x = (Q₁ − P₁)/√2 = 0, the reaction coordinate).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import sympy

from .expansion import NormalModes, hamiltonian_taylor, hessian_of, normal_modes, potential_taylor
from .lie import Normalization, normalize
from .polynomials import MonomialBasis


@dataclass
class EquilibriumNormalForm:
    """A normalized equilibrium: see the module docstring; energies are relative to ``energy``."""

    position: np.ndarray
    energy: float
    modes: NormalModes
    normalization: Normalization
    hamiltonian_real: list[np.ndarray]
    imaginary_residual: float = 0.0
    changes: dict = field(default_factory=dict, repr=False)

    @property
    def to_original(self) -> list[list[np.ndarray]]:
        """δx_i(X): the original coordinates' displacements as real polynomials of degree ≤ order − 1
        in the real normal-form coordinates (computed on first use)."""
        if "to" not in self.changes:
            self.changes["to"] = self._change(inverse=False)
        return self.changes["to"]

    @property
    def from_original(self) -> list[list[np.ndarray]]:
        """X_i(δx): the inverse change (computed on first use)."""
        if "from" not in self.changes:
            self.changes["from"] = self._change(inverse=True)
        return self.changes["from"]

    def _change(self, *, inverse: bool) -> list[list[np.ndarray]]:
        basis, modes, top = self.basis, self.modes, self.order - 1
        functions = self.normalization.coordinates(inverse=inverse)  # y(Y), or Y(y)
        if inverse:
            functions = [basis.substitute_linear(f, np.linalg.inv(modes.complex_matrix), top) for f in functions]
            functions = combine(basis, modes.to_complex, functions)  # X(δx)
        else:
            functions = [basis.substitute_linear(f, np.linalg.inv(modes.to_complex), top) for f in functions]
            functions = combine(basis, modes.complex_matrix, functions)  # δx(X)
        functions, residual = real_parts(functions)
        self.imaginary_residual = max(self.imaginary_residual, residual)
        return functions

    @property
    def basis(self) -> MonomialBasis:
        return self.normalization.basis

    @property
    def n_dof(self) -> int:
        return self.basis.n_dof

    @property
    def order(self) -> int:
        return self.normalization.order

    def action_terms(self, order: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """K's terms in the actions (I for a saddle pair, J for a centre): exponents (m, n) and coefficients.

        Only the balanced monomials q^a p^a are functions of the actions (q_k p_k = I_k, or −i J_k for
        a centre); the partial form's other terms, and resonant terms, are left out.
        """
        top = self.order if order is None else order
        n = self.n_dof
        exponents, values = [], []
        centre = ~self.modes.hyperbolic
        for degree in range(2, top + 1):
            e = self.basis.exponents[degree]
            balanced = np.all(e[:, :n] == e[:, n:], axis=1) & (self.normalization.hamiltonian[degree] != 0)
            for i in np.flatnonzero(balanced):
                a = e[i, :n]
                value = self.normalization.hamiltonian[degree][i] * (-1j) ** int(np.sum(a[centre]))
                exponents.append(a.copy())
                values.append(value.real)
        return np.array(exponents, dtype=np.int64).reshape(-1, n), np.array(values)

    def evaluate_actions(self, actions: np.ndarray, order: int | None = None) -> np.ndarray:
        """K(I, J) at ``actions`` (shape (m, n)) from :meth:`action_terms`."""
        exponents, values = self.action_terms(order)
        actions = np.atleast_2d(actions)
        return np.prod(actions[:, None, :] ** exponents[None, :, :], axis=2) @ values

    def original_states(self, normal: np.ndarray) -> np.ndarray:
        """Phase-space states x = x_s + δx(X) for real normal-form points X (shape (m, 2n))."""
        normal = np.atleast_2d(normal)
        displacement = self.basis.evaluate_all(self.to_original, normal).real.T
        return np.concatenate([self.position, np.zeros(self.n_dof)]) + displacement

    def normal_states(self, states: np.ndarray) -> np.ndarray:
        """Real normal-form points X(δx) of phase-space states (shape (m, 2n))."""
        states = np.atleast_2d(states)
        displacement = states - np.concatenate([self.position, np.zeros(self.n_dof)])
        return self.basis.evaluate_all(self.from_original, displacement).real.T


def combine(basis: MonomialBasis, matrix: np.ndarray, functions: list[list[np.ndarray]]) -> list[list[np.ndarray]]:
    """The linear combinations Σ_j matrix[i, j] f_j of polynomials."""
    out = []
    for row in matrix:
        total = [np.zeros_like(c) for c in functions[0]]
        for weight, f in zip(row, functions):
            if weight != 0:
                total = [t + weight * c for t, c in zip(total, f)]
        out.append(total)
    return out


def real_parts(functions: list[list[np.ndarray]]) -> tuple[list[list[np.ndarray]], float]:
    """The real polynomials, and the largest imaginary part dropped (rounding when all is well)."""
    largest = max(float(np.max(np.abs(c.imag), initial=0.0)) for f in functions for c in f)
    return [[np.ascontiguousarray(c.real) for c in f] for f in functions], largest


def equilibrium_normal_form(expression: sympy.Expr, symbols, position, order: int, *, form: str = "full",
                            inverse_mass: np.ndarray | None = None, transforms: bool = True,
                            resonance_tolerance: float = 1e-9) -> EquilibriumNormalForm:
    """Normal form to degree ``order`` of H = pᵀM⁻¹p/2 + V at the equilibrium ``position`` of V = ``expression``.

    ``transforms``: compute both coordinate changes now (else each on its first use).
    """
    n = len(symbols)
    basis = MonomialBasis(n, order)
    potential = potential_taylor(expression, symbols, position, order)
    energy = potential.get((0,) * n, 0.0)
    mass = None if inverse_mass is None else np.linalg.inv(inverse_mass)
    modes = normal_modes(hessian_of(potential, n), mass)
    h_complex = basis.substitute_linear(hamiltonian_taylor(basis, potential, inverse_mass), modes.complex_matrix)
    normalization = normalize(basis, h_complex, modes.eta, order, form=form, resonance_tolerance=resonance_tolerance)
    to_complex_inverse = np.linalg.inv(modes.to_complex)
    (hamiltonian_real,), imaginary = real_parts([basis.substitute_linear(normalization.hamiltonian, to_complex_inverse)])
    result = EquilibriumNormalForm(position=np.asarray(position, dtype=np.float64), energy=float(energy), modes=modes,
                                   normalization=normalization, hamiltonian_real=hamiltonian_real,
                                   imaginary_residual=imaginary)
    if transforms:  # now, rather than on first use
        for change in ("to_original", "from_original"):
            getattr(result, change)
    return result


def system_normal_form(system, position, order: int, *, form: str = "full", transforms: bool = True,
                       resonance_tolerance: float = 1e-9) -> EquilibriumNormalForm:
    """:func:`equilibrium_normal_form` of an ldpipe system (its formula, parameters and masses)."""
    from ...systems.formula import parse_potential

    if not system.formula:
        raise ValueError(f"system {system.name!r} has no formula for V: the normal form needs its Taylor coefficients")
    expression = parse_potential(system.formula, system.coordinates, system.parameters, f"systems.{system.name}")
    symbols = [sympy.Symbol(name, real=True) for name in system.coordinates]
    inverse_mass = None if system.mass_matrix is None else system.inverse_mass
    return equilibrium_normal_form(expression, symbols, position, order, form=form, inverse_mass=inverse_mass,
                                   transforms=transforms, resonance_tolerance=resonance_tolerance)
