"""Stable and unstable manifolds of a saddle fixed point of a discrete map, by fundamental segments.

Near a saddle fixed point x* with a real multiplier lambda (|lambda| > 1 for the unstable
manifold; the stable one is the unstable manifold of the inverse map, multiplier 1/mu) and its
eigenvector v, the manifold is the line x* + s v to second order in s. A fundamental segment,
the points x* + s v with |s| from d to d |lambda| (on both sides of x*: both branches), is
mapped by f onto the next one; its images under f, f^2, ..., f^k cover the manifold out to k
segments. The points of the first segment are spaced geometrically in s, so their images are
spaced alike along each later segment; the error of the start, O(d^2), is carried along (it
shrinks along the manifold by the other multiplier).
"""

from __future__ import annotations

import numpy as np


def fixed_point_manifold(system, point: np.ndarray, multiplier: float, eigenvector: np.ndarray, *,
                         stable: bool, iterations: int, segment_points: int = 400,
                         first_distance: float = 1e-7) -> np.ndarray:
    """Points of the unstable (``stable`` False) or stable manifold of the saddle fixed point
    ``point`` of the map ``system``, from the fundamental segment of the eigenvector of the real
    ``multiplier`` (that of the manifold's direction: |multiplier| > 1 for the unstable one,
    < 1 for the stable one, which is iterated by the inverse map), mapped ``iterations`` times:
    an array of shape (iterations + 1, 2, segment_points, n), by image, branch (+v, -v) and
    point along the segment. An image that leaves the real line (overflow) holds NaN."""
    multiplier = float(multiplier)
    growth = abs(1.0 / multiplier if stable else multiplier)
    if not growth > 1:
        raise ValueError(f"multiplier: {multiplier} is not of the {'stable' if stable else 'unstable'} direction")
    direction = -1 if stable else 1
    vector = np.real(np.asarray(eigenvector, dtype=complex))
    vector = vector / np.linalg.norm(vector)
    s = first_distance * growth ** (np.arange(segment_points) / segment_points)
    n = len(point)
    out = np.full((iterations + 1, 2, segment_points, n), np.nan)
    for branch, sign in enumerate((1.0, -1.0)):
        current = np.asarray(point)[None, :] + sign * s[:, None] * vector[None, :]
        out[0, branch] = current
        for k in range(1, iterations + 1):
            with np.errstate(over="ignore", invalid="ignore"):
                current = np.array([system.step(x, direction) if np.all(np.isfinite(x)) else np.full(n, np.nan)
                                    for x in current])
            out[k, branch] = current
    return out
