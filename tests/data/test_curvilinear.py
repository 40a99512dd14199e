"""Velocity data on curvilinear grids (2-D coordinates), against closed forms and the formula system.

- Solid-body rotation on a rotated plane grid: the field is linear and the grid affine, so the
  interpolants are exact (cubic convolution reproduces degree <= 2) and the end points are the
  start rotated by omega t, the arc length omega r t (closed forms) to the integrator's
  tolerance; M_1/2 against the closed-form integrand's quadrature (scipy). The same with the
  velocities written along the grid's i and j (ROMS's convention), the angle from the file and
  computed from the coordinates.
- Solid-body rotation about the polar axis on a rotated-pole lon/lat grid: lon0 + omega t, lat0,
  and the arc length omega R cos(lat0) t in km (closed forms), to the interpolation's error.
- The double gyre (Shadden et al. 2005) on a rotated and on a smoothly bent grid
  (ldpipe.data.curvilinear) at two spacings: the LD error against the formula system falls at
  the interpolant's third order, as on the regular grid.
- A uniform flow towards the rotated grid's edge stops at it after the closed-form time, flagged.
- Bad data: each message names the variable (missing coordinates, staggered shapes, an angle in
  degrees labelled radians, components not said).
"""

import math

import numpy as np
import pytest
from scipy.integrate import quad

from ldpipe.config import validate_config
from ldpipe.config.parameters import parameters_from_config
from ldpipe.core.maps.assembly import compute_ld_map
from ldpipe.data.curvilinear import (
    ROTATION, curvilinear_dataset, double_gyre_dataset, plane_grid, rotated_pole_grid, write_dataset,
)
from ldpipe.engine import LDSettings, compute_ld
from ldpipe.errors import ConfigError
from ldpipe.systems import make_system
from support.double_gyre import DOUBLE_GYRE
from support.gridded import write_velocity_file

#: The curvilinear engine is loaded by these tests alone (and the curvilinear series of
#: test_file_series, in the same xdist group so one worker compiles it).
pytestmark = [pytest.mark.compiles, pytest.mark.xdist_group("curvilinear_grids")]
TIGHT = {"rtol": 1e-11, "atol": 1e-11}
OMEGA = 0.3  # the plane rotation's rate about the domain's centre (1, 0.5)


def rotation(x, y, t):
    return -OMEGA * (y - 0.5) + 0 * t, OMEGA * (x - 1.0) + 0 * t


def data_system(path, name="curvi", **entry):
    return make_system(name, {"velocity_data": {"path": str(path), **entry}})


def rotated(starts, angle):
    dx, dy = starts[:, 0] - 1.0, starts[:, 1] - 0.5
    return np.column_stack([1.0 + math.cos(angle) * dx - math.sin(angle) * dy,
                            0.5 + math.sin(angle) * dx + math.cos(angle) * dy])


@pytest.mark.parametrize("components, write_angle", [("geographic", False), ("grid", True), ("grid", False)])
def test_solid_body_rotation_on_a_rotated_grid(tmp_path, components, write_angle):
    x, y = plane_grid("rotated", 0.1)
    path = write_dataset(curvilinear_dataset(rotation, x, y, np.arange(0.0, 6.01, 1.0), components=components,
                                             write_angle=write_angle), tmp_path / "rotation.nc")
    entry = {"components": components} | ({"angle": "angle"} if write_angle else {})
    data = data_system(path, **entry)
    starts = np.array([[1.5, 0.5], [1.2, 0.9], [0.4, 0.3], [1.0, 0.5]])
    tau = 3.0
    radius = np.hypot(starts[:, 0] - 1.0, starts[:, 1] - 0.5)
    result = compute_ld(data, starts, 1, LDSettings(tau=tau, p="arclength", **TIGHT), t0=1.0)
    # measured: 5.8e-13 (positions), 1.3e-12 (arc length), each way of writing the velocities: the
    # integrator's tolerance
    np.testing.assert_allclose(result.end_state, rotated(starts, OMEGA * tau), rtol=0, atol=5e-11)
    np.testing.assert_allclose(result.ld, OMEGA * radius * tau, rtol=0, atol=5e-11)
    backward = compute_ld(data, starts, -1, LDSettings(tau=tau, p=0.5, **TIGHT), t0=4.5)
    np.testing.assert_allclose(backward.end_state, rotated(starts, -OMEGA * tau), rtol=0, atol=5e-11)

    def m_half(r, phase):  # |u|^1/2 + |v|^1/2 along the circle, integrated by quad
        return quad(lambda s: math.sqrt(abs(OMEGA * r * math.sin(phase - OMEGA * s)))
                    + math.sqrt(abs(OMEGA * r * math.cos(phase - OMEGA * s))), 0.0, tau, limit=200)[0]
    phases = np.arctan2(starts[:, 1] - 0.5, starts[:, 0] - 1.0)
    expected = [m_half(r, phase) for r, phase in zip(radius, phases)]
    # measured: 4.0e-10 (the quadrature of |.|^1/2 across its zeros, by the engine's folded rule); at
    # the centre, a fixed point, the velocity is rounding (1e-17) whose square root integrates to 5e-9
    np.testing.assert_allclose(backward.ld[:3], expected[:3], rtol=0, atol=1e-9)
    assert backward.ld[3] < 2e-8


def test_starts_off_the_grid_stay_where_they_are(tmp_path):
    # beyond the grid's edge the velocity is 0 (the data's edge): a start there never moves, so it
    # ends exactly where it started (its indices, found or not, are never mapped back), LD 0, flagged
    x, y = plane_grid("rotated", 0.1)
    path = write_dataset(curvilinear_dataset(rotation, x, y, np.arange(0.0, 6.01, 1.0)), tmp_path / "rotation.nc")
    data = data_system(path, components="geographic")
    starts = np.array([[2.9, 0.5], [1.0, -1.5], [40.0, -25.0], [1.5, 0.5]])  # just off, off, far off, on
    result = compute_ld(data, starts, 1, LDSettings(tau=2.0, p=0.5, **TIGHT), t0=1.0)
    np.testing.assert_array_equal(result.end_state[:3], starts[:3])
    np.testing.assert_array_equal(result.ld[:3], 0.0)
    assert result.ld[3] > 0.1 and np.all(np.isfinite(result.end_state))
    flags = data.stop_flags(result.end_state, 1.0, 3.0)
    np.testing.assert_array_equal(flags["left_data"], [True, True, True, False])


@pytest.mark.parametrize("shift", [0.0, 180.0])
def test_solid_body_rotation_on_a_rotated_pole_grid(tmp_path, shift):
    # rotation about the polar axis, a turn in 40 days: u = omega R cos(lat), v = 0 (m/s, time in
    # days) on a grid even in a frame tilted 40 degrees: its i direction is 0 to 40 degrees from east.
    # Shifted by 180 degrees of longitude (the rotation does not change) the grid straddles the
    # dateline, its longitudes written in -180..180, so they jump by 360 inside the file.
    radius, omega = 6371000.0, 2 * math.pi / (40 * 86400.0)
    lon, lat = rotated_pole_grid((30.0, 20.0), 0.5, 40.0)
    lon = np.mod(lon + shift + 180.0, 360.0) - 180.0
    path = write_dataset(curvilinear_dataset(lambda x, y, t: (omega * radius * np.cos(np.radians(y)) + 0 * t, 0 * y),
                                             lon, lat, np.arange(0.0, 4.01, 1.0), sphere=True,
                                             time_units="days since 2000-01-01"), tmp_path / "pole.nc")
    data = data_system(path, coordinates="sphere")  # the coordinates from CF, eastward/northward by standard names
    assert data.coordinates == ("lon", "lat") and data.source.grid_coordinates == ("lon_rho", "lat_rho")
    starts = np.array([[-10.0, -45.0], [-5.0, -30.0], [0.0, -40.0], [8.0, -50.0]]) + [shift, 0.0]
    starts[1, 0] -= 360.0 * (shift > 0)  # 175 written as -185: a start in either convention
    result = compute_ld(data, starts, 1, LDSettings(tau=1.0, p="arclength", **TIGHT), t0=1.0)
    expected = starts + [math.degrees(omega * 86400.0), 0.0]
    # measured: 1.5e-6 degrees (4.3e-5 on a 2-degree grid, 1.6e-5 on a 1-degree: third order from
    # there), the arc length 1.05e-8 relative (6.0e-7, 9.2e-8); longitudes compared modulo 360
    np.testing.assert_allclose(np.mod(result.end_state[:, 0] - expected[:, 0] + 180.0, 360.0) - 180.0, 0.0,
                               rtol=0, atol=6e-6)
    np.testing.assert_allclose(result.end_state[:, 1], expected[:, 1], rtol=0, atol=6e-6)
    arc = omega * 86400.0 * radius * np.cos(np.radians(starts[:, 1])) / 1000.0
    np.testing.assert_allclose(result.ld, arc, rtol=5e-8)
    assert not data.stop_flags(result.end_state, 1.0, 2.0)["left_data"].any()


def test_double_gyre_on_curvilinear_grids_converges_at_the_interpolants_order(tmp_path):
    # as test_velocity_data's double gyre: 30 starts, tau = 5 from t0 = 2, M_1/2, rtol 1e-12, against
    # the formula system; each grid's (a, b) frame and the times every h = 1/8 and 1/16. The error is
    # the RMS over the starts (the largest one jumps between trajectories as the grids refine).
    settings = LDSettings(tau=5.0, p=0.5, rtol=1e-12, atol=1e-12)
    grid = np.meshgrid(np.linspace(0.15, 1.85, 6), np.linspace(0.1, 0.9, 5))
    starts = np.column_stack([grid[0].ravel(), grid[1].ravel()])
    reference = compute_ld(make_system("formula", DOUBLE_GYRE), starts, 1, settings, t0=2.0).ld
    errors = {}
    for kind in ("regular", "rotated", "curvilinear"):
        for n in (8, 16):
            path = write_dataset(double_gyre_dataset(kind, 1.0 / n, 1.5 + np.arange(6 * n + 1) / n),
                                 tmp_path / f"{kind}{n}.nc")
            data = data_system(path, name=f"{kind}{n}", components="geographic")
            difference = compute_ld(data, starts, 1, settings, t0=2.0).ld - reference
            errors[kind, n] = math.sqrt(np.mean(difference**2))
    # measured RMS errors (h = 1/8, 1/16; and 1/32): regular 1.5e-3, 1.3e-4 (9.8e-6); rotated 3.1e-3,
    # 2.8e-4 (2.0e-5); curvilinear 2.4e-3, 2.0e-4 (2.4e-5): slopes 3.5 to 3.6 (3.0 to 3.8 at 1/32), the
    # cubic's third order seen a little above it; the curvilinear grids' errors 1.5 to 2.2 times the
    # regular grid's (the gyre sampled across its axes)
    for kind in ("regular", "rotated", "curvilinear"):
        slope = math.log2(errors[kind, 8] / errors[kind, 16])
        assert 2.7 < slope < 4.2, (kind, errors)
        assert errors[kind, 16] < 3.0 * errors["regular", 16], (kind, errors)


def test_a_uniform_flow_stops_at_the_rotated_grids_edge(tmp_path):
    # u = 0.1 east everywhere on the grid rotated by 30 degrees: a trajectory from (x0, y0) leaves
    # the grid where the ray east first crosses its edge. In the grid's (a, b) frame the ray runs
    # along (cos 30, -sin 30) and the edges are a = 1.4 and b = -1.2 (closed form: the smaller of
    # the two times); the map says left_data and the time it stopped.
    x, y = plane_grid("rotated", 0.1)
    path = write_dataset(curvilinear_dataset(lambda X, Y, T: (0.1 + 0 * X + 0 * T, 0 * Y), x, y,
                                             np.arange(0.0, 60.01, 2.0)), tmp_path / "uniform.nc")
    spec = {"system": "uniform", "t0": 30.0, "tau": 28.0, "p": 0.5, "ftle": True,
            "integrator": {"rtol": 1e-10, "atol": 1e-10},
            "section": {"axes": [{"name": "x", "range": [0.5, 1.5], "points": 3},
                                 {"name": "y", "range": [0.2, 0.8], "points": 3}]}}
    config = validate_config({"systems": {"uniform": {"velocity_data": {"path": str(path), "components": "geographic"}}},
                              "ld_maps": {"u": spec}})
    dataset = compute_ld_map(parameters_from_config(config, "ld", "u"), None, show_progress=False)
    X0, Y0 = np.meshgrid(dataset.x.values, dataset.y.values, indexing="ij")
    a0 = math.cos(ROTATION) * (X0 - 1.0) + math.sin(ROTATION) * (Y0 - 0.5)
    b0 = -math.sin(ROTATION) * (X0 - 1.0) + math.cos(ROTATION) * (Y0 - 0.5)
    exit_time = np.minimum((1.4 - a0) / (0.1 * math.cos(ROTATION)), (b0 + 1.2) / (0.1 * math.sin(ROTATION)))
    assert np.all(exit_time < 28.0)
    assert dataset.left_data_forward.values.all() and not dataset.on_land_forward.values.any()
    # measured: 1.0e-8 relative (exit time), 4.2e-8 (LD), end points 3.1e-9 (the step across the edge)
    np.testing.assert_allclose(dataset.exit_time_forward.values, exit_time, rtol=1e-7)
    np.testing.assert_allclose(dataset.ld_forward.values, exit_time * math.sqrt(0.1), rtol=1e-7)
    end_x = X0 + 0.1 * exit_time
    np.testing.assert_allclose(dataset.end_x_forward.values, end_x, rtol=0, atol=1e-7)


def test_bad_curvilinear_data_is_refused_naming_the_variable(tmp_path):
    x, y = plane_grid("rotated", 0.2)
    times = np.arange(0.0, 3.01, 1.0)
    good = curvilinear_dataset(rotation, x, y, times, components="grid", write_angle=True)
    with pytest.raises(ConfigError, match=r"velocity_data\.components': the grid is curvilinear, and 'u', 'v' do "
                                          r"not say"):
        data_system(write_dataset(good, tmp_path / "good.nc"))
    degrees = good.assign(angle=good.angle * 180.0 / math.pi)  # still labelled radians
    degrees.angle.attrs["units"] = "radians"
    with pytest.raises(ConfigError, match=r"angle variable 'angle' differs from the grid coordinates' rotation by "
                                          r".* wrong unit"):
        data_system(write_dataset(degrees, tmp_path / "degrees.nc"), components="grid", angle="angle")
    unitless = good.copy()
    unitless.angle.attrs.pop("units")
    with pytest.raises(ConfigError, match=r"velocity_data\.angle': variable 'angle' has units None; expected radians"):
        data_system(write_dataset(unitless, tmp_path / "unitless.nc"), components="grid", angle="angle")
    holes = good.copy()
    holes["x_rho"] = holes.x_rho.where(holes.x_rho < 1.5)
    with pytest.raises(ConfigError, match=r"2-D coordinate 'x_rho' has \d+ missing values \(the first at index"):
        data_system(write_dataset(holes, tmp_path / "holes.nc"), components="grid")
    u_points = good.u.drop_vars(["x_rho", "y_rho"]).isel(xi=slice(0, -1)).rename(xi="xi_u")  # a C-grid's u, v not
    staggered = good.drop_vars("u").assign(u=u_points)
    with pytest.raises(ConfigError, match=r"velocity_data\.u': variables 'u' .*'xi_u': 14.* and 'v' .* fit neither "
                                          r"the coordinates' points \(time, 13, 15\) nor an Arakawa C-grid's faces"):
        data_system(write_dataset(staggered, tmp_path / "staggered.nc"), components="grid",
                    x="x_rho", y="y_rho")
    with pytest.raises(ConfigError, match=r"velocity_data\.longitude': 2-D longitude and latitude are on the sphere"):
        data_system(tmp_path / "good.nc", components="grid", longitude="x_rho", latitude="y_rho")
    lon, lat = rotated_pole_grid((30.0, 20.0), 2.0, 80.0)  # the frame tilted so far the south pole is inside
    polar = curvilinear_dataset(lambda X, Y, T: (0 * X + T, 0 * Y), lon, lat, times, sphere=True)
    with pytest.raises(ConfigError, match=r"curvilinear grid \('lon_rho', 'lat_rho'\) jumps by .* degrees of "
                                          r"longitude .* round a pole.* not supported yet"):
        data_system(write_dataset(polar, tmp_path / "polar.nc"), coordinates="sphere")
    regular = write_velocity_file(tmp_path / "regular.nc", rotation, np.linspace(0, 2, 5), np.linspace(0, 1, 5), times)
    with pytest.raises(ConfigError, match=r"velocity_data': components, angle, c_grid and metrics are of a curvilinear "
                                          r"grid"):
        data_system(regular, components="grid")


def test_the_ftle_of_a_rotation_on_a_rotated_grid_is_zero(tmp_path):
    # a rotation is an isometry: the FTLE is 0 (closed form); the map's end points come back from
    # index space through the grid's coordinates, so a wrong mapping would stretch them
    x, y = plane_grid("rotated", 0.1)
    path = write_dataset(curvilinear_dataset(rotation, x, y, np.arange(0.0, 6.01, 1.0)), tmp_path / "rotation.nc")
    spec = {"system": "rot", "t0": 3.0, "tau": 2.5, "p": 0.5, "ftle": True,
            "integrator": {"rtol": 1e-10, "atol": 1e-10},
            "section": {"axes": [{"name": "x", "range": [0.6, 1.4], "points": 5},
                                 {"name": "y", "range": [0.2, 0.8], "points": 4}]}}
    config = validate_config({"systems": {"rot": {"velocity_data": {"path": str(path), "components": "geographic"}}},
                              "ld_maps": {"r": spec}})
    dataset = compute_ld_map(parameters_from_config(config, "ld", "r"), None, show_progress=False)
    for label in ("forward", "backward"):
        assert dataset[f"ftle_defined_{label}"].values.all()
        # measured: 4.8e-12 (the integrator's tolerance, differentiated over the map's spacing)
        assert np.max(np.abs(dataset[f"ftle_{label}"].values)) < 3e-11, label


def test_noise_on_a_curvilinear_grid_is_refused(tmp_path):
    # the engine's noise would be of the grid's indices, not of x and y: refused before any integration
    x, y = plane_grid("rotated", 0.2)
    path = write_dataset(curvilinear_dataset(rotation, x, y, np.arange(0.0, 6.01, 1.0)), tmp_path / "rotation.nc")
    spec = {"system": "rot", "t0": 3.0, "tau": 1.0, "p": 0.5,
            "noise": {"diffusion": {"x": "0.01", "y": "0.01"}, "members": 2, "seed": 1, "dt": 0.1},
            "section": {"axes": [{"name": "x", "range": [0.8, 1.2], "points": 2},
                                 {"name": "y", "range": [0.4, 0.6], "points": 2}]}}
    config = validate_config({"systems": {"rot": {"velocity_data": {"path": str(path), "components": "geographic"}}},
                              "ld_maps": {"r": spec}})
    with pytest.raises(ValueError, match=r"noise on a curvilinear grid .* is not supported yet"):
        compute_ld_map(parameters_from_config(config, "ld", "r"), None, show_progress=False)
