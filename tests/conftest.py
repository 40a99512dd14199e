"""Shared fixtures: the paper's systems and the harmonic oscillators, compiled once per test session,
and one quick workflow run."""

import subprocess

import pytest

from ldpipe.systems import make_system
from support.closed_forms import oscillator_system
from support.workflow import SNAKEMAKE, copy_workflow



@pytest.fixture(scope="session")
def barbanis():
    return make_system("barbanis_2dof", {"builtin": "barbanis_2dof"})


@pytest.fixture(scope="session")
def barbanis_contopoulos():
    return make_system("barbanis_contopoulos_3dof", {"builtin": "barbanis_contopoulos_3dof"})


@pytest.fixture(scope="session")
def oscillator():
    """Two uncoupled harmonic oscillators, whose LD is a closed form (support.closed_forms)."""
    return oscillator_system()


@pytest.fixture
def workdir(tmp_path):
    """A fresh copy of the workflow files, for a test that runs or plans the workflow."""
    return copy_workflow(tmp_path / "workflow")


@pytest.fixture(scope="session")
def quick_run(tmp_path_factory):
    """The quick configuration, run once locally on two cores: ``(workdir, completed process)``.

    Every end-to-end test that needs a complete run reads this one (a run is ~60 jobs, minutes),
    and none may change its results; a test that edits the configuration writes a new file.
    """
    workdir = copy_workflow(tmp_path_factory.mktemp("quick_run"))
    result = subprocess.run(
        [SNAKEMAKE, "--configfile", "config.quick.yaml", "--cores", "2"],
        cwd=workdir, capture_output=True, text=True, timeout=1800,
    )
    return workdir, result
