"""The tree passes ``ruff check`` with the rules ``pyproject.toml``'s ``[tool.ruff]`` selects
(unused and undefined names, redefinitions, statements and syntax pycodestyle refuses), read
from the checkout as git lists it: source, tests, benchmarks, the workflow's scripts and the
documentation's examples."""

import shutil
import subprocess
import sys
from pathlib import Path

from support.workflow import ROOT


def ruff() -> list[str]:
    """The ruff of the running environment (the ``test`` extra installs it)."""
    beside = Path(sys.executable).with_name("ruff")
    return [str(beside)] if beside.is_file() else [shutil.which("ruff") or "ruff"]


def test_the_tree_passes_ruff(tmp_path):
    # the cache goes to a temporary folder: the test writes nothing into the checkout
    checked = subprocess.run([*ruff(), "check", "--cache-dir", str(tmp_path), "--output-format", "concise", str(ROOT)],
                             cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert checked.returncode == 0, checked.stdout[-3000:] + checked.stderr[-2000:]


def test_an_unused_import_fails_the_check(tmp_path):
    """The configuration selects what it says: a file with an unused import and an undefined name
    is refused, naming both (with pyproject's settings, read from the checkout)."""
    bad = tmp_path / "bad.py"
    bad.write_text("import os\n\n\ndef f():\n    return undefined_name\n")
    checked = subprocess.run([*ruff(), "check", "--no-cache", "--config", str(ROOT / "pyproject.toml"),
                              "--output-format", "concise", str(bad)], capture_output=True, text=True, timeout=60)
    assert checked.returncode == 1 and "F401" in checked.stdout and "F821" in checked.stdout, checked.stdout
