"""docs/architecture.md's recipes name every file the thing they add touches."""

import re

from support.workflow import ROOT

ARCHITECTURE = ROOT / "docs" / "architecture.md"


def recipe(title: str) -> str:
    """The text of the "Adding things" bullet that starts with ``**title**``."""
    text = ARCHITECTURE.read_text()
    match = re.search(rf"^- \*\*{re.escape(title)}\*\*:(.*?)(?=^- \*\*|^## )", text, re.S | re.M)
    assert match, f"no recipe for {title!r} in {ARCHITECTURE}"
    return match.group(1)


def kind_branches() -> set[str]:
    """The compiled sources (templates and kernels, read as text) that test an integrand's kind."""
    sources = set()
    for folder in ("engine/templates", "systems/kernels"):
        for path in (ROOT / "src" / "ldpipe" / folder).glob("*.py"):
            if re.search(r"\bKIND_[A-Z]+\b", path.read_text()):
                sources.add(f"{folder}/{path.name}")
    return sources


def test_the_integrand_recipe_names_every_source_that_branches_on_the_kind():
    named = set(re.findall(r"`((?:engine|systems)/[\w/]+\.py)`", recipe("An integrand")))
    found = kind_branches()
    assert found, "no template tests an integrand kind: the search is broken"
    assert found - named == set(), f"the integrand recipe leaves out {sorted(found - named)}"
    assert "engine/integrands.py" in named


def test_the_recipe_reader_finds_what_a_bullet_leaves_out():
    # the check fails where the recipe names fewer files than the sources that branch
    named = set(re.findall(r"`((?:engine|systems)/[\w/]+\.py)`", "a record in `engine/integrands.py`"))
    assert kind_branches() - named
