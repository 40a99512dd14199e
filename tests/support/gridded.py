"""Analytic velocity fields sampled onto regular grids and written as CF netCDF files (for velocity-data tests)."""

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
