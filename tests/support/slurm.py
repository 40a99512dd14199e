"""A single-node SLURM cluster started for a test session (tests/workflow/local_cluster.sh):
the workflow's SLURM test and the Dask SLURMCluster test share it as a fixture."""

import os
import shutil
import subprocess
import tempfile
from pathlib import Path

import pytest

from support.workflow import ROOT

CLUSTER_SCRIPT = ROOT / "tests" / "workflow" / "local_cluster.sh"
SLURM_DAEMONS = ("slurmctld", "slurmd", "munged")  # Debian's slurm-wlm and munge, as local_cluster.sh finds them


@pytest.fixture(scope="session")
def slurm_environment():
    """Environment variables that point SLURM clients at a local cluster started for this session.

    The cluster is stopped (its jobs cancelled, the daemons this fixture started stopped by
    their pid files) and its folder removed at the end, also when a test fails.
    """
    missing = [daemon for daemon in SLURM_DAEMONS if shutil.which(daemon) is None]
    if missing:
        pytest.skip(f"SLURM is not installed (no {', '.join(missing)}; .ci/run installs Debian's slurm-wlm and munge)")
    if os.geteuid() != 0:
        pytest.skip("the local SLURM cluster needs root (SlurmUser=root, munged as the munge user)")
    # The cluster's folder must be reachable by the munge user, which pytest's tmp_path is not.
    state = Path(tempfile.mkdtemp(prefix="ldpipe-slurm-"))
    try:
        try:
            started = subprocess.run(
                ["bash", str(CLUSTER_SCRIPT), "start", str(state)], capture_output=True, text=True, timeout=120
            )
        except subprocess.TimeoutExpired:
            pytest.fail("SLURM is installed but did not start within 120 s")
        if started.returncode != 0:
            pytest.fail(f"SLURM is installed but could not be started: {started.stderr.strip()}")
        yield {
            **os.environ,
            "SLURM_CONF": str(state / "slurm.conf"),
            "PATH": f"{state / 'bin'}{os.pathsep}{os.environ.get('PATH', '')}",
        }
    finally:
        subprocess.run(["bash", str(CLUSTER_SCRIPT), "stop", str(state)], capture_output=True, timeout=120)
        shutil.rmtree(state, ignore_errors=True)
