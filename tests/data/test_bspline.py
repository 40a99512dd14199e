"""The cubic B-spline interpolant of velocity data (``interpolation: cubic_bspline``) against closed forms.

- Cubic reproduction: a field of degree <= 3 in each of x, y and t is its own not-a-knot cubic
  spline (its coefficients c[m] = p(m) - p''(m)/6 are a cubic in m, whose fourth difference, the
  boundary condition, vanishes), so the interpolant equals it everywhere on the grid, edges
  included, to rounding. Cubic convolution (exact to degree 2) misses the same field.
- Fourth order: on a smooth field the largest velocity error falls as h^4 (least-squares slope
  over three spacings); cubic convolution's falls as h^3.
- C2: along each axis the interpolant is a cubic in each cell; the second derivative of the
  cubic through four points inside the cell on each side of a node, taken at the node, agrees
  across it to rounding. Cubic convolution (C1) jumps there by O(h) (checked too: the test can fail).
- The double gyre (Shadden et al. 2005) sampled on finer grids: the LD and the FTLE (grid
  differences) of a map of starts converge to the formula system's at fourth order.
- The key: validated by the schema, given through ldpipe.system, refused (naming the key) with a
  value it does not know or on a grid that does not offer it.
"""

import numpy as np
import pytest
import xarray as xr

import ldpipe
from ldpipe.config import validate_config
from ldpipe.config.parameters import parameters_from_config
from ldpipe.core.maps.assembly import compute_ld_map
from ldpipe.core.maps.ftle import ftle
from ldpipe.engine import LDSettings, compute_ld
from ldpipe.errors import ConfigError
from ldpipe.systems import make_system
from support.double_gyre import DOUBLE_GYRE, double_gyre_velocity
from support.gridded import write_velocity_file


def data_system(path, interpolation, name="data"):
    return make_system(name, {"velocity_data": {"path": str(path), "interpolation": interpolation}})


def velocities(system, points):
    """(u, v) of ``system`` at rows (x, y, t) of ``points``, its kernel called with one window bound
    for them all (as the engine calls it)."""
    out = np.empty((len(points), 2))
    with system.time_window(points[:, 2].min(), points[:, 2].max()):
        for row, point in zip(out, points):
            system.rhs(np.ascontiguousarray(point[:2]), float(point[2]), row)
    return out


def cubic_field(x, y, t):
    """Degree 3 in each variable (and products): a not-a-knot cubic spline's own interpolant."""
    return (0.3 + 0.1 * x**3 - 0.2 * x * y**2 + 0.01 * t**3 * y - 0.03 * x**2 * y**3 * t,
            -0.2 * x**2 * y + 0.05 * y**3 - 0.02 * t**2 * x + 0.004 * (x * y * t) ** 3)


def smooth_field(x, y, t):
    return np.sin(1.3 * x + 0.4 * t) * np.cos(0.9 * y), np.cos(0.7 * x) * np.sin(1.1 * y - 0.5 * t)


@pytest.fixture(scope="module")
def cubic_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("bspline") / "cubic.nc"
    return write_velocity_file(path, cubic_field, np.linspace(-2, 2, 9), np.linspace(-1, 1.5, 6), np.linspace(0, 3, 7))


def test_cubic_field_is_reproduced_to_the_edges(cubic_file):
    rng = np.random.default_rng(3)
    inner = np.column_stack([rng.uniform(-2, 2, 150), rng.uniform(-1, 1.5, 150), rng.uniform(0, 3, 150)])
    edges = np.array([[-2, -1, 0], [2, 1.5, 3], [-1.95, 1.49, 0.02], [1.99, -0.97, 2.97], [0.3, -1, 1.7]])
    points = np.vstack([inner, edges])
    exact = np.array(cubic_field(points[:, 0], points[:, 1], points[:, 2])).T
    scale = np.abs(exact).max()
    error = np.abs(velocities(data_system(cubic_file, "cubic_bspline"), points) - exact).max()
    # rounding of the prefilter and the 64-term sum: measured ~2e-15 of the field's size
    assert error < 1e-12 * scale, error
    # cubic convolution is exact only to degree 2: the same field is missed by far more
    missed = np.abs(velocities(data_system(cubic_file, "cubic_convolution"), points) - exact).max()
    assert missed > 1e-4 * scale, missed


def _largest_error(tmp_path, n, interpolation):
    x, y, t = np.linspace(0, 3, 3 * n + 1), np.linspace(0, 2, 2 * n + 1), np.linspace(0, 2, 2 * n + 1)
    path = write_velocity_file(tmp_path / f"smooth_{n}.nc", smooth_field, x, y, t)
    rng = np.random.default_rng(5)
    points = np.column_stack([rng.uniform(0, 3, 150), rng.uniform(0, 2, 150), rng.uniform(0, 2, 150)])
    exact = np.array(smooth_field(points[:, 0], points[:, 1], points[:, 2])).T
    return np.abs(velocities(data_system(path, interpolation, f"smooth_{n}"), points) - exact).max()


def _slope(spacings, errors):
    return np.polyfit(np.log(spacings), np.log(errors), 1)[0]


def test_fourth_order_on_a_smooth_field(tmp_path):
    counts = (4, 8, 16)
    spacings = [1.0 / n for n in counts]
    bspline = [_largest_error(tmp_path, n, "cubic_bspline") for n in counts]
    convolution = [_largest_error(tmp_path, n, "cubic_convolution") for n in counts]
    # the B-spline is fourth order (measured slope 3.9, errors 2.4e-4 .. 1.0e-6); cubic
    # convolution third (measured 3.0)
    assert 3.6 < _slope(spacings, bspline) < 4.4, bspline
    assert 2.6 < _slope(spacings, convolution) < 3.4, convolution
    assert bspline[-1] < convolution[-1]


def _second_derivative_jumps(system, nodes, axis, base):
    """At each interior node of ``axis`` (0 x, 1 y, 2 t) along the line through ``base``: the jump of
    the velocity's second derivative there, each side's taken from the cubic through four points of
    its own cell (the interpolant is a cubic in each cell, so that cubic is the interpolant's
    piece itself); and the largest |second derivative| seen."""
    h = nodes[1] - nodes[0]
    fractions = np.array([0.15, 0.4, 0.6, 0.85])
    jumps, sizes = [], []
    for node in nodes[1:-1]:
        sides = []
        for offsets in (-h * fractions[::-1], h * fractions):
            points = np.tile(base, (4, 1))
            points[:, axis] = node + offsets
            values = velocities(system, points)
            # the cubic in s = (coordinate - node) / h through the four values; its second derivative at s = 0
            coefficients = np.polyfit(offsets / h, values, 3)
            sides.append(2.0 * coefficients[1] / h**2)
        jumps.append(np.abs(sides[1] - sides[0]).max())
        sizes.append(np.abs(sides[0]).max())
    return max(jumps), max(sizes)


@pytest.mark.parametrize("axis", [0, 1, 2])
def test_second_derivative_is_continuous_across_cell_edges(tmp_path, axis):
    n = 6
    nodes = [np.linspace(0, 3, 3 * n + 1), np.linspace(0, 2, 2 * n + 1), np.linspace(0, 2, 2 * n + 1)]
    path = write_velocity_file(tmp_path / "smooth.nc", smooth_field, *nodes)
    base = np.array([1.37, 0.81, 0.93])
    jump, size = _second_derivative_jumps(data_system(path, "cubic_bspline", "c2"), nodes[axis], axis, base)
    # rounding amplified by 1/(0.15 h)^2: measured ~1e-10 of the second derivative's size
    assert jump < 1e-7 * size, (jump, size)
    # cubic convolution is C1: its second derivative jumps by O(h) of it at these nodes (measured ~0.1)
    jump, size = _second_derivative_jumps(data_system(path, "cubic_convolution", "c1"), nodes[axis], axis, base)
    assert jump > 1e-2 * size, (jump, size)


def _gyre_map_errors(tmp_path, counts):
    """The double gyre sampled with h = 1/n in x, y and t: the largest LD (M_1/2) and FTLE errors of
    a 9 x 5 map of starts (t0 = 2, tau = 5 forward, rtol 1e-12) against the formula system's, per n."""
    axes = (np.linspace(0.1, 1.9, 9), np.linspace(0.1, 0.9, 5))
    gx, gy = np.meshgrid(*axes, indexing="ij")
    starts = np.column_stack([gx.ravel(), gy.ravel()])
    settings = LDSettings(tau=5.0, p=0.5, rtol=1e-12, atol=1e-12)
    complete = np.ones(gx.shape, dtype=bool)

    def fields(system):
        result = compute_ld(system, starts, 1, settings, t0=2.0)
        return result.ld.ravel(), ftle(result.end_state.reshape(*gx.shape, 2), axes, 5.0, complete)[0]

    ld_exact, ftle_exact = fields(make_system("gyre", DOUBLE_GYRE))
    ld_errors, ftle_errors = [], []
    for n in counts:
        grid = (np.linspace(0, 2, 2 * n + 1), np.linspace(0, 1, n + 1), 1.5 + np.arange(6 * n + 1) / n)
        path = write_velocity_file(tmp_path / f"gyre_{n}.nc", double_gyre_velocity, *grid)
        ld, ftle_values = fields(data_system(path, "cubic_bspline", f"gyre_{n}"))
        ld_errors.append(np.abs(ld - ld_exact).max())
        ftle_errors.append(np.abs(ftle_values - ftle_exact).max())
    return ld_errors, ftle_errors


def test_double_gyre_map_converges_at_fourth_order(tmp_path):
    counts = (8, 16, 32)
    ld_errors, ftle_errors = _gyre_map_errors(tmp_path, counts)
    # at least fourth order, each halving of h: measured LD errors 1.7e-3, 9.2e-5, 1.6e-6 (local
    # slopes 4.2, 5.9), FTLE 7.6e-4, 2.6e-5, 3.5e-7 (4.9, 6.2): faster than the velocity's h^4 at
    # these spacings, the velocity's error oscillating within each cell and partly cancelling along
    # a trajectory. Cubic convolution's LD slope is 2.9 (test_velocity_data).
    for errors in (ld_errors, ftle_errors):
        local = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
        assert np.all(local > 3.5) and np.all(local < 7.5), errors
    assert ld_errors[-1] < 5e-6 and ftle_errors[-1] < 1.5e-6, (ld_errors, ftle_errors)


def test_a_window_interpolates_as_the_whole_grid(tmp_path):
    # a window's coefficients come from its nodes and MARGIN more each side; the prefilter's
    # dependence decays as |sqrt(3) - 2|^k with the distance k, so they equal the whole grid's to
    # ~|z|^MARGIN (1e-14) of the field: the window's interpolant is the whole grid's
    n = 8
    nodes = (np.linspace(0, 12, 12 * n + 1), np.linspace(0, 8, 8 * n + 1), np.linspace(0, 6, 6 * n + 1))
    path = write_velocity_file(tmp_path / "wide.nc", smooth_field, *nodes)
    whole = data_system(path, "cubic_bspline", "whole")
    window = make_system("window", {"velocity_data": {"path": str(path), "interpolation": "cubic_bspline",
                                                      "window": {"x": [5.0, 7.0], "y": [3.0, 5.0]}}})
    rng = np.random.default_rng(7)
    points = np.column_stack([rng.uniform(5, 7, 100), rng.uniform(3, 5, 100), rng.uniform(2.5, 3.5, 100)])
    assert np.abs(velocities(window, points) - velocities(whole, points)).max() < 1e-12


def test_trajectories_along_a_wall_stay_on_it(tmp_path):
    # the double gyre's walls x = 0, 2 and y = 0, 1 are invariant (u or v is 0 on them, in the data
    # too): a trajectory started on one slides along it to the formula system's end point; the
    # spline's rounding on the wall must not carry it outside the grid, where it would stop
    n = 16
    grid = (np.linspace(0, 2, 2 * n + 1), np.linspace(0, 1, n + 1), 1.5 + np.arange(6 * n + 1) / n)
    path = write_velocity_file(tmp_path / "gyre.nc", double_gyre_velocity, *grid)
    starts = np.array([[0.5, 0.0], [1.3, 1.0], [0.0, 0.4], [2.0, 0.7], [1.21, 0.0]])
    settings = LDSettings(tau=5.0, p=0.5, rtol=1e-10, atol=1e-10)
    exact = compute_ld(make_system("gyre", DOUBLE_GYRE), starts, 1, settings, t0=2.0).end_state
    data = data_system(path, "cubic_bspline", "walls")
    ends = compute_ld(data, starts, 1, settings, t0=2.0).end_state
    # the interpolation error at h = 1/16 moves them by ~1e-5 (the map test's errors)
    assert np.abs(ends - exact).max() < 1e-4, np.abs(ends - exact).max()
    flags = data.stop_flags(ends, 2.0, 7.0)
    assert not flags["left_data"].any() and not flags["on_land"].any()


def test_land_and_edge_stop_trajectories(tmp_path):
    # as with cubic convolution (test_velocity_data): u = 1 m/s eastward, land for x >= 6, so a
    # trajectory from x0 stops at the coast x = 5 after 5 - x0 seconds (land nodes carry their
    # nearest water's value, 1, so the spline of the data is 1 everywhere); v = 1 northward
    # reaches the top edge y = 4 after 4 - y0 seconds and is flagged as leaving the data
    x, y, t = np.arange(0.0, 10.01, 1.0), np.arange(0.0, 4.01, 1.0), np.arange(0.0, 20.01, 1.0)
    coast = write_velocity_file(tmp_path / "coast.nc", lambda X, Y, T: (1.0 + 0 * X, 0 * Y), x, y, t,
                                land=lambda X, Y: X >= 6)
    north = write_velocity_file(tmp_path / "north.nc", lambda X, Y, T: (0 * X, 1.0 + 0 * Y), x, y, t)
    base = {"section": {"axes": [{"name": "x", "range": [1.0, 3.0], "points": 3},
                                 {"name": "y", "range": [0.5, 2.5], "points": 3}]},
            "t0": 8.0, "tau": 8.0, "p": 0.5, "integrator": {"rtol": 1e-10, "atol": 1e-10}}
    entry = {"interpolation": "cubic_bspline"}
    config = validate_config({"systems": {"coast": {"velocity_data": {"path": str(coast), **entry}},
                                          "north": {"velocity_data": {"path": str(north), **entry}}},
                              "ld_maps": {"c": {**base, "system": "coast"}, "n": {**base, "system": "north"}}})
    coast_map = compute_ld_map(parameters_from_config(config, "ld", "c"), None, show_progress=False)
    x0 = coast_map.x.values[:, None] + 0 * coast_map.y.values
    assert coast_map.on_land_forward.values.all() and not coast_map.left_data_forward.values.any()
    np.testing.assert_allclose(coast_map.exit_time_forward.values, 5.0 - x0, rtol=2e-7)
    north_map = compute_ld_map(parameters_from_config(config, "ld", "n"), None, show_progress=False)
    y0 = 0 * north_map.x.values[:, None] + north_map.y.values
    assert north_map.left_data_forward.values.all() and not north_map.on_land_forward.values.any()
    np.testing.assert_allclose(north_map.exit_time_forward.values, 4.0 - y0, rtol=2e-7)
    np.testing.assert_allclose(north_map.exit_time_backward.values, y0, rtol=2e-7)


def test_the_key_through_the_api_and_its_errors(cubic_file, tmp_path):
    system = ldpipe.system(name="cubic", velocity_data={"path": str(cubic_file), "interpolation": "cubic_bspline"})
    assert system.interpolation == "cubic_bspline"
    default = ldpipe.system(name="cubic", velocity_data={"path": str(cubic_file)})
    assert default.interpolation == "cubic_convolution" and "interpolation" not in default.spec["velocity_data"]
    with pytest.raises(ConfigError, match="interpolation"):
        ldpipe.system(name="cubic", velocity_data={"path": str(cubic_file), "interpolation": "quintic"})
    with xr.open_dataset(cubic_file) as dataset:  # in memory, the key beside the dataset
        in_memory = ldpipe.system(name="memory", velocity_data={"dataset": dataset.load(),
                                                                "interpolation": "cubic_bspline"})
    points = np.array([[0.3, 0.2, 1.1], [-1.7, 1.4, 2.9]])
    assert np.array_equal(velocities(in_memory, points), velocities(system, points))
    with pytest.raises(ConfigError, match=r"velocity_data\.interpolation.*quintic"):
        make_system("cubic", {"velocity_data": {"path": str(cubic_file), "interpolation": "quintic"}})
    uneven = write_velocity_file(tmp_path / "uneven.nc", cubic_field, np.array([-2.0, -1.0, 0.5, 2.0]),
                                 np.linspace(-1, 1.5, 6), np.linspace(0, 3, 7))
    with pytest.raises(ConfigError, match=r"velocity_data\.interpolation.*uneven"):
        make_system("uneven", {"velocity_data": {"path": str(uneven), "interpolation": "cubic_bspline"}})
