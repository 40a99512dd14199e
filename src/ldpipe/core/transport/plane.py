"""The dividing plane of an index-1 saddle of a 3 DoF system, its one-way flux, and samples of it.

The plane passes through the saddle q_s normal to the unstable eigenvector n of the Hessian; its
tangents t_1, t_2 are the other two eigenvectors (for a quadratic saddle they diagonalize the
restricted Hessian). With q = q_s + u_1 t_1 + u_2 t_2 + s n and the momenta rotated alike
(a rotation is canonical), ṡ = p_n and, as for the 2 DoF line (:mod:`ldpipe.core.transport.flux`),

    flux = ∫ δ(E − H) δ(s) p_n θ(p_n) dq dp = vol{(u, p_u): |p_u|²/2 + V(u) ≤ E}
         = ∫ π · 2 (E − V(u)) d²u          (a disc of p_u of radius √(2(E − V)))
         = 2π ∫_0^{2π} dθ ∫_0^{r(θ)} (E − V(r, θ)) r dr,

r(θ) where the ray from the saddle in the plane meets V = E. For a quadratic saddle
V = E_c + ω_1² u_1²/2 + ω_2² u_2²/2 on the plane, with ΔE = E − E_c and v_i = ω_i u_i / √2,
∫ (ΔE − |v|²) d²v · 2/(ω_1 ω_2) = (π ΔE²/2) · 2/(ω_1 ω_2), so the flux is (2π)² ΔE² / (2 ω_1 ω_2):
the volume {ω_1 I_1 + ω_2 I_2 ≤ ΔE} of the centre–centre actions times (2π)² of angles.

Every point of that 4-volume is an outward crossing; uniform samples of it are flux-weighted
crossings, so :func:`ldpipe.core.transport.reactive_flux_monte_carlo` takes a plane as it takes a line.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import optimize

from ..sections import potential_of_columns
from ...systems import System
from .flux import saddle_eigenvectors


@dataclass(frozen=True)
class DividingPlane:
    """The plane {s = n·(q − q_s) = 0} of a 3 DoF saddle at energy E; ``tangents`` has shape (2, 3)."""

    system: System
    saddle: np.ndarray
    normal: np.ndarray
    tangents: np.ndarray
    energy: float

    @classmethod
    def at_saddle(cls, system: System, saddle, energy: float, *, well=None) -> DividingPlane:
        """The plane through ``saddle`` normal to the Hessian's unstable eigenvector, n pointing away
        from ``well`` (default the origin), so s > 0 is the product side."""
        if system.n_dof != 3:
            raise ValueError(f"DividingPlane is for 3 DoF systems; {system.name} has {system.n_dof}")
        saddle, vectors = saddle_eigenvectors(system, saddle, well)
        if energy <= system.potential(saddle):
            raise ValueError(f"energy {energy!r} is not above the saddle's {system.potential(saddle)!r}")
        return cls(system, saddle, vectors[:, 0], vectors[:, 1:].T.copy(), float(energy))

    def potential(self, u: np.ndarray) -> np.ndarray:
        """V at plane coordinates ``u`` of shape (count, 2)."""
        q = self.saddle[None, :] + np.asarray(u, dtype=np.float64) @ self.tangents
        return potential_of_columns(self.system, np.ascontiguousarray(q.T))

    def radius(self, theta: float) -> float:
        """Distance from the saddle along direction θ of the plane to the first point where V = E."""
        direction = math.cos(theta) * self.tangents[0] + math.sin(theta) * self.tangents[1]
        curvature = float(direction @ self.system.hessian(self.saddle) @ direction)
        if curvature <= 0:
            raise ValueError("the Hessian restricted to the dividing plane is not positive definite")
        step = 0.25 * math.sqrt(2.0 * (self.energy - self.system.potential(self.saddle)) / curvature)

        def excess(r):
            return self.system.potential(self.saddle + r * direction) - self.energy

        inner = 0.0
        while excess(inner + step) < 0:
            inner += step
            if inner > 1e6:
                raise ValueError(f"the allowed region of the dividing plane is unbounded at θ = {theta:.6g}")
        return optimize.brentq(excess, inner, inner + step, xtol=1e-15, rtol=4 * np.finfo(float).eps, maxiter=200)

    def area(self, angles: int = 256, radial: int = 32) -> float:
        """The directional flux 2π ∫ dθ ∫_0^{r(θ)} (E − V) r dr (the 4-volume of the allowed (u, p_u)).

        θ by the trapezoidal rule on ``angles`` points (exponentially accurate for the smooth periodic
        r(θ) of a star-shaped region), r by Gauss–Legendre on ``radial`` nodes (exact for a polynomial
        V of degree ≤ 2·radial − 2 along rays, e.g. the cubic potentials here).
        """
        theta = 2.0 * math.pi * np.arange(angles) / angles
        nodes, weights = np.polynomial.legendre.leggauss(radial)
        total = 0.0
        for t in theta:
            r_max = self.radius(float(t))
            r = 0.5 * r_max * (nodes + 1.0)
            u = np.column_stack([r * math.cos(t), r * math.sin(t)])
            total += 0.5 * r_max * float(np.sum(weights * (self.energy - self.potential(u)) * r))
        return float(2.0 * math.pi * total * 2.0 * math.pi / angles)

    def _extent(self, angles: int = 512) -> tuple[np.ndarray, np.ndarray]:
        theta = 2.0 * math.pi * np.arange(angles) / angles
        return theta, np.array([self.radius(float(t)) for t in theta])

    def sample(self, count: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        """``count`` points (u, p_u), each of shape (count, 2), uniform on the allowed 4-volume.

        Rejection from the box |u_i| ≤ R, |p_u,i| ≤ P: R bounds r(θ) (512 angles, 2 % margin), P is
        √(2 (E − V_min)) with V_min the least V found on the region (minimizer and a polar grid), 1 %
        margin. Points of {V < E} in the box but off the saddle's component (beyond r(θ)) are refused
        with an error rather than silently sampled.
        """
        theta, radii = self._extent()
        reach = 1.02 * float(radii.max())
        grid_r = np.linspace(0.0, 1.0, 33)[:, None] * radii[None, :]
        polar = np.stack([grid_r * np.cos(theta), grid_r * np.sin(theta)], axis=-1).reshape(-1, 2)
        low = float(self.potential(polar).min())
        found = optimize.minimize(lambda u: float(self.potential(u[None, :])[0]), np.zeros(2), method="Nelder-Mead",
                                  options={"xatol": 1e-12, "fatol": 1e-14})
        low = min(low, float(found.fun))
        bound = 1.01 * math.sqrt(2.0 * (self.energy - low))
        u_out, p_out, have = [], [], 0
        while have < count:
            size = 8 * (count - have) + 64
            u = rng.uniform(-reach, reach, size=(size, 2))
            p = rng.uniform(-bound, bound, size=(size, 2))
            keep = 0.5 * np.sum(p**2, axis=1) + self.potential(u) <= self.energy
            u, p = u[keep], p[keep]
            angle = np.mod(np.arctan2(u[:, 1], u[:, 0]), 2.0 * math.pi)
            edge = np.interp(angle, np.append(theta, 2.0 * math.pi), np.append(radii, radii[0]))
            if np.any(np.hypot(u[:, 0], u[:, 1]) > 1.001 * edge):
                raise ValueError("the dividing plane's allowed region has parts off the saddle's component "
                                 "within the sampling box; the plane is not a simple disc at this energy")
            u_out.append(u)
            p_out.append(p)
            have += len(u)
        return np.concatenate(u_out)[:count], np.concatenate(p_out)[:count]

    def states(self, u: np.ndarray, pu: np.ndarray) -> np.ndarray:
        """States (q, p) at plane points ``u`` with tangential momenta ``pu`` and p_n = +√(2(E − V) − |p_u|²)."""
        u = np.asarray(u, dtype=np.float64)
        pu = np.asarray(pu, dtype=np.float64)
        pn = np.sqrt(np.maximum(2.0 * (self.energy - self.potential(u)) - np.sum(pu**2, axis=1), 0.0))
        q = self.saddle[None, :] + u @ self.tangents
        p = pu @ self.tangents + pn[:, None] * self.normal[None, :]
        return np.hstack([q, p])
