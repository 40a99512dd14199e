"""Stochastic LD maps through the map machinery: the member dimension, its mean and spread, the
same bits in any tiling and with several start times, the file written and read back, and the
configuration's refusals naming their keys.

The system and noise are those of tests/engine/test_stochastic.py (OU in x, GBM in y), so the
engine module compiled there serves here.
"""

import numpy as np
import pytest

import ldpipe
from ldpipe.config import validate_config
from ldpipe.core.maps import assembly, stochastic
from ldpipe.errors import ConfigError
from ldpipe.figures.data import load_ld_map
from ldpipe.io.contracts import LD_GRID
from ldpipe.io.datafile import open_stage_file, write_stage_file
from ldpipe.stages.plan import ld_map_points, ld_tile_points

NOISE = {"diffusion": {"x": "sigma", "y": "beta*y"}, "parameters": {"sigma": 0.5, "beta": 1.0}, "members": 3,
         "seed": 42, "dt": 0.05, "scheme": "milstein"}


@pytest.fixture(scope="module")
def system():
    return ldpipe.system(name="sde_ou_gbm", vector_field={"x": "-theta*x", "y": "mu*y"}, coordinates=["x", "y"],
                         parameters={"theta": 1.0, "mu": 1.0})


def noisy_map(system, **keys):
    spec = {"section": ldpipe.section(x=(-1, 1, 6), y=(0.5, 1.5, 4)), "tau": 0.5, "p": 0.5, "noise": NOISE, **keys}
    return ldpipe.ld_map(system, **spec)


def test_member_dimension_mean_and_spread(system, tmp_path):
    whole = noisy_map(system)
    assert whole.ld_forward.dims == ("member", "x", "y") and whole.sizes["member"] == 3
    assert whole.ld_forward_mean.dims == ("x", "y")
    # the mean and spread are those of the member dimension (n - 1 in the spread's denominator)
    for label in ("forward", "backward"):
        np.testing.assert_allclose(whole[f"ld_{label}_mean"], whole[f"ld_{label}"].mean("member"), rtol=1e-14)
        np.testing.assert_allclose(whole[f"ld_{label}_spread"], whole[f"ld_{label}"].std("member", ddof=1),
                                   rtol=1e-12)
    assert np.all(whole.ld_forward_spread > 0)  # members differ: each has its own noise
    assert whole.attrs["scheme"] == "milstein" and whole.attrs["members"] == 3 and whole.attrs["dt"] == 0.05
    assert whole.attrs["steps"] == 10 and whole.attrs["seed"] == "42" and "rtol" not in whole.attrs
    # a figure draws the ensemble mean (ldpipe.figures.data.load_ld_map)
    drawn = load_ld_map(whole, "total").values
    np.testing.assert_allclose(drawn, whole.ld_forward_mean + whole.ld_backward_mean, rtol=1e-14)
    # the file: written and read back with the LD map's contract, bit for bit
    path = tmp_path / "noisy.nc"
    write_stage_file(whole, path)
    with open_stage_file(path, stage=LD_GRID) as back:
        for name in whole.data_vars:
            np.testing.assert_array_equal(back[name].values, whole[name].values)


def test_tiles_chunks_and_start_times_give_the_same_bits(system, monkeypatch):
    # Each point's noise is counted by its index in the whole grid: 3 tiles, or engine calls of 7 paths,
    # compute the whole map's bits; a map of two start times holds at each the map of that start time alone.
    whole = noisy_map(system)
    tiled = noisy_map(system, tiles=3)
    with monkeypatch.context() as patch:
        patch.setattr(stochastic, "PATHS_PER_CALL", 7)
        chunked = noisy_map(system)
    for name in whole.data_vars:
        np.testing.assert_array_equal(tiled[name].values, whole[name].values)
        np.testing.assert_array_equal(chunked[name].values, whole[name].values)
    both = noisy_map(system, t0=[0.0, 0.3], tiles=2)
    later = noisy_map(system, t0=0.3)
    for name in whole.data_vars:
        np.testing.assert_array_equal(both[name].sel(t0=0.0).values, whole[name].values)
        np.testing.assert_array_equal(both[name].sel(t0=0.3).values, later[name].values)
    assert not np.array_equal(later.ld_forward.values, whole.ld_forward.values)
    # one direction of time: that direction's variables alone, the same bits as in the map of both
    backward = noisy_map(system, directions="backward")
    assert "ld_forward" not in backward and "ld_backward_mean" in backward
    for name in ("ld_backward", "exit_time_backward", "ld_backward_mean", "ld_backward_spread"):
        np.testing.assert_array_equal(backward[name].values, whole[name].values)


@pytest.mark.parametrize("keys, where", [
    ({"ftle": True}, "'ftle': a map with noise"),
    ({"structures": True}, "'structures': a map with noise"),
    ({"time": "variable", "region": {"x": [-2, 2], "y": [-2, 2]}}, "'time': a map with noise"),
    ({"noise": {**NOISE, "diffusion": {"x": "sigma*y", "y": "beta*y"}}}, "'noise.scheme': milstein needs diagonal"),
    ({"noise": {**NOISE, "diffusion": {"x": "open(sigma)", "y": "1"}}}, "'noise.diffusion.x': unknown functions"),
    ({"noise": {**NOISE, "members": 0}}, "'noise.members'"),
])
def test_refusals_name_their_key(system, keys, where):
    # the API names the argument the configuration key stands for
    with pytest.raises(ConfigError, match=where.replace(".", r"\.")):
        noisy_map(system, **keys)


def test_noise_on_a_discrete_map_is_refused():
    henon = ldpipe.system(map="henon")
    with pytest.raises(ConfigError, match=r"argument 'noise'.*discrete map"):
        ldpipe.ld_map(henon, section=ldpipe.section(x=(-1, 1, 3), y=(-1, 1, 3)), iterations=5,
                      noise={"diffusivity": 0.1})


def test_noise_on_a_hamiltonian_is_refused():
    oscillator = ldpipe.system(name="sde_refused", formula="(x**2 + y**2)/2", coordinates=["x", "y"])
    section = ldpipe.section(x=(-1, 1, 3), px=(-1, 1, 3), fixed={"y": 0.0}, solve="py")
    with pytest.raises(ConfigError, match=r"argument 'noise'.*Hamiltonian"):
        ldpipe.ld_map(oscillator, section=section, energy=1.0, noise={"diffusivity": 0.1})


def test_a_band_is_sized_by_its_paths(system, monkeypatch):
    # On a machine of 1100 MB (1000 for the process, 200 bytes a path: ldpipe.core.maps.budget), 100 x 100
    # points fit (2 MB) but not with 64 members a point (122 MB): refused before any path, naming tiles.
    monkeypatch.setattr(assembly, "machine_memory_mb", lambda: 1100)
    section = ldpipe.section(x=(-1, 1, 100), y=(0.5, 1.5, 100))
    with pytest.raises(ConfigError, match=r"argument 'tiles'.*noisy paths \(64 members a grid point\)"):
        ldpipe.ld_map(system, section=section, tau=0.1, noise={"diffusivity": 0.1, "members": 64, "dt": 0.1})


def test_the_workflow_sizes_a_noisy_maps_jobs_by_its_paths():
    # A tile job's memory and time limit are sized by what it integrates (workflow/rules/common.smk):
    # 6 x 4 points in 2 tiles of 3 rows, 16 members a point: 3 * 4 * 16 paths a tile, 6 * 4 * 16 in the file.
    config = validate_config({
        "systems": {"s": {"vector_field": {"x": "-x", "y": "y"}, "coordinates": ["x", "y"]}},
        "ld_maps": {"m": {"system": "s", "tiles": 2, "noise": {"diffusivity": 0.1, "members": 16}, "section": {
            "axes": [{"name": "x", "range": [-1, 1], "points": 6}, {"name": "y", "range": [-1, 1], "points": 4}]}}}})
    assert ld_tile_points(config, "m", 2) == 3 * 4 * 16
    assert ld_map_points(config, "m") == 6 * 4 * 16


def test_the_command_line_takes_every_key_of_the_noise_block(system, tmp_path, capsys):
    """``ldpipe ld``'s noise options: the map of --diffusion, --noise-parameter, --noise-scheme,
    --noise-dt, --seed and --members is the API's of the same block (the same engine, bit for
    bit); with --map they change that entry's block; the other forms of the block (a diffusivity
    per variable, rows of a full G, walls) are read as the configuration writes them; bad input
    names the option, before anything is written."""
    import yaml

    from ldpipe.cli import main
    from ldpipe.cli.main import build_parser
    from ldpipe.cli.noise import noise_options

    config = tmp_path / "flows.yaml"
    entry = {"system": "sde_ou_gbm", "section": ldpipe.section(x=(-1, 1, 6), y=(0.5, 1.5, 4)), "tau": 0.5, "p": 0.5}
    config.write_text(yaml.safe_dump({
        "systems": {"sde_ou_gbm": {"vector_field": {"x": "-theta*x", "y": "mu*y"}, "coordinates": ["x", "y"],
                                   "parameters": {"theta": 1.0, "mu": 1.0}}},
        "ld_maps": {"noisy": {**entry, "noise": NOISE}}}))
    described = ["ld", "--config", str(config), "--system", "sde_ou_gbm", "--axis", "x=-1:1:6", "--axis",
                 "y=0.5:1.5:4", "--tau", "0.5", "--p", "0.5", "--quiet"]
    noise = ["--diffusion", "x=sigma", "--diffusion", "y=beta*y", "--noise-parameter", "sigma=0.5",
             "--noise-parameter", "beta=1", "--noise-scheme", "milstein", "--noise-dt", "0.05", "--seed", "42",
             "--members", "3"]
    assert main([*described, *noise, "-o", str(tmp_path / "cli.nc")]) == 0
    expected = noisy_map(system)
    with open_stage_file(tmp_path / "cli.nc", stage=LD_GRID) as written:
        for name in expected.data_vars:
            np.testing.assert_array_equal(written[name].values, expected[name].values, err_msg=name)
    named = ["ld", "--config", str(config), "--map", "noisy", "--quiet"]
    assert main([*named, "--seed", "7", "-o", str(tmp_path / "seed7.nc")]) == 0
    reseeded = noisy_map(system, noise={**NOISE, "seed": 7})
    with open_stage_file(tmp_path / "seed7.nc", stage=LD_GRID) as written:
        np.testing.assert_array_equal(written.ld_forward.values, reseeded.ld_forward.values)
    forms = build_parser().parse_args([*described, "--diffusion-row", "atan2(y, x), 0.1", "--diffusion-row", "0, 1",
                                       "--reflect", "x=-2:2", "-o", "x.nc"])
    assert noise_options(forms) == {"diffusion": [["atan2(y, x)", "0.1"], ["0", "1"]], "reflect": {"x": [-2.0, 2.0]}}
    forms = build_parser().parse_args([*described, "--diffusivity", "x=0.5", "--diffusivity", "y=0", "-o", "x.nc"])
    assert noise_options(forms) == {"diffusivity": {"x": 0.5, "y": 0.0}}
    for options, message in (
        (["--diffusivity", "0.1", "--diffusion", "x=1"], "the noise options (--diffusivity, --diffusion): give exactly one"),
        (["--diffusivity", "x=abc"], "--diffusivity x: expected a number"),
        (["--diffusivity", "0.1", "--members", "0"], "--members: 0 is less than the minimum of 1"),
        (["--diffusion", "x=sigma", "--diffusion", "y=beta*y", "--noise-parameter", "sigma=1"],
         "--diffusion y: unknown names ['beta']"),
        (["--diffusion-row", "1, 0", "--diffusion-row", "0, foo("], "--diffusion-row 2 formula 2: cannot parse"),
        (["--diffusion-row", "1, 0"], "--diffusion-row: expected a mapping variable -> formula, or 2 rows"),
        (["--diffusivity", "0.1", "--reflect", "z=0:1"], "--reflect: ['z'] are not state variables"),
        (["--diffusivity", "0.1", "--noise-dt", "2"], "--noise-dt: 2.0 is greater than the maximum of 1"),
        (["--diffusion", "x=y", "--diffusion", "y=x", "--noise-scheme", "milstein"], "--noise-scheme: milstein needs"),
        (["--diffusivity", "0.1", "--seed", "1.5"], "--seed: expected a whole number"),
    ):
        assert main([*described, *options, "-o", str(tmp_path / "bad.nc")]) == 2, options
        assert message in capsys.readouterr().err, options
    assert main([*named, "--diffusivity", "-1", "-o", str(tmp_path / "bad.nc")]) == 2
    assert "--diffusivity: -1.0 is not valid" in capsys.readouterr().err  # the entry's block, with -1
    assert not (tmp_path / "bad.nc").exists()
