"""A velocity dataset read from a zarr store gives the same map as from netCDF, bit for bit.

Both stores hold the same float64 values (written from one xarray Dataset), and the data window
the engine reads is the same array, so every variable of the map must be identical: an
invariant of the reading, no tolerance.
"""

import numpy as np
import xarray as xr

from ldpipe.config import validate_config
from ldpipe.core.maps.assembly import compute_ld_map
from ldpipe.config.parameters import parameters_from_config
from support.double_gyre import double_gyre_velocity
from support.gridded import write_velocity_file

H = 1.0 / 8


def test_zarr_and_netcdf_give_identical_maps(tmp_path):
    x, y, t = np.arange(0, 2 + H / 2, H), np.arange(0, 1 + H / 2, H), np.arange(0.0, 6.0 + H / 2, H)
    netcdf = write_velocity_file(tmp_path / "gyre.nc", double_gyre_velocity, x, y, t)
    with xr.open_dataset(netcdf) as dataset:
        # zarr format 2 with consolidated metadata, as published ocean stores are (format 3 warns on consolidating)
        dataset.load().to_zarr(tmp_path / "gyre.zarr", mode="w", zarr_format=2)
    spec = {"t0": 3.0, "tau": 2.0, "p": 0.5, "ftle": True, "integrator": {"rtol": 1e-9, "atol": 1e-9},
            "section": {"axes": [{"name": "x", "range": [0.1, 1.9], "points": 6},
                                 {"name": "y", "range": [0.1, 0.9], "points": 4}]}}
    config = validate_config({"systems": {"nc": {"velocity_data": {"path": str(netcdf)}},
                                          "zarr": {"velocity_data": {"path": str(tmp_path / "gyre.zarr")}}},
                              "ld_maps": {"a": {**spec, "system": "nc"}, "b": {**spec, "system": "zarr"}}})
    maps = [compute_ld_map(parameters_from_config(config, "ld", name), None, show_progress=False) for name in "ab"]
    assert sorted(maps[0].data_vars) == sorted(maps[1].data_vars)
    for name in maps[0].data_vars:
        np.testing.assert_array_equal(maps[0][name].values, maps[1][name].values, err_msg=name)
    assert maps[0].ftle_forward.values.max() > 0.1  # the gyre stretches: the comparison is not of zeros
