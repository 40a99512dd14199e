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
- The same eddy centred on the equator and at 60 N, on grids whose cells are alike in km (the
  longitudes' spacing 1 / cos(60) times wider at 60 N): a rotation of the sphere carries one onto
  the other, so their vortices have the same radius in km and the same convexity deficiency
  (symmetry), up to the grids' differences within a cell.
- A field whose level sets are ellipses in the Lambert azimuthal equal-area projection about
  (0, 80 N), 800 by 150 km with the long axis east: convex on the sphere (in the projection, where
  areas are the sphere's), but in the longitude-latitude chart a banana (a great circle heading
  east bows poleward there). Its coherent boundary is the ellipse of its level, its deficiency
  ~0 and its area pi A B (-ln level) in km2 (closed forms); measured in the chart it would stop at
  a small inner contour.
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


def eddy_velocity_at(centre):
    """u, v (m/s) of the eddy (module docstring) about the unit vector ``centre``."""
    def velocity(lon, lat, t):
        p = unit(lon, lat)
        a = 0.5 * np.sum((p - centre.reshape((3,) + (1,) * (p.ndim - 1))) ** 2, axis=0)  # 1 - cos g, no cancellation
        # at the centre, where the formula is 0/0, its limit R w0 / 2
        speed = RADIUS * W0 * np.where(a > 0, EPS * -np.expm1(-a / EPS) / np.where(a > 0, a * (2 - a), 1.0), 0.5)
        turn = np.cross(centre, p, axis=0) * speed
        lam, phi = np.radians(lon), np.radians(lat)
        east = -np.sin(lam) * turn[0] + np.cos(lam) * turn[1]
        north = -np.sin(phi) * np.cos(lam) * turn[0] - np.sin(phi) * np.sin(lam) * turn[1] + np.cos(phi) * turn[2]
        return east + 0 * t, north + 0 * t
    return velocity


def eddy_vorticity(lon, lat):
    """The closed form (module docstring), per day."""
    p = unit(lon, lat)
    a = 0.5 * np.sum((p - CENTRE.reshape((3,) + (1,) * (p.ndim - 1))) ** 2, axis=0)  # 1 - cos g
    return W0 * DAY * np.exp(-a / EPS)


#: u, v (m/s) of the eddy: R w0 eps (1 - exp(-(1 - cos g)/eps)) / sin^2 g times c x p, east and north.
eddy_velocity = eddy_velocity_at(CENTRE)


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
    # 2 pi R^2 (1 - cos g) (measured: 0.054 % apart)
    cap = 2 * math.pi * (RADIUS / 1000) ** 2 * (1 - math.cos(g.mean()))
    assert result.area.attrs["units"] == "km2"
    assert float(result.area[0]) == pytest.approx(cap, rel=0.002)


def test_the_eddy_at_the_equator_and_at_60n_is_the_same_vortex(tmp_path):
    found = {}
    for lat_c in (0.0, 60.0):
        stretch = 1 / math.cos(math.radians(lat_c))  # cells alike in km
        path = write_velocity_file(tmp_path / f"eddy_{lat_c:g}.nc", eddy_velocity_at(unit(0.0, lat_c)),
                                   np.arange(-4.0 * stretch, 4.0 * stretch + 0.01, 0.1 * stretch),
                                   np.arange(lat_c - 3.5, lat_c + 3.51, 0.1), np.arange(-1.0, 3.01, 1.0),
                                   names=("lon", "lat"), time_units="days since 2000-01-01")
        section = ldpipe.section(lon=(-2.0 * stretch, 2.03 * stretch, 31), lat=(lat_c - 2.0, lat_c + 2.03, 31))
        result = ldpipe.lavd(sphere_system(path, f"eddy_{lat_c:g}"), section=section, duration=2.0, interval=0.2,
                             integrator={"rtol": 1e-10, "atol": 1e-10})
        assert result.sizes["vortex"] == 1
        boundary = unit(result.boundary_lon.values, result.boundary_lat.values)
        radius = RADIUS / 1000 * np.arccos(np.clip(unit(0.0, lat_c) @ boundary, -1, 1)).mean()
        found[lat_c] = (radius, float(result.area[0]), float(result.convexity_deficiency[0]))
    cell = 0.1 * math.pi * RADIUS / 1000 / 180  # km
    (r0, a0, d0), (r60, a60, d60) = found.values()
    # symmetry (measured: radii 131.41 and 131.24 km, 0.015 cells apart; areas 0.26 % apart;
    # deficiencies 0.00264 and 0.00265)
    assert abs(r0 - r60) < 0.1 * cell, found
    assert a60 == pytest.approx(a0, rel=0.01)
    assert abs(d0 - d60) < 2e-4 and max(d0, d60) < 0.01, found


def test_a_vortex_convex_on_the_sphere_is_measured_in_its_projection():
    from ldpipe.core.sphere import tangent_plane
    from ldpipe.core.structures.lavd import _area, _hull_area, coherent_vortices

    radius, a, b, centre = RADIUS / 1000, 800.0, 150.0, np.array([0.0, 80.0])
    lon, lat = np.arange(-50.0, 50.01, 2.0), np.arange(74.0, 86.01, 0.25)  # 51 x 49
    plane = tangent_plane(np.stack(np.meshgrid(lon, lat, indexing="ij"), axis=-1), centre, radius)
    field = np.exp(-(plane[..., 0] ** 2 / a**2 + plane[..., 1] ** 2 / b**2))
    defined = np.ones(field.shape, dtype=bool)
    parameters = {"levels": 100, "convexity_deficiency": 0.01, "min_points": 8}

    def projection(ring, at):
        return tangent_plane(ring, np.asarray(at), radius)

    (vortex,) = coherent_vortices(field, defined, (lon, lat), parameters, projection)
    level = vortex["level"]
    ring = tangent_plane(vortex["boundary"], centre, radius)
    # the closed-form ellipse of its level (measured: within 0.6 % of -ln(level); the contour is
    # linear between grid lines of 2 degrees of longitude), deficiency and area (measured 0.0011, 0.24 %)
    np.testing.assert_allclose(ring[:, 0] ** 2 / a**2 + ring[:, 1] ** 2 / b**2, -math.log(level), rtol=0.03)
    assert vortex["convexity_deficiency"] < 0.005
    assert vortex["area"] == pytest.approx(math.pi * a * b * -math.log(level), rel=0.01)
    # every level down to where the contour leaves the grid is an ellipse: the boundary is far out
    # (measured: level 0.09, the last closed in the grid), not stopped by its convexity
    assert level < 0.2
    # in the chart the same ring is a banana (measured deficiency 0.46), and the chart's measure
    # would have kept only an inner contour (measured: level 0.87)
    chart = vortex["boundary"]
    assert (_hull_area(chart) - _area(chart)) / _area(chart) > 0.1
    (small,) = coherent_vortices(field, defined, (lon, lat), parameters)
    assert small["level"] > 0.5


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
