"""The LD integrands (descriptor kinds), one record each, and the registry that names them.

The Lagrangian descriptor integrates, over each step, either sum_c |x'_c|^p over the 2 n_dof
phase-space velocity components (``p`` in (0, 1]) or the phase-space arc length ||x'||
(``p = "arclength"``). The compiled quadrature (``templates/quadrature.py``,
``templates/block_quadrature.py``, ``templates/driver.py``) branches on a run-time *kind*
whose values are compile-time constants of the generated module (``KIND_HALF``, ...;
:data:`KINDS`): p = 1/2 takes sqrt in the hot path, p = 1 a kink (only sign changes need
cutting), a general p |v|**p, and the arc length sqrt(sum v_c^2) with no per-component cusp
pass. :func:`integrand_for` picks the record for a ``p`` (validating it); everything else
(``compute_ld``'s arguments, the Taylor scheme's order and nodes, stage attributes, figure
captions) reads the record.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

#: The value of ``p`` that asks for the phase-space arc length.
ARCLENGTH = "arclength"


@dataclass(frozen=True)
class Integrand:
    """One kind of LD integrand.

    ``kind`` is its compile-time constant (named ``constant`` in the generated module);
    ``exponent`` the fixed p the compiled code uses for it, or None when it takes the
    settings' p (the general power).
    """

    name: str
    constant: str
    kind: int
    exponent: float | None
    description: str

    def p_exponent(self, p) -> float:
        """The exponent passed to the compiled quadrature for ``p``."""
        return self.exponent if self.exponent is not None else float(p)


#: The registry: integrand name -> record; the kinds' values are the compile-time constants.
INTEGRANDS: dict[str, Integrand] = {
    "half": Integrand("half", "KIND_HALF", 0, 0.5, "M_p with p = 1/2: sqrt in the hot path"),
    "one": Integrand("one", "KIND_ONE", 1, 1.0, "M_p with p = 1: |v| (a kink, not a cusp: only sign changes cut)"),
    "power": Integrand("power", "KIND_POW", 2, None, "M_p with a general 0 < p < 1: |v|**p"),
    # no per-component cusp: the driver skips the quadrature's special pass for it
    ARCLENGTH: Integrand(ARCLENGTH, "KIND_ARCLENGTH", 3, 1.0, "the phase-space arc length ||x'||"),
}

#: The compile-time constants of the kinds, by the names the compiled code uses.
KINDS: dict[str, int] = {record.constant: record.kind for record in INTEGRANDS.values()}


def is_arclength(p) -> bool:
    """Whether ``p`` asks for the arc length."""
    return isinstance(p, str) and p == ARCLENGTH


def check_p(p) -> float | str:
    """``p`` validated: a number in (0, 1] (as float) or ``"arclength"``; ValueError naming ``p``."""
    message = f"p: expected a number in (0, 1] or {ARCLENGTH!r}, got {p!r}"
    if isinstance(p, str):
        if p != ARCLENGTH:
            raise ValueError(message)
        return p
    if isinstance(p, bool) or not isinstance(p, (int, float)):
        raise ValueError(f"p: expected a number, got {p!r}")
    value = float(p)
    if not math.isfinite(value) or value <= 0.0:
        raise ValueError(f"p: expected a finite number > 0, got {p!r}")
    if value > 1.0:
        raise ValueError(message)
    return value


def integrand_for(p) -> Integrand:
    """The record of the integrand ``p`` asks for (validated as by :func:`check_p`)."""
    p = check_p(p)
    if is_arclength(p):
        return INTEGRANDS[ARCLENGTH]
    if p == 0.5:
        return INTEGRANDS["half"]
    if p == 1.0:
        return INTEGRANDS["one"]
    return INTEGRANDS["power"]


def caption(p, number=lambda value: format(float(value), "g")) -> str:
    """``p`` as figure captions say it: "arc length" or "p = 0.5" (``number`` formats the value)."""
    return "arc length" if is_arclength(p) else f"p = {number(p)}"


def descriptor_attribute(p) -> str:
    """``p`` as the ``descriptor`` attribute of an LD stage file: "arclength" or "M_p, p = 0.5"."""
    return ARCLENGTH if is_arclength(p) else f"M_p, p = {p}"
