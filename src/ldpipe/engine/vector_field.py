"""The engine path of a general flow dx/dt = f(x, t) (:class:`ldpipe.systems.VectorFieldSystem`).

The generated module is the system's ``rhs`` source, a header (the tableau of DOP853 as
arrays, the state dimension, the integrand kinds) and the templates ``quadrature`` and
``events`` (the same LD quadrature and event location as the Hamiltonian engine),
``step_control`` and ``flow_status`` (the Hamiltonian drivers' step control and flow outcomes) and
``vector_field_driver`` (first-order DOP853, one trajectory at a time, see its docstring).
Only schemes whose record says ``general_flow`` take this path (today: dop853).
"""

from __future__ import annotations

import re
import threading
import weakref

import numpy as np

from .. import tableaux
from ..jitcache import load_generated_module
from .codegen import JIT_OPTIONS, _literal, _module_names, template
from .integrands import KINDS

TEMPLATES = ("quadrature", "events", "step_control", "flow_status", "vector_field_driver")
NC = 8  # coefficients of the dense output (degree 7) and of its derivative
_RUNNERS: dict[tuple[int, str], tuple[weakref.ref, object]] = {}
#: The driver functions of the generated module: LDs, and section crossings (ldpipe.flow).
ENTRIES = ("vector_field_process", "vector_field_crossings")
_LOCK = threading.Lock()


def _array_literal(matrix: np.ndarray) -> str:
    rows = ", ".join("[" + ", ".join(repr(float(v)) for v in row) + "]" for row in np.atleast_2d(matrix))
    return f"np.array([{rows}])"


def vector_field_source(system) -> str:
    """The full text of the generated module for ``system`` (see the module docstring)."""
    constants = {"N": system.n_state, "NC": NC, "ORDER": tableaux.DOP853_ORDER, **KINDS}
    lines = [
        "",
        "",
        f"# ---- ldpipe.engine.vector_field: dop853, {system.n_state} state variables ----",
        "import math",
        "",
        "import numpy as np",
        "from numba import njit",
        "",
        f"JIT = {JIT_OPTIONS}",
        "",
        "rhs = njit(**JIT)(rhs)",
        "",
        *(f"{name} = {_literal(value)}" for name, value in constants.items()),
        f"A = {_array_literal(tableaux.A)}",
        f"C = {_literal(np.asarray(tableaux.C, dtype=float))}",
        f"E3 = {_literal(np.asarray(tableaux.E3, dtype=float))}",
        f"E5 = {_literal(np.asarray(tableaux.E5, dtype=float))}",
        f"G = {_array_literal(tableaux.DOP853_DENSE)}",
    ]
    engine = "\n".join(lines) + "\n" + "".join(f"\n\n# ---- {name} ----\n{template(name)}" for name in TEMPLATES)
    clash = (_module_names(system.kernel_source) & _module_names(engine)) - {"math", "np", "numpy", "rhs"}
    if clash:
        raise ValueError(f"system {system.name!r}: its kernel source defines {sorted(clash)}, names the engine uses")
    return system.kernel_source + engine


def get_vector_field_runner(system, entry: str = "vector_field_process"):
    """The driver ``entry`` (one of :data:`ENTRIES`) for ``system``, kept per live system
    (compiled lazily, or loaded from disk)."""
    if entry not in ENTRIES:
        raise ValueError(f"entry: expected one of {ENTRIES}, got {entry!r}")
    key = (id(system), entry)
    with _LOCK:
        cached = _RUNNERS.get(key)
        if cached is not None and cached[0]() is system:
            return cached[1]
        prefix = re.sub(r"\W", "_", f"vfield_engine_{system.name}")
        runner = getattr(load_generated_module(vector_field_source(system), prefix=prefix), entry)
        _RUNNERS[key] = (weakref.ref(system, lambda _ref, key=key: _RUNNERS.pop(key, None)), runner)
        return runner
