"""Velocity data from Python: ``ldpipe.system(velocity_data=...)`` given an ``xarray.Dataset``
(in memory, decoded by xarray, or lazy and dask-backed) or the DataArrays u, v.

The reference is the pipeline's own route: the same data written to netCDF and named by path.
The maps must agree bit for bit (the same values reach the same compiled engine), and the map's
file must say that its data came from memory (no path) with their variables, shape and hash.
The data are ldpipe's example (a jet by a coast on the sphere, with land), coarsened.
"""

import datetime
import json
import textwrap

import dask.array
import numpy as np
import pandas as pd
import pytest
import xarray as xr

import ldpipe
from ldpipe.config import load_config, validate_config
from ldpipe.config.parameters import parameters_from_config
from ldpipe.data.example import example_dataset
from ldpipe.stages.ld import run_ld_map
from support.stage_files import assert_same_file

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


def test_dates_in_the_configuration_give_the_map_the_api_gives_for_them(example_file, tmp_path):
    """config.yaml's t0 and tau as a date and a duration (the date unquoted, as YAML reads a
    timestamp): the day numbers by the data's units ("days since 2000-01-01": 2000-01-02 12:00 is
    day 1.5, 30 hours 1.25 days), and the stage's file equals the API's map of the same date, bit
    for bit, parameters and dates recorded included."""
    config_file = tmp_path / "config.yaml"
    config_file.write_text(textwrap.dedent(f"""\
        systems:
          ex: {{velocity_data: {{path: {json.dumps(str(example_file))}, coordinates: sphere}}}}
        ld_maps:
          ex:
            system: ex
            section: {json.dumps(SECTION["section"])}
            t0: 2000-01-02 12:00:00
            tau: 30h
        """))
    config = load_config(config_file)
    parameters = parameters_from_config(config, "ld", "ex")
    assert (parameters["t0"], parameters["tau"]) == (1.5, 1.25)
    stage_file = run_ld_map(output=tmp_path / "ex.nc", equilibria=None, **parameters)
    system = ldpipe.system(name="ex", velocity_data={"path": str(example_file), "coordinates": "sphere"})
    api_map = ldpipe.ld_map(system, **{**SECTION, "t0": "2000-01-02T12:00", "tau": pd.Timedelta(hours=30)})
    assert_same_file(api_map, ldpipe.open_dataset(stage_file))
    assert (api_map.attrs["t0_date"], api_map.attrs["tau_duration"]) == ("2000-01-02T12:00:00", "P1DT6H0M0S")


def test_a_date_in_the_configuration_is_refused_naming_its_key_where_no_calendar_places_it(example, tmp_path):
    plain = example.copy()
    plain["time"] = plain.time.assign_attrs(units="days")  # a time unit, no reference date
    del plain.time.attrs["calendar"]
    plain.to_netcdf(tmp_path / "plain.nc")
    systems = {"plain": {"velocity_data": {"path": str(tmp_path / "plain.nc"), "coordinates": "sphere"}},
               "flow": {"vector_field": {"x": "y", "y": "-x"}, "coordinates": ["x", "y"]}}

    def entry(system, **times):
        section = SECTION["section"] if system == "plain" else {
            "axes": [{"name": "x", "range": [0.0, 1.0], "points": 3}, {"name": "y", "range": [0.0, 1.0], "points": 3}],
            "fixed": {}}
        return {"systems": systems, "ld_maps": {"m": {"system": system, "section": section, **times}}}

    with pytest.raises(ldpipe.ConfigError, match=r"^config key 'ld_maps.m.t0': '2000-01-02' is a date, but the time "
                                                 r"coordinate 'time' .* is no calendar"):
        validate_config(entry("plain", t0=datetime.date(2000, 1, 2)))
    with pytest.raises(ldpipe.ConfigError, match=r"^config key 'ld_maps.m.t0.last': '2000-01-03' is a date, but "
                                                 r"system 'flow' has no calendar"):
        validate_config(entry("flow", t0={"first": 0.0, "last": "2000-01-03", "count": 2}))
    with pytest.raises(ldpipe.ConfigError, match=r"^config key 'ld_maps.m.tau': '1D' is a duration, but system "
                                                 r"'flow' has no time unit"):
        validate_config(entry("flow", tau="1D"))
    crossings = {"system": "flow", "t0": "2000-01-02", "time": 2.0, "section": {"coordinate": "y", "value": 0.0},
                 "initial_conditions": {"axes": entry("flow")["ld_maps"]["m"]["section"]["axes"]}}
    with pytest.raises(ldpipe.ConfigError, match=r"^config key 'poincare_sections.p.t0': '2000-01-02' is a date"):
        validate_config({"systems": systems, "poincare_sections": {"p": crossings}})
    # the pipeline reads its configuration before a rule makes the data (the example's file): a date
    # then has no calendar to be placed on, and is refused naming its key, not the data's path
    later = {**systems, "plain": {"velocity_data": {"path": str(tmp_path / "later.nc"), "coordinates": "sphere"}}}
    with pytest.raises(ldpipe.ConfigError, match=r"^config key 'ld_maps.m.tau': '1D' is placed on the calendar .*"
                                                 r"later.nc, which does not exist yet"):
        validate_config({**entry("plain", t0=1.0, tau="1D"), "systems": later})
    # a duration is a number of the data's time units and bounded as one: -1 day is no tau
    with pytest.raises(ldpipe.ConfigError, match=r"config key 'ld_maps.m.tau': -1.0 is less than or equal to the "
                                                 r"minimum of 0"):
        validate_config(entry("plain", t0=1.0, tau="-1D"))
    # numbers as text (YAML 1.1 reads 1e1 so) are the numbers they spell, on any system
    checked = validate_config(entry("plain", t0="1.5", tau="2.0"))["ld_maps"]["m"]
    assert (checked["t0"], checked["tau"]) == (1.5, 2.0)


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
