"""Reversing symmetries of an LD map: the backward fields from the forward ones at mirrored pixels.

For H = p^T M^-1 p / 2 + V(q) and signs s in {+1, -1}^n, let S(q, p) = (s q, -s p). If
V(s q) = V(q) and M^-1_ij s_i s_j = M^-1_ij (M^-1 couples only coordinates of equal sign),
then H(S z) = H(z), and S, the composition of the reflection q -> s q (symplectic) with
time reversal p -> -p (anti-symplectic), is anti-symplectic. Writing Hamilton's equations as
z' = J grad H(z): for w(t) = S phi_{-t}(z0), w' = -S J grad H(phi_{-t}) = J S grad H(phi_{-t})
(S J = -J S for this S) = J grad H(S phi_{-t}) (H o S = H, S^2 = 1) = J grad H(w). So w is
the trajectory from S z0:

    phi_{-t}(z0) = S phi_t(S z0).

Every LD integrand ldpipe has (:mod:`ldpipe.engine.integrands`) is a function of the
phase-space velocity that sign flips leave alone: sum_c |z'_c|^p, or the arc length ||z'||
(S is diagonal with entries +-1). Since d/dt phi_{-t}(z0) = -S (phi_t)'(S z0), the integrand
along the backward trajectory of z0 at time -t equals that along the forward trajectory of
S z0 at time t, so LD_backward(z0) = LD_forward(S z0) for every tau. The other per-pixel
fields of a fixed-time map obey the same identity: the time reached, the escape flag
(max_i |q_i| beyond a radius: invariant under q -> s q), the region exit flag (never set at
fixed time), |H(end) - H(start)| (H o S = H), and, for a scheme that treats the two directions
alike, the step count and the failure flag, which are properties of the numerical
integration: the backward integration of z0 with steps -h is, operation for operation, the
forward integration of S z0 with steps h with some signs flipped (grad V(s q) = s grad V(q)),
so they agree to rounding. The map's fields other than these (end states, FTLE, stop flags
of data, adaptive refinement) are not mirrored: maps that have them integrate both ways.

S maps a section onto itself when every fixed coordinate it negates is 0, the solved
coordinate keeps its value's rule (a solved momentum p_k is unchanged by S, s_k = -1, so its
sign, that of dq_k/dt, is kept; a solved position q_k is unchanged, s_k = +1, so its root
rule picks the same root), and each axis is left alone or negated; a negated axis must be a
grid that is mirror-symmetric to rounding: |values[j] + values[N-1-j]| <= tolerance for every j,
so that the mirrored pixel is the image S z0 up to a start error far below the integration's
(:func:`mirror_tolerance`). The pixel
(a, b) then maps to (a or -a, b or -b), and the backward fields are the forward fields
flipped along the negated axes. The Barbanis potential, even in y, has S(x, y, px, py) =
(x, -y, -px, py), which maps U_xpx (y = 0, p_y > 0 solved) onto itself, px -> -px.

Only fixed-time maps are mirrored (a variable-time map's region box would have to be
S-invariant too), and only along the second axis: tiles are bands of the first axis, and a
tile mirrored along it would need another tile's forward fields.

The tolerance: ``np.linspace(-a, a, N)`` rounds each value on its own (start + j step), so a
value and its mirror image miss each other by up to ~2 eps a (measured: at most 1.95 eps a over
N <= 5000 and a from 1e-3 to 100; 1.33 eps a, 2 ulp, for Fig. 3's N = 1500; eps the machine
epsilon). The default, :data:`TOLERANCE_EPS` = 4 eps times max|values|, takes every such grid
with a factor 2 to spare and nothing coarser: a grid off by 1e-9 is integrated both ways. A
start that far from the image (5e-15 on Fig. 3's axis) is eight orders of magnitude below the
error the integration itself makes (rtol 1e-7 per step on these maps); where the flow is
chaotic both differences grow alike, so the mirrored LD differs from the integrated one no more
than a rerun at a slightly different tolerance would (benchmarks/ld_symmetry.md). The solved
coordinate c inherits the axes' mismatch scaled by its conditioning: on the energy surface
c dc = p_a dp_a for a solved momentum, so |dc| <= tolerance (1 + max|values| / |c|) is allowed
there (near the energy boundary, c -> 0, the solved p_y of Fig. 3 misses its image by up to 7e-13).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

#: The LD map key that turns mirroring on (``true``: required), off (``false``) or leaves it to detection.
SETTING_KEY = "backward_by_symmetry"
AUTO = "auto"
#: The default tolerance of a mirrored axis, in units of machine epsilon times max|values| (module docstring).
TOLERANCE_EPS = 4.0


def mirror_tolerance(values: np.ndarray) -> float:
    """The default largest |values[j] + values[N-1-j]| a mirrored axis may have: :data:`TOLERANCE_EPS`
    machine epsilons of its largest |value| (the rounding of a linspace; module docstring)."""
    return TOLERANCE_EPS * float(np.finfo(np.float64).eps) * float(np.max(np.abs(values)))


def mirror_mismatch(values: np.ndarray) -> float:
    """The largest |values[j] + values[N-1-j]|: how far the grid misses its own mirror image."""
    return float(np.max(np.abs(values[::-1] + values)))


@dataclass(frozen=True)
class ReversingSymmetry:
    """S(q, p) = (s q, -s p) with ``signs`` = s, one per coordinate."""

    signs: tuple[int, ...]

    def phase_signs(self) -> np.ndarray:
        """The factor S multiplies each phase-space coordinate (q..., p...) by."""
        s = np.array(self.signs, dtype=np.float64)
        return np.concatenate([s, -s])

    def describe(self, phase_coordinates: tuple[str, ...]) -> str:
        """S as a map, e.g. ``(x, y, px, py) -> (x, -y, -px, py)``."""
        images = [name if sign > 0 else f"-{name}" for name, sign in zip(phase_coordinates, self.phase_signs())]
        return f"({', '.join(phase_coordinates)}) -> ({', '.join(images)})"


@dataclass(frozen=True)
class MapMirror:
    """A reversing symmetry of a map's section: which of its two axes it negates."""

    symmetry: ReversingSymmetry
    mirrored: tuple[bool, bool]
    description: str
    #: The largest |values[j] + values[N-1-j]| accepted on the negated axis, and the largest found.
    tolerance: float = 0.0
    mismatch: float = 0.0
    #: Where the solved coordinate sits in a state, and the largest |value| of the negated axis
    #: (the scale of its conditioning, module docstring); None where nothing is solved.
    solved: int | None = None
    scale: float = 0.0

    def mirror(self, field: np.ndarray) -> np.ndarray:
        """``field`` (on the grid, axes first) at the image pixel of each pixel: flipped along the negated axes."""
        return field[tuple(slice(None, None, -1) if m else slice(None) for m in self.mirrored)]

    def maps_grid(self, states: np.ndarray, allowed: np.ndarray) -> bool:
        """Whether the image pixel of every pixel holds S of its state to :attr:`tolerance`:
        ``states`` (shape (rows, columns, 2 n_dof)) on the grid, ``allowed`` its mask. Every
        coordinate within the tolerance, the solved one within tolerance (1 + scale / |c|) (its
        conditioning, module docstring). The detection checks the axes; this checks the solved
        coordinate's rounding and root too."""
        if not np.array_equal(self.mirror(allowed), allowed):
            return False
        own = states[allowed]
        difference = np.abs(self.mirror(states)[allowed] - own * self.symmetry.phase_signs())
        bound = np.full(own.shape, self.tolerance)
        if self.solved is not None:
            with np.errstate(divide="ignore"):
                bound[:, self.solved] *= 1.0 + self.scale / np.abs(own[:, self.solved])
        return bool(np.all(difference <= bound))


def _kinetic_invariant(system, signs: tuple[int, ...]) -> bool:
    """M (so M^-1) couples only coordinates whose signs agree, exactly."""
    if system.mass_matrix is None:
        return True
    return all(value == 0.0 for i, row in enumerate(system.mass_matrix) for j, value in enumerate(row)
               if signs[i] != signs[j])


@lru_cache(maxsize=32)
def _even_signs(formula: str, coordinates: tuple[str, ...], parameters: tuple) -> tuple[tuple[int, ...], ...]:
    """Every s with V(s q) = V(q) identically (sympy: the difference expands or simplifies to 0)."""
    import sympy  # here, with the formula's parsing: a map that mirrors nothing never needs it

    from ...systems.formula import parse_potential

    potential = parse_potential(formula, coordinates, dict(parameters), "systems")
    symbols = [sympy.Symbol(c, real=True) for c in coordinates]
    found = []
    for signs in itertools.product((1, -1), repeat=len(coordinates)):
        difference = sympy.expand(potential.xreplace({q: s * q for q, s in zip(symbols, signs)}) - potential)
        if difference == 0 or (not difference.is_polynomial(*symbols) and sympy.simplify(difference) == 0):
            found.append(signs)
    return tuple(found)


def reversing_symmetries(system) -> list[ReversingSymmetry]:
    """The sign-flip reversing symmetries S(q, p) = (s q, -s p) that hold exactly for ``system``:
    V(s q) = V(q) proved symbolically from its formula and M^-1 invariant. Always includes time
    reversal (s = +1) for a natural Hamiltonian with a formula; none for a vector field or a
    system without a formula."""
    if not system.hamiltonian or not system.formula:
        return []
    signs = _even_signs(system.formula, tuple(system.coordinates), tuple(sorted(system.parameters.items())))
    return [ReversingSymmetry(s) for s in signs if _kinetic_invariant(system, s)]


def section_mirror(system, section, symmetry: ReversingSymmetry,
                   tolerance: float | None = None) -> tuple[tuple[bool, bool] | None, str]:
    """``(mirrored, reason)``: which axes S negates if it maps ``section``'s grid onto itself
    (see the module docstring), else None and why not. A negated axis must miss its mirror image
    by at most ``tolerance`` (None: :func:`mirror_tolerance` of its values)."""
    sign = dict(zip(system.phase_coordinates, symmetry.phase_signs()))
    for name, value in section.fixed.items():
        if sign[name] < 0 and value != 0.0:
            return None, f"it negates {name}, fixed at {value!r} (not 0)"
    if sign[section.solve] < 0:
        momentum = section.solve in system.momenta
        what = "the sign of the solved momentum" if momentum else "the root of the solved position"
        return None, f"it negates {section.solve}, so it does not keep {what}"
    mirrored = []
    for name, values in zip(section.axes, section.axis_values()):
        allowed = mirror_tolerance(values) if tolerance is None else tolerance
        if sign[name] < 0 and not mirror_mismatch(values) <= allowed:
            return None, (f"it negates the axis {name}, whose grid is not mirror-symmetric (largest "
                          f"|v[::-1] + v| = {mirror_mismatch(values):.3g}, tolerance {allowed:.3g})")
        mirrored.append(bool(sign[name] < 0))
    return (mirrored[0], mirrored[1]), ""


def map_mirror(system, section, tolerance: float | None = None) -> tuple[MapMirror | None, str]:
    """``(mirror, reason)``: the first reversing symmetry of ``system`` (:func:`reversing_symmetries`)
    that maps ``section`` onto itself, or None and why none does. One that negates the first axis
    is not taken: tiles split a map along it, and a tile would need another tile's rows (a map's
    file does not depend on its tiles). ``tolerance``: the largest |values[j] + values[N-1-j]|
    accepted on the mirrored axis (None: :func:`mirror_tolerance`, a few ulp of its scale)."""
    symmetries = reversing_symmetries(system)
    if not symmetries:
        return None, f"system {system.name!r} has no sign-flip reversing symmetry that can be proved (no formula?)"
    reasons = []
    for symmetry in symmetries:
        mirrored, reason = section_mirror(system, section, symmetry, tolerance)
        description = symmetry.describe(system.phase_coordinates)
        if mirrored is not None and mirrored[0]:
            mirrored, reason = None, (f"it negates the first axis {section.axes[0]}, along which tiles split the map "
                                      "(give that axis second)")
        if mirrored is not None:
            values = section.axis_values()[1]
            solved = system.phase_coordinates.index(section.solve) if section.solve else None
            return MapMirror(symmetry, mirrored, description,
                             tolerance=mirror_tolerance(values) if tolerance is None else tolerance,
                             mismatch=mirror_mismatch(values) if mirrored[1] else 0.0, solved=solved,
                             scale=float(np.max(np.abs(values)))), ""
        reasons.append(f"{description}: {reason}")
    return None, "no reversing symmetry maps the section's grid onto itself: " + "; ".join(reasons)
