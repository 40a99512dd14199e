"""A spatial ``window`` on curvilinear grids and C-grids: only its box of nodes is read.

- Identity: inside the window the map (or the trajectories) are the whole grid's bit for bit, for
  trajectories that stay in it (the box's values, the metric's differences and the interpolants'
  stencils are the whole grid's there), on a bent plane grid, on a C-grid and on a sphere's grid
  across the dateline (the window written in either convention); and every read of u and v is the
  box: the nodes inside the window and one more each side (the cells covering it), with the
  stencil's real neighbour beyond (collocated), or the faces between the box's centres (C-grid),
  counted by recording each read of the dataset.
- Closed form: a uniform flow on the rotated grid (affine, so the interpolants are exact) leaves
  the box through its edge, an index line of the grid, after the time the ray takes to reach it.
- A window with no node of the grid in it is refused, naming ``window``.
- A window south of a tripolar grid's fold (the whole grid refused by it) is read: a rotation about
  the polar axis against its closed form.
"""

import math

import numpy as np
import pytest

from ldpipe.config import validate_config
from ldpipe.config.parameters import parameters_from_config
from ldpipe.core.maps.assembly import compute_ld_map
from ldpipe.data.curvilinear import (
    ROTATION, curvilinear_dataset, double_gyre_c_grid_dataset, double_gyre_dataset, plane_grid, rotated_pole_grid,
    write_dataset,
)
from ldpipe.data.tripolar import tripolar_dataset
from ldpipe.engine import LDSettings, compute_ld
from ldpipe.errors import ConfigError
from ldpipe.systems import make_system
from ldpipe.systems.velocity_data.files import FileSeries

#: The same engines as test_curvilinear and test_c_grid (one worker compiles them).
pytestmark = [pytest.mark.compiles, pytest.mark.xdist_group("curvilinear_grids")]
TIGHT = {"rtol": 1e-10, "atol": 1e-10}


@pytest.fixture
def reads(monkeypatch):
    """The shape of every array read from a dataset, by variable."""
    shapes = []
    read = FileSeries.read

    def recorded(self, name, indexers):
        values = read(self, name, indexers)
        shapes.append((name, np.shape(values)))
        return values

    monkeypatch.setattr(FileSeries, "read", recorded)
    return shapes


def node_box(x, y, window, halo):
    """The inclusive (rows, columns) of the nodes inside the window (x and y intervals) widened by
    ``halo`` nodes each side, within the grid: found here from the coordinates alone."""
    (x_low, x_high), (y_low, y_high) = window
    rows, columns = np.nonzero((x >= x_low) & (x <= x_high) & (y >= y_low) & (y <= y_high))
    ny, nx = x.shape
    return ((max(0, rows.min() - halo), min(ny - 1, rows.max() + halo)),
            (max(0, columns.min() - halo), min(nx - 1, columns.max() + halo)))


def size(span):
    return span[1] - span[0] + 1


def ld_map(path, entry, section, tau, t0=2.0):
    spec = {"system": "s", "t0": t0, "tau": tau, "p": 0.5, "ftle": True, "integrator": dict(TIGHT),
            "section": {"axes": [{"name": "x", "range": section[0], "points": 4},
                                 {"name": "y", "range": section[1], "points": 3}]}}
    config = validate_config({"systems": {"s": {"velocity_data": {"path": str(path), **entry}}}, "ld_maps": {"m": spec}})
    return compute_ld_map(parameters_from_config(config, "ld", "m"), None, show_progress=False)


def test_a_window_of_a_bent_grid_reads_its_box_and_keeps_the_whole_grids_map(tmp_path, reads):
    times = np.arange(0.0, 4.01, 0.5)
    path = write_dataset(double_gyre_dataset("curvilinear", 0.1, times), tmp_path / "gyre.nc")
    entry = {"components": "geographic"}
    window = {"x": [0.5, 1.5], "y": [0.05, 0.95]}
    section, tau = ([0.85, 1.15], [0.4, 0.6]), 0.5  # the double gyre moves at most 0.1 pi tau = 0.16
    whole = ld_map(path, entry, section, tau)
    reads.clear()
    boxed = ld_map(path, entry | {"window": window}, section, tau)
    assert not whole.left_data_forward.values.any() and not whole.left_data_backward.values.any()
    for name in whole.data_vars:
        np.testing.assert_array_equal(boxed[name].values, whole[name].values, err_msg=name)
    x, y = plane_grid("curvilinear", 0.1)
    rows, columns = node_box(x, y, window.values(), 2)  # the covering cells' nodes and the stencil's neighbour
    velocity_reads = [shape for name, shape in reads if name in ("u", "v")]
    assert velocity_reads and all(shape[1:] == (size(rows), size(columns)) for shape in velocity_reads), reads
    assert size(rows) * size(columns) < 0.6 * x.size  # a box, not the grid


def test_a_uniform_flow_leaves_the_window_at_its_boxs_edge(tmp_path):
    # u = 0.1 east on the grid rotated by 30 degrees (affine: node (i, j) at a = -1.4 + 0.1 i,
    # b = -1.2 + 0.1 j in its frame). The box read is the nodes inside the window and one more each
    # side; a trajectory stops where the ray along (cos 30, -sin 30) in (a, b) first crosses the
    # box's last column a = -1.4 + 0.1 i1 or first row b = -1.2 + 0.1 j0 (closed form)
    x, y = plane_grid("rotated", 0.1)
    path = write_dataset(curvilinear_dataset(lambda X, Y, T: (0.1 + 0 * X + 0 * T, 0 * Y), x, y,
                                             np.arange(0.0, 60.01, 4.0)), tmp_path / "uniform.nc")
    window = {"x": [0.8, 1.3], "y": [0.3, 0.8]}
    dataset = ld_map(path, {"components": "geographic", "window": window}, ([0.9, 1.1], [0.45, 0.6]), 28.0, t0=30.0)
    (j0, _), (_, i1) = node_box(x, y, window.values(), 1)
    X0, Y0 = np.meshgrid(dataset.x.values, dataset.y.values, indexing="ij")
    a0 = math.cos(ROTATION) * (X0 - 1.0) + math.sin(ROTATION) * (Y0 - 0.5)
    b0 = -math.sin(ROTATION) * (X0 - 1.0) + math.cos(ROTATION) * (Y0 - 0.5)
    exit_time = np.minimum((-1.4 + 0.1 * i1 - a0) / (0.1 * math.cos(ROTATION)),
                           (b0 + 1.2 - 0.1 * j0) / (0.1 * math.sin(ROTATION)))
    assert np.all(exit_time < 28.0)
    assert dataset.left_data_forward.values.all() and not dataset.on_land_forward.values.any()
    # the whole grid's test measures 1e-8 relative (the step across the edge): the same here
    np.testing.assert_allclose(dataset.exit_time_forward.values, exit_time, rtol=1e-7)
    np.testing.assert_allclose(dataset.end_x_forward.values, X0 + 0.1 * exit_time, rtol=0, atol=1e-7)


def test_a_window_off_the_grid_is_refused_naming_it(tmp_path):
    x, y = plane_grid("rotated", 0.2)
    path = write_dataset(curvilinear_dataset(lambda X, Y, T: (0 * X + T, 0 * Y), x, y, np.arange(0.0, 3.01, 1.0)),
                         tmp_path / "grid.nc")
    with pytest.raises(ConfigError, match=r"velocity_data\.window': no node of the curvilinear grid .* lies in the "
                                          r"window x \[5\.0, 6\.0\], y \[0\.0, 1\.0\]"):
        make_system("s", {"velocity_data": {"path": str(path), "components": "geographic",
                                            "window": {"x": [5.0, 6.0], "y": [0.0, 1.0]}}})
    with pytest.raises(ConfigError, match=r"velocity_data\.window': expected an interval for each of \['x', 'y'\]"):
        make_system("s", {"velocity_data": {"path": str(path), "components": "geographic",
                                            "window": {"xi": [0, 5], "eta": [0, 5]}}})


def test_a_window_of_a_c_grid_reads_the_faces_of_its_box_and_keeps_the_whole_grids_trajectories(tmp_path, reads):
    times = np.arange(0.0, 4.01, 0.5)
    land = lambda i, j: (i >= 3) & (i <= 4) & (j >= 5) & (j <= 7)  # noqa: E731 - an island inside the box
    path = write_dataset(double_gyre_c_grid_dataset("conformal", 0.1, times, land=land), tmp_path / "c.nc")
    entry = {"path": str(path), "x": "x_rho", "y": "y_rho", "components": "grid", "mask": "mask_rho"}
    window = {"x_rho": [0.5, 1.5], "y_rho": [0.05, 0.95]}  # the state's coordinates: the entry's x and y
    starts = np.array([[0.9, 0.45], [1.1, 0.55], [1.0, 0.3], [0.8, 0.7]])
    settings = LDSettings(tau=0.6, p="arclength", **TIGHT)
    runs = ((1, 1.0), (-1, 3.0))
    whole = make_system("whole", {"velocity_data": entry})
    expected = [compute_ld(whole, starts, direction, settings, t0=t0) for direction, t0 in runs]
    reads.clear()
    boxed = make_system("boxed", {"velocity_data": entry | {"window": window}})
    for (direction, t0), wanted in zip(runs, expected):
        result = compute_ld(boxed, starts, direction, settings, t0=t0)
        assert not whole.stop_flags(wanted.end_state, t0, t0 + direction * 0.6)["left_data"].any()
        np.testing.assert_array_equal(result.end_state, wanted.end_state)
        np.testing.assert_array_equal(result.ld, wanted.ld)
    x, y = plane_grid("conformal", 0.1)
    rows, columns = node_box(x, y, window.values(), 1)  # the centres of the cells covering the window
    shapes = {name: {shape[-2:] for n, shape in reads if n == name} for name in ("u", "v", "mask_rho")}
    assert shapes == {"u": {(size(rows), size(columns) - 1)}, "v": {(size(rows) - 1, size(columns))},
                      "mask_rho": {(size(rows), size(columns))}}, reads


@pytest.mark.parametrize("longitudes", [[170.0, 200.0], [-190.0, -160.0]])
def test_a_window_across_the_dateline_keeps_the_whole_grids_trajectories(tmp_path, longitudes):
    # a rotation about the polar axis on a rotated-pole grid straddling the dateline, its longitudes
    # written in -180..180 (a jump of 360 inside the file); the window in either convention
    radius, omega = 6371000.0, 2 * math.pi / (40 * 86400.0)
    lon, lat = rotated_pole_grid((30.0, 20.0), 1.0, 40.0)
    lon = np.mod(lon + 360.0, 360.0) - 180.0
    path = write_dataset(curvilinear_dataset(lambda x, y, t: (omega * radius * np.cos(np.radians(y)) + 0 * t, 0 * y),
                                             lon, lat, np.arange(0.0, 4.01, 1.0), sphere=True,
                                             time_units="days since 2000-01-01"), tmp_path / "pole.nc")
    entry = {"path": str(path), "coordinates": "sphere"}
    whole = make_system("whole", {"velocity_data": entry})
    boxed = make_system("boxed", {"velocity_data": entry | {"window": {"lon": longitudes, "lat": [-50.0, -30.0]}}})
    starts = np.array([[178.0, -45.0], [-175.0, -40.0], [182.0, -35.0]])
    settings = LDSettings(tau=0.5, p="arclength", **TIGHT)
    expected = compute_ld(whole, starts, 1, settings, t0=1.0)
    result = compute_ld(boxed, starts, 1, settings, t0=1.0)
    assert not whole.stop_flags(expected.end_state, 1.0, 1.5)["left_data"].any()
    np.testing.assert_array_equal(result.end_state, expected.end_state)
    np.testing.assert_array_equal(result.ld, expected.ld)
    assert boxed.box != whole.box


def test_a_window_south_of_a_tripolar_grids_fold_is_read(tmp_path):
    # the whole ORCA-like grid is read joined across its north fold (test_folded.py); a window south
    # of it (where the grid is a regular 5-degree longitude-latitude grid) as any grid's box. A rotation about the polar axis, a turn
    # in 40 days, is linear in the index there: lon0 + omega t, lat0 (closed form); the starts on
    # rows of the grid, where the LD's metric (cos lat) is the nodes' own, so the arc length
    # omega R cos(lat0) t is exact too
    radius, omega = 6371000.0, 2 * math.pi / (40 * 86400.0)
    field = lambda lon, lat, t: (omega * radius * np.cos(np.radians(lat)) + 0 * t, 0 * lat)  # noqa: E731
    path = write_dataset(tripolar_dataset(field, np.arange(0.0, 2.01, 0.5)), tmp_path / "tripolar.nc")
    entry = {"path": str(path), "coordinates": "sphere"}
    assert make_system("whole", {"velocity_data": entry}).engine_name == "velocity_data_folded"
    boxed = make_system("boxed", {"velocity_data": entry | {"window": {"lon": [-60.0, 60.0], "lat": [-40.0, 20.0]}}})
    starts = np.array([[-20.0, -30.0], [0.0, 0.0], [12.5, 10.0]])
    result = compute_ld(boxed, starts, 1, LDSettings(tau=1.0, p="arclength", **TIGHT), t0=0.5)
    # measured: 2.5e-14 degrees, the arc length 5.2e-14 relative (rounding)
    np.testing.assert_allclose(result.end_state, starts + [math.degrees(omega * 86400.0), 0.0], rtol=0, atol=1e-12)
    arc = omega * 86400.0 * radius * np.cos(np.radians(starts[:, 1])) / 1000.0
    np.testing.assert_allclose(result.ld, arc, rtol=1e-12)
