"""Missing values in map files: a point never integrated (outside the energetically allowed region,
or starting on land) or whose value is not defined (an FTLE whose neighbours stopped early) is NaN
in memory and the file's declared ``_FillValue`` on disk, never 0, with the flag that says why.
Every expectation below is a flag's definition or a closed form, not a value read off the code."""

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
import xarray as xr  # noqa: E402

from ldpipe.config import validate_config  # noqa: E402
from ldpipe.config.parameters import parameters_from_config  # noqa: E402
from ldpipe.core.equilibria.potential import equilibrium_table  # noqa: E402
from ldpipe.core.maps.assembly import compute_ld_map, ld_map_dataset  # noqa: E402
from ldpipe.io.datafile import (missing_value_encoding, open_stage_file, stage_dataset,  # noqa: E402
                                write_stage_file)
from support.gridded import write_velocity_file  # noqa: E402

#: Fields of a Hamiltonian map that have no value at a point never integrated.
NEVER_INTEGRATED = ("ld_forward", "ld_backward", "exit_time_forward", "exit_time_backward", "energy_error", "py")


def barbanis_config():
    """The LD stage tests' small Barbanis slice (same system and settings: the same engine module),
    which holds allowed and forbidden points."""
    ld_map = {
        "system": "barbanis_2dof", "saddle_near": [5.5, -7.0],
        "section": {"axes": [{"name": "x", "range": [4.8, 6.0], "points": 13},
                             {"name": "px", "range": [-0.6, 0.6], "points": 9}],
                    "fixed": {"y": -7.0}, "solve": "py"},
        "energy": {"excess": 0.125}, "tau": 5.0, "time": "variable",
        "region": {"x": [4.5, 6.5], "y": [-8.5, -5.5]},
        "integrator": {"scheme": "dop853", "rtol": 1e-8, "atol": 1e-8},
    }
    return validate_config({"systems": {"barbanis_2dof": {"builtin": "barbanis_2dof"}}, "ld_maps": {"m": ld_map}})


@pytest.fixture(scope="module")
def barbanis_map(barbanis):
    equilibria = equilibrium_table(barbanis, {"x": [-20.0, 20.0], "y": [-20.0, 20.0]})
    return ld_map_dataset(parameters_from_config(barbanis_config(), "ld", "m"), equilibria, show_progress=False)


def test_forbidden_points_are_missing_and_allowed_ones_never_are(barbanis_map):
    """Missing exactly where 'allowed' is false (its definition: no real solved momentum, never
    integrated): the engine gave a finite value at every allowed point."""
    allowed = barbanis_map.allowed.values
    assert 0 < allowed.sum() < allowed.size
    for name in NEVER_INTEGRATED:
        np.testing.assert_array_equal(np.isnan(barbanis_map[name].values), ~allowed, err_msg=name)
    assert "missing" in barbanis_map.ld_forward.attrs["comment"]


def test_xarray_plot_leaves_the_forbidden_region_empty(barbanis_map):
    """xarray's own pcolormesh of a field: the drawn array is masked (matplotlib leaves it blank)
    exactly at the forbidden points, so they cannot read as the lowest LD."""
    figure, ax = plt.subplots()
    try:
        mesh = barbanis_map.ld_forward.plot(ax=ax)
        drawn = np.ma.masked_invalid(mesh.get_array()).reshape(barbanis_map.ld_forward.shape)
        np.testing.assert_array_equal(np.ma.getmaskarray(drawn), ~barbanis_map.allowed.values)
    finally:
        plt.close(figure)


def test_file_round_trip_keeps_missing_values_and_flags(barbanis_map, tmp_path):
    """Written and read back: NaN at the same points, declared as the CF fill value, the flags kept;
    a variable that declares no missing value (the flags, the step counts) gets no fill value."""
    path = write_stage_file(barbanis_map, tmp_path / "m.nc")
    read = open_stage_file(path, stage="ld_grid")
    for name in NEVER_INTEGRATED:
        np.testing.assert_array_equal(read[name].values, barbanis_map[name].values, err_msg=name)  # NaN == NaN here
        assert np.isnan(read[name].encoding["_FillValue"]), name
    np.testing.assert_array_equal(read.allowed.values, barbanis_map.allowed.values)
    with xr.open_dataset(path, mask_and_scale=False) as raw:
        assert "_FillValue" in raw.ld_forward.attrs and "_FillValue" not in raw.x.attrs
        assert "_FillValue" not in raw.allowed.attrs and "_FillValue" not in raw.steps_forward.attrs


def test_only_declared_missing_values_reach_a_file(tmp_path):
    """The rule 'no NaN in a file' with its one exception: NaN in a variable that declares it its
    missing value. Undeclared NaN, and inf even where NaN is declared, are refused."""
    declared = xr.Dataset({"a": ("x", [1.0, np.nan], {}, missing_value_encoding())})
    assert np.isnan(stage_dataset(declared, stage="s", title="t", parameters={}).a.values[1])
    with pytest.raises(ValueError, match="'a' holds NaN and declares no missing value"):
        stage_dataset(xr.Dataset({"a": ("x", [1.0, np.nan])}), stage="s", title="t", parameters={})
    with pytest.raises(ValueError, match="'a' holds inf"):
        stage_dataset(xr.Dataset({"a": ("x", [1.0, np.inf], {}, missing_value_encoding())}), stage="s", title="t",
                      parameters={})
    written = stage_dataset(declared, stage="s", title="t", parameters={})
    written["b"] = ("x", [2.0, np.nan])  # added afterwards, undeclared: refused on writing too
    with pytest.raises(ValueError, match="'b' holds NaN"):
        write_stage_file(written, tmp_path / "bad.nc")
    assert not (tmp_path / "bad.nc").exists()


def test_points_on_land_are_missing_and_flagged(tmp_path):
    """u = 1 m/s eastward, land at the nodes x >= 6: a start in a cell with a land node (x0 >= 5,
    the cells [5, 6] and beyond) stops at once, so its LD is missing and 'start_on_land' says so;
    from x0 < 5 the trajectory stops at the coast x = 5 with M_0.5 = (5 - x0) (1 m/s)^0.5 (closed form).
    The FTLE map of the same data is missing exactly where 'ftle_defined' is false."""
    x, y, t = np.arange(0.0, 10.01, 1.0), np.arange(0.0, 4.01, 1.0), np.arange(0.0, 20.01, 1.0)
    coast = write_velocity_file(tmp_path / "coast.nc", lambda X, Y, T: (1.0 + 0 * X, 0 * Y), x, y, t,
                                land=lambda X, Y: X >= 6)
    base = {"section": {"axes": [{"name": "x", "range": [2.5, 7.5], "points": 6},
                                 {"name": "y", "range": [0.5, 2.5], "points": 3}]},
            "t0": 8.0, "tau": 8.0, "p": 0.5, "integrator": {"rtol": 1e-10, "atol": 1e-10}, "system": "coast"}
    config = validate_config({"systems": {"coast": {"velocity_data": {"path": str(coast)}}},
                              "ld_maps": {"c": base, "f": {**base, "ftle": True}}})
    coast_map = compute_ld_map(parameters_from_config(config, "ld", "c"), None, show_progress=False)
    x0 = coast_map.x.values[:, None] + 0 * coast_map.y.values
    on_land = x0 >= 5
    np.testing.assert_array_equal(coast_map.start_on_land.values, on_land)
    for name in ("ld_forward", "ld_backward"):
        np.testing.assert_array_equal(np.isnan(coast_map[name].values), on_land, err_msg=name)
    np.testing.assert_allclose(coast_map.ld_forward.values[~on_land], (5.0 - x0)[~on_land], rtol=5e-7)
    ftle_map = compute_ld_map(parameters_from_config(config, "ld", "f"), None, show_progress=False)
    for label in ("forward", "backward"):
        defined = ftle_map[f"ftle_defined_{label}"].values
        np.testing.assert_array_equal(np.isnan(ftle_map[f"ftle_{label}"].values), ~defined, err_msg=label)
