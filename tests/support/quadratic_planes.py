"""Dividing planes of the quadratic 3 DoF saddle (support.quadratic_saddle) off its normal modes.

In the mode coordinates (a, b, c) = R q the Hamiltonian is a sum of three conserved energies,
e_a = p_a²/2 − λ² a²/2 (the saddle's), e_b and e_c (oscillators, ≥ 0), and a(t) = A_+ e^{λt} + A_- e^{−λt}.
A trajectory with e_a > 0 passes over the saddle with a(t) monotone in the direction of p_a; one with
e_a < 0 turns back to the side it came from. So the weight of every crossing of a plane that
separates a → −∞ from a → +∞ is known without integrating:

    w = sign(p_a) if e_a > 0 (reactive from the well a < 0 to the products a > 0, or the reverse),
    w = 0         if e_a < 0 (it leaves on the side it came from),

provided the commitment threshold is beyond the band where s can turn back (:func:`commit_threshold`).
The flux of the trajectories with e_a > 0, the reactive flux, is (2π)² ΔE²/(2 ω_1 ω_2) through any
dividing surface (through the normal-mode plane every crossing has e_a > 0). Two planes with
recrossings by construction:

* **tilted**: through the saddle with unit normal n = cos α â + sin α b̂. Its one-way flux is the
  volume of its allowed (u, p_u) region, 2π ∫ (ΔE − uᵀKu/2)₊ d²u = 2π² ΔE² / √det K, K the Hessian
  restricted to the plane (ldpipe.core.transport.plane's integral for a quadratic V). K's eigenvalues
  are ω_2² and ω_1² cos²α − λ² sin²α (positive while tan α < ω_1/λ), so the one-way flux exceeds
  the reactive flux by the factor ω_1 / √(ω_1² cos²α − λ² sin²α). A reactive trajectory recrosses
  where the b oscillation outruns a's drift (|sin α ḃ| > cos α ȧ), so weights −1, 0 and +1 all occur.
* **shifted**: the normal-mode plane moved to a = a_0 > 0. On it V = −λ² a_0²/2, the excess is
  ΔE' = ΔE + λ² a_0²/2 and the one-way flux (2π)² ΔE'²/(2 ω_1 ω_2); trajectories with e_a < 0 coming
  from the products cross it twice (weight 0), those with e_a > 0 once (weight +1): the weights are
  Bernoulli with p = (ΔE/ΔE')², the ratio of the two fluxes, and their standard error a closed form.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ldpipe.core.transport import DividingPlane
from support.quadratic_saddle import LAM, OM1, OM2, rotation

# The name, with support.quadratic_saddle.spec(), under which tests/transport/test_flux_3dof.py
# builds this system: the same name and kernel text reuse its compiled flow engine.
NAME = "quadratic_saddle_3dof"


def reactive_flux(excess) -> float:
    """(2π)² ΔE² / (2 ω_1 ω_2): the flux of the trajectories with e_a > 0."""
    return (2 * math.pi * excess) ** 2 / (2 * OM1 * OM2)


def tilted_plane(system, excess: float, angle: float) -> DividingPlane:
    """The plane through the saddle with normal cos α â + sin α b̂ (α = ``angle``), tangents orthonormal."""
    a, b, c = rotation()
    normal = math.cos(angle) * a + math.sin(angle) * b
    tangents = np.array([-math.sin(angle) * a + math.cos(angle) * b, c])
    return DividingPlane(system, np.zeros(3), normal, tangents, float(excess))


def tilted_one_way_flux(excess: float, angle: float) -> float:
    """2π² ΔE² / √det K on the tilted plane: (2π)² ΔE² / (2 ω_2 √(ω_1² cos²α − λ² sin²α))."""
    along = OM1**2 * math.cos(angle) ** 2 - LAM**2 * math.sin(angle) ** 2
    if along <= 0:
        raise ValueError(f"tilt {angle} is beyond atan(ω_1/λ): the plane's allowed region is unbounded")
    return (2 * math.pi * excess) ** 2 / (2 * OM2 * math.sqrt(along))


def shifted_plane(system, excess: float, shift: float) -> DividingPlane:
    """The normal-mode plane moved to a = ``shift`` (towards the products)."""
    a, b, c = rotation()
    return DividingPlane(system, shift * a, a.copy(), np.array([b, c]), float(excess))


def shifted_excess(excess: float, shift: float) -> float:
    """ΔE' = ΔE + λ² a_0²/2: the excess over V = −λ² a_0²/2 on the shifted plane."""
    return excess + 0.5 * LAM**2 * shift**2


def shift_for_fraction(excess: float, fraction: float) -> float:
    """The shift a_0 at which a fraction p = (ΔE/ΔE')² of the crossings is reactive."""
    return math.sqrt(2 * excess * (1 / math.sqrt(fraction) - 1)) / LAM


def exact_weights(states: np.ndarray) -> np.ndarray:
    """Each state's weight from its conserved saddle energy: sign(p_a) if e_a > 0, else 0."""
    a_hat = rotation()[0]
    a, p_a = states[:, :3] @ a_hat, states[:, 3:] @ a_hat
    e_a = 0.5 * p_a**2 - 0.5 * LAM**2 * a**2
    return np.where(e_a > 0, np.sign(p_a), 0.0)


def commit_threshold(plane: DividingPlane) -> float:
    """Twice the smallest commitment threshold that classifies every crossing of these planes right.

    s = n·(q − q_0) with n = cos α â + sin α b̂ and q_0 = a_0 â (one of α, a_0 is 0 here). Tilted: at the
    crossing a = −tan α b, and before it (after it) a is smaller (larger) on a reactive trajectory, so s
    stays below (above) sin α (b(t) − b(0)) ≤ 2 sin α b_max until it leaves for good; on a non-reactive one
    a keeps its sign and |s| > sin α b_max only on that side. b_max = √(2 e_b)/ω_1, and e_b ≤ ΔE/(1 −
    λ² tan²α/ω_1²) since e_a ≥ −λ² a²/2 at the crossing. Shifted: a non-reactive trajectory turns at
    a ∈ (0, a_0], s ≥ −a_0. The bound is 2 sin α b_max + a_0; a threshold twice that leaves a margin.
    """
    a_hat, b_hat = rotation()[:2]
    sin = abs(float(plane.normal @ b_hat))
    tan = sin / abs(float(plane.normal @ a_hat))
    excess = plane.energy - plane.system.potential(np.zeros(3))
    e_b = excess / (1 - LAM**2 * tan**2 / OM1**2)
    return 2 * (2 * sin * math.sqrt(2 * e_b) / OM1 + abs(float(plane.saddle @ a_hat)))


@dataclass(frozen=True)
class ExactlySampled:
    """A plane through the saddle whose allowed region, the ellipsoid {|p_u|²/2 + uᵀKu/2 ≤ ΔE}, is sampled
    and measured in closed form (uniform in the unit 4-ball, mapped linearly; volume 2π² ΔE²/√det K).

    It has what :func:`ldpipe.core.transport.reactive_flux_monte_carlo` asks of a surface, without the plane's
    numerical extent and quadrature (tens of ms a call): for many short runs of the estimator.
    """

    plane: DividingPlane

    @property
    def system(self):
        return self.plane.system

    @property
    def saddle(self) -> np.ndarray:
        return self.plane.saddle

    @property
    def normal(self) -> np.ndarray:
        return self.plane.normal

    def _restricted_hessian(self) -> np.ndarray:
        rot = rotation()
        hessian = rot.T @ np.diag([-LAM**2, OM1**2, OM2**2]) @ rot
        return self.plane.tangents @ hessian @ self.plane.tangents.T

    def area(self) -> float:
        return 2 * math.pi**2 * self.plane.energy**2 / math.sqrt(np.linalg.det(self._restricted_hessian()))

    def sample(self, count: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        ball = rng.standard_normal((count, 4))
        ball *= (rng.uniform(size=count) ** 0.25 / np.linalg.norm(ball, axis=1))[:, None]
        values, vectors = np.linalg.eigh(self._restricted_hessian())
        scale = math.sqrt(2 * self.plane.energy)
        u = scale * (ball[:, :2] / np.sqrt(values)) @ vectors.T
        return u, scale * ball[:, 2:]

    def states(self, u: np.ndarray, pu: np.ndarray) -> np.ndarray:
        return self.plane.states(u, pu)
