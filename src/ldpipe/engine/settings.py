"""LDSettings: every numerical choice of one LD computation, validated on construction."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Union

from .stepping import SCHEMES
from .taylor import MAX_ORDER, MIN_ORDER, jorba_zou_order

ADAPTIVE_SCHEMES = ("dop853", "taylor")
FIXED_STEP_SCHEMES = ("rk4", "sym4", "sym6")

#: Default escape radius: a trajectory is stopped and flagged ``escaped`` the first time
#: max_i |q_i| exceeds it. 100 is an order of magnitude beyond the saddles of the paper's
#: potentials (|q| ~ 9 in the Barbanis 2 DoF, ~12 in the 3 DoF model) and far inside the
#: finite-time blow-up of their escaping trajectories, where the potential is already below
#: -1e4, so nothing that gets there comes back into the well at the energies studied.
DEFAULT_ESCAPE_RADIUS = 100.0


def _number(name: str, value, *, positive: bool = True) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f"{name}: expected a number, got {value!r}")
    value = float(value)
    if not math.isfinite(value) or (positive and value <= 0.0):
        raise ValueError(f"{name}: expected a finite number > 0, got {value!r}")
    return value


def _box(name: str, value) -> tuple[float, ...] | None:
    if value is None:
        return None
    try:
        items = tuple(float(v) for v in value)
    except TypeError:
        raise ValueError(f"{name}: expected a sequence of numbers, one per coordinate, got {value!r}") from None
    if not items or not all(math.isfinite(v) for v in items):
        raise ValueError(f"{name}: expected finite numbers, one per coordinate, got {value!r}")
    return items


@dataclass(frozen=True)
class LDSettings:
    """Numerical settings of :func:`ldpipe.engine.compute_ld`.

    Parameters
    ----------
    scheme : {"dop853", "taylor", "rk4", "sym4", "sym6"}
        ``dop853``: adaptive Dormand–Prince 8(5,3) with per-trajectory step control (uses
        ``rtol``/``atol``). ``taylor``: Taylor series of order ``taylor_order`` with the
        Jorba–Zou step rule (uses ``rtol``/``atol``; polynomial potentials only; see
        :mod:`ldpipe.engine.taylor`). ``rk4``: classical fixed-step Runge–Kutta. ``sym4``/``sym6``:
        fixed-step symplectic compositions of Störmer–Verlet (Suzuki 4th order, 5 forces per
        step; Yoshida's triple jump of it, 6th order, 15 forces per step). Fixed-step schemes
        use ``dt``.
    rtol, atol : float
        Relative and absolute tolerance of the adaptive schemes (per component of (q, p)).
    taylor_order : int or None
        Degree of the momentum series of the ``taylor`` scheme (q is one degree higher);
        None picks from m_JZ = ceil(-ln(min(rtol, atol)) / 2) + 1 (Jorba & Zou's rule): m_JZ + 5
        for the arc length, m_JZ - 2 for |v|^p (measured, see :attr:`order`).
    dt : float
        Step of the fixed-step schemes; the last step is shortened to end exactly at ``tau``.
    p : float in (0, 1] or "arclength"
        The LD integrand: sum_c |x'_c|^p over the 2 n_dof phase-space velocity components, or
        the phase-space arc length ||x'||.
    tau : float
        Integration time (> 0); the direction is an argument of ``compute_ld``.
    region_lower, region_upper : sequence of float (length n_dof) or None
        The configuration box of the variable-time LD: a trajectory stops at its first exit
        from the box (located on the step's interpolant), flagged ``left_region``. None for
        both: fixed time.
    escape_radius : float
        A trajectory stops, flagged ``escaped``, when max_i |q_i| first exceeds it (located
        on the interpolant, LD integrated up to it). See ``DEFAULT_ESCAPE_RADIUS``.
    block : int
        Trajectories per structure-of-arrays block (lanes advanced together).
    max_steps : int
        Cap on step attempts per trajectory; a trajectory that reaches it stops, flagged
        ``failed``.
    quad_nodes : int or None
        Gauss nodes per step (and per piece) of the LD quadrature; None picks 4 for dop853 at
        rtol >= 1e-5, 8 for dop853 at tighter tolerances, 8 (arc length) or 12-16 (|v|^p) for
        taylor, and 6 for the fixed-step schemes (see :attr:`nodes`).
    window : float or None
        The LD quadrature treats a velocity root within this many step lengths outside a step
        as a singularity of that step (see :mod:`ldpipe.engine.quadrature`). None (default)
        picks it from the accuracy asked for: 0.1 step lengths for dop853 at rtol >= 1e-7,
        0.2 otherwise (see :attr:`quadrature_window`).
    """

    scheme: str = "dop853"
    rtol: float = 1e-10
    atol: float = 1e-10
    taylor_order: int | None = None
    dt: float = 0.01
    p: Union[float, str] = 0.5
    tau: float = 50.0
    region_lower: tuple[float, ...] | None = None
    region_upper: tuple[float, ...] | None = None
    escape_radius: float = DEFAULT_ESCAPE_RADIUS
    block: int = 64
    max_steps: int = 1_000_000
    quad_nodes: int | None = None
    window: float | None = None

    def __post_init__(self):
        if self.scheme not in SCHEMES:
            raise ValueError(f"scheme: unknown scheme {self.scheme!r}; expected one of {list(SCHEMES)}")
        set_ = lambda name, value: object.__setattr__(self, name, value)  # noqa: E731
        for name in ("rtol", "atol", "dt", "tau", "escape_radius"):
            set_(name, _number(name, getattr(self, name)))
        if self.window is not None:
            set_("window", _number("window", self.window))
        if self.rtol < 1e-15:
            raise ValueError(f"rtol: {self.rtol!r} is below what double precision can deliver; use >= 1e-15")
        if isinstance(self.p, str):
            if self.p != "arclength":
                raise ValueError(f"p: expected a number in (0, 1] or 'arclength', got {self.p!r}")
        else:
            p = _number("p", self.p)
            if p > 1.0:
                raise ValueError(f"p: expected a number in (0, 1] or 'arclength', got {self.p!r}")
            set_("p", p)
        lower = _box("region_lower", self.region_lower)
        upper = _box("region_upper", self.region_upper)
        if (lower is None) != (upper is None):
            raise ValueError("region_lower, region_upper: give both (variable time) or neither (fixed time)")
        if lower is not None:
            if len(lower) != len(upper):
                raise ValueError(f"region_lower, region_upper: lengths differ ({len(lower)} and {len(upper)})")
            if not all(lo < hi for lo, hi in zip(lower, upper)):
                raise ValueError(f"region_lower, region_upper: need lower < upper in every coordinate, got {lower}, {upper}")
        set_("region_lower", lower)
        set_("region_upper", upper)
        for name, low in (("block", 1), ("max_steps", 1)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < low:
                raise ValueError(f"{name}: expected an integer >= {low}, got {value!r}")
        if self.taylor_order is not None:
            value = self.taylor_order
            if isinstance(value, bool) or not isinstance(value, int) or not MIN_ORDER <= value <= MAX_ORDER:
                raise ValueError(f"taylor_order: expected None or an integer in [{MIN_ORDER}, {MAX_ORDER}], got {value!r}")
        if self.quad_nodes is not None:
            if isinstance(self.quad_nodes, bool) or not isinstance(self.quad_nodes, int) or not 2 <= self.quad_nodes <= 32:
                raise ValueError(f"quad_nodes: expected None or an integer in [2, 32], got {self.quad_nodes!r}")

    @property
    def adaptive(self) -> bool:
        return self.scheme in ADAPTIVE_SCHEMES

    @property
    def order(self) -> int | None:
        """The Taylor scheme's order in use (None for the other schemes)."""
        if self.scheme != "taylor":
            return None
        if self.taylor_order is not None:
            return self.taylor_order
        order = jorba_zou_order(min(self.rtol, self.atol))
        if self.p == "arclength":
            # Five orders above Jorba & Zou's: an engine step's fixed work (the quadrature over
            # the step, the lanes' bookkeeping) outweighs the series' ~m^2 terms, so longer steps
            # pay until the step's Gauss rule limits the accuracy. Measured (400 points of the
            # benchmark section against dop853 at rtol 1e-14, 8 nodes): at rtol 1e-10 order 18
            # ran 82 steps per tau = 50 against 154 at order 13, 1.3-1.5x the throughput, the
            # median error 2.0e-12 against 1.5e-12; at 1e-12 order 20 (89 steps) against 15
            # (157), 1.2-1.5x, median 3.4e-14 against 2.7e-14. Order 24 lost accuracy.
            order += 5
        else:
            # |v|^p: two orders below, for shorter steps. A velocity component that nearly
            # touches zero inside a step makes |v|^p vary on the scale sqrt(|v_min| / |v''|),
            # which Gauss–Legendre resolves only on steps a few times that long. Measured (1000
            # points of the benchmark section, p = 1/2, against dop853 at rtol 1e-14): at rtol
            # 1e-12 the worst error was 2e-9 at order 15 and 4e-12 at order 13; at 1e-10, 5e-9
            # at order 13 and 1.3e-10 at order 11; the medians did not change.
            order -= 2
        return max(MIN_ORDER, min(MAX_ORDER, order))

    @property
    def variable_time(self) -> bool:
        return self.region_lower is not None

    @property
    def quadrature_window(self) -> float:
        """The window in use: ``window``, or the default for the accuracy asked for.

        Measured on the Barbanis 2 DoF benchmark (benchmarks/compare.py, errors against the
        reference): a root at 0.1-0.5 step lengths outside a step changes the LD error of
        dop853 at rtol 1e-4 .. 1e-8 by less than 2 % whether it is cut out or left to
        Gauss–Legendre, but a window of 0.5 sends 3 of the 4 components of every step to
        the slower cusp path at rtol 1e-4 and costs 2.5x the time. At rtol 1e-10 a window
        of 0.1 raised the median error 7x and one of 0.5 the worst 9x, against 0.2.
        """
        if self.window is not None:
            return self.window
        return 0.1 if (self.adaptive and self.rtol >= 1e-7) else 0.2

    @property
    def nodes(self) -> int:
        """The Gauss nodes in use: ``quad_nodes``, or the default for the scheme and accuracy.

        At rtol 1e-4 and 1e-5 the LD error of dop853 is the trajectory's: 4 nodes instead of 8
        left the median and worst errors against the benchmark reference unchanged (within
        3 %) and were 10-15 % faster; at 1e-6 and tighter 6 nodes already raised the errors.
        """
        if self.quad_nodes is not None:
            return self.quad_nodes
        if self.scheme == "taylor":
            # Its steps are 2-5x longer than dop853's at the same tolerance. Measured (400 points
            # of the benchmark section, against dop853 at rtol 1e-14): the arc length at its
            # default orders needs 8 nodes (6 raised the median error 60x at rtol 1e-12, order
            # 20); |v|^p needs 12 (8 raised the worst error 15x at rtol 1e-8) and 16 below 1e-9.
            if self.p == "arclength":
                return 8
            return 12 if self.rtol >= 1e-9 else 16
        if not self.adaptive:
            return 6
        return 4 if self.rtol >= 1e-5 else 8
