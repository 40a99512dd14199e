"""The guide's entries for each model's files read files written in that model's layout.

docs/guide/velocity_data.md gives an entry per model convention (ROMS, NEMO with and without its
mesh's metrics, HYCOM); each is
taken from the page as written and made into a system in a folder holding a file named and laid
out as that model writes it (one level), written here from one C-grid of ldpipe.data.curvilinear:
a rotated-pole grid (spacing 1 degree, tilted 30 degrees) whose u faces carry c times the
great-circle distance between the centres they separate and whose v faces carry 0, so that the
index velocity is c (closed form, as in test_c_grid.py). The same faces in ROMS's and in NEMO's
layout read by their two entries give the same trajectories bit for bit (an invariant: the same
numbers reach the same kernel), and they move along the frame's latitude circle at c h degrees a
second (the closed form, to the coordinates' interpolation between the centres).
"""

import math

import numpy as np
import pytest
import xarray as xr
import yaml

from ldpipe.config import validate_config
from ldpipe.data.curvilinear import c_grid_dataset, rotated_pole_grid, write_dataset
from ldpipe.engine import LDSettings, compute_ld
from ldpipe.systems import make_system

from support.workflow import documented_yaml

pytestmark = [pytest.mark.compiles, pytest.mark.xdist_group("c_grid_engine")]  # test_c_grid.py's engine
RADIUS, H, C, TILT = 6371000.0, 1.0, 1e-5, 30.0


def documented_entry(marker: str, name: str) -> dict:
    return yaml.safe_load(documented_yaml(marker))["systems"][name]["velocity_data"]


@pytest.fixture(scope="module")
def roms_faces():
    lon, lat = rotated_pole_grid((12.0, 8.0), H, TILT)
    phi = np.radians(np.arange(-8.0, 8.0 + H / 2, H))

    def u_face(X, Y, T):
        return np.broadcast_to(C * 2 * RADIUS * np.arcsin(np.cos(phi)[:, None] * math.sin(math.radians(H) / 2)),
                               np.broadcast_shapes(X.shape, T.shape))

    land = lambda i, j: (i == 20) & (j == 3)  # noqa: E731 (a land cell, so the mask is read)
    return c_grid_dataset(u_face, lambda X, Y, T: 0 * X + 0 * T, lon, lat, np.arange(0.0, 4e4 + 1, 1e4),
                          sphere=True, land=land)


def frame_point(frame):
    """(lon, lat) of rotated-pole frame points (lam', phi'), degrees (ldpipe.data.curvilinear's turn)."""
    lam, phi = np.radians(frame[:, 0]), np.radians(frame[:, 1])
    r = np.array([np.cos(phi) * np.cos(lam), np.cos(phi) * np.sin(lam), np.sin(phi)])
    b = math.radians(TILT)
    x, z = math.cos(b) * r[0] + math.sin(b) * r[2], -math.sin(b) * r[0] + math.cos(b) * r[2]
    return np.column_stack([np.degrees(np.arctan2(r[1], x)), np.degrees(np.arcsin(z))])


def test_the_roms_and_nemo_entries_read_their_models_layouts_alike(roms_faces, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    faces = roms_faces.rename(time="ocean_time")
    roms = faces.rename(xi="xi_rho", eta="eta_rho").assign(
        u=faces.u.rename(eta="eta_u"), v=faces.v.rename(xi="xi_v"))
    write_dataset(roms, "roms_his_0001.nc")
    # NEMO: u east of each T point and v north of it, on the T points' arrays (outer faces appended),
    # with NEMO's names
    outer_u = xr.full_like(faces.u.isel(xi_u=[0]), 9.0)
    outer_v = xr.full_like(faces.v.isel(eta_v=[0]), -9.0)
    nemo = xr.Dataset({
        "uo": xr.concat([faces.u, outer_u], "xi_u").rename(xi_u="x", eta="y", ocean_time="time_counter"),
        "vo": xr.concat([faces.v, outer_v], "eta_v").rename(eta_v="y", xi="x", ocean_time="time_counter"),
        "tmask": faces.mask_rho.rename(eta="y", xi="x").drop_vars(["lon_rho", "lat_rho"]),
    }, coords={"nav_lon": (("y", "x"), faces.lon_rho.values, {"units": "degrees_east"}),
               "nav_lat": (("y", "x"), faces.lat_rho.values, {"units": "degrees_north"})})
    write_dataset(nemo, "nemo_1d_0001.nc")

    systems = {name: make_system(name, {"velocity_data": documented_entry(marker, name)})
               for marker, name in (("roms_his_*.nc", "roms"), ("nemo_c_grid:", "nemo_c_grid"))}
    frame = np.array([[-6.0, -4.0], [0.0, 5.0], [5.0, 0.0]])
    starts, t = frame_point(frame), 2e4
    settings = LDSettings(tau=t, p="arclength", rtol=1e-10, atol=1e-10)
    results = {name: compute_ld(system, starts, 1, settings, t0=1e4) for name, system in systems.items()}
    np.testing.assert_array_equal(results["roms"].end_state, results["nemo_c_grid"].end_state)
    np.testing.assert_array_equal(results["roms"].ld, results["nemo_c_grid"].ld)
    # measured 4.3e-6 degrees: the coordinates' cubic between centres 1 degree apart, mapping the
    # starts and the ends (test_c_grid.py's 1.2e-6 on a grid twice as fine)
    np.testing.assert_allclose(results["roms"].end_state, frame_point(frame + [C * H * t, 0.0]), rtol=0, atol=2e-5)
    assert systems["roms"].engine_name == "velocity_data_c_grid"


def test_the_hycom_entry_reads_hycoms_names(tmp_path, monkeypatch):
    # HYCOM's served layout: water_u, water_v east and north on (time, lat, lon), hours since 2000;
    # a uniform eastward 0.1 m/s: dlon/dt = u / (R cos lat) in degrees (closed form)
    monkeypatch.chdir(tmp_path)
    lat, lon = np.arange(20.0, 30.1, 0.5), np.arange(-80.0, -69.9, 0.5)
    shape = (5, lat.size, lon.size)
    attrs = {"units": "m/s"}
    hycom = xr.Dataset({"water_u": (("time", "lat", "lon"), np.full(shape, 0.1), attrs),
                        "water_v": (("time", "lat", "lon"), np.zeros(shape), attrs)},
                       coords={"time": ("time", np.arange(5.0), {"units": "hours since 2000-01-01 00:00:00"}),
                               "lat": ("lat", lat, {"units": "degrees_north"}),
                               "lon": ("lon", lon, {"units": "degrees_east"})})
    write_dataset(hycom, "hycom_surface_0001.nc")
    system = make_system("hycom", {"velocity_data": documented_entry("hycom_surface_*.nc", "hycom")})
    result = compute_ld(system, np.array([[-75.0, 25.0]]), 1, LDSettings(tau=2.0, p=0.5, rtol=1e-10, atol=1e-10),
                        t0=1.0)
    # the start on a row of nodes, where the velocity in degrees is the nodes' own: measured exact
    # to rounding
    dlon = math.degrees(0.1 * 2 * 3600.0 / (6371000.0 * math.cos(math.radians(25.0))))
    np.testing.assert_allclose(result.end_state, [[-75.0 + dlon, 25.0]], rtol=0, atol=1e-10)


def test_the_conformal_grid_is_orthogonal_and_its_corners_are_its_cells_corners():
    # x + iy = w + d sin(k w) turned and shifted is analytic in w = a + ib, so by Cauchy-Riemann
    # its i and j directions are at right angles at every node (closed form); centred differences
    # see it to O(h^2): measured |cos| <= 1.6e-4 at h = 0.05 (the bent "curvilinear" grid's 0.31)
    from ldpipe.data.curvilinear import plane_grid

    def worst_cosine(kind):
        x, y = plane_grid(kind, 0.05)
        di = np.stack([x[1:-1, 2:] - x[1:-1, :-2], y[1:-1, 2:] - y[1:-1, :-2]])
        dj = np.stack([x[2:, 1:-1] - x[:-2, 1:-1], y[2:, 1:-1] - y[:-2, 1:-1]])
        return np.abs((di * dj).sum(0) / np.hypot(*di) / np.hypot(*dj)).max()

    assert worst_cosine("conformal") < 6e-4
    assert worst_cosine("curvilinear") > 0.1
    # the corners (offset 0.5) of an affine grid are the means of the four centres around them
    # (closed form), one fewer each way
    x, y = plane_grid("rotated", 0.1)
    corners = plane_grid("rotated", 0.1, offset=0.5)
    for centres, corner in zip((x, y), corners):
        mean = (centres[:-1, :-1] + centres[1:, :-1] + centres[:-1, 1:] + centres[1:, 1:]) / 4
        np.testing.assert_allclose(corner, mean, rtol=0, atol=1e-14)


def test_the_nemo_entry_with_its_mesh_metrics_reads_them(roms_faces, tmp_path, monkeypatch):
    # NEMO's layout with its mesh's metrics, exact on the rotated-pole grid: e1t = R cos(phi') h and
    # e2t = R h at the T points, e2u = R h on the u faces, e1v = R cos(phi' + h/2) h on the v faces
    # (h in radians). A u face's flux is then u e2u and a cell's area e1t e2t, so the index velocity
    # of row phi' is c 2 asin(cos(phi') sin(h/2)) / (cos(phi') h) (closed form), along the frame's
    # latitude circle. The outer column of e2u and row of e1v hold 1 m, refused if read.
    monkeypatch.chdir(tmp_path)
    faces = roms_faces
    outer_u = xr.full_like(faces.u.isel(xi_u=[0]), 9.0)
    outer_v = xr.full_like(faces.v.isel(eta_v=[0]), -9.0)
    h = math.radians(H)
    phi = np.radians(np.arange(-8.0, 8.0 + H / 2, H))[:, None] + 0 * faces.lon_rho.values
    e1v = RADIUS * np.cos(phi + h / 2) * h
    e2u = np.full(phi.shape, RADIUS * h)
    e1v[-1], e2u[:, -1] = 1.0, 1.0
    metres = {"units": "m"}
    nemo = xr.Dataset({
        "uo": xr.concat([faces.u, outer_u], "xi_u").rename(xi_u="x", eta="y", time="time_counter"),
        "vo": xr.concat([faces.v, outer_v], "eta_v").rename(eta_v="y", xi="x", time="time_counter"),
        "tmask": faces.mask_rho.rename(eta="y", xi="x").drop_vars(["lon_rho", "lat_rho"]),
        "e1t": (("y", "x"), RADIUS * np.cos(phi) * h, metres), "e2t": (("y", "x"), np.full(phi.shape, RADIUS * h), metres),
        "e2u": (("y", "x"), e2u, metres), "e1v": (("y", "x"), e1v, metres),
    }, coords={"nav_lon": (("y", "x"), faces.lon_rho.values, {"units": "degrees_east"}),
               "nav_lat": (("y", "x"), faces.lat_rho.values, {"units": "degrees_north"})})
    write_dataset(nemo, "nemo_mesh_1d_0001.nc")
    validate_config(yaml.safe_load(documented_yaml("nemo_mesh_1d_*.nc")))  # the block as a configuration
    system = make_system("nemo_metrics", {"velocity_data": documented_entry("nemo_mesh_1d_*.nc", "nemo_metrics")})
    assert system.grid_attributes() == {"grid_metrics": "dx: e1t, dy: e2t, u_face: e2u, v_face: e1v",
                                        "metric_tolerance": 0.05}
    frame = np.array([[-6.0, -4.0], [0.0, 5.0], [5.0, 0.0]])
    t = 2e4
    cos_phi = np.cos(np.radians(frame[:, 1]))
    rate = C * 2 * np.arcsin(cos_phi * math.sin(h / 2)) / (cos_phi * h)  # index per second
    result = compute_ld(system, frame_point(frame), 1, LDSettings(tau=t, p="arclength", rtol=1e-10, atol=1e-10),
                        t0=1e4)
    end = frame_point(frame + np.column_stack([rate * H * t, 0 * rate]))
    # measured 4.3e-6 degrees, as the entries without metrics (the coordinates' cubic between centres):
    # on this grid the exact metrics and the great-circle distances differ by 1e-7, so what this
    # checks is the documented entry, NEMO's layout of the metrics and their units on the sphere
    # (the metrics' effect is tests/data/test_c_grid_metrics.py's)
    np.testing.assert_allclose(result.end_state, end, rtol=0, atol=2e-5)
