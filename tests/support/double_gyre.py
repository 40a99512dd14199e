"""The double gyre of Shadden, Lekien & Marsden (2005), Physica D 212, 271, eq. (9):

    u = -pi A sin(pi f(x, t)) cos(pi y),  v = pi A cos(pi f(x, t)) sin(pi y) df/dx,
    f(x, t) = eps sin(w t) x^2 + (1 - 2 eps sin(w t)) x,

on [0, 2] x [0, 1], with the paper's A = 0.1, eps = 0.25, w = 2 pi / 10. As a formula system
(``DOUBLE_GYRE``), as numpy (``double_gyre_velocity``, vectorized, for sampling it onto grids
and for scipy references); its hyperbolic trajectories on the walls and their manifolds by the
direct method (``hyperbolic_trajectory``, ``wall_manifold``), with scipy alone.
"""

import math

import numpy as np
from scipy.integrate import solve_ivp

A, EPS, OMEGA = 0.1, 0.25, 2 * math.pi / 10
DOUBLE_GYRE = {
    "vector_field": {
        "x": "-pi*A*sin(pi*(eps*sin(w*t)*x**2 + (1 - 2*eps*sin(w*t))*x))*cos(pi*y)",
        "y": "pi*A*cos(pi*(eps*sin(w*t)*x**2 + (1 - 2*eps*sin(w*t))*x))*sin(pi*y)*(2*eps*sin(w*t)*x + 1 - 2*eps*sin(w*t))",
    },
    "coordinates": ["x", "y"],
    "parameters": {"A": A, "eps": EPS, "w": OMEGA},
}


def double_gyre_velocity(x, y, t):
    """(u, v) at points x, y (arrays broadcasting together) and time t."""
    a = EPS * np.sin(OMEGA * t)
    f = a * x**2 + (1 - 2 * a) * x
    dfdx = 2 * a * x + 1 - 2 * a
    return -np.pi * A * np.sin(np.pi * f) * np.cos(np.pi * y), np.pi * A * np.cos(np.pi * f) * np.sin(np.pi * y) * dfdx


def double_gyre_field(t, state):
    """solve_ivp's right-hand side."""
    u, v = double_gyre_velocity(state[0], state[1], t)
    return np.array([u, v])


def sampled_gyre_errors(directory, grids, probes: int) -> tuple[list[float], list[float]]:
    """The double gyre sampled on each grid of ``grids`` (``(x, y, t)`` node arrays covering
    [0, 2] x [0, 1] x [1.5, 7.5]) as velocity data: the largest LD error against the formula
    system over 30 starts (tau = 5 from t0 = 2, rtol 1e-12), and the largest velocity error at
    ``probes`` random points, per grid (:func:`support.gridded.sampled_flow_errors`)."""
    from support.gridded import sampled_flow_errors

    grid = np.meshgrid(np.linspace(0.15, 1.85, 6), np.linspace(0.1, 0.9, 5))
    starts = np.column_stack([grid[0].ravel(), grid[1].ravel()])
    return sampled_flow_errors(directory, grids, probes, formula=DOUBLE_GYRE, velocity=double_gyre_velocity,
                               starts=starts, t0=2.0, tau=5.0, probe_box=((0, 2), (0, 1), (2, 7)))


# ---------------------------------------------------------------- the direct method: hyperbolic
# trajectories on the walls and their manifolds, by scipy alone (no ldpipe code)

PERIOD = 2 * math.pi / OMEGA


def _wall_velocity(x, t, wall: int):
    """u and du/dx on the wall y = ``wall`` (0 or 1), where v = 0 (the walls are invariant):
    u = -pi A sin(pi f) cos(pi wall)."""
    a = EPS * np.sin(OMEGA * t)
    f, dfdx = a * x**2 + (1 - 2 * a) * x, 2 * a * x + 1 - 2 * a
    sign = 1.0 if wall == 0 else -1.0
    return -sign * math.pi * A * np.sin(math.pi * f), -sign * math.pi**2 * A * np.cos(math.pi * f) * dfdx


def hyperbolic_trajectory(wall: int, t0: float) -> tuple[float, float]:
    """Where the distinguished hyperbolic trajectory on the wall y = ``wall`` near x = 1 is at
    ``t0``, and the multiplier of its period map along the wall: the periodic orbit of the wall's
    1-D flow x' = u(x, wall, t), by Newton on the period map (its derivative from the variational
    equation). On the bottom wall the orbit repels along the wall (the wall is its unstable
    manifold), on the top wall it attracts; Newton runs on the map over one period in the
    direction of time that contracts, so that it converges from x = 1 (the steady saddle)."""
    direction = -1.0 if wall == 0 else 1.0

    def rhs(t, state):
        u, dudx = _wall_velocity(state[0], t, wall)
        return [u, dudx * state[1]]

    x = 1.0
    for _ in range(30):
        sol = solve_ivp(rhs, (t0, t0 + direction * PERIOD), [x, 1.0], method="DOP853", rtol=1e-13, atol=1e-13)
        step = -(sol.y[0, -1] - x) / (sol.y[1, -1] - 1.0)
        x += step
        if abs(step) < 1e-13:
            return x, float(sol.y[1, -1])
    raise RuntimeError("Newton on the period map did not converge")


def _many_field(t, state):
    half = len(state) // 2
    u, v = double_gyre_velocity(state[:half], state[half:], t)
    return np.concatenate([u, v])


def advect(points: np.ndarray, t_from: float, t_to: float, rtol: float = 1e-11) -> np.ndarray:
    """``points`` (n, 2) carried by the flow from ``t_from`` to ``t_to`` (scipy's DOP853)."""
    if t_from == t_to or not len(points):
        return np.array(points, dtype=float)
    sol = solve_ivp(_many_field, (t_from, t_to), np.concatenate([points[:, 0], points[:, 1]]), method="DOP853",
                    rtol=rtol, atol=rtol)
    return np.column_stack([sol.y[:len(points), -1], sol.y[len(points):, -1]])


def wall_manifold(wall: int, t0: float, periods: int, spacing: float, seed_length: float = 1e-3) -> np.ndarray:
    """The manifold of the wall's hyperbolic trajectory that leaves the wall, at time ``t0``: the
    stable one of the bottom trajectory, the unstable one of the top, as a polyline from the
    trajectory outward, grown over ``periods`` periods.

    On a wall the Jacobian is diagonal (u_y = v_x = 0 there), so the direction off the wall is an
    eigenvector at every time: the segment of ``seed_length`` along it from the trajectory, taken
    ``periods`` periods before t0 (unstable) or after it (stable; the trajectory is periodic,
    so it is where it is at t0), is advected to t0 one time unit at a time, and after each step a
    point is inserted, advected from the segment, midway (in the segment's parameter) between any
    two neighbours further apart than ``spacing`` (refinement by arc length).
    """
    x_h, _ = hyperbolic_trajectory(wall, t0)
    start = np.array([x_h, float(wall)])
    off_wall = np.array([0.0, 1.0 if wall == 0 else -1.0])
    t_start = t0 + (periods * PERIOD if wall == 0 else -periods * PERIOD)
    s = np.linspace(0.0, seed_length, 20)
    points, t = start + s[:, None] * off_wall, t_start
    while t != t0:
        t_next = t0 if abs(t0 - t) <= 1.0 else t + math.copysign(1.0, t0 - t)
        points, t = advect(points, t, t_next), t_next
        while True:
            wide = np.flatnonzero(np.hypot(*np.diff(points, axis=0).T) > spacing)
            if not len(wide):
                break
            middle = 0.5 * (s[wide] + s[wide + 1])
            points = np.insert(points, wide + 1, advect(start + middle[:, None] * off_wall, t_start, t), axis=0)
            s = np.insert(s, wide + 1, middle)
    return points
