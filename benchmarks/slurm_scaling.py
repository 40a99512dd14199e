"""Wall time of the LD stage on a local SLURM cluster against the number of tiles and of jobs.

One LD map of the configuration (default: Fig. 3's fixed-time map at ΔE = 0.125, τ = 50, on a
``--points`` x ``--points`` grid) is computed by ``snakemake --workflow-profile profiles/slurm``
on a single-node cluster started by ``tests/workflow/local_cluster.sh`` (this machine's cores and
memory), for every number of tiles in ``--tiles`` and of concurrent SLURM jobs in ``--jobs``,
each tile a one-core job; and, as the baseline, by a plain local ``snakemake --cores N`` (tiles
on every core). The timed run is the target ``results/ld/MAP.nc`` only: tiles and gather (one tile: one job), with
the system's equilibria computed beforehand. Reported per run: the wall time of the snakemake
command, the CPU seconds of the tile jobs (Snakemake's benchmark files: the work, which tiling
does not change much), and ``uptime``'s load averages just before the run, since the machine may
be shared. ``--repeat`` runs each setting several times; every run is kept.

Needs root and Debian's slurm-wlm and munge (as tests/workflow/test_slurm.py). Run from the repository:

    .venv/bin/python benchmarks/slurm_scaling.py                      # 600 x 600, tiles 1 2 4 8, jobs 1 2
    .venv/bin/python benchmarks/slurm_scaling.py --points 300 --tiles 1 4 --jobs 2 --repeat 2

Writes a Markdown table to stdout and every run to ``benchmarks/results/slurm_scaling_<time>.json``.
"""

from __future__ import annotations

import argparse
import csv
import datetime as dt
import json
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
SNAKEMAKE = str(Path(sys.executable).with_name("snakemake"))
CLUSTER_SCRIPT = ROOT / "tests" / "workflow" / "local_cluster.sh"
# As tests/workflow/test_slurm.py: no accounting on the local cluster, short polls for short jobs.
CLUSTER_OPTIONS = [
    "--slurm-no-account",
    "--slurm-status-command", "squeue",
    "--slurm-init-seconds-before-status-checks", "2",
    "--latency-wait", "5",
    "--max-threads", "1",
]


def load_average() -> str:
    return " ".join(f"{value:.2f}" for value in os.getloadavg())


def workflow_copy(folder: Path, map_name: str, points: int, tiles: int) -> Path:
    """The workflow files in ``folder``, with one map's grid and tile count overridden."""
    folder.mkdir(parents=True)
    for name in ("Snakefile", "config.yaml"):
        shutil.copy(ROOT / name, folder / name)
    for name in ("workflow", "profiles"):
        shutil.copytree(ROOT / name, folder / name)
    override = {"max_grid_points": points, "ld_maps": {map_name: {"tiles": tiles}}}
    (folder / "benchmark.yaml").write_text(json.dumps(override))  # JSON is YAML
    return folder


def run(arguments: list[str], workdir: Path, env: dict | None = None) -> float:
    """Wall seconds of one snakemake command, which must succeed."""
    start = time.perf_counter()
    result = subprocess.run([SNAKEMAKE, *arguments], cwd=workdir, env=env, capture_output=True, text=True)
    seconds = time.perf_counter() - start
    if result.returncode != 0:
        raise RuntimeError(f"snakemake {' '.join(arguments)} failed in {workdir}:\n{result.stderr[-4000:]}")
    return seconds


def tile_cpu_seconds(workdir: Path, map_name: str) -> float:
    """CPU seconds of the map's tile jobs (of a map of one tile, its one job ``map``), from
    Snakemake's benchmark files (column cpu_time)."""
    total = 0.0
    folder = workdir / "results" / "benchmarks" / "ld" / map_name
    for path in sorted([*folder.glob("tile-*.tsv"), *folder.glob("map.tsv")]):
        with path.open() as handle:
            rows = list(csv.DictReader(handle, delimiter="\t"))
        total += float(rows[-1]["cpu_time"])
    return total


def measure(args: argparse.Namespace, scratch: Path, slurm_env: dict) -> list[dict]:
    target = f"results/ld/{args.map}.nc"
    with open(ROOT / "config.yaml") as handle:
        system = yaml.safe_load(handle)["ld_maps"][args.map]["system"]
    rows = []
    for tiles in args.tiles:
        # Equilibria once per tile count, outside the timed runs; each timed run starts from a
        # copy of this folder (Snakemake's metadata included, so only the LD jobs run).
        base = workflow_copy(scratch / f"base-{tiles}", args.map, args.points, tiles)
        run(["--configfile", "benchmark.yaml", "--cores", "1", f"results/{system}/equilibria.nc"], base)
        settings = [("local", args.local_cores)] + [("slurm", jobs) for jobs in args.jobs]
        for repeat in range(args.repeat):
            for executor, jobs in settings:
                workdir = scratch / f"{executor}-{tiles}-{jobs}-{repeat}"
                shutil.copytree(base, workdir, symlinks=True)
                load = load_average()
                if executor == "local":
                    seconds = run(["--configfile", "benchmark.yaml", "--cores", str(jobs), target], workdir)
                else:
                    command = [
                        "--workflow-profile", "profiles/slurm", "--configfile", "benchmark.yaml",
                        *CLUSTER_OPTIONS, "--jobs", str(jobs), target,
                    ]
                    seconds = run(command, workdir, env=slurm_env)
                row = {
                    "executor": executor,
                    "tiles": tiles,
                    "jobs": jobs,
                    "repeat": repeat,
                    "wall_seconds": round(seconds, 2),
                    "tile_cpu_seconds": round(tile_cpu_seconds(workdir, args.map), 2),
                    "load_before": load,
                }
                rows.append(row)
                print(f"  {row}", file=sys.stderr, flush=True)
                shutil.rmtree(workdir)
    return rows


def markdown(rows: list[dict], args: argparse.Namespace) -> str:
    lines = [
        f"LD map {args.map}, {args.points} x {args.points} points; wall time of `snakemake {args.map}.nc` "
        "(tiles and gather)",
        "",
        "| executor | tiles | concurrent jobs (local: cores) | wall s | tile CPU s | load before (1, 5, 15 min) |",
        "| --- | ---: | ---: | ---: | ---: | --- |",
    ]
    for row in rows:
        lines.append(
            f"| {row['executor']} | {row['tiles']} | {row['jobs']} | {row['wall_seconds']:.1f} "
            f"| {row['tile_cpu_seconds']:.1f} | {row['load_before']} |"
        )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--map", default="fig3_dE0.125", help="an LD map of config.yaml")
    parser.add_argument("--points", type=int, default=600, help="grid points per axis (max_grid_points)")
    parser.add_argument("--tiles", type=int, nargs="+", default=[1, 2, 4, 8])
    parser.add_argument("--jobs", type=int, nargs="+", default=[1, 2], help="concurrent SLURM jobs")
    parser.add_argument("--local-cores", type=int, default=os.cpu_count(), help="cores of the local baseline")
    parser.add_argument("--repeat", type=int, default=1)
    parser.add_argument("--output", type=Path, default=ROOT / "benchmarks" / "results")
    args = parser.parse_args()

    scratch = Path(tempfile.mkdtemp(prefix="ldpipe-slurm-scaling-"))
    cluster = Path(tempfile.mkdtemp(prefix="ldpipe-slurm-"))
    try:
        started = subprocess.run(["bash", str(CLUSTER_SCRIPT), "start", str(cluster)], capture_output=True, text=True)
        if started.returncode != 0:
            sys.exit(f"could not start the local SLURM cluster:\n{started.stderr}")
        slurm_env = {
            **os.environ,
            "SLURM_CONF": str(cluster / "slurm.conf"),
            "PATH": f"{cluster / 'bin'}{os.pathsep}{os.environ.get('PATH', '')}",
        }
        rows = measure(args, scratch, slurm_env)
    finally:
        subprocess.run(["bash", str(CLUSTER_SCRIPT), "stop", str(cluster)], capture_output=True)
        shutil.rmtree(cluster, ignore_errors=True)
        shutil.rmtree(scratch, ignore_errors=True)

    table = markdown(rows, args)
    print(table)
    args.output.mkdir(parents=True, exist_ok=True)
    stamp = dt.datetime.now(dt.timezone.utc).strftime("%Y%m%dT%H%M%SZ")
    record = {
        "arguments": {k: (str(v) if isinstance(v, Path) else v) for k, v in vars(args).items()},
        "machine": {"cpus": os.cpu_count(), "platform": platform.platform(), "python": platform.python_version()},
        "rows": rows,
    }
    (args.output / f"slurm_scaling_{stamp}.json").write_text(json.dumps(record, indent=2))


if __name__ == "__main__":
    main()
