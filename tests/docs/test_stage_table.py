"""The user guide's stage table names every stage the workflow has, so it cannot fall behind.

A reader finds a stage's configuration block, rules, module and guide page in one table of
docs/guide/index.md. A new rule file, a new rule or a new stage module the table does not name
fails here, with what is missing.
"""

from __future__ import annotations

import re

from support.workflow import DOCUMENTATION, ROOT

#: Modules of ldpipe.stages that are not stages: they plan and parameterise the others.
NOT_STAGES = {"__init__", "parameters", "plan"}


def _stage_table() -> list[list[str]]:
    """The rows of the guide's table whose header starts with "stage": each a list of cells."""
    text = DOCUMENTATION["docs/guide/index.md"]
    table = re.search(r"^\| stage.*?\n(?:\|.*\n)+", text, flags=re.M)
    assert table, "docs/guide/index.md has no table whose first column is the stage"
    return [[cell.strip() for cell in row.strip().strip("|").split("|")] for row in table.group(0).splitlines()[2:]]


def _named(cells: list[str]) -> set[str]:
    return {word for cell in cells for word in re.findall(r"`([^`]+)`", cell)}


def test_the_stage_table_names_every_rule_file_rule_and_stage_module():
    rows = _stage_table()
    header = [cell.lower() for cell in re.search(r"^\| stage.*$", DOCUMENTATION["docs/guide/index.md"],
                                                flags=re.M).group(0).strip("|").split("|")]
    rules_column = next(i for i, name in enumerate(header) if "rules" in name)
    module_column = next(i for i, name in enumerate(header) if "module" in name)
    rules_named = _named(row[rules_column] for row in rows)
    modules_named = _named(row[module_column] for row in rows)

    missing = []
    for path in sorted((ROOT / "workflow/rules").glob("*.smk")):
        if path.name == "common.smk":  # helpers of the rules, not a stage's
            continue
        if path.name not in rules_named:
            missing.append(f"the rule file {path.name}")
        # named rules; a file's generated rules (one per figure, per study) are named by their data
        missing += [f"the rule {rule} of {path.name}" for rule in re.findall(r"^rule (\w+):", path.read_text(), flags=re.M)
                    if rule not in rules_named]
    for path in sorted((ROOT / "src/ldpipe/stages").glob("*.py")):
        if path.stem not in NOT_STAGES and path.stem not in modules_named:
            missing.append(f"the stage module stages/{path.name}")
    assert not missing, f"docs/guide/index.md's stage table does not name {missing}"


def test_every_row_links_its_guide_page():
    for row in _stage_table():
        pages = re.findall(r"\]\(([^)#]+)", row[0])
        assert pages, f"the stage {row[0]!r} links no guide page"
        for page in pages:
            assert (ROOT / "docs/guide" / page).is_file(), f"{row[0]}: no page {page}"
