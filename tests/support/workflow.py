"""The repository as a clone holds it, and how tests run its commands: the venv's ``snakemake``
(on a copy of the workflow's files) and ``ldpipe``, and what they print."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]  # the repository
BIN = Path(sys.executable).parent  # the venv's commands, beside its python
SNAKEMAKE = str(BIN / "snakemake")
LDPIPE = str(BIN / "ldpipe")
# Two cores on any machine: the quick run is the reference the SLURM test compares its one-thread
# cluster jobs with, so its multi-threaded stages must really run on more than one thread.
CORES = 2

BUILT = {"_build", "gallery", "generated"}  # what building the docs writes into docs/
BUILD_DOCS = ".venv/bin/sphinx-build -W docs docs/_build/html"  # the development page's command
#: The pytest-xdist group of every test that reads conftest's ``quick_run`` or ``lint``: session
#: fixtures run once per worker, and these two run Snakemake for minutes, so their readers share one.
SNAKEMAKE_RUNS_GROUP = "quick_run"


def _documentation() -> dict[str, str]:
    """What a user reads, by path from the root: the README and every Markdown page of docs/."""
    pages = [p for p in sorted((ROOT / "docs").rglob("*.md")) if not BUILT & set(p.relative_to(ROOT).parts)]
    return {str(p.relative_to(ROOT)): p.read_text() for p in [ROOT / "README.md", *pages]}


DOCUMENTATION = _documentation()
README = DOCUMENTATION["README.md"]


def copy_workflow(folder: Path) -> Path:
    """What a clone holds for the workflow, copied to ``folder`` (code comes from the installed ldpipe)."""
    folder.mkdir(parents=True, exist_ok=True)
    for name in ("Snakefile", "config.yaml", "config.quick.yaml"):
        shutil.copy(ROOT / name, folder / name)
    for name in ("workflow", "profiles"):
        shutil.copytree(ROOT / name, folder / name)
    return folder


def run_snakemake(workdir: Path, *arguments: str, env: dict | None = None,
                  timeout: float = 600) -> subprocess.CompletedProcess:
    """``snakemake --cores 2 ARGUMENTS`` by the venv's Snakemake in ``workdir``, its output captured
    as text. Targets go before ``--configfile``, which takes every word after it as a file."""
    return subprocess.run([SNAKEMAKE, "--cores", str(CORES), *arguments], cwd=workdir, env=env,
                          capture_output=True, text=True, timeout=timeout)


def job_counts(output: str) -> dict[str, int]:
    """The first "Job stats" table Snakemake prints (before a run, or of a dry run): rule -> jobs."""
    table = output.split("Job stats:", 1)[1].split("\n\n", 1)[0]
    rows = re.finditer(r"^(\w+)\s+(\d+)\s*$", table, flags=re.M)
    return {m.group(1): int(m.group(2)) for m in rows if m.group(1) != "total"}


def documented_yaml(marker: str) -> str:
    """The one ```yaml block of the README and the documentation pages that contains ``marker``."""
    blocks = [b for text in DOCUMENTATION.values()
              for b in re.findall(r"^```yaml\n(.*?)^```", text, flags=re.S | re.M) if marker in b]
    assert len(blocks) == 1, f"expected one yaml block with {marker!r} in README.md and docs/"
    return blocks[0]
