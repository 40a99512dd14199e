"""The LAVD of velocity data on the sphere (longitude, latitude in degrees, u, v east and north in
m/s, time in days) against closed forms. The vorticity on the sphere is
(1 / (R cos lat)) (dv/dlon - d(u cos lat)/dlat) (lon, lat in radians), per day here; the region's
mean weights each particle by cos(lat) of its start point, the area of its start cell.

- Solid-body rotation about the polar axis, u = Omega R cos(lat), v = 0: its vorticity is
  2 Omega sin(lat) exactly; each particle runs along its parallel, so its vorticity is constant and
  the LAVD over T is T |2 Omega sin(lat0) - mean|, the mean of 2 Omega sin(lat) over the start grid
  weighted by cos(lat).
- A steady eddy on the sphere about the centre c (unit vector), its vorticity
  w0 exp(-(1 - cos g)/eps) at the angle g from c: Gaussian in the chord |p - c| = sqrt(2 (1 - cos g))
  (the planar Gaussian exp(-r^2/rho^2) to leading order in rho/R, eps = rho^2 / (2 R^2)). By Stokes
  the circulation round the cap of angle g is the integral of the vorticity over it,
  2 pi R^2 w0 eps (1 - exp(-(1 - cos g)/eps)), so the azimuthal speed is
  R w0 eps (1 - exp(-(1 - cos g)/eps)) / sin g, about c (the velocity that times c x p / sin g).
  Each particle keeps its g and its vorticity: the LAVD is T |w(g0) - mean|, its maximum at c, and
  the coherent boundary lies between the closed-form circles g of its own level and g* where
  w(g*) = mean (as in test_lavd.py).
- The example currents (ldpipe.data.example): the jet's streamfunction psi(x, y, t) on the local
  plane x = R cos(lat_c)(lon - lon_c), y = R (lat - lat_c) gives u = -psi_y, v = psi_x, and so on
  the sphere, with d/dlon = R cos(lat_c) d/dx and d/dlat = R d/dy,
  vorticity = (cos(lat_c) / cos(lat)) psi_xx + psi_yy + tan(lat) u / R
  with psi_xx = v_x, psi_yy = -u_y from the closed-form derivatives of the jet.
"""

import math

import numpy as np
import pytest
from support.gridded import write_velocity_file

import ldpipe
from ldpipe.core.structures.lavd import data_vorticity

DAY = 86400.0
RADIUS = 6.371e6
OMEGA = 2 * math.pi / (20 * DAY)  # a turn in 20 days, as tests/data/test_sphere.py


def sphere_system(path, name):
    return ldpipe.system(name=name, velocity_data={"path": str(path), "x": "lon", "y": "lat",
                                                   "coordinates": "sphere"})


# --- solid-body rotation ---------------------------------------------------------------------------

def polar_rotation(lon, lat, t):
    return OMEGA * RADIUS * np.cos(np.radians(lat)) + 0 * lon + 0 * t, 0 * lat + 0 * t


@pytest.fixture(scope="module")
def rotation(tmp_path_factory):
    # all round the sphere (joined across the seam), so the particles never reach an edge
    path = write_velocity_file(tmp_path_factory.mktemp("rotation") / "rotation.nc", polar_rotation,
                               np.arange(0.0, 359.5, 1.0), np.arange(-60.0, 60.01, 1.0), np.arange(0.0, 6.01, 1.0),
                               names=("lon", "lat"), time_units="days since 2000-01-01")
    return sphere_system(path, "polar_rotation")


def test_the_data_vorticity_of_solid_body_rotation_is_two_omega_sin_lat(rotation):
    # across the seam too (359.5 to 0: the grid is joined there) and in the other convention
    points = np.column_stack([np.concatenate([np.linspace(3.3, 351.7, 60), [359.5, 359.99995, 0.00003, -10.4]]),
                              np.concatenate([np.linspace(-55.2, 57.9, 60), [12.3, -33.3, 41.0, 22.2]])])
    exact = 2 * OMEGA * DAY * np.sin(np.radians(points[:, 1]))  # per day
    # measured: 1.9e-5 of 2 Omega (the interpolant of cos(lat) on a 1-degree grid)
    np.testing.assert_allclose(data_vorticity(rotation, points, 1.5), exact, rtol=0, atol=1e-4 * 2 * OMEGA * DAY)


def test_the_data_vorticity_of_solid_body_rotation_on_uneven_latitudes(tmp_path):
    # the rectilinear grid's interpolant, latitudes 0.5 to 2 degrees apart: again 2 Omega sin(lat)
    # (measured: 5.3e-5 of 2 Omega)
    steps = np.random.default_rng(7).uniform(0.4, 1.6, 90)
    lat = -60.0 + 120.0 * np.concatenate([[0.0], np.cumsum(steps)]) / steps.sum()
    path = write_velocity_file(tmp_path / "uneven.nc", polar_rotation, np.arange(-60.0, 90.01, 1.0), lat,
                               np.arange(0.0, 6.01, 1.0), names=("lon", "lat"), time_units="days since 2000-01-01")
    system = sphere_system(path, "polar_rotation_uneven")
    assert system.engine_name == "velocity_data_rectilinear2_sphere"
    points = np.column_stack([np.linspace(-50.3, 81.7, 60), np.linspace(-55.2, 57.9, 60)])
    exact = 2 * OMEGA * DAY * np.sin(np.radians(points[:, 1]))
    np.testing.assert_allclose(data_vorticity(system, points, 1.5), exact, rtol=0, atol=2e-4 * 2 * OMEGA * DAY)


def test_lavd_of_solid_body_rotation_is_the_closed_form_with_area_weights(rotation):
    section = ldpipe.section(lon=(100.0, 140.0, 9), lat=(-50.0, 55.0, 22))
    result = ldpipe.lavd(rotation, section=section, duration=3.0, t0=1.0, interval=0.5)
    lon, lat = np.meshgrid(result.lon.values, result.lat.values, indexing="ij")
    omega = 2 * OMEGA * DAY * np.sin(np.radians(lat))
    mean = np.average(omega, weights=np.cos(np.radians(lat)))
    assert result.lavd_defined.values.all()
    # measured: 2.0e-5 of T 2 Omega; the unweighted mean is 0.012 of 2 Omega off the weighted one
    np.testing.assert_allclose(result.lavd.values, 3.0 * np.abs(omega - mean), rtol=0,
                               atol=1e-4 * 3.0 * 2 * OMEGA * DAY)


# --- a steady Gaussian eddy at mid-latitude ---------------------------------------------------------

CENTRE_LON, CENTRE_LAT = 30.0, 45.0
W0, RHO = 1e-5, 100e3  # peak vorticity (1/s) and e-folding radius (m)
EPS = RHO**2 / (2 * RADIUS**2)


def unit(lon, lat):
    lam, phi = np.radians(lon), np.radians(lat)
    return np.array([np.cos(phi) * np.cos(lam), np.cos(phi) * np.sin(lam), np.sin(phi)])


CENTRE = unit(CENTRE_LON, CENTRE_LAT)


def eddy_vorticity(lon, lat):
    """The closed form (module docstring), per day."""
    p = unit(lon, lat)
    a = 0.5 * np.sum((p - CENTRE.reshape((3,) + (1,) * (p.ndim - 1))) ** 2, axis=0)  # 1 - cos g
    return W0 * DAY * np.exp(-a / EPS)


def eddy_velocity(lon, lat, t):
    """u, v (m/s) of the eddy: R w0 eps (1 - exp(-(1 - cos g)/eps)) / sin^2 g times c x p, east and north."""
    p = unit(lon, lat)
    a = 0.5 * np.sum((p - CENTRE.reshape((3,) + (1,) * (p.ndim - 1))) ** 2, axis=0)  # 1 - cos g, from the chord: no cancellation
    # at the centre, where the formula is 0/0, its limit R w0 / 2
    speed = RADIUS * W0 * np.where(a > 0, EPS * -np.expm1(-a / EPS) / np.where(a > 0, a * (2 - a), 1.0), 0.5)
    turn = np.cross(CENTRE, p, axis=0) * speed
    lam, phi = np.radians(lon), np.radians(lat)
    east = -np.sin(lam) * turn[0] + np.cos(lam) * turn[1]
    north = -np.sin(phi) * np.cos(lam) * turn[0] - np.sin(phi) * np.sin(lam) * turn[1] + np.cos(phi) * turn[2]
    return east + 0 * t, north + 0 * t


EDDY_T = 4.0  # days: about 1.5 turns of its core


@pytest.fixture(scope="module")
def eddy(tmp_path_factory):
    lon = np.arange(CENTRE_LON - 5.0, CENTRE_LON + 5.01, 0.1)
    lat = np.arange(CENTRE_LAT - 3.5, CENTRE_LAT + 3.51, 0.1)
    path = write_velocity_file(tmp_path_factory.mktemp("eddy") / "eddy.nc", eddy_velocity, lon, lat,
                               np.arange(-1.0, EDDY_T + 2.01, 1.0), names=("lon", "lat"),
                               time_units="days since 2000-01-01")
    system = sphere_system(path, "sphere_eddy")
    # no start point on the centre, where the velocity's formula is 0/0; latitude the first axis
    section = ldpipe.section(lat=(CENTRE_LAT - 2.0, CENTRE_LAT + 2.03, 41), lon=(CENTRE_LON - 3.0, CENTRE_LON + 3.07, 41))
    return system, ldpipe.lavd(system, section=section, duration=EDDY_T, interval=0.2,
                               integrator={"rtol": 1e-10, "atol": 1e-10})


def test_the_data_vorticity_of_the_eddy_is_the_closed_form(eddy):
    system, _ = eddy
    points = np.column_stack([np.linspace(27.2, 32.9, 50), np.linspace(46.7, 43.1, 50)])
    # measured: 0.0018 of w0 (cells of 0.1 degree, some 11 km, rho = 100 km)
    assert np.abs(data_vorticity(system, points, 1.0) - eddy_vorticity(*points.T)).max() < 0.005 * W0 * DAY


def test_lavd_of_the_eddy_is_the_closed_form_and_its_vortex_the_cap(eddy):
    _, result = eddy
    assert result.lavd.dims == ("lat", "lon")
    lat, lon = np.meshgrid(result.lat.values, result.lon.values, indexing="ij")
    omega = eddy_vorticity(lon, lat)
    mean = np.average(omega, weights=np.cos(np.radians(lat)))
    assert result.lavd_defined.values.all()
    error = np.abs(result.lavd.values - EDDY_T * np.abs(omega - mean)).max() / (EDDY_T * W0 * DAY)
    assert error < 0.005, error  # measured: 0.0013 of T w0

    assert result.sizes["vortex"] == 1
    centre = unit(float(result.centre_lon[0]), float(result.centre_lat[0]))
    cell = math.radians(float(result.lat[1] - result.lat[0]))  # a cell's side along the meridian (rad)
    # measured: 0.008 cells from the closed-form centre (the quadratic through the 3 x 3 block)
    assert math.acos(min(1.0, float(CENTRE @ centre))) < 0.05 * cell
    g_zero = math.acos(1 + EPS * math.log(mean / (W0 * DAY)))  # w(g*) = mean
    level = float(result.level[0])
    g_level = math.acos(1 + EPS * math.log(level / (EDDY_T * W0 * DAY) + mean / (W0 * DAY)))
    boundary = unit(result.boundary_lon.values, result.boundary_lat.values)
    g = np.arccos(np.clip(CENTRE @ boundary, -1, 1))
    # measured (in cells): g from 11.958 to 12.217; g of its level 11.967, g* 12.525
    assert g.min() > g_level - 0.2 * cell and g.max() < g_zero, (g.min(), g.max(), g_level, g_zero)
    assert g_zero - g.mean() < 0.6 * cell
    assert float(result.convexity_deficiency[0]) < 0.01
    # the area on the sphere (km2) of the polygon against that of the cap of its mean angle,
    # 2 pi R^2 (1 - cos g) (measured: 0.055 % apart)
    cap = 2 * math.pi * (RADIUS / 1000) ** 2 * (1 - math.cos(g.mean()))
    assert result.area.attrs["units"] == "km2"
    assert float(result.area[0]) == pytest.approx(cap, rel=0.002)


def test_the_area_of_a_longitude_latitude_rectangle_is_the_closed_form():
    # R^2 (lon2 - lon1) (sin lat2 - sin lat1), lon in radians: exact for the loop integral's
    # trapezoidal rule (d lon = 0 along meridians, sin lat constant along parallels); the
    # boundary's columns in the order of a section given latitude first
    from ldpipe.core.structures.lavd import sphere_area

    lat = np.linspace(20.0, 50.0, 31)
    lon_lat = np.concatenate([np.column_stack([np.full(31, -10.0), lat]), np.column_stack([np.full(31, 15.0), lat[::-1]])])
    ring = np.concatenate([lon_lat, lon_lat[:1]])[:, ::-1]
    exact = 6371.0**2 * math.radians(25.0) * (math.sin(math.radians(50.0)) - math.sin(math.radians(20.0)))
    assert sphere_area(ring, 6371.0, lon_column=1) == pytest.approx(exact, rel=1e-12)


# --- the example currents ----------------------------------------------------------------------------

def jet_vorticity(lon, lat, days):
    """The example jet's vorticity on the sphere (module docstring), per day, from its closed-form
    derivatives: u_y and v_x of u = U (s + 2 s th W), v = U L s W_x, s = sech^2(y/L), th = tanh(y/L),
    W = sum eps_n cos(k_n (x - c_n t))."""
    from ldpipe.data.example import EARTH_RADIUS, LAT_C, LON_C, WAVELENGTH, WAVES, L, U, jet_velocity

    x = EARTH_RADIUS * math.cos(math.radians(LAT_C)) * np.radians(lon - LON_C)
    y = EARTH_RADIUS * np.radians(lat - LAT_C)
    s, th = 1.0 / np.cosh(y / L) ** 2, np.tanh(y / L)
    phases = [(eps, 2 * np.pi * n / WAVELENGTH, x - c * days * DAY) for eps, n, c in WAVES]
    w = sum(eps * np.cos(k * z) for eps, k, z in phases)
    w_xx = sum(-eps * k**2 * np.cos(k * z) for eps, k, z in phases)
    u_y = U / L * (-2 * s * th + 2 * w * s * (s - 2 * th**2))
    v_x = U * L * s * w_xx
    u = jet_velocity(lon, lat, days * DAY)[0]
    phi = np.radians(lat)
    return DAY * (math.cos(math.radians(LAT_C)) / np.cos(phi) * v_x - u_y + np.tan(phi) * u / EARTH_RADIUS)


def example_system(directory, resolution: float, days: float):
    from ldpipe.data.example import write_example

    path = write_example(directory / f"example_{round(resolution * 1000)}.nc", days=days, resolution=resolution)
    return ldpipe.system(name=f"example_{round(resolution * 1000)}", velocity_data={"path": str(path),
                                                                                  "coordinates": "sphere"})


@pytest.fixture(scope="module")
def examples(tmp_path_factory):
    """The example on its own 0.25-degree grid over 8 days, and on a 0.125-degree grid over 3."""
    directory = tmp_path_factory.mktemp("example")
    return {0.25: example_system(directory, 0.25, 8.0), 0.125: example_system(directory, 0.125, 3.0)}


def test_the_example_s_data_vorticity_is_the_jet_s(examples):
    # across the jet and its meanders at t = 2.3 days: the error of the interpolant's derivative,
    # second order in the cell (measured 0.043 and 0.010 per day of a largest 1.54: 4.3 times
    # smaller); the term tan(lat) u / R alone is up to 0.0125 per day, so without it the finer
    # grid's error would not fall below it
    points = np.column_stack([np.linspace(-68.3, -47.9, 60), np.linspace(34.1, 40.7, 60)])
    exact = jet_vorticity(points[:, 0], points[:, 1], 2.3)
    errors = [np.abs(data_vorticity(examples[cell], points, 2.3) - exact).max() for cell in (0.25, 0.125)]
    assert errors[1] < 0.025 and errors[0] / errors[1] > 3, errors


def test_lavd_of_the_example_is_its_vorticity_deviation_along_the_trajectories(examples):
    """The LAVD against its definition computed independently: the same trajectories (the flow map
    in steps of the LAVD's interval), the jet's closed-form vorticity along them, its mean weighted
    by cos(lat) of the start points, and the trapezoidal rule."""
    from ldpipe.core.trajectories import FlowSettings, flow_map
    from ldpipe.data.example import EARTH_RADIUS, LAT_C, L

    example = examples[0.25]
    t0, duration, interval = 1.0, 6.0, 0.25
    section = ldpipe.section(lon=(-66.0, -52.0, 57), lat=(33.0, 42.0, 37))
    result = ldpipe.lavd(example, section=section, duration=duration, t0=t0, interval=interval)
    assert result.lavd_defined.values.all()  # the section is east of the coast
    lon, lat = np.meshgrid(result.lon.values, result.lat.values, indexing="ij")
    states = np.column_stack([lon.ravel(), lat.ravel()])
    weights = np.cos(np.radians(states[:, 1]))
    total, previous = np.zeros(len(states)), None
    for step in range(round(duration / interval) + 1):
        if step:
            states = flow_map(example, states, interval, FlowSettings(), t0=t0 + interval * (step - 1)).end_state
        omega = jet_vorticity(states[:, 0], states[:, 1], t0 + interval * step)
        deviation = np.abs(omega - np.average(omega, weights=weights))
        if previous is not None:
            total += 0.5 * interval * (previous + deviation)
        previous = deviation
    # measured: 0.089 of a largest 8.1; at most the duration times twice the data vorticity's error
    # (0.043 per day where sampled above: 0.52)
    assert np.abs(result.lavd.values.ravel() - total).max() < 0.25

    # the jet's velocity, and so its vorticity, falls as sech^2(y/L) away from its axis (below
    # 1 % of the peak beyond 3 L): the vortices are on the meandering jet, none beyond
    assert result.sizes["vortex"] >= 1
    y = EARTH_RADIUS * np.radians(result.centre_lat.values - LAT_C)
    assert np.all(np.abs(y) < 3 * L), y / L
