"""The workflow's files as a clone holds them, copied for tests that run or plan Snakemake."""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]  # the repository
SNAKEMAKE = str(Path(sys.executable).with_name("snakemake"))  # the venv's, beside its python


def copy_workflow(folder: Path) -> Path:
    """What a clone holds for the workflow, copied to ``folder`` (code comes from the installed ldpipe)."""
    folder.mkdir(parents=True, exist_ok=True)
    for name in ("Snakefile", "config.yaml", "config.quick.yaml"):
        shutil.copy(ROOT / name, folder / name)
    for name in ("workflow", "profiles"):
        shutil.copytree(ROOT / name, folder / name)
    return folder
