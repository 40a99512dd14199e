"""Distances between extracted curves and reference curves, both ways.

The reference may be anything known as polylines: the closed-form manifolds of a model, the
manifold stage's cut of the globalised manifolds by a section, or another extractor's curves.
"""

from __future__ import annotations

import numpy as np


def distance_to_polylines(points: np.ndarray, polylines: list[np.ndarray], scale=(1.0, 1.0)) -> np.ndarray:
    """For each of ``points`` (n, 2), the distance to the nearest segment of ``polylines`` (each
    (m, 2)), with the axes divided by ``scale`` first (a grid's cell sizes: distances in cells)."""
    scale = np.asarray(scale, dtype=float)
    points = np.asarray(points, dtype=float).reshape(-1, 2) / scale
    best = np.full(len(points), np.inf)
    for line in polylines:
        line = np.asarray(line, dtype=float).reshape(-1, 2) / scale
        if len(line) == 1:
            best = np.minimum(best, np.hypot(*(points - line[0]).T))
            continue
        start, step = line[:-1], np.diff(line, axis=0)
        for chunk in range(0, len(points), 2048):
            p = points[chunk:chunk + 2048, None, :]
            length2 = np.sum(step**2, axis=-1)
            t = np.clip(np.sum((p - start) * step, axis=-1) / np.where(length2 > 0, length2, 1.0), 0.0, 1.0)
            nearest = start + t[..., None] * step
            best[chunk:chunk + 2048] = np.minimum(best[chunk:chunk + 2048],
                                                  np.min(np.hypot(*(p - nearest).transpose(2, 0, 1)), axis=1))
    return best


def _summary(distances: np.ndarray) -> dict[str, float]:
    if not len(distances):
        return {"median": np.inf, "p95": np.inf, "worst": np.inf}
    return {"median": float(np.median(distances)), "p95": float(np.percentile(distances, 95)),
            "worst": float(np.max(distances))}


def curve_distances(curves: list[np.ndarray], reference: list[np.ndarray], scale=(1.0, 1.0),
                    reference_samples: list[np.ndarray] | None = None) -> dict[str, dict[str, float]]:
    """How far ``curves`` lie from ``reference`` and ``reference`` from ``curves``: the median,
    95th percentile and worst distance of each one's points to the other's polylines.

    ``reference_samples`` are the reference's points for the second way (default its polylines'
    vertices; give points sampled along a closed-form line, whose polyline is only its ends).
    """
    points = np.concatenate(curves) if curves else np.zeros((0, 2))
    samples = reference_samples if reference_samples is not None else reference
    back = np.concatenate(samples) if samples else np.zeros((0, 2))
    return {"to_reference": _summary(distance_to_polylines(points, reference, scale)),
            "from_reference": _summary(distance_to_polylines(back, curves, scale) if curves else np.full(len(back), np.inf))}
