"""Detection of the NHIM's grid cell on a pair of LD maps (forward and backward ridges)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Detection:
    """A grid point chosen by a criterion: its index (i, j), section coordinates and score."""

    index: tuple[int, int]
    point: np.ndarray
    score: float


def ridge_level(field: np.ndarray, allowed: np.ndarray) -> float:
    """A spike-proof scale of a field's ridges: the median of the per-row maxima, or of the per-column
    maxima, whichever is larger (the scan that crosses the ridges gives the higher one). Each row that
    crosses a ridge contributes about the ridge's value there; a few grid points that happen to lie
    very close to the ridge (spikes) move the median little, unlike the global maximum."""
    masked = np.where(allowed, field, -np.inf)
    levels = []
    for axis in (1, 0):
        maxima = masked.max(axis=axis)
        maxima = maxima[np.isfinite(maxima)]
        levels.append(float(np.median(maxima)))
    return max(levels)


def nhim_score(ld_forward: np.ndarray, ld_backward: np.ndarray, allowed: np.ndarray) -> np.ndarray:
    """The detection criterion ``min(F / F_ridge, B / B_ridge)`` on the allowed points (-inf elsewhere).

    ``F_ridge``, ``B_ridge`` are :func:`ridge_level` of each field, so each field counts in units
    of its typical ridge height and a spike on one ridge (far from the other) scores only what the
    other field gives it there.

    Parameters
    ----------
    ld_forward, ld_backward : ndarray, shape (m, n)
    allowed : ndarray of bool, shape (m, n)

    Returns
    -------
    ndarray, shape (m, n)
    """
    allowed = np.asarray(allowed, dtype=bool)
    if not allowed.any():
        raise ValueError("no allowed point on the map; nothing to detect")
    level_forward = ridge_level(ld_forward, allowed)
    level_backward = ridge_level(ld_backward, allowed)
    if not (level_forward > 0 and level_backward > 0):
        raise ValueError("the LD fields' ridges are not positive on the allowed points; not an LD map")
    score = np.minimum(ld_forward / level_forward, ld_backward / level_backward)
    return np.where(allowed, score, -np.inf)


def _pick(score: np.ndarray, axes: tuple[np.ndarray, np.ndarray]) -> Detection:
    i, j = np.unravel_index(int(np.argmax(score)), score.shape)
    return Detection((int(i), int(j)), np.array([axes[0][i], axes[1][j]]), float(score[i, j]))


def detect_nhim_cell(
    ld_forward: np.ndarray, ld_backward: np.ndarray, allowed: np.ndarray, axes: tuple[np.ndarray, np.ndarray],
) -> Detection:
    """The grid point where both LD ridges meet (largest :func:`nhim_score`).

    ``axes`` are the grid coordinates along the two section axes, shapes (m,) and (n,).
    """
    return _pick(nhim_score(ld_forward, ld_backward, allowed), axes)


def detect_global_argmax(
    ld_forward: np.ndarray, ld_backward: np.ndarray, allowed: np.ndarray, axes: tuple[np.ndarray, np.ndarray],
) -> Detection:
    """The plain global maximum of ld_forward + ld_backward (the naive criterion, for comparison)."""
    total = np.where(np.asarray(allowed, dtype=bool), ld_forward + ld_backward, -np.inf)
    return _pick(total, axes)
