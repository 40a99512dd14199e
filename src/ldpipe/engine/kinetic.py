"""The kinetic step of a system with masses: what the engine adds for H = p^T M^-1 p / 2 + V.

Every scheme integrates the second-order system q'' = a(q) in the pair (q, q'), which is
Hamilton's equations exactly when p = q' (M = I). With a constant M, Hamilton's equations
q' = M^-1 p, p' = -grad V are the same second-order system with a(q) = -M^-1 grad V, the
pair (q, q') = (q, M^-1 p) carried instead of (q, p): a linear map of the momenta only, so
each step maps (q, p) -> (q, M q') with the scheme's own order, and the symplectic
compositions stay symplectic (their drift q += h q' is q += h M^-1 p, their kick
q' += h a is p += -h grad V). Accordingly, for a system with masses, the generated module ends
with this section, which rebinds

* ``gradient`` to M^-1 grad V and ``acceleration_block`` to -M^-1 grad V (the templates use
  them only as the acceleration a(q) and its trial value in the starting-step rule);
* ``energy`` to (q')^T M q' / 2 + V (= p^T M^-1 p / 2 + V);
* ``attempt`` to the scheme's attempt followed by p' = M a on the velocity polynomials, so
  that the LD integrands see the phase-space velocity (q', p') of H itself.

The drivers' states are (q, q'): :func:`to_engine_states` converts the rows given to the
engine, :func:`to_momenta` the rows it returns. Unit masses (``system.mass_matrix is None``)
add nothing to the module and convert nothing, so their code and results are unchanged.
Every product below is written out with M's and M^-1's entries as literals (zeros dropped).
"""

from __future__ import annotations

import numpy as np


def _combination(matrix: np.ndarray, row: int, names: list[str]) -> str:
    terms = [f"{float(c)!r} * {name}" for c, name in zip(matrix[row], names) if c != 0.0]
    return " + ".join(terms) if terms else "0.0"


def kinetic_source(system) -> str:
    """The module's closing section for ``system`` (see the module docstring); "" without masses."""
    if system.mass_matrix is None:
        return ""
    n = system.n_dof
    mass, inverse = system.mass, system.inverse_mass
    g = [f"g{i}" for i in range(n)]
    kinetic = " + ".join(
        f"{float(mass[i, k] * (1.0 if i == k else 2.0))!r} * v{i} * v{k}"
        for i in range(n) for k in range(i, n) if mass[i, k] != 0.0
    )  # fmt: skip
    lines = [
        "_potential_gradient = gradient",
        "_force_block = acceleration_block",
        "_velocity_attempt = attempt",
        "",
        "",
        "@njit(**JIT)",
        "def gradient(q, out):",
        "    _potential_gradient(q, out)",
        *[f"    g{i} = out[{i}]" for i in range(n)],
        *[f"    out[{i}] = {_combination(inverse, i, g)}" for i in range(n)],
        "",
        "",
        "@njit(**JIT)",
        "def acceleration_block(q, out, count):",
        "    _force_block(q, out, count)",
        "    for j in range(count):",
        *[f"        g{i} = out[{i}, j]" for i in range(n)],
        *[f"        out[{i}, j] = {_combination(inverse, i, g)}" for i in range(n)],
        "",
        "",
        "@njit(**JIT)",
        "def energy(qv, pv):",
        *[f"    v{i} = pv[{i}]" for i in range(n)],
        f"    return 0.5 * ({kinetic}) + potential(qv)",
        "",
        "",
        "@njit(**JIT)",
        "def attempt(W, rtol, atol):",
        "    _velocity_attempt(W, rtol, atol)",
        "    for c in range(NC):",
        "        for j in range(LANES):",
        *[f"            g{i} = W[OVC + c * CS + {n + i} * LANES + j]" for i in range(n)],
        *[f"            W[OVC + c * CS + {n + i} * LANES + j] = {_combination(mass, i, g)}" for i in range(n)],
    ]
    return "\n".join(lines) + "\n"


def to_engine_states(system, states: np.ndarray) -> np.ndarray:
    """Rows (q, p) -> (q, M^-1 p), the drivers' variables; the rows themselves without masses."""
    if system.mass_matrix is None:
        return states
    n = system.n_dof
    converted = np.array(states, dtype=np.float64, copy=True)
    converted[..., n:] = system.velocity(states[..., n:])
    return converted


def to_momenta(system, states: np.ndarray) -> np.ndarray:
    """Rows (q, q') -> (q, M q') in place (and returned); nothing to do without masses."""
    if system.mass_matrix is not None:
        n = system.n_dof
        states[..., n:] = states[..., n:] @ system.mass.T
    return states
