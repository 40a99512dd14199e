"""Poincaré sections: crossings on the section and the energy surface, located accurately; escapes."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from ldpipe.io import contracts
from ldpipe.config import validate_config
from ldpipe.io.datafile import open_stage_file
from ldpipe.core.trajectories import FlowSettings, integrate
from ldpipe.core.orbits.poincare import section_crossings
from ldpipe.core.sections import Section
from ldpipe.stages import poincare as poincare_stage
from ldpipe.stages.equilibria import run_equilibria
from ldpipe.config.parameters import parameters_from_config

EC = 15.125  # paper: critical energy of the Barbanis saddles
GRID = Section(axes=("x", "px"), ranges=((-5.5, 5.5), (-5.5, 5.5)), shape=(7, 7), fixed={"y": 0.0}, solve="py")
FLOW = FlowSettings(rtol=1e-10, atol=1e-10, escape_radius=30.0)


def section_at(system, excess, time=150.0):
    return section_crossings(system, GRID, EC + excess, section=("y", 0.0, 1), time=time, max_crossings=100, flow=FLOW)


@pytest.mark.parametrize("excess", [-0.125, 0.0, 0.125])
def test_crossings_on_the_section_and_energy_surface(barbanis, excess):
    # Section y = 0 with p_y > 0 (the paper's U_xpx); H conserved to the integration tolerance.
    data = section_at(barbanis, excess)
    valid = data.crossing_valid.values
    states = data.crossing_state.values[valid]
    assert len(states) > 100
    assert np.all(np.abs(states[:, 1]) < 1e-12) and np.all(states[:, 3] > 0)
    energies = 0.5 * (states[:, 2] ** 2 + states[:, 3] ** 2) + np.array([barbanis.potential(s[:2]) for s in states])
    np.testing.assert_allclose(energies, EC + excess, atol=1e-7)


def _rhs(system):
    def rhs(_t, y):
        return np.concatenate([y[2:], -system.gradient(y[:2])])

    return rhs


@pytest.mark.parametrize(("section", "duration"), [(("y", 0.0, 1), 60.0), (("px", 0.0, -1), 60.0),
                                                   (("y", 0.0, 1), -60.0)])
def test_crossings_match_an_independent_integration(barbanis, section, duration):
    # Independent method: scipy's DOP853 with its own event location, at rtol = atol = 1e-13, on
    # every third initial condition; a section of q (located on the step's q polynomial) and of
    # p (on the p = q' polynomial), forward and backward (the direction is the forward-time one:
    # backward, scipy sees the opposite sign change). Over 60 time units the global error of a
    # 1e-10 integration grew to ~3e2 tolerances (measured): bound 1e-7.
    states = section_at(barbanis, -0.125, time=1.0).initial_state.values
    result = integrate(barbanis, states, duration, FLOW, section=section, max_crossings=100)
    index = barbanis.phase_coordinates.index(section[0])

    def crossing(_t, y):
        return y[index] - section[1]

    crossing.direction = section[2] * np.sign(duration)
    energy = barbanis.energy(states[0])
    for k in range(0, len(states), 3):
        reference = solve_ivp(_rhs(barbanis), (0, duration), states[k], method="DOP853", rtol=1e-13, atol=1e-13,
                              events=crossing)
        times, found = reference.t_events[0], reference.y_events[0]
        times, found = times[np.abs(times) > 1e-9], found[np.abs(times) > 1e-9]
        count = int(result.crossing_count[k])
        assert count == len(times)
        np.testing.assert_allclose(result.crossing_times[k, :count], times, rtol=0, atol=1e-7)
        np.testing.assert_allclose(result.crossings[k, :count], found, rtol=0, atol=1e-7)
        # on the section to round-off, on the energy surface to the integration tolerance
        assert np.all(np.abs(result.crossings[k, :count, index] - section[1]) < 1e-12)
        np.testing.assert_allclose([barbanis.energy(y) for y in result.crossings[k, :count]], energy, rtol=0,
                                   atol=1e-8)


def test_samples_match_an_independent_integration(barbanis):
    # Samples come from the step's dense output (steps are not shortened to land on them).
    # Independent method: scipy's DOP853 at rtol = atol = 1e-13 with t_eval, on every third
    # initial condition, forward and backward. Global error of the 1e-10 integration over 20
    # time units: bound 1e-8. Energy (the invariant): at step ends |H - H0| reached 3e-9 over 20
    # time units (measured, no samples); the interpolant adds up to
    # ~3x between step ends (measured 1e-8 on 4001 samples): bound 3e-8.
    states = section_at(barbanis, -0.125, time=1.0).initial_state.values[::3]
    for duration in (20.0, -20.0):
        times = np.linspace(0.0, duration, 137)  # incommensurate with any step
        result = integrate(barbanis, states, duration, FLOW, sample_times=times)
        np.testing.assert_array_equal(result.sample_count, len(times))
        for k, start in enumerate(states):
            reference = solve_ivp(_rhs(barbanis), (0, duration), start, method="DOP853", rtol=1e-13, atol=1e-13,
                                  t_eval=times)
            np.testing.assert_allclose(result.samples[k], reference.y.T, rtol=0, atol=1e-8)
            energies = [barbanis.energy(y) for y in result.samples[k]]
            np.testing.assert_allclose(energies, barbanis.energy(start), rtol=0, atol=3e-8)


def test_the_last_crossing_wanted_ends_the_trajectory(barbanis):
    # By definition of max_crossings: the trajectory stops at its last crossing, so the end time
    # is that crossing's time, and samples after it repeat the crossing state.
    states = section_at(barbanis, -0.125, time=1.0).initial_state.values[:4]
    result = integrate(barbanis, states, 100.0, FLOW, sample_times=np.array([0.0, 100.0]), section=("y", 0.0, 1),
                       max_crossings=3)
    np.testing.assert_array_equal(result.status, 2)
    np.testing.assert_array_equal(result.crossing_count, 3)
    np.testing.assert_array_equal(result.final_time, result.crossing_times[:, 2])
    np.testing.assert_array_equal(result.sample_count, 1)
    np.testing.assert_array_equal(result.samples[:, 1], result.crossings[:, 2])


def test_escapes_are_located_at_the_radius(barbanis):
    # Above E_c some trajectories leave the well: the integration stops where max_i |q_i| first
    # reaches the radius (located on the step's q polynomial), so the state there is on the
    # radius to round-off, and the time is scipy's terminal event |q_i| = R (rtol 1e-13).
    radius = 30.0
    states = section_at(barbanis, 0.125, time=1.0).initial_state.values
    result = integrate(barbanis, states, 150.0, FLOW, sample_times=np.array([0.0, 150.0]))
    escaped = np.flatnonzero(result.status == 1)
    assert len(escaped) >= 2
    ends = result.samples[escaped, 1, :2]
    np.testing.assert_allclose(np.abs(ends).max(axis=1), radius, rtol=1e-12)
    events = []
    for i in range(2):
        for sign in (1.0, -1.0):
            def leave(_t, y, i=i, sign=sign):
                return sign * y[i] - radius

            leave.terminal = True
            leave.direction = 1
            events.append(leave)
    for k in escaped:
        reference = solve_ivp(_rhs(barbanis), (0, 150.0), states[k], method="DOP853", rtol=1e-13, atol=1e-13,
                              events=events)
        assert reference.status == 1
        np.testing.assert_allclose(result.final_time[k], reference.t[-1], rtol=0, atol=1e-7)


def test_below_the_saddle_nothing_escapes_above_it_some_do(barbanis):
    # Below E_c the well's Hill region is closed, so no trajectory can leave; above it the bottlenecks open.
    below = section_at(barbanis, -0.125)
    assert not below.escaped.values.any()
    np.testing.assert_array_equal(below.end_time.values, 150.0)
    above = section_at(barbanis, 0.125)
    escaped = above.escaped.values
    assert escaped.any()
    assert np.all(above.end_time.values[escaped] < 150.0)
    last = above.crossing_state.values[escaped, :, :2]
    assert np.all(np.abs(last) <= 30.0)


def test_stage_writes_the_section(tmp_path):
    config = validate_config({
        "systems": {"barbanis_2dof": {"builtin": "barbanis_2dof"}},
        "poincare_sections": {"p": {
            "system": "barbanis_2dof", "energy": {"excess": 0.125}, "time": 50, "max_crossings": 20,
            "initial_conditions": {"axes": [{"name": "x", "range": [-5, 5], "points": 4},
                                            {"name": "px", "range": [-5, 5], "points": 4}],
                                   "fixed": {"y": 0.0}, "solve": "py"},
        }},
    })
    equilibria = run_equilibria(**parameters_from_config(config, "equilibria", "barbanis_2dof"),
                                output=tmp_path / "eq.nc")
    path = poincare_stage.run_poincare(**parameters_from_config(config, "poincare", "p"), equilibria=equilibria,
                                       output=tmp_path / "p.nc")
    data = open_stage_file(path, stage=contracts.POINCARE)
    assert data.attrs["excess_energy"] == pytest.approx(0.125, abs=1e-12)
    assert data.sizes["crossing"] == 20 and data.crossing_valid.dtype == bool
    # The file's values: initial conditions on y = 0 and H = E (p_y solved: round-off, measured
    # 4e-15); crossings on the section y = 0 with p_y > 0 (located on the step's polynomial:
    # round-off, measured 1e-16) and on H = E to the integration tolerance (the schema's rtol 1e-10
    # over 50 time units: measured 5.7e-9, bound 3e-8). H is written out; E = the paper's E_c + 0.125.

    def energy(states):
        x, y, px, py = np.moveaxis(states, -1, 0)
        return (px**2 + py**2) / 2 + x**2 / 2 + 1.21 * y**2 / 2 - 0.11 * x * y**2

    initial = data.initial_state.values
    assert len(initial) >= 8 and np.all(initial[:, 1] == 0.0) and np.all(initial[:, 3] >= 0)
    np.testing.assert_allclose(energy(initial), EC + 0.125, rtol=0, atol=1e-12)
    states = data.crossing_state.values[data.crossing_valid.values]
    assert len(states) == data.crossing_count.values.sum() > 0
    assert np.all(np.abs(states[:, 1]) < 1e-12) and np.all(states[:, 3] > 0)
    np.testing.assert_allclose(energy(states), EC + 0.125, rtol=0, atol=3e-8)


def test_bad_initial_conditions_name_the_key():
    from ldpipe.errors import ConfigError

    with pytest.raises(ConfigError, match="poincare_sections.p.initial_conditions"):
        validate_config({
            "systems": {"b": {"builtin": "barbanis_2dof"}},
            "poincare_sections": {"p": {
                "system": "b", "energy": {"excess": 0.1},
                "initial_conditions": {"axes": [{"name": "x", "range": [-5, 5], "points": 4},
                                                {"name": "px", "range": [-5, 5], "points": 4}], "solve": "py"},
            }},
        })


def test_without_a_section_trajectories_run_to_the_end(barbanis):
    # With no section the crossing counter is 0 of 0, which must not count as full: a trajectory
    # would stop at its first upward crossing of the first coordinate through 0.
    # In the well below E_c nothing escapes, so every trajectory must reach the final time.
    states = section_at(barbanis, -0.125).initial_state.values[:5]
    result = integrate(barbanis, states, 40.0, FLOW)
    assert np.all(result.status == 0)
    np.testing.assert_allclose(result.final_time, 40.0, rtol=1e-14)


def test_a_trajectory_does_not_depend_on_its_batch(barbanis):
    # Invariant of the block layout: every lane has its own step size and events, so a trajectory
    # integrated alone (a block of ldpipe.core.trajectories.SMALL_LANES lanes) or among many (blocks of
    # ldpipe.core.trajectories.LANES, refilled as lanes finish) gives the same bits, forward and backward.
    states = section_at(barbanis, 0.125, time=1.0).initial_state.values
    for duration in (100.0, -100.0):
        times = np.linspace(0.0, duration, 33)
        batch = integrate(barbanis, states, duration, FLOW, sample_times=times, section=("y", 0.0, 1), max_crossings=50)
        assert 0 < np.sum(batch.status == 1) < len(states)  # some lanes end early and are refilled
        for k in (0, 7, len(states) - 1):
            alone = integrate(barbanis, states[k:k + 1], duration, FLOW, sample_times=times, section=("y", 0.0, 1),
                              max_crossings=50)
            np.testing.assert_array_equal(alone.samples[0], batch.samples[k])
            np.testing.assert_array_equal(alone.crossings[0], batch.crossings[k])
            np.testing.assert_array_equal(alone.crossing_times[0], batch.crossing_times[k])
            assert (alone.steps[0], alone.status[0], alone.final_time[0]) == (batch.steps[k], batch.status[k],
                                                                                batch.final_time[k])


def test_stage_with_a_coupled_kinetic_matrix(tmp_path):
    # H = p^T M^-1 p / 2 + V with M = [[1.5, 0.5], [0.5, 1.5]]: every crossing lies on y = 0 with
    # dy/dt = (M^-1 p)_y > 0 (the section's direction is the velocity's) and on the energy surface of
    # this H (written out here with numpy's inverse); the initial conditions too (their solved p_y
    # has dy/dt of the default sign +1). The file records the matrix.
    mass = np.array([[1.5, 0.5], [0.5, 1.5]])
    spec = {"builtin": "barbanis_2dof", "mass_matrix": mass.tolist()}
    config = validate_config({
        "systems": {"barbanis_coupled": spec},
        "poincare_sections": {"p": {
            "system": "barbanis_coupled", "energy": {"excess": -0.125}, "time": 40, "max_crossings": 10,
            "initial_conditions": {"axes": [{"name": "x", "range": [-4, 4], "points": 4},
                                            {"name": "px", "range": [-4, 4], "points": 4}],
                                   "fixed": {"y": 0.0}, "solve": "py"},
        }},
    })
    equilibria = run_equilibria(**parameters_from_config(config, "equilibria", "barbanis_coupled"),
                                output=tmp_path / "eq.nc")
    path = poincare_stage.run_poincare(**parameters_from_config(config, "poincare", "p"), equilibria=equilibria,
                                       output=tmp_path / "p.nc")
    data = open_stage_file(path, stage=contracts.POINCARE)
    assert data.attrs["mass_matrix"] == "[[1.5, 0.5], [0.5, 1.5]]"
    inverse = np.linalg.inv(mass)

    def energy(s):
        x, y, p = s[0], s[1], s[2:]
        return 0.5 * p @ inverse @ p + x**2 / 2 + 1.21 * y**2 / 2 - 0.11 * x * y**2

    initial = data.initial_state.values
    assert len(initial) >= 8
    np.testing.assert_allclose([energy(s) for s in initial], EC - 0.125, atol=1e-12)
    assert np.all((initial[:, 2:] @ inverse.T)[:, 1] >= 0)
    states = data.crossing_state.values[data.crossing_valid.values]
    assert len(states) > 50
    assert np.all(np.abs(states[:, 1]) < 1e-12)
    assert np.all((states[:, 2:] @ inverse.T)[:, 1] > 0)
    np.testing.assert_allclose([energy(s) for s in states], EC - 0.125, atol=1e-8)
