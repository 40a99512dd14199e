"""The batched trajectory + Lagrangian descriptor engine.

>>> from ldpipe.engine import LDSettings, compute_ld
>>> result = compute_ld(system, states, direction=+1, settings=LDSettings(scheme="dop853"))

Modules, one job each:

- :mod:`~ldpipe.engine.settings` — :class:`LDSettings` and its parts (integrator, descriptor,
  stopping rules), validated numerical choices, every default stated once;
- :mod:`~ldpipe.engine.schemes` — the integration schemes, one module each, and their
  registry ``SCHEMES`` (DOP853 generated with its tableau as literals, the Taylor series);
- :mod:`ldpipe.engine.schemes.tableaux` — coefficients of the schemes;
- :mod:`~ldpipe.engine.stepping` — the block workspace layout (structure of arrays, per-lane h)
  and what the code generator needs of a scheme;
- :mod:`~ldpipe.engine.integrands` — the LD integrands (p = 1/2, 1, general p, arc length) and
  their registry;
- :mod:`~ldpipe.engine.gauss_rules` — the Gauss rules of the LD quadrature (the quadrature itself
  is compiled, in the templates);
- :mod:`~ldpipe.engine.templates` — the compiled code as source templates: the LD integral over
  a step (cusps of |v|^p included), region exit and escape events, the fixed-step schemes,
  the block driver (lane refill, step control), and the driver of :mod:`ldpipe.core.trajectories` (samples,
  section crossings, escapes) on the same DOP853 step;
- :mod:`~ldpipe.engine.codegen` — joins the system's kernel source, the compile-time constants
  and the templates into one module, which imports the LD quadrature from common modules shared
  by every engine of one shape, all loaded through :mod:`ldpipe.jitcache` so that numba's
  on-disk cache serves the next process (``python -m ldpipe.engine.codegen --dump`` prints them);
- :mod:`~ldpipe.engine.vector_field` — the flow engine's module for a general vector field,
  assembled the same way;
- :mod:`~ldpipe.engine.integrator` — compiled runners per system (of both engines), and the
  thread pool over units;
- :mod:`~ldpipe.engine.api` — :func:`compute_ld` and :class:`LDResult`.
"""

import numbers

from ..errors import ConfigError
from .schemes import SCHEMES
from .settings import DEFAULT_ESCAPE_RADIUS, DescriptorSettings, IntegratorSettings, LDSettings, StoppingRules

__all__ = [
    "DEFAULT_ESCAPE_RADIUS", "DescriptorSettings", "IntegratorSettings", "LDResult", "LDSettings", "SCHEMES",
    "StoppingRules", "compute_ld", "use_threads",
]


def use_threads(threads: int | None) -> None:
    """Let the engine run on ``threads`` threads, at most numba's (None or 0: leave them as they are);
    a ConfigError naming ``threads`` for a negative or fractional count (numba's own ValueError
    would come from deep inside a run)."""
    if threads is not None and (isinstance(threads, bool) or not isinstance(threads, numbers.Integral)
                                or threads < 0):
        raise ConfigError(f"threads: expected a whole number of threads, 1 or more (0 or None: every core), "
                          f"got {threads!r}")
    if threads:
        import numba  # here, where the engine runs: a job that only reads files never loads it

        numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))


def __getattr__(name: str):
    # compute_ld and LDResult bring numba and the code generator: imported on first use, so that
    # a job reading only settings or schemes (a figure, a gather) starts without them.
    if name in ("LDResult", "compute_ld"):
        from . import api  # a static import, so that ldpipe.io.provenance counts api.py among a stage's sources

        return getattr(api, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
