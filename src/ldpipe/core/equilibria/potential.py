"""Equilibria of H = p^T M^-1 p / 2 + V(q) in a box, and the linear analysis at each.

Equilibria are the critical points of V (with p = 0). The Jacobian of Hamilton's
equations there is J = [[0, M^-1], [-Hess V, 0]]: if Hess V u = h M u, then
J (u, beta M u) = beta (u, beta M u) with beta^2 = -h (M = I without masses). So every
eigenvalue of J is real (a saddle direction, h < 0) or imaginary (a centre, h > 0),
and the Morse index of V (the count of h < 0; M positive definite leaves it unchanged,
Sylvester's law of inertia) gives the type: 0 a minimum, 1 an index-1 saddle
(saddle x centre^(n-1)), and so on.

The multi-start search for roots in a box (:func:`roots_in_box`) is written once, over a
function and its Jacobian: here f = grad V with the Hessian, in ``flow_equilibria`` the vector
field of a general flow with Df.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import xarray as xr

from ...errors import ConfigError, StageFileError
from ...systems import System, VectorFieldSystem


@dataclass(frozen=True)
class LinearAnalysis:
    """Linearization at one equilibrium; modes ordered as described in :func:`linear_analysis`."""

    hessian_eigenvalues: np.ndarray  # (n,) ascending
    eigenvalues: np.ndarray  # (2n,) complex
    eigenvectors: np.ndarray  # (2n, 2n) complex, row k is the eigenvector of mode k
    morse_index: int
    kind: str


def box_bounds(system: System | VectorFieldSystem, box: dict[str, list[float]]) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper corners of the search box, in coordinate order."""
    lower = np.array([box[name][0] for name in system.coordinates], dtype=float)
    upper = np.array([box[name][1] for name in system.coordinates], dtype=float)
    return lower, upper


def _newton_polish(function: Callable, jacobian: Callable, x: np.ndarray, iterations: int = 3) -> np.ndarray:
    # A few Newton steps on f = 0 take a hybrid solver's answer to rounding level.
    for _ in range(iterations):
        try:
            x = x - np.linalg.solve(jacobian(x), function(x))
        except np.linalg.LinAlgError:
            break
    return x


def roots_in_box(
    function: Callable[[np.ndarray], np.ndarray],
    jacobian: Callable[[np.ndarray], np.ndarray],
    lower: np.ndarray,
    upper: np.ndarray,
    seeds_per_axis: int = 9,
    tolerance: float = 1e-10,
) -> np.ndarray:
    """Roots of ``function`` (R^n to R^n, Jacobian ``jacobian``) in the box, shape (k, n), sorted.

    Seeds form a ``seeds_per_axis``^n grid over the box; scipy's hybrid solver, given the
    Jacobian, takes each to a root, and Newton's method polishes it. A root is kept if inside the
    box with ``|f| <= tolerance`` scaled by the sizes of the Jacobian there and of the box, each
    at least 1 (|f| / |Df| estimates the distance to the root), and merged with one found before
    when closer than ``sqrt(tolerance)`` times the box size.
    """
    from scipy.optimize import root  # here: jobs that only read equilibria (figures, LD maps) skip scipy.optimize

    axes = [np.linspace(lo, hi, seeds_per_axis) for lo, hi in zip(lower, upper)]
    scale = float(np.max(upper - lower))
    found: list[np.ndarray] = []
    for seed in itertools.product(*axes):
        solution = root(function, np.array(seed), jac=jacobian, method="hybr")
        x = _newton_polish(function, jacobian, solution.x)
        if not np.all(np.isfinite(x)) or np.any(x < lower) or np.any(x > upper):
            continue
        size = max(1.0, float(np.max(np.abs(jacobian(x)))))
        if np.max(np.abs(function(x))) > tolerance * size * max(1.0, scale):
            continue
        if all(np.max(np.abs(x - other)) > np.sqrt(tolerance) * scale for other in found):
            found.append(x)
    if not found:
        return np.empty((0, len(lower)))
    return np.array(sorted(found, key=tuple))


def numeric_equilibria(
    system: System,
    lower: np.ndarray,
    upper: np.ndarray,
    seeds_per_axis: int = 9,
    tolerance: float = 1e-10,
) -> np.ndarray:
    """Critical points of V in the box, shape (k, n_dof): the roots of grad V, with the Hessian
    as its Jacobian (see :func:`roots_in_box` for the seeds, the acceptance test and the merge)."""
    return roots_in_box(system.gradient, system.hessian, lower, upper, seeds_per_axis, tolerance)


def classify(morse_index: int, n_dof: int, degenerate: bool) -> str:
    if degenerate:
        return "degenerate"
    if morse_index == 0:
        return "minimum"
    if morse_index == n_dof and n_dof > 1:
        return "maximum"
    return f"index-{morse_index} saddle"


def linear_analysis(system: System, q: np.ndarray, degeneracy_tolerance: float = 1e-10) -> LinearAnalysis:
    """Eigenvalues and eigenvectors of the Jacobian at the equilibrium ``q``.

    Modes are ordered: saddle pairs first (+lambda, -lambda, largest lambda
    first), then centre pairs (+i omega, -i omega, largest omega first), then
    zero modes. Eigenvectors have unit Euclidean norm, phased so that their
    largest position component is real and positive. For the 2 DoF index-1
    saddle this is the paper's order lambda, -lambda, i omega, -i omega.
    """
    n = system.n_dof
    values, vectors = system.normal_modes(q)
    mass = system.mass
    scale = max(1.0, float(np.max(np.abs(values))))
    degenerate = bool(np.any(np.abs(values) <= degeneracy_tolerance * scale))
    saddle = [(np.sqrt(-h), vectors[:, i]) for i, h in enumerate(values) if h < -degeneracy_tolerance * scale]
    centre = [(np.sqrt(h), vectors[:, i]) for i, h in enumerate(values) if h > degeneracy_tolerance * scale]
    zero = [vectors[:, i] for i, h in enumerate(values) if abs(h) <= degeneracy_tolerance * scale]
    eigenvalues: list[complex] = []
    eigenvectors: list[np.ndarray] = []

    def add(beta: complex, u: np.ndarray) -> None:
        momentum = beta * u if system.mass_matrix is None else beta * (mass @ u)
        vector = np.concatenate([u, momentum]).astype(complex)
        vector /= np.linalg.norm(vector)
        # Fix the arbitrary phase: the largest position component real and positive.
        pivot = vector[np.argmax(np.abs(vector[:n]))]
        vector *= np.conj(pivot) / abs(pivot)
        eigenvalues.append(complex(beta))
        eigenvectors.append(vector)

    for rate, u in sorted(saddle, key=lambda item: -item[0]):
        add(rate, u)
        add(-rate, u)
    for frequency, u in sorted(centre, key=lambda item: -item[0]):
        add(1j * frequency, u)
        add(-1j * frequency, u)
    for u in zero:
        add(0.0, u)
        add(0.0, u)
    morse_index = int(np.sum(values < -degeneracy_tolerance * scale))
    return LinearAnalysis(
        hessian_eigenvalues=values,
        eigenvalues=np.array(eigenvalues),
        eigenvectors=np.array(eigenvectors),
        morse_index=morse_index,
        kind=classify(morse_index, n, degenerate),
    )


def locate_equilibria(
    system: System,
    box: dict[str, list[float]],
    seeds_per_axis: int = 9,
    tolerance: float = 1e-10,
) -> tuple[np.ndarray, dict]:
    """Every equilibrium in ``box``: the closed form where there is one, checked numerically.

    Returns the positions, shape (k, n_dof), and a dict describing how they were
    obtained, for the file's attributes. For a built-in system, a numeric root
    the closed form lacks is an error (the derivation would be incomplete).
    """
    lower, upper = box_bounds(system, box)
    numeric = numeric_equilibria(system, lower, upper, seeds_per_axis, tolerance)
    if system.closed_form_equilibria is None:
        return numeric, {"method": "numeric", "numeric_found": len(numeric)}
    closed = system.closed_form_equilibria()
    inside = np.all((closed >= lower) & (closed <= upper), axis=1)
    closed = closed[inside]
    matched = []
    for point in numeric:
        distances = np.max(np.abs(closed - point), axis=1) if len(closed) else np.array([np.inf])
        if distances.min() > np.sqrt(tolerance) * max(1.0, float(np.max(upper - lower))):
            raise RuntimeError(
                f"{system.name}: numeric search found an equilibrium at {point} that the closed form "
                "lacks; the closed-form derivation is incomplete"
            )
        matched.append(distances.min())
    details = {
        "method": "closed form, cross-checked by multi-start root finding",
        "numeric_found": len(numeric),
        "closed_form_found": len(closed),
        "max_distance_closed_form_to_numeric": float(max(matched)) if matched else 0.0,
    }
    return closed, details


def spectrum_variables(eigenvalues: np.ndarray, eigenvectors: np.ndarray) -> dict[str, tuple]:
    """The Jacobian's eigenvalues, shape (k, modes), and unit eigenvectors, shape (k, modes, phase),
    at k equilibria as the variables of an equilibria file, Hamiltonian or flow alike (real and
    imaginary parts apart: netCDF has no complex type)."""
    return {
        "eigenvalue_real": (("equilibrium", "mode"), eigenvalues.real,
                            {"long_name": "real part of the Jacobian eigenvalue"}),
        "eigenvalue_imag": (("equilibrium", "mode"), eigenvalues.imag,
                            {"long_name": "imaginary part of the Jacobian eigenvalue"}),
        "eigenvector_real": (("equilibrium", "mode", "phase"), eigenvectors.real,
                             {"long_name": "real part of the Jacobian eigenvector (unit norm)"}),
        "eigenvector_imag": (("equilibrium", "mode", "phase"), eigenvectors.imag,
                             {"long_name": "imaginary part of the Jacobian eigenvector (unit norm)"}),
    }


def equilibrium_table(
    system: System,
    box: dict[str, list[float]],
    seeds_per_axis: int = 9,
    tolerance: float = 1e-10,
) -> xr.Dataset:
    """The equilibrium stage's result as a Dataset (see the README for its variables)."""
    positions, details = locate_equilibria(system, box, seeds_per_axis, tolerance)
    n = system.n_dof
    analyses = [linear_analysis(system, q) for q in positions]
    energies = np.array([system.potential(q) for q in positions])
    eigenvalues = np.array([a.eigenvalues for a in analyses]).reshape(len(positions), 2 * n)
    eigenvectors = np.array([a.eigenvectors for a in analyses]).reshape(len(positions), 2 * n, 2 * n)
    saddles = [i for i, a in enumerate(analyses) if a.kind == "index-1 saddle"]
    phase = list(system.phase_coordinates)
    dataset = xr.Dataset(
        {
            "position": (("equilibrium", "coordinate"), positions.reshape(-1, n), {"long_name": "equilibrium position"}),
            "energy": (("equilibrium",), energies, {"long_name": "energy H at the equilibrium (p = 0)"}),
            "morse_index": (("equilibrium",), np.array([a.morse_index for a in analyses], dtype=np.int32),
                            {"long_name": "number of negative eigenvalues of the Hessian of V"}),
            "type": (("equilibrium",), np.array([a.kind for a in analyses], dtype=object),
                     {"long_name": "type of equilibrium"}),
            "hessian_eigenvalue": (("equilibrium", "hessian_mode"),
                                   np.array([a.hessian_eigenvalues for a in analyses]).reshape(-1, n),
                                   {"long_name": "eigenvalues of the Hessian of V, ascending" if system.mass_matrix is None
                                    else "eigenvalues h of Hess V u = h M u (M the mass_matrix), ascending"}),
            **spectrum_variables(eigenvalues, eigenvectors),
            "saddle_equilibrium": (("saddle",), np.array(saddles, dtype=np.int32),
                                   {"long_name": "index along 'equilibrium' of each index-1 saddle"}),
            "critical_energy": (("saddle",), energies[saddles] if saddles else np.empty(0),
                                {"long_name": "critical energy E_c of the index-1 saddle; excess energy is E - E_c"}),
        },
        coords={
            "coordinate": ("coordinate", np.array(system.coordinates, dtype=object)),
            "phase": ("phase", np.array(phase, dtype=object)),
            "mode": ("mode", np.arange(2 * n, dtype=np.int32)),
        },
    )
    dataset.attrs.update({f"search_{k}": v for k, v in details.items()})
    dataset.attrs["system"] = system.name
    dataset.attrs["system_description"] = system.description
    dataset.attrs.update(system.kinetic_attributes())
    if system.formula:
        dataset.attrs["potential_formula"] = system.formula
    dataset.attrs["mode_order"] = (
        "saddle pairs (+lambda, -lambda), largest first; then centre pairs (+i omega, -i omega), "
        "largest first; then zero modes"
    )
    return dataset


def select_saddle(equilibria: xr.Dataset, near: list[float] | None) -> tuple[np.ndarray, float]:
    """Position and critical energy of the index-1 saddle nearest ``near`` (default: lowest E_c)."""
    if equilibria.sizes.get("saddle", 0) == 0:
        raise ConfigError(
            f"system {equilibria.attrs.get('system')!r} has no index-1 saddle in its equilibrium search box; "
            "an excess energy or a 'saddle' coordinate needs one (widen systems.<name>.equilibria.box)"
        )
    indices = equilibria.saddle_equilibrium.values
    positions = equilibria.position.values[indices]
    energies = equilibria.critical_energy.values
    if near is None:
        choice = int(np.argmin(energies))
    else:
        if len(near) != positions.shape[1]:
            raise ConfigError(f"saddle_near: expected {positions.shape[1]} numbers, got {near}")
        choice = int(np.argmin(np.linalg.norm(positions - np.asarray(near), axis=1)))
    return positions[choice], float(energies[choice])


def well_and_frequencies(equilibria: xr.Dataset, saddle: np.ndarray, *,
                         require_well: bool = True) -> tuple[np.ndarray | None, np.ndarray]:
    """The minimum nearest the saddle (the well; None if there is none and ``require_well`` is
    false) and the saddle's centre frequencies, from the equilibria file."""
    minima = np.flatnonzero(equilibria.type.values == "minimum")
    positions = equilibria.position.values
    index = int(np.argmin(np.linalg.norm(positions - saddle, axis=1)))
    if len(minima):
        well = positions[minima[np.argmin(np.linalg.norm(positions[minima] - saddle, axis=1))]]
    elif require_well:
        raise StageFileError("the equilibria file has no minimum: a well is needed (the transport stage)")
    else:
        well = None
    imag = equilibria.eigenvalue_imag.values[index]
    frequencies = imag[imag > 1e-12]  # (+iω, −iω) pairs: one positive value per centre
    return well, np.sort(frequencies)[::-1]
