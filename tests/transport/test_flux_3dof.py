"""Flux through the dividing plane of a 3 DoF saddle, against closed forms and independent values.

Quadratic saddle (support.quadratic_saddle) V = −λ² a²/2 + ω_1² b²/2 + ω_2² c²/2 in rotated
coordinates (a, b, c) = R (x, y, z), E_c = 0, excess ΔE: the plane a = 0 carries the one-way flux
(2π)² ΔE² / (2 ω_1 ω_2) (derived in ldpipe.core.transport.plane), every crossing of it is reactive (a(t)
is monotone through 0, uncoupled), and a uniform sample of the allowed (u, p_u) 4-volume has uniform
mode energies (e_1, e_2) on the triangle e_1 + e_2 ≤ ΔE (the volume element is (2π)² de_1 de_2 /
(ω_1 ω_2)): Pr(e_1 + e_2 ≤ ΔE/2) = 1/4 and Pr(e_1 ≤ ΔE/2) = 3/4. Planes with recrossings, and the
estimator's standard error, are tested in test_reactive_flux.py.

Barbanis–Contopoulos 3 DoF: the one-way flux's relative deviation from the harmonic value is a
series in ΔE whose coefficients follow from the cubic part of V on the plane (derived in
test_barbanis_contopoulos_flux_tends_to_the_harmonic_value). At η = 0 the z oscillator decouples and
the reactive flux is the 2 DoF flux, the Lyapunov orbit's action, convolved with the oscillator's
density of states (support.decoupled_flux): an independent value for the Monte Carlo estimate.
"""

import math

import numpy as np
import pytest
from scipy import stats

from ldpipe.core.trajectories import FlowSettings
from ldpipe.systems import make_system
from ldpipe.core.transport import DividingPlane, reactive_flux_monte_carlo
from support import quadratic_saddle as quadratic
from support.decoupled_flux import decoupled_reactive_flux
from support.quadratic_saddle import OM1, OM2

FLOW = FlowSettings(rtol=1e-9, atol=1e-9, escape_radius=60.0)


@pytest.fixture(scope="module")
def quadratic_saddle():
    return make_system("quadratic_saddle_3dof", quadratic.spec()), quadratic.rotation()


@pytest.mark.parametrize("excess", [0.02, 0.7])
def test_quadratic_plane_flux_is_the_centre_action_volume(quadratic_saddle, excess):
    system, rot = quadratic_saddle
    plane = DividingPlane.at_saddle(system, np.zeros(3), excess)
    assert abs(abs(plane.normal @ rot[0]) - 1) < 1e-12
    exact = quadratic.plane_flux(excess)
    assert plane.area() == pytest.approx(exact, rel=1e-12)


def test_quadratic_plane_samples_are_uniform_in_the_mode_energies(quadratic_saddle):
    system, rot = quadratic_saddle
    excess = 0.7
    plane = DividingPlane.at_saddle(system, np.zeros(3), excess)
    u, pu = plane.sample(100_000, np.random.default_rng(3))
    q, p = u @ plane.tangents, pu @ plane.tangents
    modes = [0.5 * (p @ rot[i]) ** 2 + 0.5 * om**2 * (q @ rot[i]) ** 2 for i, om in ((1, OM1), (2, OM2))]
    for fraction, exact in ((np.mean(modes[0] + modes[1] <= excess / 2), 0.25),
                            (np.mean(modes[0] <= excess / 2), 0.75)):
        assert abs(fraction - exact) < 4 * math.sqrt(exact * (1 - exact) / len(u))
    assert np.all(modes[0] + modes[1] <= excess * (1 + 1e-12))


def test_quadratic_plane_monte_carlo_counts_every_crossing_reactive(quadratic_saddle):
    """Every crossing reactive: the estimate is the plane's flux A exactly, and its standard error is the
    floor A/N (the sample variance is 0; the floor 1/N is the variance, ddof = 1, of N − 1 ones and one
    zero). With none of N crossings non-reactive, the exact (Clopper–Pearson) one-sided upper bound on
    the non-reactive fraction at confidence 1 − α is 1 − α^{1/N} ≈ −ln α / N, so k floor errors below
    the estimate is that bound at confidence ≈ 1 − e^{−k}: 63 % at k = 1, 95 % at k = 3, the rule of
    three; not the 84 % and 99.9 % of k normal standard errors."""
    system, _ = quadratic_saddle
    excess, count = 0.7, 500
    plane = DividingPlane.at_saddle(system, np.zeros(3), excess)
    result = reactive_flux_monte_carlo(plane, commit=1.0, duration=12.0, batch=count, max_samples=count, flow=FLOW)
    assert (result.reactive, result.antireactive, result.undecided) == (count, 0, 0)
    exact = quadratic.plane_flux(excess)
    assert result.flux == pytest.approx(exact, rel=1e-12)
    assert result.stderr == pytest.approx(exact / count, rel=1e-12)
    assert np.var(np.r_[np.ones(count - 1), 0.0], ddof=1) == pytest.approx(1 / count, rel=1e-12)
    for k in (1, 3):
        bound = stats.beta.ppf(1 - math.exp(-k), 1, count)  # Clopper–Pearson, 0 of N
        assert bound * result.surface_flux / result.stderr == pytest.approx(k, rel=k / count)


@pytest.fixture(scope="module")
def bc_saddle():
    system = make_system("barbanis_contopoulos_3dof", {"builtin": "barbanis_contopoulos_3dof", "parameters": {
        "omega_x2": 0.9, "omega_y2": 1.6, "omega_z2": 0.4, "epsilon": 0.08, "eta": 0.01}})
    saddle = system.closed_form_equilibria()[1]
    frequencies = np.sqrt(np.linalg.eigvalsh(system.hessian(saddle))[1:])
    return system, saddle, system.potential(saddle), frequencies


def _anharmonic_series(hessian, epsilon, eta, terms):
    """The coefficients a_k ⟨c^{2k}⟩, k = 1..``terms``, of the one-way flux's relative deviation from the
    harmonic value (see the test): c is the cubic part −ε d_x² d_y − η d_x² d_z of V at the displacement
    d = v_1 t_1 + v_2 t_2 along the centre eigenvectors t_i, on the ellipse v = (√2 cos θ/ω_1, √2 sin θ/ω_2)
    (the trapezoidal rule on 64 angles is exact for c^{2k}, a trigonometric polynomial of degree 6k < 64)."""
    values, vectors = np.linalg.eigh(hessian)
    theta = 2 * math.pi * np.arange(64) / 64
    v = math.sqrt(2) * np.array([np.cos(theta), np.sin(theta)]) / np.sqrt(values[1:])[:, None]
    d = vectors[:, 1:] @ v
    c = -epsilon * d[0] ** 2 * d[1] - eta * d[0] ** 2 * d[2]
    return [2 * math.factorial(3 * k) / (math.factorial(k + 2) * math.factorial(2 * k)) * float(np.mean(c ** (2 * k)))
            for k in range(1, terms + 1)]


def test_barbanis_contopoulos_flux_tends_to_the_harmonic_value(bc_saddle):
    """One-way over harmonic flux: 1 + Σ_k a_k ⟨c^{2k}⟩ ΔE^k, a_k = 2 (3k)!/((k+2)! (2k)!), c V's cubic part.

    V is cubic, so on the plane V = E_c + (ω_1² v_1² + ω_2² v_2²)/2 + c(v) exactly, c the cubic part
    (``_anharmonic_series``). With v = √ΔE r (√2 cos θ/ω_1, √2 sin θ/ω_2) the flux 2π ∫ (E − V)₊ d²v
    (ldpipe.core.transport.plane) is the harmonic flux 2π²ΔE²/(ω_1ω_2) times G = ⟨4 ∫ (1 − r² − s r³)₊ r dr⟩_θ,
    s = √ΔE c(θ), c(θ) = c at r = 1. The n-th s-derivative of the integral at 0 is, for n ≥ 2, ½ (d/dx)^{n−2}
    x^{3n/2} at x = r² = 1 (it integrates the (n−2)-th derivative of δ(1 − x)); odd n cancel between θ
    and θ + π (c is odd), so the n = 2k term is 4 · ½ (3k)!/(k+2)! ⟨c^{2k}⟩ ΔE^k/(2k)!: a_k = 1, 5/2, 42/5, 33.

    So the deviation is κ_1 ΔE (κ_1 = ⟨c²⟩ = 6.05e-5) to first order, doubling when ΔE does, and the
    series to k = 3 leaves at most twice the k = 4 term plus the rounding of E − V over ΔE (V ≈ 24 is a
    sum of terms up to 50): measured 3e-14/ΔE (3.0e-12 at ΔE = 0.01, 2.5e-14 at 1), allowed 1e-13/ΔE.
    At ΔE = 1 the k = 3 term, 1.2e-11, is a hundred times that: the quadrature resolves it.
    """
    system, saddle, critical, (om1, om2) = bc_saddle
    kappa = _anharmonic_series(system.hessian(saddle), 0.08, 0.01, 4)
    deviation = {}
    for excess in (0.01, 0.02, 0.25, 1.0):
        harmonic = (2 * math.pi * excess) ** 2 / (2 * om1 * om2)
        deviation[excess] = DividingPlane.at_saddle(system, saddle, critical + excess).area() / harmonic - 1
        series = sum(kappa[k] * excess ** (k + 1) for k in range(3))
        assert abs(deviation[excess] - series) < 2 * kappa[3] * excess**4 + 1e-13 / excess, excess
    assert kappa[2] > 50 * (2 * kappa[3] + 1e-13)
    assert deviation[0.01] == pytest.approx(kappa[0] * 0.01, rel=1e-4)
    assert deviation[0.02] / deviation[0.01] == pytest.approx(2.0, rel=0.02)


@pytest.fixture(scope="module")
def decoupled():
    """Barbanis–Contopoulos at η = 0, named as tests/engine/test_hard_cases.py names it (same kernels)."""
    return make_system("bc_eta0", {"builtin": "barbanis_contopoulos_3dof", "parameters": {"eta": 0.0}})


def test_decoupled_reactive_flux_is_the_2dof_flux_convolved_with_the_oscillator(decoupled):
    """At η = 0 the Monte Carlo reactive flux through the plane is Φ_3 = ∫_0^ΔE (2π/ω_z) Φ_2(E − E_z) dE_z.

    The z oscillator is uncoupled and z is a tangent of the plane, so a crossing's weight depends on its
    (x, y) part alone and the flux integral factors: the oscillator's phase-space area below E_z is the
    ellipse π √(2E_z) √(2E_z)/ω_z = 2π E_z/ω_z, its density of states 2π/ω_z, and Φ_2, the 2 DoF reactive
    flux at E − E_z, is the action of the Lyapunov orbit there (MacKay 1990). support.decoupled_flux
    computes Φ_3 from orbits by Gauss–Legendre in E_z (6 nodes; 4 nodes with half the orbit samples
    agree to 3e-11, far below the estimate's relative error, 1e-3).

    Recrossings of the plane grow with the energy; at ΔE = 80 0.8 % of its crossings are not reactive,
    so the one-way flux exceeds Φ_3 by 8 standard errors of 8000 samples (the estimate is 0.01 from
    it): the check fails if every crossing counts. The threshold 3 is beyond twice the reach of the
    widest orbit of the NHIM from the plane (1.37), as the transport stage requires of its line.
    """
    system = decoupled
    saddle = system.closed_form_equilibria()[1]
    excess, count, commit = 80.0, 8000, 3.0
    exact, reach = decoupled_reactive_flux(system, saddle, excess, math.sqrt(0.4))
    assert commit > 2 * reach
    plane = DividingPlane.at_saddle(system, saddle, system.potential(saddle) + excess)
    result = reactive_flux_monte_carlo(plane, commit=commit, duration=20.0, batch=count // 2, max_samples=count,
                                       target_stderr=0.0, flow=FLOW, seed=3)
    assert (result.samples, result.undecided) == (count, 0)
    assert abs(result.flux - exact) < 4 * result.stderr
    assert result.surface_flux - exact > 5 * result.stderr


def test_barbanis_contopoulos_reactive_flux_at_most_the_one_way_flux(bc_saddle):
    """At E = 24 (the paper's energy): the classified Monte Carlo flux does not exceed the plane's
    one-way flux, and every sample committed within the integration time."""
    system, saddle, _, _ = bc_saddle
    plane = DividingPlane.at_saddle(system, saddle, 24.0)
    result = reactive_flux_monte_carlo(plane, commit=2.0, duration=20.0, batch=400, max_samples=400, flow=FLOW)
    assert result.undecided == 0
    assert result.surface_flux == pytest.approx(plane.area(), rel=1e-14)
    assert result.flux <= result.surface_flux * (1 + 1e-14)
