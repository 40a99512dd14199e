"""Maps with several start times (``t0`` a list or a range): a start-time dimension, bit for bit.

Every trajectory is integrated on its own, and each start time's bands are gathered as a map
with one start time is, so the stacked file must equal the maps computed one t0 at a time
exactly (an invariant of the tiling, no tolerance); the animated figure has one frame per start.
"""

import copy
import re

import numpy as np
import pytest
from PIL import Image

from ldpipe.config import validate_config
from ldpipe.errors import ConfigError
from ldpipe.io.datafile import open_stage_file
from ldpipe.stages.figures import run_figure
from ldpipe.core.maps.assembly import compute_ld_map
from ldpipe.stages.ld import run_ld_map
from ldpipe.stages.plan import ld_map_points, ld_map_tiles, ld_tile_points
from ldpipe.config.parameters import parameters_from_config
from support.double_gyre import double_gyre_velocity
from support.gridded import write_velocity_file
from support.tick_labels import assert_readable_tick_labels

H = 1.0 / 8
SPEC = {"system": "gyre", "tau": 1.5, "p": 0.5, "ftle": True, "tiles": 2, "integrator": {"rtol": 1e-9, "atol": 1e-9},
        "section": {"axes": [{"name": "x", "range": [0.1, 1.9], "points": 6}, {"name": "y", "range": [0.1, 0.9], "points": 4}]}}


def gyre_config(path, t0, figures=None):
    return validate_config({"systems": {"gyre": {"velocity_data": {"path": str(path)}}},
                            "ld_maps": {"m": {**copy.deepcopy(SPEC), "t0": t0}}, **({"figures": figures} if figures else {})})


def test_stacked_start_times_equal_single_maps_and_animate(tmp_path):
    x, y, t = np.arange(0, 2 + H / 2, H), np.arange(0, 1 + H / 2, H), np.arange(0.0, 6.0 + H / 2, H)
    path = write_velocity_file(tmp_path / "gyre.nc", double_gyre_velocity, x, y, t)
    starts = [2.0, 2.5, 3.0]
    figures = {"anim": {"kind": "ld_animation", "ld_maps": ["m"]}}
    config = gyre_config(path, {"first": 2.0, "last": 3.0, "count": 3}, figures)
    assert ld_map_tiles(config, "m") == 6  # two bands for each of three start times: six Snakemake jobs
    stacked = open_stage_file(run_ld_map(output=tmp_path / "m.nc", equilibria=None, tiles=6, show_progress=False,
                                         **parameters_from_config(config, "ld", "m")), stage="ld_grid")
    assert stacked.t0.values.tolist() == starts and stacked.ld_forward.dims == ("t0", "x", "y")
    assert gyre_config(path, starts)["ld_maps"]["m"]["t0"] == starts  # the same map as a list
    for k, start in enumerate(starts):
        single = compute_ld_map(parameters_from_config(gyre_config(path, start), "ld", "m"), None, show_progress=False)
        assert sorted(single.data_vars) == sorted(stacked.data_vars)
        for name in single.data_vars:
            np.testing.assert_array_equal(stacked[name].values[k], single[name].values, err_msg=f"{name} at t0 = {start}")
    assert not np.array_equal(stacked.ld_forward.values[0], stacked.ld_forward.values[2])  # the flow changes in time
    settings = parameters_from_config(config, "figures", "anim")
    gif = tmp_path / "anim.gif"
    run_figure(**settings, inputs={"ld_maps": [str(tmp_path / "m.nc")]}, png=tmp_path / "anim.png", gif=gif)
    with Image.open(gif) as image:
        assert image.n_frames == len(starts)
    from ldpipe.figures.ld_animation import draw_ld_animation

    assert_readable_tick_labels(draw_ld_animation(settings["settings"], ld_maps=[str(tmp_path / "m.nc")]), tmp_path)


def test_snakemake_runs_a_job_per_start_time_and_band(workdir):
    # three start times in two bands each: six tile jobs, one gather, the animation (its GIF an output)
    import yaml

    from support.workflow import job_counts, run_snakemake

    x, y, t = np.arange(0, 2 + H / 2, H), np.arange(0, 1 + H / 2, H), np.arange(0.0, 6.0 + H / 2, H)
    write_velocity_file(workdir / "gyre.nc", double_gyre_velocity, x, y, t)
    config = {"systems": {"gyre": {"velocity_data": {"path": "gyre.nc"}}},
              "ld_maps": {"m": {**SPEC, "t0": [2.0, 2.5, 3.0]}},
              "figures": {"anim": {"kind": "ld_animation", "ld_maps": ["m"]}}}
    (workdir / "starts.yaml").write_text(yaml.safe_dump(config))
    result = run_snakemake(workdir, "anim", "-n", "--quiet", "rules", "--configfile", "starts.yaml", timeout=300)
    assert result.returncode == 0, result.stderr
    assert job_counts(result.stdout) == {"ld_tile": 6, "ld_gather": 1, "anim": 1}
    # each tile job asks for the memory of its own points, a band of one start time's grid: on a
    # 2000 x 1500 section (the file's 3 x 3e6 points) in 3 x 2 tiles, 1000 rows x 1500 columns,
    # 1 GB plus 200 bytes a point (workflow/rules/common.smk), where a third of that was asked
    big = {**config, "ld_maps": {"m": {**config["ld_maps"]["m"], "section": {"axes": [
        {"name": "x", "range": [0.1, 1.9], "points": 2000}, {"name": "y", "range": [0.1, 0.9], "points": 1500}]}}}}
    (workdir / "big.yaml").write_text(yaml.safe_dump(big))
    result = run_snakemake(workdir, "anim", "-n", "--configfile", "big.yaml", timeout=300)
    assert result.returncode == 0, result.stderr
    tiles = re.findall(r"rule ld_tile:.*?resources: [^\n]*mem_mb=(\d+)", result.stdout, flags=re.S)
    assert len(tiles) == 6 and set(tiles) == {str(1000 + 1000 * 1500 * 200 // 2**20)}, tiles


def test_figures_of_one_start_time_refuse_a_stacked_map(tmp_path):
    with pytest.raises(ConfigError, match=r"map 'm' has several start times .*kind 'ld_animation' draws them all"):
        gyre_config(tmp_path / "gyre.nc", [2.0, 2.5], {"f": {"kind": "ld_ftle", "ld_maps": ["m"]}})


@pytest.mark.parametrize("tiles", [2, 4])
def test_tile_points_the_workflow_sizes_jobs_by_are_a_tiles_points(tmp_path, tiles):
    """A tile job's memory and time limit are sized by its points (workflow/rules/common.smk).
    With several start times a tile is a band of one start time's grid: the count planned must be
    the largest tile's, counted here independently on the tiles computed (6 rows in 2 bands of 3,
    or in 4 bands of 1 or 2 rows, each of 4 columns), not the map's points over the tiles."""
    x, y, t = np.arange(0, 2 + H / 2, H), np.arange(0, 1 + H / 2, H), np.arange(0.0, 6.0 + H / 2, H)
    path = write_velocity_file(tmp_path / "gyre.nc", double_gyre_velocity, x, y, t)
    config = gyre_config(path, [2.0, 2.5, 3.0])
    config["ld_maps"]["m"]["tiles"] = tiles
    count = ld_map_tiles(config, "m")
    assert count == 3 * tiles
    parameters = parameters_from_config(config, "ld", "m")
    counted = [compute_ld_map(parameters, None, tile=k, tiles=count, show_progress=False).ld_forward.size
               for k in range(count)]
    assert sum(counted) == ld_map_points(config, "m") == 3 * 6 * 4
    assert ld_tile_points(config, "m", count) == max(counted) == 4 * -(-6 // tiles)
