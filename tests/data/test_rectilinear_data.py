"""Velocity data on rectilinear grids (unevenly spaced axes), against closed forms.

- A field of degree <= 2 in each variable, which the non-uniform cubic reproduces exactly (the
  slopes of parabolas through three nodes are exact for quadratics), sampled on random uneven
  grids gives the formula system's LD and end states to the integrator's tolerance; a regular
  grid keeps the uniform kernel.
- The double gyre (support.double_gyre) on refined uneven grids: the velocity and LD errors
  against the formula system fall at the interpolant's third order.
"""

import numpy as np

from ldpipe.systems import VelocityDataSystem, make_system
from support.double_gyre import sampled_gyre_errors
from support.gridded import assert_quadratic_field_ld, quadratic_field, write_velocity_file


def data_system(path, name="data", **entry):
    return make_system(name, {"velocity_data": {"path": str(path), **entry}})


def uneven(low, high, count, rng, spread=0.6):
    """``count`` increasing nodes from ``low`` to ``high``, spacings random within 1 +- ``spread`` of each other."""
    steps = rng.uniform(1 - spread, 1 + spread, count - 1)
    return low + (high - low) * np.concatenate([[0.0], np.cumsum(steps)]) / steps.sum()


def test_uneven_quadratic_field_gives_the_formula_ld(tmp_path):
    # the field of tests/data/test_velocity_data.py (degree <= 2 in x, y, t), now on random uneven
    # x, y and t: reproduced exactly, so the LD is the formula system's (to the integrator's tolerance)
    rng = np.random.default_rng(7)
    path = write_velocity_file(tmp_path / "q.nc", quadratic_field, uneven(-4, 4, 9, rng), uneven(-3, 3, 7, rng),
                               uneven(0, 6, 7, rng))
    data = data_system(path)
    assert data.engine_name == "velocity_data_rectilinear2"
    assert_quadratic_field_ld(data)
    # a regular grid keeps the uniform kernel, within the uniformity tolerance (1e-6 of the spacing) too
    for name, jitter in (("regular", 0.0), ("nearly", 1e-9)):
        x = np.linspace(-4, 4, 9) + jitter * np.sin(np.arange(9.0))
        regular = data_system(write_velocity_file(tmp_path / f"{name}.nc", quadratic_field, x, np.linspace(-3, 3, 7),
                                                  np.linspace(0, 6, 7)))
        assert type(regular) is VelocityDataSystem and regular.engine_name == "velocity_data"


def warped(low, high, count):
    """Nodes x(s) = low + (high - low) (s - 0.08 sin(2 pi s)) at even s: a smooth grid whose
    spacings vary by a factor 3 (ocean depth levels, Mercator latitudes), refined by ``count``."""
    s = np.linspace(0.0, 1.0, count)
    return low + (high - low) * (s - 0.08 * np.sin(2 * np.pi * s))


def _slope(spacings, errors):
    return np.polyfit(np.log(spacings), np.log(errors), 1)[0]


def test_double_gyre_on_uneven_grids_converges_at_third_order(tmp_path):
    counts = (8, 16, 32)
    grids = [(warped(0, 2, 2 * n + 1), warped(0, 1, n + 1), warped(1.5, 7.5, 6 * n + 1)) for n in counts]
    ld_errors, velocity_errors = sampled_gyre_errors(tmp_path, grids, probes=100)
    spacings = [1.0 / n for n in counts]  # the mean spacing of every axis; the largest is 1.5 times it
    # third order (the Hermite cubic on parabolic slopes); measured slopes: velocity 3.15 (errors 1.7e-3 ..
    # 2.1e-5), LD 2.95 (1.3e-2 .. 2.1e-4)
    assert 2.7 < _slope(spacings, velocity_errors) < 3.5, velocity_errors
    assert 2.5 < _slope(spacings, ld_errors) < 3.5, ld_errors
