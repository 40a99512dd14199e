"""Every file and every ``ldpipe`` name the documentation writes exists.

Modules move and get renamed; a page that still names the old place sends a reader nowhere. This
reads the README, the changelog, the benchmarks' index and every Markdown page of docs/ (as a
reader gets them, no Sphinx build and no engine) and checks:

- every link target (``[text](target)``, and the paths of ``{include}`` and ``{figure}``) exists,
  resolved from the page's folder as GitHub and the site resolve it;
- every repository path written in backticks exists. A word of a code span is a path if it has a
  ``/`` and ends in ``/`` or a file suffix, or starts with a top-level folder of the repository
  (``tests/engine``). It is looked up from the repository's root, else from ``src/ldpipe`` (the
  short module paths, ``engine/settings.py``), else from ``docs/``. A bare file name with a source
  suffix (``jitcache.py``, ``config.yaml``) must exist somewhere in the repository. Paths under a
  folder ``.gitignore`` names (``results/``, ``.venv/``, ...) are what running ldpipe writes, not
  repository paths, and placeholders (``stages/NAME.py``, ``results/{system}/...``, ``*``) are
  patterns, not paths: both are skipped;
- every dotted name ``ldpipe.x.y`` anywhere in the text imports as a module or is an attribute of
  one (importlib and getattr: nothing of the pages is executed); so does a short one in backticks
  that starts with a module of the package (``ld_grid.resolve_ld_map``, ``io.datafile``), read
  as ``ldpipe.core.maps.grid.resolve_ld_map``, as the short paths are read from ``src/ldpipe``.

A failure lists every unresolved reference with its file and line.
"""

from __future__ import annotations

import importlib
import re
from functools import cache

import pytest

from support.workflow import DOCUMENTATION, ROOT

#: What a user reads, the changelog the site includes, and the benchmarks' index the pages point to
PAGES = {**DOCUMENTATION, **{name: (ROOT / name).read_text() for name in ("CHANGELOG.md", "benchmarks/README.md")}}

#: The folders running ldpipe writes into (the workflow's results, the built site, caches).
GENERATED = tuple(line.strip().lstrip("/") for line in (ROOT / ".gitignore").read_text().splitlines()
                  if line.strip().endswith("/") and not line.startswith("#"))
TOP_FOLDERS = tuple(f"{p.name}/" for p in ROOT.iterdir() if p.is_dir() and not p.name.startswith("."))
#: What a bare file name must end in to be read as one of the repository's (a user's own
#: ``study.yaml`` is not).
SOURCE_SUFFIXES = (".py", ".smk", ".md", ".rst")

CODE_SPAN = re.compile(r"(`+)(.+?)\1")
LINK = re.compile(r"\]\(([^)\s]+)\)")
DIRECTIVE = re.compile(r"^\s*[`:]{3,}\{(?:include|figure|image)\}\s+(\S+)")
# ldpipe.x.y not preceded by a name, a dot or a folder (ds.ldpipe.plot, the accessor, and
# workflow/envs/ldpipe.yaml are not names)
DOTTED = re.compile(r"(?<![\w./])ldpipe(?:\.[A-Za-z_]\w*)+")
SHORT_DOTTED = re.compile(r"[A-Za-z_]\w*(?:\.[A-Za-z_]\w*)+")
#: The package's own modules and folders: a short dotted name starts with one of them. (Not the
#: API's names: ``nhim.studies`` and ``system.hamiltonian`` are configuration keys.)
MODULES = frozenset(p.name.removesuffix(".py") for p in (ROOT / "src/ldpipe").iterdir()
                    if p.suffix == ".py" or (p / "__init__.py").is_file())
PLACEHOLDER = re.compile(r"[{}<>*…]|\.\.\.|\b[A-Z]{3,}\b")
SUFFIX = re.compile(r"\.[A-Za-z]\w*$")


def _lines(text: str):
    """``(line number, line, inside a fenced block)`` of a Markdown page."""
    fence = None
    for number, line in enumerate(text.splitlines(), start=1):
        opening = re.match(r"^\s*(`{3,}|~{3,}|:{3,})", line)
        if fence is None and opening:
            fence = opening.group(1)
            yield number, line, False  # a directive's argument sits on its opening line
            continue
        if fence is not None and line.strip().startswith(fence) and line.strip().strip(fence[0]) == "":
            fence = None
            continue
        yield number, line, fence is not None


def _path_words(span: str) -> list[str]:
    """The words of a code span that are written as repository paths."""
    words = []
    for word in span.split():
        word = word.strip("'\",;:()[]").removeprefix("./").split("::", 1)[0]  # a test's node id: its file
        if not word or "://" in word or word.startswith(("-", "$", "~", "/")) or "=" in word:
            continue
        if PLACEHOLDER.search(word) or word.startswith(GENERATED):
            continue
        last = word.rstrip("/").rsplit("/", 1)[-1]
        if "/" in word.rstrip("/") or word.endswith("/"):
            if word.endswith("/") or SUFFIX.search(last) or word.startswith(TOP_FOLDERS):
                words.append(word)
        elif word.endswith(SOURCE_SUFFIXES) and not DOTTED.fullmatch(word.removesuffix(".py")):
            words.append(word)
    return words


def _short_names(span: str) -> list[str]:
    """The words of a code span that are dotted names relative to the package (``flow.FlowSettings``,
    ``stages.ld.run_ld_map(...)``); a word that ends in a file suffix (``config.yaml``) is a file."""
    names = []
    for word in span.split():
        word = re.sub(r"\(.*", "", word.strip("'\",;:[]`"))  # a call's arguments
        if SHORT_DOTTED.fullmatch(word) and word.split(".")[0] in MODULES and not _is_file_name(word):
            names.append(word)
    return names


def _is_file_name(word: str) -> bool:
    return word.rsplit(".", 1)[-1] in {"py", "yaml", "yml", "md", "rst", "json", "toml", "nc", "zarr", "png", "smk", "txt", "html"}


@cache
def _file_names() -> frozenset[str]:
    skip = {".git", ".venv", "__pycache__", *(g.rstrip("/") for g in GENERATED)}
    return frozenset(p.name for p in ROOT.rglob("*") if not skip & set(p.relative_to(ROOT).parts))


def _path_exists(word: str) -> bool:
    if "/" not in word:
        return word in _file_names()
    return any((base / word).exists() for base in (ROOT, ROOT / "src/ldpipe", ROOT / "docs"))


def _link_exists(page: str, target: str) -> bool:
    target = target.split("#", 1)[0]
    if not target or re.match(r"^[a-z]+:", target):  # an anchor on the page, a web or mail address
        return True
    path = ((ROOT / page).parent / target).resolve()
    if path.is_relative_to(ROOT) and str(path.relative_to(ROOT)).startswith(GENERATED):
        return True  # a page the site's build writes (the gallery's)
    return path.exists()


def _imports(name: str) -> bool:
    """Whether ``name`` is a module, or an attribute of the longest module prefix of it."""
    parts = name.split(".")
    for end in range(len(parts), 0, -1):
        module_name = ".".join(parts[:end])
        try:
            thing = importlib.import_module(module_name)
        except ModuleNotFoundError as error:
            if error.name and module_name.startswith(error.name):  # this prefix is not a module
                continue
            raise  # a module that exists failed to import: that is a failure of its own
        for attribute in parts[end:]:
            if not hasattr(thing, attribute):
                return False
            thing = getattr(thing, attribute)
        return True
    return False


def unresolved(pages: dict[str, str]) -> list[str]:
    """``file:line: what`` for every reference of ``pages`` (path from the root -> text) that does not
    resolve."""
    found = []
    for page, text in pages.items():
        for number, line, fenced in _lines(text):
            where = f"{page}:{number}"
            for name in DOTTED.findall(line):
                if not _imports(name):
                    found.append(f"{where}: no module or attribute {name}")
            if fenced:
                continue
            targets = [m.group(1) for m in LINK.finditer(line)]
            if directive := DIRECTIVE.match(line):
                targets.append(directive.group(1))
            found += [f"{where}: link to {t}, which is not there" for t in targets if not _link_exists(page, t)]
            for span in CODE_SPAN.finditer(line):
                found += [f"{where}: no file {w}" for w in _path_words(span.group(2)) if not _path_exists(w)]
                found += [f"{where}: no module or attribute ldpipe.{n}" for n in _short_names(span.group(2))
                          if not _imports(f"ldpipe.{n}")]
    return found


def test_the_benchmarks_index_lists_every_benchmark_script():
    """One line per script in benchmarks/README.md, so a new benchmark is found with its results."""
    index = PAGES["benchmarks/README.md"]
    missing = [p.name for p in sorted((ROOT / "benchmarks").glob("*.py")) if f"`{p.name}`" not in index]
    assert not missing, f"benchmarks/README.md does not list {missing}"


def test_every_path_and_ldpipe_name_in_the_documentation_resolves():
    missing = unresolved(PAGES)
    assert not missing, "\n".join(["unresolved references:", *missing])


@pytest.mark.parametrize("text, expected", [
    ("see `engine/settings.py` and `src/ldpipe/io/contracts.py`", []),
    ("see `engine/setting.py`", ["no file engine/setting.py"]),
    ("the rules in `workflow/rules/nope.smk`", ["no file workflow/rules/nope.smk"]),
    ("tests by subject: `tests/engine`, `tests/nowhere`", ["no file tests/nowhere"]),
    ("a folder `nhim_gone/`", ["no file nhim_gone/"]),
    ("a module `gone_module.py`", ["no file gone_module.py"]),
    ("`tests/docs/test_docs.py::test_the_readme_is_a_front_door`, `study.yaml`", []),
    ("`tests/docs/test_gone.py::test_x`", ["no file tests/docs/test_gone.py"]),
    ("the [gallery](gallery/index.rst), `workflow/envs/ldpipe.yaml`", []),
    ("[the engine](engine.md), [lost](lost.md#top)", ["link to lost.md#top"]),
    ("`ldpipe.io.contracts.StageFile`, `ldpipe.nhim`, ds.ldpipe.plot()", []),
    ("`ldpipe.io.contract`", ["no module or attribute ldpipe.io.contract"]),
    ("`core.maps.grid.resolve_ld_map(parameters)`, `io.datafile`, `config.yaml`, `np.sqrt`", []),
    ("`core.equilibria.potential.well_and_frequency`", ["no module or attribute ldpipe.core.equilibria.potential.well_and_frequency"]),
    ("`ldpipe.io.contracts.StageFil`", ["no module or attribute ldpipe.io.contracts.StageFil"]),
    ("`results/{system}/equilibria.nc`, `stages/NAME.py`, `.venv/bin/python`, `docs/_build/html`", []),
])
def test_the_check_finds_what_it_should(text, expected):
    """The rule on a page of one line: what resolves passes and each broken reference is named."""
    found = unresolved({"docs/page.md": text + "\n"})
    assert [f.split(": ", 1)[1].split(", which")[0] for f in found] == expected, found
