"""Manifolds of the Lyapunov orbits: start on the orbit, separate at the Floquet rate, cut the section."""

from dataclasses import replace

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from ldpipe.io import contracts
from ldpipe.config import validate_config
from ldpipe.io.datafile import open_stage_file
from ldpipe.core.trajectories import FlowSettings, integrate
from ldpipe.core.orbits.manifolds import ManifoldSettings, globalized_manifolds, start_states
from ldpipe.core.orbits.periodic import CorrectorSettings, LyapunovFamily, linearize_saddle
from ldpipe.stages import manifolds as manifold_stage
from ldpipe.stages import upo as upo_stage
from ldpipe.stages.equilibria import run_equilibria
from ldpipe.config.parameters import parameters_from_config
from ldpipe.systems import make_system
from ldpipe.core.variational import propagate

EXCESS = 0.125
EPSILON = 1e-6
SETTINGS = ManifoldSettings(points=40, displacement=EPSILON, time=25.0, samples=100, crossings=2)
FLOW = FlowSettings(rtol=1e-11, atol=1e-11, escape_radius=30.0)


def orbit_at(system, y_sign, excess=EXCESS):
    family = LyapunovFamily(system, linearize_saddle(system, np.array([5.5, y_sign * np.sqrt(50.0)])), 0,
                            CorrectorSettings())
    ec = family.saddle.critical_energy
    family.continue_to(ec + excess, initial_amplitude=1e-4, max_step=0.1, max_members=500)
    return family.at_energy(ec + excess, energy_tolerance=1e-12)


@pytest.fixture(scope="module")
def bottom(barbanis):
    orbit = orbit_at(barbanis, -1)
    return orbit, globalized_manifolds(barbanis, orbit.initial_state, orbit.period, SETTINGS, FLOW)


@pytest.fixture(scope="module")
def top(barbanis):
    orbit = orbit_at(barbanis, +1)
    return orbit, globalized_manifolds(barbanis, orbit.initial_state, orbit.period, SETTINGS, FLOW)


def test_points_start_within_epsilon_of_the_orbit(bottom):
    # By construction: each start is the orbit point plus or minus epsilon times an eigenvector whose
    # position part has unit length, so the configuration-space distance is epsilon.
    _, data = bottom
    offset = data.start_state.values - data.orbit_state.values[None, None]
    np.testing.assert_allclose(np.linalg.norm(offset[..., :2], axis=-1), EPSILON, rtol=1e-9)
    assert np.all(np.linalg.norm(offset, axis=-1) < 10 * EPSILON)


def test_separation_grows_at_the_floquet_rate(barbanis, bottom):
    # Linear theory: after one period the displacement along the unstable eigenvector is multiplied
    # by lambda (forward); along the stable one by lambda going backward. Errors O(epsilon lambda).
    orbit, data = bottom
    lam = data.attrs["unstable_multiplier"]
    start = start_states(barbanis, orbit.initial_state, orbit.period, SETTINGS)
    for k, duration in ((1, orbit.period), (0, -orbit.period)):
        states = start["starts"][k].reshape(-1, 4)
        result = integrate(barbanis, states, duration, FlowSettings(rtol=1e-13, atol=1e-13),
                           sample_times=np.array([0.0, duration]))
        orbit_points = np.tile(start["orbit"], (2, 1))  # the orbit is back where it started after T
        ratio = (np.linalg.norm(result.samples[:, 1] - orbit_points, axis=1)
                 / np.linalg.norm(result.samples[:, 0] - orbit_points, axis=1))
        np.testing.assert_allclose(ratio, lam, rtol=1e-3)


def test_section_curves_lie_on_the_section_and_energy_surface(barbanis, bottom):
    # Crossings located on the step's polynomial: on y = 0 to round-off, with p_y > 0, on the orbit's energy surface
    # to the integration tolerance.
    orbit, data = bottom
    valid = data.section_valid.values
    states = data.section_state.values[valid]
    assert valid[:, 0, 0].all()  # every inward trajectory of both manifolds reaches the section
    assert np.all(np.abs(states[:, 1]) < 1e-12) and np.all(states[:, 3] > 0)
    energies = np.array([barbanis.energy(s) for s in states])
    np.testing.assert_allclose(energies, orbit.energy, atol=1e-7)


def test_trajectories_and_cuts_match_an_independent_integration(barbanis, bottom):
    # Independent method: scipy's DOP853 at rtol = atol = 1e-13 with t_eval, the section as an
    # event and the escape radius as a terminal event, from the same starts, on six points of
    # every manifold and branch. The differences are the 1e-11 integration's global errors,
    # amplified along the unstable direction (starts 1e-6 from a hyperbolic orbit) and largest
    # on the outward branches running out to |q| = 30: measured up to 2e-6 on samples, 3e-8 on
    # section crossings and escape times. Bounds 1e-5, 1e-7 and 1e-6; energy (invariant) within
    # 3e-8 (measured 1.4e-8).
    orbit, data = bottom
    radius = FLOW.escape_radius

    def rhs(_t, y):
        return np.concatenate([y[2:], -barbanis.gradient(y[:2])])

    def crossing(_t, y):
        return y[1]

    events = [crossing]
    for i in range(2):
        for sign in (1.0, -1.0):
            def leave(_t, y, i=i, sign=sign):
                return sign * y[i] - radius

            leave.terminal = True
            leave.direction = 1
            events.append(leave)
    for k in range(2):
        times = data.time.values[k]
        crossing.direction = np.sign(times[-1])  # p_y > 0 in forward time
        for branch in range(2):
            for point in range(0, SETTINGS.points, 7):
                reference = solve_ivp(rhs, (0, times[-1]), data.start_state.values[k, branch, point], method="DOP853",
                                      rtol=1e-13, atol=1e-13, t_eval=times, events=events)
                status = int(data.status.values[k, branch, point])
                count = int(data.sample_count.values[k, branch, point])
                if status != 2:  # not stopped early at the last crossing wanted
                    assert count == len(reference.t)
                samples = data.trajectory.values[k, branch, point, :count]
                np.testing.assert_allclose(samples, reference.y.T[:count], rtol=0, atol=1e-5)
                np.testing.assert_allclose([barbanis.energy(y) for y in samples], orbit.energy, rtol=0, atol=3e-8)
                if status == 1:
                    assert reference.status == 1  # escaped where scipy's terminal event fired
                    escape_time = np.concatenate(reference.t_events[1:])
                    np.testing.assert_allclose(data.end_time.values[k, branch, point], escape_time, rtol=0, atol=1e-6)
                found = reference.y_events[0].reshape(-1, 4)[np.abs(reference.t_events[0]) > 1e-9][: SETTINGS.crossings]
                valid = data.section_valid.values[k, branch, :, point]
                assert valid.sum() == len(found)
                np.testing.assert_allclose(data.section_state.values[k, branch, : len(found), point], found, rtol=0,
                                           atol=1e-7)


def test_section_curves_are_ordered_closed_curves(bottom):
    # The first cut of a tube is a closed curve; taken in orbit-phase order, neighbours are close.
    _, data = bottom
    for k in range(2):
        curve = data.section_state.values[k, 0, 0][:, [0, 2]]
        gaps = np.linalg.norm(np.diff(np.vstack([curve, curve[:1]]), axis=0), axis=1)
        assert gaps.max() < 0.25 * np.ptp(curve, axis=0).max()


def test_outward_branches_escape(bottom):
    # Beyond the saddle the Barbanis potential falls without bound: the outward unstable branch leaves.
    _, data = bottom
    assert data.escaped.values[1, 1].all()
    assert np.all(data.end_time.values[1, 1] < SETTINGS.time)


def test_time_reversal_and_mirror_map_top_manifolds_onto_bottom(bottom, top):
    # Independent check by symmetry: (x, y, px, py, t) -> (x, -y, -px, py, -t) maps the top saddle's
    # orbit to the bottom's, its unstable manifold to the bottom's stable one, and the section
    # y = 0, p_y > 0 to itself with px -> -px.
    (_, lower), (_, upper) = bottom, top
    for top_k, bottom_k in ((1, 0), (0, 1)):
        mapped = upper.section_state.values[top_k, 0, 0] * np.array([1.0, -1.0, -1.0, 1.0])
        reference = lower.section_state.values[bottom_k, 0, 0]
        distance = np.linalg.norm(mapped[:, None] - reference[None], axis=-1).min(axis=1)
        assert distance.max() < 1e-6


def test_stage_writes_manifolds_from_the_upo_file(tmp_path):
    # The file's shape, and its values: (1) the starts leave the orbit along the monodromy matrix's
    # unstable (stable) eigenvector, computed here at each orbit point over one period from the
    # UPO file's period (independent of the stage's transport of one eigenvector by the STM):
    # direction measured within 3.5e-10 (round-off of a 1e-6 difference of states of size 10 is
    # ~2e-9), bound 1e-8. (2) The starts lie on H = E: an eigenvector of a multiplier != 1 is
    # tangent to the energy surface (dH.e = w(f, e) = lambda w(f, e) = 0), so only epsilon^2 ~ 1e-12
    # remains (measured 1.0e-12, the orbit samples' own error), bound 1e-10. (3) The trajectories
    # stay on H = E to the integration tolerance (rtol 1e-10 over 10 time units: measured 3.7e-9,
    # bound 3e-8). H is written out here; E = E_c + 2.25 with the paper's E_c = 15.125.
    config = validate_config({
        "systems": {"barbanis_2dof": {"builtin": "barbanis_2dof"}},
        "periodic_orbits": {"bottom": {"system": "barbanis_2dof", "saddle_near": [5.5, -7.0],
                                       "energies": {"excess": [0.125, 2.25]}, "samples": 20}},
        "manifolds": {"m": {"orbits": "bottom", "energy": {"excess": 2.25}, "points": 8, "samples": 10, "time": 10}},
    })
    equilibria = run_equilibria(**parameters_from_config(config, "equilibria", "barbanis_2dof"),
                                output=tmp_path / "eq.nc")
    upo = upo_stage.run_upo(**parameters_from_config(config, "upo", "bottom"), equilibria=equilibria,
                            output=tmp_path / "upo.nc")
    path = manifold_stage.run_manifolds(**parameters_from_config(config, "manifolds", "m"), upo=upo,
                                        output=tmp_path / "m.nc")
    data = open_stage_file(path, stage=contracts.MANIFOLDS)
    assert data.attrs["excess_energy"] == pytest.approx(2.25, abs=1e-11)
    assert dict(data.trajectory.sizes) == {"manifold": 2, "branch": 2, "point": 8, "sample": 10, "phase": 4}
    assert list(data.manifold.values) == ["stable", "unstable"]

    def energy(states):
        x, y, px, py = np.moveaxis(states, -1, 0)
        return (px**2 + py**2) / 2 + x**2 / 2 + 1.21 * y**2 / 2 - 0.11 * x * y**2

    system = make_system("barbanis_2dof", {"builtin": "barbanis_2dof"})
    period = float(open_stage_file(upo, stage=contracts.UPO).period.values[1])  # the family's dE = 2.25
    starts, orbit = data.start_state.values, data.orbit_state.values
    for j, point in enumerate(orbit):
        values, vectors = np.linalg.eig(propagate(system, point, period, rtol=1e-12, atol=1e-12).stm)
        for k, column in ((1, np.argmax(np.abs(values))), (0, np.argmin(np.abs(values)))):  # unstable, stable
            eigenvector = vectors[:, column].real / np.linalg.norm(vectors[:, column].real)
            for branch in range(2):
                offset = starts[k, branch, j] - point
                direction = offset / np.linalg.norm(offset)
                assert min(np.linalg.norm(direction - eigenvector), np.linalg.norm(direction + eigenvector)) < 1e-8
    np.testing.assert_allclose(energy(starts), 15.125 + 2.25, rtol=0, atol=1e-10)
    counts = data.sample_count.values
    samples = data.trajectory.values[np.arange(10) < counts[..., None]]
    assert len(samples) == counts.sum() > 0
    np.testing.assert_allclose(energy(samples), 15.125 + 2.25, rtol=0, atol=3e-8)


def test_manifolds_with_equal_masses(barbanis, bottom):
    # H = |p|^2 / 16 + V (m_x = m_y = 8) is the unit-mass system slowed down by sqrt(8) (same energy,
    # q(t) = q_unit(t / sqrt(8))): the orbit's Floquet multiplier is the unit-mass one (an identity,
    # the exponent times the period is unchanged). The manifolds leave the orbit at that rate and cut
    # y = 0 with p_y > 0 on this H's energy surface (H written out here).
    massive = make_system(
        "barbanis_m8", {"builtin": "barbanis_2dof", "masses": {"x": 8.0, "y": 8.0}})
    orbit = orbit_at(massive, -1)
    unit_orbit, unit_data = bottom
    assert orbit.period == pytest.approx(np.sqrt(8.0) * unit_orbit.period, rel=1e-10)
    # the same motion sqrt(8) times slower: the unit-mass test's time span scaled to reach the section
    settings = replace(SETTINGS, time=np.sqrt(8.0) * SETTINGS.time)
    data = globalized_manifolds(massive, orbit.initial_state, orbit.period, settings, FLOW)
    lam = data.attrs["unstable_multiplier"]
    assert lam == pytest.approx(unit_data.attrs["unstable_multiplier"], rel=1e-7)
    start = start_states(massive, orbit.initial_state, orbit.period, settings)
    states = start["starts"][1].reshape(-1, 4)
    result = integrate(massive, states, orbit.period, FlowSettings(rtol=1e-13, atol=1e-13),
                       sample_times=np.array([0.0, orbit.period]))
    orbit_points = np.tile(start["orbit"], (2, 1))
    ratio = (np.linalg.norm(result.samples[:, 1] - orbit_points, axis=1)
             / np.linalg.norm(result.samples[:, 0] - orbit_points, axis=1))
    np.testing.assert_allclose(ratio, lam, rtol=1e-3)
    valid = data.section_valid.values
    cuts = data.section_state.values[valid]
    assert valid[:, 0, 0].all()
    assert np.all(np.abs(cuts[:, 1]) < 1e-12) and np.all(cuts[:, 3] > 0)
    x, y = cuts[:, 0], cuts[:, 1]
    energies = (cuts[:, 2] ** 2 + cuts[:, 3] ** 2) / 16.0 + x**2 / 2 + 1.21 * y**2 / 2 - 0.11 * x * y**2
    np.testing.assert_allclose(energies, orbit.energy, atol=1e-7)
