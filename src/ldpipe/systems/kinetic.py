"""The kinetic matrix: H = p^T M^-1 p / 2 + V(q) with a constant, symmetric positive definite M.

A system entry may give ``masses`` (a mass per coordinate, a diagonal M) or ``mass_matrix``
(the whole M, rows in coordinate order); without either, M is the identity. This module
reads and checks them; :class:`ldpipe.systems.System` keeps the result (``mass_matrix``, None
for the identity, so that unit masses take exactly today's code paths and give bit-identical
results).

>>> kinetic_matrix({"masses": {"x": 8, "y": 8}}, ("x", "y"), "systems.dlb")
((8.0, 0.0), (0.0, 8.0))
>>> kinetic_matrix({"masses": {"x": 1}}, ("x", "y"), "systems.s") is None
True
"""

from __future__ import annotations

import numpy as np

from ..errors import ConfigError

# Relative asymmetry |M - M^T| / max|M| accepted in a given matrix (rounding of typed decimals);
# the matrix used is then the symmetric part.
SYMMETRY_TOLERANCE = 1e-12


def _number(value, key: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value):
        raise ConfigError(f"config key '{key}': expected a finite number, got {value!r}")
    return float(value)


def kinetic_matrix(spec: dict, coordinates: tuple[str, ...], key: str) -> tuple[tuple[float, ...], ...] | None:
    """M of a ``systems:`` entry as a tuple of rows, or None when it is the identity.

    ``key`` names the entry in error messages. ConfigError for both keys given, an unknown
    coordinate, a mass <= 0, a matrix of the wrong shape, not symmetric, or not positive definite.
    """
    n = len(coordinates)
    if "masses" in spec and "mass_matrix" in spec:
        raise ConfigError(f"config key '{key}': give 'masses' (diagonal) or 'mass_matrix', not both")
    if "masses" in spec:
        masses = spec["masses"]
        if not isinstance(masses, dict):
            raise ConfigError(
                f"config key '{key}.masses': expected a mapping coordinate -> mass, e.g. "
                f"{{{coordinates[0]}: 8.0}}, got {masses!r}"
            )
        matrix = np.eye(n)
        for name, value in masses.items():
            if name not in coordinates:
                raise ConfigError(
                    f"config key '{key}.masses.{name}': {name!r} is not a coordinate; expected one of {list(coordinates)}"
                )
            mass = _number(value, f"{key}.masses.{name}")
            if not mass > 0.0:
                raise ConfigError(f"config key '{key}.masses.{name}': a mass must be > 0, got {value!r}")
            index = coordinates.index(name)
            matrix[index, index] = mass
    elif "mass_matrix" in spec:
        rows = spec["mass_matrix"]
        where = f"{key}.mass_matrix"
        if not isinstance(rows, (list, tuple)) or len(rows) != n or not all(
            isinstance(row, (list, tuple)) and len(row) == n for row in rows
        ):
            raise ConfigError(
                f"config key '{where}': expected {n} rows of {n} numbers (coordinates {list(coordinates)}), got {rows!r}"
            )
        matrix = np.array([[_number(v, f"{where}[{i}][{j}]") for j, v in enumerate(row)] for i, row in enumerate(rows)])
        scale = float(np.max(np.abs(matrix)))
        if scale == 0.0 or float(np.max(np.abs(matrix - matrix.T))) > SYMMETRY_TOLERANCE * scale:
            raise ConfigError(f"config key '{where}': the kinetic matrix must be symmetric, got {rows!r}")
        matrix = 0.5 * (matrix + matrix.T)
        try:
            np.linalg.cholesky(matrix)
        except np.linalg.LinAlgError:
            eigenvalues = np.linalg.eigvalsh(matrix)
            raise ConfigError(
                f"config key '{where}': the kinetic matrix must be positive definite; its eigenvalues are "
                f"{[float(f'{e:.6g}') for e in eigenvalues]}"
            ) from None
    else:
        return None
    if np.array_equal(matrix, np.eye(n)):
        return None
    return tuple(tuple(float(v) for v in row) for row in matrix)


def inverse_of(matrix: np.ndarray) -> np.ndarray:
    """M^-1: exact reciprocals for a diagonal M (1/8 is 0.125 exactly), else by LU."""
    if np.array_equal(matrix, np.diag(np.diag(matrix))):
        return np.diag(1.0 / np.diag(matrix))
    inverse = np.linalg.inv(matrix)
    return 0.5 * (inverse + inverse.T)
