"""Adaptive LD maps: integrate the pixels where the map's structure is, interpolate where it is resolved.

An LD map is smooth almost everywhere; its information sits on curves (the singular features
along the stable and unstable manifolds, the boundaries between fates). The refinement works on
the map's own pixel grid, so every value it integrates is the full map's trajectory at that pixel.
Each direction of time is refined on its own, on its own fate and LD (the forward map's structure
lies along the stable manifolds, the backward map's along the unstable ones), so a pixel may be
integrated in one direction and interpolated in the other (the masks ``computed_forward`` and
``computed_backward``). For each direction:

1. *Coarse lattice*: every ``coarse_spacing``-th row and column of the grid (and the last
   ones). Its cells are the rectangles between neighbouring lattice lines.
2. *Test points*: each cell's centre and edge midpoints, pixels of the grid (the corners of
   its four children), integrated as real trajectories.
3. *Criterion*: a cell is subdivided (into those four children, one level down) where its
   corners and test points differ in *fate* (energetically forbidden; escaped; failed; the face
   of the saddle region the trajectory left by, or none: ran to tau), or where a test point's
   LD (``ld_forward`` or ``ld_backward``) differs from the cell's interpolant by more than
   ``tolerance`` times that field's *value range* (max - min over the allowed pixels of
   the whole map's coarse lattice, so every tile of a map uses the same bound). A cell whose
   sampled points are all forbidden but which holds an allowed pixel is subdivided too (the
   allowed region is known at every pixel without integrating). A cell is never accepted on an
   interpolated value: its test points are trajectories.
4. The interpolant is bilinear in the corners plus a slope times the *solved coordinate's*
   departure from its own bilinear interpolant (the slope fitted to the five test points by
   least squares, the residuals then checked against the tolerance). The solved momentum is a
   square root of the energy left, so near the boundary of the allowed region the LD, a smooth
   function of the full initial state, goes as the root too; the slope term carries that part,
   known at every pixel without integrating, and bilinear carries the smooth rest.
5. An accepted cell's four children are filled with that interpolant from their corners
   (computed pixels keep their values; smaller cells are filled after larger ones, so a shared
   edge takes the finer one). Subdivision goes down to cells whose pixels are all computed, or
   to ``max_level`` halvings, below which a failing cell is integrated pixel by pixel: the map
   is never coarser than the criterion asks.
6. *Centre test*: a cell at most ``CENTRE_TEST_SIDE`` pixels a side whose four corners share a
   fate (most such cells flank a fate switch their parent saw, their corners already on its
   side) integrates its centre first; if the centre has the corners' fate and every
   value field within the tolerance of their bilinear interpolant, the cell is accepted on that
   trajectory (bilinear fill), else it is tested as in 2-3. At the last level this skips most
   edge midpoints of the cells beside a switch, whose values and fates there are known smooth.

All the new points of one level are integrated together (one batch of engine calls, as a full
map's tile is), so the engine's lanes stay full and every thread busy.

What a feature narrower than a coarse cell needs to be found: the points sampled before the
first decision form a lattice of spacing ``coarse_spacing / 2`` (corners and test points), so
a fate region that contains a square of that side in pixels (e.g. a band at least
``coarse_spacing / 2`` pixels wide along a grid axis) always holds a sample of its own fate, and
its cell is subdivided; a narrower one is found when it crosses a sample or moves a test point's
LD by more than the tolerance (the LD's cusp along a manifold is wide in value even where the
fate switch is thin). ``tests/stages/test_ld_adaptive.py`` checks the bound on bands of every
offset, and that it is sharp; choose ``coarse_spacing`` at most twice the narrowest fate
feature, in pixels.

Cells are global (the lattice of the whole map), so a tile (a band of rows) refines the cells
that reach into its rows, whole, and a rerun gives the same bits. The engine's result for a
trajectory does not depend on the other trajectories of its batch, so a computed pixel equals
the full map's, and a tiled map the untiled one, bit for bit.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import functools
import sys

import numpy as np
import xarray as xr
from tqdm import tqdm

from ...engine import LDSettings
from ...jitcache import njit_functions
from .grid import BOTH, MAP_FIELDS, fields_dataset, integrate_points, map_directions
from ...logs import get_logger, progress_output
from ..sections import Section, section_states
from ...systems import System

log = get_logger(__name__)

#: The fields whose values the criterion compares with the interpolant.
VALUE_FIELDS = ("ld_forward", "ld_backward")
#: The fate of an energetically forbidden pixel (never integrated).
FORBIDDEN = -1
#: Cells at most this many pixels a side, with one fate at their corners, are tested at their centre
#: alone first (see the module docstring).
CENTRE_TEST_SIDE = 2


@dataclass(frozen=True)
class RefineSettings:
    """An adaptive map's settings (a map's ``refine:`` block, whose schema holds the defaults); see
    the module docstring.

    tolerance : float
        Largest accepted |test point - interpolant|, as a fraction of each LD field's value range.
    coarse_spacing : int
        Pixels between coarse lattice lines (>= 2; a power of two halves down to the pixel evenly).
    max_level : int or None
        Halvings of a coarse cell at most; a cell still failing then is integrated at every pixel.
        None: down to the pixel.
    """

    tolerance: float
    coarse_spacing: int
    max_level: int | None = None

    def __post_init__(self):
        if not (isinstance(self.tolerance, (int, float)) and np.isfinite(self.tolerance) and self.tolerance > 0):
            raise ValueError(f"tolerance: expected a finite number > 0, got {self.tolerance!r}")
        if isinstance(self.coarse_spacing, bool) or not isinstance(self.coarse_spacing, (int, np.integer)) \
                or self.coarse_spacing < 2:
            raise ValueError(f"coarse_spacing: expected a whole number of pixels >= 2, got {self.coarse_spacing!r}")
        if self.max_level is not None and (isinstance(self.max_level, bool) or not isinstance(self.max_level, int)
                                           or self.max_level < 0):
            raise ValueError(f"max_level: expected a whole number >= 0 or None, got {self.max_level!r}")

    @classmethod
    def from_config(cls, spec: Mapping) -> RefineSettings:
        """The settings of a map's validated ``refine:`` block (the schema's defaults filled in)."""
        return cls(spec["tolerance"], spec["coarse_spacing"], spec.get("max_level"))

    def attributes(self) -> dict:
        """The settings as file attributes (``max_level`` -1: down to the pixel)."""
        return {"refine_tolerance": float(self.tolerance), "refine_coarse_spacing": int(self.coarse_spacing),
                "refine_max_level": -1 if self.max_level is None else int(self.max_level)}


def lattice(points: int, spacing: int) -> np.ndarray:
    """The coarse lattice lines of an axis of ``points`` pixels: every ``spacing``-th, and the last."""
    return np.unique(np.append(np.arange(0, points, spacing), points - 1))


def band_bounds(rows: slice, points: int, spacing: int) -> tuple[int, int]:
    """The lattice rows (first, last, inclusive) that enclose the band ``rows``: its cells, whole."""
    lines = lattice(points, spacing)
    first = int(lines[lines <= rows.start].max())
    last = int(lines[lines >= rows.stop - 1].min())
    return first, last


#: ``evaluate(i, j)``: the fields (the refinement's value fields among them) and ``fate`` of the allowed band pixels
#: (i, j) (band rows, columns), each an array of their length.
Evaluate = Callable[[np.ndarray, np.ndarray], dict[str, np.ndarray]]


@dataclass
class RefinedBand:
    """The refinement's result on a band of rows: every field filled, and what was integrated.

    fields : dict of ndarray, shape of the band
    computed : ndarray of bool
        Pixels whose values are integrated (the others allowed ones are interpolated).
    levels : list of (cells examined, points integrated) per level (level 0: the coarse lattice).
    """

    fields: dict[str, np.ndarray]
    computed: np.ndarray
    levels: list[tuple[int, int]]


def bilinear(a: np.ndarray, b: np.ndarray, f00, f10, f01, f11) -> np.ndarray:
    """The bilinear interpolant at fractions (a, b) of a cell with corner values f_ab (the same
    arithmetic for the criterion and the fill, so a cell's edge gives the same bits from either side)."""
    return (1 - a) * (1 - b) * f00 + a * (1 - b) * f10 + (1 - a) * b * f01 + a * b * f11


def _children(i0, i1, j0, j1, extra: tuple[np.ndarray, ...] = ()) -> tuple[np.ndarray, ...]:
    """The (up to) four children of each cell, halved along each axis that is more than a pixel wide
    (each child with its parent's ``extra`` values)."""
    im, jm = (i0 + i1) // 2, (j0 + j1) // 2
    split_i, split_j = i1 - i0 >= 2, j1 - j0 >= 2
    parts = []
    for lo_i, hi_i, keep_i in ((i0, np.where(split_i, im, i1), True), (im, i1, split_i)):
        for lo_j, hi_j, keep_j in ((j0, np.where(split_j, jm, j1), True), (jm, j1, split_j)):
            keep = np.broadcast_to(np.asarray(keep_i) & np.asarray(keep_j), i0.shape)
            parts.append((lo_i[keep], hi_i[keep], lo_j[keep], hi_j[keep], *(e[keep] for e in extra)))
    return tuple(np.concatenate(column) for column in zip(*parts))


def _cells_sum(prefix: np.ndarray, i0, i1, j0, j1) -> np.ndarray:
    """Sums of a mask over the closed cells [i0, i1] x [j0, j1] from its 2-D prefix sum."""
    return prefix[i1 + 1, j1 + 1] - prefix[i0, j1 + 1] - prefix[i1 + 1, j0] + prefix[i0, j0]


def refine_band(allowed: np.ndarray, first_row: int, shape: tuple[int, int], evaluate: Evaluate,
                settings: RefineSettings, outside_scale: Mapping[str, np.ndarray] | None = None,
                regressor: np.ndarray | None = None, value_fields: tuple[str, ...] = VALUE_FIELDS) -> RefinedBand:
    """Refine the band of rows ``first_row`` .. ``first_row + len(allowed) - 1`` of a map of ``shape``.

    The band must start and end on lattice rows (:func:`band_bounds`). ``outside_scale`` holds the
    value fields at the allowed lattice pixels of the map outside the band, for the value range.
    ``regressor`` (band shape; the section's solved coordinate, None: none) is known at every pixel
    without integrating; see the module docstring. ``value_fields``: the fields the criterion
    compares with the interpolant (``evaluate`` returns them).
    """
    regressor = np.zeros(allowed.shape) if regressor is None else np.where(allowed, regressor, 0.0)
    rows, cols = allowed.shape
    spacing = settings.coarse_spacing
    row_lines = lattice(shape[0], spacing)
    row_lines = row_lines[(row_lines >= first_row) & (row_lines < first_row + rows)] - first_row
    col_lines = lattice(shape[1], spacing)
    if row_lines[0] != 0 or row_lines[-1] != rows - 1:
        raise ValueError(f"band rows {first_row}..{first_row + rows - 1} do not start and end on lattice rows")
    prefix = np.zeros((rows + 1, cols + 1), dtype=np.int64)
    prefix[1:, 1:] = np.cumsum(np.cumsum(allowed, axis=0), axis=1)
    fields: dict[str, np.ndarray] = {}
    fate = np.full(allowed.shape, FORBIDDEN, dtype=np.int64)
    computed = np.zeros(allowed.shape, dtype=bool)

    def integrate(i: np.ndarray, j: np.ndarray) -> int:
        flat = np.unique(i * cols + j)
        i, j = np.divmod(flat, cols)
        keep = allowed[i, j] & ~computed[i, j]
        i, j = i[keep], j[keep]
        if len(i):
            values = evaluate(i, j)
            fate[i, j] = values.pop("fate")
            for name, array in values.items():
                if name not in fields:
                    fields[name] = np.zeros(allowed.shape, dtype=array.dtype)
                fields[name][i, j] = array
            computed[i, j] = True
        return len(i)

    levels = []
    gi, gj = np.meshgrid(row_lines, col_lines, indexing="ij")
    levels.append((0, integrate(gi.ravel(), gj.ravel())))
    if not fields:  # nothing allowed on the band's lattice: every field is 0 wherever evaluated
        probe = evaluate(np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64))
        probe.pop("fate")
        fields = {name: np.zeros(allowed.shape, dtype=array.dtype) for name, array in probe.items()}
    tolerances = {}
    for name in value_fields:
        on_lattice = fields[name][gi, gj][allowed[gi, gj]]
        samples = [on_lattice, *([np.asarray(outside_scale[name])] if outside_scale else [])]
        samples = np.concatenate(samples)
        spread = float(samples.max() - samples.min()) if samples.size else 0.0
        tolerances[name] = settings.tolerance * spread

    i0, j0 = np.meshgrid(row_lines[:-1], col_lines[:-1], indexing="ij")
    i1, j1 = np.meshgrid(row_lines[1:], col_lines[1:], indexing="ij")
    cells = tuple(np.ascontiguousarray(a.ravel()) for a in (i0, i1, j0, j1))
    fills: list[tuple[np.ndarray, ...]] = []
    level = 0
    while cells[0].size:
        i0, i1, j0, j1 = cells
        # Cells with every pixel computed (a pixel wide) or none allowed need nothing more.
        open_cells = ((i1 - i0 >= 2) | (j1 - j0 >= 2)) & (_cells_sum(prefix, i0, i1, j0, j1) > 0)
        i0, i1, j0, j1 = (a[open_cells] for a in cells)
        # Small cells whose corners share a fate are tested at their centre first; those it accepts
        # need none of their edge midpoints (most such cells flank a fate switch their parent saw).
        small = (i1 - i0 <= CENTRE_TEST_SIDE) & (j1 - j0 <= CENTRE_TEST_SIDE) & (fate[i0, j0] != FORBIDDEN)
        for corner in (fate[i1, j0], fate[i0, j1], fate[i1, j1]):
            small &= corner == fate[i0, j0]
        if small.any():
            centre_cells = tuple(a[small] for a in (i0, i1, j0, j1))
            passed = _centre_test(centre_cells, fate, fields, tolerances, integrate, levels)
            fills.append((*(a[passed] for a in centre_cells), *(np.zeros(int(passed.sum())),) * len(value_fields)))
            rest = ~small
            rest[np.flatnonzero(small)[~passed]] = True
            i0, i1, j0, j1 = (a[rest] for a in (i0, i1, j0, j1))
        im, jm = (i0 + i1) // 2, (j0 + j1) // 2
        tests = ((im, j0), (im, j1), (i0, jm), (i1, jm), (im, jm))
        levels.append((len(i0), integrate(np.concatenate([t[0] for t in tests]), np.concatenate([t[1] for t in tests]))))
        corner_fates = [fate[i0, j0], fate[i1, j0], fate[i0, j1], fate[i1, j1]]
        split = np.zeros(len(i0), dtype=bool)
        for other in corner_fates[1:] + [fate[ti, tj] for ti, tj in tests]:
            split |= other != corner_fates[0]
        # All sampled points forbidden but an allowed pixel inside: the allowed region is narrower than the cell.
        split |= corner_fates[0] == FORBIDDEN
        height, width = (i1 - i0).astype(np.float64), (j1 - j0).astype(np.float64)
        fractions = [((ti - i0) / height, (tj - j0) / width) for ti, tj in tests]
        # The solved coordinate's own departure from bilinear at each test point: the regressor.
        q_corners = (regressor[i0, j0], regressor[i1, j0], regressor[i0, j1], regressor[i1, j1])
        q = np.stack([regressor[ti, tj] - bilinear(a, b, *q_corners) for (ti, tj), (a, b) in zip(tests, fractions)])
        qq = np.sum(q * q, axis=0)
        # The slope only where the test points saw the regressor's largest departure in the cell (to a
        # factor 2): never extrapolated to pixels where it bends more sharply (the energy boundary).
        seen = _kernels()[1](regressor, allowed, i0, i1, j0, j1) <= 2 * np.max(np.abs(q), axis=0)
        qq = np.where(seen, qq, 0.0)
        slopes = {}
        for name in value_fields:
            field = fields[name]
            corners = (field[i0, j0], field[i1, j0], field[i0, j1], field[i1, j1])
            r = np.stack([field[ti, tj] - bilinear(a, b, *corners) for (ti, tj), (a, b) in zip(tests, fractions)])
            slope = np.where(qq > 0, np.sum(r * q, axis=0) / np.where(qq > 0, qq, 1.0), 0.0)
            split |= np.any(np.abs(r - slope * q) > tolerances[name], axis=0)
            slopes[name] = slope
        accepted = tuple(a[~split] for a in (i0, i1, j0, j1))
        fills.append(_children(*accepted, extra=tuple(slopes[name][~split] for name in value_fields)))
        failing = tuple(a[split] for a in (i0, i1, j0, j1))
        if level == settings.max_level:  # no more halvings: a failing cell is integrated at every pixel
            pixels = [np.mgrid[a:b + 1, c:d + 1].reshape(2, -1) for a, b, c, d in zip(*failing)]
            pixels = np.concatenate(pixels, axis=1) if pixels else np.zeros((2, 0), dtype=np.int64)
            levels.append((len(failing[0]), integrate(pixels[0], pixels[1])))
            break
        cells = _children(*failing)
        level += 1
    for cell_set in fills:
        _fill(fields, computed, allowed, regressor, value_fields, *cell_set)
    log.info("adaptive band: %d of %d allowed pixels integrated; (cells, points) per level %s",
             int(computed.sum()), int(allowed.sum()), levels)
    return RefinedBand(fields, computed, levels)


def _centre_test(cells, fate, fields, tolerances, integrate, levels) -> np.ndarray:
    """Integrate each cell's centre; True where it has the corners' fate and every value field
    within the tolerance of the corners' bilinear interpolant (the cell is then accepted)."""
    i0, i1, j0, j1 = cells
    ci, cj = (i0 + i1) // 2, (j0 + j1) // 2
    levels.append((len(i0), integrate(ci, cj)))
    passed = fate[ci, cj] == fate[i0, j0]
    a, b = (ci - i0) / np.maximum(i1 - i0, 1), (cj - j0) / np.maximum(j1 - j0, 1)
    for name in tolerances:
        field = fields[name]
        guess = bilinear(a, b, field[i0, j0], field[i1, j0], field[i0, j1], field[i1, j1])
        passed &= np.abs(field[ci, cj] - guess) <= tolerances[name]
    return passed


def _fill(fields: dict[str, np.ndarray], computed: np.ndarray, allowed: np.ndarray, regressor: np.ndarray,
          value_fields: tuple[str, ...], i0, i1, j0, j1, *slopes) -> None:
    """Fill the allowed, not computed pixels of each cell, in order, with the interpolant of its
    corners: bilinear, plus for the value fields their parent's slope times the regressor's
    departure from bilinear (flags, uniform over an accepted cell's fate, from a corner; step
    counts rounded). The fields of one kind are filled together (one pass over the pixels)."""
    slope_of = dict(zip(value_fields, slopes))
    no_slope = np.zeros(len(i0))
    kernel = _kernels()[0]
    kinds: dict[int, list[str]] = {}
    for name, field in fields.items():
        mode = 2 if field.dtype == np.bool_ else 1 if np.issubdtype(field.dtype, np.integer) else 0
        kinds.setdefault(mode, []).append(name)
    for mode, names in kinds.items():
        for dtype in sorted({fields[name].dtype.str for name in names}):  # one tuple type per call
            group = [name for name in names if fields[name].dtype.str == dtype]
            kernel(tuple(fields[name] for name in group), tuple(slope_of.get(name, no_slope) for name in group),
                   allowed, computed, regressor, i0, i1, j0, j1, mode)


def fate_codes(result) -> np.ndarray:
    """A trajectory's fate as one integer: the face of the region box it left by (0: none), escaped,
    failed (an :class:`ldpipe.engine.LDResult`'s flags; ran to tau is face 0 and neither flag)."""
    return (result.exit_face + 32) + 64 * result.escaped.astype(np.int64) + 128 * result.failed.astype(np.int64)


def adaptive_ld_dataset(
    system: System,
    section: Section,
    energy: float | None,
    settings: LDSettings,
    refine: RefineSettings,
    rows: slice | None = None,
    show_progress: bool = False,
    t0: float = 0.0,
    directions: str = BOTH,
) -> xr.Dataset:
    """:func:`ldpipe.core.maps.grid.ld_grid_dataset` refined adaptively: the same variables, integrated where
    the criterion asks and interpolated elsewhere (see the module docstring), each direction refined
    on its own; plus the masks ``computed_forward`` and ``computed_backward`` and the attributes
    ``refine_*`` (``refine_trajectories``: trajectories integrated over both directions;
    ``refine_trajectories_forward``, ``refine_trajectories_backward``: each direction's). ``directions``:
    as the full map's (one direction: only its variables, masks and counts)."""
    shape = section.shape
    rows = rows if rows is not None else slice(0, shape[0])
    first, last = band_bounds(rows, shape[0], refine.coarse_spacing)
    states, allowed, solved = section_states(system, section, energy, slice(first, last + 1))
    index = np.full(allowed.shape, -1, dtype=np.int64)
    index[allowed] = np.arange(len(states))
    stream, interval = progress_output(log)
    progress = tqdm(unit="traj", desc="LD (adaptive)", disable=not show_progress, file=stream,
                    mininterval=interval, ascii=stream is not sys.stderr)
    directions = map_directions(directions)
    count = {label: 0 for _, label in directions}

    def evaluate_states(chosen: np.ndarray, direction: int, label: str) -> dict[str, np.ndarray]:
        result = integrate_points(system, chosen, direction, settings, progress, t0)
        count[label] += len(chosen)
        return {**{f"{name}_{label}": getattr(result, name) for name in MAP_FIELDS}, "fate": fate_codes(result)}

    with progress:
        # The value range is the whole map's: the lattice pixels outside the band are integrated too.
        row_lines, col_lines = lattice(shape[0], refine.coarse_spacing), lattice(shape[1], refine.coarse_spacing)
        outside_rows = row_lines[(row_lines < first) | (row_lines > last)]
        outside = {label: None for _, label in directions}
        if outside_rows.size:
            o_states, o_allowed, _ = section_states(system, section, energy, outside_rows)
            o_index = np.full(o_allowed.shape, -1, dtype=np.int64)
            o_index[o_allowed] = np.arange(len(o_states))
            on_lattice = o_index[:, col_lines]
            for direction, label in directions:
                values = evaluate_states(o_states[on_lattice[on_lattice >= 0]], direction, label)
                outside[label] = {f"ld_{label}": values[f"ld_{label}"]}
        # Each direction is refined on its own fate and LD: the forward map's switches (W^s, exit
        # faces forward) are not the backward map's, and each needs only its own trajectories.
        bands = {label: refine_band(allowed, first, shape,
                                    functools.partial(_evaluate_pixels, evaluate_states, states, index, direction, label),
                                    refine, outside[label], solved, value_fields=(f"ld_{label}",))
                 for direction, label in directions}
    inside = slice(rows.start - first, rows.stop - first)
    fields = {name: band.fields[name][inside] for band in bands.values() for name in band.fields}
    dataset = fields_dataset(system, section, fields, allowed[inside], None if solved is None else solved[inside], rows)
    for label, band in bands.items():
        dataset[f"computed_{label}"] = (section.axes, band.computed[inside],
                                        {"long_name": f"{label} trajectory integrated here (elsewhere allowed "
                                                      f"points are interpolated)"})
    dataset.attrs.update(refine.attributes())
    dataset.attrs.update({f"refine_trajectories_{label}": count[label] for label in bands})
    dataset.attrs["refine_trajectories"] = sum(count.values())
    return dataset


def _evaluate_pixels(evaluate_states, states, index, direction: int, label: str, i, j) -> dict[str, np.ndarray]:
    """One direction's fields and fate at band pixels (i, j) (an :data:`Evaluate`)."""
    return evaluate_states(states[index[i, j]], direction, label)



#: The loops over every pixel of many cells, compiled once (numba's disk cache). ``fill_cells``: per
#: pixel, for each field of a tuple (one dtype), the weighted corners (the weights and sums in the
#: order :func:`bilinear` forms them) plus slope times departure; rounded for a count (mode 1), a
#: corner's flag (mode 2).
#: ``largest_departure``: per cell, the largest |regressor - its bilinear interpolant| over its
#: allowed pixels. Both frame a cell (``cell_frame``) and weigh its corners (``corner_weights``) alike.
_CELL_LOOPS = """
import numpy as np


def cell_frame(regressor, i0, i1, j0, j1, c):
    a0, a1, b0, b1 = i0[c], i1[c], j0[c], j1[c]
    return (a0, a1, b0, b1, max(a1 - a0, 1), max(b1 - b0, 1),
            regressor[a0, b0], regressor[a1, b0], regressor[a0, b1], regressor[a1, b1])


def corner_weights(i, j, a0, b0, h, w):
    a = (i - a0) / h
    b = (j - b0) / w
    return (1 - a) * (1 - b), a * (1 - b), (1 - a) * b, a * b


def fill_cells(fields, slopes, allowed, computed, regressor, i0, i1, j0, j1, mode):
    for c in range(i0.shape[0]):
        a0, a1, b0, b1, h, w, q00, q10, q01, q11 = cell_frame(regressor, i0, i1, j0, j1, c)
        for i in range(a0, a1 + 1):
            for j in range(b0, b1 + 1):
                if computed[i, j] or not allowed[i, j]:
                    continue
                if mode == 2:
                    for field in fields:
                        field[i, j] = field[a0, b0]
                    continue
                w00, w10, w01, w11 = corner_weights(i, j, a0, b0, h, w)
                departure = regressor[i, j] - (w00 * q00 + w10 * q10 + w01 * q01 + w11 * q11)
                for k in range(len(fields)):
                    field = fields[k]
                    value = w00 * field[a0, b0] + w10 * field[a1, b0] + w01 * field[a0, b1] + w11 * field[a1, b1]
                    value = value + slopes[k][c] * departure
                    if mode == 1:
                        value = np.rint(value)
                    field[i, j] = value


def largest_departure(regressor, allowed, i0, i1, j0, j1):
    out = np.zeros(i0.shape[0])
    for c in range(i0.shape[0]):
        a0, a1, b0, b1, h, w, q00, q10, q01, q11 = cell_frame(regressor, i0, i1, j0, j1, c)
        for i in range(a0, a1 + 1):
            for j in range(b0, b1 + 1):
                if allowed[i, j]:
                    w00, w10, w01, w11 = corner_weights(i, j, a0, b0, h, w)
                    out[c] = max(out[c], abs(regressor[i, j] - (w00 * q00 + w10 * q10 + w01 * q01 + w11 * q11)))
    return out
"""

@functools.cache
def _kernels():
    # the helpers compiled too, so the loops call them compiled (and inline them)
    return njit_functions(_CELL_LOOPS, ("cell_frame", "corner_weights", "fill_cells", "largest_departure"),
                          "ld_adaptive")[2:]
