"""The LAVD of velocity data: the translating Gaussian vortex of test_lavd.py, sampled on grids and
written as a velocity file, its vorticity taken from the data interpolant's derivatives.

The closed forms are those of test_lavd.py (its module docstring): the LAVD over T is
T |w0 exp(-r0^2/R^2) - wbar|, the centre at the origin at t0 and at (U T, 0) at t0 + T, the
boundary between the circle of its own level and r* = R sqrt(ln(w0/wbar)). The data's
interpolant is third order in the cell (support.gridded), so its vorticity, a derivative, is
second order: the LAVD's error falls by some 4 as the data's cells halve.
"""

import math

import numpy as np
import pytest
from support.gridded import write_velocity_file

import ldpipe
from ldpipe.core.structures.lavd import data_vorticity
from ldpipe.errors import ConfigError

R, W0, U, T = 0.3, 1.0, 0.5, 4.0
K = W0 * R**2 / 2
# the LAVD's grid of test_lavd.py
SECTION = ldpipe.section(x=(-1.0, 1.03, 41), y=(-0.98, 1.0, 41))


def vortex_velocity(x, y, t):
    """u, v of the vortex of vorticity w0 exp(-r^2/R^2) centred at (U t, 0), carried at U along x;
    at the centre itself, where the formula is 0/0, its limit (U, 0)."""
    dx = x - U * t
    r2 = dx**2 + y**2
    g = np.where(r2 > 0, -np.expm1(-r2 / R**2) / np.where(r2 > 0, r2, 1.0), 1 / R**2)
    return U - K * g * y, K * g * dx


def vortex_data(tmp_path, cell: float, step: float):
    """The vortex sampled every ``cell`` in x, y (over all the particles reach) and ``step`` in time."""
    x = np.arange(-1.5, 3.7 + cell / 2, cell)
    y = np.arange(-1.4, 1.4 + cell / 2, cell)
    t = np.arange(-step, T + 2 * step, step)
    path = write_velocity_file(tmp_path / f"vortex_{cell}.nc", vortex_velocity, x, y, t)
    return ldpipe.system(name="vortex_data", velocity_data={"path": str(path)})


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    directory = tmp_path_factory.mktemp("vortex")
    found = {}
    for cell, step in ((0.1, 0.2), (0.05, 0.1)):
        system = vortex_data(directory, cell, step)
        found[cell] = (system, ldpipe.lavd(system, section=SECTION, duration=T, interval=0.1,
                                           integrator={"rtol": 1e-10, "atol": 1e-10}))
    return found


def test_the_data_vorticity_is_the_vortex_s(results):
    # at t = 1 the vorticity about the centre (0.5, 0): measured largest error 0.031 and 0.0057
    # of w0 = 1 (cells of 0.1 and 0.05: second order, 5.5 times smaller)
    errors = []
    points = np.column_stack([np.linspace(-0.2, 1.1, 40), np.linspace(-0.6, 0.55, 40)])
    exact = W0 * np.exp(-((points[:, 0] - U) ** 2 + points[:, 1] ** 2) / R**2)
    for system, _ in results.values():
        errors.append(np.abs(data_vorticity(system, points, 1.0) - exact).max())
    assert errors[1] < 0.015 and errors[0] / errors[1] > 3, errors


def test_lavd_of_velocity_data_is_the_closed_form(results):
    errors = []
    for _, result in results.values():
        x, y = np.meshgrid(result.x.values, result.y.values, indexing="ij")
        omega = W0 * np.exp(-(x**2 + y**2) / R**2)
        assert result.lavd_defined.values.all()
        errors.append(np.abs(result.lavd.values - T * np.abs(omega - omega.mean())).max())
    # measured: 0.053 and 0.0093 (of a largest LAVD of 3.7)
    assert errors[1] < 0.03 and errors[0] / errors[1] > 3, errors


def test_vortex_centre_and_boundary_from_velocity_data(results):
    _, result = results[0.05]
    assert result.sizes["vortex"] == 1
    cell = float(result.x[1] - result.x[0])
    centre = np.array([float(result.centre_x[0]), float(result.centre_y[0])])
    end = np.array([float(result.centre_end_x[0]), float(result.centre_end_y[0])])
    # measured: 0.036 cells from the origin, and at t0 + T 0.036 cells from (U T, 0)
    assert np.hypot(*centre) < 0.15 * cell
    assert np.hypot(*(end - [U * T, 0.0])) < 0.15 * cell

    x, y = np.meshgrid(result.x.values, result.y.values, indexing="ij")
    mean = float(np.mean(W0 * np.exp(-(x**2 + y**2) / R**2)))
    r_zero = R * math.sqrt(math.log(W0 / mean))
    level = float(result.level[0])
    r_level = R * math.sqrt(-math.log(level / (T * W0) + mean / W0))
    boundary = np.column_stack([result.boundary_x.values, result.boundary_y.values])
    r = np.hypot(*(boundary - centre).T)
    # measured: r from 0.4677 to 0.4878 (cells of 0.051); r_level 0.4697, r* 0.4933
    assert r.min() > r_level - 0.2 * cell and r.max() < r_zero, (r.min(), r.max(), r_level, r_zero)
    assert r_zero - r.mean() < 0.6 * cell
    assert float(result.convexity_deficiency[0]) < 0.01
    assert float(result.area[0]) == pytest.approx(math.pi * r.mean() ** 2, rel=0.02)


def test_lavd_refuses_velocity_data_on_the_sphere(tmp_path):
    # the vorticity on the sphere needs its metric: refused, naming what is taken
    lon, lat, t = np.linspace(0, 10, 11), np.linspace(-5, 5, 11), np.linspace(0, 2, 3)
    path = write_velocity_file(tmp_path / "sphere.nc", lambda X, Y, T_: (0.1 + 0 * X, 0 * Y), lon, lat, t,
                               names=("lon", "lat"))
    system = ldpipe.system(name="sphere_data", velocity_data={"path": str(path), "x": "lon", "y": "lat",
                                                              "coordinates": "sphere"})
    with pytest.raises(ConfigError, match=r"ldpipe.lavd: system 'sphere_data'.*regular or rectilinear grid in the plane"):
        ldpipe.lavd(system, section=ldpipe.section(lon=(2, 8, 5), lat=(-2, 2, 5)), duration=1.0)
