"""Analytic velocity fields sampled onto grids (any increasing axes) and written as CF netCDF files (for velocity-data tests)."""

import numpy as np
import xarray as xr


def write_velocity_file(path, field, x, y, t, *, names=("x", "y"), units="m/s", time_units="s", land=None):
    """Sample ``field(X, Y, T) -> (u, v)`` on the grid (x, y, t) and write it to ``path``.

    ``land(X, Y)`` (optional) is True where the grid node is land: u, v are missing (NaN) there.
    Returns ``path``.
    """
    T, Y, X = np.meshgrid(t, y, x, indexing="ij")
    u, v = (np.broadcast_to(c, T.shape).astype(float) for c in field(X, Y, T))
    if land is not None:
        mask = np.broadcast_to(land(X[0], Y[0]), T.shape)
        u = np.where(mask, np.nan, u)
        v = np.where(mask, np.nan, v)
    attrs = {"units": units} if units else {}
    dims = ("time", names[1], names[0])
    dataset = xr.Dataset({"u": (dims, u, attrs), "v": (dims, v, attrs)},
                         coords={names[0]: (names[0], x), names[1]: (names[1], y),
                                 "time": ("time", t, {"units": time_units} if time_units else {})})
    dataset.to_netcdf(path)
    return path


def write_velocity_file_3d(path, field, x, y, z, t, *, names=("x", "y", "z"), units="m/s", time_units="s",
                           z_units="m", positive="down", land=None):
    """Sample ``field(X, Y, Z, T) -> (u, v, w)`` (w upward) on the grid (x, y, z, t) and write u, v, w
    on (time, z, y, x) to ``path``, the vertical coordinate with its ``units`` and CF ``positive``
    attribute (None: left out). ``land(X, Y, Z)`` (optional) is True at land nodes (NaN there). Returns ``path``."""
    T, Z, Y, X = np.meshgrid(t, z, y, x, indexing="ij")
    u, v, w = (np.broadcast_to(c, T.shape).astype(float) for c in field(X, Y, Z, T))
    if land is not None:
        mask = np.broadcast_to(land(X[0], Y[0], Z[0]), T.shape)
        u, v, w = (np.where(mask, np.nan, c) for c in (u, v, w))
    attrs = {"units": units}
    dims = ("time", names[2], names[1], names[0])
    vertical = {k: value for k, value in (("units", z_units), ("positive", positive)) if value}
    dataset = xr.Dataset({"u": (dims, u, attrs), "v": (dims, v, attrs), "w": (dims, w, attrs)},
                         coords={names[0]: (names[0], x), names[1]: (names[1], y), names[2]: (names[2], z, vertical),
                                 "time": ("time", t, {"units": time_units})})
    dataset.to_netcdf(path)
    return path


def quadratic_field(x, y, t):
    """u = 0.3 + 0.1 y^2 - 0.05 t x, v = -0.2 x + 0.02 t^2: degree <= 2 in each variable, which the
    velocity-data interpolants reproduce exactly (on even and uneven grids)."""
    return 0.3 + 0.1 * y**2 - 0.05 * t * x, -0.2 * x + 0.02 * t**2


def assert_quadratic_field_ld(data) -> None:
    """``data`` (:func:`quadratic_field` sampled on a grid covering x in [-4, 4], y in [-3, 3], t in
    [0, 6]) gives the formula system's LD and end states to the integrator's tolerance, forward and backward."""
    from ldpipe.engine import LDSettings, compute_ld
    from ldpipe.systems import make_system

    formula = make_system("quadratic_field", {"vector_field": {"x": "0.3 + 0.1*y**2 - 0.05*t*x", "y": "-0.2*x + 0.02*t**2"},
                                              "coordinates": ["x", "y"]})
    states = np.array([[0.0, 0.0], [0.7, -1.1], [-1.3, 0.9], [1.6, 1.4]])
    for direction, t0 in ((1, 1.0), (-1, 4.5)):
        settings = LDSettings(tau=1.5, p=0.5, rtol=1e-11, atol=1e-11)
        got = compute_ld(data, states, direction, settings, t0=t0)
        want = compute_ld(formula, states, direction, settings, t0=t0)
        # measured: LD relative differences 4e-14 (5e-14 on the uneven grid), end states 1e-13 absolute
        # (rounding in the interpolation sums)
        np.testing.assert_allclose(got.ld, want.ld, rtol=1e-12)
        np.testing.assert_allclose(got.end_state, want.end_state, rtol=1e-12, atol=1e-12)
        assert not got.failed.any()


def sampled_flow_errors(directory, grids, probes: int, *, formula: dict, velocity, starts: np.ndarray, t0: float,
                        tau: float, probe_box) -> tuple[list[float], list[float]]:
    """An analytic flow, given as the formula system ``formula`` and as numpy ``velocity(x, y, t)
    -> (u, v)``, sampled on each grid of ``grids`` (``(x, y, t)`` node arrays covering the
    trajectories of ``starts`` over [t0, t0 + tau] and a stencil more) as velocity data: per grid,
    the largest LD (M_1/2, forward, rtol 1e-12) error against the formula system over ``starts``,
    and the largest velocity error at ``probes`` random points of ``probe_box`` ((x0, x1), (y0, y1),
    (t0, t1)). Returns (LD errors, velocity errors)."""
    from ldpipe.engine import LDSettings, compute_ld
    from ldpipe.systems import make_system

    settings = LDSettings(tau=tau, p=0.5, rtol=1e-12, atol=1e-12)
    reference = compute_ld(make_system("formula", formula), starts, 1, settings, t0=t0)
    rng = np.random.default_rng(1)
    points = np.column_stack([rng.uniform(low, high, probes) for low, high in probe_box])
    exact = np.array(velocity(points[:, 0], points[:, 1], points[:, 2])).T
    ld_errors, velocity_errors = [], []
    for k, (x, y, t) in enumerate(grids):
        path = write_velocity_file(directory / f"sampled{k}.nc", velocity, x, y, t)
        data = make_system("sampled", {"velocity_data": {"path": str(path)}})
        result = compute_ld(data, starts, 1, settings, t0=t0)
        ld_errors.append(np.max(np.abs(result.ld - reference.ld)))
        velocity_errors.append(max(np.max(np.abs(data.vector_field(p[:2], p[2]) - u)) for p, u in zip(points, exact)))
    return ld_errors, velocity_errors
