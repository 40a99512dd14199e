"""Velocity data in many files along time, read as one dataset.

- The example generator's jet split along time into files, given as a glob and as a list: the
  map equals the single file's bit for bit (an invariant of the reading: the same nodes reach
  the same compiled kernel, so no tolerance); so do a curvilinear grid's trajectories.
- Inconsistent series are refused naming the files: a different grid, overlapping times,
  files out of time order, a glob that matches nothing.
"""

import numpy as np
import pytest

from ldpipe.config import validate_config
from ldpipe.config.parameters import parameters_from_config
from ldpipe.core.maps.assembly import compute_ld_map
from ldpipe.data.curvilinear import double_gyre_dataset, write_dataset
from ldpipe.data.example import example_dataset, write_example, write_example_series
from ldpipe.engine import LDSettings, compute_ld
from ldpipe.errors import ConfigError
from ldpipe.systems import make_system, system_data_files

#: A small example: 1-degree grid, a day and a half every 6 hours (7 times).
SMALL = {"days": 1.5, "resolution": 1.0}


def _map(path):
    entry = {"path": path, "coordinates": "sphere"}
    spec = {"system": "jet", "t0": 0.7, "tau": 0.6, "p": 0.5, "ftle": True,
            "integrator": {"rtol": 1e-8, "atol": 1e-8},
            "section": {"axes": [{"name": "lon", "range": [-75.0, -50.0], "points": 6},
                                 {"name": "lat", "range": [34.0, 41.0], "points": 5}]}}
    config = validate_config({"systems": {"jet": {"velocity_data": entry}}, "ld_maps": {"m": spec}})
    return compute_ld_map(parameters_from_config(config, "ld", "m"), None, show_progress=False)


def test_a_series_of_files_gives_the_single_files_map(tmp_path):
    single = write_example(tmp_path / "one.nc", **SMALL)
    (tmp_path / "parts").mkdir()
    parts = write_example_series(tmp_path / "parts", 3, **SMALL)  # times 0-0.5, 0.75-1, 1.25-1.5 days
    reference = _map(str(single))
    # the jet moves the starts at sea, two start on land (their LD missing): the comparison is not
    # of missing values alone
    assert np.nanmax(reference.ld_forward.values) > 0.5 and reference.on_land_forward.values.any()
    assert reference.start_on_land.values.sum() == 2
    np.testing.assert_array_equal(np.isnan(reference.ld_forward.values), reference.start_on_land.values)
    # t0 = 0.7 +- 0.6 days: both directions read across files (their ends at 0.5 and 1 days)
    for path in (str(tmp_path / "parts" / "example_*.nc"), [str(p) for p in parts]):
        series = _map(path)
        assert sorted(series.data_vars) == sorted(reference.data_vars)
        for name in reference.data_vars:
            np.testing.assert_array_equal(series[name].values, reference[name].values, err_msg=name)
    assert system_data_files({"velocity_data": {"path": str(tmp_path / "parts" / "example_*.nc")}}) == [
        str(p) for p in parts]


def _write(dataset, path):
    dataset.to_netcdf(path)
    return str(path)


def test_inconsistent_series_are_refused_naming_the_files(tmp_path):
    data = example_dataset(**SMALL)
    first = _write(data.isel(time=slice(0, 3)), tmp_path / "a.nc")
    second = _write(data.isel(time=slice(3, 7)), tmp_path / "b.nc")
    make_system("ok", {"velocity_data": {"path": [first, second], "coordinates": "sphere"}})  # consistent
    overlapping = _write(data.isel(time=slice(2, 7)), tmp_path / "c.nc")
    with pytest.raises(ConfigError, match=r"times of .*a\.nc \(to 0\.5\) and .*c\.nc \(from 0\.5\) overlap"):
        make_system("s", {"velocity_data": {"path": [first, overlapping], "coordinates": "sphere"}})
    with pytest.raises(ConfigError, match=r"times of .*b\.nc .* and .*a\.nc .* are out of order"):
        make_system("s", {"velocity_data": {"path": [second, first], "coordinates": "sphere"}})
    moved = data.isel(time=slice(3, 7)).assign_coords(lon=data.lon.values + 0.5)
    shifted = _write(moved, tmp_path / "d.nc")
    with pytest.raises(ConfigError, match=r"grids of .*a\.nc and .*d\.nc differ \(coordinate 'lon'"):
        make_system("s", {"velocity_data": {"path": [first, shifted], "coordinates": "sphere"}})
    coarse = _write(example_dataset(days=1.5, resolution=2.0).isel(time=slice(3, 7)), tmp_path / "e.nc")
    with pytest.raises(ConfigError, match=r"grids of .*a\.nc and .*e\.nc differ"):
        make_system("s", {"velocity_data": {"path": [first, coarse], "coordinates": "sphere"}})
    with pytest.raises(ConfigError, match=r"velocity_data\.path': the glob .* matches no file"):
        make_system("s", {"velocity_data": {"path": str(tmp_path / "none_*.nc"), "coordinates": "sphere"}})
    with pytest.raises(ConfigError, match=r"velocity_data\.path': no dataset at .*missing\.nc"):
        make_system("s", {"velocity_data": {"path": [first, str(tmp_path / "missing.nc")], "coordinates": "sphere"}})
    hours = data.isel(time=slice(3, 7)).assign_coords(time=data.time.values[3:7] * 24.0)
    hours.time.attrs["units"] = "hours since 2000-01-01"
    with pytest.raises(ConfigError, match=r"time units of .*f\.nc \('hours since 2000-01-01'\) differ"):
        make_system("s", {"velocity_data": {"path": [first, _write(hours, tmp_path / "f.nc")],
                                            "coordinates": "sphere"}})


@pytest.mark.compiles
@pytest.mark.xdist_group("curvilinear_grids")  # test_curvilinear's engine
def test_a_curvilinear_series_gives_the_single_files_trajectories(tmp_path):
    gyre = double_gyre_dataset("curvilinear", 0.2, np.arange(0.0, 6.01, 0.5))
    single = write_dataset(gyre, tmp_path / "gyre.nc")
    parts = [str(write_dataset(gyre.isel(time=part), tmp_path / f"gyre{k}.nc"))
             for k, part in enumerate((slice(0, 5), slice(5, 13)))]
    starts = np.array([[0.3, 0.4], [1.2, 0.7], [1.7, 0.2]])
    settings = LDSettings(tau=3.0, p=0.5, rtol=1e-9, atol=1e-9)
    results = [compute_ld(make_system(name, {"velocity_data": {"path": path, "components": "geographic"}}), starts, 1,
                          settings, t0=1.0) for name, path in (("one", str(single)), ("parts", parts))]
    np.testing.assert_array_equal(results[0].ld, results[1].ld)
    np.testing.assert_array_equal(results[0].end_state, results[1].end_state)
    other = double_gyre_dataset("rotated", 0.2, np.arange(0.0, 6.01, 0.5)).isel(time=slice(5, 13))
    with pytest.raises(ConfigError, match=r"grids of .*gyre0\.nc and .*rotated\.nc differ \(variable 'x_rho'\)"):
        make_system("mixed", {"velocity_data": {"path": [parts[0], str(write_dataset(other, tmp_path / "rotated.nc"))],
                                                "components": "geographic"}})


def test_the_example_writer_splits_the_example_along_time(tmp_path):
    from ldpipe.data.example import main

    main([str(tmp_path / "series"), "--files", "3", "--days", "1.5"])
    files = sorted((tmp_path / "series").glob("example_*.nc"))
    assert [f.name for f in files] == ["example_000.nc", "example_001.nc", "example_002.nc"]
    system = make_system("cli", {"velocity_data": {"path": str(tmp_path / "series" / "example_*.nc"),
                                                   "coordinates": "sphere"}})
    assert system.source.time_range == (0.0, 1.5) and system.source.t_grid[2] == 7  # every 6 hours, as one file


def test_later_files_grids_are_compared_on_their_edges_and_middle_lines(tmp_path):
    # a series of a large grid must not read every file's grid whole: each later file's 2-D grid
    # variable is read on its four edges and its middle row and column (3 rows and 3 columns of a
    # 40 x 60 grid: 3 * 60 + 3 * 40 = 300 values, not 2400), and a node changed on the middle row
    # (a grid moved there, as a regridded file would be) is refused naming the variable
    from ldpipe.systems.velocity_data.files import grid_lines, series_times
    import xarray as xr

    lon, lat = np.meshgrid(np.linspace(-60.0, -30.0, 60), np.linspace(20.0, 40.0, 40))
    grid = xr.DataArray(lon, dims=("y", "x"))
    assert grid_lines(grid).size == 300
    def write(name, times, shift=0.0):
        moved = lon.copy()
        moved[20, 30] += shift
        dataset = xr.Dataset({"u": (("time", "y", "x"), np.zeros((len(times), 40, 60))),
                              "nav_lon": (("y", "x"), moved), "nav_lat": (("y", "x"), lat)},
                             coords={"time": ("time", times, {"units": "days since 2000-01-01"})})
        dataset.to_netcdf(tmp_path / name)
        return str(tmp_path / name)
    first, same = write("a.nc", [0.0, 1.0]), write("b.nc", [2.0, 3.0])
    times, starts = series_times([first, same], ("u", "nav_lon", "nav_lat"), "time", "k.path")
    np.testing.assert_array_equal(times, [0.0, 1.0, 2.0, 3.0])
    assert starts == (0, 2)
    moved = write("c.nc", [2.0, 3.0], shift=0.1)
    with pytest.raises(ConfigError, match=r"grids of .*a\.nc and .*c\.nc differ \(variable 'nav_lon'\)"):
        series_times([first, moved], ("u", "nav_lon", "nav_lat"), "time", "k.path")
