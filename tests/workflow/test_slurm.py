"""The workflow on a real SLURM cluster.

A single-node cluster (munged, slurmctld and slurmd on this machine, accounting off; started by
tests/workflow/local_cluster.sh) runs stages of the quick configuration through
`snakemake --executor slurm`, each job an sbatch submission, and every stage file it writes must
equal what the session's local run of the same configuration (conftest's ``quick_run``) wrote.
The reference is an independent execution: a local run on two threads a job, against cluster
jobs on one core each (the cluster run is limited to one thread a job), so the comparison also
shows that no number depends on the thread count or on the process that computed it. Left out:
the figures (drawings of these files) and the accuracy-cost stage, whose numbers are wall times. The test skips,
saying why, only where SLURM is not installed or the test does not run as root (.ci/run installs it, as root);
where it is installed, a cluster that does not come up is a failure.
"""

import os
import re
import subprocess
from pathlib import Path

import pytest

from ldpipe.io.filediff import compare_files
from support.slurm import slurm_environment  # noqa: F401 (a fixture)
from support.workflow import SNAKEMAKE, job_counts

pytestmark = pytest.mark.slow

# What cannot be equal between two runs (the history attribute, measured wall times) is left out
# by ldpipe.io.filediff, which compares the stored values bit for bit.

# What the test cluster needs on top of profiles/slurm: no accounting, so no account and squeue
# for the job status; its jobs are seconds long, so the first status check after 2 s instead of
# 40 s and a short wait for files; one thread a job; no retry.
CLUSTER_OPTIONS = (
    "--slurm-no-account",
    "--slurm-status-command", "squeue",
    "--slurm-init-seconds-before-status-checks", "2",
    "--latency-wait", "5",
    "--max-threads", "1",
    "--retries", "0",  # a failure shows at once instead of being retried
    "--seconds-between-status-checks", "1",  # jobs take seconds; the default polls every 10 s
    "--jobs", "8",  # the node runs two at once; SLURM starts the queued ones as soon as one ends
)


def snakemake(workdir: Path, *arguments: str, env: dict | None = None) -> subprocess.Popen:
    """A snakemake run in ``workdir``, started; its output goes to ``workdir/snakemake.log``."""
    with open(workdir / "snakemake.log", "w") as log:  # the child keeps its own descriptor
        return subprocess.Popen([SNAKEMAKE, *arguments], cwd=workdir, stdout=log, stderr=subprocess.STDOUT, env=env)


def finish(run: subprocess.Popen, workdir: Path) -> str:
    """Wait for a run started by :func:`snakemake`; it must succeed. Its output."""
    try:
        run.wait(timeout=1800)
    finally:
        if run.poll() is None:
            run.terminate()  # snakemake cancels its SLURM jobs when it stops
            try:
                run.wait(timeout=60)
            except subprocess.TimeoutExpired:
                run.kill()  # the fixture's teardown cancels what is left on the cluster
                run.wait()
    output = (workdir / "snakemake.log").read_text()
    assert run.returncode == 0, output[-5000:]
    return output


def test_quick_configuration_on_slurm_equals_a_local_run(slurm_environment, quick_run, workdir):
    local, local_result = quick_run
    assert local_result.returncode == 0, local_result.stderr[-5000:]
    # Each cluster job costs ~9 s of submission, two Snakemake starts and status polling on two
    # cores, so by default the cluster runs the chains of the quick configuration that have
    # every kind of job: equilibria, a Fig. 3 map's LD tiles as separate multi-threaded jobs and
    # their gather, Fig. 4's maps of one tile (one job each), a periodic-orbit family and the NHIM
    # study of Fig. 4 (9 jobs). LDPIPE_SLURM_TEST=full runs
    # every stage file instead (~40 jobs, minutes), leaving out the accuracy-cost stage,
    # whose numbers are wall times, and the figures, which are drawings of these files.
    if os.environ.get("LDPIPE_SLURM_TEST") == "full":
        stage_files = sorted(
            path.relative_to(local) for path in (local / "results").rglob("*.nc") if path.parts[-2] != "accuracy"
        )
    else:
        stage_files = [Path("results/nhim/fig4.nc"), Path("results/ld/fig3_dE0.125.nc")]
    run = snakemake(
        workdir,
        "--workflow-profile", "profiles/slurm",
        "--configfile", "config.quick.yaml",
        *CLUSTER_OPTIONS,
        *map(str, stage_files),
        env=slurm_environment,
    )
    output = finish(run, workdir)

    # Every job went through sbatch but those of local rules, which Snakemake's log announces
    # as "localrule".
    jobs = job_counts(output)
    assert jobs.get("ld_tile", 0) > 1, jobs  # LD tiles are separate cluster jobs
    assert jobs.get("ld_map", 0) > 0 and jobs.get("ld_gather", 0) > 0, jobs
    local_jobs = len(re.findall(r"^localrule \w+:$", output, flags=re.M))
    submitted = output.count("has been submitted with SLURM jobid")
    assert submitted == sum(jobs.values()) - local_jobs > 0, output[-5000:]

    computed = sorted(path.relative_to(workdir) for path in (workdir / "results").rglob("*.nc"))
    assert any(path.parts[1] == "ld" for path in computed), computed
    for path in computed:
        differences = compare_files(local / path, workdir / path)
        assert not differences, f"{path}: " + "; ".join(map(str, differences))


def test_slurm_profile_gives_every_job_threads_memory_and_a_time_limit(workdir):
    """The paper configuration planned with profiles/slurm (a dry run, no cluster needed): every
    job states the memory and time limit sbatch is given, and fits the profile's per-job cap."""
    run = snakemake(workdir, "--workflow-profile", "profiles/slurm", "-n")
    output = finish(run, workdir)
    jobs = re.findall(r"\n(?:local)?rule (\w+):\n(.*?)\n(?:Shell command|\n)", output, flags=re.S)
    assert len(jobs) == sum(job_counts(output).values())
    for rule, block in jobs:
        if rule == "all":
            continue
        threads = re.search(r"threads: (\d+)", block)
        resources = dict(re.findall(r"(\w+)=([^,\s]+)", block.split("resources:")[-1]))
        assert 1 <= (int(threads.group(1)) if threads else 1) <= 32, (rule, block)  # max-threads
        # The smallest job (equilibria) peaks at 271 MB (results/benchmarks): less would be killed
        # where SLURM enforces memory.
        assert int(resources["mem_mb"]) >= 300 and int(resources["runtime"]) >= 1, (rule, resources)
