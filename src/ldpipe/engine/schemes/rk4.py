"""The ``rk4`` scheme: classical fixed-step Runge–Kutta (template ``templates/rk4.py``).

Its dense output is the quintic Hermite interpolant of q through (q, p, a) at both ends of the
step (``templates/hermite.py``).
"""

from __future__ import annotations

from dataclasses import dataclass

from ..stepping import Layout, SchemeSource
from .base import FixedStepScheme


@dataclass(frozen=True)
class RK4(FixedStepScheme):
    """The classical 4th-order Runge–Kutta method with a fixed step."""

    def source(self, system, lanes: int, order: int | None = None) -> SchemeSource:
        return SchemeSource(Layout.build(system.n_dof, lanes, 6, 4), False, self.order, templates=("hermite", "rk4"))


RK4_SCHEME = RK4(
    name="rk4",
    description="classical Runge-Kutta, fixed step (dt)",
    order=4,
    ladder=(0.2, 0.1, 0.05, 0.02, 0.01),
)
