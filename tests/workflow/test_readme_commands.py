"""Every shell command of the ```bash blocks of README.md and of the documentation pages (docs/)
works as written.

The commands are read from the pages themselves, so a newly documented command is picked up, and
each is classified by :func:`plan`:

- run verbatim, in a fresh copy of the workflow (``ldpipe equilibria ...``, ``snakemake ... -n``,
  ``python -m ldpipe.engine.codegen --dump ...``); the quick run is the session's one quick run
  (conftest's ``quick_run``, the same command), which must have succeeded;
- run with less work, saying how: the Fig. 4 map commands at 48 × 48 instead of 1500 × 1500 (the
  map from ``--config`` through the configuration's own cap ``max_grid_points: 48``, the map from
  options with its ``:1500`` point counts replaced), and the workflow runs (``snakemake``,
  ``snakemake fig4``, the parameter study at full resolution) as dry runs with ``-n``; the quick
  parameter study really runs, in a copy of the quick run's results; the benchmark comparison on a
  12 × 12 grid, a few reference points and one round instead of 300 × 300 and three; the fuzz
  command with 20 examples of each family instead of 10^4;
- covered by another test or by CI: the install-and-test command is what ``.ci/run`` runs (checked
  here, verbatim), and so is the docs extra's install (the test extra includes it, checked here);
  the docs build is run verbatim by tests/docs/test_docs.py (in a copy of docs/); the fast subset of
  the tests is a part of CI's run; the report command is built and opened in a browser by
  tests/workflow/test_report.py, and the SLURM command is run on a real local cluster by
  tests/workflow/test_slurm.py.

A command that matches none of these fails, so a new documented command gets handled here.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from ldpipe.io.datafile import open_stage_file

from support.workflow import (BIN, BUILD_DOCS, DOCUMENTATION, ROOT, SNAKEMAKE_RUNS_GROUP, copy_workflow, documented_yaml,
                              run_snakemake)


def bash_commands(text: str) -> list[str]:
    """The commands of the ```bash blocks: continuation lines joined, comments dropped."""
    commands = []
    for block in re.findall(r"^```bash\n(.*?)^```", text, flags=re.S | re.M):
        for command in block.replace("\\\n", " ").splitlines():
            command = re.sub(r"\s+#.*$", "", command).strip()
            if command and not command.startswith("#"):
                commands.append(" ".join(command.split()))
    return commands


INSTALL_AND_SNAKEMAKE = "python3 -m venv .venv && .venv/bin/pip install -e . && .venv/bin/snakemake"
INSTALL_AND_TEST = "python3 -m venv .venv && .venv/bin/pip install -e '.[test]' && .venv/bin/pytest"
INSTALL_DOCS = ".venv/bin/pip install -e '.[docs]'"
INSTALL_DASK = ".venv/bin/pip install -e '.[dask]'"


def plan(command: str) -> tuple[str, str, str]:
    """``(how, shell command to run or '', why)`` for one documented command; ``how`` is 'run',
    'quick run' (the session's quick run) or 'covered'."""
    if command == INSTALL_AND_TEST:
        return "covered", "", "CI's command: .ci/run runs it verbatim (checked below)"
    if command == INSTALL_DOCS:
        return "covered", "", "CI's install of the test extra includes the docs extra (checked below)"
    if command == INSTALL_DASK:
        return "covered", "", "CI's install of the test extra includes the dask extra (checked below)"
    if command == ".venv/bin/ruff check .":
        return "covered", "", "tests/test_lint.py runs ruff check on the checkout with the project's settings"
    if command == BUILD_DOCS:
        return "covered", "", "tests/docs/test_docs.py runs it verbatim in a copy of docs/"
    if command in ('pytest -m "not slow"', '.venv/bin/pytest -m "not slow"', ".venv/bin/pytest"):
        return "covered", "", "CI's pytest run, or the part of it without the end-to-end runs"
    if re.fullmatch(r'\.venv/bin/pytest -m "not slow and not compiles"( tests\S*)+', command):
        # what the fast subset runs is CI's too; collecting it checks the marker expression and the folders
        return "run", command + " --collect-only -q", "collected (its tests run in CI's pytest)"
    if re.fullmatch(r"python -m ldpipe\.data\.example \S+\.nc", command):
        return "run", command, "verbatim"
    if command == "snakemake --configfile config.quick.yaml":
        return "quick run", "", "conftest's quick_run runs this command once per session"
    if re.fullmatch(r"python -m ldpipe\.engine\.codegen --dump \w+ \w+", command):
        return "run", command, "verbatim"
    if re.fullmatch(r"\.venv/bin/python benchmarks/compare\.py --n 300 --repeat 3 .*", command):
        smaller = command.replace("--n 300 --repeat 3", "--n 12 --n-per-traj 2 --n-ref 3 --n-ref-accuracy 1 --repeat 1")
        # one Taylor arc-length rtol, not five: each rtol picks an order, a module of ~80 CPU s to compile
        return ("run", smaller + " --taylor-arclength-rtols 1e-10 --out results/compare",
                "12 × 12 grid, 3 reference points, one round, one Taylor arc-length rtol")
    if re.fullmatch(r"\.venv/bin/python benchmarks/fuzz_inputs\.py( --examples \d+)?", command):
        return "run", ".venv/bin/python benchmarks/fuzz_inputs.py --examples 20", "20 examples of each family"
    if command == INSTALL_AND_SNAKEMAKE:
        # The install is CI's (the test extras include the main install); the run is planned.
        return "run", ".venv/bin/snakemake -n", "install as CI; the full run as a dry run (-n)"
    if re.fullmatch(r"ldpipe equilibria .*", command):
        return "run", command, "verbatim"
    if re.fullmatch(r"ldpipe ld --config config\.yaml --map \S+ -o \S+", command):
        return "run", command, "verbatim, with max_grid_points: 48 in config.yaml (48 × 48, not 1500 × 1500)"
    if re.fullmatch(r"ldpipe ld --system .*", command):
        return "run", command.replace(":1500 ", ":48 "), "grid reduced from 1500 × 1500 to 48 × 48"
    if re.fullmatch(r"snakemake( \S+)* -n", command):
        return "run", command, "verbatim (a dry run)"
    if re.fullmatch(r"snakemake --report \S+\.html", command):
        return "covered", "", "tests/workflow/test_report.py builds the report of the quick run and opens it in Chromium"
    if re.fullmatch(r"snakemake study --configfile config\.quick\.yaml study\.yaml", command):
        return "run", command, "verbatim, in a copy of the quick run (its family and saddle exist)"
    if re.fullmatch(r"snakemake( -c\d+)? [\w-]+( --configfile [\w.]+)?", command):
        return "run", command + " -n", "as a dry run (-n): it computes at the paper's resolution"
    if re.fullmatch(r"(\.venv/bin/)?snakemake --workflow-profile profiles/slurm .*", command):
        return "covered", "", "tests/workflow/test_slurm.py runs this profile on a real local SLURM cluster"
    return "unknown", "", "no rule for this command: classify it in tests/workflow/test_readme_commands.py"


# each command once, with the first page that shows it
COMMANDS = {command: page for page, text in reversed(DOCUMENTATION.items()) for command in bash_commands(text)}
# the `snakemake ...` spans of the pages' running text
INLINE = sorted({span for text in DOCUMENTATION.values() for span in re.findall(r"`(snakemake [^`]*)`", text.replace("\n", " "))})


def test_the_documentation_shows_commands():
    # The blocks this test was written against; a command that is no longer there is simply not run.
    assert len(COMMANDS) >= 10
    readme = bash_commands(DOCUMENTATION["README.md"])
    assert INSTALL_AND_SNAKEMAKE in readme and INSTALL_AND_TEST in readme


def test_ci_runs_the_readme_test_command_verbatim():
    assert INSTALL_AND_TEST in (ROOT / ".ci/run").read_text()


def test_ci_installs_what_the_docs_build_needs():
    extras = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["optional-dependencies"]
    assert "ldpipe[docs]" in extras["test"]
    assert {"sphinx", "myst-parser", "furo", "sphinx-gallery"} <= {re.split(r"[<>=\[]", d)[0] for d in extras["docs"]}


def test_ci_installs_what_the_dask_guide_installs():
    extras = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["optional-dependencies"]
    assert "ldpipe[dask]" in extras["test"]
    assert {"dask", "distributed", "dask-jobqueue"} <= {re.split(r"[<>=\[]", d)[0] for d in extras["dask"]}


def test_inline_snakemake_commands_put_targets_before_configfile():
    """Snakemake 9's --configfile takes every following word: a target after it is read as a file."""
    for span in INLINE:
        words = span.split()
        if "--configfile" in words:
            files = []
            for word in words[words.index("--configfile") + 1:]:
                if word.startswith("-"):
                    break
                files.append(word)
            assert files and all(w.endswith((".yaml", ".yml")) for w in files), span


@pytest.fixture(scope="module")
def readme_workdir(tmp_path_factory):
    """A copy of the workflow as a clone has it, ``.venv`` the running environment, ``study.yaml``
    the documented one, the benchmarks, and a config.yaml capped at 48 × 48 grids for the map
    commands."""
    workdir = copy_workflow(tmp_path_factory.mktemp("readme"))
    (workdir / ".venv").symlink_to(Path(sys.prefix))
    shutil.copytree(ROOT / "benchmarks", workdir / "benchmarks", ignore=shutil.ignore_patterns("results"))
    (workdir / "study.yaml").write_text(documented_yaml("study_dE0.125"))
    return workdir


def _environment() -> dict:
    return {**os.environ, "PATH": f"{BIN}{os.pathsep}{os.environ['PATH']}"}


def _reads_quick_run(command: str) -> bool:
    how, shell, _ = plan(command)
    return how == "quick run" or shell.startswith("snakemake study --configfile config.quick.yaml")


@pytest.mark.slow
@pytest.mark.parametrize("command", [
    pytest.param(command, marks=pytest.mark.xdist_group(SNAKEMAKE_RUNS_GROUP)) if _reads_quick_run(command) else command
    for command in COMMANDS])
def test_documented_command(command, readme_workdir, request):
    how, shell, why = plan(command)
    assert how != "unknown", f"{COMMANDS[command]}: command {command!r}: {why}"
    if how == "covered":
        pytest.skip(f"covered elsewhere: {why}")
    if how == "quick run":
        _, result = request.getfixturevalue("quick_run")
        assert result.returncode == 0, result.stderr[-3000:]
        return
    workdir = readme_workdir
    if shell.startswith(".venv/bin/pytest"):  # the suite's own selection, collected where the tests are
        workdir = ROOT
    if shell.startswith("ldpipe ld --config"):
        workdir = readme_workdir / "capped"
        if not workdir.exists():
            workdir.mkdir()
            text = (readme_workdir / "config.yaml").read_text()
            (workdir / "config.yaml").write_text(text + "\nmax_grid_points: 48\n")
    if shell.startswith("snakemake study --configfile config.quick.yaml"):
        quick_dir, result = request.getfixturevalue("quick_run")
        assert result.returncode == 0, result.stderr[-3000:]
        # beside the quick run's folder: the rules' code inputs are relative paths to the installed
        # ldpipe, which must stay the same for the existing stage files to count as done
        workdir = request.getfixturevalue("tmp_path_factory").mktemp("readme_study")
        assert workdir.parent == quick_dir.parent
        shutil.copytree(quick_dir, workdir, symlinks=True, dirs_exist_ok=True)
        (workdir / "study.yaml").write_text(documented_yaml("study_dE0.125"))
    result = subprocess.run(["bash", "-c", shell], cwd=workdir, env=_environment(), capture_output=True, text=True,
                            timeout=1200)
    assert result.returncode == 0, f"{command!r} ({why}) failed:\n{result.stdout[-3000:]}\n{result.stderr[-3000:]}"
    output = re.search(r" -o (\S+)$", shell)
    if output:  # the file it writes is a finished stage file
        stage = "equilibria" if shell.startswith("ldpipe equilibria") else "ld_grid"
        dataset = open_stage_file(workdir / output.group(1), stage=stage)
        if stage == "ld_grid":
            assert dataset.ld_forward.shape == (48, 48)  # the reduced grid
    if shell.startswith("snakemake study --configfile config.quick.yaml"):
        assert (workdir / "results/figures/study.png").stat().st_size > 0
        for name in ("study_dE0.125", "study_dE0.375", "study_dE0.625"):
            assert open_stage_file(workdir / f"results/ld/{name}.nc", stage="ld_grid").ld_forward.shape == (48, 48)
        ran = set(re.findall(r"localrule (\w+):|rule (\w+):", result.stderr + result.stdout))
        rules = {a or b for a, b in ran}
        # "nothing else": the family and the saddle come from the existing stage files
        assert rules <= {"ld_tile", "ld_gather", "ld_map", "study"}, rules
    if "benchmarks/compare.py" in shell:  # its tables, with the rows asked for
        report = next((workdir / "results/compare").glob("compare_*.md")).read_text()
        assert "dop853" in report and "taylor" in report and "flattened" in report
        # the one Taylor arc-length rtol asked for, and no other (each would be a compile of its own)
        assert "| engine taylor | rtol 1e-10 | arclength |" in report, report
        assert "| engine taylor | rtol 1e-08 | arclength |" not in report, report


@pytest.mark.slow
def test_inline_snakemake_targets_are_planned_and_the_lint_is_clean(readme_workdir, lint):
    """Commands the pages' text names in passing: `snakemake fig3`, `snakemake accuracy_figure`, ...
    (dry runs, one plan for all), and `snakemake --lint`, which the workflow page says is clean
    (the session's one lint run, conftest's ``lint``)."""
    spans = set(INLINE)
    targets = sorted(span.split()[1] for span in spans if re.fullmatch(r"snakemake [\w/.]+", span))
    assert "fig3" in targets and "accuracy_figure" in targets
    planned = run_snakemake(readme_workdir, *targets, "-n")
    assert planned.returncode == 0, planned.stderr[-3000:]
    if "snakemake --lint" in spans:
        assert lint.returncode == 0 and "Congratulations, your workflow is in a good condition!" in lint.stdout + lint.stderr, (
            lint.stdout[-3000:] + lint.stderr[-3000:])
