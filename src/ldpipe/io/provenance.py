"""Which library source files a stage depends on, so Snakemake can rerun it when they change.

Snakemake sees a rule's own script change but not the modules it imports. Each
rule therefore depends on the source files of every ldpipe module its
stage imports, directly or through other ldpipe modules, found by reading the
import statements (nothing is imported or compiled to find them), through one
input: their digest (:func:`code_digest`). Some packages hold
source that is read as text and compiled, not imported (the engine's templates, the built-in
systems' kernels): a stage that reaches such a package depends on every file in it.
"""

from __future__ import annotations

import ast
import hashlib
import os
from functools import lru_cache
from pathlib import Path

from .atomic import write_text_atomic

PACKAGE_ROOT = Path(__file__).resolve().parent.parent
PACKAGE = PACKAGE_ROOT.name
#: Packages whose files are code generation's text (``importlib.resources``), not imports.
TEXT_SOURCE_PACKAGES = ("ldpipe.engine.templates", "ldpipe.systems.kernels")


@lru_cache(maxsize=None)  # asked again for every module that imports it, two file checks each time
def _module_file(module: str) -> Path | None:
    parts = module.split(".")
    if parts[0] != PACKAGE:
        return None
    base = PACKAGE_ROOT.joinpath(*parts[1:])
    for candidate in (base.with_suffix(".py"), base / "__init__.py"):
        if candidate.is_file():
            return candidate
    return None


#: The fields of a statement that hold statements (bodies of functions, classes, loops, with,
#: if/else, try/except/finally, match cases): an import is a statement, so it is found by
#: walking these alone, not every expression as ``ast.walk`` does (a tenth of the time).
STATEMENT_FIELDS = ("body", "orelse", "finalbody", "handlers", "cases")


def statements(body: list[ast.stmt]):
    """Every statement in ``body``, nested ones included."""
    for node in body:
        yield node
        for name in STATEMENT_FIELDS:
            nested = getattr(node, name, None)
            if isinstance(nested, list):
                yield from statements(nested)


def import_base(node: ast.ImportFrom, package: str) -> str:
    """The absolute name of the module a ``from ... import`` statement in ``package`` imports from."""
    if not node.level:
        return node.module or ""
    anchor = package.split(".")
    anchor = anchor[: len(anchor) - (node.level - 1)]
    return ".".join(anchor + ([node.module] if node.module else []))


@lru_cache(maxsize=None)  # a Snakefile asks for ~30 stages' closures, which share most files
def _imported_modules(path: Path, module: str) -> frozenset[str]:
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    found = set()
    for node in statements(ast.parse(path.read_text(), filename=str(path)).body):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = import_base(node, package)
            found.add(base)
            # `from . import x` and `from .pkg import mod` may name submodules.
            found.update(f"{base}.{alias.name}" for alias in node.names)
    return frozenset(name for name in found if name.split(".")[0] == PACKAGE)


def imported_modules(module: str) -> set[str]:
    """The ldpipe modules (and packages) ``module``'s source imports by name, anywhere in it."""
    path = _module_file(module)
    return set() if path is None else set(_imported_modules(path, module))


@lru_cache(maxsize=None)
def library_sources(module: str) -> tuple[str, ...]:
    """Sorted paths of the source files ``module`` depends on within ldpipe, itself included.

    Parent packages' ``__init__.py`` files are included, since importing a module runs them.
    """
    seen: dict[str, Path] = {}
    pending = [module]
    while pending:
        name = pending.pop()
        if name in seen:
            continue
        path = _module_file(name)
        if path is None:
            continue
        seen[name] = path
        parents = name.split(".")
        pending.extend(".".join(parents[:i]) for i in range(1, len(parents)))
        pending.extend(_imported_modules(path, name))
        if name in TEXT_SOURCE_PACKAGES:
            pending.extend(f"{name}.{source.stem}" for source in path.parent.glob("*.py") if source.stem != "__init__")
    return tuple(sorted(str(path) for path in seen.values()))


def code_digest(module: str, folder: str | os.PathLike) -> Path:
    """A file in ``folder`` listing the SHA-256 of each of ``module``'s :func:`library_sources`,
    rewritten only when that list changes.

    A rule takes it as its one code input: its time is newer than a stage's outputs exactly when
    a source the stage depends on changed. Snakemake checks every input of every ready job each
    time it schedules, so one file per rule in place of dozens keeps that check cheap.
    """
    lines = []
    for source in map(Path, library_sources(module)):
        lines.append(f"{hashlib.sha256(source.read_bytes()).hexdigest()}  {source.relative_to(PACKAGE_ROOT).as_posix()}\n")
    text = "".join(lines)
    path = Path(folder) / f"{module}.sha256"
    if not path.is_file() or path.read_text() != text:
        write_text_atomic(path, text)  # a reader never sees half a list
    return path
