"""Equilibria of an autonomous vector field dx/dt = f(x) in a box, and their eigenvalues.

A general flow has no energy and no Hessian: its equilibria are the roots of f, found by the
same multi-start search as the Hamiltonian's (``equilibria.roots_in_box`` over f and the
compiled Jacobian Df), and its linear analysis is the spectrum of Df there. The type counts the
eigenvalues with positive and negative real part (the unstable and stable dimensions): a
``sink``, a ``source``, a ``saddle`` (both), or ``non-hyperbolic`` where an eigenvalue's real
part is zero to the tolerance. A time-dependent field has no fixed equilibria and is refused.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from .potential import box_bounds, roots_in_box, spectrum_variables
from ...errors import ConfigError


def vector_field_equilibria(system, lower: np.ndarray, upper: np.ndarray, seeds_per_axis: int = 9,
                            tolerance: float = 1e-10) -> np.ndarray:
    """Roots of f in the box, shape (k, n_state), sorted, with Df as the Jacobian (see
    :func:`ldpipe.core.equilibria.potential.roots_in_box` for the seeds, the acceptance test and the merge)."""
    return roots_in_box(system.vector_field, system.jacobian, lower, upper, seeds_per_axis, tolerance)


def classify_flow(eigenvalues: np.ndarray, tolerance: float) -> tuple[str, int, int]:
    """(type, unstable dimension, stable dimension) from the Jacobian's eigenvalues."""
    scale = max(1.0, float(np.max(np.abs(eigenvalues)))) if len(eigenvalues) else 1.0
    unstable = int(np.sum(eigenvalues.real > tolerance * scale))
    stable = int(np.sum(eigenvalues.real < -tolerance * scale))
    if unstable + stable < len(eigenvalues):
        return "non-hyperbolic", unstable, stable
    if unstable and stable:
        return "saddle", unstable, stable
    return ("source" if unstable else "sink"), unstable, stable


def sorted_spectrum(matrix: np.ndarray, keys) -> tuple[np.ndarray, np.ndarray]:
    """The eigenvalues of ``matrix`` and its eigenvectors (rows, unit norm, phased so that their
    largest component is real and positive), ordered by ``np.lexsort(keys(eigenvalues))``."""
    eigenvalues, eigenvectors = np.linalg.eig(matrix)
    order = np.lexsort(keys(eigenvalues))
    values = eigenvalues[order].astype(complex)
    vectors = np.zeros((len(order), len(order)), dtype=complex)
    for mode, column in enumerate(order):
        vector = eigenvectors[:, column].astype(complex)
        vector /= np.linalg.norm(vector)
        pivot = vector[np.argmax(np.abs(vector))]
        vectors[mode] = vector * np.conj(pivot) / abs(pivot)
    return values, vectors


def flow_equilibrium_table(system, box: dict[str, list[float]], seeds_per_axis: int = 9,
                                    tolerance: float = 1e-10, key: str | None = None) -> xr.Dataset:
    """The equilibrium stage's result for an autonomous vector field (contract FLOW_EQUILIBRIA).

    Modes are ordered by decreasing real part of the eigenvalue (then by imaginary part);
    eigenvectors have unit norm, phased so that their largest component is real and positive.
    """
    if system.time_dependent:
        raise ConfigError(
            f"config key '{key or f'systems.{system.name}'}': system {system.name!r} is a time-dependent vector "
            "field; it has no fixed equilibria (the equilibrium stage applies to autonomous fields)"
        )
    lower, upper = box_bounds(system, box)
    positions = vector_field_equilibria(system, lower, upper, seeds_per_axis, tolerance)
    return spectral_table(
        system, positions, tolerance, order=lambda e: (-e.imag, -e.real), classify=classify_flow,
        words={"position": "equilibrium (a root of f)", "type": "type of equilibrium",
               "unstable": "number of Jacobian eigenvalues with positive real part",
               "stable": "number of Jacobian eigenvalues with negative real part"},
        attributes={"mode_order": "decreasing real part of the eigenvalue, then decreasing imaginary part"})


def spectral_table(system, positions, tolerance: float, *, order, classify, words: dict[str, str],
                   attributes: dict[str, str], matrix: str = "Jacobian") -> xr.Dataset:
    """The equilibrium stage's table of ``positions`` (a vector field's equilibria, a map's fixed
    points): each one's spectrum of ``system.jacobian`` ordered by ``order``
    (:func:`sorted_spectrum`), its type and dimensions by ``classify``. ``words`` are the long
    names of ``position``, ``type``, ``unstable`` and ``stable``; ``matrix`` names the matrix in
    the spectrum's long names; ``attributes`` join the table's own."""
    n = system.n_state
    positions = np.reshape(positions, (-1, n))
    values = np.zeros((len(positions), n), dtype=complex)
    vectors = np.zeros((len(positions), n, n), dtype=complex)
    kinds, unstable, stable = [], [], []
    for index, x in enumerate(positions):
        values[index], vectors[index] = sorted_spectrum(system.jacobian(x), order)
        kind, u, s = classify(values[index], tolerance)
        kinds.append(kind)
        unstable.append(u)
        stable.append(s)
    spectrum = spectrum_variables(values, vectors)
    for variable in spectrum.values():
        variable[2]["long_name"] = variable[2]["long_name"].replace("Jacobian", matrix)
    dataset = xr.Dataset(
        {
            "position": (("equilibrium", "coordinate"), positions, {"long_name": words["position"]}),
            "type": (("equilibrium",), np.array(kinds, dtype=object), {"long_name": words["type"]}),
            "unstable_dimension": (("equilibrium",), np.array(unstable, dtype=np.int32),
                                   {"long_name": words["unstable"]}),
            "stable_dimension": (("equilibrium",), np.array(stable, dtype=np.int32), {"long_name": words["stable"]}),
            **spectrum,
        },
        coords={
            "coordinate": ("coordinate", np.array(system.coordinates, dtype=object)),
            "phase": ("phase", np.array(system.coordinates, dtype=object)),
            "mode": ("mode", np.arange(n, dtype=np.int32)),
        },
    )
    dataset.attrs.update({"search_method": "numeric", "search_numeric_found": len(positions),
                          "system": system.name, "system_description": system.description,
                          "classification_tolerance": tolerance, **attributes})
    return dataset
