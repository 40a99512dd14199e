"""Which library files each stage depends on: the rerun trigger for library edits."""

import hashlib
import os
from pathlib import Path

from ldpipe.io.provenance import code_digest, library_sources


def names(module):
    root = Path(library_sources("ldpipe")[0]).parent
    return {str(Path(path).relative_to(root)) for path in library_sources(module)}


def test_equilibrium_stage_depends_on_what_it_imports_only():
    sources = names("ldpipe.stages.equilibria")
    # What it imports, directly or through other modules, and the packages' __init__ files.
    for expected in ("core/equilibria/potential.py", "io/datafile.py", "systems/builtin.py", "systems/formula.py",
                     "systems/base.py", "jitcache.py", "stages/__init__.py", "__init__.py"):
        assert expected in sources, expected
    # Not the engine or the LD grid: editing those must not rerun the equilibria.
    assert not any(name.startswith("engine/") for name in sources)
    assert "core/maps/grid.py" not in sources and "core/sections.py" not in sources
    # Nor the configuration's validation (which knows the engine's schemes): a stage reads the
    # system entry through ldpipe.systems.
    assert not any(name.startswith("config/") for name in sources)


def test_ld_stage_depends_on_the_engine_the_saddle_selection_and_the_contracts():
    sources = names("ldpipe.stages.ld")
    assert {"core/maps/grid.py", "core/sections.py", "core/equilibria/potential.py", "io/contracts.py", "engine/__init__.py",
            "engine/api.py"} <= sources
    # It reads the equilibria file through the file's contract, not through the stage that wrote it.
    assert "stages/equilibria.py" not in sources
    assert not any(name.startswith("cli/") for name in sources)


def test_orbit_stages_depend_on_the_engine_only_where_they_integrate_with_it():
    # Poincaré sections and manifolds integrate on the engine's DOP853 step (ldpipe.core.trajectories), so an
    # engine edit reruns them; the periodic orbits use scipy's variational integration, so it does not.
    assert not any(name.startswith("engine/") for name in names("ldpipe.stages.upo"))
    for stage in ("ldpipe.stages.upo", "ldpipe.stages.manifolds", "ldpipe.stages.poincare"):
        sources = names(stage)
        assert "io/contracts.py" in sources, stage
        assert "core/maps/grid.py" not in sources and "stages/ld.py" not in sources, stage
    for stage in ("ldpipe.stages.manifolds", "ldpipe.stages.poincare"):
        assert {"core/trajectories.py", "engine/templates/flow_driver.py"} <= names(stage), stage

def test_code_generation_templates_count_as_sources():
    # The engine's templates and the built-in kernels are read as text and compiled, never
    # imported: an edit to one must still rerun the stages whose compiled code it becomes.
    ld = names("ldpipe.stages.ld")
    assert {"engine/templates/driver.py", "engine/templates/quadrature.py", "systems/kernels/barbanis_2dof.py"} <= ld
    assert "engine/templates/flow_driver.py" in names("ldpipe.stages.poincare")


def test_code_digest_lists_every_source_and_changes_only_with_them(tmp_path):
    # The workflow's one code input per rule: Snakemake reruns a stage when the file is newer than
    # its outputs, so it must be rewritten when a source changes and left alone when none does.
    module = "ldpipe.stages.upo"
    path = code_digest(module, tmp_path)
    # sha256sum's format, each hash recomputed here with hashlib: one line per source, in order.
    expected = "".join(f"{hashlib.sha256(Path(source).read_bytes()).hexdigest()}  {name}\n"
                       for source, name in zip(library_sources(module), sorted(names(module))))
    assert path.read_text() == expected
    os.utime(path, (1_000_000_000, 1_000_000_000))
    assert code_digest(module, tmp_path).stat().st_mtime == 1_000_000_000  # nothing changed: not rewritten
    path.write_text(expected.replace(expected[:64], "0" * 64, 1))  # as if a source had changed since
    os.utime(path, (1_000_000_000, 1_000_000_000))
    assert code_digest(module, tmp_path).read_text() == expected
    assert path.stat().st_mtime > 1_000_000_000


NESTED_IMPORTS = '''
import a0
def f():
    import a1
    class C:
        from a2 import x
if x:
    import a3
elif y:
    import a4
else:
    import a5
for i in x:
    import a6
else:
    import a7
while x:
    import a8
else:
    import a9
try:
    import a10
except ImportError:
    import a11
else:
    import a12
finally:
    import a13
with x:
    import a14
match x:
    case 1:
        import a15
async def g():
    async for i in x:
        import a16
    async with x:
        import a17
x = [y for y in z]  # expressions hold no import
'''


def test_the_statement_walk_finds_every_import_a_full_walk_finds():
    # The reference is ast.walk over every node; the statement walk (provenance's) must find the same
    # import statements, in a file with an import in every kind of nested block and in the package.
    import ast

    from ldpipe.io.provenance import PACKAGE_ROOT, statements

    def imports(nodes):
        return sorted((node.lineno, ast.dump(node)) for node in nodes if isinstance(node, (ast.Import, ast.ImportFrom)))

    tree = ast.parse(NESTED_IMPORTS)
    assert len(imports(ast.walk(tree))) == 18
    assert imports(statements(tree.body)) == imports(ast.walk(tree))
    for path in PACKAGE_ROOT.rglob("*.py"):
        tree = ast.parse(path.read_text())
        assert imports(statements(tree.body)) == imports(ast.walk(tree)), path
