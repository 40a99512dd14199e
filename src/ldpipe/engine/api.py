"""The public entry point: ``compute_ld(system, initial_states, direction, settings)``."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .integrator import get_runner, run_units
from .integrands import integrand_for
from .kinetic import to_engine_states, to_momenta
from .gauss_rules import folded_jacobi_rule, legendre_rule
from .schemes import check_scheme, get_scheme
from .settings import LDSettings, engine_escape_radius


class LDResult(NamedTuple):
    """Per-trajectory results of :func:`compute_ld`, arrays of shape (N,) (``end_state``: (N, 2 n_dof)).

    ld : float64
        The Lagrangian descriptor accumulated over [0, time].
    time : float64
        |t| actually integrated: tau, or the exit time from the region box, or the escape time.
    escaped : bool
        Stopped because max_i |q_i| exceeded the escape radius: dop853 at the crossing located
        on the step, the fixed-step schemes at the start of the step that left the radius (or
        overflowed), the last state they can trust; ``ld``, ``time`` and ``energy_error`` are
        those of that point.
    left_region : bool
        Stopped at the first exit from the region box (variable-time LD only).
    energy_error : float64
        |H(end) - H(start)|, H at the end taken on the interpolant at the stopping time; 0 for a
        vector-field system, which has no energy (its LD map files carry no energy error).
    steps : int64
        Step attempts (accepted and rejected): the work spent on the trajectory.
    failed : bool
        Stopped early by the step cap, or (dop853) a step size below 1e-13 tau;
        ``ld`` and ``time`` then cover the part integrated.
    end_state : float64, shape (N, 2 n_dof)
        The state (q..., p...) where the trajectory stopped, the one ``energy_error`` is taken
        at: at tau; at the region exit or the escape crossing, on the step's interpolant at the
        located crossing (adaptive schemes; the fixed-step ones locate region exits the same
        way); for a fixed-step escape, at the start of the step that left the radius; for a
        failed trajectory, the last accepted state; for one that did not start (outside the
        region or the escape radius, or not finite), the initial state.
    exit_face : int64
        The face of the region box the trajectory left by: +(i+1) for the upper face
        (q_i = region_upper[i]), -(i+1) for the lower face of coordinate i; for a trajectory
        starting outside the region, the face it is beyond (lowest i); 0 if it did not leave
        the region (also for escapes and fixed-time LDs). Nonzero exactly where ``left_region``.
    """

    ld: np.ndarray
    time: np.ndarray
    escaped: np.ndarray
    left_region: np.ndarray
    energy_error: np.ndarray
    steps: np.ndarray
    failed: np.ndarray
    end_state: np.ndarray
    exit_face: np.ndarray


def _kind(p) -> tuple[int, float]:
    """The integrand's compile-time kind and the exponent the compiled quadrature takes."""
    integrand = integrand_for(p)
    return integrand.kind, integrand.p_exponent(p)


def compute_ld(
    system, initial_states, direction: int = 1, settings: LDSettings | None = None, t0: float = 0.0
) -> LDResult:
    """Lagrangian descriptors of many trajectories of a natural Hamiltonian system or a general flow.

    The LD integrand is over the phase-space velocity (dq/dt, dp/dt) = (M^-1 p, -grad V)
    of H = p^T M^-1 p / 2 + V (M = I without masses).

    Parameters
    ----------
    system : ldpipe.systems.System or ldpipe.systems.VectorFieldSystem
        The system; its compiled kernels drive the integration.
    initial_states : array_like, shape (N, 2 n_dof) or (N, n_state)
        Rows (q_1..q_n, p_1..p_n); for a vector field, rows of its state variables. The region
        box and the escape radius apply to the configuration q of a Hamiltonian system and to
        every state variable of a vector field.
    direction : {+1, -1}
        +1 integrates forward in time, -1 backward (the vector field is integrated with
        negative time steps; momenta are not flipped).
    settings : LDSettings, optional
        Numerical settings; defaults to ``LDSettings()``.
    t0 : float
        The start time: trajectories run over [t0, t0 + direction tau]. Only a time-dependent
        vector field depends on it; the Hamiltonian systems are autonomous and must leave it 0.

    Returns
    -------
    LDResult
        Arrays of shape (N,) (``end_state``: (N, 2 n_dof)), in the order of ``initial_states``.
    """
    settings = LDSettings() if settings is None else settings
    if not isinstance(settings, LDSettings):
        raise TypeError(f"settings: expected LDSettings, got {type(settings).__name__}")
    if isinstance(direction, bool) or direction not in (1, -1):
        raise ValueError(f"direction: expected +1 (forward) or -1 (backward), got {direction!r}")
    t0 = float(t0)
    if not math.isfinite(t0):
        raise ValueError(f"t0: expected a finite start time, got {t0!r}")
    if not system.hamiltonian:
        return _compute_vector_field_ld(system, initial_states, direction, settings, t0)
    if t0 != 0.0:
        raise ValueError(f"t0: system {system.name!r} is autonomous (a Hamiltonian); a start time {t0!r} changes nothing, give 0")
    n = system.n_dof
    states = np.ascontiguousarray(initial_states, dtype=np.float64)
    if states.ndim == 1 and states.shape[0] == 2 * n:
        states = states[None, :]
    if states.ndim != 2 or states.shape[1] != 2 * n:
        raise ValueError(
            f"initial_states: expected shape (N, {2 * n}) with rows (q..., p...) for {system.name}, got {states.shape}"
        )
    if settings.variable_time:
        if len(settings.region_lower) != n:
            raise ValueError(
                f"region_lower, region_upper: expected {n} values (one per coordinate {system.coordinates}), "
                f"got {len(settings.region_lower)}"
            )
        lo = np.array(settings.region_lower, dtype=np.float64)
        hi = np.array(settings.region_upper, dtype=np.float64)
    else:
        lo = np.full(n, -np.inf)
        hi = np.full(n, np.inf)
    kind, p_exp = _kind(settings.p)
    nodes = settings.nodes
    glx, glw = legendre_rule(nodes)
    gjx, gjf = folded_jacobi_rule(nodes, p_exp)
    n_fixed = 1 if settings.adaptive else max(1, math.ceil(settings.tau / settings.dt - 1e-9))

    N = states.shape[0]
    outputs = (
        np.zeros(N),
        np.zeros(N),
        np.zeros(N, dtype=np.bool_),
        np.zeros(N, dtype=np.bool_),
        np.zeros(N),
        np.zeros(N, dtype=np.int64),
        np.zeros(N, dtype=np.bool_),
        np.zeros((N, 2 * n)),
        np.zeros(N, dtype=np.int64),
    )
    if N == 0:
        return LDResult(*outputs)
    lanes = settings.lanes
    from numba import get_num_threads

    # Units of whole blocks, at least ~8 per thread for load balance, at most 16 blocks each.
    per_thread = max(1, N // (8 * get_num_threads()))
    unit = max(lanes, min(16 * lanes, per_thread))
    runner = get_runner(system, settings.scheme, lanes, settings.order)
    args = (
        float(direction),
        settings.tau,
        settings.dt,
        n_fixed,
        settings.rtol,
        settings.atol,
        kind,
        p_exp,
        lo,
        hi,
        settings.variable_time,
        settings.escape_radius,
        settings.max_steps,
        glx,
        glw,
        gjx,
        gjf,
        settings.quadrature_window,
        get_scheme(settings.scheme).coefficients(),
    )
    # With masses the drivers carry (q, M^-1 p) (ldpipe.engine.kinetic); results are in (q, p).
    run_units(runner, to_engine_states(system, states), unit, args, outputs, get_num_threads())
    to_momenta(system, outputs[7])
    return LDResult(*outputs)


def _region(settings: LDSettings, n: int, names) -> tuple[np.ndarray, np.ndarray]:
    """The region box as arrays (infinite without variable time), checked against the dimension."""
    if not settings.variable_time:
        return np.full(n, -np.inf), np.full(n, np.inf)
    if len(settings.region_lower) != n:
        raise ValueError(
            f"region_lower, region_upper: expected {n} values (one per coordinate {tuple(names)}), "
            f"got {len(settings.region_lower)}"
        )
    return np.array(settings.region_lower, dtype=np.float64), np.array(settings.region_upper, dtype=np.float64)


def _compute_vector_field_ld(system, initial_states, direction: int, settings: LDSettings, t0: float) -> LDResult:
    """compute_ld for a general flow: first-order DOP853 (:mod:`ldpipe.engine.vector_field`)."""
    from numba import get_num_threads

    from .vector_field import engine_dimension, get_vector_field_runner

    check_scheme(get_scheme(settings.scheme), system)
    n = system.n_state
    states = np.ascontiguousarray(initial_states, dtype=np.float64)
    if states.ndim == 1 and states.shape[0] == n:
        states = states[None, :]
    if states.ndim != 2 or states.shape[1] != n:
        raise ValueError(f"initial_states: expected shape (N, {n}) with rows {system.coordinates} for {system.name}, "
                         f"got {states.shape}")
    lo, hi = _region(settings, n, system.coordinates)
    engine_states = np.ascontiguousarray(system.engine_states(states), dtype=np.float64)
    if settings.variable_time and engine_states is not states:
        raise ValueError(f"region_lower, region_upper: system {system.name!r} is integrated in another form than "
                         "its state variables (a curvilinear grid's indices, 3-D positions round a pole), where a "
                         "region box of its state variables is not a box; give a fixed-time LD")
    kind, p_exp = _kind(settings.p)
    glx, glw = legendre_rule(settings.nodes)
    gjx, gjf = folded_jacobi_rule(settings.nodes, p_exp)
    N = states.shape[0]
    m = engine_dimension(system)
    if m != n:  # the engine's states are another form of the state (no region there: a fixed-time LD, refused above)
        lo, hi = np.full(m, -np.inf), np.full(m, np.inf)
    outputs = (np.zeros(N), np.zeros(N), np.zeros(N, dtype=np.bool_), np.zeros(N, dtype=np.bool_),
               np.zeros(N, dtype=np.int64), np.zeros(N, dtype=np.bool_), np.zeros((N, m)), np.zeros(N, dtype=np.int64))
    if N:
        runner = get_vector_field_runner(system)
        radius = engine_escape_radius(system, settings.escape_radius)
        args = (t0, float(direction), settings.tau, settings.rtol, settings.atol, kind, p_exp, lo, hi,
                settings.variable_time, radius, settings.max_steps, glx, glw, gjx, gjf,
                settings.quadrature_window)
        threads = get_num_threads()
        with system.time_window(t0, t0 + direction * settings.tau):
            run_units(runner, engine_states, max(1, min(256, N // (8 * threads) or 1)), args, outputs, threads)
    ld, time, escaped, left, steps, failed, end, face = outputs
    if hasattr(system, "times_from_engine"):  # an engine state that says when a trajectory stopped
        time = system.times_from_engine(end, time)
    end = states_at_end(system, states, engine_states, end)
    return LDResult(ld, time, escaped, left, np.zeros(N), steps, failed, end, face)


def states_at_end(system, states: np.ndarray, engine_states: np.ndarray, engine_ends: np.ndarray) -> np.ndarray:
    """The end states of a flow's trajectories as its state variables, from the engine's (a
    curvilinear grid's indices mapped back); one that never moved ends where it started, exactly
    (a start off the grid, whose indices have no coordinates)."""
    if engine_states is states:
        return engine_ends
    ends = np.array(system.states_from_engine(engine_ends), dtype=np.float64)
    same = (engine_ends == engine_states) | (np.isnan(engine_ends) & np.isnan(engine_states))  # NaN: not started
    unmoved = np.all(same, axis=1)
    ends[unmoved] = states[unmoved]
    return ends
