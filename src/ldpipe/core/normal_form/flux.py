"""The flux over the saddle, the NHIM and the dividing surface, from a normal form.

In normal-form coordinates the NHIM at excess energy ΔE is {Q₁ = P₁ = 0, K(0, z) = ΔE}, z the
centre coordinates, and the flux through the dividing surface Q₁ = P₁ is the phase-space volume
it encloses in the centre space, {z : K(0, z) ≤ ΔE} (MacKay 1990; Waalkens & Wiggins 2004). Two
ways to compute it:

* ``actions`` (the full form, K a function of the actions): in 2 DoF 2π J with K(0, J) = ΔE
  (Newton), the action of the Lyapunov orbit; in 3 DoF (2π)² times the area of
  {(J₂, J₃) ≥ 0 : K(0, J₂, J₃) ≤ ΔE}, by Gauss–Legendre over J₂ of the root J₃(J₂);
* ``volume`` (any form, the partial one too): polar rays in the centre planes,
  z_k = √(2 J_k) (cos θ_k, −sin θ_k) with J_k = s w_k (w = 1 in 2 DoF, (1 − u, u) in 3 DoF), so
  that dz = ds dθ (2 DoF) or s ds du dθ₂ dθ₃ (3 DoF); along each ray K = Σ_d K_d(ẑ) r^d with
  r = √s, whose root K = ΔE is found by Newton; the angles by the trapezoid rule (spectral for
  a periodic integrand), u by Gauss–Legendre.
"""

from __future__ import annotations

import math

import numpy as np

from .saddle import EquilibriumNormalForm


def increasing_root(function, derivative, guess: np.ndarray, *, iterations: int = 200, tolerance: float = 4e-16) -> np.ndarray:
    """Roots x ≥ 0 of f(x) = 0 for f(0) < 0 increasing through its first root: Newton's steps, kept
    inside a bracket [lo, hi] (grown from ``guess`` by doubling) and bisected when they leave it."""
    guess = np.maximum(np.asarray(guess, dtype=np.float64), 1e-300)
    lo = np.zeros_like(guess)
    hi = guess.copy()
    for _ in range(200):
        low = function(hi) < 0
        if not low.any():
            break
        lo = np.where(low, hi, lo)
        hi = np.where(low, 2 * hi, hi)
    else:
        raise ArithmeticError("no energy level above the root's guess: is ΔE within the normal form's reach?")
    x = 0.5 * (lo + hi)
    for _ in range(iterations):
        value = function(x)
        lo = np.where(value < 0, x, lo)
        hi = np.where(value > 0, x, hi)
        newton = x - value / derivative(x)
        inside = (newton > lo) & (newton < hi)
        following = np.where(inside, newton, 0.5 * (lo + hi))
        if np.all(np.abs(following - x) <= tolerance * np.abs(following)) or np.all(hi - lo <= tolerance * hi):
            return following
        x = following
    raise ArithmeticError("the energy level's root did not converge")


def centre_action_at(nf: EquilibriumNormalForm, excess: float, *, order: int | None = None) -> float:
    """The 2 DoF centre action J with K(0, J) = ΔE (full form)."""
    if nf.n_dof != 2:
        raise ValueError("centre_action_at is for 2 DoF; use flux(..., method='actions') in 3 DoF")
    exponents, values = nf.action_terms(order)
    pure = exponents[:, 0] == 0
    powers, coefficients = exponents[pure, 1], values[pure]
    k = lambda j: j[:, None] ** powers @ coefficients - excess  # noqa: E731
    dk = lambda j: (powers * j[:, None] ** np.maximum(powers - 1, 0)) @ coefficients  # noqa: E731
    return float(increasing_root(k, dk, np.array([excess / nf.modes.frequencies[0]]))[0])


def _centre_area(nf: EquilibriumNormalForm, excess: float, order: int | None, nodes: int) -> float:
    """Area of {(J₂, J₃) ≥ 0 : K(0, J₂, J₃) ≤ ΔE} (3 DoF, full form)."""
    exponents, values = nf.action_terms(order)
    keep = exponents[:, 0] == 0
    e2, e3, c = exponents[keep, 1], exponents[keep, 2], values[keep]

    def k(j2, j3):
        return (j2[:, None] ** e2 * j3[:, None] ** e3) @ c - excess

    def dk3(j2, j3):
        return (j2[:, None] ** e2 * e3 * j3[:, None] ** np.maximum(e3 - 1, 0)) @ c

    omega = nf.modes.frequencies
    axis = e3 == 0
    top = float(increasing_root(lambda j: j[:, None] ** e2[axis] @ c[axis] - excess,
                                lambda j: (e2[axis] * j[:, None] ** np.maximum(e2[axis] - 1, 0)) @ c[axis],
                                np.array([excess / omega[0]]))[0])
    x, w = np.polynomial.legendre.leggauss(nodes)
    j2 = 0.5 * top * (x + 1)
    j3 = increasing_root(lambda j: k(j2, j), lambda j: dk3(j2, j), np.maximum((excess - omega[0] * j2) / omega[1], 1e-3 * top))
    return float(0.5 * top * np.sum(w * j3))


def ray_directions(n_centres: int, angles: int, nodes: int) -> tuple[np.ndarray, np.ndarray]:
    """Unit points ẑ of the module docstring (centre coordinates (Q₂.., P₂..)) and their quadrature weights.

    The weights integrate s*²/2 (3 DoF) or s* (2 DoF) over the directions to the enclosed volume.
    """
    theta = 2 * np.pi * np.arange(angles) / angles
    if n_centres == 1:
        points = np.stack([np.sqrt(2) * np.cos(theta), -np.sqrt(2) * np.sin(theta)], axis=1)
        return points, np.full(angles, 2 * np.pi / angles)
    if n_centres != 2:
        raise ValueError("rays are for 1 or 2 centre modes (2 or 3 DoF)")
    x, w = np.polynomial.legendre.leggauss(nodes)
    u = 0.5 * (x + 1)
    t2, t3, uu = np.meshgrid(theta, theta, u, indexing="ij")
    _, _, ww = np.meshgrid(theta, theta, 0.5 * w, indexing="ij")
    a2, a3 = np.sqrt(2 * (1 - uu)), np.sqrt(2 * uu)
    points = np.stack([a2 * np.cos(t2), a3 * np.cos(t3), -a2 * np.sin(t2), -a3 * np.sin(t3)], axis=-1).reshape(-1, 4)
    weights = (ww * (2 * np.pi / angles) ** 2).ravel()
    return points, weights


def _normal_points(n: int, centre_points: np.ndarray) -> np.ndarray:
    """Full normal-form points X with Q₁ = P₁ = 0 from centre points (Q₂.., P₂..)."""
    points = np.zeros((len(centre_points), 2 * n))
    m = n - 1
    points[:, 1:n] = centre_points[:, :m]
    points[:, n + 1:] = centre_points[:, m:]
    return points


def ray_radii(nf: EquilibriumNormalForm, excess: float, directions: np.ndarray, *, order: int | None = None) -> np.ndarray:
    """r* = √s* along each centre direction ẑ, where K(0, r ẑ) = ΔE (K in the real coordinates)."""
    top = nf.order if order is None else order
    points = _normal_points(nf.n_dof, directions)
    parts = np.stack([nf.basis.evaluate([np.zeros(0)] * d + [nf.hamiltonian_real[d]], points).real
                      if d >= 2 else np.zeros(len(points)) for d in range(top + 1)], axis=1)
    degrees = np.arange(top + 1)
    k = lambda r: np.sum(parts * r[:, None] ** degrees, axis=1) - excess  # noqa: E731
    dk = lambda r: np.sum(parts[:, 1:] * degrees[1:] * r[:, None] ** (degrees[1:] - 1), axis=1)  # noqa: E731
    return increasing_root(k, dk, np.sqrt(excess / parts[:, 2]))


def flux(nf: EquilibriumNormalForm, excess: float, *, method: str = "actions", order: int | None = None,
         angles: int = 32, nodes: int = 24) -> float:
    """The flux over the saddle at excess energy ΔE (module docstring): a volume in the centre space."""
    centres = nf.n_dof - 1
    if method == "actions":
        if centres == 1:
            return 2 * math.pi * centre_action_at(nf, excess, order=order)
        if centres == 2:
            return (2 * math.pi) ** 2 * _centre_area(nf, excess, order, nodes)
        raise ValueError("flux by actions is for 2 and 3 DoF")
    if method == "volume":
        directions, weights = ray_directions(centres, angles, nodes)
        s = ray_radii(nf, excess, directions, order=order) ** 2
        return float(np.sum(weights * (s if centres == 1 else 0.5 * s * s)))
    raise ValueError(f"method must be 'actions' or 'volume', got {method!r}")


def nhim_points(nf: EquilibriumNormalForm, excess: float, *, angles: int = 64, nodes: int = 8) -> np.ndarray:
    """Phase-space points of the NHIM at excess energy ΔE: the orbit (2 DoF), the 3-sphere sampled (3 DoF)."""
    directions, _ = ray_directions(nf.n_dof - 1, angles, nodes)
    radii = ray_radii(nf, excess, directions)
    return nf.original_states(_normal_points(nf.n_dof, directions * radii[:, None]))


def lyapunov_orbit_points(nf: EquilibriumNormalForm, excess: float, mode: int, *, angles: int = 64) -> np.ndarray:
    """Phase-space points of the Lyapunov orbit of centre ``mode`` (0 the lowest frequency) at ΔE:
    the NHIM's circle where every other centre action is zero (invariant in the full form)."""
    centres = nf.n_dof - 1
    theta = 2 * np.pi * np.arange(angles) / angles
    directions = np.zeros((angles, 2 * centres))
    directions[:, mode] = np.sqrt(2) * np.cos(theta)
    directions[:, centres + mode] = -np.sqrt(2) * np.sin(theta)
    radii = ray_radii(nf, excess, directions)
    return nf.original_states(_normal_points(nf.n_dof, directions * radii[:, None]))


def dividing_surface_points(nf: EquilibriumNormalForm, excess: float, centre_points: np.ndarray) -> np.ndarray:
    """Phase-space points of the dividing surface Q₁ = P₁ = t > 0 (the forward half) at ΔE above
    the given centre points (Q₂.., P₂..), which must lie inside the NHIM's region K(0, z) < ΔE."""
    points = _normal_points(nf.n_dof, np.atleast_2d(centre_points))
    n = nf.n_dof

    def energy(t):
        trial = points.copy()
        trial[:, 0] = trial[:, n] = t
        return nf.basis.evaluate(nf.hamiltonian_real, trial).real - excess

    def slope(t, h=1e-7):
        return (energy(t + h) - energy(t - h)) / (2 * h)

    guess = np.sqrt(np.maximum(-energy(np.zeros(len(points))), 0.0) / nf.modes.saddle_rate)  # K ≈ K(0, z) + λ t²
    t = increasing_root(energy, slope, np.maximum(guess, 1e-8))
    points[:, 0] = points[:, n] = t
    return nf.original_states(points)
