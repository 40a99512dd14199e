"""Faults: killed writes, bad input files, bad configuration values, reruns.

- A process SIGKILLed while ``write_stage_file`` runs (mid-write, or with the data complete
  but not yet renamed) leaves nothing under the final name, and an earlier complete file
  intact.
- A missing, truncated, foreign (netCDF without ldpipe's attributes, or not netCDF) or
  wrong-stage input to a stage run from the ``ldpipe`` command exits with status 2 and a
  message naming the file and the stage it expected.
- A bad configuration value of every kind (wrong type, out of range, unknown key, reference to
  an entry that does not exist) is refused with a message naming the key and what is allowed.
- A real Snakemake run on a copy of the workflow: a job killed mid-run leaves no
  complete-looking output, and the rerun recomputes only that job and what depends on it; so
  does deleting an output.
"""

import copy
import os
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest
import xarray as xr
import yaml

from ldpipe.cli import main
from ldpipe.config import validate_config
from ldpipe.io.datafile import open_stage_file, write_stage_file
from ldpipe.core.equilibria.potential import equilibrium_table
from ldpipe.errors import ConfigError, StageFileError
from ldpipe.stages.equilibria import run_equilibria
from ldpipe.core.maps.assembly import compute_ld_map
from ldpipe.stages.ld import run_ld_gather
from ldpipe.config.parameters import parameters_from_config
from support.workflow import copy_workflow, job_counts, run_snakemake

PYTHON = sys.executable


# --- a write killed by SIGKILL ----------------------------------------------------------------
WRITER = textwrap.dedent("""
    import os, signal, sys
    import numpy as np, xarray as xr
    from ldpipe.io import datafile

    path, size, kill_at_rename = sys.argv[1], int(sys.argv[2]), sys.argv[3] == "1"
    if kill_at_rename:
        # The worst moment: the data are written and synced under the temporary name, the rename
        # not yet done.
        def die(source, destination):
            os.kill(os.getpid(), signal.SIGKILL)
        datafile.os.replace = die
    values = np.random.default_rng(0).standard_normal(size)  # incompressible: a slow write
    dataset = xr.Dataset({"energy": (("point",), values)})
    print("writing", flush=True)
    datafile.write_stage_file(dataset, path, stage="probe", title="new", parameters={})
""")


def start_writer(path, size, kill_at_rename):
    return subprocess.Popen([PYTHON, "-c", WRITER, str(path), str(size), "1" if kill_at_rename else "0"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def small_dataset(title_value=1.0):
    return xr.Dataset({"energy": (("point",), np.full(3, title_value))})


def test_kill_before_the_rename_keeps_the_earlier_file(tmp_path):
    path = tmp_path / "s.nc"
    write_stage_file(small_dataset(), path, stage="probe", title="old", parameters={})
    writer = start_writer(path, 1000, kill_at_rename=True)
    _, stderr = writer.communicate(timeout=120)
    assert writer.returncode == -signal.SIGKILL, stderr
    # The complete earlier file is still what the final name holds; the killed write's data sit
    # under a hidden temporary name that no stage or Snakemake rule would take for the output.
    assert open_stage_file(path, stage="probe").attrs["title"] == "old"
    leftovers = [p.name for p in tmp_path.iterdir() if p.name != "s.nc"]
    assert leftovers and all(name.startswith(".s.nc.") and name.endswith(".tmp") for name in leftovers)
    # Without an earlier file, nothing at all appears under the final name.
    fresh = tmp_path / "fresh.nc"
    writer = start_writer(fresh, 1000, kill_at_rename=True)
    writer.communicate(timeout=120)
    assert writer.returncode == -signal.SIGKILL and not fresh.exists()
    with pytest.raises(StageFileError, match=r"fresh\.nc: no such file; expected the output of the 'probe' stage"):
        open_stage_file(fresh, stage="probe")


def test_kill_in_the_middle_of_a_large_write(tmp_path):
    # 64 MB of random doubles take seconds to compress and write: kill the writer as soon as
    # its temporary file has data in it.
    path = tmp_path / "big.nc"
    writer = start_writer(path, 8_000_000, kill_at_rename=False)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and writer.poll() is None:
        if any(p.name.startswith(".big.nc.") and p.stat().st_size > 0 for p in tmp_path.iterdir()):
            break
        time.sleep(0.005)
    writer.send_signal(signal.SIGKILL)
    _, stderr = writer.communicate(timeout=60)
    assert writer.returncode == -signal.SIGKILL, f"the write finished before the kill: {stderr}"
    assert not path.exists()
    with pytest.raises(StageFileError, match="no such file"):
        open_stage_file(path, stage="probe")


# --- bad input files to the stages, through the command line ------------------------------------
TINY_CONFIG = {
    "systems": {"barbanis_2dof": {"builtin": "barbanis_2dof"}},
    "periodic_orbits": {"bottom": {"system": "barbanis_2dof", "saddle_near": [5.5, -7.07],
                                   "energies": {"excess": [0.125]}, "samples": 20}},
    "manifolds": {"tube": {"orbits": "bottom", "energy": {"excess": 0.125}, "points": 4, "time": 2, "samples": 5}},
    "poincare_sections": {"plane": {
        "system": "barbanis_2dof", "energy": {"excess": -0.125}, "time": 2,
        "initial_conditions": {"axes": [{"name": "x", "range": [-1.0, 1.0], "points": 2},
                                        {"name": "px", "range": [-1.0, 1.0], "points": 2}],
                               "fixed": {"y": 0.0}, "solve": "py"},
    }},
}


@pytest.fixture(scope="module")
def bad_inputs(tmp_path_factory):
    """One file of each kind a stage must refuse, and the configuration the commands read."""
    folder = tmp_path_factory.mktemp("inputs")
    config = folder / "config.yaml"
    config.write_text(yaml.safe_dump(TINY_CONFIG))
    good = run_equilibria(**parameters_from_config(validate_config(yaml.safe_load(config.read_text())), "equilibria",
                                                   "barbanis_2dof"), output=folder / "equilibria.nc")
    truncated = folder / "truncated.nc"
    truncated.write_bytes(good.read_bytes()[:400])
    foreign = folder / "foreign.nc"
    xr.Dataset({"energy": (("point",), np.arange(3.0))}).to_netcdf(foreign, engine="netcdf4")
    text = folder / "notes.nc"
    text.write_text("not a netCDF file\n")
    wrong = write_stage_file(small_dataset(), folder / "wrong.nc", stage="ld_grid", title="t", parameters={})
    files = {"missing": folder / "missing.nc", "truncated": truncated, "foreign": foreign, "text": text,
             "wrong stage": wrong}
    return config, files


MESSAGES = {
    "missing": "no such file; expected the output of the '{stage}' stage",
    "truncated": "not a readable netCDF file",
    "foreign": "not written by ldpipe",
    "text": "not a readable netCDF file",
    "wrong stage": "written by the 'ld_grid' stage; expected the '{stage}' stage",
}


@pytest.mark.parametrize("kind", list(MESSAGES))
@pytest.mark.parametrize("command, option, stage", [
    ("ld", "--equilibria", "equilibria"),
    ("upo", "--equilibria", "equilibria"),
    ("poincare", "--equilibria", "equilibria"),
    ("manifolds", "--upo", "upo"),
])
def test_bad_input_file_is_named_with_the_expected_stage(tmp_path, capsys, bad_inputs, command, option, stage, kind):
    config, files = bad_inputs
    bad = files[kind]
    output = tmp_path / "out.nc"
    arguments = {
        "ld": ["--system", "barbanis_2dof", "--axis", "x=4.8:6.0:3", "--axis", "px=-0.6:0.6:3", "--fixed", "y=-7.0",
               "--solve", "py", "--excess-energy", "0.125", "--tau", "1", "--quiet"],
        "upo": ["--config", str(config), "--family", "bottom"],
        "poincare": ["--config", str(config), "--section", "plane"],
        "manifolds": ["--config", str(config), "--manifold", "tube"],
    }[command]
    assert main([command, *arguments, option, str(bad), "-o", str(output)]) == 2
    error = capsys.readouterr().err
    assert str(bad) in error
    assert MESSAGES[kind].format(stage=stage) in error
    assert f"'{stage}' stage" in error
    assert not output.exists() and not list(tmp_path.glob(".out.nc.*"))


def test_gather_refuses_a_tile_that_is_not_a_tile(tmp_path, bad_inputs):
    _, files = bad_inputs
    for kind in ("wrong stage", "truncated"):
        with pytest.raises(StageFileError) as info:
            run_ld_gather(tiles=[files[kind]], output=tmp_path / "map.nc")
        assert str(files[kind]) in str(info.value) and "'ld_tile' stage" in str(info.value)
    assert not (tmp_path / "map.nc").exists()


# --- bad configuration values -----------------------------------------------------------------
def base_config():
    return {
        "systems": {"barbanis_2dof": {"builtin": "barbanis_2dof"}},
        "ld_maps": {"m": {
            "system": "barbanis_2dof",
            "section": {"axes": [{"name": "x", "range": [-1.0, 1.0], "points": 3},
                                 {"name": "px", "range": [-1.0, 1.0], "points": 3}],
                        "fixed": {"y": 0.0}, "solve": "py"},
            "energy": {"excess": -0.125},
        }},
        **copy.deepcopy({key: value for key, value in TINY_CONFIG.items() if key != "systems"}),
    }


def set_key(config, dotted, value):
    *parents, last = dotted.split(".")
    node = config
    for part in parents:
        node = node[int(part)] if isinstance(node, list) else node[part]
    node[last] = value


def test_base_config_is_valid():
    validate_config(base_config())


@pytest.mark.parametrize("key, value, words", [
    # wrong type
    ("ld_maps.m.tau", "long", ["ld_maps.m.tau", "not of type 'number'"]),
    ("ld_maps.m.section.axes.0.points", 2.5, ["ld_maps.m.section.axes.0.points", "type integer"]),
    ("periodic_orbits.bottom.samples", "many", ["periodic_orbits.bottom.samples", "type integer"]),
    # out of range, with the range in the message
    ("ld_maps.m.tau", -1.0, ["ld_maps.m.tau", "> 0", "<= 10000"]),
    ("ld_maps.m.section.axes.0.points", 1, ["ld_maps.m.section.axes.0.points", ">= 2", "<= 20000"]),
    ("ld_maps.m.integrator", {"rtol": 1e-20}, ["ld_maps.m.integrator.rtol", ">= 1e-15", "<= 0.1"]),
    ("ld_maps.m.integrator", {"scheme": "euler"}, ["ld_maps.m.integrator.scheme", "'dop853'", "'rk4'", "'sym6'"]),
    ("ld_maps.m.time", "sometimes", ["ld_maps.m.time", "'fixed'", "'variable'"]),
    ("max_grid_points", 1, ["max_grid_points", ">= 2"]),
    ("periodic_orbits.bottom.tolerance", 1.0, ["periodic_orbits.bottom.tolerance", "> 0", "<= 0.0001"]),
    ("manifolds.tube.displacement", 0.5, ["manifolds.tube.displacement", "> 0", "<= 0.01"]),
    ("poincare_sections.plane.time", 0, ["poincare_sections.plane.time", "> 0"]),
    ("poincare_sections.plane.max_crossings", 0, ["poincare_sections.plane.max_crossings", ">= 1"]),
    # unknown key
    ("ld_maps.m.colour", "red", ["ld_maps.m", "unknown keys ['colour']", "'tau'"]),
    ("manifolds.tube.epsilon", 1e-6, ["manifolds.tube", "unknown keys ['epsilon']", "'displacement'"]),
    ("poincare_sections.plane.section", {"coordinate": "w"},
     ["poincare_sections.plane.section.coordinate", "not a phase coordinate", "'px'"]),
    # a reference to an entry that does not exist
    ("manifolds.tube.orbits", "top", ["manifolds.tube.orbits", "no family 'top'", "'bottom'"]),
    ("poincare_sections.plane.system", "henon",
     ["poincare_sections.plane.system", "no system 'henon'", "'barbanis_2dof'"]),
    ("manifolds.tube.energy", {"excess": 0.5}, ["manifolds.tube.energy", "not among the energies", "'bottom'"]),
    ("figures", {"f": {"kind": "ld_slices", "ld_maps": ["nope"]}}, ["figures.f.ld_maps", "'nope'", "['m']"]),
    ("nhim", {"studies": {"s": {"maps": ["nope"]}}}, ["nhim.studies.s.maps", "no LD map 'nope'", "['m']"]),
])
def test_bad_config_value_names_the_key_and_what_is_allowed(key, value, words):
    config = base_config()  # valid as it is (test_base_config_is_valid)
    set_key(config, key, value)
    with pytest.raises(ConfigError) as info:
        validate_config(config)
    for word in words:
        assert word in str(info.value), str(info.value)


def test_bad_value_on_the_command_line_names_the_key(tmp_path, capsys):
    output = tmp_path / "x.nc"
    code = main(["ld", "--system", "barbanis_2dof", "--axis", "x=0:1:3", "--axis", "px=0:1:3", "--fixed", "y=0",
                 "--solve", "py", "--excess-energy", "0", "--tau", "-5", "--quiet", "-o", str(output)])
    assert code == 2
    error = capsys.readouterr().err
    assert "tau" in error and "> 0" in error and not output.exists()


# --- Snakemake: a job killed mid-run, then rerun -------------------------------------------------
WORKFLOW_CONFIG = {
    "systems": {"barbanis_2dof": {"builtin": "barbanis_2dof"}},
    "ld_maps": {"tiny": {
        "system": "barbanis_2dof",
        "section": {"axes": [{"name": "x", "range": [-3.0, 3.0], "points": 6},
                             {"name": "px", "range": [-3.0, 3.0], "points": 5}],
                    "fixed": {"y": 0.0}, "solve": "py"},
        "energy": {"excess": -0.125}, "tau": 2, "tiles": 2,
    }},
}
# Loaded by every Python process the test's Snakemake starts (through PYTHONPATH): it SIGKILLs
# the process that is about to rename its finished temporary file onto the named output, the
# moment a killed job could do the most harm.
KILLER = textwrap.dedent("""
    import os, signal
    _target = os.environ.get("LDPIPE_TEST_KILL_AT_RENAME")
    if _target:
        _replace = os.replace

        def _replace_or_die(source, destination, *args, **kwargs):
            if str(destination).endswith(_target):
                os.kill(os.getpid(), signal.SIGKILL)
            return _replace(source, destination, *args, **kwargs)

        os.replace = _replace_or_die
""")


@pytest.mark.slow
def test_killed_job_leaves_no_output_and_the_rerun_redoes_only_it(tmp_path, barbanis):
    copy_workflow(tmp_path)
    (tmp_path / "config.yaml").write_text(yaml.safe_dump(WORKFLOW_CONFIG))
    (tmp_path / "fault").mkdir()
    (tmp_path / "fault" / "sitecustomize.py").write_text(KILLER)
    target = "results/ld/tiny.nc"
    # The equilibria the map needs, written beforehand (one job less to start): Snakemake takes a
    # file newer than its inputs, without its own metadata, as up to date.
    config = validate_config(copy.deepcopy(WORKFLOW_CONFIG))
    run_equilibria(**parameters_from_config(config, "equilibria", "barbanis_2dof"),
                   output=tmp_path / "results/barbanis_2dof/equilibria.nc")

    def snakemake(*arguments, kill=None):
        environment = {k: v for k, v in os.environ.items() if k != "LDPIPE_TEST_KILL_AT_RENAME"}
        if kill:
            paths = [str(tmp_path / "fault"), os.environ.get("PYTHONPATH")]
            environment["PYTHONPATH"] = os.pathsep.join(filter(None, paths))
            environment["LDPIPE_TEST_KILL_AT_RENAME"] = kill
        result = run_snakemake(tmp_path, *arguments, target, env=environment)
        return result.returncode, result.stdout + result.stderr

    # 1. The second tile's job is killed; --keep-going lets the others finish.
    code, log = snakemake("--keep-going", kill="tile-1-of-2.nc")
    assert code != 0 and "died with <Signals.SIGKILL: 9>" in log, log
    tiles = tmp_path / "results/ld/tiny"
    assert not (tiles / "tile-1-of-2.nc").exists() and not (tmp_path / target).exists()
    # Every file under results/ that looks like an output is complete and from its stage.
    assert open_stage_file(tiles / "tile-0-of-2.nc", stage="ld_tile").sizes["x"] == 3
    assert open_stage_file(tmp_path / "results/barbanis_2dof/equilibria.nc", stage="equilibria")
    visible = sorted(str(p.relative_to(tmp_path)) for p in (tmp_path / "results").rglob("*.nc"))
    assert visible == ["results/barbanis_2dof/equilibria.nc", "results/ld/tiny/tile-0-of-2.nc"]

    # 2. The rerun plans only the killed tile and the gather that waited for it.
    code, log = snakemake("-n")
    assert code == 0 and job_counts(log) == {"ld_tile": 1, "ld_gather": 1}, log
    assert "output: results/ld/tiny/tile-1-of-2.nc" in log and "output: results/ld/tiny/tile-0-of-2.nc" not in log

    # 3. It runs, and the map equals one computed in this process from scratch.
    code, log = snakemake()
    assert code == 0, log
    data = open_stage_file(tmp_path / target, stage="ld_grid")
    fresh = compute_ld_map(parameters_from_config(config, "ld", "tiny"),
                           equilibrium_table(barbanis, {"x": [-20.0, 20.0], "y": [-20.0, 20.0]}), show_progress=False)
    for name in fresh.data_vars:
        np.testing.assert_array_equal(data[name].values, fresh[name].values, err_msg=name)
    assert data.allowed.values.any() and data.attrs["tiles"] == 2

    # 4. A deleted output: only its jobs are planned again (its tiles were temporary), not the
    # equilibria it was computed from.
    (tmp_path / target).unlink()
    code, log = snakemake("-n")
    assert code == 0 and job_counts(log) == {"ld_tile": 2, "ld_gather": 1}, log
