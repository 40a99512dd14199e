"""A rotated quadratic 3 DoF saddle, whose flux through the dividing plane is a closed form.

V = −λ² a²/2 + ω_1² b²/2 + ω_2² c²/2 with (a, b, c) = R (x, y, z), R a fixed rotation (so the plane
is no coordinate plane), E_c = 0. At excess ΔE the plane a = 0 carries the one-way flux
(2π)² ΔE² / (2 ω_1 ω_2) (derived in ldpipe.core.transport.plane), and every crossing is reactive: a(t)
is monotone through 0, uncoupled from b and c. Used by tests/transport (library and stage).
"""

from __future__ import annotations

import math

import numpy as np

LAM, OM1, OM2 = 0.9, 1.3, 0.6


def rotation() -> np.ndarray:
    """A fixed rotation (QR of fixed numbers, determinant +1); row i is the i-th mode's direction."""
    q, r = np.linalg.qr(np.array([[1.0, 0.4, -0.3], [0.2, 1.0, 0.5], [-0.6, 0.1, 1.0]]))
    q = q * np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


def spec() -> dict:
    """The system's configuration entry (a formula system)."""
    rot = rotation()
    a, b, c = (" + ".join(f"({float(rot[i, j])!r})*{v}" for j, v in enumerate("xyz")) for i in range(3))
    return {"formula": f"-lam**2*({a})**2/2 + om1**2*({b})**2/2 + om2**2*({c})**2/2", "coordinates": ["x", "y", "z"],
            "parameters": {"lam": LAM, "om1": OM1, "om2": OM2}}


def plane_flux(excess) -> np.ndarray:
    """(2π)² ΔE² / (2 ω_1 ω_2): the volume of {ω_1 I_1 + ω_2 I_2 ≤ ΔE} times (2π)² of angles."""
    return (2 * math.pi * np.asarray(excess)) ** 2 / (2 * OM1 * OM2)
