"""The symplectic compositions ``sym4`` and ``sym6`` (template ``templates/composition.py``).

Compositions of the kick-drift-kick Störmer–Verlet map with the weights of
:mod:`ldpipe.engine.schemes.tableaux`: Suzuki's fourth-order five-stage composition (5 forces per step) and
Yoshida's triple jump of it (sixth order, 15 forces per step). One class, one record per set
of weights. Dense output as for rk4: the quintic Hermite interpolant (``templates/hermite.py``).
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
        weights = np.array(self.weights, dtype=np.float64)
        return SchemeSource(
            Layout.build(system.n_dof, lanes, 6, 0),
            False,
            self.order,
            templates=("hermite", "composition"),
            constants={"N_SUB": len(weights), "GAMMAS": weights},
        )


SYM4 = Composition(
    name="sym4", order=4, weights=tableaux.SUZUKI4, ladder=(0.2, 0.1, 0.05, 0.02, 0.01),
    description="symplectic, Suzuki's 4th-order composition of Stormer-Verlet, fixed step (dt)",
)
SYM6 = Composition(
    name="sym6", order=6, weights=tableaux.YOSHIDA6, ladder=(0.4, 0.2, 0.1, 0.05, 0.02),
    description="symplectic, Yoshida's 6th-order triple jump of sym4, fixed step (dt)",
)
