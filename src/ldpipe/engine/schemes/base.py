"""The record of one integration scheme: what every part of ldpipe needs to know about it.

A scheme is an instance of :class:`AdaptiveScheme` or :class:`FixedStepScheme` (or of a
subclass, for a scheme with rules of its own), registered by name in
:data:`ldpipe.engine.schemes.SCHEMES`. Settings validation, the CLI, the accuracy ladders,
the figures and the captions read the record; the code generator calls :meth:`Scheme.source`.

The methods that pick a default from the other settings take the engine's settings object
(:class:`ldpipe.engine.LDSettings`), of which they read ``rtol``, ``atol``, ``p`` and
``taylor_order``.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ..stepping import SchemeSource


@dataclass(frozen=True)
class Scheme(ABC):
    """One scheme of the LD engine (abstract: a record is an instance of a subclass that gives
    :meth:`nodes`, :meth:`window` and :meth:`source`; the others have defaults).

    Attributes
    ----------
    name : str
        The name in the config (``integrator.scheme``), the CLI (``--scheme``) and stage files.
    description : str
        One line, for help texts and docs.
    order : int or None
        The order of the propagated solution; None when it is chosen per call (see
        :meth:`order_for`).
    ladder : tuple of float
        Default values of the scheme's step parameter (``parameters[0]``: the tolerance of an
        adaptive scheme, the step of a fixed-step one) on the accuracy-cost ladder, loosest first.
    general_flow : bool
        Whether the scheme integrates a general vector field dx/dt = f(x, t)
        (:class:`ldpipe.systems.VectorFieldSystem`; :mod:`ldpipe.engine.vector_field`); the
        others need the (q, p) form of a natural Hamiltonian.
    adaptive : bool (class attribute)
        Per-trajectory step control from ``rtol``/``atol`` (True) or a fixed step ``dt``.
    parameters : tuple of str (class attribute)
        The integrator settings the scheme uses: ``("rtol", "atol")`` or ``("dt",)``.
    """

    name: str
    description: str
    order: int | None
    ladder: tuple[float, ...]
    general_flow: bool = False

    adaptive: ClassVar[bool]
    parameters: ClassVar[tuple[str, ...]]

    def order_for(self, settings) -> int | None:
        """The order in use with ``settings``, when the scheme chooses it per call (else None)."""
        return None

    @abstractmethod
    def nodes(self, settings) -> int:
        """Default Gauss nodes per step of the LD quadrature."""

    def lanes(self, settings) -> int:
        """Default trajectories per block (lanes advanced together): 64."""
        return 64

    @abstractmethod
    def window(self, settings) -> float:
        """Default quadrature window (``templates/block_quadrature.py``'s ``fast``), in step lengths."""

    def check_system(self, system) -> None:
        """Raise ValueError, saying why, if the scheme cannot integrate ``system`` for a reason of
        its own (the default: none). Whether it takes a general flow at all is the registry's
        check, :func:`ldpipe.engine.schemes.check_scheme`, which calls this."""

    @abstractmethod
    def source(self, system, lanes: int, order: int | None = None) -> SchemeSource:
        """The compiled parts of the scheme for ``system`` and ``lanes`` lanes."""

    def coefficients(self) -> np.ndarray:
        """The step's run-time coefficients, which the LD driver puts at the end of the block
        workspace for ``attempt`` (the default: none, every number of the step is compiled in)."""
        return np.zeros(0)

    def variant(self, order: int | None = None) -> str:
        """What an engine module of the scheme compiles, as its name says it: the scheme's name, with
        the ``order`` of a scheme compiled per order (``taylor13``). Schemes whose records return the
        same variant share one module (the same source text)."""
        return self.name if order is None else f"{self.name}{order}"


@dataclass(frozen=True)
class AdaptiveScheme(Scheme):
    """A scheme with per-trajectory step control from ``rtol`` and ``atol``."""

    adaptive: ClassVar[bool] = True
    parameters: ClassVar[tuple[str, ...]] = ("rtol", "atol")

    def window(self, settings) -> float:
        """0.1 step lengths at rtol >= 1e-7, 0.2 at tighter tolerances.

        Measured on the Barbanis 2 DoF benchmark (benchmarks/compare.py, errors against the
        reference): a root at 0.1-0.5 step lengths outside a step changes the LD error of
        dop853 at rtol 1e-4 .. 1e-8 by less than 2 % whether it is cut out or left to
        Gauss–Legendre, but a window of 0.5 sends 3 of the 4 components of every step to
        the slower cusp path at rtol 1e-4 and costs 2.5x the time. At rtol 1e-10 a window
        of 0.1 raised the median error 7x and one of 0.5 the worst 9x, against 0.2.
        """
        return 0.1 if settings.rtol >= 1e-7 else 0.2


@dataclass(frozen=True)
class FixedStepScheme(Scheme):
    """A scheme with a fixed step ``dt`` (the last step shortened to end exactly at tau)."""

    adaptive: ClassVar[bool] = False
    parameters: ClassVar[tuple[str, ...]] = ("dt",)

    def nodes(self, settings) -> int:
        return 6

    def window(self, settings) -> float:
        return 0.2
