"""The layers of docs/architecture.md, read from the import statements of every ldpipe module.

From the bottom: the foundations (errors, logs, text, the numba cache of generated source, the
stage-file plumbing in ``ldpipe.io``, the Dataset accessor), the systems, the engine, the science
(everything else: equilibria, orbits, sections, NHIM, transport, accuracy, configuration, the
independent references in ``ldpipe.testing``), the figures, and on top the stages, the command
line and the Python API (``ldpipe.api``). A module imports only from its own layer or those below.
A figure reads a stage's file through :mod:`ldpipe.io.contracts`, never through the stage that
wrote it.
"""

import ast

import pytest

from ldpipe.io.provenance import PACKAGE_ROOT, imported_modules

FOUNDATIONS = {"ldpipe", "ldpipe.errors", "ldpipe.logs", "ldpipe.text", "ldpipe.jitcache", "ldpipe.io",
               "ldpipe.accessor"}
LAYERS = ("foundations", "systems", "engine", "science", "figures", "stages and command line")


def package_modules() -> list[str]:
    names = []
    for path in sorted(PACKAGE_ROOT.rglob("*.py")):
        parts = path.relative_to(PACKAGE_ROOT.parent).with_suffix("").parts
        names.append(".".join(parts[:-1] if parts[-1] in ("__init__", "__main__") else parts))
    return sorted(set(names))


MODULES = frozenset(package_modules())


def layer(module: str) -> int:
    """The index of ``module``'s layer in LAYERS (a name imported from a package: the package's)."""
    while module not in MODULES and "." in module:
        module = module.rpartition(".")[0]
    parts = module.split(".")
    top = ".".join(parts[:2])
    if module in FOUNDATIONS or top in FOUNDATIONS - {"ldpipe"}:
        return 0
    return {"ldpipe.systems": 1, "ldpipe.engine": 2, "ldpipe.figures": 4, "ldpipe.stages": 5,
            "ldpipe.cli": 5, "ldpipe.api": 5}.get(top, 3)


def test_the_walk_sees_the_package_and_its_imports():
    modules = package_modules()
    assert {"ldpipe", "ldpipe.engine", "ldpipe.engine.api", "ldpipe.figures.nhim", "ldpipe.stages.ld",
            "ldpipe.io.contracts", "ldpipe.config.maps", "ldpipe.cli.orbits"} <= set(modules)
    # A known downward import, relative and absolute forms both resolved.
    assert "ldpipe.ld_grid" in imported_modules("ldpipe.stages.ld")
    assert "ldpipe.io.contracts" in imported_modules("ldpipe.figures.nhim")


def test_every_layer_is_populated_as_the_architecture_says():
    # A layer map that sent a whole package to the wrong layer would make the import rule vacuous.
    expected = {"ldpipe.io.datafile": 0, "ldpipe.jitcache": 0, "ldpipe.systems.formula": 1,
                "ldpipe.engine.codegen": 2, "ldpipe.equilibria": 3, "ldpipe.config.loading": 3,
                "ldpipe.nhim.refinement": 3, "ldpipe.testing.reference_ld": 3, "ldpipe.figures.nhim": 4,
                "ldpipe.stages.transport": 5, "ldpipe.cli.main": 5, "ldpipe.api": 5, "ldpipe.accessor": 0}
    assert {module: layer(module) for module in expected} == expected
    assert {layer(m) for m in package_modules()} == set(range(len(LAYERS)))


@pytest.mark.parametrize("module", [m for m in package_modules() if layer(m) < len(LAYERS) - 1])
def test_no_module_imports_a_layer_above_it(module):
    upward = sorted(f"{name} ({LAYERS[layer(name)]})" for name in imported_modules(module) if layer(name) > layer(module))
    assert not upward, f"{module} ({LAYERS[layer(module)]}) imports {upward} from a layer above it"


def private_imports(path) -> list[str]:
    """``from X import _name`` statements of one file: a private name shared is a public one misnamed."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.ImportFrom) and node.module != "__future__":
            found += [f"line {node.lineno}: {alias.name}" for alias in node.names
                      if alias.name.startswith("_") and not alias.name.startswith("__")]
    return found


def test_no_module_imports_a_private_name_from_another():
    offenders = {str(path.relative_to(PACKAGE_ROOT)): private_imports(path) for path in PACKAGE_ROOT.rglob("*.py")}
    assert {path: names for path, names in offenders.items() if names} == {}


def test_the_private_import_check_sees_one(tmp_path):
    source = tmp_path / "m.py"
    source.write_text("from .codegen import JIT, _literal\nfrom .. import __version__\n")
    assert private_imports(source) == ["line 1: _literal"]
