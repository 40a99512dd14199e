"""The perturbed Bickley jet of Rypina et al. (2007), J. Atmos. Sci. 64, 3595, eq. (2)-(3), in units
of the jet's speed U and width L (U = L = 1): the stream function

    psi = -tanh(y) + sech(y)^2 * sum_n eps_n cos(k_n (x - c_n t)),

u = -d psi / dy = sech(y)^2 (1 + 2 tanh(y) S),  v = d psi / dx = -sech(y)^2 sum_n eps_n k_n sin(k_n (x - c_n t)),
S = sum_n eps_n cos(k_n (x - c_n t)), with the paper's amplitudes eps = (0.075, 0.4, 0.3) and phase
speeds c = (0.1446, 0.205, 0.461) (in U), and wavenumbers k_n = n pi / 3 (a channel of length 6).
As a formula system (``BICKLEY_JET``) and as numpy (``bickley_velocity``).
"""

import math

import numpy as np

EPS = (0.075, 0.4, 0.3)
SPEEDS = (0.1446, 0.205, 0.461)
WAVENUMBERS = tuple(n * math.pi / 3 for n in (1, 2, 3))

_waves = [f"e{n}*cos(k{n}*(x - c{n}*t))" for n in (1, 2, 3)]
_slopes = [f"e{n}*k{n}*sin(k{n}*(x - c{n}*t))" for n in (1, 2, 3)]
BICKLEY_JET = {
    "vector_field": {
        "x": f"(1 + 2*tanh(y)*({' + '.join(_waves)}))/cosh(y)**2",
        "y": f"-({' + '.join(_slopes)})/cosh(y)**2",
    },
    "coordinates": ["x", "y"],
    "parameters": {**{f"e{n}": e for n, e in zip((1, 2, 3), EPS)}, **{f"c{n}": c for n, c in zip((1, 2, 3), SPEEDS)},
                   **{f"k{n}": k for n, k in zip((1, 2, 3), WAVENUMBERS)}},
}


def bickley_velocity(x, y, t):
    """(u, v) at points x, y (arrays broadcasting together) and time t."""
    phases = [k * (x - c * t) for k, c in zip(WAVENUMBERS, SPEEDS)]
    waves = sum(e * np.cos(phase) for e, phase in zip(EPS, phases))
    slopes = sum(e * k * np.sin(phase) for e, k, phase in zip(EPS, WAVENUMBERS, phases))
    sech2 = 1.0 / np.cosh(y) ** 2
    return sech2 * (1 + 2 * np.tanh(y) * waves), -sech2 * slopes
