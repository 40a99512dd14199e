"""The symplectic compositions ``sym4`` and ``sym6`` (template ``templates/composition.py``).

Compositions of the kick-drift-kick Störmer–Verlet map with the weights of
:mod:`ldpipe.engine.schemes.tableaux`: Suzuki's fourth-order five-stage composition (5 forces per step) and
Yoshida's triple jump of it (sixth order, 15 forces per step). One class, one record per set
of weights. Dense output as for rk4: the quintic Hermite interpolant (``templates/hermite.py``).

The weights are run-time coefficients (:meth:`Composition.coefficients`), not compiled in: every
composition of a system shares one engine module, ``engine_<system>_composition_<lanes>``.
Measured against weights compiled in (benchmarks/accuracy_ladder.md): the same LDs bit for bit,
and a throughput difference within the 3 % that would pay for a module per composition.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import tableaux
from ..stepping import Layout, SchemeSource
from .base import FixedStepScheme


@dataclass(frozen=True)
class Composition(FixedStepScheme):
    """A symmetric composition of Störmer–Verlet with ``weights`` (summing to 1), fixed step."""

    weights: tuple[float, ...] = ()

    def __post_init__(self):
        # The record holds plain floats (hashable, printable) whatever sequence the tableau is.
        object.__setattr__(self, "weights", tuple(float(w) for w in self.weights))

    def source(self, system, lanes: int, order: int | None = None) -> SchemeSource:
        # The module is the same text for every composition, so its ORDER (read by adaptive step
        # control only) is that of the Stormer-Verlet map they compose, not a composition's own.
        return SchemeSource(Layout.build(system.n_dof, lanes, 6, 0), False, 2, templates=("hermite", "composition"))

    def coefficients(self) -> np.ndarray:
        """The weights of the sub-steps, in order."""
        return np.array(self.weights, dtype=np.float64)

    def variant(self, order: int | None = None) -> str:
        return "composition"


SYM4 = Composition(
    name="sym4", order=4, weights=tableaux.SUZUKI4, ladder=(0.2, 0.1, 0.05, 0.02, 0.01),
    description="symplectic, Suzuki's 4th-order composition of Stormer-Verlet, fixed step (dt)",
)
SYM6 = Composition(
    name="sym6", order=6, weights=tableaux.YOSHIDA6, ladder=(0.4, 0.2, 0.1, 0.05, 0.02),
    description="symplectic, Yoshida's 6th-order triple jump of sym4, fixed step (dt)",
)
