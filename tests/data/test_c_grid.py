"""Velocity data on an Arakawa C-grid (ROMS's layout): a coast is a wall, against closed forms.

On ldpipe.data.curvilinear's grid rotated by 30 degrees (spacing h = 0.1, affine: its metric
exact), u = 0.05 and v = 0.03 m/s along the grid's i and j on every open face, land an L (the
centres i >= 20, and i >= 14 with j >= 16: a coast with a corner). In index space U0 = u / h =
0.5 and V0 = v / h = 0.3 per second; in a cell whose far face is closed the index velocity falls
linearly to 0 at it (kernels/staggered_velocity.py), so a trajectory approaches the wall as
exp(-U0 t) and never reaches it. Piecewise closed forms follow (the test docstrings say which).
"""

import math

import numpy as np
import pytest
from scipy.integrate import quad

from ldpipe.config import validate_config
from ldpipe.config.parameters import parameters_from_config
from ldpipe.core.maps.assembly import compute_ld_map
from ldpipe.core.trajectories import COMPLETED, FlowSettings, flow_map
from ldpipe.data.curvilinear import (ROTATION, c_grid_dataset, double_gyre_c_grid_dataset, plane_grid,
                                     rotated_pole_grid, write_dataset)
from ldpipe.engine import LDSettings, compute_ld
from ldpipe.errors import ConfigError
from ldpipe.systems import make_system

#: The C-grid's kernel and engine are loaded by these tests alone, and by test_c_grid_metrics and
#: test_model_conventions, in the same xdist group so one worker compiles them.
pytestmark = [pytest.mark.compiles, pytest.mark.xdist_group("c_grid_engine")]
H, U0, V0 = 0.1, 0.5, 0.3
ENTRY = {"x": "x_rho", "y": "y_rho", "components": "grid", "mask": "mask_rho"}


def coast(i, j):
    return (i >= 20) | ((i >= 14) & (j >= 16))


@pytest.fixture(scope="module")
def c_grid(tmp_path_factory):
    # the faces by land as a model's output may leave them: u as the field gives it, v missing; only
    # the mask and the missing values close them
    x, y = plane_grid("rotated", H)
    dataset = c_grid_dataset(lambda X, Y, T: 0.05 + 0 * X + 0 * T, lambda X, Y, T: 0.03 + 0 * X + 0 * T, x, y,
                             np.arange(0.0, 200.01, 10.0), land=coast, land_faces="unmasked")
    path = write_dataset(dataset, tmp_path_factory.mktemp("c_grid") / "c_grid.nc")
    return path, make_system("c_grid", {"velocity_data": {"path": str(path), **ENTRY}})


def physical(indices):
    """The grid's affine map from node indices (i, j) to (x, y) (ldpipe.data.curvilinear.plane_grid)."""
    a, b = -1.4 + H * indices[:, 0], -1.2 + H * indices[:, 1]
    return np.column_stack([1.0 + math.cos(ROTATION) * a - math.sin(ROTATION) * b,
                            0.5 + math.sin(ROTATION) * a + math.cos(ROTATION) * b])


def corner_path(t):
    """Index position and velocity at time t of the start (13.2, 14.9), in cell (13, 15): diagonal
    until i = 13.5 (t2 = 0.6, j = 15.08); then east at U0 below the closed face j = 15.5, where
    1 - (j - 14.5) = 0.42 exp(-V0 (t - t2)); from i = 18.5 (t3 = 10.6) slowing towards the wall
    i = 19.5: i = 19.5 - exp(-U0 (t - t3))."""
    t2, t3 = 0.6, 10.6
    if t <= t2:
        return np.array([13.2 + U0 * t, 14.9 + V0 * t]), np.array([U0, V0])
    decay = 0.42 * math.exp(-V0 * (t - t2))
    j, dj = 15.5 - decay, V0 * decay
    if t <= t3:
        return np.array([13.5 + U0 * (t - t2), j]), np.array([U0, dj])
    slow = math.exp(-U0 * (t - t3))
    return np.array([19.5 - slow, j]), np.array([U0 * slow, dj])


def test_a_trajectory_into_the_coasts_corner_follows_the_closed_form(c_grid):
    _, system = c_grid
    start = physical(np.array([[13.2, 14.9]]))
    for tau in (5.0, 15.0):
        result = compute_ld(system, start, 1, LDSettings(tau=tau, p="arclength", rtol=1e-11, atol=1e-11), t0=10.0)
        position, _ = corner_path(tau)
        # measured: 5.2e-12 (tau 5), 2.4e-11 (tau 15): the integrator across the cells' kinks
        np.testing.assert_allclose(result.end_state, physical(position[None]), rtol=0, atol=1e-10)
        # the arc length: the index speed times h (an affine grid's metric), integrated by quad
        kinks = [0.6, 10.6]
        arc = sum(quad(lambda s: H * np.hypot(*corner_path(s)[1]), a, min(b, tau))[0]
                  for a, b in zip([0.0] + kinks, kinks + [tau]) if a < tau)
        np.testing.assert_allclose(result.ld, arc, rtol=3e-10)  # measured 6.3e-11, 1.7e-11
        assert not system.stop_flags(result.end_state, 10.0, 10.0 + tau)["on_land"].any()


def test_no_trajectory_crosses_into_land(c_grid):
    # starts all over the sea, long enough that every one has come up to a wall (or left the data):
    # none ends in a land cell or past a closed face (the walls i = 19.5 for j < 15.5, j = 15.5 for
    # 13.5 < i < 19.5, i = 13.5 above the corner); forward into the coast, backward away from it
    _, system = c_grid
    rng = np.random.default_rng(3)
    indices = np.column_stack([rng.uniform(0.6, 19.4, 400), rng.uniform(0.6, 23.4, 400)])
    indices = indices[~coast(np.floor(indices[:, 0] + 0.5), np.floor(indices[:, 1] + 0.5))]
    settings = LDSettings(tau=80.0, p=0.5, rtol=1e-9, atol=1e-9)
    for direction, t0 in ((1, 10.0), (-1, 90.0)):
        result = compute_ld(system, physical(indices), direction, settings, t0=t0)
        flags = system.stop_flags(result.end_state, t0, t0 + direction * 80.0)
        assert not flags["on_land"].any()
        i, j = system.engine_states(result.end_state).T
        inside = ~flags["left_data"]
        past = np.maximum(i[inside] - 19.5, np.minimum(i[inside] - 13.5, j[inside] - 15.5))
        # measured: 2.9e-11 cells past a wall at most (the trajectories resting on it, to rounding)
        assert past.size == 0 or past.max() < 3e-10
    assert inside.sum() == 0  # backward every one leaves by the west or south edge


def test_the_map_stops_at_the_data_edge_at_the_closed_form_time(c_grid):
    # backward from t0 = 100 the flow runs south-west at (U0, V0) through open faces only (the cells
    # west of and below the coast): a start at (i0, j0) leaves the cells with both faces, i >= 0.5 and
    # j >= 0.5, after min((i0 - 0.5) / U0, (j0 - 0.5) / V0) seconds (closed form)
    path, _ = c_grid
    corners = physical(np.array([[4.0, 3.0], [10.0, 11.0]]))
    spec = {"system": "c_grid", "t0": 100.0, "tau": 60.0, "p": 0.5,
            "integrator": {"rtol": 1e-10, "atol": 1e-10},
            "section": {"axes": [{"name": "x_rho", "range": sorted(corners[:, 0].tolist()), "points": 3},
                                 {"name": "y_rho", "range": sorted(corners[:, 1].tolist()), "points": 3}]}}
    config = validate_config({"systems": {"c_grid": {"velocity_data": {"path": str(path), **ENTRY}}},
                              "ld_maps": {"m": spec}})
    dataset = compute_ld_map(parameters_from_config(config, "ld", "m"), None, show_progress=False)
    X, Y = np.meshgrid(dataset.x_rho.values, dataset.y_rho.values, indexing="ij")
    a = math.cos(ROTATION) * (X - 1.0) + math.sin(ROTATION) * (Y - 0.5)
    b = -math.sin(ROTATION) * (X - 1.0) + math.cos(ROTATION) * (Y - 0.5)
    i0, j0 = (a + 1.4) / H, (b + 1.2) / H
    assert np.all((i0 > 0.5) & (i0 < 13.5) & (j0 > 0.5) & (j0 < 15.5))
    exit_time = np.minimum((i0 - 0.5) / U0, (j0 - 0.5) / V0)
    assert dataset.left_data_backward.values.all()
    # measured: 4.6e-9 relative (the step across the edge)
    np.testing.assert_allclose(dataset.exit_time_backward.values, exit_time, rtol=2e-8)


def test_staggered_shapes_that_fit_no_c_grid_are_refused(tmp_path):
    x, y = plane_grid("rotated", 0.2)
    good = c_grid_dataset(lambda X, Y, T: 0 * X + 0.1 + 0 * T, lambda X, Y, T: 0 * X + 0 * T, x, y, np.arange(4.0))
    short = good.isel(xi_u=slice(0, -1))  # u one face short
    with pytest.raises(ConfigError, match=r"velocity_data\.u': variables 'u' .* and 'v' .* fit neither the "
                                          r"coordinates' points .* nor an Arakawa C-grid's faces"):
        make_system("s", {"velocity_data": {"path": str(write_dataset(short, tmp_path / "short.nc")), **ENTRY}})
    with pytest.raises(ConfigError, match=r"velocity_data\.components': a C-grid's u and v are normal to its"):
        make_system("s", {"velocity_data": {"path": str(write_dataset(good, tmp_path / "good.nc")),
                                            **ENTRY, "components": "geographic"}})


def test_a_c_grid_on_a_rotated_pole_grid(tmp_path):
    # On the rotated-pole grid (spacing 0.5 degrees of the frame, tilted 40 degrees) u on every
    # face is c times the great-circle distance between the centres it separates, which on the
    # frame's latitude circle phi' is 2 R asin(cos phi' sin(h / 2)) (closed form), v = 0: the index
    # velocity is c, so a start at frame (lam', phi') moves along its circle at c h degrees a second;
    # the end point is the frame's (lam' + c h t, phi') turned by the tilt, the arc length
    # R cos(phi') c h t (radians), in km. Time in seconds, c = 1e-5 per second.
    radius, h, c, tilt = 6371000.0, 0.5, 1e-5, 40.0
    lon, lat = rotated_pole_grid((30.0, 20.0), h, tilt)
    phi = np.radians(np.arange(-20.0, 20.0 + h / 2, h))

    def u_face(X, Y, T):
        return np.broadcast_to(c * 2 * radius * np.arcsin(np.cos(phi)[:, None] * math.sin(math.radians(h) / 2)),
                               np.broadcast_shapes(X.shape, T.shape))

    dataset = c_grid_dataset(u_face, lambda X, Y, T: 0 * X + 0 * T, lon, lat, np.arange(0.0, 4e4 + 1, 1e4),
                             sphere=True)
    path = write_dataset(dataset, tmp_path / "pole_c_grid.nc")
    system = make_system("pole_c_grid", {"velocity_data": {
        "path": str(path), "coordinates": "sphere", "longitude": "lon_rho", "latitude": "lat_rho",
        "components": "grid"}})
    frame = np.array([[-10.0, -5.0], [0.0, 8.0], [12.0, 0.0]])  # (lam', phi') in degrees
    t = 2e4
    start, end = rotated_pole_point(frame, tilt), rotated_pole_point(frame + [c * h * t, 0.0], tilt)
    result = compute_ld(system, start, 1, LDSettings(tau=t, p="arclength", rtol=1e-11, atol=1e-11), t0=1e4)
    # measured: 1.2e-6 degrees (the coordinates' cubic between centres, mapping the start and the
    # end), the arc length 1.1e-8 relative (the metric's cubic)
    np.testing.assert_allclose(result.end_state, end, rtol=0, atol=4e-6)
    arc = radius * np.cos(np.radians(frame[:, 1])) * math.radians(c * h * t) / 1000.0
    np.testing.assert_allclose(result.ld, arc, rtol=4e-8)


def rotated_pole_point(frame, tilt):
    """(lon, lat) of frame points (lam', phi') (degrees), as ldpipe.data.curvilinear.rotated_pole_grid turns them."""
    lam, phi = np.radians(frame[:, 0]), np.radians(frame[:, 1])
    r = np.array([np.cos(phi) * np.cos(lam), np.cos(phi) * np.sin(lam), np.sin(phi)])
    b = math.radians(tilt)
    x, z = math.cos(b) * r[0] + math.sin(b) * r[2], -math.sin(b) * r[0] + math.cos(b) * r[2]
    return np.column_stack([np.degrees(np.arctan2(r[1], x)), np.degrees(np.arcsin(z))])


def test_nemos_layout_gives_romss_trajectories(c_grid, tmp_path):
    # the same faces written NEMO's way: u and v on arrays of the centres' shape, the outer faces
    # (east of the last column, north of the last row) appended with values that must not be read;
    # with c_grid: nemo the trajectories equal the ROMS layout's bit for bit (the same numbers reach
    # the same kernel: an invariant, no tolerance)
    import xarray as xr

    path, roms = c_grid
    with xr.open_dataset(path) as dataset:
        data = dataset.load()
    outer_u = xr.full_like(data.u.isel(xi_u=slice(0, 1)), 7.0)
    outer_v = xr.full_like(data.v.isel(eta_v=slice(0, 1)), -7.0)
    nemo = data.assign(u=xr.concat([data.u, outer_u], "xi_u").rename(xi_u="xi"),
                       v=xr.concat([data.v, outer_v], "eta_v").rename(eta_v="eta"))
    nemo_path = write_dataset(nemo, tmp_path / "nemo.nc")
    system = make_system("nemo", {"velocity_data": {"path": str(nemo_path), **ENTRY, "c_grid": "nemo"}})
    starts = physical(np.array([[13.2, 14.9], [5.0, 20.0], [18.0, 3.0]]))
    settings = LDSettings(tau=30.0, p=0.5, rtol=1e-10, atol=1e-10)
    for direction, t0 in ((1, 10.0), (-1, 90.0)):
        want = compute_ld(roms, starts, direction, settings, t0=t0)
        got = compute_ld(system, starts, direction, settings, t0=t0)
        np.testing.assert_array_equal(got.end_state, want.end_state)
        np.testing.assert_array_equal(got.ld, want.ld)
    with pytest.raises(ConfigError, match=r"velocity_data\.c_grid': NEMO's u and v are on arrays of the centres'"):
        make_system("nemo_on_roms", {"velocity_data": {"path": str(path), **ENTRY, "c_grid": "nemo"}})


# The flow map by exact cell crossing (ldpipe.systems.velocity_data.cell_crossing): the interpolant's
# trajectory itself, so against the closed forms above to rounding, with no tolerance to set.
CELLS = FlowSettings(method="cell_crossing")


def test_cell_crossing_follows_the_coasts_corner_in_closed_form(c_grid):
    _, system = c_grid
    start = physical(np.array([[13.2, 14.9]]))
    for tau in (5.0, 15.0):
        result = flow_map(system, start, tau, CELLS, t0=10.0)
        position, _ = corner_path(tau)
        # measured: 1.1e-16 and 2.2e-16 (rounding: the series are summed to 1e-15 cells)
        np.testing.assert_allclose(result.end_state, physical(position[None]), rtol=0, atol=1e-13)
        assert result.status[0] == COMPLETED


def test_cell_crossing_never_crosses_into_land_and_stops_at_the_data_edge(c_grid):
    # the starts of test_no_trajectory_crosses_into_land: forward every one comes up to a wall and
    # stays on its sea side, or leaves by the north edge; backward every one leaves by the west or
    # south edge; one from a cell not by the coast (its east and north neighbours at sea) on the
    # edge line at the closed-form point start - (U0, V0) min((i0 - 0.5) / U0, (j0 - 0.5) / V0)
    # (the flow is uniform in those cells, and backward it goes through such cells only)
    _, system = c_grid
    rng = np.random.default_rng(3)
    indices = np.column_stack([rng.uniform(0.6, 19.4, 400), rng.uniform(0.6, 23.4, 400)])
    indices = indices[~coast(np.floor(indices[:, 0] + 0.5), np.floor(indices[:, 1] + 0.5))]
    forward = flow_map(system, physical(indices), 80.0, CELLS, t0=10.0)
    flags = system.stop_flags(forward.end_state, 10.0, 90.0)
    assert not flags["on_land"].any()
    i, j = system.engine_states(forward.end_state[~flags["left_data"]]).T
    past = np.maximum(i - 19.5, np.minimum(i - 13.5, j - 15.5))
    assert past.max() <= 1e-12  # measured: 7e-15 (rounding of the coordinates' round trip)
    backward = flow_map(system, physical(indices), -80.0, CELLS, t0=90.0)
    assert system.stop_flags(backward.end_state, 90.0, 10.0)["left_data"].all()
    exit_time = np.minimum((indices[:, 0] - 0.5) / U0, (indices[:, 1] - 0.5) / V0)
    edge = indices - np.array([U0, V0]) * exit_time[:, None]
    ci, cj = np.floor(indices[:, 0] + 0.5), np.floor(indices[:, 1] + 0.5)
    open_sea = ~coast(ci + 1, cj) & ~coast(ci, cj + 1)
    assert open_sea.sum() > 200
    # measured: 8.7e-11 (the end is left EDGE_OUTSIDE = 1e-9 cells of 0.1 past the edge)
    np.testing.assert_allclose(backward.end_state[open_sea], physical(edge[open_sea]), rtol=0, atol=3e-10)


def test_cell_crossing_follows_quadratic_time_dependence_exactly(tmp_path):
    # u and v the same on every face and quadratic in time: Keys' cubic convolution reproduces a
    # quadratic exactly (Keys 1981), so the index position is i0 + int U dt, a cubic in t (closed form)
    x, y = plane_grid("rotated", H)

    def u(X, Y, T):
        return 0 * X + 0.02 + 1e-3 * (T - 5.0) + 4e-4 * (T - 5.0) ** 2

    def v(X, Y, T):
        return 0 * X + 0.01 - 2e-3 * (T - 5.0)

    dataset = c_grid_dataset(u, v, x, y, np.arange(0.0, 20.01, 0.5))
    system = make_system("quadratic", {"velocity_data": {"path": str(write_dataset(dataset, tmp_path / "q.nc")),
                                                           "x": "x_rho", "y": "y_rho", "components": "grid"}})
    starts = np.array([[6.3, 8.0], [7.5, 10.2], [10.0, 6.7]])
    for t0, tau in ((1.0, 12.0), (15.0, -11.0)):
        t1 = t0 + tau

        s0, s1 = t0 - 5.0, t1 - 5.0
        di = (0.02 * (s1 - s0) + 5e-4 * (s1**2 - s0**2) + 4e-4 / 3 * (s1**3 - s0**3)) / H
        dj = (0.01 * (s1 - s0) - 1e-3 * (s1**2 - s0**2)) / H
        result = flow_map(system, physical(starts), tau, CELLS, t0=t0)
        # measured: 4.4e-16 and 2.2e-16 (rounding)
        np.testing.assert_allclose(result.end_state, physical(starts + [di, dj]), rtol=0, atol=1e-12)


def test_cell_crossing_on_the_double_gyre_is_dop853s_limit(tmp_path):
    # an independent method: DOP853 at rtol 1e-13 on the same interpolant (the engine's LD path)
    # converges to the same trajectories; the cell crossing run back in time returns to its starts
    # (the flow map's inverse)
    times = np.arange(0.0, 6.01, 0.1)
    dataset = double_gyre_c_grid_dataset("conformal", 0.1, times)
    system = make_system("gyre", {"velocity_data": {"path": str(write_dataset(dataset, tmp_path / "g.nc")),
                                                      "x": "x_rho", "y": "y_rho", "components": "grid"}})
    rng = np.random.default_rng(5)
    starts = np.column_stack([rng.uniform(0.2, 1.8, 12), rng.uniform(0.2, 0.8, 12)])
    ends = flow_map(system, starts, 5.0, CELLS, t0=0.5)
    reference = compute_ld(system, starts, 1, LDSettings(tau=5.0, p=0.5, rtol=1e-13, atol=1e-13), t0=0.5)
    # measured: 5.7e-11 (DOP853's error across the faces at 1e-13: 5.4e-8 at 1e-12, 3.9e-11 at
    # 1e-14, converging on the cell crossing); the grid's cells are 0.1 wide
    np.testing.assert_allclose(ends.end_state, reference.end_state, rtol=0, atol=3e-10)
    back = flow_map(system, ends.end_state, -5.0, CELLS, t0=5.5)
    np.testing.assert_allclose(back.end_state, starts, rtol=0, atol=1e-12)  # measured: 1.6e-15
    assert (ends.steps > 20).all()  # it did cross cells (a piece per cell and data interval)


def test_cell_crossing_is_the_c_grids_and_reports_the_flow_codes(c_grid):
    from ldpipe.engine.templates import flow_status
    from ldpipe.systems.velocity_data import cell_crossing

    assert (cell_crossing.COMPLETED, cell_crossing.FAILED) == (flow_status.FLOW_COMPLETED,
                                                               flow_status.FLOW_STEP_UNDERFLOW)
    with pytest.raises(ValueError, match="method: expected one of"):
        FlowSettings(method="analytic")
    with pytest.raises(ValueError, match="method 'cell_crossing' moves points through a C-grid's cells"):
        flow_map(make_system("b", {"builtin": "barbanis_2dof"}), np.zeros((1, 4)), 1.0, CELLS)
    _, system = c_grid
    capped = flow_map(system, physical(np.array([[2.0, 2.0]])), 40.0, FlowSettings(method="cell_crossing", max_steps=3))
    assert capped.status[0] == flow_status.FLOW_STEP_UNDERFLOW and capped.steps[0] == 3


def test_cell_crossing_refuses_uneven_data_times(tmp_path):
    # its series are per data interval of one length; uneven times are DOP853's to integrate
    x, y = plane_grid("rotated", 0.2)
    dataset = c_grid_dataset(lambda X, Y, T: 0 * X + 0.1 + 0 * T, lambda X, Y, T: 0 * X + 0 * T, x, y,
                             np.array([0.0, 1.0, 3.0, 4.0, 7.0]))
    system = make_system("uneven", {"velocity_data": {"path": str(write_dataset(dataset, tmp_path / "u.nc")),
                                                        "x": "x_rho", "y": "y_rho", "components": "grid"}})
    with pytest.raises(ValueError, match="method 'cell_crossing' needs the data at evenly spaced times"):
        flow_map(system, physical(np.array([[3.0, 3.0]])), 2.0, CELLS, t0=1.0)
