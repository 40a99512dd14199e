"""The FSLE of velocity data on the sphere (longitude, latitude in degrees; u, v east and north in
m/s; time in days): separations are great-circle distances in km, against closed forms.

- Solid-body rotation about the axis through (lon 0, lat 0), a turn in 4 days
  (u = -omega R sin(lat) cos(lon), v = omega R sin(lon)): an isometry of the sphere, so every
  neighbour keeps its great-circle distance from its point (closed form) and a final separation
  1 % above the initial one is never reached. The points run from the equator to 82 N, where the
  chart's degrees of longitude are 1 / cos(82) = 7 times shorter in km than at the start: measured
  in lon/lat degrees an east-west pair would separate sevenfold.
- The same rotation on a global grid through the poles (integrated as 3-D positions): in 1.6 days
  the points run 144 degrees, from the equator over the north pole and down the other side, where
  their longitudes jump by 180 degrees and wrap at the seam; still no separation grows (closed
  form), nor one of points started at the pole itself.
- Zonal flow sheared in latitude, d lon/dt = W + A (lat - 45 degrees) (radians a day), on a grid
  joined across its seam: each particle keeps its latitude and its longitude runs linearly, so
  every neighbour's great-circle distance is known at every time (closed form: the neighbours'
  start points by the navigation formula for a destination at a bearing, their distances by the
  haversine formula, neither the code's vector algebra), and the first time one reaches the final
  separation is found by scipy's brentq. The section straddles the seam (179 to -179).
"""

import math

import numpy as np
import pytest
from scipy.optimize import brentq
from support.gridded import write_velocity_file

import ldpipe
from ldpipe.errors import ConfigError

RADIUS = 6.371e6  # m, the default earth_radius
R_KM = RADIUS / 1000.0
DAY = 86400.0


def sphere_system(path, name):
    return ldpipe.system(name=name, velocity_data={"path": str(path), "coordinates": "sphere"})


# --- solid-body rotation about an equatorial axis ----------------------------------------------------

OMEGA = 2 * math.pi / 4  # radians a day


def equatorial_rotation(lon, lat, t):
    lam, phi = np.radians(lon), np.radians(lat)
    return (-OMEGA / DAY * RADIUS * np.sin(phi) * np.cos(lam) + 0 * t,
            OMEGA / DAY * RADIUS * np.sin(lam) + 0 * lat + 0 * t)


def test_a_rotation_keeps_great_circle_separations_up_to_high_latitude(tmp_path):
    # all round the sphere in longitude (near the pole a circle's longitude swings far), up to 86 N
    path = write_velocity_file(tmp_path / "rotation.nc", equatorial_rotation, np.arange(0.0, 359.0, 2.0),
                               np.arange(-10.0, 86.01, 2.0), np.arange(-1.0, 2.01, 1.0), names=("lon", "lat"),
                               time_units="days since 2000-01-01")
    system = sphere_system(path, "equatorial_rotation")
    # 0.8 days: 72 degrees along circles through (90 E, 0) and its neighbours, up to 82 N
    result = ldpipe.fsle(system, section=ldpipe.section(lon=(85.0, 95.0, 5), lat=(0.0, 10.0, 5)),
                         initial_separation=20.0, final_separation=20.2, max_time=0.8,
                         integrator={"rtol": 1e-10, "atol": 1e-10})
    for label in ("forward", "backward"):
        assert result[f"fsle_defined_{label}"].values.all()
        # closed form: an isometry, no separation grows (measured: within 1 % at a 2-degree grid's
        # interpolant, whose velocity gradient is the rotation's to its second order)
        assert not result[f"fsle_reached_{label}"].values.any(), label
        assert not result[f"fsle_{label}"].values.any()
    assert result.attrs["separation_units"] == "km"


@pytest.mark.compiles  # the polar grid's flow-map engine, which no other test loads
def test_a_rotation_over_the_pole_keeps_great_circle_separations(tmp_path):
    path = write_velocity_file(tmp_path / "globe.nc", equatorial_rotation, np.arange(0.0, 359.0, 2.0),
                               np.arange(-90.0, 90.01, 2.0), np.arange(-3.0, 3.01, 1.0), names=("lon", "lat"),
                               time_units="days since 2000-01-01")
    system = sphere_system(path, "equatorial_rotation_globe")
    assert system.engine_name == "velocity_data_polar"
    settings = {"initial_separation": 20.0, "final_separation": 20.2, "integrator": {"rtol": 1e-10, "atol": 1e-10}}
    # 144 degrees along circles through the poles and near them; starts at the pole too
    for section, days in ((ldpipe.section(lon=(85.0, 95.0, 3), lat=(0.0, 10.0, 3)), 1.6),
                          (ldpipe.section(lon=(0.0, 90.0, 2), lat=(88.0, 90.0, 2)), 1.0)):
        result = ldpipe.fsle(system, section=section, max_time=days, **settings)
        for label in ("forward", "backward"):
            assert result[f"fsle_defined_{label}"].values.all()
            # closed form: an isometry (measured: separations within 1 % on the 2-degree grid)
            assert not result[f"fsle_reached_{label}"].values.any(), (label, section)


# --- zonal flow sheared in latitude, across the seam --------------------------------------------------

W, A, LAT_C = 0.1, 2.0, 45.0  # radians a day, radians a day per radian, degrees


def zonal_rate(lat):
    """d lon/dt in radians a day at ``lat`` (degrees)."""
    return W + A * np.radians(lat - LAT_C)


def sheared_zonal(lon, lat, t):
    return RADIUS * np.cos(np.radians(lat)) * zonal_rate(lat) / DAY + 0 * lon + 0 * t, 0 * lon + 0 * lat + 0 * t


def destination(lon, lat, bearing, distance):
    """The navigation formula (degrees; ``bearing`` clockwise from north, ``distance`` in km)."""
    phi, lam, b, d = math.radians(lat), math.radians(lon), math.radians(bearing), distance / R_KM
    phi2 = math.asin(math.sin(phi) * math.cos(d) + math.cos(phi) * math.sin(d) * math.cos(b))
    lam2 = lam + math.atan2(math.sin(b) * math.sin(d) * math.cos(phi), math.cos(d) - math.sin(phi) * math.sin(phi2))
    return math.degrees(lam2), math.degrees(phi2)


def haversine(a, b):
    (l1, p1), (l2, p2) = np.radians(a), np.radians(b)
    h = math.sin((p2 - p1) / 2) ** 2 + math.cos(p1) * math.cos(p2) * math.sin((l2 - l1) / 2) ** 2
    return 2 * R_KM * math.asin(math.sqrt(h))


def closed_form_time(lon, lat, delta0, delta_f, direction):
    """The first time a neighbour of (lon, lat) is ``delta_f`` km away (module docstring)."""
    def at(point, t):
        return point[0] + direction * math.degrees(zonal_rate(point[1]) * t), point[1]

    times = []
    for bearing in (90.0, 270.0, 0.0, 180.0):
        neighbour = destination(lon, lat, bearing, delta0)
        def gap(t, neighbour=neighbour):
            return haversine(at((lon, lat), t), at(neighbour, t)) - delta_f
        # the separation grows monotonically from delta0 (the pairs shear apart): bracket its root
        if gap(10.0) > 0:
            times.append(brentq(gap, 0.0, 10.0, xtol=1e-14, rtol=1e-14))
    return min(times)


@pytest.fixture(scope="module")
def zonal(tmp_path_factory):
    # joined across the seam (-180 .. 178 in steps of 2)
    path = write_velocity_file(tmp_path_factory.mktemp("zonal") / "zonal.nc", sheared_zonal,
                               np.arange(-180.0, 179.0, 2.0), np.arange(30.0, 60.01, 1.0), np.arange(-6.0, 6.01, 1.0),
                               names=("lon", "lat"), time_units="days since 2000-01-01")
    return sphere_system(path, "sheared_zonal")


def test_sheared_zonal_flow_across_the_seam_is_its_closed_form(zonal):
    delta0, delta_f = 5.0, 20.0
    section = ldpipe.section(lon=(178.0, 182.0, 5), lat=(40.0, 50.0, 3))
    result = ldpipe.fsle(zonal, section=section, initial_separation=delta0, final_separation=delta_f,
                         max_time=5.0, interval=0.02, integrator={"rtol": 1e-11, "atol": 1e-11})
    lon, lat = np.meshgrid(result.lon.values, result.lat.values, indexing="ij")
    for label, direction in (("forward", 1), ("backward", -1)):
        assert result[f"fsle_reached_{label}"].values.all(), label
        tau = np.vectorize(lambda x, y: closed_form_time(x, y, delta0, delta_f, direction))(lon, lat)
        # measured: 1.4e-4 relative, the same at checks 0.01 days apart: the data interpolant's
        # error in the shear (u sampled every degree of latitude), not the placement between checks
        np.testing.assert_allclose(result[f"fsle_time_{label}"].values, tau, rtol=5e-4, err_msg=label)
        np.testing.assert_allclose(result[f"fsle_{label}"].values, math.log(delta_f / delta0) / tau, rtol=5e-4)
        # the deformation gradient in the local (east, north) frame is the shear [[1, s], [0, 1]],
        # s = +-A cos(lat) t at the check t where the final separation is reached (the first multiple
        # of the interval past tau): the Cauchy-Green tensor's largest eigenvalue
        # 1 + s^2/2 + |s| sqrt(1 + s^2/4), its eigenvector at the angle atan((lambda - 1) / s) from east
        s = direction * A * np.cos(np.radians(lat)) * np.ceil(tau / 0.02) * 0.02
        largest = 1 + s**2 / 2 + np.abs(s) * np.sqrt(1 + s**2 / 4)
        expected = np.arctan((largest - 1) / s)
        # (measured: 2.8e-5)
        np.testing.assert_allclose(np.sin(result[f"fsle_angle_{label}"].values - expected), 0.0, atol=1.5e-4,
                                   err_msg=label)
    # the seam: the flow does not depend on the longitude, so the points at 180 and 182 (= -178)
    # have the FSLE of those at 178 (an identity; measured 1e-13)
    np.testing.assert_allclose(result.fsle_forward.values[-1], result.fsle_forward.values[0], rtol=1e-9)


def test_sphere_fsle_arguments_are_km_and_its_axes_lon_lat(zonal):
    # the default initial separation: the smaller spacing (1 degree) as km of arc
    result = ldpipe.fsle(zonal, section=ldpipe.section(lon=(0.0, 4.0, 3), lat=(40.0, 41.0, 2)),
                         final_separation=500.0, max_time=0.1)
    assert result.attrs["initial_separation"] == pytest.approx(math.pi * R_KM / 180.0)
    with pytest.raises(ConfigError, match=r"ldpipe.fsle: argument 'final_separation': 30000.0; on the sphere a "
                                          r"great-circle distance in km, expected less than half its circumference"):
        ldpipe.fsle(zonal, section=ldpipe.section(lon=(0.0, 4.0, 3), lat=(40.0, 41.0, 2)),
                    final_separation=30000.0, max_time=0.1)


def test_a_sphere_fsle_section_is_longitude_and_latitude(tmp_path):
    # 3-D data on the sphere: a section of longitude and depth has no great-circle separations
    from support.gridded import write_velocity_file_3d

    path = write_velocity_file_3d(tmp_path / "three.nc", lambda x, y, z, t: (0.1 + 0 * x, 0 * y, 0 * z),
                                  np.arange(0.0, 10.01, 1.0), np.arange(40.0, 45.01, 1.0), np.array([0.0, 10.0, 20.0]),
                                  np.arange(0.0, 2.01, 1.0), names=("lon", "lat", "depth"),
                                  time_units="days since 2000-01-01")
    system = ldpipe.system(name="three", velocity_data={"path": str(path), "coordinates": "sphere", "w": "w"})
    with pytest.raises(ConfigError, match=r"^ldpipe.fsle: section: system 'three' is on the sphere: the FSLE's "
                                          r"section axes must be its longitude 'lon' and latitude 'lat', got "
                                          r"\['lon', 'depth'\]"):
        ldpipe.fsle(system, section=ldpipe.section(lon=(2.0, 4.0, 3), depth=(5.0, 15.0, 3), fixed={"lat": 41.0}),
                    final_separation=10.0, max_time=1.0)


def test_a_curvilinear_sphere_grid_s_state_is_longitude_latitude(tmp_path):
    # its source's x, y are the grid's index dimensions (xi, eta); the state, and the FSLE's
    # section, are longitude and latitude (the FSLE on such a grid was checked against the sheared
    # zonal flow's closed form outside the suite: its engine is compiled by no other test)
    from ldpipe.core.structures.fsle import sphere_columns
    from ldpipe.data.curvilinear import curvilinear_dataset

    i, j = np.meshgrid(np.arange(0, 9), np.arange(0, 7), indexing="xy")
    lon, lat = 170.0 + 0.5 * (0.9 * i - 0.4 * j), 38.0 + 0.5 * (0.4 * i + 0.9 * j)
    curvilinear_dataset(sheared_zonal, lon, lat, np.arange(0.0, 2.01, 1.0), sphere=True,
                        time_units="days since 2000-01-01").to_netcdf(tmp_path / "curved.nc")
    system = sphere_system(tmp_path / "curved.nc", "curved")
    assert (system.source.x, system.source.y) == ("xi", "eta")
    assert sphere_columns(system, ["lat", "lon"]) == [0, 1]
