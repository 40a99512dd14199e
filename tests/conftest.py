"""Shared fixtures: the paper's systems and the harmonic oscillators, compiled once per test session,
one quick workflow run and one lint of the workflow; and the groups pytest-xdist's workers share
the tests in."""

import pytest

from ldpipe.systems import make_system
from support import xdist_groups
from support.closed_forms import oscillator_system
from support.workflow import copy_workflow, run_snakemake


@pytest.hookimpl(trylast=True)  # after -m and -k have deselected: the node ids the controller gets
def pytest_collection_modifyitems(config, items):
    xdist_groups.record_groups(config, items)


@pytest.hookimpl(optionalhook=True)  # pytest-xdist's hooks: absent with -p no:xdist
def pytest_configure_node(node):
    node.workerinput[xdist_groups.GROUPS_FOLDER] = str(xdist_groups.groups_folder(node.config))


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config, log):
    if config.getoption("dist") == "loadgroup":
        return xdist_groups.make_scheduler(config, log)
    return None


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
    return workdir, run_snakemake(workdir, "--configfile", "config.quick.yaml", timeout=1800)


@pytest.fixture(scope="session")
def lint(tmp_path_factory):
    """``snakemake --lint`` of a copy of the workflow, run once (it parses the whole workflow): the
    workflow test checks it, and the README test, whose text says the lint is clean, reads it."""
    return run_snakemake(copy_workflow(tmp_path_factory.mktemp("lint")), "--lint")
