"""Stages on vector-field systems: LD maps without energy (closed forms), equilibria of an autonomous
field (closed forms), and the refusals of what needs a Hamiltonian, each naming its config key."""

import copy
import math

import numpy as np
import pytest
import yaml
from scipy.integrate import solve_ivp

from ldpipe.config import validate_config
from ldpipe.io.datafile import open_stage_file
from ldpipe.errors import ConfigError
from ldpipe.core.trajectories import FlowSettings, integrate
from ldpipe.core.maps.grid import resolve_ld_map
from ldpipe.stages.equilibria import run_equilibria
from ldpipe.core.maps.assembly import compute_ld_map
from ldpipe.stages.ld import run_ld_gather, run_ld_tile
from ldpipe.config.parameters import parameters_from_config
from ldpipe.stages.poincare import run_poincare
from ldpipe.systems import make_system
from support.closed_forms import linear_saddle_ld
from support.workflow import documented_yaml

LAM, MU = 0.8, 0.5
SYSTEMS = {
    # three state variables (odd): x, y a saddle, z growing, all uncoupled
    "saddle3": {"vector_field": {"x": "lam*x", "y": "-lam*y", "z": "mu*z"}, "coordinates": ["x", "y", "z"],
                "parameters": {"lam": LAM, "mu": MU}},
    "duffing": {"vector_field": {"x": "y", "y": "x - x**3 - delta*y + F*cos(omega*t)"}, "coordinates": ["x", "y"],
                "parameters": {"delta": 0.25, "F": 0.3, "omega": 1.2}},
    "unforced": {"vector_field": {"x": "y", "y": "x - x**3 - delta*y"}, "coordinates": ["x", "y"],
                 "parameters": {"delta": 0.25}, "equilibria": {"box": {"x": [-2.0, 2.0], "y": [-2.0, 2.0]}}},
}
MAP = {
    "system": "saddle3",
    "t0": 2.5,
    "section": {"axes": [{"name": "x", "range": [-0.5, 0.5], "points": 5}, {"name": "y", "range": [0.1, 0.9], "points": 4}],
                "fixed": {"z": 0.3}},
    "tau": 2.0,
    "p": 0.5,
    "integrator": {"rtol": 1e-12, "atol": 1e-12},
}


def config(**overrides):
    return validate_config({"systems": copy.deepcopy(SYSTEMS), "ld_maps": {"m": {**copy.deepcopy(MAP), **overrides}}})


def test_ld_map_of_a_vector_field_is_the_closed_form(tmp_path):
    # The uncoupled field's M_p is the sum of the linear closed forms (support.closed_forms): the
    # x, y saddle and z as a growing direction (linear_saddle_ld with y0 = 0); t0 changes nothing
    # for this autonomous field. Two tiles gathered equal the closed form at every grid point.
    parameters = parameters_from_config(config(tiles=2), "ld", "m")
    tiles = [run_ld_tile(output=tmp_path / f"t{k}.nc", equilibria=None, tile=k, tiles=2, show_progress=False, **parameters)
             for k in range(2)]
    dataset = open_stage_file(run_ld_gather(tiles=tiles, output=tmp_path / "m.nc"), stage="ld_grid")
    x, y = np.meshgrid(dataset.x.values, dataset.y.values, indexing="ij")
    for name, direction in (("ld_forward", 1), ("ld_backward", -1)):
        exact = np.vectorize(lambda a, b: linear_saddle_ld(a, b, LAM, 2.0, 0.5, direction)
                             + linear_saddle_ld(0.3, 0.0, MU, 2.0, 0.5, direction))(x, y)
        np.testing.assert_allclose(dataset[name].values, exact, rtol=1e-10, err_msg=name)
    assert dataset.allowed.values.all()
    assert "energy_error" not in dataset and "energy" not in dataset.attrs
    assert dataset.attrs["t0"] == 2.5
    assert dataset.x.attrs["long_name"] == "state variable x"


def test_time_dependent_map_depends_on_t0():
    # The forced Duffing field depends on t: the map from t0 = 0 and from t0 = 1.5 differ, while both
    # integrate every point (no energy surface masks any).
    spec = {"system": "duffing", "section": {"axes": [{"name": "x", "range": [-1.0, 1.0], "points": 3},
                                                      {"name": "y", "range": [-0.5, 0.5], "points": 3}]},
            "tau": 4.0, "integrator": {"rtol": 1e-10, "atol": 1e-10}}
    maps = [compute_ld_map(parameters_from_config(config(**spec, t0=t0), "ld", "m"), None, show_progress=False)
            for t0 in (0.0, 1.5)]
    assert maps[0].allowed.values.all()
    assert np.max(np.abs(maps[0].ld_forward.values - maps[1].ld_forward.values)) > 1e-3


@pytest.mark.parametrize("overrides, key", [
    ({"energy": {"total": 1.0}}, "ld_maps.m.energy"),
    ({"saddle_near": [0.0, 0.0, 0.0]}, "ld_maps.m.saddle_near"),
    ({"section": {**MAP["section"], "solve": "z"}}, "ld_maps.m.section.solve"),
    ({"section": {**MAP["section"], "fixed": {}}}, "ld_maps.m.section"),
    ({"section": {**MAP["section"], "fixed": {"z": "saddle"}}}, "ld_maps.m.section.fixed"),
    ({"time": "variable"}, "ld_maps.m.region"),
])
def test_bad_vector_field_maps_name_the_key(overrides, key):
    with pytest.raises(ConfigError, match=rf"config key '{key}'"):
        config(**overrides)


def test_a_scheme_without_general_flow_is_refused_naming_scheme_and_system():
    parameters = parameters_from_config(config(integrator={"scheme": "rk4", "dt": 0.01}), "ld", "m")
    with pytest.raises(ConfigError, match=r"'ld_maps.m.integrator.scheme': scheme 'rk4' cannot integrate system 'saddle3'"):
        compute_ld_map(parameters, None, show_progress=False)


def test_hamiltonian_stages_refuse_a_vector_field():
    base = {"systems": copy.deepcopy(SYSTEMS)}
    orbits = {**base, "periodic_orbits": {"f": {"system": "unforced", "energies": {"excess": [0.1]}}}}
    with pytest.raises(ConfigError, match=r"'periodic_orbits.f.system': system 'unforced' is a vector field"):
        validate_config(orbits)
    hamiltonian_map = {**base, "systems": {**base["systems"], "h": {"builtin": "barbanis_2dof"}},
                       "ld_maps": {"m": {**copy.deepcopy(MAP), "system": "h", "t0": 1.0,
                                         "section": {**MAP["section"], "solve": "py"}, "energy": {"total": 1.0}}}}
    with pytest.raises(ConfigError, match=r"'ld_maps.m.t0': system 'h' is autonomous"):
        validate_config(hamiltonian_map)


def test_equilibria_of_an_autonomous_field_are_the_closed_forms(tmp_path):
    # x' = y, y' = x - x^3 - delta y: roots (0, 0), (+-1, 0). Jacobian [[0, 1], [1 - 3x^2, -delta]]:
    # at 0, lambda^2 + delta lambda - 1 = 0 (a saddle); at +-1, lambda^2 + delta lambda + 2 = 0,
    # lambda = (-delta +- i sqrt(8 - delta^2))/2 (a sink).
    cfg = validate_config({"systems": copy.deepcopy(SYSTEMS)})
    path = run_equilibria(**parameters_from_config(cfg, "equilibria", "unforced"), output=tmp_path / "eq.nc")
    data = open_stage_file(path, stage="flow_equilibria")
    np.testing.assert_allclose(data.position.values, [[-1.0, 0.0], [0.0, 0.0], [1.0, 0.0]], atol=1e-12)
    assert list(data.type.values) == ["sink", "saddle", "sink"]
    delta = 0.25
    saddle = [(-delta + math.sqrt(delta**2 + 4)) / 2, (-delta - math.sqrt(delta**2 + 4)) / 2]
    np.testing.assert_allclose(data.eigenvalue_real.values[1], saddle, rtol=1e-12)
    np.testing.assert_allclose(data.eigenvalue_real.values[0], [-delta / 2] * 2, rtol=1e-12)
    np.testing.assert_allclose(data.eigenvalue_imag.values[0], [math.sqrt(8 - delta**2) / 2, -math.sqrt(8 - delta**2) / 2],
                               rtol=1e-12)
    assert list(data.unstable_dimension.values) == [0, 1, 0]


def test_equilibria_of_a_time_dependent_field_are_refused(tmp_path):
    cfg = validate_config({"systems": copy.deepcopy(SYSTEMS)})
    with pytest.raises(ConfigError, match=r"'systems.duffing': system 'duffing' is a time-dependent vector field"):
        run_equilibria(**parameters_from_config(cfg, "equilibria", "duffing"), output=tmp_path / "eq.nc")


def test_the_documented_example_is_a_valid_configuration():
    # The documented vector_field example validates as written, and its map resolves.
    cfg = validate_config(yaml.safe_load(documented_yaml("forced_duffing_t0")))
    assert cfg["ld_maps"]["forced_duffing_t0"]["t0"] == 1.5
    system, section, settings, info = resolve_ld_map(parameters_from_config(cfg, "ld", "forced_duffing_t0"), None, None)
    assert system.time_dependent and section.solve is None and info["energy"] is None and info["t0"] == 1.5


def test_the_documented_exact_gradient_ftle_example_is_a_valid_configuration():
    # The documented `ftle: variational` example validates as written, and its map resolves.
    cfg = validate_config(yaml.safe_load(documented_yaml("double_gyre_ftle_exact")))
    assert cfg["ld_maps"]["double_gyre_ftle_exact"]["ftle"] == "variational"
    system, section, settings, info = resolve_ld_map(parameters_from_config(cfg, "ld", "double_gyre_ftle_exact"), None, None)
    assert system.time_dependent and section.solve is None


def test_poincare_section_of_a_vector_field_closed_form(tmp_path):
    # The oscillator x' = y, y' = -x as a vector field: x = r cos(t - phi), y = -r sin(t - phi) from
    # (r cos phi, r sin phi) (closed form). y crosses 0 decreasing where x = r > 0, at the times
    # t = phi + 2 pi k from the start (phi in (0, 2 pi)), whatever t0 (the field is autonomous).
    cfg = validate_config({
        "systems": {"osc": {"vector_field": {"x": "y", "y": "-x"}, "coordinates": ["x", "y"]}},
        "poincare_sections": {"p": {
            "system": "osc", "t0": 0.7, "time": 20.0, "max_crossings": 10,
            "initial_conditions": {"axes": [{"name": "x", "range": [0.2, 0.6], "points": 3},
                                            {"name": "y", "range": [-0.4, 0.4], "points": 3}]},
            "section": {"coordinate": "y", "value": 0.0, "direction": -1},
        }},
    })
    path = run_poincare(**parameters_from_config(cfg, "poincare", "p"), equilibria=None, output=tmp_path / "p.nc")
    data = open_stage_file(path, stage="poincare")
    assert data.attrs["t0"] == 0.7 and "energy" not in data.attrs
    for start, crossings, times, count in zip(data.initial_state.values, data.crossing_state.values,
                                              data.crossing_time.values, data.crossing_count.values):
        r, phi = np.hypot(*start), math.atan2(start[1], start[0]) % (2 * math.pi)
        expected = phi + 2 * math.pi * np.arange(10)
        expected = expected[(expected > 0) & (expected <= 20.0)]
        assert count == len(expected)
        np.testing.assert_allclose(times[:count], expected, rtol=1e-9)
        np.testing.assert_allclose(crossings[:count], [[r, 0.0]] * count, atol=1e-9)


def test_forced_duffing_crossings_against_scipy():
    # Crossings of y = 0 (decreasing: turning points at a maximum of x) by the forced Duffing oscillator from t0 = 1.3, against
    # scipy's DOP853 at rtol 1e-13 with an event (an independent integrator and root finder).
    system = make_system("duffing", SYSTEMS["duffing"])
    p = SYSTEMS["duffing"]["parameters"]
    start, t0, duration = np.array([0.5, -0.6]), 1.3, 25.0

    def field(t, s):
        return [s[1], s[0] - s[0] ** 3 - p["delta"] * s[1] + p["F"] * math.cos(p["omega"] * t)]

    event = lambda t, s: s[1]  # noqa: E731
    event.direction = -1
    reference = solve_ivp(field, (t0, t0 + duration), start, method="DOP853", rtol=1e-13, atol=1e-13, events=event)
    result = integrate(system, start[None, :], duration, FlowSettings(rtol=1e-12, atol=1e-12),
                       section=("y", 0.0, -1), max_crossings=50, t0=t0)
    count = result.crossing_count[0]
    assert count == len(reference.t_events[0]) > 2
    np.testing.assert_allclose(result.crossing_times[0, :count], reference.t_events[0] - t0, rtol=1e-9)
    np.testing.assert_allclose(result.crossings[0, :count], reference.y_events[0], atol=1e-9)
