"""A map whose band this machine cannot hold is refused before any trajectory is integrated,
naming the map's ``tiles``; the threshold is tested on both sides of it."""

import pytest

from ldpipe.config import validate_config
from ldpipe.config.parameters import parameters_from_config
from ldpipe.core.equilibria.potential import equilibrium_table
from ldpipe.core.maps import assembly
from ldpipe.core.maps.budget import BASE_MB, BYTES_PER_POINT, band_memory_mb, fewest_tiles, machine_memory_mb
from ldpipe.errors import ConfigError
from ldpipe.systems import make_system


def test_the_estimate_is_the_workflows_and_the_tiles_that_fit_are_the_fewest():
    # 2**20 / 200 points take one MB: the estimate counts whole MB over the process's base
    assert band_memory_mb(0) == BASE_MB and band_memory_mb(2**20 // BYTES_PER_POINT * 3) == BASE_MB + 2
    # a tile of points just fitting in 100 MB above the base: one tile; one point more: two
    fit = 100 * 2**20 // BYTES_PER_POINT
    assert fewest_tiles(fit, BASE_MB + 100) == 1 and fewest_tiles(fit + 1, BASE_MB + 100) == 2
    assert fewest_tiles(10, BASE_MB) is None  # not even one point fits beside the process
    assert machine_memory_mb() > BASE_MB  # Linux says how much memory it has


def test_a_band_over_the_machines_memory_is_refused_naming_tiles_and_one_under_it_is_not():
    points = 4000 * 3000
    need = band_memory_mb(points)
    assembly.check_band_memory("m", points, points, available_mb=need)  # exactly what it needs: accepted
    with pytest.raises(ConfigError, match=r"config key 'ld_maps\.m\.tiles': a band of 12000000 grid points needs "
                                          rf"about {need} MB .* more than this machine's {need - 1} MB; give tiles: 2 or"):
        assembly.check_band_memory("m", points, points, available_mb=need - 1)


def test_a_map_too_big_for_this_machine_is_refused_before_any_integration(monkeypatch):
    # 20000 x 20000 points in one tile: 80 GB at 200 bytes a point, more than any machine this
    # runs on; the engine must never be reached (it would fail to allocate, or swap for hours)
    config = validate_config({"systems": {"barbanis_2dof": {"builtin": "barbanis_2dof"}}, "ld_maps": {"big": {
        "system": "barbanis_2dof", "energy": {"total": 1.0}, "tau": 1.0,
        "section": {"axes": [{"name": "x", "range": [-1.0, 1.0], "points": 20000},
                             {"name": "px", "range": [-1.0, 1.0], "points": 20000}],
                    "fixed": {"y": 0.0}, "solve": "py"}}}})
    parameters = parameters_from_config(config, "ld", "big")

    def never(*args, **kwargs):
        raise AssertionError("the map was computed")

    monkeypatch.setattr(assembly, "ld_grid_dataset", never)
    with pytest.raises(ConfigError, match=r"ld_maps\.big\.tiles': a band of 400000000 grid points"):
        assembly.compute_ld_map(parameters, equilibrium_table(make_system("barbanis_2dof", {"builtin": "barbanis_2dof"}),
                                                          {"x": [-20.0, 20.0], "y": [-20.0, 20.0]}),
                                show_progress=False)
