"""Poincaré sections: crossings on the section and the energy surface, located accurately; escapes."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from ldpipe import contracts
from ldpipe.config import validate_config
from ldpipe.datafile import open_stage_file
from ldpipe.flow import FlowSettings, integrate
from ldpipe.poincare import poincare_dataset
from ldpipe.sections import Section
from ldpipe.stages import poincare as poincare_stage
from ldpipe.stages.equilibria import equilibria_parameters, run_equilibria

EC = 15.125  # paper: critical energy of the Barbanis saddles
GRID = Section(axes=("x", "px"), ranges=((-5.5, 5.5), (-5.5, 5.5)), shape=(7, 7), fixed={"y": 0.0}, solve="py")
FLOW = FlowSettings(rtol=1e-10, atol=1e-10, escape_radius=30.0)


def section_at(system, excess, time=150.0):
    return poincare_dataset(system, GRID, EC + excess, section=("y", 0.0, 1), time=time, max_crossings=100, flow=FLOW)


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


def test_crossings_match_an_independent_integration(barbanis):
    # Independent method: scipy's DOP853 with its own event location, at tighter tolerance.
    data = section_at(barbanis, -0.125, time=60.0)
    start = data.initial_state.values[5]

    def rhs(_t, y):
        return np.concatenate([y[2:], -barbanis.gradient(y[:2])])

    def crossing(_t, y):
        return y[1]

    crossing.direction = 1
    reference = solve_ivp(rhs, (0, 60.0), start, method="DOP853", rtol=1e-13, atol=1e-13, events=crossing)
    times = reference.t_events[0]
    times, states = times[times > 1e-9], reference.y_events[0][times > 1e-9]
    count = int(data.crossing_count.values[5])
    assert count == len(times)
    np.testing.assert_allclose(data.crossing_time.values[5, :count], times, atol=1e-7)
    np.testing.assert_allclose(data.crossing_state.values[5, :count], states, atol=1e-7)


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
    equilibria = run_equilibria(**equilibria_parameters(config, "barbanis_2dof"), output=tmp_path / "eq.nc")
    path = poincare_stage.run_poincare(**poincare_stage.poincare_parameters(config, "p"), equilibria=equilibria,
                                       output=tmp_path / "p.nc")
    data = open_stage_file(path, stage=contracts.POINCARE)
    assert data.attrs["excess_energy"] == pytest.approx(0.125, abs=1e-12)
    assert data.sizes["crossing"] == 20 and data.crossing_valid.dtype == bool


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
    # Regression: with no section, the crossing counter (0 of 0) used to count as full, so a
    # trajectory stopped at its first upward crossing of the first coordinate through 0.
    # In the well below E_c nothing escapes, so every trajectory must reach the final time.
    states = section_at(barbanis, -0.125).initial_state.values[:5]
    result = integrate(barbanis, states, 40.0, FLOW)
    assert np.all(result.status == 0)
    np.testing.assert_allclose(result.final_time, 40.0, rtol=1e-14)
