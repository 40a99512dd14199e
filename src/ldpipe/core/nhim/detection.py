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


@dataclass(frozen=True)
class Candidate:
    """A separated group of grid cells that both manifold curves cross: one NHIM crossing's estimate.

    point : ndarray, shape (2,)
        Centre of the group's cells (section coordinates).
    cells : int
        Cells in the group.
    """

    point: np.ndarray
    cells: int


def switch_cells(fates: np.ndarray, allowed: np.ndarray) -> np.ndarray:
    """Grid cells (2 x 2 corners, all allowed) across which a fate switches, shape (m - 1, n - 1).

    A fate is +1 or -1 (the side of the saddle a trajectory leaves by), or 0 for a point that
    stays in the region to the end of the integration: on the manifold as far as it resolves, so a
    cell with a 0 corner counts as crossed too.
    """
    corners = [fates[:-1, :-1], fates[1:, :-1], fates[:-1, 1:], fates[1:, 1:]]
    inside = allowed[:-1, :-1] & allowed[1:, :-1] & allowed[:-1, 1:] & allowed[1:, 1:]
    stack = np.stack(corners)
    return inside & ((stack.max(axis=0) > stack.min(axis=0)) | (stack == 0).any(axis=0))


def crossing_candidates(
    forward: np.ndarray, backward: np.ndarray, allowed: np.ndarray, axes: tuple[np.ndarray, np.ndarray],
) -> list[Candidate]:
    """Every separated place where the stable curve W^s (the forward fate's switch) and the unstable
    curve W^u (the backward fate's) pass through the same grid cells, most cells first.

    Each group of such cells, connected through edges or corners, is one candidate: two crossings
    of the NHIM more than about two cells apart give two groups. A group is only a candidate: two
    curves that come close without crossing give one too, and the refinement tells.

    Parameters
    ----------
    forward, backward : ndarray of int, shape (m, n)
        Fates on the grid (:func:`ldpipe.core.nhim.exit_fates`).
    allowed : ndarray of bool, shape (m, n)
    axes : (ndarray (m,), ndarray (n,))
    """
    from scipy import ndimage

    allowed = np.asarray(allowed, dtype=bool)
    both = switch_cells(np.asarray(forward), allowed) & switch_cells(np.asarray(backward), allowed)
    labels, count = ndimage.label(both, structure=np.ones((3, 3), dtype=int))
    centres_a = 0.5 * (axes[0][:-1] + axes[0][1:])
    centres_b = 0.5 * (axes[1][:-1] + axes[1][1:])
    candidates = []
    for label in range(1, count + 1):
        i, j = np.nonzero(labels == label)
        candidates.append(Candidate(np.array([centres_a[i].mean(), centres_b[j].mean()]), int(len(i))))
    return sorted(candidates, key=lambda c: -c.cells)
