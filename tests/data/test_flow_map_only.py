"""Maps without their LD (``ld: false``): the flow map and its FTLE alone, by the flow driver.

- The same steps as the LD engine's (``vector_field_endpoints`` runs its step loop,
  ``trajectory``), so the flow map, exit times, step counts and FTLE equal those of the map computed with
  its LD (``ftle: true``, itself checked against closed forms and scipy in test_ftle.py) bit for bit.
- A shear flow u = 0.1 y, v = 0.05 (closed form: its flow map over T = 1 is (x + 0.1 y, y + 0.05),
  C = [[1, 0.1], [0.1, 1.01]]) gives its FTLE.
- A map file records the escape radius the engine used: raised to twice the data's extent.
"""

import copy
import math

import numpy as np
import pytest

from ldpipe.config import validate_config
from ldpipe.errors import ConfigError
from ldpipe.io.contracts import FLOW_MAP
from ldpipe.io.datafile import open_stage_file
from ldpipe.core.maps.assembly import compute_ld_map
from ldpipe.stages.ld import run_ld_gather, run_ld_tile
from ldpipe.config.parameters import parameters_from_config
from support.double_gyre import double_gyre_velocity
from support.gridded import write_velocity_file

H = 1.0 / 8
SECTION = {"axes": [{"name": "x", "range": [0.1, 1.9], "points": 10}, {"name": "y", "range": [0.1, 0.9], "points": 6}]}


def gyre_config(path, **changes):
    spec = {"system": "gyre", "t0": 3.0, "tau": 2.0, "p": 0.5, "ftle": True, "section": copy.deepcopy(SECTION),
            "integrator": {"rtol": 1e-9, "atol": 1e-9}, **changes}
    return validate_config({"systems": {"gyre": {"velocity_data": {"path": str(path)}}}, "ld_maps": {"m": spec}})


def test_flow_map_alone_equals_the_ld_maps_flow_map(tmp_path):
    x, y, t = np.arange(0, 2 + H / 2, H), np.arange(0, 1 + H / 2, H), np.arange(0.0, 6.0 + H / 2, H)
    path = write_velocity_file(tmp_path / "gyre.nc", double_gyre_velocity, x, y, t)
    with_ld = compute_ld_map(parameters_from_config(gyre_config(path), "ld", "m"), None, show_progress=False)
    parameters = parameters_from_config(gyre_config(path, ld=False, tiles=2), "ld", "m")
    tiles = [run_ld_tile(output=tmp_path / f"t{k}.nc", equilibria=None, tile=k, tiles=2, show_progress=False,
                         **parameters) for k in range(2)]
    alone = open_stage_file(run_ld_gather(tiles=tiles, output=tmp_path / "m.nc"), stage=FLOW_MAP)
    assert not [name for name in alone.data_vars if name.startswith(("ld_", "left_region_"))]
    assert alone.attrs["descriptor"] == "none"
    compared = [name for name in alone.data_vars if name.startswith(("ftle", "end_", "exit_time", "steps", "escaped",
                                                                     "failed", "on_land", "left_data"))]
    assert len(compared) == 20
    for name in compared:
        np.testing.assert_array_equal(alone[name].values, with_ld[name].values, err_msg=name)
    assert alone.ftle_defined_forward.values.any() and alone.ftle_forward.values.max() > 0.1


def test_shear_ftle_without_ld_and_the_recorded_escape_radius(tmp_path):
    path = write_velocity_file(tmp_path / "shear.nc", lambda X, Y, T: (0.1 * Y + 0 * T, 0.05 + 0 * X),
                               np.linspace(0, 4, 5), np.linspace(0, 4, 5), np.linspace(0, 4, 5))
    spec = {"system": "shear", "t0": 2.0, "tau": 1.0, "p": 0.5, "ftle": True, "ld": False,
            "section": {"axes": [{"name": "x", "range": [1.0, 3.0], "points": 5},
                                 {"name": "y", "range": [1.0, 3.0], "points": 5}]}}
    systems = {"shear": {"velocity_data": {"path": str(path)}}}
    config = validate_config({"systems": systems, "ld_maps": {"s": spec}})
    dataset = compute_ld_map(parameters_from_config(config, "ld", "s"), None, show_progress=False)
    expected = math.log((2.01 + math.sqrt(0.01**2 + 4 * 0.01)) / 2) / 2  # closed form (module docstring)
    for label in ("forward", "backward"):
        assert dataset[f"ftle_defined_{label}"].values.all()
        np.testing.assert_allclose(dataset[f"ftle_{label}"].values, expected, rtol=1e-12)
    # the engine's radius: twice the data's largest |coordinate| (4), not the configured 100
    assert dataset.attrs["escape_radius"] == 100.0
    far = write_velocity_file(tmp_path / "far.nc", lambda X, Y, T: (0.1 * Y + 0 * T, 0.05 + 0 * X),
                              np.linspace(0, 400, 5), np.linspace(0, 400, 5), np.linspace(0, 4, 5))
    config = validate_config({"systems": {"shear": {"velocity_data": {"path": str(far)}}},
                              "ld_maps": {"s": {**spec, "section": {"axes": [
                                  {"name": "x", "range": [100.0, 300.0], "points": 3},
                                  {"name": "y", "range": [100.0, 300.0], "points": 3}]}}}})
    assert compute_ld_map(parameters_from_config(config, "ld", "s"), None, show_progress=False).attrs["escape_radius"] == 800.0
    with pytest.raises(ConfigError, match=r"ld_maps\.s\.ld': a map without its LD holds only"):
        validate_config({"systems": systems, "ld_maps": {"s": {**spec, "ftle": False}}})
    with pytest.raises(ConfigError, match=r"has no LD to draw"):
        validate_config({"systems": systems, "ld_maps": {"s": spec},
                         "figures": {"f": {"kind": "ld_ftle", "ld_maps": ["s"]}}})


def test_a_hamiltonian_map_keeps_its_ld():
    # the flow map alone is a vector field's (a Hamiltonian section's end states come from another driver)
    spec = {"system": "b", "section": {"axes": [{"name": "x", "range": [-1.0, 1.0], "points": 5},
                                                {"name": "px", "range": [-1.0, 1.0], "points": 5}],
                                       "fixed": {"y": 0.0}, "solve": "py"},
            "energy": {"excess": 0.1}, "tau": 1.0, "p": 0.5, "ftle": True, "ld": False}
    with pytest.raises(ConfigError, match=r"ld_maps\.m\.ld': a map without its LD is of a vector-field system"):
        validate_config({"systems": {"b": {"builtin": "barbanis_2dof"}}, "ld_maps": {"m": spec}})
