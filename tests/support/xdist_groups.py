"""pytest-xdist's ``--dist loadgroup`` for this suite: which worker runs which tests.

Session fixtures run once per worker, module fixtures once per worker that runs a test of the
module. So every test that reads conftest's ``quick_run`` or ``lint`` (Snakemake runs of
minutes) is in one group, :data:`support.workflow.SNAKEMAKE_RUNS_GROUP`, a test marked
``xdist_group(NAME)`` in group NAME, and every other test in its file's group; a worker runs a
whole group. xdist's own loadgroup appends the group to each test's node id, which pytest 9.2's
node ids no longer take; here the workers write each test's group to a file instead and the
controller's scheduler reads it.
"""

from __future__ import annotations

import json
import shutil
import tempfile
from pathlib import Path

import pytest

from .workflow import SNAKEMAKE_RUNS_GROUP

#: The key of ``workerinput`` that names the folder the workers write their groups to.
GROUPS_FOLDER = "ldpipe_xdist_groups"


def group_of(item: pytest.Item) -> str:
    if {"quick_run", "lint"} & set(item.fixturenames):
        return SNAKEMAKE_RUNS_GROUP
    marker = item.get_closest_marker("xdist_group")
    if marker is not None:
        return str(marker.args[0] if marker.args else marker.kwargs["name"])
    return item.nodeid.split("::")[0]


def record_groups(config: pytest.Config, items: list[pytest.Item]) -> None:
    """On a worker: order the Snakemake runs' group first (the longest, it starts first) and write
    every test's group for the controller."""
    if not hasattr(config, "workerinput") or GROUPS_FOLDER not in config.workerinput:
        return
    groups = {item: group_of(item) for item in items}
    items.sort(key=lambda item: groups[item] != SNAKEMAKE_RUNS_GROUP)
    folder = Path(config.workerinput[GROUPS_FOLDER])
    written = folder / f".{config.workerinput['workerid']}.tmp"
    written.write_text(json.dumps({item.nodeid: groups[item] for item in items}))
    written.replace(folder / f"{config.workerinput['workerid']}.json")


def groups_folder(config: pytest.Config) -> Path:
    """The controller's folder for the workers' group files, made on first use, removed at exit."""
    if not hasattr(config, "ldpipe_xdist_groups"):
        config.ldpipe_xdist_groups = Path(tempfile.mkdtemp(prefix="ldpipe-xdist-groups-"))
        config.add_cleanup(lambda: shutil.rmtree(config.ldpipe_xdist_groups, ignore_errors=True))
    return config.ldpipe_xdist_groups


def make_scheduler(config: pytest.Config, log):
    """A load-scope scheduler whose scope is a test's group, the groups in collection order."""
    from xdist.scheduler import LoadScopeScheduling

    folder = groups_folder(config)

    class GroupScheduling(LoadScopeScheduling):
        def __init__(self, config, log=None):
            super().__init__(config, log)
            self.groups: dict[str, str] = {}

        def _split_scope(self, nodeid: str) -> str:
            if not self.groups:  # every worker has collected (and written) by the first call
                self.groups.update(json.loads(next(iter(sorted(folder.glob("*.json")))).read_text()))
            return self.groups[nodeid]

    config.option.loadscopereorder = False  # keep the Snakemake runs' group first
    return GroupScheduling(config, log)
