"""Uneven times on a curvilinear grid and a C-grid, against closed forms.

The non-uniform cubic in time (kernels/nonuniform_cubic_weights.py's, in the curvilinear and C-grid
kernels) reproduces every quadratic in time exactly, the ghost times on the end nodes' parabola
included; in space the interpolants are exact for these fields on the rotated grid (affine): a
linear field for the collocated grid's cubic convolution, a uniform one for the C-grid's faces.

- A solid-body rotation about (1, 0.5) whose rate is quadratic in time, omega(t) = omega0 (1 +
  b t + c t^2): a start turns by theta(t0 + tau) - theta(t0), theta = omega0 (t + b t^2/2 + c t^3/3),
  and its arc length is r times that angle (closed forms).
- A uniform flow along the C-grid's i of speed u0 (1 + b t + c t^2) (no land): the index moves by
  the integral of u / h (closed form).
"""

import math

import numpy as np
import pytest

from ldpipe.data.curvilinear import c_grid_dataset, curvilinear_dataset, plane_grid, write_dataset
from ldpipe.engine import LDSettings, compute_ld
from ldpipe.systems import make_system

pytestmark = [pytest.mark.compiles, pytest.mark.xdist_group("curvilinear_grids")]
TIGHT = {"rtol": 1e-11, "atol": 1e-11}
#: Output times as uneven as monthly means and worse: spacings from 0.4 to 1.1.
TIMES = np.array([0.0, 0.6, 1.5, 1.9, 2.8, 3.3, 4.4, 5.1, 6.0])
OMEGA, B, C = 0.3, 0.3, -0.04  # omega(t) > 0 on [0, 6]


def rate(t):
    return 1.0 + B * t + C * t * t


def turned(t):
    return t + B * t * t / 2 + C * t ** 3 / 3


def test_a_rotation_quadratic_in_time_at_uneven_times(tmp_path):
    x, y = plane_grid("rotated", 0.1)
    field = lambda X, Y, T: (-OMEGA * rate(T) * (Y - 0.5), OMEGA * rate(T) * (X - 1.0))  # noqa: E731
    path = write_dataset(curvilinear_dataset(field, x, y, TIMES), tmp_path / "rotation.nc")
    data = make_system("s", {"velocity_data": {"path": str(path), "components": "geographic"}})
    starts = np.array([[1.5, 0.5], [1.2, 0.9], [0.6, 0.3], [1.1, 0.2]])
    radius = np.hypot(starts[:, 0] - 1.0, starts[:, 1] - 0.5)
    phase = np.arctan2(starts[:, 1] - 0.5, starts[:, 0] - 1.0)
    for direction, t0, tau in ((1, 0.2, 5.5), (-1, 5.9, 5.0), (1, 1.6, 1.0)):
        result = compute_ld(data, starts, direction, LDSettings(tau=tau, p="arclength", **TIGHT), t0=t0)
        angle = OMEGA * (turned(t0 + direction * tau) - turned(t0))
        expected = np.column_stack([1.0 + radius * np.cos(phase + angle), 0.5 + radius * np.sin(phase + angle)])
        # measured: 3.9e-12 (positions), 9.1e-12 (arc length): the integrator's tolerance; read as
        # even times at their mean spacing they miss by 8e-3
        np.testing.assert_allclose(result.end_state, expected, rtol=0, atol=4e-11)
        np.testing.assert_allclose(result.ld, radius * abs(angle), rtol=0, atol=4e-11)


def test_a_uniform_c_grid_flow_quadratic_in_time_at_uneven_times(tmp_path):
    h, u0 = 0.1, 0.02
    x, y = plane_grid("rotated", h)
    dataset = c_grid_dataset(lambda X, Y, T: u0 * rate(T) + 0 * X, lambda X, Y, T: 0 * X + 0 * T, x, y, TIMES)
    path = write_dataset(dataset, tmp_path / "c.nc")
    data = make_system("c", {"velocity_data": {"path": str(path), "x": "x_rho", "y": "y_rho",
                                               "components": "grid"}})
    a0 = np.array([-0.9, -0.5, 0.0, 0.3])  # the grid's frame: node (i, j) at a = -1.4 + h i, b = -1.2 + h j
    b0 = np.array([-0.4, 0.0, 0.3, 0.6])
    angle = math.radians(30.0)

    def physical(a, b):
        return np.column_stack([1.0 + math.cos(angle) * a - math.sin(angle) * b,
                                0.5 + math.sin(angle) * a + math.cos(angle) * b])

    for direction, t0, tau in ((1, 0.1, 5.8), (-1, 5.5, 4.7)):
        result = compute_ld(data, physical(a0, b0), direction, LDSettings(tau=tau, p="arclength", **TIGHT), t0=t0)
        run = u0 * (turned(t0 + direction * tau) - turned(t0))  # the distance along a (signed)
        # measured: 2.2e-16 (positions), 2.9e-14 (arc length); read as even times at their mean
        # spacing they miss by 1.1e-3
        np.testing.assert_allclose(result.end_state, physical(a0 + run, b0), rtol=0, atol=1e-12)
        np.testing.assert_allclose(result.ld, abs(run), rtol=0, atol=1e-12)
