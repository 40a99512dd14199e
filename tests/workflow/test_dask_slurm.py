"""A map in blocks on dask-jobqueue's SLURMCluster: its workers are jobs of a real SLURM cluster.

The single-node cluster the workflow's SLURM test starts (tests/support/slurm.py) runs two
Dask workers as sbatch jobs; the map computed on them must equal the one-process map bit for
bit, data, flags and attributes (every trajectory is integrated on its own, so where a block
runs cannot change it). The system and settings are those tests/test_api.py compiles
(Hénon–Heiles, DOP853 at rtol 1e-8), so the jobs load the engine from the cache.
"""

import copy
import os
import sys
from pathlib import Path

import pytest

import ldpipe
from support.henon_heiles import HENON_HEILES
from support.slurm import slurm_environment  # noqa: F401 (a fixture)
from support.stage_files import assert_same_file

distributed = pytest.importorskip("distributed")
jobqueue = pytest.importorskip("dask_jobqueue")

pytestmark = pytest.mark.slow

HH_MAP = {"section": {"axes": [{"name": "y", "range": [-0.45, 0.8], "points": 40},
                               {"name": "py", "range": [-0.5, 0.5], "points": 40}],
                      "fixed": {"px": 0.0}, "solve": "x", "root": "largest"},
          "energy": 0.125, "tau": 2.0, "integrator": {"scheme": "dop853", "rtol": 1e-8, "atol": 1e-8}}


def test_a_map_on_slurm_jobs_equals_the_one_process_map(slurm_environment, monkeypatch, tmp_path):
    for name in ("SLURM_CONF", "PATH"):  # sbatch, squeue and scancel of the test cluster
        monkeypatch.setenv(name, slurm_environment[name])
    hh = ldpipe.system(name="henon_heiles", **HENON_HEILES)
    eager = ldpipe.ld_map(hh, name="hh", **copy.deepcopy(HH_MAP))
    source = Path(ldpipe.__file__).resolve().parents[1]  # the jobs import this ldpipe
    with jobqueue.SLURMCluster(cores=1, processes=1, memory="1500MB", walltime="00:10:00", python=sys.executable,
                               job_script_prologue=[f"export PYTHONPATH={source}"], log_directory=str(tmp_path),
                               scheduler_options={"dashboard_address": ":0"}) as cluster:
        cluster.scale(jobs=2)
        with distributed.Client(cluster) as client:
            client.wait_for_workers(2, timeout=180)
            jobs = client.run(lambda: os.environ.get("SLURM_JOB_ID"))
            assert len(jobs) == 2 and all(jobs.values()), jobs  # every worker is a SLURM job
            lazy = ldpipe.ld_map(hh, name="hh", chunks=300, client=client, **copy.deepcopy(HH_MAP))
            assert_same_file(lazy.compute(), eager)
