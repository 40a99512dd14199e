"""The Python API, used as a notebook would: every result equals the pipeline's file for the same entry.

The expected values here are the pipeline's own files (``ldpipe ld``, ``ldpipe equilibria`` and the
stage functions Snakemake calls) computed from the same configuration entry: the API must give
them back bit for bit, data and attributes, but for ``history`` (when and how a file was written).
The systems and settings are those the stage tests already compile (Hénon–Heiles with DOP853 at
rtol 1e-8, tests/stages/test_ld.py; Barbanis' orbits and manifolds at the quick run's settings).
"""

import inspect
import subprocess
import sys

import matplotlib.pyplot as plt
import numpy as np
import pytest
import xarray as xr
import yaml

import ldpipe
from ldpipe.cli import main
from ldpipe.config import load_config, validate_config
from ldpipe.errors import ConfigError
from ldpipe.io.datafile import open_stage_file
from ldpipe.logs import log_to
from ldpipe.stages.equilibria import run_equilibria
from ldpipe.stages.manifolds import run_manifolds
from ldpipe.config.parameters import parameters_from_config
from ldpipe.stages.upo import run_upo
from support.henon_heiles import HENON_HEILES, hh_slice
from support.stage_files import assert_same_file

#: ldds' Hénon–Heiles slice at the settings of tests/stages/test_ld.py, in two tiles (gathered).
HH_MAP = hh_slice(tiles=2)
#: One orbit of Barbanis' bottom family and its manifolds, at the quick run's manifold settings.
FAMILY = {"system": "barbanis_2dof", "saddle_near": [5.5, -7.0711], "energies": {"excess": [0.125]},
          "tolerance": 1e-10, "energy_tolerance": 1e-12}
MANIFOLD = {"orbits": "bottom", "energy": {"excess": 0.125}, "points": 40, "samples": 150, "displacement": 1e-6,
            "time": 30, "section": {"coordinate": "y", "value": 0.0, "direction": 1}, "crossings": 2,
            "integrator": {"rtol": 1e-10, "atol": 1e-10, "escape_radius": 30}}


@pytest.fixture(scope="module")
def hh_config(tmp_path_factory):
    path = tmp_path_factory.mktemp("api") / "hh.yaml"
    path.write_text(yaml.safe_dump({"systems": {"henon_heiles": HENON_HEILES}, "ld_maps": {"hh": HH_MAP}}))
    return path


@pytest.fixture(scope="module")
def hh():
    return ldpipe.system(name="henon_heiles", **HENON_HEILES)


@pytest.fixture(scope="module")
def hh_map(hh):
    """The map as a notebook writes it: the section and the total energy by their shorthands."""
    section = ldpipe.section(y=(-0.45, 0.8, 11), py=(-0.5, 0.5, 9), fixed={"px": 0.0}, solve="x", root="largest")
    return ldpipe.ld_map(hh, name="hh", section=section, energy=0.125, tau=2.0,
                         integrator={"scheme": "dop853", "rtol": 1e-8, "atol": 1e-8}, tiles=2)


def test_import_is_cheap_and_names_the_api():
    # importing ldpipe loads none of the heavy libraries; the API's names (some shared with
    # science modules, loaded by the API itself) are its functions
    code = ("import sys, ldpipe; "
            "print(sorted(m for m in ('numba', 'matplotlib', 'sympy', 'scipy') if m in sys.modules));"
            "print(callable(ldpipe.ld_map), callable(ldpipe.nhim), callable(ldpipe.transport))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split("\n")
    assert out[:2] == ["[]", "True True True"]


# Stages whose modules load none of these on import: each is imported where it is first used, so a
# job that only reads files (an LD gather, the NHIM validation, most figures) never pays for it
# (the design, not a measurement; transport, saddle flux, normal form and accuracy need theirs).
LAZY_STAGES = ("equilibria", "figures", "ld", "manifolds", "nhim", "nhim_orbits", "nhim_sampling", "nhim_validation",
               "structures", "upo")


def test_stage_modules_import_the_engine_and_the_algebra_on_first_use():
    code = ("import sys; " + "; ".join(f"import ldpipe.stages.{name}" for name in LAZY_STAGES) + "; "
            "print(sorted(m for m in ('matplotlib', 'numba', 'scipy.integrate', 'sympy') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out == "[]\n"


def test_section_shorthand_is_the_config_block():
    block = ldpipe.section(y=(-0.45, 0.8, 11), py=(-0.5, 0.5, 9), fixed={"px": 0.0}, solve="x", root="largest")
    assert block == HH_MAP["section"]


def test_ld_map_equals_the_cli_file_bit_for_bit(tmp_path, hh_config, hh_map):
    out = tmp_path / "hh.nc"
    assert main(["ld", "--config", str(hh_config), "--map", "hh", "--quiet", "-o", str(out)]) == 0
    stored = ldpipe.open_dataset(out)
    assert_same_file(hh_map, stored)
    assert 0 < int(stored.allowed.sum()) < stored.allowed.size and stored.attrs["tiles"] == 2
    # the entry as the configuration holds it, passed as it is, gives the same map
    entry = {key: value for key, value in load_config(hh_config)["ld_maps"]["hh"].items() if key != "system"}
    assert_same_file(ldpipe.ld_map(ldpipe.system(name="henon_heiles", **HENON_HEILES), name="hh", **entry), stored)


def test_equilibria_equals_the_cli_file_bit_for_bit(tmp_path, hh_config, hh):
    out = tmp_path / "eq.nc"
    assert main(["equilibria", "--config", str(hh_config), "--system", "henon_heiles", "-o", str(out)]) == 0
    assert_same_file(ldpipe.equilibria(hh), ldpipe.open_dataset(out))


def test_orbits_and_manifolds_equal_the_stage_functions_files(tmp_path):
    # The files as Snakemake's rules make them: parameters_from_config, then the stage function.
    config = validate_config({"systems": {"barbanis_2dof": {"builtin": "barbanis_2dof"}},
                              "periodic_orbits": {"bottom": dict(FAMILY)}, "manifolds": {"m": dict(MANIFOLD)}})
    equilibria = run_equilibria(**parameters_from_config(config, "equilibria", "barbanis_2dof"),
                                output=tmp_path / "eq.nc")
    upo = run_upo(**parameters_from_config(config, "upo", "bottom"), equilibria=equilibria, output=tmp_path / "upo.nc")
    manifolds = run_manifolds(**parameters_from_config(config, "manifolds", "m"), upo=upo, output=tmp_path / "m.nc")

    barbanis = ldpipe.system(builtin="barbanis_2dof")
    orbits = ldpipe.periodic_orbits(barbanis, name="bottom", **{k: v for k, v in FAMILY.items() if k != "system"})
    assert_same_file(orbits, open_stage_file(upo, stage="upo"))
    cuts = ldpipe.manifolds(orbits, name="m", **{k: v for k, v in MANIFOLD.items() if k != "orbits"})
    assert_same_file(cuts, open_stage_file(manifolds, stage="manifolds"))

    # the family drawn on a given axes: its orbit's (x, y) over one period, as the file holds it
    figure, ax = plt.subplots()
    try:
        assert orbits.ldpipe.plot(ax) is ax
        (line,) = ax.lines
        np.testing.assert_array_equal(line.get_xdata(), orbits.trajectory.values[0, :, 0])
        np.testing.assert_array_equal(line.get_ydata(), orbits.trajectory.values[0, :, 1])
    finally:
        plt.close(figure)


def test_bad_arguments_get_the_config_message_naming_the_argument(hh):
    section = ldpipe.section(y=(-0.45, 0.8, 3), py=(-0.5, 0.5, 3), fixed={"px": 0.0}, solve="x", root="largest")
    entry = {"system": "henon_heiles", "section": section, "energy": {"total": 0.125}, "tau": -1.0}
    with pytest.raises(ConfigError) as config_error:
        validate_config({"systems": {"henon_heiles": dict(HENON_HEILES)}, "ld_maps": {"m": entry}})
    with pytest.raises(ConfigError) as api_error:
        ldpipe.ld_map(hh, section=section, energy=0.125, tau=-1.0)
    # the same message, the argument named where the key was
    config_text = str(config_error.value).split("config key 'ld_maps.m.tau': ")[1]
    assert f"argument 'tau': {config_text}" in str(api_error.value)
    assert str(api_error.value).startswith("ldpipe.ld_map: argument 'tau': ")
    unknown = r"ldpipe.ld_map: unknown arguments \['taux'\] \(did you mean 'tau'\?\); allowed are \[.*'tau'"
    with pytest.raises(ConfigError, match=unknown):
        ldpipe.ld_map(hh, section=section, energy=0.125, taux=1.0)
    with pytest.raises(ConfigError, match=r"ldpipe.system: argument 'builtin': 'barbanis'"):
        ldpipe.system(builtin="barbanis")
    with pytest.raises(ConfigError, match=r"ldpipe.equilibria: argument 'seeds_per_axis': 0"):
        ldpipe.equilibria(hh, seeds_per_axis=0)


@pytest.mark.parametrize("value", [float("nan"), float("inf"), -float("inf")])
def test_non_finite_numbers_are_refused_by_name_in_config_and_api(hh, value):
    section = ldpipe.section(y=(-0.45, 0.8, 3), py=(-0.5, 0.5, 3), fixed={"px": value}, solve="x", root="largest")
    entry = {"system": "henon_heiles", "section": section, "energy": {"total": 0.125}}
    with pytest.raises(ConfigError, match=r"config key 'ld_maps.m.section.fixed.px': expected a finite number"):
        validate_config({"systems": {"henon_heiles": dict(HENON_HEILES)}, "ld_maps": {"m": entry}})
    with pytest.raises(ConfigError, match=r"ldpipe.ld_map: argument 'section.fixed.px': expected a finite number"):
        ldpipe.ld_map(hh, section=section, energy=0.125)
    with pytest.raises(ConfigError, match=r"ldpipe.ld_map: argument 'energy.total': expected a finite number"):
        ldpipe.ld_map(hh, section={**section, "fixed": {"px": 0.0}}, energy=value)
    with pytest.raises(ConfigError, match=r"ldpipe.system: argument 'parameters.delta': expected a finite number"):
        ldpipe.system(builtin="barbanis_2dof", parameters={"delta": value})


@pytest.mark.parametrize("value", ["nan", "inf", "-inf", "1e999"])
def test_non_finite_numbers_are_refused_by_the_cli_before_any_work(tmp_path, capsys, value):
    out = tmp_path / "m.nc"
    common = ["ld", "--system", "barbanis_2dof", "--axis", "x=4.8:6.0:3", "--axis", "px=-0.6:0.6:3", "--solve", "py",
              "--quiet", "-o", str(out)]
    with pytest.raises(SystemExit) as exit_status:  # argparse's own refusal of an option's value
        main([*common, "--fixed", "y=-7", f"--excess-energy={value}"])
    assert exit_status.value.code == 2
    assert f"argument --excess-energy: expected a finite number, got {value!r}" in capsys.readouterr().err
    assert main([*common, "--fixed", f"y={value}", "--excess-energy", "0.1"]) == 2
    assert f"--fixed y: expected a finite number, got {value!r}" in capsys.readouterr().err
    assert main(["equilibria", "--system", "barbanis_2dof", "--parameter", f"delta={value}", "-o", str(out)]) == 2
    assert f"--parameter delta: expected a finite number, got {value!r}" in capsys.readouterr().err
    assert not out.exists()


def test_a_configuration_error_inside_a_stage_prints_its_message_alone(tmp_path, capsys):
    # |x| is not twice differentiable: the system's kernels refuse it when the stage builds them.
    config = tmp_path / "abs.yaml"
    config.write_text('systems:\n  absy:\n    formula: "Abs(x) + y**2"\n    coordinates: [x, y]\n')
    out = tmp_path / "eq.nc"
    assert main(["equilibria", "--config", str(config), "--system", "absy", "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("ldpipe equilibria: error: config key 'systems.absy.formula': ") and "DiracDelta" in err
    assert err.count("\n") == 1 and "Traceback" not in err
    # under Snakemake the log file gets the message, still without a traceback
    log = tmp_path / "stage.log"
    with pytest.raises(ConfigError), log_to(log):
        raise ConfigError("config key 'x': bad")
    assert "stage failed: config key 'x': bad" in log.read_text() and "Traceback" not in log.read_text()


def test_accessor_draws_the_map_on_the_given_axes(hh_config, hh_map, tmp_path):
    figure, ax = plt.subplots()
    try:
        assert hh_map.ldpipe.plot(ax=ax, descriptor="forward") is ax
        (mesh,) = ax.collections
        drawn = np.ma.masked_invalid(mesh.get_array()).reshape(hh_map.ld_forward.shape[::-1])
        allowed = hh_map.allowed.values.T
        # the forward LD with its first axis, y, across (the mesh's rows are py), forbidden points masked (grey)
        np.testing.assert_array_equal(np.ma.getmaskarray(drawn), ~allowed)
        np.testing.assert_array_equal(drawn.compressed(), hh_map.ld_forward.values.T[allowed])
        # the colour scale: the schema's default percentiles [5, 99.9] of the allowed values
        expected = np.percentile(hh_map.ld_forward.values.T[allowed], [5.0, 99.9])
        np.testing.assert_array_equal(mesh.get_clim(), expected)
        assert ax.get_xlabel() == "$y$" and ax.get_ylabel() == "$p_y$"
    finally:
        plt.close(figure)
    # any Dataset has the accessor once ldpipe is imported, however it was opened
    path = tmp_path / "hh.nc"
    hh_map.to_netcdf(path)
    with xr.open_dataset(path) as opened:
        assert opened.ldpipe.stage == "ld_grid"


def test_a_flow_map_without_its_ld_is_returned_as_the_stage_computes_it(tmp_path):
    # ld: false files hold the flow map and the FTLE under the flow_map contract; the API returns the
    # file of the single-tile stage computation (compute_ld_map), its variables bit for bit
    from ldpipe.core.maps.assembly import compute_ld_map
    from support.gridded import write_velocity_file

    grid = np.linspace(0.0, 4.0, 5)
    path = write_velocity_file(tmp_path / "shear.nc", lambda X, Y, T: (0.1 * Y + 0 * T, 0.05 + 0 * X), grid, grid, grid)
    entry = {"t0": 2.0, "tau": 1.0, "p": 0.5, "ftle": True, "ld": False,
             "section": {"axes": [{"name": "x", "range": [1.0, 3.0], "points": 5},
                                  {"name": "y", "range": [1.0, 3.0], "points": 5}]}}
    shear = ldpipe.system(name="shear", velocity_data={"path": str(path)})
    flow_map = ldpipe.ld_map(shear, name="s", **entry)
    assert "ld_forward" not in flow_map and "ftle_forward" in flow_map
    config = validate_config({"systems": {"shear": {"velocity_data": {"path": str(path)}}}, "ld_maps": {"s": {"system": "shear", **entry}}})
    expected = compute_ld_map(parameters_from_config(config, "ld", "s"), None, show_progress=False)
    for name, variable in expected.data_vars.items():
        np.testing.assert_array_equal(flow_map[name].values, variable.values, err_msg=name)


def test_every_api_docstring_is_whole_and_names_its_shared_arguments():
    # The shared entries (ldpipe.api.arguments.SHARED_DOCS) are substituted at import: a placeholder
    # left, or a function that takes `threads` with no word on it, would reach help() as it is.
    for name in ldpipe.API:
        function = getattr(ldpipe, name)
        assert "%(" not in function.__doc__, name
        if "threads" in inspect.signature(function).parameters:
            assert "threads : int, optional" in function.__doc__, name


@pytest.mark.parametrize("energy", [0.125, 1])
def test_energy_shorthand_is_the_total_energy_block(hh, energy):
    # ``energy=E`` stands for ``energy={"total": E}``, a whole number too: the same map bit for bit
    # (Henon-Heiles' saddle is at 1/6, so a number read as an excess energy gives another map)
    section = ldpipe.section(y=(-0.45, 0.8, 5), py=(-0.5, 0.5, 4), fixed={"px": 0.0}, solve="x", root="largest")
    settings = {"section": section, "tau": 0.5, "integrator": {"scheme": "dop853", "rtol": 1e-8, "atol": 1e-8}}
    block = ldpipe.ld_map(hh, name="hh", energy={"total": energy}, **settings)
    assert_same_file(ldpipe.ld_map(hh, name="hh", energy=energy, **settings), block)
    assert block.allowed.values.any()
    excess = ldpipe.ld_map(hh, name="hh", energy={"excess": energy}, **settings)
    assert not np.array_equal(excess.allowed.values, block.allowed.values) or \
        not np.array_equal(excess.ld_forward.values, block.ld_forward.values)


def test_a_bool_energy_is_no_shorthand(hh):
    # True is an int to Python, but not a number to the configuration: it is refused as the argument
    # 'energy' itself, not made a block {"total": True} whose key the message would name instead
    section = ldpipe.section(y=(-0.45, 0.8, 3), py=(-0.5, 0.5, 3), fixed={"px": 0.0}, solve="x", root="largest")
    with pytest.raises(ConfigError, match=r"argument 'energy': True is not of type 'object'"):
        ldpipe.ld_map(hh, section=section, energy=True, tau=0.5)
