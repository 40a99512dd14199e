"""Velocity data on a global grid that reaches the poles, against closed forms: trajectories cross them.

- Solid-body rotation about the axis through (lon 0, lat 0), a turn in 4 days
  (u = -omega R sin(lat) cos(lon), v = omega R sin(lon)), and about the axis through (lon 0, lat 30),
  sampled on global 1 degree grids with a row at each pole (-90 .. 90) and with the last rows half
  a spacing from them (-89.5 .. 89.5). The circles about the first axis through a pole cross both
  poles, about the second one of them: a point is after t the start rotated by omega t about the
  axis (closed form, Rodrigues' formula), having run omega R sin(angle to the axis) t (its arc
  length, closed form); its M_1 is the integral of |u| + |v| along the closed-form circle (scipy's
  quad of the closed-form integrand). The rotation is an isometry: its FTLE in great-circle lengths
  is 0 everywhere (closed form), at the poles too.
- Land on every node south of 85 S: the circle through both poles stops entering its first land
  cell, at 84 S on the meridian 270 after 264 degrees (closed form), flagged, its exit time the
  time it moved.
- The rows the window adds beyond a pole are the grid's own half-way round with u and v negated
  (an identity of the chart continued past the pole).
- A grid whose last latitude is neither at the pole nor half a spacing from it, one past the pole,
  and one with an odd number of longitudes, are refused by name. The tripolar example grid's
  geometry is checked by identities (its north fold is joined in test_folded.py).
"""

import math

import numpy as np
import pytest
from scipy.integrate import quad
from support.gridded import write_velocity_file

from ldpipe.config import validate_config
from ldpipe.config.parameters import parameters_from_config
from ldpipe.core.maps.assembly import compute_ld_map
from ldpipe.data.tripolar import tripolar_grid
from ldpipe.engine import LDSettings, compute_ld
from ldpipe.errors import ConfigError
from ldpipe.systems import make_system
from ldpipe.systems.velocity_data.curvilinear import folded_row

TIGHT = {"rtol": 1e-11, "atol": 1e-11}
RADIUS, OMEGA = 6.371e6, 2 * math.pi / (4 * 86400.0)  # m, rad/s: a turn in 4 days
DAY = 86400.0
LON = np.arange(0.0, 359.5, 1.0)
GRIDS = {"pole_rows": np.arange(-90.0, 90.01, 1.0), "half_spacing": np.arange(-89.5, 89.51, 1.0)}


def axis(tilt):
    """The rotation's axis: the unit vector at longitude 0 and latitude ``tilt`` (degrees)."""
    return np.array([math.cos(math.radians(tilt)), 0.0, math.sin(math.radians(tilt))])


def unit(points):
    lam, phi = np.radians(points[..., 0]), np.radians(points[..., 1])
    return np.stack([np.cos(phi) * np.cos(lam), np.cos(phi) * np.sin(lam), np.sin(phi)], axis=-1)


def rotation(tilt):
    """The field omega a x X of the rotation about ``axis(tilt)`` as (u, v): u = omega R (sin(tilt)
    cos(lat) - cos(tilt) sin(lat) cos(lon)), v = omega R cos(tilt) sin(lon); tilted, u varies at
    first order in the distance from the pole, so every row near it counts."""
    sin_a, cos_a = math.sin(math.radians(tilt)), math.cos(math.radians(tilt))

    def field(lon, lat, t):
        lam, phi = np.radians(lon), np.radians(lat)
        return (OMEGA * RADIUS * (sin_a * np.cos(phi) - cos_a * np.sin(phi) * np.cos(lam)) + 0 * t,
                OMEGA * RADIUS * cos_a * np.sin(lam) + 0 * lat + 0 * t)
    return field


def rotated(starts, days, tilt):
    """The start points (lon, lat in degrees) rotated by OMEGA * days about ``axis(tilt)`` (Rodrigues' formula)."""
    angle, a, r = OMEGA * days * DAY, axis(tilt), unit(starts)
    r = (r * math.cos(angle) + np.cross(a, r) * math.sin(angle) + np.outer(r @ a, a) * (1 - math.cos(angle)))
    return np.column_stack([np.degrees(np.arctan2(r[:, 1], r[:, 0])), np.degrees(np.arctan2(r[:, 2], np.hypot(r[:, 0], r[:, 1])))])


def great_circle_degrees(a, b):
    """The angle (degrees) between points (lon, lat) a and b."""
    return np.degrees(2 * np.arcsin(0.5 * np.linalg.norm(unit(a) - unit(b), axis=1)))


#: Each rotation's starts: on circles through both poles (the equatorial axis: the great circle
#: x = 0, a start at a pole), or through one (30 degrees: at 60 degrees from the axis, as the north
#: pole is, and at 120, as the south pole is), one 1 degree from the poles' circle and two others.
STARTS = {0.0: np.array([[90.0, 0.0], [0.0, 90.0], [89.0, 0.0], [100.0, -30.0], [200.0, 40.0], [10.0, 5.0]]),
          30.0: np.array([[0.0, -30.0], [180.0, 30.0], [0.0, 90.0], [0.0, -90.0], [1.0, -31.0], [45.0, 60.0]])}


@pytest.fixture(scope="module")
def grids(tmp_path_factory):
    folder = tmp_path_factory.mktemp("poles")
    return {(name, tilt): write_velocity_file(folder / f"{name}_{tilt:g}.nc", rotation(tilt), LON, lat,
                                              np.arange(0.0, 4.01, 0.5), names=("lon", "lat"),
                                              time_units="days since 2000-01-01")
            for name, lat in GRIDS.items() for tilt in STARTS}


def polar_system(path, name="globe"):
    return make_system(name, {"velocity_data": {"path": str(path), "coordinates": "sphere"}})


def m_1(start, days, tilt):
    """M_1 along the closed-form circle: the integral of |u| + |v| (m/s times days), by quad."""
    field = rotation(tilt)

    def integrand(t):
        lon, lat = rotated(start[None], t, tilt)[0]
        u, v = field(lon, lat, 0.0)
        return abs(u) + abs(v)
    return quad(integrand, 0.0, days, limit=400, epsabs=1e-10, epsrel=1e-12)[0]


@pytest.mark.compiles  # the polar engine (3-D positions), loaded by this file's tests alone
@pytest.mark.parametrize("tilt", sorted(STARTS))
@pytest.mark.parametrize("grid", sorted(GRIDS))
def test_rotation_crosses_the_poles(grids, grid, tilt):
    system = polar_system(grids[grid, tilt])
    assert system.poles == ((0, 0) if grid == "pole_rows" else (1, 1))
    starts = STARTS[tilt]
    days = 3.2  # 288 degrees: the circles through the poles cross both, or theirs
    speed = OMEGA * RADIUS * np.sqrt(1.0 - (unit(starts) @ axis(tilt)) ** 2)
    for direction, t0 in ((1, 0.4), (-1, 3.6)):
        arc = compute_ld(system, starts, direction, LDSettings(tau=days, p="arclength", **TIGHT), t0=t0)
        assert not arc.failed.any() and (arc.time == days).all()
        flags = system.stop_flags(arc.end_state, t0, t0 + direction * days)
        assert not flags["left_data"].any() and not flags["on_land"].any()
        errors = great_circle_degrees(arc.end_state, rotated(starts, direction * days, tilt))
        # measured: <= 1.6e-6 degrees (the cubic interpolation's error on the 1 degree grid)
        assert errors.max() < 4e-6, errors
        # measured: relative error <= 3.4e-8 (a trajectory that stopped at the last latitude, as
        # before, lost 40 % or more of its arc length)
        np.testing.assert_allclose(arc.ld, speed * days * DAY / 1000.0, rtol=1e-7)
        assert arc.end_state[:, 0].min() >= 0.0 and arc.end_state[:, 0].max() < 360.0  # the grid's convention
    m1 = compute_ld(system, starts, 1, LDSettings(tau=days, p=1.0, **TIGHT), t0=0.4)
    # measured: relative error <= 3.3e-8 (the basis turns fast near the pole: its distances run
    # as states make the steps follow it)
    np.testing.assert_allclose(m1.ld, [m_1(start, days, tilt) for start in starts], rtol=1e-7)


@pytest.mark.compiles
def test_rotation_has_zero_ftle_round_the_pole(grids):
    # A map round the north pole (lat 80 .. 89.5) whose circles cross it within the time; the
    # rotation's FTLE is 0 (closed form) but for the differences' error. End points on either side
    # of the pole are 180 degrees apart in longitude: differenced as longitudes they would give an
    # exponent of order ln(huge) / tau.
    system = polar_system(grids["half_spacing", 0.0])
    section = {"axes": [{"name": "lon", "range": [80.0, 100.0], "points": 9},
                        {"name": "lat", "range": [80.0, 89.5], "points": 6}]}
    entry = {"system": "globe", "t0": 1.0, "tau": 0.5, "p": "arclength", "ftle": True,
             "integrator": {"rtol": 1e-10, "atol": 1e-10}, "section": section}
    config = validate_config({"systems": {"globe": system.spec}, "ld_maps": {"pole": entry}})
    dataset = compute_ld_map(parameters_from_config(config, "ld", "pole"), None, show_progress=False)
    for label in ("forward", "backward"):
        assert dataset[f"ftle_defined_{label}"].values.all()
        # measured: |FTLE| <= 1.3e-3 per day (the differences' error over 2.5 and 1.9 degrees, at the edges)
        assert np.abs(dataset[f"ftle_{label}"].values).max() < 5e-3, label
        ends = np.column_stack([dataset[f"end_lon_{label}"].values.ravel(), dataset[f"end_lat_{label}"].values.ravel()])
        lon, lat = np.meshgrid(dataset.lon.values, dataset.lat.values, indexing="ij")
        expected = rotated(np.column_stack([lon.ravel(), lat.ravel()]), 0.5 if label == "forward" else -0.5, 0.0)
        assert great_circle_degrees(ends, expected).max() < 4e-6
    # the trajectories did cross the pole: the end points are on the far side
    assert (dataset.end_lon_forward.values > 180.0).any()


def test_grids_that_do_not_close_round_the_pole_are_refused(tmp_path):
    near = write_velocity_file(tmp_path / "near.nc", rotation(0.0), LON, np.arange(-89.7, 89.8, 1.0), np.arange(0.0, 2.01),
                               names=("lon", "lat"), time_units="days since 2000-01-01")
    with pytest.raises(ConfigError, match=r"velocity_data\.y': latitude coordinate 'lat' ends 0\.3 degrees from the "
                                          r"south pole.*neither at the pole nor half a spacing"):
        polar_system(near)
    past = write_velocity_file(tmp_path / "past.nc", rotation(0.0), LON, np.arange(-90.0, 91.01, 1.0), np.arange(0.0, 2.01),
                               names=("lon", "lat"), time_units="days since 2000-01-01")
    with pytest.raises(ConfigError, match=r"velocity_data\.y': latitude coordinate 'lat' passes the north pole"):
        polar_system(past)
    odd = write_velocity_file(tmp_path / "odd.nc", rotation(0.0), np.arange(0.0, 359.9, 360.0 / 359), GRIDS["pole_rows"],
                              np.arange(0.0, 2.01), names=("lon", "lat"), time_units="days since 2000-01-01")
    with pytest.raises(ConfigError, match=r"velocity_data\.x': the global grid reaches a pole, but its 359 longitudes"):
        polar_system(odd)


@pytest.mark.compiles
def test_land_round_a_pole_stops_trajectories_that_cross_the_other(tmp_path):
    # Land on every node south of 85 S: the circle through both poles (start lon 90 on the equator)
    # crosses the north pole, runs down the meridian 270 and stops entering the first cell with a
    # land corner, at 84 S (closed form: the circle's point at angle 264 degrees, 264 / 90 days
    # on); the circle that stays north of 45 degrees runs on, unflagged.
    path = write_velocity_file(tmp_path / "cap.nc", rotation(0.0), LON, GRIDS["pole_rows"], np.arange(0.0, 4.01, 0.5),
                               names=("lon", "lat"), time_units="days since 2000-01-01", land=lambda X, Y: Y <= -85.0)
    system = polar_system(path)
    starts = STARTS[0.0][[0, 4]]
    result = compute_ld(system, starts, 1, LDSettings(tau=3.2, p="arclength", **TIGHT), t0=0.4)
    flags = system.stop_flags(result.end_state, 0.4, 3.6)
    assert flags["on_land"].tolist() == [True, False] and not flags["left_data"].any()
    # measured: 270 E exactly, 84 S within 1.5e-9 degrees (the kernel stops it just past the cell's
    # edge); the arc length within 2e-11 (on the meridian u = 0 and v = omega R at every node)
    np.testing.assert_allclose(result.end_state[0], [270.0, -84.0], atol=1e-8)
    np.testing.assert_allclose(result.ld[0], OMEGA * RADIUS * (264.0 / 360.0) * 4 * DAY / 1000.0, rtol=1e-9)
    # the time it stopped (the time it moved, a state whose kink the step control locates): measured 4e-11
    np.testing.assert_allclose(result.time, [264.0 / 90.0, 3.2], rtol=1e-9)
    # backward the circle runs the other way, down meridian 90 straight to the cap (84 S after 84 degrees)
    back = compute_ld(system, starts, -1, LDSettings(tau=3.2, p="arclength", **TIGHT), t0=3.6)
    np.testing.assert_allclose(back.time, [84.0 / 90.0, 3.2], rtol=1e-9)
    np.testing.assert_allclose(back.end_state[0], [90.0, -84.0], atol=1e-8)
    # a map's exit times are those times, its flags the same (no search for a crossing afterwards)
    section = {"axes": [{"name": "lon", "range": [88.0, 92.0], "points": 3},
                        {"name": "lat", "range": [-2.0, 2.0], "points": 3}]}
    entry = {"system": "globe", "t0": 0.4, "tau": 3.2, "p": "arclength", "integrator": {"rtol": 1e-11, "atol": 1e-11},
             "directions": "forward", "section": section}
    config = validate_config({"systems": {"globe": system.spec}, "ld_maps": {"cap": entry}})
    dataset = compute_ld_map(parameters_from_config(config, "ld", "cap"), None, show_progress=False)
    assert dataset.on_land_forward.values.all()
    np.testing.assert_allclose(dataset.exit_time_forward.values[1, 1], 264.0 / 90.0, rtol=1e-9)


@pytest.mark.parametrize("grid", sorted(GRIDS))
def test_the_rows_beyond_a_pole_are_the_grid_half_way_round_with_u_and_v_negated(grids, grid):
    # An identity of the chart continued past the pole (ldpipe.systems.velocity_data.polar): the row
    # at 90 + d is the row at 90 - d half-way round the ring, both components negated; so is the
    # row at -90 - d. Read in the kernel's buffer (y, x, time, u/v on the padded grid).
    system = polar_system(grids[grid, 30.0])
    window = system.data_window(1.0, 2.0)
    nt, ny, nx = (int(value) for value in window.buffer[:3])
    first, step = window.y_grid[:2]
    data = window.buffer[16:16 + (ny + 2) * (nx + 2) * (nt + 2) * 2].reshape(ny + 2, nx + 2, nt + 2, 2)
    latitudes = first + step * np.arange(-1, ny + 1)  # the padded rows'
    assert latitudes[0] < -90.0 - step and latitudes[-1] > 90.0 + step  # real rows beyond each pole, padding too
    columns = np.arange(-1, nx + 1)  # the padded columns, window column 0 the grid's first longitude
    for row, lat in enumerate(latitudes):
        if abs(lat) <= 90.0:
            continue
        mirror = np.flatnonzero(np.isclose(latitudes, np.sign(lat) * 180.0 - lat))[0]
        across = (columns + len(LON) // 2) % len(LON) + 1  # the padded column half-way round
        np.testing.assert_array_equal(data[row, :, :, :], -data[mirror, across, :, :])


def test_a_tripolar_grid_has_its_fold():
    # ldpipe.data.tripolar's ORCA-like grid, by identities of its construction: the cap's first row
    # is the circle of the fold latitude at the columns' own longitudes (|w| = a); its last row, the
    # fold, lies on the segment between the cap's poles through the North Pole (w real: longitude
    # 0 or 180) and maps onto itself reversed; the cap's rows and columns cross at right angles
    # (bipolar coordinates through a conformal map), to the differences' error.
    lon, lat = tripolar_grid(columns=72, spacing=5.0, fold_latitude=60.0, cap_rows=6, south=-75.0)
    cap = 27  # rows -75 .. 55 below the cap
    np.testing.assert_allclose(lat[cap], 60.0, atol=1e-12)
    np.testing.assert_allclose(lon[cap], lon[0], atol=1e-12)
    np.testing.assert_allclose(np.abs(np.sin(np.radians(lon[-1]))), 0.0, atol=1e-12)
    fold = unit(np.stack([lon[-1], lat[-1]], axis=-1))
    np.testing.assert_allclose(fold, fold[::-1], atol=1e-12)
    points = unit(np.stack([lon, lat], axis=-1))
    along_i = points[cap + 1:-1, 2:] - points[cap + 1:-1, :-2]  # centred differences inside the cap
    along_j = points[cap + 2:, 1:-1] - points[cap:-2, 1:-1]
    cosine = np.einsum("...k,...k", along_i, along_j) / np.linalg.norm(along_i, axis=-1) / np.linalg.norm(along_j, axis=-1)
    interior = np.abs(np.sin(np.radians(lon[cap + 1:-1, 1:-1]))) > 0.3  # away from the cap's poles (0, 180)
    # measured: |cos| <= 0.010 there (centred differences on a 5 degree grid); a cap not quite
    # conformal (the stereographic radius taken as the half colatitude, not its tangent) is at 0.033
    assert np.abs(cosine[interior]).max() < 0.02
    assert folded_row(lon, lat) == "last" and folded_row(lon[:-1], lat[:-1]) == ""  # the row below does not fold
