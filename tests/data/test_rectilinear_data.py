"""Velocity data on rectilinear grids (unevenly spaced axes) and in 3-D, against closed forms.

- A field of degree <= 2 in each variable, which the non-uniform cubic reproduces exactly (the
  slopes of parabolas through three nodes are exact for quadratics), sampled on random uneven
  grids gives the formula system's LD and end states (2-D) or scipy's trajectory and M_1 (3-D,
  the independent reference of support.scipy_reference) to the integrator's tolerance.
- The double gyre (support.double_gyre) on refined uneven grids: the velocity and LD errors
  against the formula system fall at the interpolant's third order.
- The linear saddle with vertical stretching on uneven depth levels: its flow map is linear, so
  the FTLE is exactly its largest stretching rate in the section's plane (closed form).
- Solid-body rotation about the polar axis with a constant sinking on the sphere, on uneven
  latitudes and depths: lon0 + omega t, lat0, z0 + w t (closed form).
- The sea floor (missing values below a depth) and the surface stop a sinking or rising
  trajectory after the closed-form time, flagged on_land and left_data.
"""

import math

import numpy as np
import pytest
import xarray as xr

from ldpipe.config import validate_config
from ldpipe.engine import LDSettings, compute_ld
from ldpipe.errors import ConfigError
from ldpipe.core.maps.assembly import compute_ld_map
from ldpipe.config.parameters import parameters_from_config
from ldpipe.systems import VelocityDataSystem, make_system
from support.double_gyre import sampled_gyre_errors
from support.gridded import assert_quadratic_field_ld, quadratic_field, write_velocity_file, write_velocity_file_3d
from support.scipy_reference import flow_m1_and_arclength

TIGHT = dict(rtol=1e-11, atol=1e-11)


def data_system(path, name="data", **entry):
    return make_system(name, {"velocity_data": {"path": str(path), **entry}})


def uneven(low, high, count, rng, spread=0.6):
    """``count`` increasing nodes from ``low`` to ``high``, spacings random within 1 +- ``spread`` of each other."""
    steps = rng.uniform(1 - spread, 1 + spread, count - 1)
    return low + (high - low) * np.concatenate([[0.0], np.cumsum(steps)]) / steps.sum()


def test_uneven_quadratic_field_gives_the_formula_ld(tmp_path):
    # the field of tests/data/test_velocity_data.py (degree <= 2 in x, y, t), now on random uneven
    # x, y and t: reproduced exactly, so the LD is the formula system's (to the integrator's tolerance)
    rng = np.random.default_rng(7)
    path = write_velocity_file(tmp_path / "q.nc", quadratic_field, uneven(-4, 4, 9, rng), uneven(-3, 3, 7, rng),
                               uneven(0, 6, 7, rng))
    data = data_system(path)
    assert data.engine_name == "velocity_data_rectilinear2"
    assert_quadratic_field_ld(data)
    # a regular grid keeps the uniform kernel, within the uniformity tolerance (1e-6 of the spacing) too
    for name, jitter in (("regular", 0.0), ("nearly", 1e-9)):
        x = np.linspace(-4, 4, 9) + jitter * np.sin(np.arange(9.0))
        regular = data_system(write_velocity_file(tmp_path / f"{name}.nc", quadratic_field, x, np.linspace(-3, 3, 7),
                                                  np.linspace(0, 6, 7)))
        assert type(regular) is VelocityDataSystem and regular.engine_name == "velocity_data"


def warped(low, high, count):
    """Nodes x(s) = low + (high - low) (s - 0.08 sin(2 pi s)) at even s: a smooth grid whose
    spacings vary by a factor 3 (ocean depth levels, Mercator latitudes), refined by ``count``."""
    s = np.linspace(0.0, 1.0, count)
    return low + (high - low) * (s - 0.08 * np.sin(2 * np.pi * s))


def _slope(spacings, errors):
    return np.polyfit(np.log(spacings), np.log(errors), 1)[0]


def test_double_gyre_on_uneven_grids_converges_at_third_order(tmp_path):
    counts = (8, 16, 32)
    grids = [(warped(0, 2, 2 * n + 1), warped(0, 1, n + 1), warped(1.5, 7.5, 6 * n + 1)) for n in counts]
    ld_errors, velocity_errors = sampled_gyre_errors(tmp_path, grids, probes=100)
    spacings = [1.0 / n for n in counts]  # the mean spacing of every axis; the largest is 1.5 times it
    # third order (the Hermite cubic on parabolic slopes); measured slopes: velocity 3.15 (errors 1.7e-3 ..
    # 2.1e-5), LD 2.95 (1.3e-2 .. 2.1e-4)
    assert 2.7 < _slope(spacings, velocity_errors) < 3.5, velocity_errors
    assert 2.5 < _slope(spacings, ld_errors) < 3.5, ld_errors


def test_3d_quadratic_field_gives_scipys_trajectory(tmp_path):
    # u, v, w of degree <= 2 in each of x, y, z, t on uneven axes (depth levels 0 .. 100 m, z positive
    # down: dz/dt = -w): reproduced exactly, so the end states and M_1 are scipy's on the formulas
    def field(x, y, z, t):
        return (0.3 + 0.1 * y**2 - 0.05 * t * x + 0.002 * z, -0.2 * x + 0.02 * t**2 + 0.001 * y * z,
                -2.0 - 0.5 * x * t + 0.01 * z * y)
    rng = np.random.default_rng(3)
    path = write_velocity_file_3d(tmp_path / "q3.nc", field, uneven(-4, 4, 9, rng), uneven(-3, 3, 7, rng),
                                  uneven(0, 100, 8, rng), uneven(0, 6, 7, rng))
    data = data_system(path, name="q3", w="w")
    assert data.coordinates == ("x", "y", "z") and data.engine_name == "velocity_data_rectilinear3"

    def formulas(t, s):
        u, v, w = field(s[0], s[1], s[2], t)
        return np.array([u, v, -w])
    states = np.array([[0.0, 0.0, 40.0], [0.7, -1.1, 55.0], [-1.3, 0.9, 30.0]])
    for direction, t0 in ((1, 1.0), (-1, 4.5)):
        result = compute_ld(data, states, direction, LDSettings(tau=1.5, p=1.0, **TIGHT), t0=t0)
        for state, ld, end in zip(states, result.ld, result.end_state):
            m1, _, want = flow_m1_and_arclength(formulas, state, t0, t0 + 1.5 * direction)
            # measured: end states 2e-11, M_1 4e-12 relative (ldpipe at 1e-11 against scipy at 1e-13)
            np.testing.assert_allclose(end, want, rtol=1e-10, atol=1e-10)
            np.testing.assert_allclose(ld, m1, rtol=1e-10)
        assert not result.failed.any()


def test_3d_rotation_and_sinking_on_the_sphere(tmp_path):
    # rotation about the polar axis, u = omega R cos(lat) (m/s), v = 0, and w = -0.001 m/s (sinking),
    # depth positive down in m, time in days, on uneven latitudes and depths: the closed form is
    # (lon0 + omega t in degrees, lat0, z0 + 0.001 t in metres)
    radius, omega = 6.371e6, 2 * math.pi / (20 * 86400.0)

    def field(lon, lat, z, t):
        return omega * radius * np.cos(np.radians(lat)) + 0 * z, 0 * lon, -0.001 + 0 * t
    rng = np.random.default_rng(5)
    path = write_velocity_file_3d(tmp_path / "rot3.nc", field, np.arange(-30.0, 120.01, 1.5), uneven(-50, 50, 61, rng),
                                  uneven(0.0, 500.0, 9, rng), np.arange(0.0, 6.01, 1.0), names=("lon", "lat", "depth"),
                                  time_units="days since 2000-01-01")
    data = data_system(path, name="rot3", coordinates="sphere", w="w")
    assert data.coordinates == ("lon", "lat", "depth")
    # the last start is the first written as 370 degrees: the same point, its longitude kept in its own numbers
    starts = np.array([[10.0, 5.0, 100.0], [-20.0, 30.0, 200.0], [35.0, -15.0, 50.0], [370.0, 5.0, 100.0]])
    days = 3.0
    result = compute_ld(data, starts, 1, LDSettings(tau=days, p=0.5, **TIGHT), t0=1.0)
    expected = starts + [360.0 / 20 * days, 0.0, 0.001 * 86400 * days]
    # measured: longitudes 7.8e-6 degrees off (the cos(lat) profile interpolated on the uneven ~1.7 degree
    # latitudes, third order); latitudes exact and depths 7e-13 m (v = 0, w constant: exact)
    np.testing.assert_allclose(result.end_state[:, 0], expected[:, 0], rtol=0, atol=3e-5)
    np.testing.assert_allclose(result.end_state[:, 1:], expected[:, 1:], rtol=0, atol=1e-9)
    assert not data.stop_flags(result.end_state, 1.0, 1.0 + days)["left_data"].any()
    # a spatial window (depth too) that holds the trajectories and their stencils reads the same nodes:
    # the same bits
    windowed = data_system(path, name="rot3_window", coordinates="sphere", w="w",
                           window={"lon": [-25.0, 100.0], "lat": [-25.0, 40.0], "depth": [30.0, 480.0]})
    again = compute_ld(windowed, starts, 1, LDSettings(tau=days, p=0.5, **TIGHT), t0=1.0)
    np.testing.assert_array_equal(again.end_state, result.end_state)
    np.testing.assert_array_equal(again.ld, result.ld)
    # the LD in physical units, w in u's units (m/s): M_1/2 is (sqrt(u) + sqrt(|w|)) tau in (m/s)^1/2 days
    # with u = omega R cos(lat0), w = 0.001 m/s (closed form; measured relative error 7.2e-8)
    speed = omega * radius * np.cos(np.radians(starts[:, 1]))
    np.testing.assert_allclose(result.ld, (np.sqrt(speed) + math.sqrt(0.001)) * days, rtol=3e-7)
    assert data.ld_units(True) == "km" and data.ld_units(False, 0.5) == "(m/s)^0.5 days"
    # the arc length sqrt(u^2 + w^2) tau in km (closed form), with a rotation slow enough that w counts:
    # u = 0.002 cos(lat) m/s
    slow = omega * 0.002 / (omega * radius)

    def slow_field(lon, lat, z, t):
        return slow * radius * np.cos(np.radians(lat)) + 0 * z, 0 * lon, -0.001 + 0 * t
    path = write_velocity_file_3d(tmp_path / "slow3.nc", slow_field, np.arange(-30.0, 120.01, 1.5),
                                  uneven(-50, 50, 61, rng), uneven(0.0, 500.0, 9, rng), np.arange(0.0, 6.01, 1.0),
                                  names=("lon", "lat", "depth"), time_units="days since 2000-01-01")
    arc = compute_ld(data_system(path, name="slow3", coordinates="sphere", w="w"), starts, 1,
                     LDSettings(tau=days, p="arclength", **TIGHT), t0=1.0)
    speed = slow * radius * np.cos(np.radians(starts[:, 1]))
    np.testing.assert_allclose(arc.ld, np.hypot(speed, 0.001) * days * 86400 / 1000.0, rtol=1e-6)  # measured 2.6e-7


def test_2d_polar_rotation_on_uneven_latitudes_ld_in_kilometres(tmp_path):
    # rotation about the polar axis, u = omega R cos(lat) m/s, v = 0, on uneven latitudes (time in
    # days): the arc length is omega R cos(lat0) tau in km, M_1/2 sqrt(omega R cos(lat0)) tau (closed forms)
    radius, omega = 6.371e6, 2 * math.pi / (20 * 86400.0)
    rng = np.random.default_rng(7)
    lon, lat = np.arange(-60.0, 90.01, 1.0), uneven(-60.0, 60.0, 91, rng)

    def field(lon, lat, t):
        return omega * radius * np.cos(np.radians(lat)) + 0 * lon + 0 * t, 0 * lat
    path = write_velocity_file(tmp_path / "rot2.nc", field, lon, lat, np.arange(0.0, 6.01, 1.0),
                               names=("lon", "lat"), time_units="days since 2000-01-01")
    data = data_system(path, name="rot2", coordinates="sphere")
    assert data.engine_name == "velocity_data_rectilinear2_sphere"
    starts = np.array([[0.0, 0.0], [-5.0, 35.5], [5.0, -50.25]])
    speed = omega * radius * np.cos(np.radians(starts[:, 1]))
    days = 2.0
    for direction in (1, -1):
        # measured: relative errors up to 3.7e-7 (arc length) and 1.9e-7 (M_1/2), the interpolation
        # of cos(lat) between the uneven ~1.3 degree latitudes
        arc = compute_ld(data, starts, direction, LDSettings(tau=days, p="arclength", **TIGHT), t0=3.0)
        np.testing.assert_allclose(arc.ld, speed * days * 86400 / 1000.0, rtol=1e-6)
        half = compute_ld(data, starts, direction, LDSettings(tau=days, p=0.5, **TIGHT), t0=3.0)
        np.testing.assert_allclose(half.ld, np.sqrt(speed) * days, rtol=6e-7)
    assert data.ld_units(True) == "km"


SADDLE_RATES = (0.2, 0.1, 0.3)  # x' = a x, y' = -b y, z' = c z (z a depth: the file's upward w = -c z)


def test_3d_linear_saddle_ftle_on_uneven_depths(tmp_path):
    # the flow map is linear, diag(e^(aT), e^(-bT), e^(cT)) (closed form), so the grid differences are
    # exact: the FTLE is the largest rate of the section's two axes, forward max(a, c) = c on a vertical
    # section (x, z) at fixed y and max(a, -b) = a on a horizontal one (x, y) at a fixed depth; backward
    # (the inverse map) max(-a, -c) = -a and max(-a, b) = b
    a, b, c = SADDLE_RATES
    rng = np.random.default_rng(11)
    path = write_velocity_file_3d(tmp_path / "saddle3.nc", lambda X, Y, Z, T: (a * X + 0 * T, -b * Y, -c * Z),
                                  uneven(-4, 4, 9, rng), uneven(-2, 2, 7, rng), uneven(0.5, 80.0, 10, rng),
                                  np.linspace(0, 4, 5))
    base = {"system": "saddle", "t0": 2.0, "tau": 1.5, "p": 0.5, "ftle": True,
            "integrator": {"rtol": 1e-12, "atol": 1e-12}}
    config = validate_config({
        "systems": {"saddle": {"velocity_data": {"path": str(path), "w": "w"}}},
        "ld_maps": {"vertical": {**base, "section": {"axes": [{"name": "x", "range": [-1.0, 1.0], "points": 5},
                                                              {"name": "z", "range": [10.0, 20.0], "points": 4}],
                                                     "fixed": {"y": 0.5}}},
                    "horizontal": {**base, "section": {"axes": [{"name": "x", "range": [-1.0, 1.0], "points": 5},
                                                                {"name": "y", "range": [-0.5, 0.5], "points": 4}],
                                                       "fixed": {"z": 15.0}}}}})
    expected = {"vertical": (c, -a), "horizontal": (a, b)}
    for name, (forward, backward) in expected.items():
        dataset = compute_ld_map(parameters_from_config(config, "ld", name), None, show_progress=False)
        for label, rate in (("forward", forward), ("backward", backward)):
            assert dataset[f"ftle_defined_{label}"].values.all(), (name, label)
            # measured: 6e-14 relative (the integrator's tolerance 1e-12)
            np.testing.assert_allclose(dataset[f"ftle_{label}"].values, rate, rtol=1e-12, err_msg=f"{name} {label}")
        assert not dataset.on_land_forward.values.any() and not dataset.left_data_forward.values.any()


def test_sea_floor_and_surface_stop_trajectories(tmp_path):
    # w = -0.5 m/s (sinking) everywhere, depth positive down on uneven levels, missing values at 140 m and
    # deeper: the cell [100, 140] has land nodes, so a trajectory from z0 stops on the sea floor at 100 m
    # after (100 - z0) / 0.5 s (forward, on_land); backward it rises to the top level 0 m after z0 / 0.5 s
    # (left_data). Closed forms; M_0.5 = time * 0.5^0.5.
    levels = np.array([0.0, 10.0, 25.0, 45.0, 70.0, 100.0, 140.0, 190.0])
    path = write_velocity_file_3d(tmp_path / "floor.nc", lambda X, Y, Z, T: (0 * X, 0 * Y, -0.5 + 0 * T),
                                  np.linspace(0, 4, 5), np.linspace(0, 4, 5), levels, np.linspace(0, 400, 5),
                                  land=lambda X, Y, Z: Z >= 140)
    config = validate_config({
        "systems": {"floor": {"velocity_data": {"path": str(path), "w": "w"}}},
        "ld_maps": {"f": {"system": "floor", "t0": 200.0, "tau": 190.0, "p": 0.5,
                          "integrator": {"rtol": 1e-10, "atol": 1e-10},
                          "section": {"axes": [{"name": "x", "range": [1.0, 3.0], "points": 3},
                                              {"name": "y", "range": [1.0, 3.0], "points": 3}],
                                      "fixed": {"z": 30.0}}}}})
    dataset = compute_ld_map(parameters_from_config(config, "ld", "f"), None, show_progress=False)
    assert dataset.on_land_forward.values.all() and not dataset.left_data_forward.values.any()
    assert dataset.left_data_backward.values.all() and not dataset.on_land_backward.values.any()
    # measured: 1.6e-8 relative at the sea floor (the step across it), 5e-13 at the surface (the edge), located
    # on the dense output; the LD 1.7e-8 relative
    np.testing.assert_allclose(dataset.exit_time_forward.values, (100.0 - 30.0) / 0.5, rtol=1e-7)
    np.testing.assert_allclose(dataset.exit_time_backward.values, 30.0 / 0.5, rtol=1e-11)
    np.testing.assert_allclose(dataset.ld_forward.values, (100.0 - 30.0) / 0.5 * math.sqrt(0.5), rtol=1e-7)
    # the same sea floor as a land-sea mask on (z, y, x), 0 at 140 m and deeper, over finite velocities: the same stops
    with xr.open_dataset(path) as opened:
        masked = opened.load().fillna(0.0)
    masked["sea"] = (("z", "y", "x"), np.broadcast_to((levels < 140)[:, None, None], (8, 5, 5)).astype(float))
    masked.to_netcdf(tmp_path / "masked.nc")
    config["systems"]["floor"]["velocity_data"].update(path=str(tmp_path / "masked.nc"), mask="sea")
    masked_map = compute_ld_map(parameters_from_config(config, "ld", "f"), None, show_progress=False)
    assert masked_map.on_land_forward.values.all() and masked_map.left_data_backward.values.all()
    np.testing.assert_array_equal(masked_map.exit_time_forward.values, dataset.exit_time_forward.values)


def test_bad_3d_data_errors_name_the_coordinate(tmp_path):
    def field(X, Y, Z, T):
        return X + 0 * T, Y, Z
    x, y, t = np.arange(5.0), np.arange(4.0), np.arange(3.0)
    unsigned = write_velocity_file_3d(tmp_path / "unsigned.nc", field, x, y, np.array([0.0, 5.0, 20.0]), t, positive=None)
    with pytest.raises(ConfigError, match=r"velocity_data\.positive': the vertical coordinate 'z' says neither"):
        data_system(unsigned, w="w")
    assert data_system(unsigned, w="w", positive="up").source.vertical_scale == 1.0  # the entry's key decides
    with xr.open_dataset(unsigned) as dataset:
        shouting = dataset.load()
    shouting.z.attrs["positive"] = "DOWN"  # CF's values in any case
    shouting.to_netcdf(tmp_path / "shouting.nc")
    assert data_system(tmp_path / "shouting.nc", w="w").source.vertical_scale == -1.0
    with xr.open_dataset(unsigned) as dataset:
        loaded = dataset.load()
    shuffled = loaded.assign_coords(z=[0.0, 20.0, 5.0])
    shuffled.to_netcdf(tmp_path / "unsorted.nc")
    with pytest.raises(ConfigError, match=r"velocity_data\.z': coordinate 'z' is not monotonic"):
        data_system(tmp_path / "unsorted.nc", w="w")
    without_depth = loaded.assign(w=loaded.w.isel(z=0, drop=True))
    without_depth.to_netcdf(tmp_path / "flat_w.nc")
    with pytest.raises(ConfigError, match=r"velocity_data\.w': variable 'w' has dimensions \('time', 'y', 'x'\); "
                                          r"expected \('time', 'z', 'y', 'x'\)"):
        data_system(tmp_path / "flat_w.nc", w="w")
    # the FTLE of 3-D data on the sphere would mix degrees of arc with metres: refused, naming the key
    with pytest.raises(ConfigError, match=r"ld_maps\.m\.ftle': system 's' is 3-D data on the sphere"):
        validate_config({"systems": {"s": {"velocity_data": {"path": str(unsigned), "w": "w", "coordinates": "sphere"}}},
                         "ld_maps": {"m": {"system": "s", "tau": 1.0, "p": 0.5, "ftle": True,
                                           "section": {"axes": [{"name": "lon", "range": [0.0, 1.0], "points": 3},
                                                                {"name": "lat", "range": [0.0, 1.0], "points": 3}],
                                                       "fixed": {"depth": 5.0}}}}})


def test_3d_example_currents_keep_their_depth_and_decay(tmp_path):
    # the example's 3-D currents (ldpipe.data.example --depth): w = 0, so a trajectory keeps its depth
    # (closed form), and u, v at a node are the jet's times exp(-depth / 300 m); nodes below the shelf's
    # sea floor are missing (land)
    from ldpipe.data.example import DECAY_DEPTH, example_dataset, jet_velocity, sea_floor

    dataset = example_dataset(days=1.0, resolution=1.0, depths=4)
    depth = dataset.depth.values
    assert dataset.depth.attrs["positive"] == "down" and np.all(np.diff(np.diff(depth)) > 0)  # wider with depth
    lon, lat = np.meshgrid(dataset.lon.values, dataset.lat.values)
    below = depth[:, None, None] > sea_floor(lon, lat)
    np.testing.assert_array_equal(np.isnan(dataset.u.values[0]) & below, below)
    u, v = jet_velocity(-60.0, 37.0, 86400.0)
    node = dataset.sel(lon=-60.0, lat=37.0, time=1.0)
    # float32 storage: 6e-8 relative
    np.testing.assert_allclose(node.u.values, u * np.exp(-depth / DECAY_DEPTH), rtol=1e-6)
    np.testing.assert_allclose(node.v.values, v * np.exp(-depth / DECAY_DEPTH), rtol=1e-6, atol=1e-9)
    dataset.to_netcdf(tmp_path / "example3d.nc")
    data = data_system(tmp_path / "example3d.nc", name="example3d", coordinates="sphere", w="w")
    starts = np.array([[-60.0, 37.0, 50.0], [-55.0, 40.0, 300.0]])
    result = compute_ld(data, starts, 1, LDSettings(tau=0.5, p=0.5, **TIGHT), t0=0.25)
    np.testing.assert_array_equal(result.end_state[:, 2], starts[:, 2])
    assert not result.failed.any() and np.all(result.end_state[:, 0] != starts[:, 0])


def test_a_window_of_uneven_data_interpolates_as_the_whole_data(tmp_path):
    # Invariant: a window (the nodes a map needs, read alone) keeps one node more on each side for
    # the cubic's stencil, so inside it the velocity is the whole data's, to rounding. The field is
    # the double gyre (not a quadratic, which Keys' extrapolated boundary node would reproduce too:
    # an edge cell of the window reading an extrapolated node instead is then 4e-5 off).
    from support.double_gyre import double_gyre_velocity

    x, y, t = warped(0.0, 2.0, 33), warped(0.0, 1.0, 17), warped(0.0, 8.0, 49)
    path = write_velocity_file(tmp_path / "gyre.nc", double_gyre_velocity, x, y, t)
    whole, windowed = data_system(path), data_system(path, window={"x": [0.6, 1.6], "y": [0.3, 0.8]})
    rng = np.random.default_rng(3)
    # points over the window's box [0.6, 1.6] x [0.3, 0.8], and along each of its sides (in the cells
    # that straddle them, where the stencil reaches past the window's nodes)
    box = np.column_stack([rng.uniform(0.6, 1.6, 40), rng.uniform(0.3, 0.8, 40)])
    sides = [np.column_stack([np.full(20, value), rng.uniform(0.3, 0.8, 20)]) for value in (0.6, 1.6)]
    sides += [np.column_stack([rng.uniform(0.6, 1.6, 20), np.full(20, value)]) for value in (0.3, 0.8)]
    points = np.vstack([box, *sides])
    for time in (2.3, 5.1):
        difference = max(np.max(np.abs(windowed.vector_field(p, time) - whole.vector_field(p, time))) for p in points)
        # measured: 0 (the same nodes, the same arithmetic); 4e-5 with an extrapolated node
        assert difference < 1e-14, (time, difference)
