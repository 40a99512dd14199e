"""The arc-length LD of a natural Hamiltonian's trajectories with its exact gradient along the
variational equations, and the deviation-vector indicators (FLI, SALI) of the same run.

The generated module is the system's kernel source (``gradient``, ``hessian``), a header (the
degrees of freedom ``N_DOF``, the phase-space dimension ``D``, the inverse kinetic matrix
``INV``) and the template ``variational_ld`` (the augmented system and its fixed-step
fourth-order Runge-Kutta integration, derived in the template's docstring), assembled by
:func:`ldpipe.engine.codegen.assemble`, loaded through :mod:`ldpipe.jitcache` (numba's disk
cache serves later processes) and run over units of starts on every thread.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .codegen import assemble, load_modules, template
from .integrator import kept_runner, run_units

ENTRY = "variational_ld"


class VariationalLDResult(NamedTuple):
    """Arrays over the starts of :func:`variational_ld`."""

    #: The arc-length LD over the time integrated.
    ld: np.ndarray
    #: dL/dx_0, shape (N, 2 n_dof), in the order (q..., p...).
    gradient: np.ndarray
    #: max over the steps of log10 |Phi u_1| (the fast Lyapunov indicator).
    fli: np.ndarray
    #: min over the steps of the smaller alignment index of Phi u_1 and Phi u_2.
    sali: np.ndarray
    #: Stopped early: the configuration left the escape radius or a value was not finite.
    escaped: np.ndarray
    #: |t| integrated (tau, or less where escaped).
    time: np.ndarray


def variational_modules(system):
    """The texts of the generated module of ``system``'s variational LD (see the module docstring)."""
    n = system.n_dof
    inverse = np.eye(n) if system.mass_matrix is None else np.asarray(system.inverse_mass, dtype=float)
    constants = {"N_DOF": n, "D": 2 * n, "INV": inverse}
    title = f"ldpipe.engine.variational_ld: {n} degrees of freedom"
    return assemble(system, f"variational_ld_{system.name}", title, ("gradient", "hessian"), constants,
                    [("variational_ld", template("variational_ld"))])


def deviation_vectors(dimension: int) -> tuple[np.ndarray, np.ndarray]:
    """Two fixed orthonormal deviation vectors with every component nonzero (none of them special
    to a coordinate): u_1 = (1, 1, ..., 1) / sqrt(D) and u_2 its alternating-sign partner made
    orthogonal to it."""
    first = np.full(dimension, 1.0 / math.sqrt(dimension))
    second = np.array([(-1.0) ** i * (1.0 + i) for i in range(dimension)])
    second -= (second @ first) * first
    return first, second / np.linalg.norm(second)


def variational_ld(system, states, tau: float, dt: float, direction: int = 1,
                   escape_radius: float = 1e3) -> VariationalLDResult:
    """The arc-length LD of each row of ``states`` over ``tau`` (``direction`` +1 forward, -1
    backward) with its gradient dL/dx_0, the FLI and the SALI, by fourth-order Runge-Kutta with
    equal steps no longer than ``dt`` (see the template ``variational_ld``)."""
    from numba import get_num_threads

    if not system.hamiltonian:
        raise ValueError(f"system: the variational LD takes a natural Hamiltonian; {system.name!r} is a vector field")
    for name, value in (("tau", tau), ("dt", dt), ("escape_radius", escape_radius)):
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
            raise ValueError(f"{name}: expected a finite number > 0, got {value!r}")
    if isinstance(direction, bool) or direction not in (1, -1):
        raise ValueError(f"direction: expected +1 (forward) or -1 (backward), got {direction!r}")
    dimension = 2 * system.n_dof
    states = np.ascontiguousarray(states, dtype=np.float64)
    if states.ndim != 2 or states.shape[1] != dimension:
        raise ValueError(f"states: expected shape (N, {dimension}) with rows {system.phase_coordinates} for "
                         f"{system.name}, got {states.shape}")
    steps = max(1, math.ceil(tau / dt - 1e-9))
    count = states.shape[0]
    outputs = (np.zeros(count), np.zeros((count, dimension)), np.zeros(count), np.zeros(count),
               np.zeros(count, dtype=np.bool_), np.zeros(count))
    if count:
        runner = kept_runner(system, ("variational_ld", ENTRY),
                             lambda: getattr(load_modules(variational_modules(system)), ENTRY))
        threads = get_num_threads()
        u1, u2 = deviation_vectors(dimension)
        args = (direction * tau / steps, steps, float(escape_radius), u1, u2)
        run_units(runner, states, max(1, min(64, count // (8 * threads) or 1)), args, outputs, threads)
    return VariationalLDResult(*outputs)
