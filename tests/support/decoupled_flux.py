"""The reactive flux of Barbanis–Contopoulos 3 DoF at η = 0 from 2 DoF Lyapunov orbits, without Monte Carlo.

At η = 0, H = H_xy(x, y, p_x, p_y) + H_z with H_z = p_z²/2 + ω_z² z²/2 (ω_z² the parameter omega_z2):
the z oscillator is uncoupled. The saddle is (x_s, y_s, 0) and its Hessian is block diagonal, so the unstable
direction n lies in the (x, y) plane, z is a tangent of the dividing plane, and a state's weight
(where its (x, y) motion comes from and goes to) depends on its (x, y, p_x, p_y) part only. In the
flux integral ∫ δ(E − H) δ(s) ṡ θ(ṡ) w dq dp the (z, p_z) integral then factors out:

    Φ_3(E) = ∫ dz dp_z Φ_2(E − H_z(z, p_z)) = ∫_0^{E − E_s} (2π/ω_z) Φ_2(E − E_z) dE_z,

because the oscillator's phase-space area below E_z is the ellipse π √(2 E_z) · √(2 E_z)/ω_z =
2π E_z/ω_z, so its density of states is 2π/ω_z, and Φ_2(E_2) = 0 for E_2 ≤ E_s. Φ_2, the 2 DoF
reactive flux, is the action ∮ p·dq of the Lyapunov orbit of the in-plane centre mode at E_2 (MacKay
1990; ldpipe.core.transport.flux). In e = E_2 − E_s it is analytic (Lyapunov's theorem) and ~2πe/ω, so the
E_z integral is done by Gauss–Legendre on a few orbit energies; the orbits come from ldpipe's
differential corrector (scipy's DOP853), in seconds.
"""

from __future__ import annotations

import math

import numpy as np

from ldpipe.core.orbits.periodic import CorrectorSettings, LyapunovFamily, linearize_saddle, sample_orbit
from ldpipe.core.transport import orbit_action


def decoupled_reactive_flux(system, saddle, excess: float, omega_z: float, *, nodes: int = 6,
                            samples: int = 129) -> tuple[float, float]:
    """Φ_3 at ``excess`` ΔE above ``saddle`` (module docstring), and how far from the dividing plane the
    Lyapunov orbit at E_s + ΔE reaches (the widest of the NHIM's orbits: a commitment threshold must be
    well beyond it).

    Φ_3 = (2π/ω_z) ∫_0^ΔE Φ_2(E_s + e) de (e = E − E_s − E_z) by ``nodes``-point Gauss–Legendre; each
    orbit sampled at ``samples`` points, where the spectral action has converged to rounding.
    """
    linear = linearize_saddle(system, saddle)
    z_mode = int(np.argmin(np.abs(linear.omegas - omega_z)))
    assert abs(linear.omegas[z_mode] - omega_z) < 1e-9 * omega_z, linear.omegas
    settings = CorrectorSettings()
    family = LyapunovFamily(system, linear, 1 - z_mode, settings)
    critical = linear.critical_energy
    family.continue_to(critical + excess, initial_amplitude=1e-4, max_step=0.1, max_members=5000)

    def orbit_states(energy):
        return sample_orbit(system, family.at_energy(energy, energy_tolerance=1e-12), samples, settings)[1]

    x, w = np.polynomial.legendre.leggauss(nodes)
    actions = [orbit_action(orbit_states(critical + e), system.n_dof) for e in 0.5 * excess * (x + 1)]
    unstable = np.linalg.eigh(system.hessian(saddle))[1][:, 0]
    reach = float(np.max(np.abs((orbit_states(critical + excess)[:, :3] - saddle) @ unstable)))
    return 2 * math.pi / omega_z * 0.5 * excess * float(np.dot(w, actions)), reach
