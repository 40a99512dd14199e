"""The FTLE by grid differences at the edges of a map and of the data, against closed forms.

- A flow map F(a, b) = (a + c sin b, b), a shear whose rate varies across b: J = [[1, c cos b],
  [0, 1]], so lambda_max = 1 + g^2/2 + |g| sqrt(1 + g^2/4) with g = c cos b (closed form). Its
  b-derivative by the centred difference errs by -h^2/6 of it, by numpy's second-order one-sided
  one at the edges by +h^2/3 (Taylor): the FTLE high along every edge, a bright frame. The edges'
  third-order stencil must err less than the interior, and its error fall as h^3.
- A uniform strain u = s x, v = -s y written as gridded data, the map's section the data's whole
  extent: the flow map is (x e^(sT), y e^(-sT)), linear, so every stencil is exact and the FTLE is
  s wherever defined; a trajectory stays in the data [-1, 1]^2 over T forward where
  |x| e^(sT) <= 1 (backward |y| e^(sT) <= 1), and every such point has an FTLE, those beside a
  neighbour that left the data too (one-sided away from it).
- The shear u = U sin(k y), v = 0 as data, the section's edges on the data's edges in y: the
  map's FTLE (interpolated velocity, differenced end states) is as close to the closed form at
  the edges as inside.
"""

import math

import numpy as np
import pytest

import ldpipe
from ldpipe.core.maps.ftle import ftle
from support.gridded import write_velocity_file


def shear_ftle(gamma: np.ndarray, time: float) -> np.ndarray:
    """ln(lambda_max) / (2 T) of J = [[1, gamma], [0, 1]]: lambda_max = 1 + g^2/2 + |g| sqrt(1 + g^2/4)."""
    lam = 1 + gamma**2 / 2 + np.abs(gamma) * np.sqrt(1 + gamma**2 / 4)
    return np.log(lam) / (2 * time)


def test_edge_differences_are_as_accurate_as_the_interior():
    c, time = 2.0, 1.0
    edge_errors, inner_errors = [], []
    spacings = (0.2, 0.1, 0.05)
    for h in spacings:
        a = h * np.arange(-2.0, 3.0)
        b = 0.2 + h * np.arange(round(0.8 / h) + 1)  # b in [0.2, 1.0]: cos and sin both away from zero
        A, B = np.meshgrid(a, b, indexing="ij")
        ends = np.stack([A + c * np.sin(B), B], axis=-1)
        values, defined = ftle(ends, (a, b), time, np.ones(A.shape, dtype=bool))
        assert defined.all()
        error = np.abs(values[2] / shear_ftle(c * np.cos(b), time) - 1)
        edge_errors.append(max(error[0], error[-1]))
        inner_errors.append(error[1:-1].max())
    # measured: the interior's errors 5.9e-3, 1.5e-3, 3.8e-4 (slope 2); the edges' third-order stencil
    # 2.3e-3, 3.3e-4, 4.3e-5 (slope 2.9); numpy's second-order one-sided one 1.5e-2, 3.4e-3, 8.1e-4,
    # each above the interior's (the bright frame)
    assert all(edge < inner for edge, inner in zip(edge_errors, inner_errors)), (edge_errors, inner_errors)
    slope = np.polyfit(np.log(spacings), np.log(edge_errors), 1)[0]
    assert 2.7 < slope < 3.3, edge_errors


STRAIN, TAU = 0.1, 3.0


@pytest.fixture(scope="module")
def strain_map(tmp_path_factory):
    axis = np.linspace(-1.0, 1.0, 41)
    path = write_velocity_file(tmp_path_factory.mktemp("strain") / "strain.nc",
                               lambda X, Y, T: (STRAIN * X + 0 * T, -STRAIN * Y), axis, axis, np.linspace(0.0, 10.0, 11))
    section = ldpipe.section(x=(-1.0, 1.0, 41), y=(-1.0, 1.0, 41))
    return ldpipe.ld_map(ldpipe.system(velocity_data={"path": str(path)}), section=section, t0=5.0, tau=TAU,
                         ftle=True, ld=False, progress=False)


def test_uniform_strain_ftle_is_its_rate_up_to_the_data_edge(strain_map):
    x, y = np.meshgrid(strain_map.x.values, strain_map.y.values, indexing="ij")
    growth = math.exp(STRAIN * TAU)
    for label, stretched in (("forward", x), ("backward", y)):
        stays = np.abs(stretched) * growth <= 1.0  # closed form; the nearest grid point is 0.04 inside
        np.testing.assert_array_equal(strain_map[f"ftle_defined_{label}"].values, stays, err_msg=label)
        # beside the points that left, the old rule (every neighbour ran the whole time) left a
        # column undefined each side: 27 of the 29 columns that stay
        assert stays.sum() == 29 * 41
        # measured relative error 2.5e-13 (the integrator's rounding; the flow map is linear)
        np.testing.assert_allclose(strain_map[f"ftle_{label}"].values[stays], STRAIN, rtol=2e-12, err_msg=label)


def test_shear_data_ftle_at_the_data_edge(tmp_path):
    u, k, time, h = 0.05, 1.0, 10.0, 0.4
    y = h * np.arange(8)
    path = write_velocity_file(tmp_path / "shear.nc", lambda X, Y, T: (u * np.sin(k * Y) + 0 * T, 0 * X),
                               np.arange(-2.0, 2.0 + h / 2, h), y, np.linspace(0.0, 20.0, 5))
    section = ldpipe.section(x=(-h, h, 3), y=(0.0, float(y[-1]), len(y)))
    dataset = ldpipe.ld_map(ldpipe.system(velocity_data={"path": str(path)}), section=section, t0=10.0, tau=time,
                            ftle=True, ld=False, progress=False, integrator={"rtol": 1e-12, "atol": 1e-12})
    assert dataset.ftle_defined_forward.values[1].all()  # the middle row along x (three points)
    error = np.abs(dataset.ftle_forward.values[1] / shear_ftle(time * u * k * np.cos(k * y), time) - 1)
    # measured: interior 2.6e-2 (the centred difference's h^2/6), edges 7.1e-3 and 1.2e-2; with the
    # second-order one-sided differences 4.9e-2 and 4.4e-2, the edges brighter than the interior
    assert max(error[0], error[-1]) < error[1:-1].min(), error
