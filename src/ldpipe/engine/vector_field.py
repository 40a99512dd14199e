"""The engine path of a general flow dx/dt = f(x, t) (:class:`ldpipe.systems.VectorFieldSystem`).

The generated module is the system's ``rhs`` source, a header (the tableau of DOP853 as
arrays, the state dimension, the integrand kinds), the import of the Hamiltonian engine's
common module ``quadrature`` (the same LD quadrature, compiled once for every engine of either
kind), and the templates ``events`` (the same event location), ``step_control`` and
``flow_status`` (the Hamiltonian drivers' step control and flow outcomes) and
``vector_field_driver`` (first-order DOP853, one trajectory at a time, see its docstring),
assembled by :func:`ldpipe.engine.codegen.assemble` as the Hamiltonian engine is. ``events``
stays in the module: it reads the state's dimension, and it is small.
Only schemes whose record says ``general_flow`` take this path (today: dop853).

The flow map alone (``vector_field_endpoints``: end states, no LD) is a second module, the same
text with that template appended, so adding it left the LD module's text and cache as they were.

A system whose LD is not taken in its state's units (velocity data on the sphere: kilometres
and the data's velocity units, not degrees) gives the section that says how
(``ld_metric_source``); it closes the LD module, rebinding what the LD reads. Every other system
gives none, and its module's text is what it was without it; the flow map's module has no LD and
takes none.
"""

from __future__ import annotations

import numpy as np

from .schemes import tableaux
from .codegen import COMMON_LAYERS, EngineModules, assemble, load_modules, template
from .integrands import KINDS
from .integrator import kept_runner

TEMPLATES = ("events", "step_control", "flow_status", "vector_field_driver")
LAYERS = COMMON_LAYERS[:1]  # the quadrature
NC = 8  # coefficients of the dense output (degree 7) and of its derivative
#: The driver functions of the generated module: LDs, and section crossings (ldpipe.core.trajectories).
ENTRIES = ("vector_field_process", "vector_field_crossings")
#: The flow map's driver (ldpipe.core.trajectories.flow_map), in the module with its template appended.
ENDPOINTS = "vector_field_endpoints"
KERNELS = ("rhs",)


def engine_dimension(system) -> int:
    """The number of components the engine integrates: the system's ``engine_dimension`` where it
    integrates its states in another form (velocity data round a pole: 3-D Cartesian positions on
    the sphere, :meth:`engine_states`), else its state variables' count."""
    return int(getattr(system, "engine_dimension", system.n_state))


def vector_field_modules(system, extra: tuple[str, ...] = ()) -> EngineModules:
    """The texts of the generated module for ``system`` (see the module docstring) and of its
    common module, with the templates ``extra`` appended."""
    constants = {
        "N": engine_dimension(system),
        "NC": NC,
        "ORDER": tableaux.DOP853_ORDER,
        **KINDS,
        "A": np.atleast_2d(tableaux.A),
        "C": np.asarray(tableaux.C, dtype=float),
        "E3": np.asarray(tableaux.E3, dtype=float),
        "E5": np.asarray(tableaux.E5, dtype=float),
        "G": np.atleast_2d(tableaux.DOP853_DENSE),
    }
    title = f"ldpipe.engine.vector_field: dop853, {engine_dimension(system)} state variables"
    bodies = [(name, template(name)) for name in TEMPLATES + extra]
    if system.ld_metric_source and ENDPOINTS not in extra:  # the flow map alone has no LD to take a metric
        bodies.append(("the LD's metric (given by the system)", system.ld_metric_source))
    prefix = f"vfield_{'endpoints' if ENDPOINTS in extra else 'engine'}_{system.engine_name}"
    return assemble(system, prefix, title, KERNELS, constants, bodies, LAYERS)


def get_vector_field_runner(system, entry: str = "vector_field_process"):
    """The driver ``entry`` (one of :data:`ENTRIES`, or :data:`ENDPOINTS`) for ``system``, kept
    per live system (compiled lazily, or loaded from disk)."""
    if entry not in ENTRIES + (ENDPOINTS,):
        raise ValueError(f"entry: expected one of {ENTRIES + (ENDPOINTS,)}, got {entry!r}")

    def build():
        return getattr(load_modules(vector_field_modules(system, (ENDPOINTS,) if entry == ENDPOINTS else ())), entry)

    return kept_runner(system, ("vector_field", entry), build)
