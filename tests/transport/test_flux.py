"""Flux over a saddle, each number against an independent value.

Closed forms on the quadratic saddle H = (p_x² + p_y²)/2 − λ²x²/2 + ω²y²/2 at excess energy ΔE
(E_c = 0):

* Lyapunov orbit: x = 0, y = A cos ωt with ω²A²/2 = ΔE, so ∮ p·dq = ∫_0^{2π/ω} p_y² dt
  = A²ω² π/ω = π ω A² = 2π ΔE / ω.
* Flux through x = 0: the area of {(y, p_y): p_y²/2 + ω²y²/2 ≤ ΔE}, an ellipse with half-axes
  √(2ΔE)/ω and √(2ΔE): π · 2ΔE/ω = 2π ΔE / ω. The saddle is uncoupled, so x(t) is monotone
  through the line and every crossing is reactive: the Monte Carlo flux must equal it.

On Barbanis 2 DoF, the identity of reactive-island theory (MacKay 1990): the orbit's action equals
the area ∮ p_x dx enclosed by the first cut of its manifold tube with y = 0 (the tube is a
Lagrangian cylinder, ∮ p·dq is the same on every loop round it) and the reactive flux.
"""

import math

import numpy as np
import pytest

from ldpipe.core.trajectories import FlowSettings
from ldpipe.core.orbits.manifolds import ManifoldSettings, globalized_manifolds
from ldpipe.core.orbits.periodic import CorrectorSettings, LyapunovFamily, linearize_saddle
from ldpipe.systems import make_system
from ldpipe.core.transport import (
    DividingLine, closed_curve_area, orbit_action, reactive_flux_monte_carlo, well_area, well_shell_volume,
)

LAM, OMEGA = 0.8, 1.3


@pytest.fixture(scope="module")
def quadratic_saddle():
    """The quadratic saddle, rotated by 30° so the dividing line is not a coordinate axis."""
    c, s = math.cos(math.pi / 6), math.sin(math.pi / 6)
    formula = (f"-lam**2*({c}*x + {s}*y)**2/2 + om**2*(-{s}*x + {c}*y)**2/2")
    return make_system("quadratic_saddle", {"formula": formula, "coordinates": ["x", "y"],
                                            "parameters": {"lam": LAM, "om": OMEGA}}), np.array([c, s])


@pytest.mark.parametrize("excess", [0.01, 0.5, 3.0])
def test_action_of_harmonic_orbit_is_2pi_dE_over_omega(excess):
    amplitude = math.sqrt(2 * excess) / OMEGA
    period = 2 * math.pi / OMEGA
    t = np.linspace(0.0, period, 33)
    orbit = np.zeros((len(t), 4))
    orbit[:, 1] = amplitude * np.cos(OMEGA * t)
    orbit[:, 3] = -amplitude * OMEGA * np.sin(OMEGA * t)
    exact = 2 * math.pi * excess / OMEGA
    assert orbit_action(orbit, 2) == pytest.approx(exact, rel=1e-14)
    # Same samples without the repeated end point.
    assert orbit_action(orbit[:-1], 2, endpoint=False) == pytest.approx(exact, rel=1e-14)


def test_action_refuses_an_open_orbit():
    orbit = np.zeros((10, 4))
    orbit[:, 1] = np.linspace(0, 1, 10)
    with pytest.raises(ValueError, match="not one closed period"):
        orbit_action(orbit, 2)


def test_loop_area_spectral_converges_exponentially_shoelace_quadratically():
    """x = cos φ + a cos 2φ, p = sin φ: ∮ p dx = −∫ sin φ (sin φ + 2a sin 2φ) dφ = −π (the a-term
    integrates to 0); a smooth curve that is not an ellipse."""
    a = 0.3
    spectral, shoelace = [], []
    for n in (8, 16, 64):
        phi = 2 * math.pi * np.arange(n) / n
        x, p = np.cos(phi) + a * np.cos(2 * phi), np.sin(phi)
        spectral.append(abs(closed_curve_area(x, p) + math.pi))
        shoelace.append(abs(closed_curve_area(x, p, method="shoelace") + math.pi))
    assert max(spectral) < 1e-13
    # O(N^-2): 16 -> 64 points divides the polygon's error by ~16.
    assert 12 < shoelace[1] / shoelace[2] < 20


def test_loop_area_of_a_shifted_tilted_ellipse():
    """Ellipse centred at (3, −2), half-axes 0.7 and 0.2, rotated 0.4 rad: area π·0.7·0.2, clockwise
    in (x, p) when traversed as below, so ∮ p dx = +area."""
    phi = 2 * math.pi * np.arange(24) / 24
    u, v = 0.7 * np.cos(phi), -0.2 * np.sin(phi)
    x = 3 + u * math.cos(0.4) - v * math.sin(0.4)
    p = -2 + u * math.sin(0.4) + v * math.cos(0.4)
    assert closed_curve_area(x, p) == pytest.approx(math.pi * 0.7 * 0.2, rel=1e-14)


@pytest.mark.parametrize("excess", [0.05, 1.0])
def test_quadratic_saddle_line_area_and_monte_carlo_flux(quadratic_saddle, excess):
    system, unstable = quadratic_saddle
    line = DividingLine.at_saddle(system, [0.0, 0.0], excess)
    assert abs(abs(line.normal @ unstable) - 1) < 1e-12
    exact = 2 * math.pi * excess / OMEGA
    lo, hi = line.interval()
    assert (lo, hi) == pytest.approx((-math.sqrt(2 * excess) / OMEGA, math.sqrt(2 * excess) / OMEGA), rel=1e-13)
    assert line.area() == pytest.approx(exact, rel=1e-12)
    result = reactive_flux_monte_carlo(line, commit=1.0, duration=12.0, batch=2000, max_samples=2000,
                                       flow=FlowSettings(rtol=1e-9, atol=1e-9, escape_radius=50.0))
    # Uncoupled: every sample is reactive, so the estimate is the exact area; the standard error is
    # only its floor, A/N.
    assert (result.reactive, result.antireactive, result.undecided) == (2000, 0, 0)
    assert result.flux == pytest.approx(exact, rel=1e-12)
    assert result.stderr == pytest.approx(exact / 2000, rel=1e-12)


def test_samples_are_uniform_on_the_allowed_region(quadratic_saddle):
    """The fraction of samples with |u| < half the interval, against the exact area fraction
    (segment of an ellipse: (2/π)(θ + sin θ cos θ) with sin θ = 1/2)."""
    system, _ = quadratic_saddle
    line = DividingLine.at_saddle(system, [0.0, 0.0], 0.5)
    u, pu = line.sample(200_000, np.random.default_rng(1))
    half = 0.5 * line.interval()[1]
    fraction = np.mean(np.abs(u) < half)
    theta = math.asin(0.5)
    exact = 2 / math.pi * (theta + math.sin(theta) * math.cos(theta))
    assert abs(fraction - exact) < 4 * math.sqrt(exact * (1 - exact) / len(u))
    assert np.all(pu**2 / 2 + OMEGA**2 * u**2 / 2 <= 0.5 + 1e-12)


@pytest.fixture(scope="module")
def barbanis_orbit(barbanis):
    position = np.array([5.5, -math.sqrt(50.0)])
    family = LyapunovFamily(barbanis, linearize_saddle(barbanis, position), 0, CorrectorSettings())
    ec = family.saddle.critical_energy
    energy = ec + 0.5
    family.continue_to(energy, initial_amplitude=1e-4, max_step=0.1, max_members=500)
    orbit = family.at_energy(energy, energy_tolerance=1e-12)
    return orbit, energy, position


def test_barbanis_action_equals_island_area_and_reactive_flux(barbanis, barbanis_orbit):
    """Three independent computations of the flux at ΔE = 0.5 over the bottom saddle."""
    from ldpipe.core.variational import sample

    orbit, energy, position = barbanis_orbit
    times = np.linspace(0.0, orbit.period, 129)
    states, _ = sample(barbanis, orbit.initial_state, times, rtol=1e-13, atol=1e-13)
    action = orbit_action(states, 2)
    # An independent form of the action for H = |p|²/2 + V: q̇ = p, so ∮ p·dq = ∫ |p|² dt.
    assert action == pytest.approx(np.sum(states[:-1, 2:] ** 2) * orbit.period / 128, rel=1e-12)

    cut = globalized_manifolds(barbanis, orbit.initial_state, orbit.period,
                               ManifoldSettings(points=32, time=25.0, samples=2, crossings=1),
                               FlowSettings(rtol=1e-12, atol=1e-12, escape_radius=30.0))
    for k in range(2):  # stable, unstable
        valid = cut.section_valid.values[k, 0, 0]
        assert valid.all()
        state = cut.section_state.values[k, 0, 0]
        area = abs(closed_curve_area(state[:, 0], state[:, 2]))
        # measured 2.8e-12 (stable) and 3.2e-12 (unstable) relative, the flow at rtol 1e-12
        assert area == pytest.approx(action, rel=1e-11)

    line = DividingLine.at_saddle(barbanis, position, energy)
    result = reactive_flux_monte_carlo(line, commit=2.0, duration=15.0, batch=4000, max_samples=4000,
                                       flow=FlowSettings(rtol=1e-9, atol=1e-9, escape_radius=30.0))
    assert result.undecided == 0
    assert abs(result.flux - action) < 3 * result.stderr
    assert result.stderr < 1e-3 * action
    # The line's directional flux counts recrossings: it is larger than the action.
    assert line.area() > action


def test_well_area_of_a_harmonic_well_is_the_ellipse():
    """V = (a²x² + b²y²)/2, no saddle: {V ≤ E} is an ellipse of area π · 2E/(ab); the shell volume
    is 2π times that, (2π)² E/(ab)."""
    system = make_system("ellipse_well", {"formula": "(a**2*x**2 + b**2*y**2)/2", "coordinates": ["x", "y"],
                                          "parameters": {"a": 1.0, "b": 1.7}})
    energy = 0.8
    assert well_area(system, [0.0, 0.0], energy) == pytest.approx(math.pi * 2 * energy / 1.7, rel=1e-10)
    assert well_shell_volume(system, [0.0, 0.0], energy) == pytest.approx(4 * math.pi**2 * energy / 1.7, rel=1e-10)


def test_barbanis_well_area_against_box_monte_carlo(barbanis):
    """The well of Barbanis 2 DoF at ΔE = 0.5 above both saddles, cut off by their dividing lines, against
    the fraction of uniform points of a box with V ≤ E on the well side of both lines (plain NumPy
    potential, no ldpipe kernel; outside the well nothing in the box is allowed on that side)."""
    energy = 15.125 + 0.5
    lines = [DividingLine.at_saddle(barbanis, [5.5, sign * math.sqrt(50.0)], energy) for sign in (-1, 1)]
    area = well_area(barbanis, [0.0, 0.0], energy, lines)
    rng = np.random.default_rng(3)
    count, box = 2_000_000, np.array([[-8.0, -10.0], [8.0, 10.0]])
    q = rng.uniform(box[0], box[1], size=(count, 2))
    inside = q[:, 0] ** 2 / 2 + 1.21 * q[:, 1] ** 2 / 2 - 0.11 * q[:, 0] * q[:, 1] ** 2 <= energy
    for line in lines:
        inside &= (q - line.saddle) @ line.normal < 0
    box_area = float(np.prod(box[1] - box[0]))
    fraction = inside.mean()
    assert abs(area - box_area * fraction) < 4 * box_area * math.sqrt(fraction * (1 - fraction) / count)
