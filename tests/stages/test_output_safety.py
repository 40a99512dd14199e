"""Nothing lost, nothing half-written: an output that cannot be written is refused before the work,
a write that fails at the end (the disk filled) leaves the previous file, and a process killed at
any moment leaves either the previous file or the complete new one."""

import importlib
import inspect
import os
import pkgutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

import ldpipe.stages
from ldpipe.cli.main import main
from ldpipe.errors import OutputError
from ldpipe.io.datafile import open_stage_file

#: `ldpipe ld` of a quick Barbanis map (the adaptive-map test's slice, smaller).
LD_ARGUMENTS = ["ld", "--system", "barbanis_2dof", "--axis", "x=4.8:6.0:9", "--axis", "px=-0.6:0.6:9",
                "--fixed", "y=-7.0", "--solve", "py", "--excess-energy", "0.125", "--tau", "2", "--quiet"]
OUTPUT_PARAMETERS = ("output", "table", "csv_output", "markdown_output", "png")


def _blocked(tmp_path) -> Path:
    """A path no one can write, root included: its parent is a file."""
    (tmp_path / "a-file").write_text("")
    return tmp_path / "a-file" / "out.nc"


def test_the_cli_refuses_an_unwritable_output_in_one_line_before_any_work(tmp_path, monkeypatch, capsys):
    def never(*args, **kwargs):
        raise AssertionError("the computation ran")

    monkeypatch.setattr("ldpipe.stages.ld.run_ld_map", never)
    monkeypatch.setattr("ldpipe.core.maps.assembly.ld_map_dataset", never)
    blocked = _blocked(tmp_path)
    assert main([*LD_ARGUMENTS, "-o", str(blocked)]) == 2
    error = capsys.readouterr().err
    assert error == f"ldpipe ld: error: {blocked}: cannot write the output there: {tmp_path / 'a-file'} is a file, " \
                    "not a folder\n"


def test_the_command_fails_fast_without_a_traceback(tmp_path):
    blocked = _blocked(tmp_path)
    result = subprocess.run([sys.executable, "-m", "ldpipe.cli", *LD_ARGUMENTS, "-o", str(blocked)], capture_output=True,
                            text=True, timeout=300, check=False)
    assert result.returncode == 2
    assert result.stderr.splitlines() == [f"ldpipe ld: error: {blocked}: cannot write the output there: "
                                          f"{tmp_path / 'a-file'} is a file, not a folder"]


def _stage_runners():
    for info in pkgutil.iter_modules(ldpipe.stages.__path__):
        module = importlib.import_module(f"ldpipe.stages.{info.name}")
        for name, function in vars(module).items():
            if name.startswith("run_") and inspect.isfunction(function) and function.__module__ == module.__name__:
                yield pytest.param(function, id=f"{info.name}.{name}")


@pytest.mark.parametrize("run", list(_stage_runners()))
def test_every_stage_checks_its_outputs_before_reading_or_computing(tmp_path, run):
    """Every stage's run_* given an output under a file fails naming it, before it looks at any
    other argument (all are None here: any work would fail otherwise)."""
    parameters = inspect.signature(run).parameters
    outputs = [name for name in OUTPUT_PARAMETERS if name in parameters]
    assert outputs, f"{run.__name__}: no output parameter among {OUTPUT_PARAMETERS}"
    blocked = _blocked(tmp_path)
    arguments = {name: None for name, p in parameters.items()
                 if p.kind is p.KEYWORD_ONLY and p.default is p.empty}
    arguments[outputs[0]] = blocked
    with pytest.raises(OutputError, match=rf"^{blocked}: cannot write the output there"):
        run(**arguments)


FILL_THE_DISK = textwrap.dedent("""
    import resource, signal, sys
    import numpy as np, xarray as xr
    from ldpipe.io.datafile import write_stage_file
    from ldpipe.errors import OutputError

    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # so a write past the limit fails with EFBIG, not the signal
    resource.setrlimit(resource.RLIMIT_FSIZE, (int(sys.argv[2]), int(sys.argv[2])))
    big = xr.Dataset({"noise": ("x", np.random.default_rng(0).random(200_000))})  # 1.6 MB, incompressible
    try:
        write_stage_file(big, sys.argv[1], stage="probe", title="new", parameters={})
    except OutputError as error:
        print(error)
        sys.exit(2)
""")


def test_a_disk_that_fills_leaves_the_previous_file_and_names_the_path(tmp_path):
    import numpy as np
    import xarray as xr

    from ldpipe.io.datafile import write_stage_file

    path = tmp_path / "out.nc"
    write_stage_file(xr.Dataset({"noise": ("x", np.arange(10.0))}), path, stage="probe", title="old", parameters={})
    before = path.read_bytes()
    scratch = tmp_path / "tmp"
    scratch.mkdir()
    result = subprocess.run([sys.executable, "-c", FILL_THE_DISK, str(path), str(200_000)], capture_output=True,
                            text=True, timeout=300, check=False, env={**os.environ, "TMPDIR": str(scratch)})
    assert result.returncode == 2, result.stderr[-3000:]
    message = result.stdout.strip()
    assert message.startswith(f"{path}: could not be written (writing: the netCDF library failed"), message
    # the fallback hits the same limit: the message says that nothing was kept
    assert f"; nothing was written (keeping the result in {scratch}" in message, message
    assert path.read_bytes() == before
    assert open_stage_file(path, stage="probe").attrs["title"] == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.nc", "tmp"]
    assert list(scratch.iterdir()) == []


def test_a_stage_file_that_cannot_be_put_in_place_is_kept_and_named(tmp_path, monkeypatch):
    import numpy as np
    import xarray as xr

    from ldpipe.io.datafile import write_stage_file

    scratch = tmp_path / "tmp"
    scratch.mkdir()
    monkeypatch.setattr("tempfile.tempdir", str(scratch))
    (tmp_path / "results").write_text("")  # the output folder became a file while the stage ran
    path = tmp_path / "results" / "out.nc"
    data = xr.Dataset({"noise": ("x", np.arange(10.0))})
    with pytest.raises(OutputError, match=r"; the result is kept in ") as raised:
        write_stage_file(data, path, stage="probe", title="kept", parameters={})
    kept = Path(str(raised.value).rsplit("; the result is kept in ", 1)[1])
    assert kept.parent == scratch
    assert open_stage_file(kept, stage="probe").attrs["title"] == "kept"


def folder_state(folder: Path) -> dict:
    """Each entry of ``folder`` with its size and modification time."""
    state = {}
    for entry in os.scandir(folder):
        try:
            status = entry.stat()
        except FileNotFoundError:  # renamed away meanwhile
            continue
        state[entry.name] = (status.st_size, status.st_mtime_ns)
    return state


@pytest.mark.slow
def test_a_map_killed_at_random_moments_leaves_the_previous_file_or_the_whole_new_one(tmp_path):
    """SIGKILL at seeded random moments of `ldpipe ld`: half of them spread over the whole run,
    half while the file is being written (a moment after anything in its folder changes). Every time the
    output is absent or a complete map equal to the reference; a clean run afterwards leaves no
    temporary and writes the reference's bits."""
    import random
    import signal
    import time

    from ldpipe.io.filediff import compare_files

    scratch = tmp_path / "scratch"  # the equilibria the command computes go to a temporary folder
    scratch.mkdir()
    environment = {**os.environ, "TMPDIR": str(scratch)}

    def command(output):
        return [sys.executable, "-m", "ldpipe.cli", *LD_ARGUMENTS, "-o", str(output)]

    reference = tmp_path / "reference.nc"
    subprocess.run(command(reference), check=True, timeout=1200, env=environment)  # compiles on an empty cache
    start = time.perf_counter()
    subprocess.run(command(tmp_path / "timing.nc"), check=True, timeout=600, env=environment)
    duration = time.perf_counter() - start
    output_folder = tmp_path / "out"
    output_folder.mkdir()
    output = output_folder / "map.nc"
    generator = random.Random(20240611)
    budget = time.perf_counter() + 30.0
    kills = torn = 0
    while kills < 20 and (kills < 6 or time.perf_counter() < budget):
        before = set(os.listdir(output_folder))
        listing = folder_state(output_folder)
        process = subprocess.Popen(command(output), env=environment, stdout=subprocess.DEVNULL,
                                   stderr=subprocess.DEVNULL)
        if kills % 2 == 0:
            time.sleep(generator.uniform(0.0, duration))
        else:  # wait for the write to begin (anything in the folder changes), then kill within it
            delay = generator.uniform(0.0, 0.01)
            while process.poll() is None and folder_state(output_folder) == listing:
                time.sleep(0.001)
            time.sleep(delay)
        process.send_signal(signal.SIGKILL)
        process.wait(timeout=60)
        kills += 1
        torn += bool(set(os.listdir(output_folder)) - before - {"map.nc"})  # killed mid-write
        if output.exists():
            open_stage_file(output, stage="ld_grid")  # complete and valid, never truncated
            assert compare_files(reference, output) == [], f"kill {kills}"
    assert torn >= 1, f"none of {kills} kills landed while the file was being written"
    completed = subprocess.run(command(output), env=environment, capture_output=True, text=True, timeout=600,
                               check=False)
    assert completed.returncode == 0, completed.stderr[-3000:]
    assert [p.name for p in output_folder.iterdir()] == ["map.nc"]  # the killed writers' temporaries removed
    same = subprocess.run([sys.executable, "-m", "ldpipe.io.filediff", str(reference), str(output)],
                          capture_output=True, text=True, timeout=300, check=False)
    assert same.returncode == 0, same.stdout
