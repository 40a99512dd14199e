"""The natural Hamiltonian H = p^T M^-1 p / 2 + V(q) as ldpipe sees it (M constant; the identity by default).

A :class:`System` carries compiled kernels for the potential and its first two
derivatives. Every kernel bakes the parameters in as compile-time constants, so
each system (and each parameter set) gets its own machine code; the trajectory
engine and the linear analysis only ever call these kernels.

Kernel signatures (all numba ``njit`` functions, float64 throughout):

``potential(q) -> float``
    ``q`` has shape ``(n_dof,)``.
``gradient(q, out) -> None``
    writes dV/dq into ``out``, shape ``(n_dof,)``.
``hessian(q, out) -> None``
    writes the symmetric matrix d2V/dq2 into ``out``, shape ``(n_dof, n_dof)``.
``acceleration_block(q, out, count) -> None``
    structure-of-arrays form for the hot loop: ``q`` and ``out`` have shape
    ``(n_dof, block)``; for the first ``count`` columns writes ``out = -dV/dq``.
``potential_block(q, out, count) -> None``
    ``q`` shape ``(n_dof, block)``, ``out`` shape ``(block,)``.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Callable, ClassVar, NamedTuple

import numpy as np

from ..jitcache import njit_functions
from .model import Unbounded, system_repr
from .kinetic import inverse_of


class Kernels(NamedTuple):
    potential: Callable
    gradient: Callable
    hessian: Callable
    acceleration_block: Callable
    potential_block: Callable


def compile_kernels(kernel_source: str, prefix: str) -> Kernels:
    """Compile the five kernels that ``kernel_source`` defines (cached on disk, see jitcache)."""
    return Kernels(*njit_functions(kernel_source, Kernels._fields, prefix))


@dataclass(frozen=True)
class System(Unbounded):
    """A natural Hamiltonian system with compiled kernels.

    Parameters
    ----------
    name : str
        The key under which the system is declared in the configuration.
    coordinates : tuple of str
        Names of the configuration coordinates, e.g. ``("x", "y")``; the
        conjugate momenta are named ``"p" + name``.
    parameters : dict of str to float
        The parameter values baked into the kernels.
    kernels : Kernels
        Compiled kernels, see the module docstring.
    kernel_source : str
        Python source defining the five kernels (undecorated, parameters as
        module-level constants), from which ``kernels`` were compiled; the engine
        compiles it into its own generated module.
    description : str
        One line for file titles and figure captions.
    closed_form_equilibria : callable or None
        Returns every equilibrium as an array of shape ``(k, n_dof)`` from a
        derived closed form; None where only a numeric search is available.
    formula : str or None
        The potential as text, for formula systems.
    mass_matrix : tuple of tuples of float, or None
        The constant kinetic matrix M of H = p^T M^-1 p / 2 + V (rows in coordinate order,
        symmetric positive definite; :mod:`ldpipe.systems.kinetic`); None for the identity,
        which keeps every code path of unit masses as it was (bit-identical results).
    """

    name: str
    coordinates: tuple[str, ...]
    parameters: dict[str, float]
    kernels: Kernels
    kernel_source: str
    description: str = ""
    closed_form_equilibria: Callable[[], np.ndarray] | None = None
    formula: str | None = None
    spec: dict = field(default_factory=dict)
    mass_matrix: tuple[tuple[float, ...], ...] | None = None

    #: A natural Hamiltonian (:class:`ldpipe.systems.VectorFieldSystem` is not).
    hamiltonian: ClassVar[bool] = True
    #: A flow in continuous time, not a discrete map.
    discrete: ClassVar[bool] = False

    def __repr__(self) -> str:
        return system_repr(self, "builtin" if "builtin" in self.spec else "formula")

    @property
    def n_dof(self) -> int:
        return len(self.coordinates)

    @property
    def momenta(self) -> tuple[str, ...]:
        return tuple("p" + name for name in self.coordinates)

    @property
    def phase_coordinates(self) -> tuple[str, ...]:
        return self.coordinates + self.momenta

    def ld_units(self, arclength: bool, p: float | None = None) -> str | None:
        """The LD is in the units of the phase space, which a system does not name: None."""
        return None

    def check_times(self, start: float, end: float, key: str | None = None) -> None:
        """An autonomous Hamiltonian holds at every time: nothing to refuse."""

    def potential(self, q: np.ndarray) -> float:
        return float(self.kernels.potential(np.ascontiguousarray(q, dtype=np.float64)))

    def potentials(self, points: np.ndarray) -> np.ndarray:
        """V at each row of ``points`` (shape (k, n_dof)) in one kernel call; the same numbers as
        :meth:`potential` row by row (the block kernel evaluates the same expression)."""
        columns = np.ascontiguousarray(np.asarray(points, dtype=np.float64).reshape(-1, self.n_dof).T)
        out = np.empty(columns.shape[1])
        self.kernels.potential_block(columns, out, columns.shape[1])
        return out

    def gradient(self, q: np.ndarray) -> np.ndarray:
        out = np.empty(self.n_dof)
        self.kernels.gradient(np.ascontiguousarray(q, dtype=np.float64), out)
        return out

    def hessian(self, q: np.ndarray) -> np.ndarray:
        out = np.empty((self.n_dof, self.n_dof))
        self.kernels.hessian(np.ascontiguousarray(q, dtype=np.float64), out)
        return out

    @property
    def mass(self) -> np.ndarray:
        """The kinetic matrix M, shape ``(n_dof, n_dof)`` (the identity without masses)."""
        return np.eye(self.n_dof) if self.mass_matrix is None else np.array(self.mass_matrix)

    @property
    def inverse_mass(self) -> np.ndarray:
        """M^-1 (exact reciprocals for diagonal masses)."""
        return np.eye(self.n_dof) if self.mass_matrix is None else inverse_of(np.array(self.mass_matrix))

    def kinetic_attributes(self) -> dict[str, str]:
        """What a stage file records of the kinetic matrix: nothing for unit masses (their files are
        as they were), else ``mass_matrix`` (the rows, as JSON) and the Hamiltonian's form."""
        if self.mass_matrix is None:
            return {}
        return {
            "mass_matrix": json.dumps([list(row) for row in self.mass_matrix]),
            "hamiltonian": "H = p^T M^-1 p / 2 + V(q), M = mass_matrix (rows in coordinate order)",
        }

    def velocity(self, momenta: np.ndarray) -> np.ndarray:
        """dq/dt = M^-1 p, for momenta of shape ``(..., n_dof)``."""
        momenta = np.asarray(momenta, dtype=np.float64)
        return momenta if self.mass_matrix is None else momenta @ self.inverse_mass.T

    def kinetic_energy(self, momenta: np.ndarray) -> np.ndarray | float:
        """p^T M^-1 p / 2, for momenta of shape ``(..., n_dof)``."""
        momenta = np.asarray(momenta, dtype=np.float64)
        # a momentum beyond ~1e154 has an infinite kinetic energy: the right answer (no energy
        # surface holds it), not a fault to warn of
        with np.errstate(over="ignore"):
            if self.mass_matrix is None:
                return 0.5 * np.sum(momenta**2, axis=-1)
            return 0.5 * np.sum(momenta * self.velocity(momenta), axis=-1)

    def energy(self, state: np.ndarray) -> float:
        """H at one phase-space point ``state = (q, p)``, shape ``(2 n_dof,)``."""
        state = np.asarray(state, dtype=np.float64)
        momentum = state[self.n_dof :]
        if self.mass_matrix is None:
            return 0.5 * float(momentum @ momentum) + self.potential(state[: self.n_dof])
        return float(self.kinetic_energy(momentum)) + self.potential(state[: self.n_dof])

    def vector_field(self, state: np.ndarray) -> np.ndarray:
        """Hamilton's equations: d(q, p)/dt = (M^-1 p, -dV/dq)."""
        state = np.asarray(state, dtype=np.float64)
        return np.concatenate([self.velocity(state[self.n_dof :]), -self.gradient(state[: self.n_dof])])

    def jacobian(self, state: np.ndarray) -> np.ndarray:
        """Jacobian of the vector field, [[0, M^-1], [-Hess V, 0]]; it depends on q only."""
        n = self.n_dof
        matrix = np.zeros((2 * n, 2 * n))
        matrix[:n, n:] = self.inverse_mass
        matrix[n:, :n] = -self.hessian(np.asarray(state, dtype=np.float64)[:n])
        return matrix

    def normal_modes(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The generalized eigenproblem Hess V u = h M u at ``q``: h ascending, u as columns.

        At an equilibrium, J (u, beta M u) = beta (u, beta M u) with beta^2 = -h, J the
        :meth:`jacobian`: h < 0 a saddle rate sqrt(-h), h > 0 a frequency sqrt(h)
        (det(Hess V - omega^2 M) = 0). The u are M-orthonormal (orthonormal for M = I).
        """
        hessian = self.hessian(q)
        if self.mass_matrix is None:
            return np.linalg.eigh(hessian)
        from scipy.linalg import eigh

        return eigh(hessian, self.mass)
