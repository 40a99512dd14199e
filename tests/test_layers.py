"""Lower layers never import upper ones, read from the import statements of every ldpipe module.

From the top: the command line and the stages (``ldpipe.cli*``, ``ldpipe.stages``), the
figures (``ldpipe.figures``), and the library (everything else: the engine, the systems, the
science modules, the file conventions and the stage file contracts). A figure reads a stage's
file through :mod:`ldpipe.contracts`, never through the stage that wrote it.
"""


import pytest

from ldpipe.provenance import PACKAGE_ROOT, imported_modules


def package_modules() -> list[str]:
    names = []
    for path in sorted(PACKAGE_ROOT.rglob("*.py")):
        parts = path.relative_to(PACKAGE_ROOT.parent).with_suffix("").parts
        names.append(".".join(parts[:-1] if parts[-1] == "__init__" else parts))
    return names


def layer(module: str) -> int:
    """0 the library, 1 the figures, 2 the stages and the command line."""
    parts = module.split(".")
    if len(parts) > 1 and (parts[1] == "stages" or parts[1].startswith("cli")):
        return 2
    if len(parts) > 1 and parts[1] == "figures":
        return 1
    return 0


def test_the_walk_sees_the_package_and_its_imports():
    modules = package_modules()
    assert {"ldpipe", "ldpipe.engine", "ldpipe.engine.api", "ldpipe.figures.nhim", "ldpipe.stages.ld"} <= set(modules)
    # A known downward import, relative and absolute forms both resolved.
    assert "ldpipe.ld_grid" in imported_modules("ldpipe.stages.ld")
    assert "ldpipe.contracts" in imported_modules("ldpipe.figures.nhim")


@pytest.mark.parametrize("module", [m for m in package_modules() if layer(m) < 2])
def test_no_module_imports_a_layer_above_it(module):
    upward = sorted(name for name in imported_modules(module) if layer(name) > layer(module))
    assert not upward, f"{module} imports {upward} from a layer above it"

