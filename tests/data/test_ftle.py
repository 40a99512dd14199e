"""FTLE of fixed-time maps against closed forms and an independent scipy flow map.

- The linear saddle x' = lam x, y' = -lam y: its flow map is linear, F = diag(e^(lam T), e^(-lam T))
  (closed form), so differences over any grid are exact and the FTLE is lam forward and backward.
- The double gyre of Shadden, Lekien & Marsden (2005): at a few grid points the FTLE from scipy's
  DOP853 (rtol 1e-12) flow map, differenced over the same neighbours and its Cauchy-Green
  eigenvalue from numpy.linalg.eigvalsh (no ldpipe code).
"""

import copy
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from ldpipe.config import validate_config
from ldpipe.errors import ConfigError
from ldpipe.core.maps.ftle import flow_map_gradient, ftle
from ldpipe.io.datafile import open_stage_file
from ldpipe.core.maps.assembly import compute_ld_map
from ldpipe.stages.ld import run_ld_gather, run_ld_tile
from ldpipe.config.parameters import parameters_from_config
from support.double_gyre import DOUBLE_GYRE, double_gyre_field

LAM = 0.8  # the linear saddle of tests/engine/test_vector_field.py (same kernel: its engine is compiled once)
SYSTEMS = {
    "linear_saddle": {"vector_field": {"x": "lam*x", "y": "-lam*y"}, "coordinates": ["x", "y"],
                      "parameters": {"lam": LAM}},
    "double_gyre": DOUBLE_GYRE,
}
SADDLE_MAP = {
    "system": "linear_saddle",
    "section": {"axes": [{"name": "x", "range": [-0.5, 0.5], "points": 7}, {"name": "y", "range": [-0.4, 0.6], "points": 6}]},
    "tau": 2.5, "p": 0.5, "integrator": {"rtol": 1e-12, "atol": 1e-12}, "ftle": True,
}


def config(name: str, spec: dict):
    return validate_config({"systems": copy.deepcopy(SYSTEMS), "ld_maps": {name: copy.deepcopy(spec)}})


def tiled_and_gathered(tmp_path, spec: dict):
    """The map ``spec`` (two tiles) computed tile by tile and gathered, as the workflow does."""
    parameters = parameters_from_config(config("m", spec), "ld", "m")
    tiles = [run_ld_tile(output=tmp_path / f"t{k}.nc", equilibria=None, tile=k, tiles=2, show_progress=False, **parameters)
             for k in range(2)]
    return open_stage_file(run_ld_gather(tiles=tiles, output=tmp_path / "m.nc"), stage="ld_grid")


def test_linear_saddle_ftle_is_its_eigenvalue(tmp_path):
    # closed form: FTLE = ln(e^(2 lam T)) / (2 T) = lam, both directions, every grid point (edges too:
    # the one-sided differences are exact on a linear map). Tiled and gathered: the same.
    dataset = tiled_and_gathered(tmp_path, {**SADDLE_MAP, "tiles": 2})
    for label in ("forward", "backward"):
        assert dataset[f"ftle_defined_{label}"].values.all()
        # measured relative error 3.2e-13 (the integrator's rtol 1e-12)
        np.testing.assert_allclose(dataset[f"ftle_{label}"].values, LAM, rtol=2e-12, err_msg=label)
        assert dataset[f"ftle_{label}"].attrs["units"] == "1/time"  # formulas name no unit of time
    # the flow map is kept: x e^(lam T) forward (closed form)
    x = dataset.x.values[:, None]
    np.testing.assert_allclose(dataset.end_x_forward.values, x * math.exp(LAM * 2.5) + 0 * dataset.y.values, rtol=1e-11)
    whole = compute_ld_map(parameters_from_config(config("m", SADDLE_MAP), "ld", "m"), None, show_progress=False)
    np.testing.assert_array_equal(whole.ftle_forward.values, dataset.ftle_forward.values)


def test_map_without_ftle_has_no_flow_map():
    spec = {k: v for k, v in SADDLE_MAP.items() if k != "ftle"}
    dataset = compute_ld_map(parameters_from_config(config("m", spec), "ld", "m"), None, show_progress=False)
    assert not any(name.startswith(("ftle", "end_")) for name in dataset.data_vars)


def test_ftle_needs_a_fixed_time_map():
    spec = {**SADDLE_MAP, "time": "variable", "region": {"x": [-1, 1], "y": [-1, 1]}}
    with pytest.raises(ConfigError, match=r"ld_maps\.m\.ftle"):
        config("m", spec)


def test_ftle_map_is_never_adaptive():
    # an adaptive map interpolates the pixels it does not integrate, and the FTLE differences the end
    # states of neighbouring pixels: the two together would difference interpolated states
    spec = {**SADDLE_MAP, "refine": {"tolerance": 0.01, "coarse_spacing": 2}}
    with pytest.raises(ConfigError, match=r"ld_maps\.m\.ftle': .*refine: null"):
        config("m", spec)
    config("m", {**SADDLE_MAP, "refine": None})


def _scipy_ftle(x, y, hx, hy, t0, tau, direction):
    """Central differences of scipy's flow map over the four neighbours, then eigvalsh of C."""
    def end(a, b):
        sol = solve_ivp(double_gyre_field, (t0, t0 + direction * tau), [a, b], method="DOP853", rtol=1e-12, atol=1e-12)
        return sol.y[:, -1]
    j = np.column_stack([(end(x + hx, y) - end(x - hx, y)) / (2 * hx), (end(x, y + hy) - end(x, y - hy)) / (2 * hy)])
    return math.log(np.linalg.eigvalsh(j.T @ j)[-1]) / (2 * tau)


def test_double_gyre_ftle_matches_scipy_flow_map():
    spec = {"system": "double_gyre", "t0": 0.0,
            "section": {"axes": [{"name": "x", "range": [0.0, 2.0], "points": 21},
                                 {"name": "y", "range": [0.0, 1.0], "points": 11}]},
            "tau": 10.0, "p": 0.5, "integrator": {"rtol": 1e-12, "atol": 1e-12}, "ftle": True}
    dataset = compute_ld_map(parameters_from_config(config("g", spec), "ld", "g"), None, show_progress=False)
    hx, hy = 0.1, 0.1
    for i, k in ((5, 5), (10, 3), (14, 7)):
        x, y = float(dataset.x[i]), float(dataset.y[k])
        for label, direction in (("forward", 1), ("backward", -1)):
            expected = _scipy_ftle(x, y, hx, hy, 0.0, 10.0, direction)
            assert dataset[f"ftle_defined_{label}"].values[i, k]
            # measured agreement 1.4e-13 (both integrators at rtol 1e-12)
            assert dataset[f"ftle_{label}"].values[i, k] == pytest.approx(expected, abs=1e-12), (label, i, k)


def test_undefined_where_no_difference_reads_only_complete_points():
    # A point is differenced along an axis centred over its two neighbours, or one-sided over the
    # next three points on one side, each of which ran the whole time. On a 5 x 5 grid whose
    # centre stopped, the centre's row and column have neither (the centre is in every stencil):
    complete = np.ones((5, 5), dtype=bool)
    complete[2, 2] = False
    expected = np.ones((5, 5), dtype=bool)
    expected[2, :] = expected[:, 2] = False
    values, defined = ftle(np.zeros((5, 5, 2)), (np.arange(5.0), np.arange(5.0)), 1.0, complete)
    np.testing.assert_array_equal(flow_map_gradient(np.zeros((5, 5, 2)), (np.arange(5.0),) * 2, complete)[1] & complete,
                                  expected)
    assert not defined.any() and np.all(np.isnan(values))  # a collapsed map has no positive stretching: undefined
    # on a 9 x 9 grid every other point has a stencil clear of the centre: its neighbours along
    # the axes one-sided away from it. The map x -> 2 x, y -> y / 2 is linear, so every
    # stencil is exact: the FTLE is ln 2 / T (closed form) at all of them.
    complete = np.ones((9, 9), dtype=bool)
    complete[4, 4] = False
    axis = np.linspace(-1.0, 1.0, 9)
    a, b = np.meshgrid(axis, axis, indexing="ij")
    ends = np.stack([2.0 * a, 0.5 * b], axis=-1)
    ends[4, 4] = (50.0, -7.0)  # where the stopped trajectory ended: no stencil reads it
    values, defined = ftle(ends, (axis, axis), 1.0, complete)
    np.testing.assert_array_equal(defined, complete)
    np.testing.assert_allclose(values[defined], math.log(2.0), rtol=1e-13)


def test_grid_ftle_converges_to_the_variational_ftle():
    # The exact gradient (variational equations along each trajectory, scipy) is what the grid's
    # central differences approximate to second order in the spacing: their error must fall at slope 2.
    from ldpipe.engine import LDSettings, compute_ld
    from ldpipe.core.maps.ftle import variational_ftle
    from ldpipe.systems import make_system

    system = make_system("double_gyre", DOUBLE_GYRE)
    points = np.array([[0.5, 0.5], [1.0, 0.3], [1.4, 0.7]])
    tau, t0 = 10.0, 0.0
    exact = variational_ftle(system, points, (0, 1), t0, tau)
    spacings, errors = [0.02, 0.01, 0.005], []
    settings = LDSettings(tau=tau, p=0.5, rtol=1e-12, atol=1e-12)
    for h in spacings:
        offsets = np.array([(a, b) for a in (-h, 0.0, h) for b in (-h, 0.0, h)])
        stencils = (points[:, None, :] + offsets[None]).reshape(-1, 2)
        ends = compute_ld(system, stencils, 1, settings, t0=t0).end_state.reshape(len(points), 3, 3, 2)
        values = [ftle(end, (np.array([-h, 0.0, h]), np.array([-h, 0.0, h])), tau, np.ones((3, 3), bool))[0][1, 1]
                  for end in ends]
        errors.append(np.max(np.abs(np.array(values) - exact)))
    slope = np.polyfit(np.log(spacings), np.log(errors), 1)[0]
    # measured: errors 3.3e-3, 8.4e-4, 2.1e-4, slope 1.98
    assert 1.7 < slope < 2.3, errors


def test_variational_ftle_map_of_the_linear_saddle_is_its_eigenvalue(tmp_path):
    # closed form: the state transition matrix is diag(e^(lam T), e^(-lam T)) at every point, so the
    # exact-gradient FTLE is lam forward and backward. Tiled and gathered: each tile its own points.
    dataset = tiled_and_gathered(tmp_path, {**SADDLE_MAP, "ftle": "variational", "tiles": 2})
    for label in ("forward", "backward"):
        assert dataset[f"ftle_defined_{label}"].values.all()
        # measured relative error 1.9e-13 (scipy at the map's rtol 1e-12)
        np.testing.assert_allclose(dataset[f"ftle_{label}"].values, LAM, rtol=1e-12, err_msg=label)
        attributes = dataset[f"ftle_{label}"].attrs
        assert (attributes["method"], attributes["rtol"], attributes["atol"]) == ("variational", 1e-12, 1e-12)
        assert attributes["units"] == "1/time"


def test_variational_ftle_map_is_variational_ftle_at_its_points():
    # identity of the plumbing: the map's values are ldpipe.core.maps.ftle.variational_ftle at its grid points
    # (axes in the map's order, start time t0, forward +tau and backward -tau), bit for bit; that
    # function is checked against the grid's differences (second-order convergence) above.
    from ldpipe.core.maps.ftle import variational_ftle
    from ldpipe.systems import make_system

    spec = {"system": "double_gyre", "t0": 1.5,
            "section": {"axes": [{"name": "y", "range": [0.2, 0.8], "points": 3},
                                 {"name": "x", "range": [0.3, 1.7], "points": 4}]},
            "tau": 5.0, "p": 0.5, "integrator": {"rtol": 1e-9, "atol": 1e-9}, "ftle": "variational"}
    dataset = compute_ld_map(parameters_from_config(config("g", spec), "ld", "g"), None, show_progress=False)
    system = make_system("double_gyre", DOUBLE_GYRE)
    y, x = np.meshgrid(dataset.y.values, dataset.x.values, indexing="ij")
    points = np.column_stack([x.ravel(), y.ravel()])
    for label, time in (("forward", 5.0), ("backward", -5.0)):
        assert dataset[f"ftle_defined_{label}"].values.all()
        expected = variational_ftle(system, points, (0, 1), 1.5, time, rtol=1e-9, atol=1e-9).reshape(x.shape)
        np.testing.assert_array_equal(dataset[f"ftle_{label}"].values, expected, err_msg=label)


def test_variational_ftle_needs_a_formula_vector_field(tmp_path):
    from support.double_gyre import double_gyre_velocity
    from support.gridded import write_velocity_file

    grid = np.linspace(0.0, 2.0, 5)
    path = write_velocity_file(tmp_path / "gyre.nc", double_gyre_velocity, grid, grid, grid)
    data_map = {**SADDLE_MAP, "system": "gyre", "ftle": "variational"}
    with pytest.raises(ConfigError, match=r"ld_maps\.m\.ftle': .*velocity data: give ftle: true"):
        validate_config({"systems": {"gyre": {"velocity_data": {"path": str(path)}}}, "ld_maps": {"m": data_map}})
    section = {"axes": [{"name": "x", "range": [-1.0, 1.0], "points": 5}, {"name": "px", "range": [-1.0, 1.0], "points": 5}],
               "fixed": {"y": 0.0}, "solve": "py"}
    hamiltonian_map = {"system": "b", "section": section, "energy": {"excess": 0.1}, "tau": 1.0, "p": 0.5,
                       "ftle": "variational"}
    with pytest.raises(ConfigError, match=r"ld_maps\.m\.ftle': .*Hamiltonian 'b'.*give ftle: true"):
        validate_config({"systems": {"b": {"builtin": "barbanis_2dof"}}, "ld_maps": {"m": hamiltonian_map}})


def test_differences_maps_converge_to_the_variational_map():
    # Two map options, one quantity: at the double gyre point (1.0, 0.3) the differences map's FTLE
    # (3 x 3 grids around it, spacing h) approaches the variational map's at second order in h.
    def centre(ftle_option, h):
        spec = {"system": "double_gyre", "t0": 0.0,
                "section": {"axes": [{"name": "x", "range": [1.0 - h, 1.0 + h], "points": 3},
                                     {"name": "y", "range": [0.3 - h, 0.3 + h], "points": 3}]},
                "tau": 10.0, "p": 0.5, "integrator": {"rtol": 1e-12, "atol": 1e-12}, "ftle": ftle_option}
        dataset = compute_ld_map(parameters_from_config(config("g", spec), "ld", "g"), None, show_progress=False)
        return np.array([dataset[f"ftle_{label}"].values[1, 1] for label in ("forward", "backward")])

    exact = centre("variational", 0.01)
    spacings = [0.02, 0.01, 0.005]
    errors = [np.max(np.abs(centre(True, h) - exact)) for h in spacings]
    slope = np.polyfit(np.log(spacings), np.log(errors), 1)[0]
    # measured: errors 6.8e-4, 1.7e-4, 4.2e-5, slope 2.00
    assert 1.7 < slope < 2.3, errors


def test_variational_ftle_takes_the_columns_of_the_section_axes():
    # Closed form: x' = lam x, y' = -lam y, z' = s x (z driven by x): the state transition matrix over
    # T has columns (e^(lam T), 0, s (e^(lam T) - 1) / lam) for x and (0, e^(-lam T), 0) for y, so
    # the FTLE of the section (x, y) is ln(e^(2 lam T) + (s (e^(lam T) - 1) / lam)^2) / (2 T). Its
    # rows for x and y hold no s at all: taking rows for columns (the same in 2 dimensions, and on a
    # diagonal flow) gives lam. Three states, the gradient off-diagonal, or the bug cannot show.
    from ldpipe.core.maps.ftle import variational_ftle
    from ldpipe.systems import make_system

    lam, s, time = 0.5, 2.0, 1.5
    system = make_system("sheared_saddle", {"vector_field": {"x": "lam*x", "y": "-lam*y", "z": "s*x"},
                                            "coordinates": ["x", "y", "z"], "parameters": {"lam": lam, "s": s}})
    points = np.array([[0.1, -0.2, 0.3], [-0.4, 0.5, 0.0]])
    growth = math.exp(lam * time)
    expected = math.log(growth**2 + (s * (growth - 1) / lam) ** 2) / (2 * time)
    values = variational_ftle(system, points, (0, 1), 0.0, time)
    # measured: relative error 6.4e-14 (scipy at the default rtol 1e-12)
    np.testing.assert_allclose(values, expected, rtol=3e-13)
    assert abs(expected - lam) > 0.3  # far from the rows' value
