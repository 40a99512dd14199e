"""The double gyre of Shadden, Lekien & Marsden (2005), Physica D 212, 271, eq. (9):

    u = -pi A sin(pi f(x, t)) cos(pi y),  v = pi A cos(pi f(x, t)) sin(pi y) df/dx,
    f(x, t) = eps sin(w t) x^2 + (1 - 2 eps sin(w t)) x,

on [0, 2] x [0, 1], with the paper's A = 0.1, eps = 0.25, w = 2 pi / 10. As a formula system
(``DOUBLE_GYRE``), as numpy (``double_gyre_velocity``, vectorized, for sampling it onto grids
and for scipy references).
"""

import math

import numpy as np

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
