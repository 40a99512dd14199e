"""The period of a Lyapunov orbit against its energy, to first order, by Lindstedt–Poincaré.

Near an index-1 saddle of a cubic potential V (unit masses), write q - q_s in the orthonormal
eigenvectors of the Hessian: a centre mode a (Hess V e_a = omega^2 e_a) and the others b_j
(Hess V e_j = s_j e_j: s_j = -lambda^2 for the saddle, omega_j^2 for other centres). The cubic
part of V is C = D3[xi, xi, xi] / 6 with D3 the (constant) third derivatives; its coefficients
c30 = D3[e_a, e_a, e_a] / 6 (of a^3) and c21_j = D3[e_a, e_a, e_j] / 2 (of a^2 b_j) are all the
first correction needs. With tau = Omega t, Omega = omega + eps^2 omega_2, a = eps cos tau + eps^2 a_2
+ eps^3 a_3, b_j = eps^2 b_j2 + ...:

* order eps^2: omega^2 (a_2'' + a_2) = -3 c30 cos^2 tau gives a_2 = (c30 / (2 omega^2)) (cos 2 tau - 3);
  omega^2 b_j2'' + s_j b_j2 = -c21_j cos^2 tau has the bounded (periodic: the orbit stays on the
  centre manifold) solution b_j2 = -c21_j / (2 s_j) + c21_j cos 2 tau / (2 (4 omega^2 - s_j));
* order eps^3: the cos tau terms of omega^2 (a_3'' + a_3) - 2 omega omega_2 cos tau = -(6 c30 a_1 a_2
  + 2 sum_j c21_j a_1 b_j2) must cancel, so

    omega_2 = [-15 c30^2 / (2 omega^2) + sum_j c21_j^2 (-1 / s_j + 1 / (2 (4 omega^2 - s_j)))] / (2 omega)

  (one mode alone: Landau & Lifshitz's -5 alpha^2 A^2 / (12 omega^3) for a'' + omega^2 a = -alpha a^2);
* the energy at the turning point is E_c + omega^2 eps^2 / 2 + O(eps^4) (the eps^3 terms cancel).

So T = 2 pi / Omega = (2 pi / omega) (1 + kappa dE + O(dE^2)) with kappa = -2 omega_2 / omega^3. The
orbit's action J = integral of T dE (dJ/dE = T on a family of periodic orbits) is then
(2 pi dE / omega) (1 + kappa dE / 2 + O(dE^2)).

The closed-form saddles of the paper's two systems (position, energy, Hessian, third derivatives)
are here too, for these slopes and for other linearizations at the saddle (the NHIM's tangent).
"""

from __future__ import annotations

import math

import numpy as np

#: A bound on the O(dE^2) remainder |T omega / (2 pi) - 1 - kappa dE| / (|kappa| dE^2) for the paper's
#: systems: measured 0.0030 on the Barbanis family up to dE = 10 and the 3 DoF x-y mode at E = 24,
#: 1e-4 on the 3 DoF z mode. The action's remainder is then below a third of it (integrate over dE).
REMAINDER = 0.01


def period_energy_slope(hessian: np.ndarray, third: np.ndarray, mode: int = 0) -> float:
    """kappa in T = (2 pi / omega) (1 + kappa dE + O(dE^2)) for centre ``mode`` (0: the lowest
    frequency) of the saddle with this Hessian and these third derivatives of V (unit masses)."""
    values, vectors = np.linalg.eigh(hessian)
    centres = [i for i in range(len(values)) if values[i] > 0]
    a = centres[mode]
    omega2 = values[a]
    e = vectors[:, a]
    c30 = np.einsum("ijk,i,j,k", third, e, e, e) / 6
    correction = -15 * c30**2 / (2 * omega2)
    for j in range(len(values)):
        if j != a:
            c21 = np.einsum("ijk,i,j,k", third, e, e, vectors[:, j]) / 2
            correction += c21**2 * (-1 / values[j] + 1 / (2 * (4 * omega2 - values[j])))
    omega = math.sqrt(omega2)
    return -2 * (correction / (2 * omega)) / omega**3


def barbanis_saddle(y_sign: int = -1) -> tuple[np.ndarray, np.ndarray]:
    """Hessian and third derivatives of V = x^2/2 + 1.21 y^2/2 - 0.11 x y^2 at its saddle (5.5, +-sqrt 50)."""
    y = y_sign * math.sqrt(50.0)
    hessian = np.array([[1.0, -0.22 * y], [-0.22 * y, 1.21 - 0.22 * 5.5]])
    third = np.zeros((2, 2, 2))
    third[0, 1, 1] = third[1, 0, 1] = third[1, 1, 0] = -0.22  # V_xyy, the only one
    return hessian, third


def barbanis_contopoulos_saddle(omega_x2: float, omega_y2: float, omega_z2: float, epsilon: float,
                                eta: float) -> tuple[np.ndarray, float, np.ndarray, np.ndarray]:
    """Saddle (x > 0), its energy, and the Hessian and third derivatives there of
    V = (wx2 x^2 + wy2 y^2 + wz2 z^2)/2 - eps x^2 y - eta x^2 z (the paper's closed-form saddle:
    x^2 = wx2 wy2 wz2 / (2 (eps^2 wz2 + eta^2 wy2)), y = eps x^2 / wy2, z = eta x^2 / wz2)."""
    x2 = omega_x2 * omega_y2 * omega_z2 / (2 * (epsilon**2 * omega_z2 + eta**2 * omega_y2))
    x, y, z = math.sqrt(x2), epsilon * x2 / omega_y2, eta * x2 / omega_z2
    energy = (omega_x2 * x2 + omega_y2 * y**2 + omega_z2 * z**2) / 2 - epsilon * x2 * y - eta * x2 * z
    hessian = np.array([[omega_x2 - 2 * epsilon * y - 2 * eta * z, -2 * epsilon * x, -2 * eta * x],
                        [-2 * epsilon * x, omega_y2, 0.0],
                        [-2 * eta * x, 0.0, omega_z2]])
    third = np.zeros((3, 3, 3))
    for k, coupling in ((1, epsilon), (2, eta)):  # V_xxy = -2 eps, V_xxz = -2 eta
        third[0, 0, k] = third[0, k, 0] = third[k, 0, 0] = -2 * coupling
    return np.array([x, y, z]), energy, hessian, third
