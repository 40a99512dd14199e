"""The LD grid stage: tiles, masks, attributes, the CLI and the gathered file."""

import numpy as np
import pytest
import xarray as xr

from ldpipe.cli import main
from ldpipe.config import validate_config
from ldpipe.io.datafile import open_stage_file, stage_parameters, write_stage_file
from ldpipe.io.filediff import compare_files
from ldpipe.core.equilibria.potential import equilibrium_table
from ldpipe.errors import ConfigError
from ldpipe.core.maps.assembly import compute_ld_map
from ldpipe.stages.ld import run_ld_gather, run_ld_map, run_ld_tile, write_ld_map
from ldpipe.config.parameters import parameters_from_config
from ldpipe.systems import make_system
from support.henon_heiles import HENON_HEILES, HH_ENERGY, hh_slice
from support.workflow import ROOT

BOX = {"x": [-20.0, 20.0], "y": [-20.0, 20.0]}


def small_config(**overrides):
    ld_map = {
        "system": "barbanis_2dof",
        "saddle_near": [5.5, -7.0],
        "section": {
            "axes": [{"name": "x", "range": [4.8, 6.0], "points": 13}, {"name": "px", "range": [-0.6, 0.6], "points": 9}],
            "fixed": {"y": -7.0},
            "solve": "py",
        },
        "energy": {"excess": 0.125},
        "tau": 5.0,
        "time": "variable",
        "region": {"x": [4.5, 6.5], "y": [-8.5, -5.5]},
        "integrator": {"scheme": "dop853", "rtol": 1e-8, "atol": 1e-8},
        **overrides,
    }
    return validate_config({"systems": {"barbanis_2dof": {"builtin": "barbanis_2dof"}}, "ld_maps": {"m": ld_map}})


@pytest.fixture(scope="module")
def equilibria(barbanis):
    return equilibrium_table(barbanis, BOX)


def test_tiles_gathered_equal_the_untiled_map(tmp_path, equilibria):
    parameters = parameters_from_config(small_config(), "ld", "m")
    whole = compute_ld_map(parameters, equilibria, show_progress=False)
    paths = []
    for tile in range(3):
        part = compute_ld_map(parameters, equilibria, tile=tile, tiles=3, show_progress=False)
        paths.append(write_ld_map(part, parameters, tmp_path / f"tile-{tile}.nc", tile_file=True))
    gathered = open_stage_file(run_ld_gather(tiles=paths[::-1], output=tmp_path / "m.nc"), stage="ld_grid")
    # Each trajectory is integrated on its own, so tiling changes nothing, bit for bit.
    for name in whole.data_vars:
        np.testing.assert_array_equal(gathered[name].values, whole[name].values, err_msg=name)
    np.testing.assert_array_equal(gathered.x.values, np.linspace(4.8, 6.0, 13))
    assert gathered.attrs["tiles"] == 3 and gathered.attrs["time_mode"] == "variable"
    assert stage_parameters(gathered)["map_name"] == "m"


@pytest.mark.parametrize("refine", [None, {"tolerance": 0.002, "coarse_spacing": 4}], ids=["full", "adaptive"])
def test_a_one_tile_map_in_one_job_is_its_tile_gathered(tmp_path, equilibria, refine):
    """The workflow's one job for a map of one tile (rule ld_map: run_ld_map) finishes the band in
    memory; the expected file is the other path through the code, the tile job's file read back
    and joined by the gather (run_ld_gather): equal variables and attributes, and compressed alike."""
    parameters = parameters_from_config(small_config(refine=refine), "ld", "m")
    equilibria = write_stage_file(equilibria, tmp_path / "equilibria.nc", stage="equilibria", title="", parameters={})
    tile = run_ld_tile(**parameters, output=tmp_path / "tile-0-of-1.nc", equilibria=equilibria, show_progress=False)
    gathered = run_ld_gather(tiles=[tile], output=tmp_path / "gathered.nc")
    alone = run_ld_map(**parameters, output=tmp_path / "alone.nc", equilibria=equilibria, tiles=1, show_progress=False)
    assert compare_files(gathered, alone) == []
    with xr.open_dataset(gathered) as expected, xr.open_dataset(alone) as found:
        for name in expected.data_vars:
            compression = {key: expected[name].encoding.get(key) for key in ("zlib", "complevel", "shuffle")}
            assert compression == {key: found[name].encoding.get(key) for key in compression}, name
        assert expected.ld_forward.encoding["zlib"]  # the map's file, not an uncompressed tile


def test_masked_points_are_never_integrated(equilibria):
    parameters = parameters_from_config(small_config(), "ld", "m")
    dataset = compute_ld_map(parameters, equilibria, show_progress=False)
    allowed = dataset.allowed.values
    assert 0 < allowed.sum() < allowed.size  # this slice has both kinds of point
    for name in ("steps_forward", "steps_backward"):
        assert np.all(dataset[name].values[~allowed] == 0), name
        assert np.all(dataset[name].values[allowed] > 0), name
    for name in ("ld_forward", "ld_backward", "exit_time_forward", "energy_error", "py"):  # missing, not 0
        assert np.all(np.isnan(dataset[name].values[~allowed])), name
        assert np.all(np.isfinite(dataset[name].values[allowed])), name
    # The solved momentum puts every allowed point on the energy surface E = E_c + 0.125.
    x, px = np.meshgrid(dataset.x, dataset.px, indexing="ij")
    y = -7.0
    py = dataset.py.values
    energy = 0.5 * (px**2 + py**2) + 0.5 * x**2 + 0.5 * 1.21 * y**2 - 0.11 * x * y**2
    np.testing.assert_allclose(energy[allowed], 15.125 + 0.125, atol=1e-12)


def test_grid_entirely_forbidden_writes_an_empty_map(tmp_path, equilibria):
    config = small_config(energy={"excess": -10.0})
    dataset = compute_ld_map(parameters_from_config(config, "ld", "m"), equilibria, show_progress=False)
    assert not dataset.allowed.values.any()
    path = write_ld_map(dataset, parameters_from_config(config, "ld", "m"), tmp_path / "empty.nc", tile_file=False)
    loaded = open_stage_file(path, stage="ld_grid")
    assert np.all(np.isnan(loaded.ld_forward.values)) and np.all(np.isnan(loaded.energy_error.values))  # all missing


def test_bad_map_settings_name_the_key():
    with pytest.raises(ConfigError, match="ld_maps.m.region"):
        small_config(region={"x": [4.5, 6.5]})  # no interval for y
    with pytest.raises(ConfigError, match="ld_maps.m.section"):
        axes = small_config()["ld_maps"]["m"]["section"]["axes"]
        small_config(section={"axes": axes, "solve": "py"})  # y neither an axis nor fixed
    with pytest.raises(ConfigError, match="ld_maps.m.p"):
        small_config(p=1.5)
    with pytest.raises(ConfigError, match="ld_maps.m.tiles"):
        small_config(tiles=20)  # more tiles than the 13 rows
    with pytest.raises(ConfigError, match="ld_maps.m.system"):
        validate_config({"systems": {"b": {"builtin": "barbanis_2dof"}}, "ld_maps": {"m": small_config()["ld_maps"]["m"]}})


def test_cli_computes_the_fig4a_slice(tmp_path):
    out = tmp_path / "slice.nc"
    code = main([
        "ld", "--system", "barbanis_2dof", "--axis", "x=4.8:6.0:16", "--axis", "px=-0.6:0.6:12",
        "--fixed", "y=-7.0", "--solve", "py", "--excess-energy", "0.125", "--tau", "50", "--p", "0.5",
        "--time", "variable", "--region", "x=4.5:6.5", "--region", "y=-8.5:-5.5", "--saddle-near", "5.5,-7",
        "--quiet", "-o", str(out),
    ])
    assert code == 0
    dataset = open_stage_file(out, stage="ld_grid")
    assert dataset.ld_forward.dims == ("x", "px")
    assert dataset.attrs["excess_energy"] == pytest.approx(0.125, abs=1e-12)
    assert dataset.attrs["tau"] == 50 and dataset.attrs["time_mode"] == "variable"
    allowed = dataset.allowed.values
    # Variable time: every trajectory stops at tau or on leaving the region, never beyond tau.
    assert np.all(dataset.exit_time_forward.values[allowed] <= 50)
    left = dataset.left_region_forward.values[allowed]
    assert np.all(dataset.exit_time_forward.values[allowed][~left] == pytest.approx(50))


def test_cli_map_from_config_and_errors(tmp_path, capsys):
    assert main(["ld", "--config", str(ROOT / "config.yaml"), "--map", "nonesuch", "-o", str(tmp_path / "x.nc")]) == 2
    assert "no map 'nonesuch'" in capsys.readouterr().err
    assert main(["ld", "--system", "barbanis_2dof", "--axis", "x=0:1:3", "--solve", "py",
                 "--excess-energy", "0", "-o", str(tmp_path / "x.nc")]) == 2
    assert "--axis: give exactly two" in capsys.readouterr().err
    assert not (tmp_path / "x.nc").exists()


def test_escaping_fixed_step_map_is_finite_and_records_its_quadrature(equilibria):
    # Fig. 3 section (y = 0, p_y > 0) at dE = 0.125 with sym6 at dt 0.4: steps overshoot the
    # escape radius by orders of magnitude. Rule: no NaN or inf reaches the file but at the missing
    # (never integrated) points.
    section = {
        "axes": [{"name": "x", "range": [-5.6, 5.6], "points": 15}, {"name": "px", "range": [-5.6, 5.6], "points": 15}],
        "fixed": {"y": 0.0},
        "solve": "py",
    }
    config = small_config(section=section, time="fixed", tau=50.0, integrator={"scheme": "sym6", "dt": 0.4})
    dataset = compute_ld_map(parameters_from_config(config, "ld", "m"), equilibria, show_progress=False)
    for name, variable in dataset.data_vars.items():
        if variable.dtype.kind == "f":
            assert np.all(np.isfinite(variable.values[dataset.allowed.values])), name
    allowed = dataset.allowed.values
    assert dataset.escaped_forward.values[allowed].any() or dataset.escaped_backward.values[allowed].any()
    # the quadrature settings in use: LDSettings' defaults for a fixed-step scheme
    assert dataset.attrs["quadrature_window"] == 0.2 and dataset.attrs["quad_nodes"] == 6


def test_map_with_a_solved_position_records_it_like_a_momentum(tmp_path):
    # Hénon–Heiles on ldds' tutorial slice (axes y, p_y; p_x = 0; x solved, the root x >= 0).
    # Invariant: every allowed point has H = E; closed form: x^2 (1 + 2 y) = 2 E - p_y^2 - y^2
    # + 2 y^3 / 3, no root (not allowed, never integrated) where the right side over 1 + 2 y is < 0.
    energy = HH_ENERGY
    config = validate_config({"systems": {"henon_heiles": dict(HENON_HEILES)}, "ld_maps": {"m": hh_slice()}})
    system = make_system("henon_heiles", dict(HENON_HEILES))
    parameters = parameters_from_config(config, "ld", "m")
    dataset = compute_ld_map(parameters, equilibrium_table(system, BOX), show_progress=False)
    path = write_ld_map(dataset, parameters, tmp_path / "m.nc", tile_file=False)
    stored = open_stage_file(path, stage="ld_grid")
    allowed = stored.allowed.values.astype(bool)
    y, py = np.meshgrid(stored.y.values, stored.py.values, indexing="ij")
    x = stored.x.values
    assert stored.x.dims == ("y", "py") and "solved from the energy" in stored.x.attrs["long_name"]
    x_squared = (2 * energy - py**2 - y**2 + 2 * y**3 / 3) / (1 + 2 * y)
    np.testing.assert_array_equal(allowed, x_squared >= 0)
    assert 0 < allowed.sum() < allowed.size
    np.testing.assert_allclose(x[allowed], np.sqrt(x_squared[allowed]), rtol=1e-13, atol=1e-15)
    assert np.all(np.isnan(x[~allowed]))  # missing: no root
    h = 0.5 * py**2 + 0.5 * (x**2 + y**2) + x**2 * y - y**3 / 3
    np.testing.assert_allclose(h[allowed], energy, rtol=0, atol=1e-12)
    for name in ("ld_forward", "ld_backward"):
        assert np.all(np.isnan(stored[name].values[~allowed])) and np.all(stored[name].values[allowed] > 0), name


def test_cli_solves_a_position_with_root_search_and_quad_nodes(tmp_path, capsys):
    # ldds' Hénon–Heiles slice from the command line: p_x = 0, x solved with --root and --search.
    # Closed form: x^2 (1 + 2 y) = 2 E - p_y^2 - y^2 + 2 y^3 / 3; nearest:0.3 takes the root x >= 0.
    config = tmp_path / "hh.yaml"
    config.write_text('systems:\n  henon_heiles:\n    formula: "(x**2 + y**2)/2 + x**2*y - y**3/3"\n'
                      "    coordinates: [x, y]\n")
    out = tmp_path / "hh.nc"
    energy = 0.125
    common = ["ld", "--config", str(config), "--system", "henon_heiles", "--axis", "y=-0.45:0.8:7",
              "--axis", "py=-0.5:0.5:5", "--fixed", "px=0", "--solve", "x", "--energy", str(energy), "--tau", "1",
              "--quiet", "-o", str(out)]
    assert main(common + ["--root", "nearest:0.3", "--search=-3:3", "--quad-nodes", "16"]) == 0
    stored = open_stage_file(out, stage="ld_grid")
    assert stored.attrs["quad_nodes"] == 16  # the setting reached the engine's record
    y, py = np.meshgrid(stored.y.values, stored.py.values, indexing="ij")
    x_squared = (2 * energy - py**2 - y**2 + 2 * y**3 / 3) / (1 + 2 * y)
    allowed = stored.allowed.values.astype(bool)
    np.testing.assert_array_equal(allowed, x_squared >= 0)
    np.testing.assert_allclose(stored.x.values[allowed], np.sqrt(x_squared[allowed]), rtol=1e-12, atol=1e-14)

    out.unlink()
    for options, message in ((["--root", "middle"], "--root: expected largest, smallest or nearest:VALUE"),
                             (["--root", "largest", "--search", "3"], "--search: expected LOW:HIGH"),
                             (["--root", "largest", "--sign", "-1"], "--sign is for a solved momentum"),
                             (["--root", "largest", "--quad-nodes", "1"], "quad_nodes")):
        assert main(common + options) == 2, options
        assert message in capsys.readouterr().err, options
        assert not out.exists()


def test_cli_refuses_root_and_search_for_a_vector_field(tmp_path, capsys):
    # A vector field has no energy: nothing is solved, so a root rule is a mistake to name.
    config = tmp_path / "saddle.yaml"
    config.write_text('systems:\n  saddle:\n    vector_field: {x: "x", y: "-y"}\n    coordinates: [x, y]\n')
    out = tmp_path / "m.nc"
    assert main(["ld", "--config", str(config), "--system", "saddle", "--axis", "x=-1:1:3", "--axis", "y=-1:1:3",
                 "--root", "largest", "--quiet", "-o", str(out)]) == 2
    assert "--root: system 'saddle' is a vector field with no energy" in capsys.readouterr().err
    assert not out.exists()


def test_map_with_masses_solves_momenta_with_them_and_records_them(tmp_path):
    # Barbanis with m_x = m_y = 8. Closed form of the solved momentum on y = -7 (diagonal masses):
    # p_y = sqrt(8 (2 (E - V(x, -7)) - p_x^2 / 8)). The LD (p = 1, M_1) at every allowed point against
    # scipy's DOP853 on Hamilton's equations written out here (dq/dt = p / 8, dp/dt = -grad V).
    from support.scipy_reference import m1_and_arclength

    spec = {"builtin": "barbanis_2dof", "masses": {"x": 8.0, "y": 8.0}}
    ld_map = small_config(p=1.0, time="fixed", tau=4.0)["ld_maps"]["m"]
    ld_map = {**ld_map, "system": "barbanis_m8", "region": {}}
    ld_map["section"]["axes"] = [{"name": "x", "range": [5.0, 5.8], "points": 4},
                                 {"name": "px", "range": [-1.0, 1.0], "points": 5}]
    config = validate_config({"systems": {"barbanis_m8": spec}, "ld_maps": {"m": ld_map}})
    system = make_system("barbanis_m8", spec)
    parameters = parameters_from_config(config, "ld", "m")
    dataset = compute_ld_map(parameters, equilibrium_table(system, BOX), show_progress=False)
    stored = open_stage_file(write_ld_map(dataset, parameters, tmp_path / "m.nc", tile_file=False), stage="ld_grid")
    assert stored.attrs["mass_matrix"] == "[[8.0, 0.0], [0.0, 8.0]]"
    assert stage_parameters(stored)["system_spec"]["masses"] == {"x": 8.0, "y": 8.0}
    energy = float(stored.attrs["energy"])
    x, px = np.meshgrid(stored.x.values, stored.px.values, indexing="ij")
    y = -7.0
    potential = x**2 / 2 + 1.21 * y**2 / 2 - 0.11 * x * y**2
    radicand = 8.0 * (2.0 * (energy - potential) - px**2 / 8.0)
    allowed = stored.allowed.values.astype(bool)
    np.testing.assert_array_equal(allowed, radicand >= 0)
    assert 6 <= allowed.sum() < allowed.size
    py = stored.py.values
    np.testing.assert_allclose(py[allowed], np.sqrt(radicand[allowed]), rtol=1e-13)

    def field(s):
        sx, sy, spx, spy = s
        return np.array([spx / 8.0, spy / 8.0, -(sx - 0.11 * sy * sy), -(1.21 * sy - 0.22 * sx * sy)])

    for i, j in zip(*np.nonzero(allowed)):
        state = np.array([x[i, j], y, px[i, j], py[i, j]])
        forward, _ = m1_and_arclength(field, state, 4.0)
        assert abs(stored.ld_forward.values[i, j] - forward) / forward < 1e-6
