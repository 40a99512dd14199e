"""The FTLE's units are per the system's unit of time: 1/day on data counted in days.

A uniform strain u = s x, v = -s y with s = 0.1 per day (velocities in m/day on x, y in metres,
time in days since a date) has the FTLE s = 0.1 (closed form, as in test_ftle_edges.py): the
number is per day, and so must the file's ``units`` and every label drawn from it say. The
same strain counted in seconds is 1/s (a formula system names no unit of time: 1/time, test_ftle.py).
"""

import matplotlib.pyplot as plt
import numpy as np

import ldpipe
from ldpipe.text import per_time
from support.gridded import write_velocity_file

STRAIN = 0.1


def strain_system(tmp_path, units: str, time_units: str):
    axis = np.linspace(-1.0, 1.0, 9)
    path = write_velocity_file(tmp_path / f"strain_{units.replace('/', '_')}.nc",
                               lambda X, Y, T: (STRAIN * X + 0 * T, -STRAIN * Y), axis, axis, np.linspace(0.0, 10.0, 11),
                               units=units, time_units=time_units)
    return ldpipe.system(velocity_data={"path": str(path)})


def strain_map(system, **options):
    section = ldpipe.section(x=(-0.5, 0.5, 6), y=(-0.5, 0.5, 6))
    return ldpipe.ld_map(system, section=section, t0=5.0, tau=2.0, ftle=True, progress=False, **options)


def test_per_time_names_the_unit_once():
    assert [per_time(u) for u in ("days", "day", "hours", "s", "seconds", None)] == \
        ["1/day", "1/day", "1/hour", "1/s", "1/second", "1/time"]


def test_ftle_of_data_in_days_is_per_day_in_the_file_and_its_pictures(tmp_path):
    from ldpipe.figures.ld_ftle import draw_ld_ftle

    system = strain_system(tmp_path, "m/day", "days since 2000-01-01")
    whole, tiled = strain_map(system), strain_map(system, tiles=2)  # tiled: the FTLE of the gathered bands
    for dataset in (whole, tiled):
        for label in ("forward", "backward"):
            assert dataset[f"ftle_{label}"].attrs["units"] == "1/day", label
            # closed form: s per day (a unit mistaken by 86400 would show); measured 1e-13
            np.testing.assert_allclose(dataset[f"ftle_{label}"].values, STRAIN, rtol=1e-9)
    path = tmp_path / "strain_map.nc"
    whole.to_netcdf(path)
    figure = draw_ld_ftle({"descriptor": "forward", "color_percentiles": [1.0, 99.0]}, ld_maps=[path])
    labels = [ax.get_ylabel() for ax in figure.axes if ax.get_label() == "<colorbar>"]
    assert labels[1:] == ["FTLE, forward [1/day]", "FTLE, backward [1/day]"], labels
    plt.close(figure)
    ax = whole.ldpipe.plot("ftle_backward")
    assert ax.figure.axes[-1].get_ylabel().endswith("[1/day]")
    plt.close(ax.figure)


def test_ftle_of_data_in_seconds_is_per_second(tmp_path):
    dataset = strain_map(strain_system(tmp_path, "m/s", "s"))
    assert dataset.ftle_forward.attrs["units"] == "1/s"
    np.testing.assert_allclose(dataset.ftle_forward.values, STRAIN, rtol=1e-9)
