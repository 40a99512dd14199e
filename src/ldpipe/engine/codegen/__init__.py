"""Assemble the engine's compiled code for one (system, scheme, lanes) and load it.

The generated engine module is, in this order:

1. the system's kernel source (``System.kernel_source``: ``potential``, ``gradient``,
   ``acceleration_block``, ... undecorated, with the parameters as module constants);
2. a header: imports, the numba options ``JIT`` (with ``cache=True``), the kernels wrapped in
   ``njit``, and every compile-time constant of the block (sizes, workspace offsets, scheme
   data, integrand kinds) as an upper-case module global;
3. the imports of the common modules' names (below), then the templates of
   :mod:`ldpipe.engine.templates` that read the system or the scheme (step control, the
   scheme's own, the driver) and the generated DOP853 step, if that is the scheme;
4. for a system with masses only, the kinetic section of :mod:`ldpipe.engine.kinetic`.

The LD quadrature and the events (``COMMON_LAYERS``) read no system or scheme code, only a
few header constants. numba's disk cache is per module file, so pasted into every engine they
were compiled once per engine; instead each layer of them is a *common module* of its own: a
header of only the constants its templates read (found with :mod:`symtable`, so that engines
of one shape share one text), an import of what it reads from the layers before it, and the
templates. ``quadrature`` reads only the integrand kinds: one module for every engine; the
block quadrature and events read the block's sizes and offsets: one module per scheme, block
size and number of degrees of freedom, whatever the system. An engine names each by its
:func:`ldpipe.jitcache.module_name` (the hash of its text), so a change to a common module
changes the engine's text, file and cache too. A common module's compiled functions come with
their LLVM bitcode from numba's cache, and an engine compiled later links and inlines them as
it did its own copy: the same machine code, the same bits. :attr:`EngineModules.inlined` is
the engine as one module, the common templates in place of the imports (the text before this
split, for tools that edit it: ``benchmarks/profile_engine.py``).

Two drivers can be assembled on the same step: ``process`` (the LD driver, ``driver.py``) and
``flow_process`` (samples, section crossings and escapes for :mod:`ldpipe.core.trajectories`,
``flow_driver.py``, which loads lanes with ``driver.py``'s ``load_lane``); both take the step
control of ``step_control.py``. ``DRIVERS`` lists the templates each needs.

The flow engine's module (:mod:`ldpipe.engine.vector_field`) is assembled by the same
:func:`assemble` (kernel source, :func:`header`, common modules, templates, the name-clash
checks). ``python -m ldpipe.engine.codegen --dump SYSTEM SCHEME`` prints every module of either
(``__main__.py``).

They are loaded by :func:`load_modules`, through :func:`ldpipe.jitcache.load_generated_module`,
which names each file by the hash of its text: a second process with the same system, scheme
and block size finds the files and numba's cache beside them, and loads machine code instead of
compiling. Any change to a template, the kernels or a constant changes the hash, so a stale
cache is never used.
"""

from __future__ import annotations

import ast
import builtins
import symtable
import textwrap
import types
from dataclasses import dataclass
from importlib import resources

import numpy as np

from ...jitcache import compiled_in_cache, load_generated_module, module_name
from .. import templates
from ..integrands import KINDS
from ..kinetic import kinetic_source
from ..schemes import get_scheme, scheme_source

# The templates that read no system or scheme code, each layer a common module (see the module
# docstring) that imports from the layers before it: (the start of its file name, its templates).
COMMON_LAYERS = (
    ("common_quadrature", ("quadrature",)),
    ("common_block_quadrature", ("block_arclength", "block_quadrature", "flag_checks", "events", "block_two_roots",
                                 "block_dips")),
)
# The templates every engine holds itself (step control reads the scheme's ORDER).
ENGINE_TEMPLATES = ("step_control",)
# Names a generated module's header binds for its code, besides the constants.
HEADER_NAMES = {"math", "np", "numpy", "njit", "JIT"}
DRIVER_TEMPLATE = "driver"
# The templates of each entry point, by the name of its compiled function.
DRIVERS = {"process": (DRIVER_TEMPLATE,), "flow_process": (DRIVER_TEMPLATE, "flow_status", "flow_driver")}
# numba options of every engine function, the system kernels the engine calls included.
# No fastmath: with it LLVM may round a function differently in each context it optimizes it
# in, and the copy of a callee that a compiling process runs (compiled on its own) and the one
# a process loading numba's cache runs (linked into ``process`` and optimized with it) gave LDs
# differing in the last bits. Strict IEEE arithmetic gives the same bits in every process, and
# measured as fast (benchmarks/engine_throughput.py): the lane loops vectorize without it.
# The numpy error model: no ZeroDivisionError checks in the hot loops (they block vectorization).
JIT_OPTIONS = '{"cache": True, "error_model": "numpy"}'
KERNELS = ("potential", "gradient", "acceleration_block")


def template(name: str) -> str:
    """The text of ``templates/<name>.py``."""
    return resources.files(templates).joinpath(f"{name}.py").read_text()


def literal(value) -> str:
    """Source of a header constant (exact: floats by repr, which round-trips; arrays of 1 or 2 axes)."""
    if isinstance(value, (bool, int, float)):
        return repr(value)
    if isinstance(value, np.ndarray) and value.ndim == 1:
        return "np.array([" + ", ".join(repr(float(v)) for v in value) + "])"
    if isinstance(value, np.ndarray) and value.ndim == 2:
        return "np.array([" + ", ".join("[" + ", ".join(repr(float(v)) for v in row) + "]" for row in value) + "])"
    raise TypeError(f"header constant of unsupported type {type(value).__name__}: {value!r}")


def header(title: str, kernels: tuple[str, ...], constants: dict) -> str:
    """The header of a generated module: ``title``, the imports, the numba options ``JIT``, the
    system's ``kernels`` wrapped in ``njit``, and each constant as an upper-case module global."""
    lines = [
        "",
        "",
        f"# ---- {title} ----",
        "import math",
        "",
        "import numpy as np",
        "from numba import njit",
        "",
        f"JIT = {JIT_OPTIONS}",
        "",
    ]
    lines += [f"{name} = njit(**JIT)({name})" for name in kernels]
    lines.append("")
    lines += [f"{name} = {literal(value)}" for name, value in constants.items()]
    return "\n".join(lines) + "\n"


def module_names(source: str) -> set[str]:
    """Names bound at module level by ``source`` (assignments, functions, imports)."""
    names = set()
    for node in ast.parse(source).body:
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, (ast.Assign, ast.AnnAssign, ast.AugAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            for target in targets:
                names |= {n.id for n in ast.walk(target) if isinstance(n, ast.Name)}
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            names |= {(alias.asname or alias.name).split(".")[0] for alias in node.names}
    return names


def read_globals(source: str) -> set[str]:
    """Names ``source`` reads as globals, at module level or in a function, and does not bind at
    module level (nor are builtins): what it needs from a header or another module."""
    table = symtable.symtable(source, "<generated>", "exec")
    bound = {s.get_name() for s in table.get_symbols() if s.is_assigned() or s.is_imported()}
    read = {s.get_name() for s in table.get_symbols() if s.is_referenced()}
    scopes = list(table.get_children())
    while scopes:
        scope = scopes.pop()
        read |= {s.get_name() for s in scope.get_symbols() if s.is_global()}
        scopes += scope.get_children()
    return {name for name in read - bound if not hasattr(builtins, name)}


def import_lines(module: str, names) -> str:
    """``from module import (names...)``, wrapped."""
    listed = textwrap.fill(", ".join(sorted(names)) + ",", 110, initial_indent="    ", subsequent_indent="    ",
                           break_on_hyphens=False)
    return f"from {module} import (\n{listed}\n)\n"


@dataclass(frozen=True)
class CommonModule:
    """A common module: its :func:`~ldpipe.jitcache.module_name`'s ``prefix``, its ``text``, the
    ``templates`` in it and the names they bind (``defines``; a later common module imports those it
    reads, an engine every public one, :attr:`exports`)."""

    prefix: str
    text: str
    templates: tuple[str, ...]
    defines: frozenset[str]

    @property
    def name(self) -> str:
        return module_name(self.text, self.prefix)

    @property
    def exports(self) -> tuple[str, ...]:
        return tuple(sorted(name for name in self.defines if not name.startswith("_")))


@dataclass(frozen=True)
class EngineModules:
    """The texts of one engine: its ``common`` modules, in the order they import each other, then
    the ``engine`` module, which imports from them (its file name starts with ``prefix``);
    ``inlined``, the engine as one module, the common templates pasted in place of the imports."""

    prefix: str
    common: tuple[CommonModule, ...]
    engine: str
    inlined: str

    def listing(self) -> str:
        """Every module's text, each under a line naming its file: what ``--dump`` prints."""
        modules = [*((m.name, m.text) for m in self.common), (module_name(self.engine, self.prefix), self.engine)]
        return "".join(f"# ==== {name}.py ====\n{text}\n" for name, text in modules)


def common_modules(layers, constants: dict) -> tuple[CommonModule, ...]:
    """The common modules of ``layers`` (pairs of a prefix and templates, see ``COMMON_LAYERS``),
    each with the header ``constants`` its templates read.

    ValueError if a template reads a name that is neither a header constant nor bound by an earlier
    layer (a kernel, the scheme's ``attempt``...): it needs system or scheme code, and belongs in
    the engine module.
    """
    modules: list[CommonModule] = []
    for prefix, names in layers:
        body = "".join(f"\n\n# ---- {name} ----\n{template(name)}" for name in names)
        needed = read_globals(body) - HEADER_NAMES
        earlier = {module.name: needed & module.defines for module in modules}
        reads = needed - set().union(*earlier.values())
        unknown = reads - set(constants)
        if unknown:
            raise ValueError(f"common templates {list(names)} read {sorted(unknown)}, neither header constants nor "
                             "names of an earlier common layer: such templates belong in the engine module")
        title = f"ldpipe.engine common module: {', '.join(names)} (generated by ldpipe.engine.codegen)"
        used = {name: value for name, value in constants.items() if name in reads}
        imports = "".join("\n" + import_lines(name, wanted) for name, wanted in earlier.items() if wanted)
        modules.append(CommonModule(prefix, header(title, (), used) + imports + body, names,
                                    frozenset(module_names(body))))
    return tuple(modules)


def assemble(system, prefix: str, title: str, kernels: tuple[str, ...], constants: dict,
             bodies: list[tuple[str, str]], layers=()) -> EngineModules:
    """The common modules of ``layers`` (:func:`common_modules`), and the engine module (its file
    named by ``prefix``): the system's kernel source, the :func:`header`, the imports of every
    public name of the common modules, and each ``(name, text)`` of ``bodies`` under a
    ``# ---- name ----`` line.

    ValueError if the kernel source binds a name the engine binds or imports too (other than the
    shared imports and the ``kernels`` it wraps): one would silently change the other; and if the
    engine's header or bodies bind a name a common module exports: the common module's own
    callers would not see it (a closing section such as the kinetic one rebinds only engine
    functions).
    """
    common = common_modules(layers, constants)
    top = header(title, kernels, constants)
    own = "".join(f"\n\n# ---- {name} ----\n{text}" for name, text in bodies)
    imports = "".join(f"\n\n# ---- {', '.join(m.templates)} (compiled in the common module {m.name}) ----\n"
                      + import_lines(m.name, m.exports) for m in common)
    engine = top + imports + own
    clash = (module_names(system.kernel_source) & module_names(engine)) - {"math", "np", "numpy", *kernels}
    if clash:
        raise ValueError(
            f"system {system.name!r}: its kernel source defines {sorted(clash)} at module level, "
            "names the engine uses for its own constants; rename them in the kernel source"
        )
    exported = set().union(*(m.exports for m in common))
    rebound = module_names(top + own) & exported
    if rebound:
        raise ValueError(f"the engine module binds {sorted(rebound)}, names of its common modules, whose own "
                         "functions would not see the engine's; rename them, or move the template into the engine")
    pasted = "".join(f"\n\n# ---- {name} ----\n{template(name)}" for m in common for name in m.templates)
    return EngineModules(prefix, common, system.kernel_source + engine, system.kernel_source + top + pasted + own)


def load_modules(modules: EngineModules) -> types.ModuleType:
    """Load the common modules of ``modules``, each after those it imports, then the engine module;
    return the engine module.

    A common module is imported under its :attr:`CommonModule.name`, the name the engine's text
    gives (the same name in every process: its text alone makes it).
    """
    loaded = []
    for common in modules.common:
        module = load_generated_module(common.text, common.prefix, tuple(loaded))
        if module.__name__ != common.name:  # its file taken by the same text under another prefix: never made here
            raise RuntimeError(f"common module {common.name} was loaded as {module.__name__}")
        loaded.append(module)
    return load_generated_module(modules.engine, modules.prefix, tuple(loaded))


def engine_modules(system, scheme: str, lanes: int, order: int | None = None, entry: str = "process") -> EngineModules:
    """The texts of the generated engine (see the module docstring).

    ``entry``: the driver function the module is built for, a key of ``DRIVERS``. Only the LD
    driver ``process`` passes a scheme's run-time coefficients; ValueError for another entry of a
    scheme that has some.
    """
    if entry != "process" and get_scheme(scheme).coefficients().size:
        raise ValueError(f"scheme {scheme!r} has run-time coefficients, which only the LD driver passes; "
                         f"{entry!r} cannot run it")
    parts = scheme_source(scheme, system, lanes, order)
    constants = {
        **parts.layout.constants(),
        "ADAPTIVE": parts.adaptive,
        "SELF_SIZED": parts.self_sized,
        "ORDER": parts.order,
        **parts.constants,
        **KINDS,
    }
    bodies = [(name, template(name)) for name in ENGINE_TEMPLATES + parts.templates]
    if parts.source:
        bodies.append((f"{scheme} step (generated by ldpipe.engine.schemes)", parts.source))
    bodies += [(name, template(name)) for name in DRIVERS[entry]]
    kinetic = kinetic_source(system)
    if kinetic:
        bodies.append(("kinetic matrix (generated by ldpipe.engine.kinetic)", kinetic))
    # the variant without the order: schemes sharing a module share its text
    title = f"ldpipe.engine: scheme {get_scheme(scheme).variant()!r}, {lanes} lanes (generated by ldpipe.engine.codegen)"
    prefix = engine_name(system.name, scheme, lanes, order, entry)
    return assemble(system, prefix, title, KERNELS, constants, bodies, COMMON_LAYERS)


def engine_source(system, scheme: str, lanes: int, order: int | None = None, entry: str = "process") -> str:
    """The text of the generated engine module (:func:`engine_modules`' ``engine``)."""
    return engine_modules(system, scheme, lanes, order, entry).engine


def engine_name(system_name: str, scheme: str, lanes: int, order: int | None = None, entry: str = "process") -> str:
    """What an engine module is compiled for, e.g. ``engine_barbanis_2dof_taylor13_64``: its file name's start.

    The scheme's record names its variant (:meth:`~ldpipe.engine.schemes.Scheme.variant`): schemes
    that share a module share its name (``engine_barbanis_2dof_composition_64`` for sym4 and sym6).
    """
    variant = get_scheme(scheme).variant(order)
    kind = "engine" if entry == "process" else "flow"
    return f"{kind}_{system_name}_{variant}_{lanes}"


def engine_compiled(system, scheme: str, lanes: int, order: int | None = None, entry: str = "process") -> bool:
    """Whether numba's disk cache already holds this engine's entry function, so that loading it
    compiles nothing (:func:`ldpipe.jitcache.compiled_in_cache`; False where that cannot tell)."""
    return compiled_in_cache(engine_modules(system, scheme, lanes, order, entry).engine, entry)


def load_engine(system, scheme: str, lanes: int, order: int | None = None, entry: str = "process") -> types.ModuleType:
    """Import the generated engine module, and its common modules first (compiled lazily, on first
    call, or loaded from disk)."""
    return load_modules(engine_modules(system, scheme, lanes, order, entry))
