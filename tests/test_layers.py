"""The layers of docs/architecture.md, read from the import statements of every ldpipe module.

From the bottom: the foundations (the version, errors, logs, text, the numba cache of generated
source, the stage-file plumbing in ``ldpipe.io``), the systems, the engine, the science core
(``ldpipe.core``, with the independent references of ``ldpipe.testing`` and the example data of
``ldpipe.data``), the configuration's rules, the figures, and on top the face: the package itself,
the Dataset accessor, the Python API, the stages and the command line. A module imports only from
its own layer or those below, whether by an import statement or by ``importlib.import_module`` of
a name written in it; the modules import one another without a cycle. Every package is mapped to
its layer here by name: a new package must be placed, not fall into a layer by default.
"""

import ast
from functools import lru_cache

import pytest

from ldpipe.io.provenance import PACKAGE_ROOT, import_base

LAYERS = ("foundations", "systems", "engine", "core", "configuration", "figures", "face")

#: Every package and top-level module of ldpipe, and its layer (an index of LAYERS).
PLACES = {
    "ldpipe._version": 0, "ldpipe.errors": 0, "ldpipe.logs": 0, "ldpipe.text": 0, "ldpipe.jitcache": 0,
    "ldpipe.io": 0,
    "ldpipe.systems": 1,
    "ldpipe.engine": 2,
    "ldpipe.core": 3, "ldpipe.core.structures": 3, "ldpipe.testing": 3, "ldpipe.data": 3,
    "ldpipe.config": 4,
    "ldpipe.figures": 5,
    "ldpipe": 6, "ldpipe.accessor": 6, "ldpipe.api": 6, "ldpipe.stages": 6, "ldpipe.cli": 6,
}

#: Packages whose files are text that code generation reads and compiles, not modules to import.
TEXT_PACKAGES = ("ldpipe.engine.templates", "ldpipe.systems.kernels")


def package_modules() -> dict[str, object]:
    """Every module of ldpipe by dotted name, with its source file."""
    names = {}
    for path in sorted(PACKAGE_ROOT.rglob("*.py")):
        parts = path.relative_to(PACKAGE_ROOT.parent).with_suffix("").parts
        if parts[-1] == "__main__":
            continue
        names[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return names


MODULES = package_modules()


def layer(module: str) -> int:
    """The layer of ``module``: that of the longest name in PLACES it is or lies under."""
    parts = module.split(".")
    for end in range(len(parts), 0, -1):
        place = ".".join(parts[:end])
        if place in PLACES:
            return PLACES[place]
    raise KeyError(module)


def constant_strings(tree: ast.Module) -> dict[str, str]:
    """The module-level names bound to a string literal (``DRAWING_MODULE = "ldpipe.figures..."``)."""
    found = {}
    for node in tree.body:
        if isinstance(node, (ast.Assign, ast.AnnAssign)) and isinstance(node.value, ast.Constant) \
                and isinstance(node.value.value, str):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            found.update({t.id: node.value.value for t in targets if isinstance(t, ast.Name)})
    return found


def dynamic_name(argument: ast.expr, constants: dict[str, str], module: str, package: str) -> str | None:
    """The module an ``import_module`` argument names: a literal, a module constant, or an f-string
    of ``__name__`` and ``__package__`` with literals."""
    if isinstance(argument, ast.Constant) and isinstance(argument.value, str):
        return argument.value
    if isinstance(argument, ast.Name):
        return constants.get(argument.id)
    if isinstance(argument, ast.JoinedStr):
        text = ""
        for part in argument.values:
            if isinstance(part, ast.Constant):
                text += part.value
            elif isinstance(part, ast.FormattedValue) and isinstance(part.value, ast.Name) \
                    and part.value.id in ("__name__", "__package__"):
                text += module if part.value.id == "__name__" else package
            else:
                return None
        return text
    return None


def resolve(name: str) -> str | None:
    """The ldpipe module that an imported name is or lies in (None: not ldpipe's)."""
    while name not in MODULES and "." in name:
        name = name.rpartition(".")[0]
    return name if name in MODULES else None


@lru_cache(maxsize=None)
def imports(module: str) -> frozenset[tuple[str, int, str]]:
    """``(imported module, line, how)`` for every ldpipe module ``module`` imports, at any depth of
    its code: ``from pkg import sub`` is the submodule alone, and ``import_module(...)`` calls of a
    name the code spells out count as imports."""
    path = MODULES[module]
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    tree = ast.parse(path.read_text(), filename=str(path))
    constants = constant_strings(tree)
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.update((alias.name, node.lineno, "import") for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = import_base(node, package)
            for alias in node.names:
                found.add((f"{base}.{alias.name}" if f"{base}.{alias.name}" in MODULES else base, node.lineno, "import"))
        elif isinstance(node, ast.Call) and node.args and (
                getattr(node.func, "id", None) == "import_module" or getattr(node.func, "attr", None) == "import_module"):
            name = dynamic_name(node.args[0], constants, module, package)
            if name is not None:
                found.add((name, node.lineno, "import_module"))
    return frozenset((resolved, line, how) for name, line, how in found
                     if (resolved := resolve(name)) is not None and resolved != module)


def importable_modules() -> list[str]:
    return [m for m in MODULES if not any(m.startswith(t + ".") for t in TEXT_PACKAGES)]


def test_every_module_has_a_place():
    unplaced = []
    for module in MODULES:
        try:
            layer(module)
        except KeyError:
            unplaced.append(module)
    assert unplaced == [], f"modules in no layer of PLACES (place their package there): {unplaced}"
    assert set(PLACES) <= set(MODULES), f"PLACES names what is not in the package: {set(PLACES) - set(MODULES)}"


def test_every_layer_is_populated_as_the_architecture_says():
    # A map that sent a whole package to the wrong layer would make the import rule vacuous.
    expected = {"ldpipe.io.datafile": 0, "ldpipe.jitcache": 0, "ldpipe.systems.formula": 1,
                "ldpipe.engine.codegen": 2, "ldpipe.core.equilibria.potential": 3, "ldpipe.config.loading": 4,
                "ldpipe.core.nhim.refinement": 3, "ldpipe.testing.reference_ld": 3, "ldpipe.core.maps.grid": 3,
                "ldpipe.core.normal_form.lie": 3, "ldpipe.figures.nhim": 5,
                "ldpipe.stages.transport": 6, "ldpipe.cli.main": 6, "ldpipe.api": 6, "ldpipe.accessor": 6}
    assert {module: layer(module) for module in expected} == expected
    assert {layer(m) for m in MODULES} == set(range(len(LAYERS)))


def test_the_walk_sees_static_relative_and_dynamic_imports():
    assert "ldpipe.core.maps.assembly" in {m for m, _, _ in imports("ldpipe.stages.ld")}
    assert "ldpipe.io.contracts" in {m for m, _, _ in imports("ldpipe.figures.nhim")}
    # the accessor's drawing module is a constant handed to import_module
    assert ("ldpipe.figures.dataset", "import_module") in {(m, how) for m, _, how in imports("ldpipe.accessor")}
    # the API, imported on first use by an f-string of __name__
    assert ("ldpipe.api", "import_module") in {(m, how) for m, _, how in imports("ldpipe")}


@pytest.mark.parametrize("module", [m for m in importable_modules() if layer(m) < len(LAYERS) - 1])
def test_no_module_imports_a_layer_above_it(module):
    upward = sorted(f"{name} ({LAYERS[layer(name)]}, line {line}, {how})" for name, line, how in imports(module)
                    if layer(name) > layer(module))
    assert not upward, f"{module} ({LAYERS[layer(module)]}) imports {upward} from a layer above it"


def import_cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan's algorithm, iterative)."""
    index, low, stack, on_stack, cycles, counter = {}, {}, [], set(), [], 0
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            for child in children:
                if child not in index:
                    index[child] = low[child] = counter
                    counter += 1
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph[child]))))
                    break
                if child in on_stack:
                    low[node] = min(low[node], index[child])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[node])
                if low[node] == index[node]:
                    component = []
                    while True:
                        member = stack.pop()
                        on_stack.discard(member)
                        component.append(member)
                        if member == node:
                            break
                    if len(component) > 1:
                        cycles.append(sorted(component))
    return cycles


def test_no_import_cycles():
    graph = {m: {name for name, _, _ in imports(m)} for m in MODULES}
    assert import_cycles(graph) == []


def test_the_cycle_finder_sees_a_package_and_its_module():
    # a package that imports its module, which imports the package back: the cycle this rule forbids
    assert import_cycles({"p": {"p.a"}, "p.a": {"p", "q"}, "q": set()}) == [["p", "p.a"]]
    assert import_cycles({"a": {"b"}, "b": {"c"}, "c": set()}) == []


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
