"""What the engine and the stages read of a system: typed protocols, one per family of kinds.

Every system object, whatever its kind (:data:`ldpipe.systems.kinds.SYSTEM_KINDS`), is a
:class:`SystemModel`; a Hamiltonian (a built-in, a potential formula) is a
:class:`HamiltonianModel` and is integrated in (q, p); a flow (a vector field, velocity data) is a
:class:`FlowModel` and is integrated by the flow engine; a flow whose trajectories data boundaries
stop (velocity data: land, the grid's edge) is a :class:`DataFlowModel`; a discrete map
x_{n+1} = f(x_n) is a :class:`MapModel` and is iterated, not integrated. Code reads the
attributes, never probes for them: every class has every attribute of its protocol, so
``system.hamiltonian`` or ``system.ld_units(...)`` needs no default (``tests/systems/test_kinds.py``
checks each registered class against its protocol).
"""

from __future__ import annotations

from contextlib import AbstractContextManager
from typing import Any, Callable, ClassVar, Protocol, runtime_checkable

import numpy as np

__all__ = ["CoordinateState", "DataFlowModel", "FlowModel", "HamiltonianModel", "MapModel", "SystemModel", "Unbounded",
           "protocol_members", "system_repr"]


def system_repr(system: Any, kind: str, **more: Any) -> str:
    """One line for a system object (a notebook prints it): its class, name, kind, coordinates
    and parameters, and ``more`` (say, a data file): not its compiled kernels or their source."""
    words = [repr(system.name), kind, f"coordinates={tuple(system.coordinates)!r}"]
    if system.parameters:
        words.append(f"parameters={dict(system.parameters)!r}")
    words += [f"{key}={value!r}" for key, value in more.items()]
    return f"{type(system).__name__}({', '.join(words)})"


class Unbounded:
    """What a system whose trajectories nothing but the region and the escape radius stops says of
    them (a built-in, a formula, a vector field; velocity data say otherwise)."""

    #: Its trajectories are bounded by the escape radius alone.
    coordinate_bound: ClassVar[float] = 0.0
    #: No land, no data's edge stops a trajectory.
    has_stop_flags: ClassVar[bool] = False
    #: Its formulas do not name the unit of their time.
    time_units: ClassVar[str | None] = None


class CoordinateState:
    """What a system whose state is its coordinates says of it (a vector field, a discrete map):
    no momenta, no kinetic matrix, and an LD in the state's own units."""

    @property
    def n_state(self) -> int:
        return len(self.coordinates)

    @property
    def phase_coordinates(self) -> tuple[str, ...]:
        return self.coordinates

    def kinetic_attributes(self) -> dict[str, str]:
        """No kinetic matrix: stage files record nothing of one (as for unit masses)."""
        return {}

    def ld_units(self, arclength: bool, p: float | None = None) -> str | None:
        """The LD is in the state's own units, which the formulas do not name: None."""
        return None


@runtime_checkable
class SystemModel(Protocol):
    """What every system offers."""

    #: The key of its entry under ``systems:``.
    name: str
    #: The configuration coordinates of a Hamiltonian, every state variable of a flow.
    coordinates: tuple[str, ...]
    #: The values baked into its kernels.
    parameters: dict
    #: Its ``systems:`` entry.
    spec: dict
    #: The source of its compiled kernels, which the engine compiles into its own module.
    kernel_source: str
    #: A natural Hamiltonian (integrated in (q, p), with an energy) or not (a flow, a map).
    hamiltonian: bool
    #: A discrete map x_{n+1} = f(x_n), iterated (no time, no vector field).
    discrete: bool
    #: A bound on |x| of any trajectory that can move, to which the engine raises its escape radius (0: none).
    coordinate_bound: float
    #: Whether data boundaries stop trajectories (then it is a :class:`DataFlowModel`).
    has_stop_flags: bool
    #: The unit of its time, in which a map's ``tau`` is counted (velocity data: the data's, such
    #: as ``days``); None where it is not named.
    time_units: str | None

    @property
    def phase_coordinates(self) -> tuple[str, ...]:
        """The names of the integrated state: (q..., p...) or the flow's state variables."""

    @property
    def description(self) -> str:
        """One line for file titles and figure captions."""

    def kinetic_attributes(self) -> dict[str, str]:
        """What a stage file records of the kinetic matrix (nothing for unit masses and flows)."""

    def ld_units(self, arclength: bool, p: float | None = None) -> str | None:
        """The ``units`` of a map's LD variables; None where the state's units are not named."""

    def check_times(self, start: float, end: float, key: str | None = None) -> None:
        """ConfigError if trajectories over times [start, end] leave what the system knows (data's times)."""


@runtime_checkable
class HamiltonianModel(SystemModel, Protocol):
    """A natural Hamiltonian H = p^T M^-1 p / 2 + V(q) (:class:`ldpipe.systems.System`)."""

    kernels: Any
    formula: str | None
    mass_matrix: tuple[tuple[float, ...], ...] | None
    closed_form_equilibria: Callable[[], np.ndarray] | None

    @property
    def n_dof(self) -> int: ...
    @property
    def momenta(self) -> tuple[str, ...]: ...
    @property
    def mass(self) -> np.ndarray: ...
    @property
    def inverse_mass(self) -> np.ndarray: ...
    def vector_field(self, state: np.ndarray, *args: Any) -> np.ndarray:
        """d(state)/dt at one state."""
    def potential(self, q: np.ndarray) -> float: ...
    def potentials(self, points: np.ndarray) -> np.ndarray: ...
    def gradient(self, q: np.ndarray) -> np.ndarray: ...
    def hessian(self, q: np.ndarray) -> np.ndarray: ...
    def velocity(self, momenta: np.ndarray) -> np.ndarray: ...
    def kinetic_energy(self, momenta: np.ndarray) -> np.ndarray | float: ...
    def energy(self, state: np.ndarray) -> float: ...
    def jacobian(self, state: np.ndarray) -> np.ndarray: ...
    def normal_modes(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]: ...


@runtime_checkable
class FlowModel(SystemModel, Protocol):
    """A flow dx/dt = f(x, t), integrated by the flow engine (``ldpipe.engine.vector_field``)."""

    #: ``rhs(state, t, out)``, compiled.
    rhs: Callable

    @property
    def n_state(self) -> int: ...

    @property
    def engine_name(self) -> str:
        """What the generated engine module's file is named after."""

    @property
    def ld_metric_source(self) -> str:
        """The engine section that takes the LD in the system's own metric ("" for none)."""

    @property
    def time_dependent(self) -> bool: ...

    def time_window(self, start: float, end: float) -> AbstractContextManager:
        """The context the compiled kernels run in over times [start, end]."""

    def vector_field(self, state: np.ndarray, *args: Any) -> np.ndarray:
        """d(state)/dt at one state."""

    def engine_states(self, states: np.ndarray) -> np.ndarray:
        """``states`` (rows of the state variables) as the compiled kernels integrate them: the
        same for most; a curvilinear grid's fractional indices. A section crossed by the engine
        (``ldpipe.core.trajectories.integrate``) is a value of an engine state's component."""

    def states_from_engine(self, engine_states: np.ndarray) -> np.ndarray:
        """Engine states back as the state variables (the inverse of :meth:`engine_states`)."""


@runtime_checkable
class DataFlowModel(FlowModel, Protocol):
    """A flow whose trajectories data boundaries stop (``has_stop_flags``): velocity data."""

    def stop_flags(self, end_states: np.ndarray, start: float, end: float) -> dict[str, np.ndarray]:
        """Where trajectories stopped, one boolean array per reason (``on_land``, ``left_data``)."""

    def stop_lines(self, end_states: np.ndarray, start: float,
                   end: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The grid line each stopped trajectory crossed last: (state index, value, side), the value
        the engine state's (:meth:`FlowModel.engine_states`), where the crossing is located."""


@runtime_checkable
class MapModel(SystemModel, Protocol):
    """A discrete map x_{n+1} = f(x_n), iterated by ``ldpipe.engine.discrete_map``, with an
    optional inverse for backward iterations (:class:`ldpipe.systems.discrete_map.DiscreteMapSystem`)."""

    #: The source of ``step(state, out)``, (with an inverse) ``inverse(state, out)`` and the tangent
    #: map's ``jacobian(state, out)``, undecorated.
    kernel_source: str
    #: The inverse map is given: backward iterations are possible.
    has_inverse: bool
    #: The period of each coordinate (0: not periodic); a periodic coordinate is kept in [0, period).
    periods: tuple[float, ...]

    @property
    def n_state(self) -> int: ...

    @property
    def engine_name(self) -> str:
        """What the generated iteration module's file is named after."""

    def step(self, state: np.ndarray, direction: int = 1) -> np.ndarray:
        """f(state) (``direction`` 1) or f^-1(state) (-1), periodic coordinates wrapped."""

    def jacobian(self, state: np.ndarray) -> np.ndarray:
        """Df at one state: the tangent map."""

    def require_inverse(self, what: str) -> None:
        """ConfigError naming the entry's ``inverse`` key if the map has none: ``what`` needs it."""


def protocol_members(protocol: type) -> set[str]:
    """The attribute and method names ``protocol`` states, its bases' included."""
    names: set[str] = set()
    for cls in protocol.__mro__:
        if cls in (object, Protocol) or not getattr(cls, "_is_protocol", False):
            continue
        names |= set(getattr(cls, "__annotations__", {}))
        names |= {name for name in vars(cls) if not name.startswith("_")}
    return names
