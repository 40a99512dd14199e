"""Many trajectories at once, with samples, section crossings and escapes, on the engine's DOP853.

Each trajectory is integrated by the engine's DOP853 step (:mod:`ldpipe.engine.schemes.dop853`:
Dormand-Prince 8(5,3) in Nyström form, scipy's error norm, per-trajectory step control),
blocks of trajectories side by side, by the driver ``flow_process``
(``ldpipe/engine/templates/flow_driver.py``). Along the way it

* records the state at requested times, from the step's dense output (the DOP853
  interpolant of degree 7; steps are not shortened for samples),
* records crossings of a surface q_i = c (or p_i = c) in a chosen direction, located on the
  same dense output to machine precision (so a crossing is as accurate as the integration),
* stops, flagged *escaped*, where a coordinate's magnitude first exceeds the escape radius
  (located on the dense output, as the LD engine does), and at the last crossing wanted.

The compiled code is assembled by :mod:`ldpipe.engine.codegen` per system and cached on disk
(:mod:`ldpipe.jitcache`), so later processes reuse the machine code.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from ..engine.api import states_at_end
from ..engine.integrator import get_runner, run_units
from ..engine.kinetic import to_engine_states, to_momenta
from ..engine.settings import DEFAULT_ESCAPE_RADIUS, MAX_STEPS_CEILING, check_tolerances, engine_escape_radius
from ..engine.templates import flow_status
from ..errors import ConfigError
from ..systems import System

# How a trajectory ended (``Trajectories.status``): the drivers' own codes, read from their template.
COMPLETED = flow_status.FLOW_COMPLETED
ESCAPED = flow_status.FLOW_ESCAPED
CROSSINGS_FULL = flow_status.FLOW_CROSSINGS_FULL
STEP_UNDERFLOW = flow_status.FLOW_STEP_UNDERFLOW
STATUS_MEANINGS = flow_status.FLOW_STATUS_MEANINGS
STATUS_VALUES = np.array([COMPLETED, ESCAPED, CROSSINGS_FULL, STEP_UNDERFLOW], dtype=np.int8)  # CF flag_values
# Trajectories advanced side by side in one block: a step attempt has a fixed cost per call
# (mostly numba reshaping workspace slices for the kernel) that wider blocks spread. A batch of
# at most SMALL_LANES trajectories (NHIM bisection rounds) runs in a block of that many lanes,
# whose attempts cost a fraction of 32 lanes'; that variant is compiled only when used.
LANES = 32
SMALL_LANES = 4


#: How :func:`flow_map` moves the points: ``dop853``, the LD engine's steps at the tolerances;
#: ``cell_crossing``, velocity data on a C-grid only: its interpolant's trajectory from cell face to
#: cell face, exact to rounding, no tolerance (:mod:`ldpipe.systems.velocity_data.cell_crossing`;
#: ``max_steps`` caps the cells crossed, the escape radius is not used: the data's edge stops it).
FLOW_MAP_METHODS = ("dop853", "cell_crossing")


@dataclass(frozen=True)
class FlowSettings:
    """DOP853 tolerances, escape radius (on every coordinate) and a cap on steps per trajectory;
    the flow map's ``method`` (:data:`FLOW_MAP_METHODS`).

    Refused on construction, naming the setting: tolerances below what doubles can honour
    (``rtol`` below :data:`ldpipe.engine.settings.RTOL_FLOOR`, 1e-15, where the step size
    underflows and every trajectory spins to ``max_steps``; ``atol`` below ``ATOL_FLOOR``),
    a non-finite escape radius, and ``max_steps`` beyond ``MAX_STEPS_CEILING`` (days of work).
    """

    rtol: float = 1e-10
    atol: float = 1e-10
    escape_radius: float = DEFAULT_ESCAPE_RADIUS
    max_steps: int = 10_000_000
    method: str = "dop853"

    def __post_init__(self):
        if self.method not in FLOW_MAP_METHODS:
            raise ValueError(f"method: expected one of {list(FLOW_MAP_METHODS)}, got {self.method!r}")
        for name in ("rtol", "atol", "escape_radius"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
                raise ValueError(f"{name}: expected a finite number > 0, got {value!r}")
        check_tolerances(self.rtol, self.atol)
        if isinstance(self.max_steps, bool) or not isinstance(self.max_steps, (int, np.integer)) \
                or not 1 <= self.max_steps <= MAX_STEPS_CEILING:
            raise ValueError(f"max_steps: expected an integer in [1, {MAX_STEPS_CEILING}], got {self.max_steps!r}")


#: The settings of :class:`FlowSettings` a user names (the rest are the engine's).
FLOW_SETTING_KEYS = ("rtol", "atol", "escape_radius", "max_steps")


def checked_flow_settings(integrator: dict | None, label: str) -> dict:
    """A user's ``integrator`` (None, or a mapping of some of :data:`FLOW_SETTING_KEYS`) as
    :class:`FlowSettings` accepts it; a ConfigError starting with ``label`` otherwise."""
    integrator = integrator or {}
    if not isinstance(integrator, dict) or set(integrator) - set(FLOW_SETTING_KEYS):
        raise ConfigError(f"{label}: {integrator!r}; expected a mapping of some of {list(FLOW_SETTING_KEYS)}")
    try:
        FlowSettings(**integrator)
    except ValueError as error:
        raise ConfigError(f"{label}: {error}") from None
    return dict(integrator)


@dataclass
class Trajectories:
    """What :func:`integrate` returns, for ``k`` trajectories.

    ``samples`` (k, s, 2n) at ``sample_times`` (after an early end, the state where the
    trajectory stopped; ``sample_count`` says how many are real), ``crossings`` (k, c, 2n)
    at ``crossing_times`` (k, c), ``crossing_count`` (k), ``status`` (k; see
    ``STATUS_MEANINGS``), ``final_time`` (k: the duration, or where the trajectory stopped:
    at the escape radius, at the last crossing wanted, or the last accepted step before a
    step-size underflow), ``steps`` (k: step attempts, accepted and rejected).
    """

    sample_times: np.ndarray
    samples: np.ndarray
    sample_count: np.ndarray
    crossings: np.ndarray
    crossing_times: np.ndarray
    crossing_count: np.ndarray
    status: np.ndarray
    final_time: np.ndarray
    steps: np.ndarray


def integrate(
    system: System,
    states: np.ndarray,
    duration: float,
    settings: FlowSettings,
    *,
    sample_times: np.ndarray | None = None,
    section: tuple[str, float, int] | None = None,
    max_crossings: int = 0,
    threads: int | None = None,
    t0: float = 0.0,
) -> Trajectories:
    """Integrate every row of ``states`` for ``duration`` (negative: backward in time).

    A vector-field system (:class:`ldpipe.systems.VectorFieldSystem`) runs from the start time
    ``t0`` on its own driver (``vector_field_crossings``, first-order DOP853), with crossings
    and escapes as here but no samples; a Hamiltonian is autonomous and takes t0 = 0 only.

    ``sample_times`` lie between 0 and ``duration`` (same sign), ordered from 0.
    ``section`` is (phase coordinate, value, direction): crossings where the
    coordinate passes ``value`` increasing (+1) or decreasing (-1) *in forward
    time*, whichever way the integration runs; at most ``max_crossings`` are kept
    and the trajectory stops at the last (status ``crossings_full``).
    """
    states = np.ascontiguousarray(states, dtype=np.float64)
    if not system.hamiltonian:
        if sample_times is not None and len(sample_times):
            raise ValueError(f"sample_times: system {system.name!r} is a vector field; its flow records crossings only")
        return _integrate_vector_field(system, states, duration, settings, section, max_crossings, threads, float(t0))
    if t0 != 0.0:
        raise ValueError(f"t0: system {system.name!r} is autonomous (a Hamiltonian); give 0")
    count, m = states.shape
    if m != 2 * system.n_dof:
        raise ValueError(f"states have {m} columns; {system.name} has {2 * system.n_dof} phase coordinates")
    sample_times = np.zeros(0) if sample_times is None else np.ascontiguousarray(sample_times, dtype=np.float64)
    if len(sample_times) and (np.any(np.diff(np.abs(sample_times)) < 0) or np.any(sample_times * duration < 0)
                              or abs(sample_times[-1]) > abs(duration)):
        raise ValueError("sample_times must run from 0 towards duration, within it")
    index, value, direction, max_crossings = _section_arguments(section, system.phase_coordinates, max_crossings)
    if index >= system.n_dof and system.mass_matrix is not None:
        # The driver carries v = M^-1 p (ldpipe.engine.kinetic). With diagonal masses p_i = m_i v_i,
        # so p_i = c is v_i = c / m_i, crossed the same way; otherwise p_i mixes every v.
        name = system.phase_coordinates[index]
        row = system.mass[index - system.n_dof]
        if np.count_nonzero(row) != 1:
            raise ValueError(
                f"section {name} = {value}: crossings of a momentum are located for diagonal masses only; "
                f"{system.name}'s kinetic matrix couples {name} to other momenta (use a coordinate section)"
            )
        value = value / row[index - system.n_dof]
    samples = np.zeros((count, len(sample_times), m))
    crossings = np.zeros((count, max_crossings, m))
    crossing_times = np.zeros((count, max_crossings))
    status = np.zeros(count, dtype=np.int64)
    n_cross = np.zeros(count, dtype=np.int64)
    n_samples = np.zeros(count, dtype=np.int64)
    final_time = np.zeros(count)
    steps = np.zeros(count, dtype=np.int64)
    if count == 0:
        return Trajectories(sample_times, samples, n_samples, crossings, crossing_times, n_cross, status, final_time,
                            steps)
    threads = _thread_count(threads)
    lanes = SMALL_LANES if count <= SMALL_LANES else LANES
    # Units of at most a block (fewer trajectories when a block each would leave a thread idle),
    # or ~8 per thread for load balance, up to 16 blocks (as the LD engine).
    unit = max(min(lanes, -(-count // threads)), min(16 * lanes, count // (8 * threads)))
    runner = get_runner(system, "dop853", lanes, entry="flow_process")
    args = (
        1.0 if duration >= 0 else -1.0, abs(float(duration)), settings.rtol, settings.atol, settings.escape_radius,
        settings.max_steps, np.abs(sample_times), index, float(value), float(direction),
    )
    outputs = (samples, n_samples, crossings, crossing_times, n_cross, status, final_time, steps)
    # With masses the driver carries (q, M^-1 p) (ldpipe.engine.kinetic); results are in (q, p).
    run_units(runner, to_engine_states(system, states), unit, args, outputs, threads)
    to_momenta(system, samples)
    to_momenta(system, crossings)
    final_time *= 1.0 if duration >= 0 else -1.0
    return Trajectories(sample_times, samples, n_samples, crossings, crossing_times, n_cross, status, final_time, steps)


def _section_arguments(section, coordinates, max_crossings: int) -> tuple[int, float, int, int]:
    """The drivers' (index, value, direction, max_crossings) of ``section`` = (name, value,
    direction) over the state's ``coordinates``; without a section, no crossings."""
    if section is None:
        return 0, 0.0, 1, 0
    name, value, direction = section
    return coordinates.index(name), value, direction, max_crossings


def _thread_count(threads: int | None) -> int:
    """``threads`` within numba's pool, or all of it."""
    import numba  # here: the engine's runners load numba too; a job that integrates nothing never does

    return min(threads, numba.config.NUMBA_NUM_THREADS) if threads else numba.get_num_threads()


def _integrate_vector_field(system, states, duration, settings, section, max_crossings, threads, t0) -> Trajectories:
    """:func:`integrate` for a vector field: crossings and escapes from t0 (see its docstring), the
    escape radius raised as the LD engine raises it (:func:`engine_escape_radius`)."""
    from ..engine.vector_field import engine_dimension, get_vector_field_runner

    count, m = states.shape
    if m != system.n_state:
        raise ValueError(f"states have {m} columns; {system.name} has {system.n_state} state variables")
    if section is not None and engine_dimension(system) != m:
        raise ValueError(f"system {system.name!r} is integrated in another form than its state variables "
                         f"{tuple(system.coordinates)} (3-D positions round a pole), where a section of one of them "
                         "is not a value of an engine state's component; its crossings are not located")
    index, value, direction, max_crossings = _section_arguments(section, system.coordinates, max_crossings)
    crossings = np.zeros((count, max_crossings, m))
    crossing_times = np.zeros((count, max_crossings))
    n_cross = np.zeros(count, dtype=np.int64)
    status = np.zeros(count, dtype=np.int64)
    final_time = np.zeros(count)
    steps = np.zeros(count, dtype=np.int64)
    if count:
        threads = _thread_count(threads)
        runner = get_vector_field_runner(system, "vector_field_crossings")
        args = (t0, 1.0 if duration >= 0 else -1.0, abs(float(duration)), settings.rtol, settings.atol,
                engine_escape_radius(system, settings.escape_radius), settings.max_steps, index, float(value),
                float(direction))
        outputs = (crossings, crossing_times, n_cross, status, final_time, steps)
        engine_states = np.ascontiguousarray(system.engine_states(states), dtype=np.float64)
        with system.time_window(t0, t0 + float(duration)):
            run_units(runner, engine_states, max(1, min(64, count // (8 * threads))), args, outputs, threads)
        if engine_states is not states:  # the crossings as state variables
            found = np.arange(max_crossings)[None, :] < n_cross[:, None]
            crossings[found] = system.states_from_engine(crossings[found])
    return Trajectories(np.zeros(0), np.zeros((count, 0, m)), np.zeros(count, dtype=np.int64), crossings,
                        crossing_times, n_cross, status, final_time, steps)


class FlowMap(NamedTuple):
    """What :func:`flow_map` returns for ``k`` trajectories: ``end_state`` (k, n) where each is
    after the duration (or stopped), ``status`` (k; ``STATUS_MEANINGS``), ``final_time`` (k,
    signed: the duration, or where it stopped) and ``steps`` (k, step attempts)."""

    end_state: np.ndarray
    status: np.ndarray
    final_time: np.ndarray
    steps: np.ndarray


def flow_map(system, states: np.ndarray, duration: float, settings: FlowSettings, *, t0: float = 0.0,
             threads: int | None = None) -> FlowMap:
    """Where each row of ``states`` is after ``duration`` (negative: backward) from ``t0``, of a
    vector-field system, by the LD engine's steps without its LD (``vector_field_endpoints``):
    the end states equal :func:`ldpipe.engine.compute_ld`'s bit for bit at the same tolerances.
    The escape radius is raised as the LD engine raises it (:func:`engine_escape_radius`)."""
    from ..engine.vector_field import ENDPOINTS, engine_dimension, get_vector_field_runner

    if settings.method == "cell_crossing":
        return _cell_crossing_flow_map(system, states, duration, settings, t0, threads)
    if system.hamiltonian:
        raise ValueError(f"system {system.name!r}: the flow map alone is of vector-field systems; a Hamiltonian's "
                         "end states are integrate()'s samples at the duration")
    states = np.ascontiguousarray(states, dtype=np.float64)
    count, m = states.shape
    if m != system.n_state:
        raise ValueError(f"states have {m} columns; {system.name} has {system.n_state} state variables")
    outputs = (np.zeros((count, engine_dimension(system))), np.zeros(count, dtype=np.int64), np.zeros(count),
               np.zeros(count, dtype=np.int64))
    if count:
        threads = _thread_count(threads)
        runner = get_vector_field_runner(system, ENDPOINTS)
        args = (float(t0), 1.0 if duration >= 0 else -1.0, abs(float(duration)), settings.rtol, settings.atol,
                engine_escape_radius(system, settings.escape_radius), settings.max_steps)
        engine_states = np.ascontiguousarray(system.engine_states(states), dtype=np.float64)
        with system.time_window(t0, t0 + float(duration)):
            run_units(runner, engine_states, max(1, min(256, count // (8 * threads) or 1)), args, outputs, threads)
        if hasattr(system, "times_from_engine"):  # an engine state that says when a trajectory stopped
            outputs = outputs[:2] + (system.times_from_engine(outputs[0], outputs[2]),) + outputs[3:]
        outputs = (states_at_end(system, states, engine_states, outputs[0]),) + outputs[1:]
    end, status, elapsed, steps = outputs
    return FlowMap(end, status, elapsed * (1.0 if duration >= 0 else -1.0), steps)


def _cell_crossing_flow_map(system, states: np.ndarray, duration: float, settings: FlowSettings, t0: float,
                            threads: int | None) -> FlowMap:
    """:func:`flow_map` by the C-grid's exact cell crossing (``method: cell_crossing``)."""
    from ..systems.velocity_data.cell_crossing import cell_crossing_endpoints
    from ..systems.velocity_data.staggered import StaggeredVelocitySystem

    if not isinstance(system, StaggeredVelocitySystem):
        raise ValueError(f"system {system.name!r}: method 'cell_crossing' moves points through a C-grid's cells "
                         "(velocity data with u and v on the faces); use method 'dop853'")
    states = np.ascontiguousarray(states, dtype=np.float64)
    count = len(states)
    outputs = (np.zeros((count, 2)), np.zeros(count, dtype=np.int64), np.zeros(count), np.zeros(count, dtype=np.int64))
    if count:
        engine_states = np.ascontiguousarray(system.engine_states(states), dtype=np.float64)
        with system.time_window(t0, t0 + float(duration)) as window:
            if window.buffer[9] > 0.0:  # the staggered kernel's header: where uneven times start
                raise ValueError(f"system {system.name!r}: method 'cell_crossing' needs the data at evenly "
                                 "spaced times (its series are per data interval of one length); use method "
                                 "'dop853'")
            args = (window.buffer, float(t0), 1.0 if duration >= 0 else -1.0, abs(float(duration)), settings.max_steps)
            run_units(cell_crossing_endpoints, engine_states, max(1, min(256, count // (8 * _thread_count(threads)) or 1)),
                      args, outputs, _thread_count(threads))
        outputs = (states_at_end(system, states, engine_states, outputs[0]),) + outputs[1:]
    end, status, elapsed, steps = outputs
    return FlowMap(end, status, elapsed * (1.0 if duration >= 0 else -1.0), steps)
