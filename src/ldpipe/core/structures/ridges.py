"""Ridges and valleys of a scalar field sampled on a regular 2-D grid, as polylines to sub-pixel accuracy.

The criterion is the second-derivative (height) ridge of Shadden, Lekien & Marsden (2005): a
ridge of g is where the derivative of g along e, the eigenvector of g's Hessian with the
smallest eigenvalue λ, vanishes (∇g · e = 0) while λ is strongly negative, so that g has a sharp
maximum across the curve. A valley of f is a ridge of −f.

The same test finds an LD's singular features (Mancho et al. 2013): where the LD's gradient
jumps, its second difference across the jump is of the order of the jump over one cell, far
larger than anywhere the LD is smooth, and the gradient changes sign (a p-norm LD with p ≤ 1
has a V-shaped minimum on a stable or unstable manifold, a valley).

How it is done, on the grid (derivatives per grid cell, so axes of different units weigh as the
grid spaces them):

* the gradient and Hessian by central differences, at pixels whose 3 × 3 neighbourhood is all
  valid (no one-sided differences at edges or masked points: an edge makes no ridge);
* on every grid edge (two neighbouring pixels) the direction e of the sharper end, so that a
  point beside a kink, whose own Hessian may be weak, is read along the kink's direction; the
  edge holds a point of the curve where ∇g · e changes sign between its ends, falling across the
  curve (a maximum, not a minimum, of g along e), and the sharper end's −λ reaches the threshold;
  the point lies where the linear interpolant of ∇g · e vanishes;
* the points of the edges of each grid cell joined pairwise into segments (marching squares),
  and the segments, which share their points with the neighbouring cells, chained into polylines.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


#: Sharpness below this fraction of the field's largest magnitude is noise, whatever the threshold.
NOISE = 1e-8


@dataclass(frozen=True)
class Curve:
    """One extracted curve: ``points`` (n, 2) in the grid's axis units, ``strength`` (n,) the
    curve's sharpness there (−λ of the sharper pixel of the grid edge the point lies on, in the
    field's units per grid cell squared) and ``value`` (n,) the field interpolated at the point."""

    points: np.ndarray
    strength: np.ndarray
    value: np.ndarray


@dataclass(frozen=True)
class Derivatives:
    """The gradient (n0, n1, 2), the Hessian's smallest eigenvalue (n0, n1) and its unit
    eigenvector (n0, n1, 2) of a field per grid cell, and where they are defined (n0, n1)."""

    gradient: np.ndarray
    smallest: np.ndarray
    direction: np.ndarray
    defined: np.ndarray


def _stencil_valid(valid: np.ndarray) -> np.ndarray:
    """Pixels whose whole 3 × 3 neighbourhood is valid (never the grid's edge)."""
    inner = np.zeros_like(valid)
    n0, n1 = valid.shape
    if n0 < 3 or n1 < 3:
        return inner
    core = np.ones((n0 - 2, n1 - 2), dtype=bool)
    for a in range(3):
        for b in range(3):
            core &= valid[a:n0 - 2 + a, b:n1 - 2 + b]
    inner[1:-1, 1:-1] = core
    return inner


def derivatives(field: np.ndarray, valid: np.ndarray) -> Derivatives:
    """Central-difference gradient and Hessian of ``field`` per grid cell; the Hessian's smallest
    eigenvalue and its eigenvector in closed form (a symmetric 2 × 2 matrix)."""
    f = np.where(valid, field, 0.0).astype(float)
    n0, n1 = f.shape
    gradient = np.zeros((n0, n1, 2))
    a = np.zeros((n0, n1))
    b = np.zeros((n0, n1))
    c = np.zeros((n0, n1))
    if n0 >= 3 and n1 >= 3:
        gradient[1:-1, :, 0] = (f[2:] - f[:-2]) / 2
        gradient[:, 1:-1, 1] = (f[:, 2:] - f[:, :-2]) / 2
        a[1:-1] = f[2:] - 2 * f[1:-1] + f[:-2]
        c[:, 1:-1] = f[:, 2:] - 2 * f[:, 1:-1] + f[:, :-2]
        b[1:-1, 1:-1] = (f[2:, 2:] - f[2:, :-2] - f[:-2, 2:] + f[:-2, :-2]) / 4
    half_trace, half_gap = (a + c) / 2, np.hypot((a - c) / 2, b)
    smallest = half_trace - half_gap
    # (H - λ I) e = 0: either row gives e; take the longer of the two candidates (never both zero
    # unless H is a multiple of I, where any direction is an eigenvector)
    first = np.stack([b, smallest - a], axis=-1)
    second = np.stack([smallest - c, b], axis=-1)
    use_first = np.hypot(first[..., 0], first[..., 1]) >= np.hypot(second[..., 0], second[..., 1])
    direction = np.where(use_first[..., None], first, second)
    norm = np.hypot(direction[..., 0], direction[..., 1])
    isotropic = norm == 0
    direction[isotropic] = (1.0, 0.0)
    direction /= np.where(isotropic, 1.0, norm)[..., None]
    defined = _stencil_valid(np.asarray(valid, dtype=bool))
    return Derivatives(gradient, np.where(defined, smallest, 0.0), direction, defined)


def _edge_points(field, d: Derivatives, cutoff: float, axis: int):
    """The curve's points on the grid edges along ``axis``: (hit, offset along the edge in
    (0, 1), strength, value), each shaped like the edges ((n0 - 1, n1) for axis 0)."""
    low = (slice(0, -1), slice(None)) if axis == 0 else (slice(None), slice(0, -1))
    high = (slice(1, None), slice(None)) if axis == 0 else (slice(None), slice(1, None))
    sharp_low, sharp_high = -d.smallest[low], -d.smallest[high]
    low_is_sharper = sharp_low >= sharp_high
    e = np.where(low_is_sharper[..., None], d.direction[low], d.direction[high])
    r_low = np.sum(d.gradient[low] * e, axis=-1)
    r_high = np.sum(d.gradient[high] * e, axis=-1)
    strength = np.maximum(sharp_low, sharp_high)
    # along the edge (unit step in ``axis``) the derivative along e must fall through zero
    falling = (r_high - r_low) * e[..., axis] < 0
    hit = (d.defined[low] & d.defined[high] & (strength >= cutoff) & (strength > 0)
           & ((r_low >= 0) != (r_high >= 0)) & falling)
    with np.errstate(divide="ignore", invalid="ignore"):
        offset = np.where(hit, r_low / (r_low - r_high), 0.0)
    offset = np.clip(offset, 0.0, 1.0)
    value = field[low] + offset * (field[high] - field[low])
    return hit, offset, strength, value


def ridge_curves(field: np.ndarray, axes: tuple[np.ndarray, np.ndarray], valid: np.ndarray, *,
                 kind: str = "ridge", threshold: float = 0.1, min_points: int = 10) -> list[Curve]:
    """The ridges (``kind="ridge"``) or valleys (``"valley"``) of ``field`` (n0, n1) over the
    regular grid ``axes`` (n0,), (n1,), where ``valid`` (n0, n1) is True, as polylines.

    ``threshold`` is the sharpness a point needs, as a fraction of the sharpest pixel's −λ over
    the field's defined pixels, and never less than :data:`NOISE` times the field's largest
    magnitude (a field flat to rounding has no ridge); curves of fewer than ``min_points`` points
    are dropped.
    """
    if kind not in ("ridge", "valley"):
        raise ValueError(f"kind: {kind!r}; expected 'ridge' or 'valley'")
    field = np.asarray(field, dtype=float)
    g = field if kind == "ridge" else -field
    d = derivatives(g, np.asarray(valid, dtype=bool))
    sharpest = float(np.max(-d.smallest[d.defined], initial=0.0))
    # a second difference of values known to a relative precision eps is uncertain by some
    # 4 eps |f|: below NOISE |f| a curvature is rounding (or the integrator's tolerance), not a ridge
    floor = NOISE * float(np.max(np.abs(field[d.defined]), initial=0.0))
    if sharpest <= floor:
        return []
    cutoff = max(threshold * sharpest, floor)
    n0, n1 = field.shape
    hits, offsets, strengths, values = zip(*(_edge_points(g, d, cutoff, axis) for axis in (0, 1)))
    # every edge's point, numbered: edges along axis 0 first ((n0 - 1) × n1), then along axis 1
    count0 = (n0 - 1) * n1
    i0, j0 = np.meshgrid(np.arange(n0 - 1), np.arange(n1), indexing="ij")
    i1, j1 = np.meshgrid(np.arange(n0), np.arange(n1 - 1), indexing="ij")
    position = np.concatenate([
        np.column_stack([(i0 + offsets[0]).ravel(), j0.ravel().astype(float)]),
        np.column_stack([i1.ravel().astype(float), (j1 + offsets[1]).ravel()]),
    ])
    hit = np.concatenate([hits[0].ravel(), hits[1].ravel()])
    strength = np.concatenate([strengths[0].ravel(), strengths[1].ravel()])
    value = np.concatenate([values[0].ravel(), values[1].ravel()]) * (1.0 if kind == "ridge" else -1.0)
    segments = _cell_segments(hit, position, n0, n1, count0)
    chains = _chain(segments)
    curves = []
    for chain in chains:
        if len(chain) < min_points:
            continue
        chain = np.asarray(chain)
        grid_points = position[chain]
        points = np.column_stack([np.interp(grid_points[:, k], np.arange(len(axes[k])), axes[k]) for k in (0, 1)])
        curves.append(Curve(points, strength[chain], value[chain]))
    return curves


def _cell_segments(hit: np.ndarray, position: np.ndarray, n0: int, n1: int, count0: int) -> list[tuple[int, int]]:
    """Pairs of edge points joined inside each grid cell: two points make a segment; four (a
    saddle of the criterion) the two shorter pairings; three the closest two."""
    i, j = np.meshgrid(np.arange(n0 - 1), np.arange(n1 - 1), indexing="ij")
    edges = np.stack([
        i * n1 + j,  # along axis 0 at j
        i * n1 + j + 1,  # along axis 0 at j + 1
        count0 + i * (n1 - 1) + j,  # along axis 1 at i
        count0 + (i + 1) * (n1 - 1) + j,  # along axis 1 at i + 1
    ], axis=-1).reshape(-1, 4)
    counts = hit[edges].sum(axis=1)
    segments = []
    for cell in np.flatnonzero(counts == 2):
        a, b = edges[cell][hit[edges[cell]]]
        segments.append((int(a), int(b)))
    for cell in np.flatnonzero(counts >= 3):
        found = [int(e) for e in edges[cell][hit[edges[cell]]]]
        pairs = ([(found[0], found[1]), (found[2], found[3])], [(found[0], found[2]), (found[1], found[3])],
                 [(found[0], found[3]), (found[1], found[2])]) if len(found) == 4 else \
            ([(found[0], found[1])], [(found[0], found[2])], [(found[1], found[2])])
        best = min(pairs, key=lambda p: sum(np.hypot(*(position[a] - position[b])) for a, b in p))
        segments.extend(best)
    return segments


def _chain(segments: list[tuple[int, int]]) -> list[list[int]]:
    """The segments joined at their shared points into polylines: open chains from their ends,
    then closed loops (the first point repeated at the end)."""
    neighbours: dict[int, list[int]] = {}
    for a, b in segments:
        neighbours.setdefault(a, []).append(b)
        neighbours.setdefault(b, []).append(a)
    used: set[frozenset] = set()
    chains = []

    def walk(start: int) -> list[int]:
        chain, here = [start], start
        while True:
            step = next((n for n in neighbours[here] if frozenset((here, n)) not in used), None)
            if step is None:
                return chain
            used.add(frozenset((here, step)))
            chain.append(step)
            here = step

    for start in sorted(neighbours, key=lambda n: (len(neighbours[n]) != 1, n)):
        while any(frozenset((start, n)) not in used for n in neighbours[start]):
            chains.append(walk(start))
    return chains
