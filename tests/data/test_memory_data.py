"""Velocity data from Python: ``ldpipe.system(velocity_data=...)`` given an ``xarray.Dataset``
(in memory, decoded by xarray, or lazy and dask-backed) or the DataArrays u, v.

The reference is the pipeline's own route: the same data written to netCDF and named by path.
The maps must agree bit for bit (the same values reach the same compiled engine), and the map's
file must say that its data came from memory (no path) with their variables, shape and hash.
The data are ldpipe's example (a jet by a coast on the sphere, with land), coarsened.
"""

import json

import dask.array
import numpy as np
import pandas as pd
import pytest
import xarray as xr

import ldpipe
from ldpipe.data.example import example_dataset

SECTION = {"section": {"axes": [{"name": "lon", "range": [-70.0, -50.0], "points": 9},
                                {"name": "lat", "range": [30.0, 40.0], "points": 7}], "fixed": {}},
           "t0": 1.0, "tau": 1.0}


@pytest.fixture(scope="module")
def example():
    """Four days every 6 h on a 1-degree grid; its file and the map from the file."""
    return example_dataset(days=4.0, step_hours=6.0, resolution=1.0)


@pytest.fixture(scope="module")
def example_file(example, tmp_path_factory):
    path = tmp_path_factory.mktemp("memory") / "example.nc"
    example.to_netcdf(path)
    return path


@pytest.fixture(scope="module")
def file_map(example_file):
    system = ldpipe.system(name="ex", velocity_data={"path": str(example_file), "coordinates": "sphere"})
    return ldpipe.ld_map(system, **SECTION)


def assert_same_data(got, expected):
    assert list(got.data_vars) == list(expected.data_vars)
    for name, variable in expected.data_vars.items():
        np.testing.assert_array_equal(got[name].values, variable.values, err_msg=name, strict=True)


def recorded_entry(ld_map):
    return json.loads(ld_map.attrs["parameters"])["system_spec"]["velocity_data"]


def test_a_map_from_a_dataset_in_memory_equals_the_map_from_its_file(example, example_file, file_map):
    assert file_map.allowed.values.any() and np.isfinite(file_map.ld_forward.values).any()
    in_memory = ldpipe.ld_map(ldpipe.system(name="ex", velocity_data={"dataset": example, "coordinates": "sphere"}),
                              **SECTION)
    assert_same_data(in_memory, file_map)
    # xarray's own reading of the file, times decoded to dates (its default): encoded back as written
    decoded = xr.open_dataset(example_file)
    assert decoded.time.dtype.kind == "M"
    from_decoded = ldpipe.ld_map(ldpipe.system(name="ex", velocity_data={"dataset": decoded, "coordinates": "sphere"}),
                                 **SECTION)
    assert_same_data(from_decoded, file_map)
    # the DataArrays alone, the grid's names read from u's dimensions
    arrays = ldpipe.system(name="ex", velocity_data={"u": example.u, "v": example.v, "coordinates": "sphere"})
    assert arrays.coordinates == ("lon", "lat")
    assert_same_data(ldpipe.ld_map(arrays, **SECTION), file_map)

    entry = recorded_entry(in_memory)
    assert "path" not in entry and recorded_entry(file_map)["path"] == str(example_file)
    record = entry["memory"]
    assert record["variables"] == ["u", "v", "time", "lat", "lon"]
    assert record["shape"] == {"time": 17, "lat": 26, "lon": 41}  # 4 days / 6 h + 1, 25 / 1 + 1, 40 / 1 + 1
    assert record["hash"].startswith("sha256:") and len(record["hash"]) == len("sha256:") + 64
    # the hash is of the values: the same values hash alike, one value changed does not
    assert recorded_entry(from_decoded)["memory"]["hash"] == record["hash"]
    changed = example.copy(deep=True)
    changed.u[3, 10, 20] += 1e-3
    other = ldpipe.system(name="ex", velocity_data={"dataset": changed, "coordinates": "sphere"})
    assert other.spec["velocity_data"]["memory"]["hash"] != record["hash"]


def test_a_lazy_dataset_gives_the_same_map_and_is_not_read_to_hash_it(example_file, file_map):
    lazy = xr.open_dataset(example_file, chunks={"time": 4})
    assert lazy.u.chunks is not None
    system = ldpipe.system(name="ex", velocity_data={"dataset": lazy, "coordinates": "sphere"})
    assert system.spec["velocity_data"]["memory"]["hash"].startswith("dask:")
    assert_same_data(ldpipe.ld_map(system, **SECTION), file_map)


def test_only_the_window_a_map_needs_is_read_from_a_lazy_dataset(example):
    # u and v as dask arrays of one time step per block that record which blocks are computed
    read = set()

    def block(array, block_info=None):
        read.add(block_info[0]["chunk-location"][0])
        return array

    lazy = example.copy()
    for name in ("u", "v"):
        values = dask.array.from_array(example[name].values, chunks=(1, -1, -1))
        lazy[name] = (example[name].dims, values.map_blocks(block, dtype=values.dtype), example[name].attrs)
    system = ldpipe.system(name="ex", velocity_data={"dataset": lazy, "coordinates": "sphere"})
    assert read == set()  # built and hashed without reading a value
    ldpipe.ld_map(system, **SECTION)
    # times 0..4 days every 6 h: [t0 - tau, t0 + tau] = [0, 2] days is steps 0..8; the cubic stencil
    # and the window's padding reach two steps beyond, 10 at most; the last 6 steps are never read
    assert read and max(read) <= 10 and len(read) < 17


def test_data_in_memory_of_the_wrong_shape_get_a_message_naming_the_variable(example):
    u, v = example.u, example.v
    with pytest.raises(ldpipe.ConfigError, match=r"ldpipe.system: argument 'velocity_data.v': variable 'v' has "
                                                 r"dimensions \('lat', 'lon'\); expected \('time', 'lat', 'lon'\)"):
        ldpipe.system(velocity_data=(u, v.isel(time=0, drop=True)))
    with pytest.raises(ldpipe.ConfigError, match=r"argument 'velocity_data.u': variable 'u' has dimensions "
                                                 r"\('lat', 'lon'\) \(shape \(26, 41\)\); expected 3"):
        ldpipe.system(velocity_data=(u.isel(time=0, drop=True), v))
    with pytest.raises(ldpipe.ConfigError, match=r"argument 'velocity_data': the DataArrays do not share one grid"):
        ldpipe.system(velocity_data=(u, v.assign_coords(lon=v.lon + 0.5)))
    with pytest.raises(ldpipe.ConfigError, match=r"argument 'velocity_data.v': expected an xarray.DataArray"):
        ldpipe.system(velocity_data={"u": u, "v": v.values})
    with pytest.raises(ldpipe.ConfigError, match=r"argument 'velocity_data.u': variable 'uo' not in the dataset"):
        ldpipe.system(velocity_data={"dataset": example, "u": "uo"})
    with pytest.raises(ldpipe.ConfigError, match=r"argument 'velocity_data.u': variable 'u' has no 'units'"):
        ldpipe.system(velocity_data=(u.drop_attrs(), v))


def test_an_entry_naming_data_in_memory_that_this_process_lacks_is_refused():
    from ldpipe.config import validate_config
    from ldpipe.systems import make_system

    record = {"variables": ["u", "v", "time", "y", "x"], "shape": {"time": 3, "y": 3, "x": 3},
              "hash": "sha256:" + "0" * 64}
    config = validate_config({"systems": {"gone": {"velocity_data": {"memory": record}}}})
    with pytest.raises(ldpipe.ConfigError, match=r"'systems.gone.velocity_data.memory': no dataset with hash"):
        make_system("gone", config["systems"]["gone"])
    with pytest.raises(ldpipe.ConfigError, match=r"'systems.none.velocity_data.path': required"):
        validate_config({"systems": {"none": {"velocity_data": {"u": "u"}}}})


@pytest.mark.parametrize(("t0", "tau"), [("2000-01-02T06", "1D"),
                                         (np.datetime64("2000-01-02T06:00"), np.timedelta64(24, "h")),
                                         (pd.Timestamp("2000-01-02 06:00"), pd.Timedelta(hours=24))])
def test_dates_and_durations_give_the_map_of_their_numbers(example, t0, tau):
    # the example's time axis is "days since 2000-01-01" (standard calendar): 2000-01-02 06:00 is
    # day 1.25 and 24 hours one day, by the definition of the units
    system = ldpipe.system(name="ex", velocity_data={"dataset": example, "coordinates": "sphere"})
    numeric = ldpipe.ld_map(system, **{**SECTION, "t0": 1.25, "tau": 1.0})
    dated = ldpipe.ld_map(system, **{**SECTION, "t0": t0, "tau": tau})
    assert_same_data(dated, numeric)
    assert (dated.attrs["t0"], dated.attrs["tau"]) == (1.25, 1.0)
    assert (dated.attrs["t0_date"], dated.attrs["tau_duration"]) == ("2000-01-02T06:00:00", "P1DT0H0M0S")
    # several start times: each one placed, the file's t0 coordinate in days, its dates beside them
    several = ldpipe.ld_map(system, **{**SECTION, "t0": ["2000-01-02", "2000-01-02T12"], "tau": "1D"})
    assert several.t0.values.tolist() == [1.0, 1.5]
    assert several.attrs["t0_dates"] == "2000-01-02T00:00:00, 2000-01-02T12:00:00"


def test_a_date_without_a_calendar_gets_its_own_message(example):
    plain = example.copy()
    plain["time"] = plain.time.assign_attrs(units="days")  # a time unit, no reference date
    del plain.time.attrs["calendar"]
    system = ldpipe.system(name="plain", velocity_data={"dataset": plain, "coordinates": "sphere"})
    with pytest.raises(ldpipe.ConfigError, match=r"^ldpipe.ld_map: argument 't0': '2000-01-02' is a date, but the "
                                                 r"time coordinate 'time' .* is no calendar"):
        ldpipe.ld_map(system, **{**SECTION, "t0": "2000-01-02"})
    flow = ldpipe.system(vector_field={"x": "y", "y": "-x"}, coordinates=["x", "y"])
    with pytest.raises(ldpipe.ConfigError, match=r"^ldpipe.ld_map: argument 't0': .* is a date, but system 'system' "
                                                 r"has no calendar"):
        ldpipe.ld_map(flow, section=ldpipe.section(x=(0, 1, 3), y=(0, 1, 3)), t0=np.datetime64("2000-01-02"))
    with pytest.raises(ldpipe.ConfigError, match=r"^ldpipe.ld_map: argument 't0': 'soon' is not a date"):
        ldpipe.ld_map(ldpipe.system(name="ex", velocity_data={"dataset": example, "coordinates": "sphere"}),
                      **{**SECTION, "t0": "soon"})


def test_a_zarr_store_opened_by_xarray_gives_the_map_of_its_netcdf_twin(example, tmp_path, file_map):
    example.to_zarr(tmp_path / "example.zarr", zarr_format=2)  # consolidated metadata: no format-3 warning
    lazy = xr.open_zarr(tmp_path / "example.zarr")
    assert lazy.u.chunks is not None
    system = ldpipe.system(name="ex", velocity_data={"dataset": lazy, "coordinates": "sphere"})
    assert_same_data(ldpipe.ld_map(system, **SECTION), file_map)


def test_three_dimensional_data_from_their_data_arrays():
    # u, v, w on (time, depth, lat, lon): the state is (lon, lat, depth), read from u's dimensions
    deep = example_dataset(days=2.0, step_hours=12.0, resolution=2.0, depths=4)
    system = ldpipe.system(name="deep", velocity_data={"u": deep.u, "v": deep.v, "w": deep.w, "coordinates": "sphere"})
    assert system.coordinates == ("lon", "lat", "depth")
    assert system.spec["velocity_data"]["memory"]["shape"] == {"time": 5, "depth": 4, "lat": 13, "lon": 21}


def test_one_direction_of_time_needs_the_data_of_its_own_times_only(example):
    """A forward map from the data's first time needs no data before it, a backward one from
    their last none after it (the example holds days [0, 4]); both directions from either, or the
    other direction, are refused naming t0."""
    system = ldpipe.system(name="ex", velocity_data={"dataset": example, "coordinates": "sphere"})
    forward = ldpipe.ld_map(system, **{**SECTION, "t0": 0.0, "tau": 2.0}, directions="forward")
    backward = ldpipe.ld_map(system, **{**SECTION, "t0": 4.0, "tau": 2.0}, directions="backward")
    assert "ld_forward" in forward and "ld_backward" not in forward
    assert "ld_backward" in backward and "ld_forward" not in backward
    for t0, directions in ((0.0, "both"), (4.0, "both"), (0.0, "backward"), (4.0, "forward")):
        with pytest.raises(ldpipe.ConfigError, match="argument 't0'.*need times"):
            ldpipe.ld_map(system, **{**SECTION, "t0": t0, "tau": 2.0}, directions=directions)
