"""netCDF conventions: round trip with attributes, atomic writes, and clear errors on bad files."""

import json

import netCDF4
import numpy as np
import pytest
import xarray as xr

from ldpipe.io import datafile
from ldpipe.io.contracts import CONTRACTS, FLOW_MAP_TILE, LD_GRID, LD_TILE, StageFile
from ldpipe.io.datafile import open_stage_file, stage_parameters, write_stage_file
from ldpipe.errors import StageFileError


def sample_dataset():
    return xr.Dataset(
        {
            "energy": (("point",), np.array([1.5, 2.25, -3.0]), {"units": "1", "long_name": "energy"}),
            "escaped": (("point",), np.array([True, False, True])),
            "count": (("point",), np.array([1, 2, 3], dtype=np.int64)),
            "label": (("point",), np.array(["a", "bb", "ccc"], dtype=object)),
        },
        coords={"point": np.arange(3)},
    )


def test_round_trip_keeps_values_types_and_attributes(tmp_path):
    path = tmp_path / "stage.nc"
    parameters = {"tau": 50.0, "grid": [3, 4], "name": "x", "flag": True, "array": np.arange(2)}
    write_stage_file(sample_dataset(), path, stage="probe", title="Probe file", parameters=parameters)
    loaded = open_stage_file(path, stage="probe", variables=("energy", "escaped"))
    # Values, dimensions and variable attributes survive; global attributes are checked below.
    xr.testing.assert_identical(
        loaded[["energy", "count", "label"]].drop_attrs(deep=False), sample_dataset()[["energy", "count", "label"]]
    )
    assert loaded.escaped.dtype == bool
    np.testing.assert_array_equal(loaded.escaped.values, [True, False, True])
    assert loaded.energy.attrs["long_name"] == "energy"
    for key in datafile.MANAGED_ATTRIBUTES:
        assert loaded.attrs[key]
    assert loaded.attrs["Conventions"].startswith("CF-")
    assert loaded.attrs["title"] == "Probe file"
    assert stage_parameters(loaded) == {"tau": 50.0, "grid": [3, 4], "name": "x", "flag": True, "array": [0, 1]}
    # Written with compression, by the netCDF4 library (read back with it directly).
    with netCDF4.Dataset(path) as handle:
        assert handle.variables["energy"].filters()["zlib"] is True
        assert handle.data_model == "NETCDF4"


def test_stage_dataset_is_the_file_read_back(tmp_path):
    # A one-element vector attribute (the centre frequency of a 2 DoF saddle) is read back from
    # netCDF as a scalar: the Dataset in memory must hold it so, and longer ones as vectors.
    dataset = sample_dataset()
    dataset.attrs.update({"one": np.array([1.5]), "two": np.array([1.0, 2.0]), "count": [3], "name": "x"})
    dataset.energy.attrs["scale"] = np.array([2.5], dtype=np.float32)
    product = datafile.stage_dataset(dataset, stage="probe", title="Probe file", parameters={"name": "x"})
    assert dataset.attrs["one"].shape == (1,) and dataset.energy.attrs["scale"].shape == (1,)  # the caller's kept
    written = open_stage_file(write_stage_file(product, tmp_path / "stage.nc"), stage="probe")
    xr.testing.assert_identical(product, written)
    for key in ("one", "two", "count"):
        assert type(product.attrs[key]) is type(written.attrs[key]), key
    assert type(product.energy.attrs["scale"]) is type(written.energy.attrs["scale"]) is np.float32


def test_intermediate_files_are_written_uncompressed_with_the_same_values(tmp_path):
    """A contract's intermediate file (a map's tile, read once by the gather and deleted) is written
    without compression, also from data read out of a compressed file (whose variables carry that
    file's encoding); the values read back are the written ones, bit for bit, either way."""
    assert LD_TILE.intermediate and FLOW_MAP_TILE.intermediate and not LD_GRID.intermediate
    kept = write_stage_file(sample_dataset(), tmp_path / "kept.nc", stage="probe", title="t", parameters={})
    loaded = open_stage_file(kept, stage="probe")
    scratch = write_stage_file(loaded, tmp_path / "tile.nc", stage=StageFile("probe", intermediate=True), title="t",
                               parameters={})
    with netCDF4.Dataset(kept) as compressed, netCDF4.Dataset(scratch) as plain:
        for name in ("energy", "escaped", "count"):
            assert compressed.variables[name].filters()["complevel"] == datafile.COMPRESSION["complevel"]
            assert compressed.variables[name].filters()["shuffle"] is datafile.COMPRESSION["shuffle"]
            assert plain.variables[name].filters()["zlib"] is False
            assert plain.variables[name].chunking() == "contiguous"
    again = open_stage_file(scratch, stage="probe")
    for name, variable in sample_dataset().variables.items():
        assert np.array_equal(again[name].values, variable.values)
        if variable.dtype.kind in "fiub":
            assert again[name].dtype == variable.dtype


def test_git_commit_is_recorded_when_known(tmp_path):
    path = write_stage_file(sample_dataset(), tmp_path / "s.nc", stage="probe", title="t", parameters={})
    commit = open_stage_file(path, stage="probe").attrs["git_commit"]
    assert commit == (datafile.git_commit() or "unknown")


def test_nan_never_reaches_a_file(tmp_path):
    dataset = sample_dataset()
    dataset["energy"][1] = np.nan
    with pytest.raises(ValueError, match="energy"):
        write_stage_file(dataset, tmp_path / "s.nc", stage="probe", title="t", parameters={})
    assert list(tmp_path.iterdir()) == []


def test_interrupted_write_leaves_no_file_under_the_final_name(tmp_path, monkeypatch):
    path = tmp_path / "s.nc"
    write_stage_file(sample_dataset(), path, stage="probe", title="old", parameters={})
    real_to_netcdf = xr.Dataset.to_netcdf

    def dies_half_way(self, target, *args, **kwargs):
        real_to_netcdf(self, target, *args, **kwargs)
        with open(target, "r+b") as handle:  # leave a truncated file behind, as a killed job would
            handle.truncate(100)
        raise KeyboardInterrupt

    monkeypatch.setattr(xr.Dataset, "to_netcdf", dies_half_way)
    with pytest.raises(KeyboardInterrupt):
        write_stage_file(sample_dataset(), path, stage="probe", title="new", parameters={})
    # The earlier complete file is untouched and no temporary file is left over.
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.nc"]
    assert open_stage_file(path, stage="probe").attrs["title"] == "old"


def test_missing_file_named(tmp_path):
    with pytest.raises(StageFileError, match=r"nope\.nc: no such file.*'equilibria'"):
        open_stage_file(tmp_path / "nope.nc", stage="equilibria")


def test_truncated_file_named(tmp_path):
    path = write_stage_file(sample_dataset(), tmp_path / "s.nc", stage="probe", title="t", parameters={})
    path.write_bytes(path.read_bytes()[:200])
    with pytest.raises(StageFileError, match=r"s\.nc: not a readable netCDF file"):
        open_stage_file(path, stage="probe")


def test_foreign_file_named(tmp_path):
    path = tmp_path / "foreign.nc"
    sample_dataset().to_netcdf(path, engine="netcdf4")
    with pytest.raises(StageFileError, match=r"foreign\.nc: not written by ldpipe"):
        open_stage_file(path, stage="probe")
    text = tmp_path / "notes.nc"
    text.write_text("just text")
    with pytest.raises(StageFileError, match=r"notes\.nc: not a readable netCDF file"):
        open_stage_file(text, stage="probe")


def test_wrong_stage_and_missing_variables_named(tmp_path):
    path = write_stage_file(sample_dataset(), tmp_path / "s.nc", stage="ld_grid", title="t", parameters={})
    with pytest.raises(StageFileError, match=r"s\.nc: written by the 'ld_grid' stage; expected the 'upo' stage"):
        open_stage_file(path, stage="upo")
    with pytest.raises(StageFileError, match=r"lacks variables \['period'\]"):
        open_stage_file(path, stage="ld_grid", variables=("energy", "period"))


def test_a_contract_names_the_stage_and_the_variables_checked(tmp_path):
    probe = StageFile("probe", ("energy", "escaped"))
    path = write_stage_file(sample_dataset(), tmp_path / "s.nc", stage=probe, title="t", parameters={})
    assert open_stage_file(path, stage="probe").attrs["ldpipe_stage"] == "probe"
    # By default every variable the contract names is checked; a reader may ask for some of them only.
    with pytest.raises(StageFileError, match=r"lacks variables \['period'\] that the 'probe' stage writes"):
        open_stage_file(path, stage=StageFile("probe", ("energy", "period")))
    assert "count" in open_stage_file(path, stage=probe, variables=("energy",))
    # Asking for a variable the contract does not name is a reader's mistake, not the file's.
    with pytest.raises(ValueError, match=r"\['count'\] are not in the 'probe' stage's contract"):
        open_stage_file(path, stage=probe, variables=("count",))


def test_only_loads_the_variables_asked_for(tmp_path):
    probe = StageFile("probe", ("energy", "escaped"))
    path = write_stage_file(sample_dataset(), tmp_path / "s.nc", stage=probe, title="t", parameters={"a": 1})
    full = open_stage_file(path, stage=probe)
    part = open_stage_file(path, stage=probe, variables=("energy",), only=True)
    # The variable asked for, its coordinate and the file's attributes, as the full load has them; no other variable.
    assert list(part.data_vars) == ["energy"]
    xr.testing.assert_identical(part, full[["energy"]])
    # Without variables, the contract's; flags still come back as booleans; the stage is still checked.
    by_contract = open_stage_file(path, stage=probe, only=True)
    assert sorted(by_contract.data_vars) == ["energy", "escaped"] and by_contract.escaped.dtype == bool
    with pytest.raises(StageFileError, match=r"s\.nc: written by the 'probe' stage; expected the 'upo' stage"):
        open_stage_file(path, stage="upo", variables=(), only=True)
    path.write_bytes(path.read_bytes()[:200])
    with pytest.raises(StageFileError, match=r"s\.nc: not a readable netCDF file"):
        open_stage_file(path, stage=probe, only=True)


def test_contracts_are_indexed_by_their_stage():
    assert all(stage == contract.stage for stage, contract in CONTRACTS.items())
    assert {"equilibria", "flow_equilibria", "ld_tile", "ld_grid", "upo", "manifolds", "poincare", "nhim",
            "nhim_orbits", "nhim_sampling", "transport", "saddle_flux", "normal_form", "accuracy_cost",
            "structures", "fsle", "lavd", "map_manifolds"} == set(CONTRACTS)


def test_parameters_attribute_is_json(tmp_path):
    path = write_stage_file(sample_dataset(), tmp_path / "s.nc", stage="probe", title="t", parameters={"a": [1.5]})
    with netCDF4.Dataset(path) as handle:
        assert json.loads(handle.getncattr("parameters")) == {"a": [1.5]}
