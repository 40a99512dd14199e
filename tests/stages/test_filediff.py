"""Comparing the stage files of two runs: equal files, a perturbed value, a missing variable or file."""

import numpy as np
import xarray as xr

from ldpipe.io.datafile import write_stage_file
from ldpipe.io.filediff import compare_files, compare_runs, main


def stage_file(path, energy, *, extra=False, wall_time=1.0):
    data = xr.Dataset(
        {
            "energy": (("point",), np.asarray(energy, dtype=np.float64), {"units": "1"}),
            "escaped": (("point",), np.array([True, False, True])),
            "refinement_wall_time": ((), wall_time),
            "monte_carlo_seconds": ((), 2 * wall_time, {"units": "s"}),
        }
    )
    if extra:
        data["extra"] = (("point",), np.zeros(3))
    return write_stage_file(data, path, stage="probe", title="Probe", parameters={"tau": 50.0})


def test_files_written_twice_are_equal_despite_history_and_wall_time(tmp_path):
    # Two writes of the same data differ only in what the comparison is told to leave out.
    a = stage_file(tmp_path / "a.nc", [1.5, 2.25, -3.0], wall_time=1.0)
    b = stage_file(tmp_path / "b.nc", [1.5, 2.25, -3.0], wall_time=7.0)
    assert compare_files(a, b) == []


def test_a_perturbed_value_is_reported_with_the_size_of_the_change(tmp_path):
    a = stage_file(tmp_path / "a.nc", [1.5, 2.25, -3.0])
    b = stage_file(tmp_path / "b.nc", [1.5, 2.25 + 2.0**-40, -3.0])
    (difference,) = compare_files(a, b)
    assert difference.where == "variable 'energy'"
    assert difference.max_abs == 2.0**-40  # exactly the perturbation: both values are representable


def test_a_variable_or_file_only_in_one_run_is_reported(tmp_path):
    for run, extra in (("one", False), ("two", True)):
        stage_file(tmp_path / run / "stage" / "a.nc", [1.0, 2.0, 3.0], extra=extra)
    stage_file(tmp_path / "two" / "stage" / "b.nc", [1.0, 2.0, 3.0])
    report = compare_runs(tmp_path / "one", tmp_path / "two")
    assert [str(d) for d in report["stage/a.nc"]] == ["variable 'extra': only in the second"]
    assert report["stage/b.nc"][0].where == "file"
    assert compare_runs(tmp_path / "one", tmp_path / "two", exclude=("stage/b.nc",))["stage/a.nc"]
    assert main([str(tmp_path / "one"), str(tmp_path / "two")]) == 1
    assert main([str(tmp_path / "one"), str(tmp_path / "one")]) == 0
