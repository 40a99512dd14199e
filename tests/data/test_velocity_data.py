"""Velocity-data systems against what is known exactly, never against themselves.

- A field the interpolant reproduces exactly (degree <= 2 in x, y and t: cubic convolution with
  Keys' boundary rule is exact for those) gives the formula system's LD and end states to the
  integrator's tolerance.
- The double gyre (Shadden et al. 2005, support.double_gyre) sampled on finer and finer grids:
  the velocity error and the LD error against the formula system fall at the interpolant's order
  (3), measured as the least-squares slope over the grids.
- Solid-body rotation on the sphere about the axis through (lon 0, lat 0): trajectories are
  circles, the start point rotated by omega t (closed form), with the data in m/s and time in days.
- Land and the data's edge by construction: a uniform flow towards a coast (or an edge) stops
  at the last water cell (the edge), after the closed-form time, and is flagged.
- Bad data: each error names the variable and what was expected.
"""

import math

import numpy as np
import pytest

from ldpipe.config import validate_config
from ldpipe.engine import LDSettings, compute_ld
from ldpipe.errors import ConfigError
from ldpipe.core.maps.assembly import compute_ld_map
from ldpipe.config.parameters import parameters_from_config
from ldpipe.systems import make_system
from support.bickley_jet import BICKLEY_JET, bickley_velocity
from support.double_gyre import sampled_gyre_errors
from support.gridded import assert_quadratic_field_ld, quadratic_field, sampled_flow_errors, write_velocity_file
from support.tick_labels import assert_readable_tick_labels

TIGHT = dict(rtol=1e-11, atol=1e-11)


def data_system(path, name="data", **entry):
    return make_system(name, {"velocity_data": {"path": str(path), **entry}})


def test_quadratic_field_gives_the_formula_ld(tmp_path):
    # degree <= 2 in each variable, so the interpolant is the field itself and the LD is the formula
    # system's (to the integrator's tolerance)
    path = write_velocity_file(tmp_path / "q.nc", quadratic_field, np.linspace(-4, 4, 9), np.linspace(-3, 3, 7),
                               np.linspace(0, 6, 7))
    assert_quadratic_field_ld(data_system(path))


def _slope(spacings, errors):
    return np.polyfit(np.log(spacings), np.log(errors), 1)[0]


def test_double_gyre_converges_at_the_interpolants_order(tmp_path):
    counts = (8, 16, 32)
    # space and time steps alike, h = 1/n; times 1.5 .. 7.5 cover [t0, t0 + tau] and a stencil more
    grids = [(np.linspace(0, 2, 2 * n + 1), np.linspace(0, 1, n + 1), 1.5 + (1.0 / n) * np.arange(6 * n + 1))
             for n in counts]
    ld_errors, velocity_errors = sampled_gyre_errors(tmp_path, grids, probes=200)
    spacings = [1.0 / n for n in counts]
    # cubic convolution is third order; measured slopes: velocity 3.18 (errors 2.7e-3 .. 3.3e-5),
    # LD 2.89 (4.9e-3 .. 8.9e-5)
    assert 2.7 < _slope(spacings, velocity_errors) < 3.5, velocity_errors
    assert 2.5 < _slope(spacings, ld_errors) < 3.5, ld_errors


def test_bickley_jet_converges_at_the_interpolants_order(tmp_path):
    # Rypina et al.'s perturbed Bickley jet (support.bickley_jet) sampled with spacing h = 1/n in x,
    # y and t, against the formula system. Cubic convolution is third order: measured velocity
    # slope 3.09 (errors 1.0e-2, 1.1e-3, 1.4e-4); the LD's 3.85 (1.1e-2, 6.0e-4, 5.4e-5; local
    # slopes 4.2 then 3.5, still above the interpolant's order at these spacings).
    counts = (4, 8, 16)
    grids = [(np.linspace(0, 6, 6 * n + 1), np.linspace(-4, 4, 8 * n + 1), 1.5 + np.arange(3 * n + 1) / n)
             for n in counts]
    starts = np.column_stack([a.ravel() for a in np.meshgrid(np.linspace(1.5, 2.5, 5), np.linspace(-1.5, 1.5, 7))])
    ld_errors, velocity_errors = sampled_flow_errors(
        tmp_path, grids, 200, formula=BICKLEY_JET, velocity=bickley_velocity, starts=starts, t0=2.0, tau=2.0,
        probe_box=((0.5, 5.5), (-3.5, 3.5), (2.0, 4.0)))
    spacings = [1.0 / n for n in counts]
    assert 2.7 < _slope(spacings, velocity_errors) < 3.5, velocity_errors
    assert 2.7 < _slope(spacings, ld_errors) < 4.5, ld_errors


def test_solid_body_rotation_on_the_sphere(tmp_path):
    # rotation by omega about the axis through (lon 0, lat 0): u = -omega R sin(lat) cos(lon),
    # v = omega R sin(lon) in m/s; the closed form is the start point's unit vector rotated by
    # omega t about x. Time in days (scale 86400 s), radius 6371 km.
    radius, omega = 6.371e6, 2 * math.pi / (20 * 86400.0)  # a turn in 20 days

    def field(lon, lat, t):
        lam, phi = np.radians(lon), np.radians(lat)
        return -omega * radius * np.sin(phi) * np.cos(lam), omega * radius * np.sin(lam) + 0 * t
    path = write_velocity_file(tmp_path / "rot.nc", field, np.arange(-60.0, 60.01, 1.0), np.arange(-50.0, 50.01, 1.0),
                               np.arange(0.0, 6.01, 1.0), names=("lon", "lat"), time_units="days since 2000-01-01")
    data = data_system(path, coordinates="sphere")
    assert data.coordinates == ("lon", "lat")
    starts = np.array([[10.0, 5.0], [-20.0, 30.0], [35.0, -15.0]])
    days = 4.0
    result = compute_ld(data, starts, 1, LDSettings(tau=days, p=0.5, **TIGHT), t0=1.0)
    angle = omega * days * 86400.0
    lam, phi = np.radians(starts[:, 0]), np.radians(starts[:, 1])
    r = np.array([np.cos(phi) * np.cos(lam), np.cos(phi) * np.sin(lam), np.sin(phi)])
    rotated = np.array([r[0], math.cos(angle) * r[1] - math.sin(angle) * r[2], math.sin(angle) * r[1] + math.cos(angle) * r[2]])
    expected = np.column_stack([np.degrees(np.arctan2(rotated[1], rotated[0])), np.degrees(np.arcsin(rotated[2]))])
    # measured: 7.8e-7 degrees (the interpolation of the trigonometric field on a 1 degree grid)
    np.testing.assert_allclose(result.end_state, expected, rtol=0, atol=5e-6)
    # A rotation is an isometry of the sphere: the FTLE is 0 (closed form), in great-circle lengths
    # (in plain degrees the map stretches longitudes by cos(lat0)/cos(lat): an FTLE of 0.063 a day here).
    config = validate_config({"systems": {"rot": {"velocity_data": {"path": str(path), "coordinates": "sphere"}}},
                              "ld_maps": {"r": {"system": "rot", "t0": 3.0, "tau": 2.5, "p": 0.5, "ftle": True,
                                                "integrator": {"rtol": 1e-10, "atol": 1e-10},
                                                "section": {"axes": [{"name": "lon", "range": [-20.0, 20.0], "points": 21},
                                                                     {"name": "lat", "range": [-30.0, 30.0], "points": 31}]}}}})
    rotation_map = compute_ld_map(parameters_from_config(config, "ld", "r"), None, show_progress=False)
    for label in ("forward", "backward"):
        assert rotation_map[f"ftle_defined_{label}"].values.all()
        # measured: 1.3e-4 per day (the differences' second-order error on the 2-degree grid)
        assert np.max(np.abs(rotation_map[f"ftle_{label}"].values)) < 5e-4, label


def test_longitudes_across_the_dateline(tmp_path):
    # Data on 150..210 E (0..360 convention) across the dateline; starts given as -175 (= 185) and
    # 170: the same solid-body rotation about the axis through (lon 0, lat 0) as above, whose
    # closed form does not care how a longitude is written (compared modulo 360).
    radius, omega = 6.371e6, 2 * math.pi / (20 * 86400.0)

    def field(lon, lat, t):
        lam, phi = np.radians(lon), np.radians(lat)
        return -omega * radius * np.sin(phi) * np.cos(lam), omega * radius * np.sin(lam) + 0 * t
    path = write_velocity_file(tmp_path / "dateline.nc", field, np.arange(150.0, 210.01, 1.0),
                               np.arange(-40.0, 40.01, 1.0), np.arange(0.0, 4.01, 1.0), names=("lon", "lat"),
                               time_units="days since 2000-01-01")
    data = data_system(path, name="dateline", coordinates="sphere")
    starts = np.array([[-175.0, 10.0], [170.0, -20.0], [185.0, 10.0]])
    result = compute_ld(data, starts, 1, LDSettings(tau=2.0, p=0.5, **TIGHT), t0=1.0)
    angle = omega * 2.0 * 86400.0
    lam, phi = np.radians(starts[:, 0]), np.radians(starts[:, 1])
    r = np.array([np.cos(phi) * np.cos(lam), np.cos(phi) * np.sin(lam), np.sin(phi)])
    rotated = np.array([r[0], math.cos(angle) * r[1] - math.sin(angle) * r[2], math.sin(angle) * r[1] + math.cos(angle) * r[2]])
    lon = np.degrees(np.arctan2(rotated[1], rotated[0]))
    wrapped = (result.end_state[:, 0] - lon + 180.0) % 360.0 - 180.0
    # measured: 5e-7 degrees (interpolation on the 1 degree grid), as the rotation test above
    np.testing.assert_allclose(wrapped, 0.0, atol=5e-6)
    np.testing.assert_allclose(result.end_state[:, 1], np.degrees(np.arcsin(rotated[2])), rtol=0, atol=5e-6)
    # -175 and 185: one point (the step control scales with |lon|: measured 3e-10 apart)
    np.testing.assert_allclose(result.ld[0], result.ld[2], rtol=2e-9)
    assert not data.stop_flags(result.end_state, 1.0, 3.0)["left_data"].any()


def test_land_and_edge_stop_trajectories(tmp_path):
    # u = 1 m/s eastward everywhere, land for x >= 6 (a north-south coast): the cell [5, 6] has a land
    # node, so a trajectory from x0 stops at x = 5 after 5 - x0 seconds; with v = 1 northward instead it
    # reaches the top edge y = 4 after 4 - y0 seconds (closed forms). M_0.5 = time * (1 m/s)^0.5, and
    # the exit time is the time it stopped, with the LD and without it (ld: false).
    x, y, t = np.arange(0.0, 10.01, 1.0), np.arange(0.0, 4.01, 1.0), np.arange(0.0, 20.01, 1.0)
    coast = write_velocity_file(tmp_path / "coast.nc", lambda X, Y, T: (1.0 + 0 * X, 0 * Y), x, y, t,
                                land=lambda X, Y: X >= 6)
    north = write_velocity_file(tmp_path / "north.nc", lambda X, Y, T: (0 * X, 1.0 + 0 * Y), x, y, t)
    base = {"section": {"axes": [{"name": "x", "range": [1.0, 3.0], "points": 3},
                                 {"name": "y", "range": [0.5, 2.5], "points": 3}]},
            "t0": 8.0, "tau": 8.0, "p": 0.5, "integrator": {"rtol": 1e-10, "atol": 1e-10}}
    config = validate_config({"systems": {"coast": {"velocity_data": {"path": str(coast)}},
                                          "north": {"velocity_data": {"path": str(north)}}},
                              "ld_maps": {"c": {**base, "system": "coast"}, "n": {**base, "system": "north"},
                                          "f": {**base, "system": "north", "ftle": True, "ld": False}}})
    coast_map = compute_ld_map(parameters_from_config(config, "ld", "c"), None, show_progress=False)
    x0 = coast_map.x.values[:, None] + 0 * coast_map.y.values
    assert coast_map.on_land_forward.values.all() and not coast_map.left_data_forward.values.any()
    np.testing.assert_allclose(coast_map.ld_forward.values, 5.0 - x0, rtol=5e-7)  # measured 7e-8 (the step across the coast)
    # the exit time is where the trajectory stopped: measured 3.4e-8 at the coast, 9e-9 at the edges;
    # backward the flow comes from the west edge x = 0, reached after x0 seconds
    np.testing.assert_allclose(coast_map.exit_time_forward.values, 5.0 - x0, rtol=2e-7)
    np.testing.assert_allclose(coast_map.exit_time_backward.values, x0, rtol=2e-7)
    north_map = compute_ld_map(parameters_from_config(config, "ld", "n"), None, show_progress=False)
    y0 = 0 * north_map.x.values[:, None] + north_map.y.values
    assert north_map.left_data_forward.values.all() and not north_map.on_land_forward.values.any()
    np.testing.assert_allclose(north_map.ld_forward.values, 4.0 - y0, rtol=5e-7)
    # backward: from y0 down to the edge y = 0 after y0 seconds
    np.testing.assert_allclose(north_map.ld_backward.values, y0, rtol=5e-7)
    assert not north_map.failed_forward.values.any()
    flow_map = compute_ld_map(parameters_from_config(config, "ld", "f"), None, show_progress=False)  # without the LD
    for stopped in (north_map, flow_map):
        assert stopped.left_data_forward.values.all() and stopped.left_data_backward.values.all()
        np.testing.assert_allclose(stopped.exit_time_forward.values, 4.0 - y0, rtol=2e-7)
        np.testing.assert_allclose(stopped.exit_time_backward.values, y0, rtol=2e-7)
    # the same coast as a land-sea mask variable (0 on land) over finite velocities: the same stops
    import xarray as xr
    with xr.open_dataset(north) as dataset:
        masked = dataset.load()
    masked = masked.assign(u=masked.u + 1.0, v=masked.v - 1.0)  # u = 1, v = 0 as on the coast file
    masked["u"].attrs["units"] = masked["v"].attrs["units"] = "m/s"
    masked["sea"] = (("y", "x"), (masked.x.values[None, :] < 6) * np.ones((len(y), 1)))
    masked.to_netcdf(tmp_path / "masked.nc")
    config = validate_config({"systems": {"masked": {"velocity_data": {"path": str(tmp_path / "masked.nc"), "mask": "sea"}}},
                              "ld_maps": {"c": {**base, "system": "masked"}}})
    masked_map = compute_ld_map(parameters_from_config(config, "ld", "c"), None, show_progress=False)
    assert masked_map.on_land_forward.values.all()
    np.testing.assert_allclose(masked_map.ld_forward.values, coast_map.ld_forward.values, rtol=1e-12)


def test_ld_ftle_figure_draws_ld_and_both_ftle(tmp_path):
    # the figure kind reads a map file with ftle: three panels (LD, FTLE forward, backward) and their
    # colour bars; a map without FTLE is refused naming the key
    from ldpipe.io.datafile import write_stage_file
    from ldpipe.stages.figures import draw_figure

    path = write_velocity_file(tmp_path / "shear.nc", lambda X, Y, T: (0.1 * Y + 0 * T, 0.05 + 0 * X),
                               np.linspace(0, 4, 5), np.linspace(0, 4, 5), np.linspace(0, 4, 5))
    spec = {"system": "shear", "t0": 2.0, "tau": 1.0, "p": 0.5, "ftle": True,
            "section": {"axes": [{"name": "x", "range": [1.0, 3.0], "points": 5},
                                 {"name": "y", "range": [1.0, 3.0], "points": 5}]}}
    config = validate_config({"systems": {"shear": {"velocity_data": {"path": str(path)}}}, "ld_maps": {"s": spec},
                              "figures": {"f": {"kind": "ld_ftle", "ld_maps": ["s"]}}})
    parameters = parameters_from_config(config, "ld", "s")
    dataset = compute_ld_map(parameters, None, show_progress=False)
    # the shear's flow map over T = 1 is (x + 0.1 y, y + 0.05): C = [[1, 0.1], [0.1, 1.01]] (closed form)
    expected = math.log((2.01 + math.sqrt(0.01**2 + 4 * 0.01)) / 2) / 2
    for label in ("forward", "backward"):
        assert dataset[f"ftle_defined_{label}"].values.all()
        np.testing.assert_allclose(dataset[f"ftle_{label}"].values, expected, rtol=1e-12)  # measured 5e-14
    written = write_stage_file(dataset, tmp_path / "s.nc", stage="ld_grid", title="s", parameters=parameters)
    settings = parameters_from_config(config, "figures", "f")["settings"]
    figure = draw_figure("ld_ftle", settings, {"ld_maps": [str(written)]})
    assert len(figure.axes) == 6  # three panels, three colour bars
    assert_readable_tick_labels(figure, tmp_path)
    # the adaptive refinement knows the fates of region exits and escapes, not land or the data's edge
    with pytest.raises(ConfigError, match=r"ld_maps\.s\.refine': .*velocity-data map"):
        validate_config({"systems": {"shear": {"velocity_data": {"path": str(path)}}},
                         "ld_maps": {"s": {**{k: v for k, v in spec.items() if k != "ftle"},
                                           "refine": {"tolerance": 0.01, "coarse_spacing": 2}}}})
    with pytest.raises(ConfigError, match=r"ld_maps\.s\.ftle"):
        validate_config({"systems": {"shear": {"velocity_data": {"path": str(path)}}},
                         "ld_maps": {"s": {k: v for k, v in spec.items() if k != "ftle"}},
                         "figures": {"f": {"kind": "ld_ftle", "ld_maps": ["s"]}}})


def test_coordinates_in_metres_are_not_escapes(tmp_path):
    # a grid in metres (|x| up to 2e5, far beyond the default escape radius 100): u = 0.5 m/s for an
    # hour moves a point 1800 m (closed form), flagged neither escaped nor stopped
    path = write_velocity_file(tmp_path / "metres.nc", lambda X, Y, T: (0.5 + 0 * X, 0 * Y), np.linspace(0, 2e5, 21),
                               np.linspace(-1e5, 1e5, 21), np.linspace(0, 7200, 5), time_units="seconds since 2000-01-01")
    data = data_system(path, name="metres")
    result = compute_ld(data, np.array([[1e5, 5e4]]), 1, LDSettings(tau=3600.0, p=0.5, **TIGHT), t0=1800.0)
    assert not result.escaped.any() and result.time[0] == 3600.0
    np.testing.assert_allclose(result.end_state, [[1e5 + 1800.0, 5e4]], rtol=1e-12)


def _write(tmp_path, name, **changes):
    x, y, t = np.arange(5.0), np.arange(4.0), np.arange(3.0)
    kwargs = {"units": "m/s"} | changes
    return write_velocity_file(tmp_path / f"{name}.nc", lambda X, Y, T: (X + 0 * T, Y + 0 * T), x, y, t, **kwargs)


def test_bad_data_errors_name_the_variable(tmp_path):
    good = _write(tmp_path, "good")
    with pytest.raises(ConfigError, match=r"velocity_data\.u': variable 'speed_u' not in .*good\.nc"):
        data_system(good, u="speed_u")
    with pytest.raises(ConfigError, match=r"velocity_data\.u': variable 'u' has no 'units'"):
        data_system(_write(tmp_path, "no_units", units=None))
    with pytest.raises(ConfigError, match=r"velocity_data\.u': velocity units 'furlongs' not understood"):
        data_system(_write(tmp_path, "furlongs", units="furlongs"))
    import xarray as xr
    with xr.open_dataset(good) as dataset:
        shuffled = dataset.load().assign_coords(x=[0.0, 2.0, 1.0, 3.0, 4.0])
    shuffled.to_netcdf(tmp_path / "unsorted.nc")
    with pytest.raises(ConfigError, match=r"velocity_data\.x': coordinate 'x' is not monotonic"):
        data_system(tmp_path / "unsorted.nc")
    data = data_system(good)
    with pytest.raises(ConfigError, match=r"times \[1, 3\], outside the time range \[0, 2\] of .* \(variable 'time'\)"):
        data.check_times(1.0, 3.0)


def test_a_coast_with_a_corner_stops_trajectories_at_its_first_land_cell(tmp_path):
    # u = 1 m/s eastward, land an L: the column x >= 8 and the arm x >= 6, y >= 6, whose corner
    # node (6, 6) is the only land node of the water cell [5, 6] x [5, 6] (a diagonal corner: a
    # straight coast never has one). Closed forms: a trajectory below the arm (y0 < 5) stops at
    # x = 7, before the column; one whose row of cells touches the corner or the arm (y0 > 5) at
    # x = 5; each after (stop - x0) seconds, flagged on land, never past its line (no trajectory
    # enters a land cell); backward every one reaches the west edge x = 0 after x0 seconds.
    x, y, t = np.arange(0.0, 10.01, 1.0), np.arange(0.0, 10.01, 1.0), np.arange(0.0, 20.01, 1.0)
    coast = write_velocity_file(tmp_path / "corner.nc", lambda X, Y, T: (1.0 + 0 * X, 0 * Y), x, y, t,
                                land=lambda X, Y: (X >= 8) | ((X >= 6) & (Y >= 6)))
    entry = {"system": "corner", "t0": 10.0, "tau": 8.0, "p": 0.5, "ftle": True,
             "integrator": {"rtol": 1e-10, "atol": 1e-10},
             "section": {"axes": [{"name": "x", "range": [1.0, 3.0], "points": 3},
                                  {"name": "y", "range": [2.5, 6.5], "points": 5}]}}
    config = validate_config({"systems": {"corner": {"velocity_data": {"path": str(coast)}}},
                              "ld_maps": {"c": entry}})
    dataset = compute_ld_map(parameters_from_config(config, "ld", "c"), None, show_progress=False)
    x0 = dataset.x.values[:, None] + 0 * dataset.y.values
    stop = np.where(dataset.y.values > 5, 5.0, 7.0) + 0 * x0
    assert dataset.on_land_forward.values.all() and not dataset.left_data_forward.values.any()
    # measured: 3.6e-8 relative (the step across the cell's edge); end points 1.4e-8 past their line
    np.testing.assert_allclose(dataset.exit_time_forward.values, stop - x0, rtol=2e-7)
    np.testing.assert_allclose(dataset.ld_forward.values, stop - x0, rtol=2e-7)
    assert np.all(dataset.end_x_forward.values <= stop + 1e-7)  # at its line, not in the land cell
    np.testing.assert_allclose(dataset.end_y_forward.values, 0 * x0 + dataset.y.values, rtol=0, atol=1e-12)
    assert dataset.left_data_backward.values.all() and not dataset.on_land_backward.values.any()
    np.testing.assert_allclose(dataset.exit_time_backward.values, x0, rtol=5e-8)  # measured 6e-9
