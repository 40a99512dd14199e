"""The integration schemes of the LD engine, one module each, and the registry that names them.

Modelled on scipy's ``solve_ivp`` (``METHODS = {'RK23': RK23, ...}``): :data:`SCHEMES` maps
each name to its record (:class:`~ldpipe.engine.schemes.base.Scheme`: adaptive or fixed step,
order, the settings it uses, its quadrature defaults, the system it needs, its source builder,
a description). Everything that needs to know about schemes reads it: ``LDSettings``
validation, the code generator, the CLI's help, the accuracy ladders, the accuracy figure's
styles, the captions; ``tests/engine/test_registry.py`` checks the config schema (a static
file) against it.

Adding a scheme is one module here (a record, with its source builder) and one line below;
then its name in the schema's enums and ladder (the test names what is missing).
"""

from __future__ import annotations

from ..stepping import SchemeSource
from .base import AdaptiveScheme, FixedStepScheme, Scheme
from .composition import SYM4, SYM6
from .dop853 import DOP853
from .rk4 import RK4_SCHEME
from .taylor import TAYLOR

#: The registry: scheme name -> record, in the order the help texts and figures list them.
SCHEMES: dict[str, Scheme] = {
    "dop853": DOP853,
    "taylor": TAYLOR,
    "rk4": RK4_SCHEME,
    "sym4": SYM4,
    "sym6": SYM6,
}


def get_scheme(name: str) -> Scheme:
    """The record of scheme ``name``; ValueError naming the registered schemes if there is none."""
    try:
        return SCHEMES[name]
    except (KeyError, TypeError):
        raise ValueError(f"scheme: unknown scheme {name!r}; expected one of {list(SCHEMES)}") from None


def scheme_source(scheme: str, system, lanes: int, order: int | None = None) -> SchemeSource:
    """The compiled parts of ``scheme`` for ``system`` and ``lanes`` lanes.

    ``order``: the order of a scheme that chooses it per call (taylor; required for it,
    ignored by the others). ValueError if the scheme cannot integrate the system (taylor: a
    system without a formula; ConfigError for a term with no Taylor recurrence, such as Abs's sign).
    """
    record = get_scheme(scheme)
    check_scheme(record, system)
    return record.source(system, lanes, order)


def check_scheme(record: Scheme, system) -> None:
    """Raise ValueError, saying why, if scheme ``record`` cannot integrate ``system``: a general
    vector field (no Hamiltonian) only with the schemes of general flows, which it names, and
    whatever the scheme itself refuses (:meth:`Scheme.check_system`)."""
    if not system.hamiltonian and not record.general_flow:
        able = [s.name for s in SCHEMES.values() if s.general_flow]
        raise ValueError(
            f"scheme {record.name!r} cannot integrate system {system.name!r}: it is a general vector field "
            f"(no Hamiltonian), which only the schemes {able} integrate"
        )
    record.check_system(system)


__all__ = ["AdaptiveScheme", "FixedStepScheme", "SCHEMES", "Scheme", "check_scheme", "get_scheme", "scheme_source"]
