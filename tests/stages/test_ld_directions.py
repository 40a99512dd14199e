"""A map's ``directions``: forward or backward alone, integrated, written and drawn as asked.

The reference is the identity: each trajectory's result depends on its start point and the
settings alone (tests/stages/test_ld_batches.py), so a map of one direction must hold exactly
the variables of that direction of the map of both, bit for bit, and its engine must integrate
half the trajectories (counted from what the engine reports: the start points of each call and
their step attempts). The systems and settings are ones other tests compile (Barbanis with
DOP853; the double gyre of tests/data/test_ftle.py).
"""

import copy

import matplotlib.pyplot as plt
import numpy as np
import pytest
import xarray as xr
import yaml

import ldpipe
import ldpipe.core.maps.grid as grid
from ldpipe.cli import main
from ldpipe.config import load_schema, validate_config
from ldpipe.config.parameters import parameters_from_config
from ldpipe.core.maps.assembly import ld_map_dataset
from ldpipe.errors import ConfigError
from ldpipe.io.datafile import open_stage_file
from support.barbanis import E_C
from support.double_gyre import DOUBLE_GYRE
from support.workflow import documented_yaml

#: A bounded Barbanis section (every trajectory runs the whole tau) with the FTLE of its flow map.
MAP = {
    "section": {"axes": [{"name": "x", "range": [-2.0, 4.0], "points": 24},
                         {"name": "px", "range": [-2.5, 2.5], "points": 20}],
                "fixed": {"y": 0.0}, "solve": "py"},
    "energy": {"total": E_C - 0.1}, "tau": 10.0, "p": 0.5, "ftle": True,
    "integrator": {"scheme": "dop853", "rtol": 1e-8, "atol": 1e-8},
}
GYRE_MAP = {
    "system": "double_gyre", "t0": 0.0,
    "section": {"axes": [{"name": "x", "range": [0.0, 2.0], "points": 21},
                         {"name": "y", "range": [0.0, 1.0], "points": 11}]},
    "tau": 5.0, "p": 0.5, "integrator": {"rtol": 1e-9, "atol": 1e-9}, "ftle": True,
}
LABELS = ("forward", "backward")


@pytest.fixture(scope="module")
def barbanis_system():
    return ldpipe.system(builtin="barbanis_2dof")


@pytest.fixture(scope="module")
def equilibria(barbanis_system):
    return ldpipe.equilibria(barbanis_system)


def counting(monkeypatch):
    """Every engine call of a map recorded: (direction, start points, step attempts reported)."""
    calls = []
    compute_ld = grid.compute_ld

    def counted(system, states, direction=1, settings=None, t0=0.0):
        result = compute_ld(system, states, direction, settings, t0)
        calls.append((direction, len(states), int(result.steps.sum())))
        return result

    monkeypatch.setattr(grid, "compute_ld", counted)
    return calls


def barbanis_map(system, equilibria, **keys):
    return ldpipe.ld_map(system, name="m", equilibria=equilibria, **{**copy.deepcopy(MAP), **keys})


@pytest.fixture(scope="module")
def both(barbanis_system, equilibria):
    return barbanis_map(barbanis_system, equilibria)


@pytest.fixture(scope="module")
def backward(barbanis_system, equilibria):
    """The backward map in two tiles, gathered: the FTLE over the whole grid of the one direction held."""
    return barbanis_map(barbanis_system, equilibria, directions="backward", tiles=2)


def direction_variables(dataset, label):
    """The names of ``dataset``'s variables of direction ``label``."""
    return sorted(name for name in dataset.variables if name.endswith(f"_{label}"))


def assert_half_of(one: xr.Dataset, both: xr.Dataset, label: str):
    """``one`` holds ``label``'s variables of ``both`` and nothing of the other direction, bit for bit."""
    other = LABELS[1 - LABELS.index(label)]
    assert one.attrs["directions"] == label and both.attrs["directions"] == "both"
    assert direction_variables(one, other) == []
    assert direction_variables(one, label) == direction_variables(both, label)
    assert {f"ld_{label}", f"ftle_{label}", f"end_x_{label}"} <= set(one.variables)
    for name in [*direction_variables(both, label), "allowed", "py", *both.coords]:
        assert np.array_equal(one[name].values, both[name].values), name


def test_forward_map_is_the_forward_half_and_integrates_half(monkeypatch, barbanis_system, equilibria, both,
                                                            backward):
    calls = counting(monkeypatch)
    forward = barbanis_map(barbanis_system, equilibria, directions="forward")
    assert_half_of(forward, both, "forward")
    # each map's energy error is its own direction's; the map of both keeps the larger of the two
    assert np.array_equal(both.energy_error.values,
                          np.maximum(forward.energy_error.values, backward.energy_error.values))
    allowed = int(both.allowed.sum())
    assert allowed > 100
    # only forward trajectories, one per allowed point, with the steps the file records
    assert [direction for direction, _, _ in calls] == [1] * len(calls)
    assert sum(points for _, points, _ in calls) == allowed
    assert sum(steps for _, _, steps in calls) == int(both.steps_forward.sum())
    calls.clear()
    barbanis_map(barbanis_system, equilibria)
    assert sorted({direction for direction, _, _ in calls}) == [-1, 1]
    assert sum(points for _, points, _ in calls) == 2 * allowed
    assert sum(steps for _, _, steps in calls) == int(both.steps_forward.sum() + both.steps_backward.sum())


def test_backward_map_in_tiles_is_the_backward_half(both, backward):
    assert_half_of(backward, both, "backward")


def test_vector_field_forward_map_is_the_forward_half():
    def gyre(**keys):
        config = validate_config({"systems": {"double_gyre": copy.deepcopy(DOUBLE_GYRE)},
                                  "ld_maps": {"g": {**copy.deepcopy(GYRE_MAP), **keys}}})
        return ld_map_dataset(parameters_from_config(config, "ld", "g"), None, show_progress=False)

    forward, whole = gyre(directions="forward"), gyre()
    assert direction_variables(forward, "backward") == []
    for name in [*direction_variables(whole, "forward"), "allowed"]:
        assert np.array_equal(forward[name].values, whole[name].values), name


def test_cli_writes_one_direction(tmp_path, capsys):
    out = tmp_path / "forward.nc"
    code = main(["ld", "--system", "barbanis_2dof", "--axis", "x=-2:4:6", "--axis", "px=-2.5:2.5:5", "--fixed",
                 "y=0", "--solve", "py", "--energy", str(E_C - 0.1), "--tau", "10", "--rtol", "1e-8", "--atol",
                 "1e-8", "--directions", "backward", "--quiet", "-o", str(out)])
    assert code == 0
    dataset = open_stage_file(out, stage="ld_grid")
    assert dataset.attrs["directions"] == "backward"
    assert "ld_backward" in dataset and direction_variables(dataset, "forward") == []
    with pytest.raises(SystemExit) as refused:
        main(["ld", "--system", "barbanis_2dof", "--directions", "sideways", "-o", str(tmp_path / "x.nc")])
    assert refused.value.code == 2 and "--directions: invalid choice: 'sideways'" in capsys.readouterr().err


def test_a_bad_value_is_refused_naming_directions(barbanis_system):
    with pytest.raises(ConfigError, match=r"argument 'directions': 'sideways' is not one of"):
        ldpipe.ld_map(barbanis_system, name="m", directions="sideways", **copy.deepcopy(MAP))
    config = {"systems": {"b": {"builtin": "barbanis_2dof"}},
              "ld_maps": {"m": {"system": "b", **copy.deepcopy(MAP), "directions": "both ways"}}}
    with pytest.raises(ConfigError, match=r"ld_maps\.m\.directions"):
        validate_config(config)


def test_the_documented_example_is_a_forward_map():
    entry = yaml.safe_load(documented_yaml("gyre_forward"))
    config = validate_config({"systems": {"double_gyre": copy.deepcopy(DOUBLE_GYRE)}, **entry})
    assert config["ld_maps"]["gyre_forward"]["directions"] == "forward"


def test_schema_lists_the_engine_directions():
    # one home: the schema's values are the map code's; its default is the code's and is not
    # filled in, so a map that leaves the key out records the parameters it recorded before it existed
    setting = load_schema()["$defs"]["ld_map"]["properties"]["directions"]
    assert setting["enum"] == list(grid.DIRECTIONS) and "default" not in setting
    assert f"Left out: {grid.BOTH}" in " ".join(setting["description"].split())
    config = validate_config(config_with({}))
    assert "directions" not in parameters_from_config(config, "ld", "m")


def config_with(map_keys: dict, **sections):
    entry = {"system": "b", **copy.deepcopy(MAP), **map_keys}
    return {"systems": {"b": {"builtin": "barbanis_2dof"}}, "ld_maps": {"m": entry}, **sections}


def test_what_needs_both_directions_refuses_one_naming_directions():
    forward = {"directions": "forward"}
    figure = {"figures": {"f": {"kind": "section_maps", "ld_maps": ["m"], "poincare": []}}}
    with pytest.raises(ConfigError, match=r"figures\.f\.descriptor.*ld_maps\.m\.directions: forward"):
        validate_config(config_with(forward, **figure))
    figure["figures"]["f"]["descriptor"] = "forward"
    validate_config(config_with(forward, **figure))  # the direction it has: drawn
    with pytest.raises(ConfigError, match=r"ld_maps\.m\.backward_by_symmetry.*directions: forward"):
        validate_config(config_with({**forward, "backward_by_symmetry": True}))
    variable = {**forward, "time": "variable", "ftle": False, "region": {"x": [-3.0, 5.0], "y": [-3.0, 3.0]}}
    study = {"nhim": {"studies": {"s": {"maps": ["m"]}}}}
    with pytest.raises(ConfigError, match=r"nhim\.studies\.s\.maps.*ld_maps\.m\.directions: forward"):
        validate_config(config_with(variable, **study))


def test_plot_draws_the_direction_a_map_has(barbanis_system, equilibria):
    forward = barbanis_map(barbanis_system, equilibria, directions="forward", ftle=False)
    ax = forward.ldpipe.plot()
    # the map's first axis across: the mesh's rows run along the second
    drawn = np.asarray(ax.collections[0].get_array()).reshape(forward.ld_forward.shape[::-1]).T
    assert np.array_equal(drawn[forward.allowed.values], forward.ld_forward.values[forward.allowed.values])
    plt.close("all")
    with pytest.raises(ConfigError, match=r"ld_maps\.m\.directions.*directions: forward.*needs the backward"):
        forward.ldpipe.plot(descriptor="total")


def test_adaptive_forward_map_is_the_forward_half(equilibria):
    # each direction is refined on its own fates and LD, so the forward map refines as the map of
    # both refines its forward half: the same pixels integrated, the same values, half the trajectories
    # (the variable-time slice of tests/stages/test_ld.py's adaptive map)
    entry = {"system": "b", "saddle_near": [5.5, -7.0], "energy": {"excess": 0.125}, "tau": 5.0, "time": "variable",
             "section": {"axes": [{"name": "x", "range": [4.8, 6.0], "points": 13},
                                  {"name": "px", "range": [-0.6, 0.6], "points": 9}],
                         "fixed": {"y": -7.0}, "solve": "py"},
             "region": {"x": [4.5, 6.5], "y": [-8.5, -5.5]}, "refine": {"tolerance": 0.002, "coarse_spacing": 4},
             "integrator": {"scheme": "dop853", "rtol": 1e-8, "atol": 1e-8}}

    def adaptive(**keys):
        config = validate_config({"systems": {"b": {"builtin": "barbanis_2dof"}}, "ld_maps": {"m": {**entry, **keys}}})
        return ld_map_dataset(parameters_from_config(config, "ld", "m"), equilibria, show_progress=False)

    forward, whole = adaptive(directions="forward"), adaptive()
    assert direction_variables(forward, "backward") == []
    assert forward.computed_forward.values.any()
    for name in direction_variables(whole, "forward"):  # NaN (missing) at the same points counts as equal
        np.testing.assert_array_equal(forward[name].values, whole[name].values, err_msg=name)
    assert forward.attrs["refine_trajectories"] == whole.attrs["refine_trajectories_forward"]


def test_ld_ftle_figure_draws_the_one_ftle(backward):
    from ldpipe.figures.ld_ftle import draw_ld_ftle

    figure = draw_ld_ftle({"descriptor": "backward", "color_percentiles": [5.0, 99.9]}, ld_maps=[backward])
    ld_ax, ftle_ax, empty = figure.axes[0], figure.axes[1], figure.axes[2]
    allowed = backward.allowed.values
    assert np.array_equal(ld_ax.images[0].get_array().data.T[allowed], backward.ld_backward.values[allowed])
    defined = backward.ftle_defined_backward.values.astype(bool)
    assert defined.any()
    assert np.array_equal(ftle_ax.images[0].get_array().data.T[defined], backward.ftle_backward.values[defined])
    assert not empty.axison and not empty.images  # no forward FTLE to draw
    plt.close(figure)
    with pytest.raises(ConfigError, match=r"ld_maps\.m\.directions.*needs the forward direction"):
        draw_ld_ftle({"descriptor": "total", "color_percentiles": [5.0, 99.9]}, ld_maps=[backward])
    with pytest.raises(ConfigError, match=r"ld_maps\.m\.directions.*directions: backward, and an NHIM study"):
        grid.open_map_file(backward, "an NHIM study")
