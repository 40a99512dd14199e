"""Trajectories with their state transition matrix, for periodic orbits and their stability.

The variational equations dPhi/dt = J(x(t)) Phi, Phi(0) = I are integrated with
the equations of motion by scipy's DOP853 (``solve_ivp``) at tight tolerances;
J is the Jacobian of Hamilton's equations, [[0, M^-1], [-Hess V(q), 0]] (M = I without
masses), from the system's compiled Hessian. This is the careful, per-trajectory path; the batch
integrator for many trajectories is :mod:`ldpipe.core.trajectories`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..systems import System

# scipy.integrate (a third of a second to import) is imported by the functions that integrate:
# the NHIM studies and samplings reach this module for the saddle's linearization alone.


@dataclass(frozen=True)
class FlowResult:
    """The end of an integration with its state transition matrix.

    ``time`` is where it stopped (an event's time if one fired), ``state`` has
    shape ``(2n,)``, ``stm`` shape ``(2n, 2n)``; ``event`` says whether the
    terminal event fired.
    """

    time: float
    state: np.ndarray
    stm: np.ndarray
    event: bool
    nfev: int


def _rhs_with_stm(system: System) -> Callable:
    n = system.n_dof
    m = 2 * n
    gradient = system.kernels.gradient
    hessian = system.kernels.hessian
    inverse = None if system.mass_matrix is None else system.inverse_mass

    def rhs(_t, y):
        q = np.ascontiguousarray(y[:n])
        grad = np.empty(n)
        hess = np.empty((n, n))
        gradient(q, grad)
        hessian(q, hess)
        phi = y[m:].reshape(m, m)
        out = np.empty_like(y)
        out[n:m] = -grad
        dphi = out[m:].reshape(m, m)
        if inverse is None:
            out[:n] = y[n:m]
            dphi[:n] = phi[n:]  # d(Phi_q)/dt = Phi_p
        else:
            out[:n] = inverse @ y[n:m]
            dphi[:n] = inverse @ phi[n:]  # d(Phi_q)/dt = M^-1 Phi_p
        dphi[n:] = -hess @ phi[:n]  # d(Phi_p)/dt = -Hess V Phi_q
        return out

    return rhs


def _rhs(system: System) -> Callable:
    n = system.n_dof
    gradient = system.kernels.gradient
    inverse = None if system.mass_matrix is None else system.inverse_mass

    def rhs(_t, y):
        grad = np.empty(n)
        gradient(np.ascontiguousarray(y[:n]), grad)
        return np.concatenate([y[n:] if inverse is None else inverse @ y[n:], -grad])

    return rhs


def propagate(
    system: System,
    state: np.ndarray,
    duration: float,
    *,
    rtol: float,
    atol: float,
    event_momentum: int | None = None,
    event_direction: int = 0,
    stm: bool = True,
) -> FlowResult:
    """Integrate from ``state`` for ``duration`` (negative: backward), with the STM.

    With ``event_momentum`` k, stop at the first zero of the momentum p_k crossed in
    ``event_direction`` (+1 increasing, -1 decreasing, 0 either) after the start.
    """
    from scipy.integrate import solve_ivp

    n = system.n_dof
    m = 2 * n
    state = np.asarray(state, dtype=np.float64)
    y0 = np.concatenate([state, np.eye(m).ravel()]) if stm else state.copy()
    events = None
    if event_momentum is not None:
        index = n + event_momentum

        def momentum_event(_t, y):
            return y[index]

        momentum_event.terminal = True
        momentum_event.direction = event_direction
        events = [momentum_event]
    result = solve_ivp(
        _rhs_with_stm(system) if stm else _rhs(system), (0.0, duration), y0,
        method="DOP853", rtol=rtol, atol=atol, events=events,
    )
    if result.status == -1:
        raise RuntimeError(f"integration failed: {result.message}")
    fired = bool(events) and len(result.t_events[0]) > 0
    if fired:
        time, y = float(result.t_events[0][0]), result.y_events[0][0]
    else:
        time, y = float(result.t[-1]), result.y[:, -1]
    return FlowResult(
        time=time, state=np.array(y[:m]), stm=np.array(y[m:]).reshape(m, m) if stm else np.eye(m),
        event=fired, nfev=int(result.nfev),
    )


def sample(
    system: System, state: np.ndarray, times: np.ndarray, *, rtol: float, atol: float, stm: bool = False
) -> tuple[np.ndarray, np.ndarray | None]:
    """States (and with ``stm`` the STMs) at ``times`` (increasing from 0) along the trajectory."""
    from scipy.integrate import solve_ivp

    n = system.n_dof
    m = 2 * n
    state = np.asarray(state, dtype=np.float64)
    y0 = np.concatenate([state, np.eye(m).ravel()]) if stm else state.copy()
    times = np.asarray(times, dtype=np.float64)
    result = solve_ivp(
        _rhs_with_stm(system) if stm else _rhs(system), (0.0, float(times[-1])), y0,
        method="DOP853", rtol=rtol, atol=atol, t_eval=times,
    )
    if result.status != 0:
        raise RuntimeError(f"integration failed: {result.message}")
    states = result.y[:m].T.copy()
    stms = result.y[m:].T.reshape(len(times), m, m).copy() if stm else None
    return states, stms


def propagate_flow(system, state: np.ndarray, t0: float, duration: float, *, rtol: float, atol: float) -> FlowResult:
    """A general flow's trajectory from ``state`` at ``t0`` for ``duration`` (negative: backward)
    with its state transition matrix, dPhi/dt = Df(x, t) Phi (Df the system's compiled Jacobian)."""
    from scipy.integrate import solve_ivp

    m = system.n_state

    def rhs(t, y):
        out = np.empty_like(y)
        out[:m] = system.vector_field(y[:m], t)
        out[m:] = (system.jacobian(y[:m], t) @ y[m:].reshape(m, m)).ravel()
        return out

    y0 = np.concatenate([np.asarray(state, dtype=np.float64), np.eye(m).ravel()])
    result = solve_ivp(rhs, (t0, t0 + duration), y0, method="DOP853", rtol=rtol, atol=atol)
    if result.status == -1:
        raise RuntimeError(f"integration failed: {result.message}")
    y = result.y[:, -1]
    return FlowResult(time=float(result.t[-1]) - t0, state=np.array(y[:m]), stm=np.array(y[m:]).reshape(m, m),
                      event=False, nfev=int(result.nfev))
