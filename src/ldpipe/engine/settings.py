"""Settings of one LD computation, each default stated once, validated on construction.

Three small records, one per concept, and the engine's flat entry object built from them:

- :class:`IntegratorSettings` — the config's ``integrator:`` block of an LD map (scheme,
  tolerances or step, Taylor order, escape radius); :meth:`IntegratorSettings.from_config`
  turns such a block into settings, for the stages, the CLI and the accuracy ladders alike;
- :class:`DescriptorSettings` — the integrand (p or the arc length) and its quadrature;
- :class:`StoppingRules` — integration time, the saddle-region box, the step cap;
- :class:`LDSettings` — all of them flat, as :func:`ldpipe.engine.compute_ld` takes them; its
  defaults are the records' and its validation theirs.

The config schema (a static file) states the same defaults; ``tests/engine/test_registry.py``
checks that it agrees with these records, and the CLI reads its defaults from them.
"""

from __future__ import annotations

import dataclasses
import math
import sys
from dataclasses import dataclass
from typing import Union

from .integrands import check_p
from .schemes import SCHEMES, get_scheme
from .schemes.taylor import MAX_ORDER, MIN_ORDER

#: Default escape radius: a trajectory is stopped and flagged ``escaped`` the first time
#: max_i |q_i| exceeds it. 100 is an order of magnitude beyond the saddles of the paper's
#: potentials (|q| ~ 9 in the Barbanis 2 DoF, ~12 in the 3 DoF model) and far inside the
#: finite-time blow-up of their escaping trajectories, where the potential is already below
#: -1e4, so nothing that gets there comes back into the well at the energies studied.
DEFAULT_ESCAPE_RADIUS = 100.0

#: The smallest relative tolerance an adaptive scheme accepts (the engine's, ``FlowSettings``',
#: and the config schema's ``minimum`` of every ``rtol``). A double carries 53 bits: one rounding
#: of a result is relative error eps/2, eps = 2.2e-16, and a step sums a dozen rounded stages, so
#: its result is known to a few eps at best. A tolerance below that asks for an error smaller
#: than the arithmetic commits: results are no more accurate, steps multiply, and far below
#: it (1e-30 for DOP853 on Barbanis) the step size underflows and every trajectory spins to
#: ``max_steps``. The floor is the power of ten above 4 eps. scipy's ``solve_ivp`` instead raises
#: rtol to 100 eps with a warning; ldpipe refuses, because the settings are recorded in each
#: file's attributes and a silently raised one would be recorded wrong.
RTOL_FLOOR = 1e-15
#: The smallest absolute tolerance: the smallest normal double. An absolute tolerance has the
#: units of the state, so doubles alone set no other floor; below this one atol itself loses
#: precision (subnormal), and a zero component has no tolerance the error norm can divide by.
ATOL_FLOOR = sys.float_info.min
#: The most steps a trajectory may be asked to take (``max_steps``, or tau/dt of a fixed-step
#: scheme): 1e9 steps of the cheapest scheme are hours for one trajectory, days for a map.
MAX_STEPS_CEILING = 10**9


def engine_escape_radius(system, radius: float) -> float:
    """The escape radius the engine uses for ``system``: ``radius``, raised to the system's
    ``coordinate_bound`` (0 for most). Velocity data bound their trajectories themselves (land,
    the data's edge), so coordinates in metres or longitudes beyond 100 are never an escape."""
    return max(radius, system.coordinate_bound)


def _number(name: str, value, *, positive: bool = True) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f"{name}: expected a number, got {value!r}")
    value = float(value)
    if not math.isfinite(value) or (positive and value <= 0.0):
        raise ValueError(f"{name}: expected a finite number > 0, got {value!r}")
    return value


def check_tolerances(rtol: float, atol: float, where: str = "") -> None:
    """Refuse tolerances no double-precision step can honour (:data:`RTOL_FLOOR`,
    :data:`ATOL_FLOOR`), naming the setting (after ``where``, e.g. ``"integrator."``) and its floor."""
    if rtol < RTOL_FLOOR:
        raise ValueError(f"{where}rtol: {rtol!r} is below what double precision can honour (one rounding is "
                         f"1.1e-16 relative); use >= {RTOL_FLOOR!r}")
    if atol < ATOL_FLOOR:
        raise ValueError(f"{where}atol: {atol!r} is below what double precision can honour (the smallest normal "
                         f"double); use >= {ATOL_FLOOR!r}")


def _integer(name: str, value, low: int, high: int | None = None, *, optional: bool = False) -> None:
    if optional and value is None:
        return
    if isinstance(value, bool) or not isinstance(value, int) or value < low or (high is not None and value > high):
        span = f">= {low}" if high is None else f"in [{low}, {high}]"
        raise ValueError(f"{name}: expected {'None or ' if optional else ''}an integer {span}, got {value!r}")


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


def _set(record, name: str, value) -> None:
    object.__setattr__(record, name, value)


class _NamesAScheme:
    """``record`` and ``adaptive`` of a settings class with a ``scheme`` field."""

    scheme: str

    @property
    def record(self):
        """The scheme's record in the registry (:data:`ldpipe.engine.schemes.SCHEMES`)."""
        return SCHEMES[self.scheme]

    @property
    def adaptive(self) -> bool:
        return self.record.adaptive


@dataclass(frozen=True)
class IntegratorSettings(_NamesAScheme):
    """The integrator of an LD map: the config's ``integrator:`` block.

    Parameters
    ----------
    scheme : str
        A scheme of the registry :data:`ldpipe.engine.schemes.SCHEMES`: ``dop853`` (adaptive
        Dormand–Prince 8(5,3), per-trajectory step control), ``taylor`` (Taylor series of order
        ``taylor_order``, Jorba–Zou steps; potentials given by a formula), ``rk4`` (classical
        Runge–Kutta, fixed step), ``sym4``/``sym6`` (fixed-step symplectic compositions of
        Störmer–Verlet, 4th and 6th order). Adaptive schemes use ``rtol``/``atol``, fixed-step
        ones ``dt`` (the record's ``parameters``).
    rtol, atol : float
        Relative and absolute tolerance of the adaptive schemes (per component of (q, p)).
    taylor_order : int or None
        Degree of the momentum series of the ``taylor`` scheme (q is one degree higher);
        None picks it from the tolerance (see :meth:`ldpipe.engine.schemes.taylor.Taylor.order_for`).
    dt : float
        Step of the fixed-step schemes; the last step is shortened to end exactly at ``tau``.
    escape_radius : float
        A trajectory stops, flagged ``escaped``, when max_i |q_i| first exceeds it (located
        on the interpolant, LD integrated up to it). See ``DEFAULT_ESCAPE_RADIUS``.
    """

    scheme: str = "dop853"
    rtol: float = 1e-8
    atol: float = 1e-8
    taylor_order: int | None = None
    dt: float = 0.01
    escape_radius: float = DEFAULT_ESCAPE_RADIUS

    def __post_init__(self):
        get_scheme(self.scheme)
        for name in ("rtol", "atol", "dt", "escape_radius"):
            _set(self, name, _number(name, getattr(self, name)))
        check_tolerances(self.rtol, self.atol)
        _integer("taylor_order", self.taylor_order, MIN_ORDER, MAX_ORDER, optional=True)

    @classmethod
    def from_config(cls, block: dict) -> "IntegratorSettings":
        """From a config ``integrator:`` block; keys left out take the defaults, unknown keys are refused."""
        names = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(block) - names)
        if unknown:
            raise ValueError(f"integrator: unknown settings {unknown}; expected some of {sorted(names)}")
        return cls(**{name: value for name, value in block.items()})

    @classmethod
    def from_spec(cls, spec: dict) -> "IntegratorSettings":
        """From a setting that names exactly the numbers its scheme uses, as the accuracy ladder gives them.

        ``{scheme, rtol[, atol]}`` for an adaptive scheme (``atol`` defaults to ``rtol``, the LD
        maps' convention), ``{scheme, dt}`` for a fixed-step one.
        """
        scheme = get_scheme(spec.get("scheme"))
        given = set(spec) - {"scheme"}
        if scheme.adaptive:
            if "rtol" not in given or not given <= {"rtol", "atol"}:
                raise ValueError(f"{scheme.name}: expected rtol (and atol) and no dt, got {spec}")
            return cls(scheme.name, rtol=spec["rtol"], atol=spec.get("atol", spec["rtol"]))
        if given != {"dt"}:
            raise ValueError(f"{scheme.name}: expected dt and no rtol/atol, got {spec}")
        return cls(scheme.name, dt=spec["dt"])

    def numbers(self) -> dict[str, float]:
        """rtol, atol and dt, 0 for those the scheme does not use (the ladder stores them so)."""
        used = self.record.parameters
        return {name: (getattr(self, name) if name in used else 0.0) for name in ("rtol", "atol", "dt")}

    @property
    def label(self) -> str:
        """E.g. ``dop853 rtol 1e-08`` (atol too where it differs) or ``rk4 dt 0.01``."""
        if self.adaptive:
            tolerance = f"rtol {self.rtol:g}" + ("" if self.atol == self.rtol else f" atol {self.atol:g}")
            return f"{self.scheme} {tolerance}"
        return f"{self.scheme} dt {self.dt:g}"

    def matches(self, other) -> bool:
        """Whether ``other`` (settings with the same fields) integrates as this does: the same
        scheme, and the numbers it uses equal to 1e-9 relative (as read back from a file)."""
        if other.scheme != self.scheme:
            return False
        return all(math.isclose(getattr(other, name), getattr(self, name), rel_tol=1e-9, abs_tol=0.0)
                   for name in self.record.parameters)

    def apply(self, base: "LDSettings") -> "LDSettings":
        """``base`` (the map's LD, time mode, region, escape radius) with this scheme and the numbers it uses."""
        return dataclasses.replace(base, scheme=self.scheme, **{name: getattr(self, name) for name in self.record.parameters})


def integrator_ladder(spec: dict) -> list[IntegratorSettings]:
    """The ladder ``{scheme: {rtol: [...]} or {dt: [...]}}`` as settings, scheme by scheme in order.

    The values listed are those of the scheme's step parameter (``rtol`` of an adaptive scheme,
    ``dt`` of a fixed-step one; the registry's ``parameters``). For an adaptive scheme ``atol``
    equals ``rtol`` (the LD maps' convention) unless the entry gives an ``atol`` list of the
    same length.
    """
    steps = []
    for scheme, values in spec.items():
        if get_scheme(scheme).adaptive:
            rtols = values["rtol"]
            atols = values.get("atol", rtols)
            if len(atols) != len(rtols):
                raise ValueError(f"{scheme}: {len(rtols)} rtol values but {len(atols)} atol values")
            steps += [IntegratorSettings.from_spec({"scheme": scheme, "rtol": float(r), "atol": float(a)})
                      for r, a in zip(rtols, atols)]
        else:
            steps += [IntegratorSettings.from_spec({"scheme": scheme, "dt": float(dt)}) for dt in values["dt"]]
    return steps


@dataclass(frozen=True)
class DescriptorSettings:
    """The LD integrand and its quadrature.

    Parameters
    ----------
    p : float in (0, 1] or "arclength"
        The LD integrand: sum_c |x'_c|^p over the 2 n_dof phase-space velocity components, or
        the phase-space arc length ||x'|| (:mod:`ldpipe.engine.integrands`).
    quad_nodes : int or None
        Gauss nodes per step (and per piece) of the LD quadrature; None: the scheme's default
        (the record's ``nodes``: 4 for dop853 at rtol >= 1e-5, 8 at tighter tolerances; 8 (arc
        length) or 12-16 (|v|^p) for taylor; 6 for the fixed-step schemes).
    window : float or None
        The LD quadrature treats a velocity root within this many step lengths outside a step
        as a singularity of that step (``templates/block_quadrature.py``'s ``fast``). None: the
        scheme's default (the record's ``window``: 0.1 step lengths for the adaptive schemes
        at rtol >= 1e-7, 0.2 otherwise).
    """

    p: Union[float, str] = 0.5
    quad_nodes: int | None = None
    window: float | None = None

    def __post_init__(self):
        _set(self, "p", check_p(self.p))
        if self.window is not None:
            _set(self, "window", _number("window", self.window))
        _integer("quad_nodes", self.quad_nodes, 2, 32, optional=True)


@dataclass(frozen=True)
class StoppingRules:
    """When a trajectory stops, besides the escape radius of the integrator settings.

    Parameters
    ----------
    tau : float
        Integration time (> 0); the direction is an argument of ``compute_ld``.
    region_lower, region_upper : sequence of float (length n_dof) or None
        The configuration box of the variable-time LD: a trajectory stops at its first exit
        from the box (located on the step's interpolant), flagged ``left_region``. None for
        both: fixed time.
    max_steps : int
        Cap on step attempts per trajectory; a trajectory that reaches it stops, flagged
        ``failed``.
    """

    tau: float = 50.0
    region_lower: tuple[float, ...] | None = None
    region_upper: tuple[float, ...] | None = None
    max_steps: int = 1_000_000

    def __post_init__(self):
        _set(self, "tau", _number("tau", self.tau))
        lower = _box("region_lower", self.region_lower)
        upper = _box("region_upper", self.region_upper)
        if (lower is None) != (upper is None):
            raise ValueError("region_lower, region_upper: give both (variable time) or neither (fixed time)")
        if lower is not None:
            if len(lower) != len(upper):
                raise ValueError(f"region_lower, region_upper: lengths differ ({len(lower)} and {len(upper)})")
            if not all(lo < hi for lo, hi in zip(lower, upper)):
                raise ValueError(f"region_lower, region_upper: need lower < upper in every coordinate, got {lower}, {upper}")
        _set(self, "region_lower", lower)
        _set(self, "region_upper", upper)
        _integer("max_steps", self.max_steps, 1, MAX_STEPS_CEILING)

    @property
    def variable_time(self) -> bool:
        return self.region_lower is not None


_INTEGRATOR = IntegratorSettings()
_DESCRIPTOR = DescriptorSettings()
_STOPPING = StoppingRules()
_PARTS = {
    "integrator": (IntegratorSettings, [f.name for f in dataclasses.fields(IntegratorSettings)]),
    "descriptor": (DescriptorSettings, [f.name for f in dataclasses.fields(DescriptorSettings)]),
    "stopping": (StoppingRules, [f.name for f in dataclasses.fields(StoppingRules)]),
}


@dataclass(frozen=True)
class LDSettings(_NamesAScheme):
    """Numerical settings of :func:`ldpipe.engine.compute_ld`, flat.

    The fields are those of :class:`IntegratorSettings` (scheme, rtol, atol, taylor_order, dt,
    escape_radius), :class:`DescriptorSettings` (p, quad_nodes, window) and
    :class:`StoppingRules` (tau, region_lower, region_upper, max_steps), with their defaults
    and validation, and ``block``: trajectories per structure-of-arrays block (lanes advanced
    together; None: the scheme's default, see :attr:`lanes`). :attr:`integrator`, :attr:`descriptor` and :attr:`stopping` give the parts
    back; :meth:`from_parts` builds one from them.
    """

    scheme: str = _INTEGRATOR.scheme
    rtol: float = _INTEGRATOR.rtol
    atol: float = _INTEGRATOR.atol
    taylor_order: int | None = _INTEGRATOR.taylor_order
    dt: float = _INTEGRATOR.dt
    p: Union[float, str] = _DESCRIPTOR.p
    tau: float = _STOPPING.tau
    region_lower: tuple[float, ...] | None = _STOPPING.region_lower
    region_upper: tuple[float, ...] | None = _STOPPING.region_upper
    escape_radius: float = _INTEGRATOR.escape_radius
    block: int | None = None
    max_steps: int = _STOPPING.max_steps
    quad_nodes: int | None = _DESCRIPTOR.quad_nodes
    window: float | None = _DESCRIPTOR.window

    def __post_init__(self):
        get_scheme(self.scheme)  # the unknown scheme first: it names the registered ones
        for cls, names in _PARTS.values():
            part = cls(**{name: getattr(self, name) for name in names})  # validates
            for name in names:
                _set(self, name, getattr(part, name))
        if self.block is not None:
            _integer("block", self.block, 1)
        if not self.adaptive:
            self._check_fixed_steps()

    def _check_fixed_steps(self) -> None:
        # A fixed-step scheme takes tau/dt steps: refuse a count that would run for days, or that
        # max_steps would cut short for every trajectory of a fixed-time map (all flagged failed).
        steps = self.tau / self.dt
        if steps > MAX_STEPS_CEILING:
            raise ValueError(f"tau, dt: tau/dt = {steps:.3g} steps a trajectory, more than {MAX_STEPS_CEILING:.0e}; "
                             f"raise dt or lower tau")
        if not self.variable_time and math.ceil(steps * (1 - 1e-12)) > self.max_steps:  # tau/dt rounded up, 1e-12 spared
            raise ValueError(f"tau, dt, max_steps: tau/dt = {steps:.6g} steps a trajectory, more than max_steps = "
                             f"{self.max_steps}: every trajectory would stop at max_steps, flagged failed; raise dt "
                             "or max_steps")

    @classmethod
    def from_parts(
        cls,
        integrator: IntegratorSettings = _INTEGRATOR,
        descriptor: DescriptorSettings = _DESCRIPTOR,
        stopping: StoppingRules = _STOPPING,
        **engine,
    ) -> "LDSettings":
        """From the parts, plus the engine's own fields (``block``)."""
        values = {**dataclasses.asdict(integrator), **dataclasses.asdict(descriptor), **dataclasses.asdict(stopping)}
        return cls(**values, **engine)

    def _part(self, key: str):
        cls, names = _PARTS[key]
        return cls(**{name: getattr(self, name) for name in names})

    @property
    def integrator(self) -> IntegratorSettings:
        return self._part("integrator")

    @property
    def descriptor(self) -> DescriptorSettings:
        return self._part("descriptor")

    @property
    def stopping(self) -> StoppingRules:
        return self._part("stopping")

    @property
    def order(self) -> int | None:
        """The order in use of a scheme that chooses it per call (taylor); None for the others."""
        return self.record.order_for(self)

    @property
    def variable_time(self) -> bool:
        return self.region_lower is not None

    @property
    def quadrature_window(self) -> float:
        """The window in use: ``window``, or the scheme's default for the accuracy asked for."""
        if self.window is not None:
            return self.window
        return self.record.window(self)

    @property
    def lanes(self) -> int:
        """The block size in use: ``block``, or the scheme's default for these settings."""
        if self.block is not None:
            return self.block
        return self.record.lanes(self)

    @property
    def nodes(self) -> int:
        """The Gauss nodes in use: ``quad_nodes``, or the scheme's default for the accuracy asked for."""
        if self.quad_nodes is not None:
            return self.quad_nodes
        return self.record.nodes(self)
