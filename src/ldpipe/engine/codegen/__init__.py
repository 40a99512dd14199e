"""Assemble the engine's compiled code for one (system, scheme, lanes) and load it.

The generated module is, in this order:

1. the system's kernel source (``System.kernel_source``: ``potential``, ``gradient``,
   ``acceleration_block``, ... undecorated, with the parameters as module constants);
2. a header: imports, the numba options ``JIT`` (with ``cache=True``), the kernels wrapped in
   ``njit``, and every compile-time constant of the block (sizes, workspace offsets, scheme
   data, integrand kinds) as an upper-case module global;
3. the templates of :mod:`ldpipe.engine.templates` (quadrature, block quadrature, flag checks, events, the
   scheme's own, the driver) and the generated DOP853 step, if that is the scheme;
4. for a system with masses only, the kinetic section of :mod:`ldpipe.engine.kinetic`.

Two drivers can be assembled on the same step: ``process`` (the LD driver, ``driver.py``) and
``flow_process`` (samples, section crossings and escapes for :mod:`ldpipe.flow`,
``flow_driver.py``, which loads lanes with ``driver.py``'s ``load_lane``); both take the step
control of ``step_control.py``. ``DRIVERS`` lists the templates each needs.

The flow engine's module (:mod:`ldpipe.engine.vector_field`) is assembled by the same
:func:`assemble` (kernel source, :func:`header`, templates, the name-clash check).
``python -m ldpipe.engine.codegen --dump SYSTEM SCHEME`` prints either (``__main__.py``).

It is loaded by :func:`ldpipe.jitcache.load_generated_module`, which names the file by the
hash of this text: a second process with the same system, scheme and block size finds the
file and numba's cache beside it, and loads machine code instead of compiling. Any change to
a template, the kernels or a constant changes the hash, so a stale cache is never used.
"""

from __future__ import annotations

import ast
import types
from importlib import resources

import numpy as np

from ...jitcache import load_generated_module
from .. import templates
from ..integrands import KINDS
from ..kinetic import kinetic_source
from ..schemes import get_scheme, scheme_source

COMMON_TEMPLATES = ("quadrature", "block_arclength", "block_quadrature", "flag_checks", "events", "block_two_roots",
                    "block_dips", "step_control")
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


def assemble(system, title: str, kernels: tuple[str, ...], constants: dict, bodies: list[tuple[str, str]]) -> str:
    """The system's kernel source, then the :func:`header`, then each ``(name, text)`` of ``bodies``
    under a ``# ---- name ----`` line: the text of a generated engine module.

    ValueError if the kernel source binds a name the engine binds too (other than the shared
    imports and the ``kernels`` it wraps): one would silently change the other.
    """
    engine = header(title, kernels, constants) + "".join(f"\n\n# ---- {name} ----\n{text}" for name, text in bodies)
    clash = (module_names(system.kernel_source) & module_names(engine)) - {"math", "np", "numpy", *kernels}
    if clash:
        raise ValueError(
            f"system {system.name!r}: its kernel source defines {sorted(clash)} at module level, "
            "names the engine uses for its own constants; rename them in the kernel source"
        )
    return system.kernel_source + engine


def engine_source(system, scheme: str, lanes: int, order: int | None = None, entry: str = "process") -> str:
    """The full text of the generated engine module (see the module docstring).

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
    bodies = [(name, template(name)) for name in COMMON_TEMPLATES + parts.templates]
    if parts.source:
        # (The comment's text is part of the cache key; the generators now live in ldpipe.engine.schemes.)
        bodies.append((f"{scheme} step (generated by ldpipe.engine.stepping)", parts.source))
    bodies += [(name, template(name)) for name in DRIVERS[entry]]
    kinetic = kinetic_source(system)
    if kinetic:
        bodies.append(("kinetic matrix (generated by ldpipe.engine.kinetic)", kinetic))
    # the variant without the order: schemes sharing a module share its text
    title = f"ldpipe.engine: scheme {get_scheme(scheme).variant()!r}, {lanes} lanes (generated by ldpipe.engine.codegen)"
    return assemble(system, title, KERNELS, constants, bodies)


def engine_name(system_name: str, scheme: str, lanes: int, order: int | None = None, entry: str = "process") -> str:
    """What an engine module is compiled for, e.g. ``engine_barbanis_2dof_taylor13_64``: its file name's start.

    The scheme's record names its variant (:meth:`~ldpipe.engine.schemes.Scheme.variant`): schemes
    that share a module share its name (``engine_barbanis_2dof_composition_64`` for sym4 and sym6).
    """
    variant = get_scheme(scheme).variant(order)
    kind = "engine" if entry == "process" else "flow"
    return f"{kind}_{system_name}_{variant}_{lanes}"


def load_engine(system, scheme: str, lanes: int, order: int | None = None, entry: str = "process") -> types.ModuleType:
    """Import the generated engine module (compiled lazily, on first call, or loaded from disk)."""
    return load_generated_module(engine_source(system, scheme, lanes, order, entry),
                                 engine_name(system.name, scheme, lanes, order, entry))
