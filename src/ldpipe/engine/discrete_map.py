"""The engine path of a discrete map x_{n+1} = f(x_n) (:class:`ldpipe.systems.DiscreteMapSystem`).

A map is iterated, not integrated: no scheme, no step control, no quadrature. The generated
module is the system's kernel source (``step``, and ``inverse`` when the map has one), a header
(the state's dimension ``N`` and the coordinates' periods ``PERIODS``), and the template
``map_driver`` (``map_process``: the orbits of a unit of starts and their LD), assembled by
:func:`ldpipe.engine.codegen.assemble` as the flow engine's module is, loaded through
:mod:`ldpipe.jitcache` so numba's disk cache serves later processes, and run over units of
starts on every thread (:func:`ldpipe.engine.integrator.run_units`; the driver releases the GIL).

A compiled loop, not numpy over the whole grid: a step of the Hénon map is a few flops, and
numpy passes over the grid's arrays once per operation per iteration; on a 1000 x 1000 grid
the loop takes a seventh of numpy's CPU time (``benchmarks/map_ld.py``, ``benchmarks/HISTORY.md``).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .codegen import assemble, load_modules, template
from .integrator import kept_runner, run_units

ENTRY = "map_process"
#: The fast Lyapunov indicator's driver, in the same module.
FLI_ENTRY = "map_fli"
# What a map without an inverse gives in its place: never called (the core refuses a backward
# half first, naming the entry's inverse key), but the driver's source names it.
NO_INVERSE = '''
@njit(**JIT)
def inverse(state, out):
    raise ValueError("this map has no inverse")
'''


class MapLDResult(NamedTuple):
    """One half of the discrete LD of each start (arrays over the starts)."""

    #: sum over the iterations held of sum_i |x^i_{n+1} - x^i_n|^p.
    ld: np.ndarray
    #: Iterations the sum holds: all of them, or those before the orbit escaped.
    iterations: np.ndarray
    #: The orbit left the escape radius, or an iterate was not finite.
    escaped: np.ndarray
    #: The last iterate inside (periodic coordinates in [0, period)).
    end_state: np.ndarray


def map_modules(system):
    """The texts of the generated module of ``system``'s iteration (see the module docstring)."""
    kernels = ("step", "inverse", "jacobian") if system.has_inverse else ("step", "jacobian")
    constants = {"N": system.n_state, "PERIODS": np.asarray(system.periods, dtype=float)}
    bodies = [] if system.has_inverse else [("no inverse", NO_INVERSE)]
    bodies += [("map_driver", template("map_driver")), ("map_tangent", template("map_tangent"))]
    title = f"ldpipe.engine.discrete_map: {system.n_state} coordinates"
    return assemble(system, f"map_engine_{system.engine_name}", title, kernels, constants, bodies)


def get_map_runner(system, entry: str = ENTRY):
    """``map_process`` (or ``map_fli``) for ``system``, kept per live system (compiled lazily, or
    loaded from disk)."""
    if entry not in (ENTRY, FLI_ENTRY):
        raise ValueError(f"entry: expected {ENTRY!r} or {FLI_ENTRY!r}, got {entry!r}")
    return kept_runner(system, ("discrete_map", entry), lambda: getattr(load_modules(map_modules(system)), entry))


def state_rows(system, states: np.ndarray) -> np.ndarray:
    """``states`` as the runners take them, one contiguous float64 row per orbit; a ValueError
    unless each row holds the map's ``n_state`` coordinates."""
    states = np.ascontiguousarray(states, dtype=np.float64)
    if states.ndim != 2 or states.shape[1] != system.n_state:
        raise ValueError(f"states: expected shape (N, {system.n_state}) with rows {system.coordinates} for "
                         f"{system.name}, got {states.shape}")
    return states


def iterate_map_ld(system, states: np.ndarray, iterations: int, p: float, direction: int,
                   escape_radius: float) -> MapLDResult:
    """One half of the discrete LD (Lopesino et al. 2015) of each row of ``states``: ``iterations``
    iterations forward (``direction`` 1) or backward (-1, the map's inverse), with the p-norm's
    exponent ``p`` (> 0), the orbit stopped where it escapes ``escape_radius`` (see
    :class:`MapLDResult`)."""
    from numba import get_num_threads

    if direction not in (1, -1):
        raise ValueError(f"direction: expected 1 or -1, got {direction!r}")
    if not p > 0:
        raise ValueError(f"p: expected a positive exponent, got {p!r}")
    if direction == -1:
        system.require_inverse("the backward half of the LD")
    states = state_rows(system, states)
    count, n = states.shape
    outputs = (np.zeros(count), np.zeros(count, dtype=np.int64), np.zeros(count, dtype=np.bool_),
               np.zeros((count, n)))
    if count:
        threads = get_num_threads()
        args = (int(iterations), float(p), float(escape_radius), direction == -1)
        run_units(get_map_runner(system), states, max(1, min(4096, count // (8 * threads) or 1)), args, outputs,
                  threads)
    return MapLDResult(*outputs)


def fast_lyapunov_indicator(system, states: np.ndarray, iterations: int, escape_radius: float) -> tuple[np.ndarray,
                                                                                                       np.ndarray]:
    """The fast Lyapunov indicator max_{n <= N} log10 |w_n| of each row of ``states`` over
    ``iterations`` iterations of the tangent map (see the template ``map_tangent``), and whether
    the orbit escaped ``escape_radius`` first: ``(fli, escaped)``."""
    from numba import get_num_threads

    states = state_rows(system, states)
    count = states.shape[0]
    outputs = (np.zeros(count), np.zeros(count, dtype=np.bool_))
    if count:
        threads = get_num_threads()
        run_units(get_map_runner(system, FLI_ENTRY), states, max(1, min(1024, count // (8 * threads) or 1)),
                  (int(iterations), float(escape_radius)), outputs, threads)
    return outputs
