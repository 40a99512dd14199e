"""Velocity data on the sphere against closed forms: the LD in physical units, and a global grid's seam.

- Solid-body rotation about the polar axis (u = omega R cos(lat), v = 0): a particle at latitude
  phi runs along its parallel at the speed omega R cos(phi), so over tau days its arc length is
  omega R cos(phi) tau 86400 / 1000 km and its M_1/2 (omega R cos(phi))^(1/2) tau, u in m/s and
  time in days (closed forms).
- Solid-body rotation about the axis through (lon 0, lat 0) (u = -omega R sin(lat) cos(lon),
  v = omega R sin(lon)): the trajectories are circles about that axis, run at the speed
  omega R sin(angle to the axis) = omega R sqrt(1 - cos(lat)^2 cos(lon)^2), constant on each
  (closed form); here the longitude rate depends on the latitude, so the metric cos(lat) is exercised.
  Its M_1/2 is the integral of |u|^1/2 + |v|^1/2 along the closed-form circle, by scipy's quad.
- The same rotation sampled on a global grid (0 .. 359 E) has circles about lon 0 that cross the
  seam 359 -> 0: their end points are the closed form's, as far as on a circle that does not cross
  it, and they do not stop; on a grid with a gap (0 .. 350 E) they stop at its edge.
"""

import math

import numpy as np
import pytest
from scipy.integrate import quad

from ldpipe.config import validate_config
from ldpipe.engine import LDSettings, compute_ld
from ldpipe.errors import ConfigError
from ldpipe.core.maps.assembly import compute_ld_map
from ldpipe.config.parameters import parameters_from_config
from ldpipe.systems import make_system
from support.gridded import write_velocity_file

TIGHT = dict(rtol=1e-11, atol=1e-11)
RADIUS, OMEGA = 6.371e6, 2 * math.pi / (20 * 86400.0)  # m, rad/s: a turn in 20 days
DAY = 86400.0


def polar_rotation(lon, lat, t):
    return OMEGA * RADIUS * np.cos(np.radians(lat)) + 0 * lon + 0 * t, 0 * lat


def equatorial_rotation(lon, lat, t):
    lam, phi = np.radians(lon), np.radians(lat)
    return -OMEGA * RADIUS * np.sin(phi) * np.cos(lam) + 0 * t, OMEGA * RADIUS * np.sin(lam)


def rotated(starts, days):
    """The start points (lon, lat in degrees) rotated by OMEGA * days about the x axis (closed form)."""
    angle = OMEGA * days * DAY
    lam, phi = np.radians(starts[:, 0]), np.radians(starts[:, 1])
    r = np.array([np.cos(phi) * np.cos(lam), np.cos(phi) * np.sin(lam), np.sin(phi)])
    r = np.array([r[0], math.cos(angle) * r[1] - math.sin(angle) * r[2], math.sin(angle) * r[1] + math.cos(angle) * r[2]])
    return np.column_stack([np.degrees(np.arctan2(r[1], r[0])), np.degrees(np.arcsin(r[2]))])


def sphere_file(tmp_path, name, field, lon, lat=np.arange(-60.0, 60.01, 1.0)):
    return write_velocity_file(tmp_path / f"{name}.nc", field, lon, lat, np.arange(0.0, 6.01, 1.0),
                               names=("lon", "lat"), time_units="days since 2000-01-01")


def sphere_system(path, name, **entry):
    return make_system(name, {"velocity_data": {"path": str(path), "coordinates": "sphere", **entry}})


def lon_difference(a, b):
    return (np.asarray(a) - b + 180.0) % 360.0 - 180.0


def test_polar_rotation_ld_in_kilometres_and_metres_per_second(tmp_path):
    data = sphere_system(sphere_file(tmp_path, "polar", polar_rotation, np.arange(-60.0, 60.01, 1.0)), "polar")
    starts = np.array([[0.0, 0.0], [-5.0, 35.5], [5.0, -50.25]])
    speed = OMEGA * RADIUS * np.cos(np.radians(starts[:, 1]))  # m/s
    days = 2.0
    for direction in (1, -1):
        arc = compute_ld(data, starts, direction, LDSettings(tau=days, p="arclength", **TIGHT), t0=3.0)
        # measured: relative error 9.9e-8 (the interpolation of cos(lat) between the 1 degree nodes;
        # 3e-13 at a node's latitude)
        np.testing.assert_allclose(arc.ld, speed * days * DAY / 1000.0, rtol=3e-7)
        half = compute_ld(data, starts, direction, LDSettings(tau=days, p=0.5, **TIGHT), t0=3.0)
        np.testing.assert_allclose(half.ld, np.sqrt(speed) * days, rtol=2e-7)  # measured 4.9e-8
    # the map file names the units: km for the arc length, the data's velocity units to the p times days
    maps = {p: {"system": "polar", "t0": 3.0, "tau": days, "p": p, "integrator": {"rtol": 1e-10, "atol": 1e-10},
                "section": {"axes": [{"name": "lon", "range": [-5.0, 5.0], "points": 3},
                                     {"name": "lat", "range": [-40.3, 40.3], "points": 3}]}} for p in ("arclength", 0.5)}
    config = validate_config({"systems": {"polar": data.spec}, "ld_maps": {"arc": maps["arclength"], "half": maps[0.5]}})
    arc_map = compute_ld_map(parameters_from_config(config, "ld", "arc"), None, show_progress=False)
    assert arc_map.ld_forward.attrs["units"] == arc_map.ld_backward.attrs["units"] == "km"
    expected = OMEGA * RADIUS * np.cos(np.radians(arc_map.lat.values)) * days * DAY / 1000.0
    np.testing.assert_allclose(arc_map.ld_forward.values, np.broadcast_to(expected, (3, 3)), rtol=2e-7)  # measured 6e-8
    half_map = compute_ld_map(parameters_from_config(config, "ld", "half"), None, show_progress=False)
    assert half_map.ld_forward.attrs["units"] == "(m/s)^0.5 days"


def test_rotation_about_an_equatorial_axis_ld_in_physical_units(tmp_path):
    data = sphere_system(sphere_file(tmp_path, "equatorial", equatorial_rotation, np.arange(-60.0, 60.01, 1.0)),
                         "equatorial")
    starts = np.array([[10.0, 5.0], [-20.0, 30.0], [35.0, -15.0]])
    days = 2.0
    lam, phi = np.radians(starts[:, 0]), np.radians(starts[:, 1])
    speed = OMEGA * RADIUS * np.sqrt(1.0 - (np.cos(phi) * np.cos(lam)) ** 2)
    arc = compute_ld(data, starts, 1, LDSettings(tau=days, p="arclength", **TIGHT), t0=1.0)
    np.testing.assert_allclose(arc.end_state, rotated(starts, days), atol=5e-7)  # measured 1.8e-7 degrees
    # measured: relative error 4.1e-8 (interpolation of the trigonometric field on the 1 degree grid)
    np.testing.assert_allclose(arc.ld, speed * days * DAY / 1000.0, rtol=1.5e-7)

    def m_half(start):
        def integrand(t):
            lon, lat = rotated(start[None], t)[0]
            u, v = equatorial_rotation(lon, lat, 0.0)
            return abs(u) ** 0.5 + abs(v) ** 0.5
        return quad(integrand, 0.0, days, limit=200, epsabs=1e-12, epsrel=1e-12)[0]

    half = compute_ld(data, starts, 1, LDSettings(tau=days, p=0.5, **TIGHT), t0=1.0)
    np.testing.assert_allclose(half.ld, [m_half(s) for s in starts], rtol=5e-8)  # measured 1.1e-8


def test_global_grid_is_joined_across_its_seam(tmp_path):
    days = 4.0  # 72 degrees about the axis through (lon 0, lat 0)
    # circles about lon 0 crossing the seam 359 -> 0 both ways, and one about lon 180 that does not
    starts = np.array([[10.0, 5.0], [350.0, -20.0], [355.0, -30.0], [190.0, 5.0]])
    expected = rotated(starts, days)
    joined = sphere_system(sphere_file(tmp_path, "global", equatorial_rotation, np.arange(0.0, 359.5, 1.0)), "global")
    assert joined.source.x_global
    result = compute_ld(joined, starts, 1, LDSettings(tau=days, p="arclength", **TIGHT), t0=1.0)
    assert not result.failed.any() and (result.time == days).all()
    flags = joined.stop_flags(result.end_state, 1.0, 1.0 + days)
    assert not flags["left_data"].any() and not flags["on_land"].any()
    errors = np.hypot(lon_difference(result.end_state[:, 0], expected[:, 0]), result.end_state[:, 1] - expected[:, 1])
    # measured: 6.6e-7 degrees on the circle about lon 180 (the interpolation error), 8e-7 .. 1.4e-6
    # across the seam (on larger circles, as far from the axis as the errors grow)
    assert errors[3] < 3e-6 and np.all(errors[:3] < 3e-6), errors
    speed = OMEGA * RADIUS * np.sqrt(1.0 - (np.cos(np.radians(starts[:, 1])) * np.cos(np.radians(starts[:, 0]))) ** 2)
    np.testing.assert_allclose(result.ld, speed * days * DAY / 1000.0, rtol=1.5e-7)  # measured 4.5e-8
    # a zonal flow winding round three times in three days (a turn a day on every parallel): no
    # escape at any number of turns, the arc length 3 omega R cos(lat) days (closed form)
    turn = 2 * math.pi / DAY
    winding = sphere_system(sphere_file(tmp_path, "winding", lambda lon, lat, t: (
        turn * RADIUS * np.cos(np.radians(lat)) + 0 * lon + 0 * t, 0 * lat), np.arange(-180.0, 179.5, 1.0)), "winding")
    wound = compute_ld(winding, starts[:2], 1, LDSettings(tau=3.0, p="arclength", **TIGHT), t0=1.0)
    assert not wound.escaped.any() and (wound.time == 3.0).all()
    np.testing.assert_allclose(wound.end_state[:, 0] - starts[:2, 0], 3 * 360.0, rtol=1e-13)  # measured 4e-16
    # measured 2.2e-13 (node latitudes: the interpolation exact there)
    np.testing.assert_allclose(wound.ld, 3 * turn * RADIUS * np.cos(np.radians(starts[:2, 1])) * DAY / 1000.0, rtol=1e-12)
    # a first column repeated at 360 is the same global grid (the repeated column unread)
    closed = sphere_system(sphere_file(tmp_path, "closed", equatorial_rotation, np.arange(0.0, 360.5, 1.0)), "closed")
    assert closed.source.x_global and closed.source.x_grid == joined.source.x_grid
    # a window across the seam, written either way round: the same circles, inside it
    for window in ([-40.0, 40.0], [320.0, 40.0]):
        windowed = sphere_system(tmp_path / "global.nc", "windowed", window={"lon": window, "lat": [-50.0, 50.0]})
        inside = compute_ld(windowed, starts[:3], 1, LDSettings(tau=days, p="arclength", **TIGHT), t0=1.0)
        assert not windowed.stop_flags(inside.end_state, 1.0, 1.0 + days)["left_data"].any()
        np.testing.assert_allclose(lon_difference(inside.end_state[:, 0], expected[:3, 0]), 0.0, atol=3e-6)  # 7.8e-7
    # the same field on a grid with a gap (0 .. 350 E) stops at its edge, lon 0 (existing behaviour)
    edged = sphere_system(sphere_file(tmp_path, "edged", equatorial_rotation, np.arange(0.0, 350.5, 1.0)), "edged")
    assert not edged.source.x_global
    stopped = compute_ld(edged, starts[:1], 1, LDSettings(tau=days, p="arclength", **TIGHT), t0=1.0)
    assert edged.stop_flags(stopped.end_state, 1.0, 1.0 + days)["left_data"].all()
    assert abs(lon_difference(stopped.end_state[0, 0], 0.0)) < 1e-9  # measured 1.3e-11 degrees past it


def test_ambiguous_longitude_grids_are_refused(tmp_path):
    with pytest.raises(ConfigError, match=r"velocity_data\.x': longitude coordinate 'lon' covers 361 degrees"):
        sphere_system(sphere_file(tmp_path, "over", polar_rotation, np.arange(0.0, 361.5, 1.0)), "over")
    with pytest.raises(ConfigError, match=r"velocity_data\.x': longitude coordinate 'lon' covers the sphere but for a gap"):
        sphere_system(sphere_file(tmp_path, "odd", polar_rotation, np.arange(0.0, 359.9, 0.7)), "odd")
    with pytest.raises(ConfigError, match=r"window\.lon': expected an interval .* dateline of a regional grid"):
        sphere_system(sphere_file(tmp_path, "regional", polar_rotation, np.arange(150.0, 210.5, 1.0)), "regional",
                      window={"lon": [170.0, -170.0], "lat": [-10.0, 10.0]})


def test_the_ring_buffer_wraps_round_the_seam(tmp_path):
    # Periodicity, an identity: in the buffer of a global grid the padding west of the first node
    # is the last node, and the closing column (first + 360) and the padding beyond it are the
    # first two nodes, land-filled values included (a coast at the seam: land on 358..1 E, 0..10 N).
    lon = np.arange(0.0, 359.5, 1.0)
    path = write_velocity_file(tmp_path / "coast.nc", equatorial_rotation, lon, np.arange(-20.0, 20.01, 1.0),
                               np.arange(0.0, 6.01, 1.0), names=("lon", "lat"), time_units="days since 2000-01-01",
                               land=lambda X, Y: ((X >= 358) | (X <= 1)) & (Y >= 0) & (Y <= 10))
    window = sphere_system(path, "coast").data_window(1.0, 2.0)
    nt, ny, nx = (int(v) for v in window.buffer[:3])
    assert nx == len(lon) + 1 and window.x_grid == (0.0, 1.0, len(lon) + 1)
    # the kernel's layout (velocity_data.read_window): (y, x, time, u/v) on the padded grid
    u = window.buffer[16:16 + (ny + 2) * (nx + 2) * (nt + 2) * 2].reshape(ny + 2, nx + 2, nt + 2, 2)[..., 0]
    np.testing.assert_array_equal(u[:, 0], u[:, nx - 1])  # node 359 west of node 0
    np.testing.assert_array_equal(u[:, nx], u[:, 1])  # the closing column: node 0
    np.testing.assert_array_equal(u[:, nx + 1], u[:, 2])  # node 1 beyond it
    assert window.land[:, 0].any() and np.array_equal(window.land[:, -1], window.land[:, 0])


def test_a_sphere_map_with_latitude_first_is_the_same_map(tmp_path):
    # The section's axes in either order (lon, lat) or (lat, lon): the same trajectories, so the same
    # LD and FTLE, transposed. The flow is the rotation about the axis through (lon 0, lat 0), an
    # isometry of the sphere: its FTLE in great-circle lengths is 0 (closed form) but for the
    # differences' error, in either order; the longitude rate depends on the latitude, so a metric
    # that took a longitude for the latitude (at the start or the end points) is far from 0.
    data = sphere_system(sphere_file(tmp_path, "equatorial", equatorial_rotation, np.arange(-60.0, 60.01, 1.0)),
                         "equatorial")
    lon = {"name": "lon", "range": [-20.0, 20.0], "points": 9}
    lat = {"name": "lat", "range": [-30.0, 30.0], "points": 7}
    entry = {"system": "equatorial", "t0": 3.0, "tau": 2.0, "p": 0.5, "ftle": True,
             "integrator": {"rtol": 1e-10, "atol": 1e-10}}
    config = validate_config({"systems": {"equatorial": data.spec},
                              "ld_maps": {"lon_lat": {**entry, "section": {"axes": [lon, lat]}},
                                          "lat_lon": {**entry, "section": {"axes": [lat, lon]}}}})
    lon_lat, lat_lon = (compute_ld_map(parameters_from_config(config, "ld", name), None, show_progress=False)
                        for name in ("lon_lat", "lat_lon"))
    assert lon_lat.ld_forward.dims == ("lon", "lat") and lat_lon.ld_forward.dims == ("lat", "lon")
    for label in ("forward", "backward"):
        # measured: LD and FTLE equal bit for bit (the same trajectories and differences)
        np.testing.assert_allclose(lat_lon[f"ld_{label}"].values.T, lon_lat[f"ld_{label}"].values, rtol=1e-12)
        np.testing.assert_allclose(lat_lon[f"ftle_{label}"].values.T, lon_lat[f"ftle_{label}"].values, rtol=0, atol=1e-12)
        for dataset in (lon_lat, lat_lon):
            assert dataset[f"ftle_defined_{label}"].values.all()
            # measured: |FTLE| <= 2.8e-3 per day (the differences' error over 5 and 10 degrees); a
            # metric read from the wrong coordinate gives 0.03 (start points) to 0.096 (end points)
            assert np.abs(dataset[f"ftle_{label}"].values).max() < 1e-2, label
