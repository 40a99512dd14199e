"""Cubic B-spline coefficients of gridded data: the prefilter of the C2 interpolant.

The cubic B-spline interpolant s(x) = sum_m c[m] beta3(x - m) of samples f[0..n-1] at the integers
is C2 and fourth-order accurate; its coefficients solve the interpolation conditions

    (c[i-1] + 4 c[i] + c[i+1]) / 6 = f[i],   i = 0 .. n-1,

for the n + 2 coefficients c[-1..n] the cells [0, n-1] read (a cell [i, i+1] reads c[i-1..i+2]:
exactly the one node of padding each side the kernel's buffer already has). Two more conditions
close the system; here the **not-a-knot** condition at each end: the fourth difference of the
coefficients vanishes there,

    c[-1] - 4 c[0] + 6 c[1] - 4 c[2] + c[3] = 0   (and its mirror at the right end).

The jump of s''' at the knot x = 1 is proportional to that difference, so s is one cubic on
[0, 2] (and on [n-3, n-1]). Every cubic polynomial p satisfies it: its coefficients
c[m] = p(m) - p''(m)/6 are a cubic in m, whose fourth difference is zero. So the interpolant
reproduces cubics exactly up to the grid's edge and stays fourth-order accurate there, where the
mirror condition of Unser (1999), s'(0) = 0, would drop to second order.

Solution (Unser 1999, "Splines: a perfect fit for signal and image processing"): the
interpolation operator (z^-1 + 4 + z)/6 factors as -6 z1 / ((1 - z1 z^-1)(1 - z1 z)) with
z1 = sqrt(3) - 2, so a causal recursion p[m] = 6 f[m] + z1 p[m-1] followed by an anticausal one
c[m] = z1 (c[m+1] - p[m]) gives a solution of the n interior conditions whatever the two
recursions start from; the general solution adds a z1^(m+1) + b z1^(n-m) (the recurrence's two
homogeneous solutions, each decaying away from one end), and the two not-a-knot conditions are a
2 x 2 linear system for a and b. Exact, O(n) along each axis, vectorized over the others.
With n = 3 samples the two fourth differences coincide; the third difference (exact for
quadratics) takes its place.

Windows: the coefficients of a node depend on every sample of its axis, but that dependence
decays as |z1|^k = 0.268^k with the distance k: the caller reads :data:`MARGIN` more nodes each
side where the data have them, and the coefficients of the window's nodes then equal the whole
grid's to |z1|^MARGIN relative (below 1e-13).
"""

from __future__ import annotations

import math

import numpy as np

#: The pole of the cubic B-spline's inverse filter.
Z1 = math.sqrt(3.0) - 2.0
#: Nodes read beyond a window on each side (where the data have them): |Z1|^MARGIN < 2e-14.
MARGIN = 24


def _edge_difference(order: int) -> np.ndarray:
    """The ``order``-th difference's weights (-1)^k C(order, k)."""
    return np.array([(-1.0) ** k * math.comb(order, k) for k in range(order + 1)])


def bspline_coefficients(values: np.ndarray, axis: int) -> np.ndarray:
    """The not-a-knot cubic B-spline coefficients c[-1..n] of samples ``values`` along ``axis``
    (n >= 3 of them): an array with two more entries along ``axis`` (module docstring)."""
    f = np.moveaxis(np.asarray(values, dtype=float), axis, 0)
    n = f.shape[0]
    if n < 3:
        raise ValueError(f"a cubic B-spline needs at least 3 samples along an axis, got {n}")
    z = Z1
    # a particular solution: positions 0 .. n + 1 hold c[-1] .. c[n]; the conditions sit at 1 .. n
    right = np.concatenate([6.0 * f[:1], 6.0 * f, 6.0 * f[-1:]])
    causal = np.empty_like(right)
    causal[0] = right[0] / (1.0 - z)  # the steady state of a constant: any start solves the interior
    for m in range(1, n + 2):
        causal[m] = right[m] + z * causal[m - 1]
    c = np.empty_like(right)
    c[n + 1] = -z / (1.0 - z) * causal[n + 1]
    for m in range(n, -1, -1):
        c[m] = z * (c[m + 1] - causal[m])
    # plus a z^m + b z^(n+1-m), fixed by the edge conditions
    positions = np.arange(n + 2, dtype=float)
    left_mode = z ** positions
    right_mode = z ** (n + 1 - positions)
    weights = _edge_difference(4 if n >= 4 else 3)
    k = len(weights)

    def left(x):
        return np.tensordot(weights, x[:k], axes=(0, 0))

    def right_end(x):
        return np.tensordot(weights, x[::-1][:k], axes=(0, 0))

    a11, a12 = left(left_mode), left(right_mode)
    a21, a22 = right_end(left_mode), right_end(right_mode)
    b1, b2 = -left(c), -right_end(c)
    determinant = a11 * a22 - a12 * a21
    a = (b1 * a22 - a12 * b2) / determinant
    b = (a11 * b2 - a21 * b1) / determinant
    shape = (n + 2,) + (1,) * (f.ndim - 1)
    c = c + a * left_mode.reshape(shape) + b * right_mode.reshape(shape)
    return np.moveaxis(c, 0, axis)
