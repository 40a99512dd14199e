"""Flux through the dividing plane of a 3 DoF saddle, against closed forms and independent values.

Quadratic saddle (support.quadratic_saddle) V = −λ² a²/2 + ω_1² b²/2 + ω_2² c²/2 in rotated
coordinates (a, b, c) = R (x, y, z), E_c = 0, excess ΔE: the plane a = 0 carries the one-way flux
(2π)² ΔE² / (2 ω_1 ω_2) (derived in ldpipe.transport.plane), every crossing of it is reactive (a(t)
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

from ldpipe.flow import FlowSettings
from ldpipe.systems import make_system
from ldpipe.transport import DividingPlane, reactive_flux_monte_carlo
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


def test_barbanis_contopoulos_flux_tends_to_the_harmonic_value(bc_saddle):
    system, saddle, critical, (om1, om2) = bc_saddle
    deviation = []
    for excess in (0.01, 0.02):
        harmonic = (2 * math.pi * excess) ** 2 / (2 * om1 * om2)
        deviation.append(DividingPlane.at_saddle(system, saddle, critical + excess).area() / harmonic - 1)
    assert abs(deviation[0]) < 1e-4
    assert deviation[1] / deviation[0] == pytest.approx(2.0, rel=0.02)


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
