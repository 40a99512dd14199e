"""Where land or the data's edge stops a trajectory, its exit time is the time it got there.

By construction (closed forms): u = 1 m/s eastward with land for x >= 6 stops a trajectory from
x0 at the coast x = 5 (the first cell with a land node) after 5 - x0 seconds; v = 1 m/s northward
reaches the top edge y = 4 after 4 - y0 seconds, and backward the bottom edge y = 0 after y0.
"""

import numpy as np

from ldpipe.config import validate_config
from ldpipe.stages.ld import compute_ld_map
from ldpipe.stages.parameters import parameters_from_config
from support.gridded import write_velocity_file


def test_exit_times_of_land_and_edge_stops(tmp_path):
    x, y, t = np.arange(0.0, 10.01, 1.0), np.arange(0.0, 4.01, 1.0), np.arange(0.0, 20.01, 1.0)
    coast = write_velocity_file(tmp_path / "coast.nc", lambda X, Y, T: (1.0 + 0 * X, 0 * Y), x, y, t,
                                land=lambda X, Y: X >= 6)
    north = write_velocity_file(tmp_path / "north.nc", lambda X, Y, T: (0 * X, 1.0 + 0 * Y), x, y, t)
    base = {"section": {"axes": [{"name": "x", "range": [1.0, 3.0], "points": 3},
                                 {"name": "y", "range": [0.5, 2.5], "points": 3}]},
            "t0": 8.0, "tau": 8.0, "p": 0.5, "integrator": {"rtol": 1e-10, "atol": 1e-10}}
    config = validate_config({"systems": {"coast": {"velocity_data": {"path": str(coast)}},
                                          "north": {"velocity_data": {"path": str(north)}}},
                              "ld_maps": {"c": {**base, "system": "coast"}, "n": {**base, "system": "north"},
                                          "f": {**base, "system": "north", "ftle": True, "ld": False}}})
    coast_map = compute_ld_map(parameters_from_config(config, "ld", "c"), None, show_progress=False)
    x0 = coast_map.x.values[:, None] + 0 * coast_map.y.values
    y0 = 0 * coast_map.x.values[:, None] + coast_map.y.values
    assert coast_map.on_land_forward.values.all()
    # measured 3.4e-8 (the step across the coast, where the velocity jumps to 0), edges 9e-9
    np.testing.assert_allclose(coast_map.exit_time_forward.values, 5.0 - x0, rtol=2e-7)
    # backward the flow comes from the west edge x = 0: reached after x0 seconds
    np.testing.assert_allclose(coast_map.exit_time_backward.values, x0, rtol=2e-7)
    for name in ("n", "f"):  # with the LD and without it
        north_map = compute_ld_map(parameters_from_config(config, "ld", name), None, show_progress=False)
        assert north_map.left_data_forward.values.all() and north_map.left_data_backward.values.all()
        np.testing.assert_allclose(north_map.exit_time_forward.values, 4.0 - y0, rtol=2e-7)
        np.testing.assert_allclose(north_map.exit_time_backward.values, y0, rtol=2e-7)
