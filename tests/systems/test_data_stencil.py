"""The vector tensor-product sum of the velocity-data kernel (``ldpipe.systems.data_stencil``).

Against an independent evaluation: numpy's einsum of the same weights over the same 4 x 4 x 4
(u, v) read from a buffer laid out as the kernel's (y, x, time, u/v), at offsets that start
anywhere (the vector loads are unaligned). The two sum in different orders, so they agree to
rounding: a few ulps of the sum of the terms' magnitudes.
"""

import numpy as np
from numba import njit

from ldpipe.systems.data_pointer import bound_data, velocity_data_pointer
from ldpipe.systems.data_stencil import stencil_velocity


@njit
def stencil(first, x_step, y_step, wx, wy, wt):
    """The sum over the bound buffer, read through the pointer the kernel reads."""
    return stencil_velocity(velocity_data_pointer(), first, x_step, y_step, wx, wy, wt)


def test_stencil_matches_the_triple_sum():
    rng = np.random.default_rng(7)
    ny, nx, nt = 6, 7, 9
    field = rng.normal(size=(ny, nx, nt, 2))
    buffer = np.concatenate([rng.normal(size=5), field.ravel()])  # a header of 5: offsets not a multiple of 8

    for _ in range(20):
        j, i, k = (int(rng.integers(0, n - 3)) for n in (ny, nx, nt))
        wx, wy, wt = (tuple(rng.uniform(-0.2, 1.0, 4)) for _ in range(3))
        first = 5 + 2 * ((j * nx + i) * nt + k)
        with bound_data(buffer):
            u, v = stencil(first, 2 * nt, 2 * nt * nx, wx, wy, wt)
        block = field[j:j + 4, i:i + 4, k:k + 4]  # (b, a, c, component)
        exact = np.einsum("bacn,a,b,c->n", block, wx, wy, wt)
        scale = np.einsum("bacn,a,b,c->n", np.abs(block), np.abs(wx), np.abs(wy), np.abs(wt))
        assert np.all(np.abs(np.array([u, v]) - exact) <= 8 * np.finfo(float).eps * scale), (u, v, exact)
