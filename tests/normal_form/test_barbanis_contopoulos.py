"""The normal form of Barbanis–Contopoulos 3 DoF's saddle against independent values.

* At η = 0 the z oscillator decouples and the flux is the 2 DoF flux (the Lyapunov orbit's action)
  convolved with the oscillator's density of states 2π/ω_z (support.decoupled_flux, from ldpipe's
  corrected orbits, accurate to about 1e-12 with its 6 Gauss–Legendre nodes).
* The flux tends to the harmonic (2π)² ΔE²/(2 ω₁ ω₂) as ΔE → 0, the relative deviation linearly
  (K's first correction is quadratic in the actions).
* The two Lyapunov orbits lie in the NHIM: in the normal form they are its circles with the other
  centre action zero; against ldpipe's corrected orbits as the order grows.
* The NHIM points the LD sampling refines on a family of slices (independent: where the forward and
  backward fates both switch, ldpipe.core.nhim) have Q₁ = P₁ = 0 in the normal form, down to
  the refinement's stated uncertainty as the order grows.
* The Monte Carlo reactive flux through the dividing plane (ldpipe.core.transport), within its error.
"""

import math

import numpy as np
import pytest

from ldpipe.core.trajectories import FlowSettings
from ldpipe.core.normal_form import flux, lyapunov_orbit_points, nhim_points, system_normal_form
from ldpipe.core.nhim import RefinementSettings
from ldpipe.core.nhim.sampling import SamplingSettings, sample_family, slice_problem
from ldpipe.core.nhim.slices import section_point_states
from ldpipe.core.orbits.periodic import CorrectorSettings, LyapunovFamily, linearize_saddle, sample_orbit
from ldpipe.systems import make_system
from ldpipe.core.transport import DividingPlane, reactive_flux_monte_carlo
from support.barbanis import BC_SADDLE, fig5_slice_problem
from support.decoupled_flux import decoupled_reactive_flux


@pytest.fixture(scope="module")
def saddle(barbanis_contopoulos):
    return barbanis_contopoulos.closed_form_equilibria()[1]


def test_decoupled_flux_is_the_orbit_action_convolved_with_the_oscillator():
    """Named as tests/transport/test_flux_3dof.py names it (same kernels)."""
    system = make_system("bc_eta0", {"builtin": "barbanis_contopoulos_3dof", "parameters": {"eta": 0.0}})
    saddle = system.closed_form_equilibria()[1]
    nf = system_normal_form(system, saddle, 10, transforms=False)
    excess = 1.0
    exact, _ = decoupled_reactive_flux(system, saddle, excess, math.sqrt(0.4))
    errors = [abs(flux(nf, excess, order=order) / exact - 1) for order in (2, 4, 6, 10)]
    # measured 5.9e-5, 7.3e-8, 1.6e-10, 2.3e-13
    assert errors[1] < errors[0] / 100 and errors[2] < errors[1] / 100
    assert errors[-1] < 1e-11
    assert flux(nf, excess, method="volume") == pytest.approx(exact, rel=1e-11)


def test_flux_tends_to_the_harmonic_value(barbanis_contopoulos, saddle):
    nf = system_normal_form(barbanis_contopoulos, saddle, 8, transforms=False)
    om1, om2 = nf.modes.frequencies
    deviation = {}
    for excess in (0.01, 0.02):
        harmonic = (2 * math.pi * excess) ** 2 / (2 * om1 * om2)
        deviation[excess] = flux(nf, excess) / harmonic - 1
    # measured −5.5e-7 at ΔE = 0.01 and a ratio 2.000
    assert abs(deviation[0.01]) < 1e-5
    assert deviation[0.02] / deviation[0.01] == pytest.approx(2.0, rel=0.01)


def test_lyapunov_orbits_lie_in_the_nhim(barbanis_contopoulos, saddle):
    system, excess, settings = barbanis_contopoulos, 0.5, CorrectorSettings()
    linear = linearize_saddle(system, saddle)
    low, high = system_normal_form(system, saddle, 4), system_normal_form(system, saddle, 8)
    for mode in (0, 1):
        family = LyapunovFamily(system, linear, mode, settings)
        family.continue_to(linear.critical_energy + excess, initial_amplitude=1e-4, max_step=0.1, max_members=500)
        orbit = family.at_energy(linear.critical_energy + excess, energy_tolerance=1e-13)
        dense = sample_orbit(system, orbit, 4001, settings)[1]
        # angles on every 250th time step: see tests/normal_form/test_barbanis.py
        distances = [np.max(np.min(np.linalg.norm(lyapunov_orbit_points(nf, excess, mode, angles=16)[:, None, :]
                                                  - dense[None], axis=2), axis=1)) for nf in (low, high)]
        # measured 7e-8 and 8e-6 at order 4; 5e-11 and 3e-11 at order 8
        assert distances[1] < 1e-9
        assert distances[0] > 10 * distances[1]
    # the sampled 3-sphere is on the energy surface, and spans both centre planes
    sphere = nhim_points(high, excess, angles=6)
    energies = np.array([system.energy(s) for s in sphere]) - linear.critical_energy
    assert np.max(np.abs(energies - excess)) < 1e-10  # measured 5e-12
    actions = high.normal_states(sphere)
    assert np.max(np.abs(actions[:, [0, 3]])) < 1e-10  # Q₁ = P₁ = 0 (round trip); measured 8e-12


@pytest.fixture(scope="module")
def ld_refined_nhim_points(barbanis_contopoulos):
    """NHIM points refined by the LD sampling on 18 slices through the saddle region, both signs of
    p_z: the fixtures and settings of tests/stages/test_nhim_sampling.py (the config's fig5_xpx map
    at E = 24, ΔE = 0.176 above the saddle; the refinement's defaults, tolerance 1e-8)."""
    base = fig5_slice_problem(barbanis_contopoulos)
    grid = {"y": BC_SADDLE[1] + np.array([-0.2, 0.0, 0.2]), "z": BC_SADDLE[2] + np.array([-0.1, 0.0, 0.1]),
            "py": [0.0, 0.2]}
    samples = sample_family(base, grid, (1, -1), SamplingSettings(), RefinementSettings())
    assert [s.status for s in samples] == ["ok"] * 36
    return base, samples


def test_ld_refined_nhim_points_lie_in_the_nhim(barbanis_contopoulos, saddle, ld_refined_nhim_points):
    """The NHIM is Q₁ = P₁ = 0 in the normal form. A refined point is within ``uncertainty`` (in the
    slice's (x, p_x)) of the slice's true NHIM point, so its |Q₁|, |P₁| are at most the truncation
    error of the order plus uncertainty × |∇Q₁|, |∇P₁| along the slice (Cauchy–Schwarz; the gradients
    by finite differences of the coordinate change)."""
    base, samples = ld_refined_nhim_points
    states = np.array([s.state for s in samples])
    forms = {order: system_normal_form(barbanis_contopoulos, saddle, order, transforms=False) for order in (2, 4, 6, 8)}
    errors = {order: np.max(np.abs(nf.normal_states(states)[:, [0, 3]])) for order, nf in forms.items()}
    # measured 2.1e-3, 2.8e-7, 2.6e-10, 2.0e-10: geometric, then the floor the refinement sets (order 8
    # differs from order 12 by 8e-14 at these points, so its truncation is negligible in the bound below)
    assert errors[4] < errors[2] / 1000 and errors[6] < errors[4] / 100
    assert errors[8] < 1e-9 and errors[8] < errors[4] / 300  # measured 1400 times below order 4
    step = 1e-6
    for sample in samples:
        problem = slice_problem(base, sample.fixed, sample.sign, sample.point, np.array([0.1, 0.1]), 11)
        nearby = section_point_states(problem, sample.point + np.array([[0.0, 0.0], [step, 0.0], [0.0, step]]))[0]
        reactive = forms[8].normal_states(nearby)[:, [0, 3]]
        gradient = np.linalg.norm((reactive[1:] - reactive[0]) / step, axis=0)
        # measured at most 0.43 of the bound (the gradients are about 0.85)
        assert np.all(np.abs(reactive[0]) <= sample.uncertainty * gradient)


def test_flux_within_the_monte_carlo_error(barbanis_contopoulos, saddle):
    """The saddle-flux Monte Carlo at ΔE = 0.5 (4000 samples, the settings of the transport tests)."""
    system = barbanis_contopoulos
    nf = system_normal_form(system, saddle, 8, transforms=False)
    energy = system.potential(saddle) + 0.5
    plane = DividingPlane.at_saddle(system, saddle, energy)
    result = reactive_flux_monte_carlo(plane, commit=2.0, duration=20.0, batch=2000, max_samples=4000,
                                       target_stderr=0.0, flow=FlowSettings(rtol=1e-9, atol=1e-9, escape_radius=60.0),
                                       seed=3)
    assert result.undecided == 0
    # measured 4.71472 ± 0.00118 (0.23 standard errors from the normal form's 4.714448)
    assert abs(result.flux - flux(nf, 0.5)) < 3 * result.stderr
