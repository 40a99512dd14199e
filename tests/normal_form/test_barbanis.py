"""The normal form of Barbanis 2 DoF's bottom saddle against the Lyapunov orbit (independent: ldpipe's
differential corrector, scipy's DOP853) and against the properties a normal form must have.

* Flux: in normal-form coordinates the NHIM at ΔE is the Lyapunov orbit and the flux over the
  saddle is its action ∮ p·dq = 2π J, K(0, J) = ΔE (MacKay 1990); the orbit's action comes from
  the corrected orbit sampled at 129 points (spectral quadrature, converged to about 3e-13).
* The NHIM points mapped back to (x, y, p_x, p_y) lie on that orbit.
* The changes of coordinates: the new coordinates' Poisson brackets in the old ones are canonical
  (degree by degree, below the truncation), the round trip is the identity to rounding, and
  H(x(X)) − E_c − K(X) = O(|X|^(N+1)) for the normal form of degree N.
"""

import math

import numpy as np
import pytest

from ldpipe.core.normal_form import dividing_surface_points, flux, nhim_points, system_normal_form
from ldpipe.core.orbits.periodic import CorrectorSettings, LyapunovFamily, linearize_saddle, sample_orbit
from ldpipe.core.transport import orbit_action

SADDLE = np.array([5.5, -math.sqrt(50.0)])
EXCESS = 0.125


@pytest.fixture(scope="module")
def normal_form(barbanis):
    return system_normal_form(barbanis, SADDLE, 12)


@pytest.fixture(scope="module")
def lyapunov_orbit(barbanis):
    settings = CorrectorSettings()
    family = LyapunovFamily(barbanis, linearize_saddle(barbanis, SADDLE), 0, settings)
    energy = family.saddle.critical_energy + EXCESS
    family.continue_to(energy, initial_amplitude=1e-4, max_step=0.1, max_members=500)
    orbit = family.at_energy(energy, energy_tolerance=1e-13)
    return orbit, settings


def test_flux_is_the_orbit_action_with_an_error_falling_geometrically(barbanis, normal_form, lyapunov_orbit):
    orbit, settings = lyapunov_orbit
    action = orbit_action(sample_orbit(barbanis, orbit, 129, settings)[1], 2)
    errors = [abs(flux(normal_form, EXCESS, order=order) / action - 1) for order in (2, 4, 6, 8, 12)]
    # measured 3.6e-6, 9.4e-10, 9.0e-13, then the orbit action's own error (3e-13)
    assert errors[-1] < 1e-8
    assert errors[0] > 1e-6
    assert errors[1] < errors[0] / 1000 and errors[2] < errors[1] / 100
    assert max(errors[3:]) < 5e-12
    # the partial form (only the reactive pair decoupled) and the centre-volume quadrature agree
    assert flux(normal_form, EXCESS, method="volume") == pytest.approx(action, rel=5e-12)
    partial = system_normal_form(barbanis, SADDLE, 8, form="partial", transforms=False)
    assert flux(partial, EXCESS, method="volume") == pytest.approx(action, rel=5e-12)


def test_nhim_points_lie_on_the_lyapunov_orbit(barbanis, normal_form, lyapunov_orbit):
    orbit, settings = lyapunov_orbit
    dense = sample_orbit(barbanis, orbit, 4001, settings)[1]
    points = nhim_points(normal_form, EXCESS, angles=16)
    distance = np.min(np.linalg.norm(points[:, None, :] - dense[None], axis=2), axis=1)
    # The normal-form angle advances uniformly in time, and its zero (P₂ = 0, fixed by the
    # reversibility p → −p, which the normal form keeps) is a turning point of the brake orbit, as is
    # the orbit's first sample: the 16 angles fall on every 250th of the 4000 time steps.
    # measured 6e-13 (the samples themselves are 2e-3 apart)
    assert np.max(distance) < 1e-9
    energies = np.array([barbanis.energy(p) for p in points]) - orbit.energy
    assert np.max(np.abs(energies)) < 1e-12


def test_dividing_surface_points_are_at_the_energy_and_cross_forward(barbanis, normal_form):
    centre = np.array([[0.0, 0.0], [0.1, -0.05], [0.2, 0.1]])
    points = dividing_surface_points(normal_form, 0.5, centre)
    energies = np.array([barbanis.energy(p) for p in points]) - normal_form.energy
    # measured 3e-12: the remainder of degree 13 at |X| ≈ 0.8, where Q₁ = P₁ carries the excess
    assert np.max(np.abs(energies - 0.5)) < 3e-11
    back = normal_form.normal_states(points)
    assert np.max(np.abs(back[:, 0] - back[:, 2])) < 1e-10  # Q₁ = P₁ on the surface; measured 2e-11 (round trip at this distance)
    assert np.all(back[:, 0] > 0)


def test_coordinate_changes_are_canonical_and_inverse(barbanis, normal_form):
    basis, new = normal_form.basis, normal_form.from_original
    top = normal_form.order - 1
    for i in range(4):
        for j in range(i + 1, 4):
            degrees = {}
            for a in range(1, top + 1):
                for b in range(1, top + 1):
                    if a + b - 2 < top:  # the truncation spoils degrees ≥ N − 1 only
                        degrees[a + b - 2] = degrees.get(a + b - 2, 0) + basis.bracket(new[i][a], a, new[j][b], b)
            canonical = 1.0 if j == i + 2 else 0.0
            assert degrees[0][0] == pytest.approx(canonical, abs=1e-15)
            # measured 2e-17 and below
            assert all(np.max(np.abs(c)) < 1e-14 for d, c in degrees.items() if d > 0)
    rng = np.random.default_rng(7)
    directions = rng.normal(size=(20, 4))
    points = 0.4 * directions / np.linalg.norm(directions, axis=1)[:, None]
    states = normal_form.original_states(points)
    # measured 6e-16
    assert np.max(np.abs(normal_form.normal_states(states) - points)) < 1e-13
    energies = np.array([barbanis.energy(s) for s in states]) - normal_form.energy
    k = basis.evaluate(normal_form.hamiltonian_real, points).real
    assert np.max(np.abs(energies - k)) < 1e-12  # measured 1e-14


@pytest.mark.parametrize("order", [4, 6])
def test_remainder_falls_with_the_next_degree(barbanis, order):
    nf = system_normal_form(barbanis, SADDLE, order)
    rng = np.random.default_rng(8)
    directions = rng.normal(size=(6, 4))
    directions /= np.linalg.norm(directions, axis=1)[:, None]
    remainders = []
    for radius in (0.5, 1.0):
        states = nf.original_states(radius * directions)
        energies = np.array([barbanis.energy(s) for s in states]) - nf.energy
        remainders.append(np.abs(energies - nf.basis.evaluate(nf.hamiltonian_real, radius * directions).real))
    slopes = np.log2(remainders[1] / remainders[0])
    # measured within 0.2 of order + 1 at these radii
    assert np.all(np.abs(slopes - (order + 1)) < 0.5)


def test_truncation_error_is_the_change_from_the_order_below(normal_form, lyapunov_orbit, barbanis):
    # The study's truncation error at order N is |flux(N) - flux(N - 2)|; as the error falls
    # geometrically (the test above) it estimates the error of flux(N - 2) against the orbit's
    # action (independent: the corrected orbit), to within its own small share (error(N) is 1e-3 of
    # error(N - 2) at N = 6). Changed from the lowest order instead, it would be 3.6e-6 at order 6,
    # four thousand times the error it reports.
    from ldpipe.core.normal_form.study import flux_table

    orbit, settings = lyapunov_orbit
    action = orbit_action(sample_orbit(barbanis, orbit, 129, settings)[1], 2)
    six = system_normal_form(barbanis, SADDLE, 6, transforms=False)
    table = flux_table(six, [EXCESS])
    assert table.orders.tolist() == [2, 4, 6]
    np.testing.assert_array_equal(table.truncation_error, np.abs(table.by_order[:, 2] - table.by_order[:, 1]))
    # measured: the estimate within 0.097 % of the order-4 flux's error (9.4e-10 relative)
    assert table.truncation_error[0] == pytest.approx(abs(table.by_order[0, 1] - action), rel=5e-3)


def test_flux_by_order_is_the_same_by_volume_and_by_actions(normal_form):
    # Two independent quadratures of one region: the full form's K truncated at each even order,
    # its centre action's root (2 pi J) and the volume its rays enclose (spectral trapezoid rule),
    # agree at every order, not only the top one; a ray radius that ignored the order given
    # would give the top order's flux at all of them (3.6e-6 off at order 2).
    for order in (2, 4, 6, 8):
        by_actions = flux(normal_form, EXCESS, method="actions", order=order)
        # measured: 6.7e-16 relative at most
        assert flux(normal_form, EXCESS, method="volume", order=order) == pytest.approx(by_actions, rel=5e-15), order
