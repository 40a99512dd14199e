"""Isoenergetic two-dimensional sections of phase space.

A section fixes all phase-space coordinates but two (the axes) and one momentum,
which is solved from the energy with a chosen sign:

    p_s = sign * sqrt(2 (E - V(q)) - sum of the other p_i^2)

(with a kinetic matrix M, H = p^T M^-1 p / 2 + V = E is a quadratic in p_s, and ``sign`` is
that of the velocity dq_s/dt; see :func:`solve_momentum`).

Points where the radicand is negative lie outside the energetically allowed
region and are masked; they are never integrated. The paper's U_xpx (y = 0,
p_y > 0) is ``axes=("x", "px"), fixed={"y": 0}, solve="py", sign=+1``; its 3 DoF
U_xpx^+ is ``axes=("x", "px"), fixed={"y": y_eq, "z": z_eq, "py": 0},
solve="pz"``.

The solved coordinate may instead be a position q_s: every momentum is then given, and
q_s solves V(q) = E - p^T M^-1 p / 2 with the other positions fixed, a 1-D root problem. Which
root is taken is stated (``root``: ``largest``, ``smallest`` or ``nearest`` a value);
points with no root are not allowed, like those outside the energy surface. If V is a
polynomial of degree at most 2 in q_s, the roots are a closed form; otherwise they are
sought on an interval ``search = (low, high)``: sign changes on SCAN_POINTS samples, then
bisection (a pair of roots closer than the sample spacing can be missed). Hénon–Heiles'
slice of ldds' tutorial is ``axes=("y", "py"), fixed={"px": 0}, solve="x",
root="largest"`` (the root x >= 0).

A section of a general flow (:class:`ldpipe.systems.VectorFieldSystem`) has no energy: two
state variables on the grid, every other one fixed, nothing solved (``solve`` is None); all
its points are integrated.

A configuration spec of a section (``ld_maps.<name>.section``,
``poincare_sections.<name>.initial_conditions``) is resolved into a
:class:`Section` once, by :meth:`Section.from_spec`, where fixed values given as
``saddle`` take the selected saddle's value; the object then travels.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from functools import lru_cache
from numbers import Real

import numpy as np

from ..errors import ConfigError
from ..systems import System

# Which root a solved position takes (``root`` of a section spec).
ROOTS = ("largest", "smallest", "nearest")
# Samples of the scan for sign changes on ``search`` and bisection steps after it.
SCAN_POINTS = 257
BISECTIONS = 64

@dataclass(frozen=True)
class Section:
    """A two-dimensional isoenergetic section; see the module docstring."""

    axes: tuple[str, str]
    ranges: tuple[tuple[float, float], tuple[float, float]]
    shape: tuple[int, int]
    fixed: dict[str, float]
    solve: str | None
    sign: int = 1
    root: str | None = None
    near: float | None = None
    search: tuple[float, float] | None = None

    @classmethod
    def from_spec(
        cls, spec: Mapping, system: System, saddle: np.ndarray | None = None, *, key: str = "section"
    ) -> Section:
        """The section a configuration spec describes, checked against ``system``.

        Parameters
        ----------
        spec : mapping
            ``axes`` (two ``{name, range: [low, high], points}``), ``fixed`` (optional;
            coordinate -> number, or ``'saddle'``), ``solve`` (a momentum, or a position),
            ``sign`` (optional, +1 or -1, default +1; momenta only), ``root`` (positions:
            ``largest``, ``smallest`` or ``{nearest: VALUE}``) and ``search`` (positions,
            optional: ``[low, high]``), as the config schema's section.
        system : System
        saddle : ndarray, shape (n_dof,), optional
            Position of the selected index-1 saddle, the value of ``'saddle'`` coordinates.
        key : str
            The spec's config key, named in every error.

        Raises
        ------
        ConfigError
            Naming the offending key, if the spec lacks a key, a fixed value is neither a
            number nor ``'saddle'`` (or is ``'saddle'`` with no saddle given), or the
            coordinates do not split the phase space (:meth:`check`).
        """
        hamiltonian = system.hamiltonian
        missing = [name for name in ("axes", "solve") if name not in spec and (hamiltonian or name != "solve")]
        if missing:
            raise ConfigError(f"config key {key!r}: lacks {missing}; a section needs 'axes' and 'solve'")
        if not hamiltonian:
            given = [name for name in ("solve", "root", "search") if name in spec]
            given += ["sign"] if spec.get("sign", 1) != 1 else []  # (the schema's default is 1)
            if given:
                raise ConfigError(
                    f"config key '{key}.{given[0]}': system {system.name!r} is a vector field with no energy; its "
                    "section has two axes and every other state variable fixed, nothing solved"
                )
        axes = spec["axes"]
        if len(axes) != 2:
            raise ConfigError(f"config key '{key}.axes': expected two axes, got {len(axes)}")
        for index, axis in enumerate(axes):
            lacking = [name for name in ("name", "range", "points") if name not in axis]
            if lacking:
                raise ConfigError(f"config key '{key}.axes.{index}': lacks {lacking}")
        root, near = root_rule(spec.get("root"), key=f"{key}.root")
        search = spec.get("search")
        if search is not None:
            if len(search) != 2 or not all(isinstance(v, Real) and not isinstance(v, bool) for v in search):
                raise ConfigError(f"config key '{key}.search': expected [low, high], got {search!r}")
            search = (float(search[0]), float(search[1]))
        section = cls(
            axes=(axes[0]["name"], axes[1]["name"]),
            ranges=(tuple(axes[0]["range"]), tuple(axes[1]["range"])),
            shape=(axes[0]["points"], axes[1]["points"]),
            fixed=fixed_values(spec.get("fixed", {}), system, saddle, key=f"{key}.fixed"),
            solve=spec.get("solve"),
            sign=spec.get("sign", 1),
            root=root,
            near=near,
            search=search,
        )
        section.check(system, key=key)
        return section

    def axis_values(self) -> tuple[np.ndarray, np.ndarray]:
        """Grid coordinates along each axis, end points included."""
        return tuple(np.linspace(lo, hi, n) for (lo, hi), n in zip(self.ranges, self.shape))

    def check(self, system: System, key: str = "section") -> None:
        """Raise ConfigError unless axes, fixed and solved coordinates split the phase space."""
        phase = system.phase_coordinates
        if not system.hamiltonian:
            self._check_flow(system, key)
            return
        named = [*self.axes, *self.fixed, self.solve]
        unknown = [name for name in named if name not in phase]
        if unknown:
            raise ConfigError(f"config key {key!r}: {unknown} are not phase coordinates of {system.name}; expected {list(phase)}")
        if self.solve in system.momenta and (self.root is not None or self.search is not None):
            raise ConfigError(
                f"config key '{key}.root': 'root' and 'search' are for a solved position; a momentum takes 'sign'"
            )
        if self.solve in system.coordinates:
            if self.root not in ROOTS or (self.root == "nearest") != (self.near is not None):
                raise ConfigError(
                    f"config key '{key}.root': solving the position {self.solve!r} needs the root to take: "
                    f"largest, smallest or {{nearest: VALUE}}; got {self.root!r}"
                )
            if self.search is None and quadratic_in(system, self.solve) is None:
                raise ConfigError(
                    f"config key '{key}.search': V of {system.name} is not a quadratic polynomial in {self.solve!r} "
                    "(or has no formula); give the interval to seek its roots in, search: [low, high]"
                )
            if self.search is not None and not self.search[0] < self.search[1]:
                raise ConfigError(f"config key '{key}.search': expected [low, high] with low < high, got {list(self.search)}")
        if len(named) != len(set(named)) or set(named) != set(phase):
            missing = sorted(set(phase) - set(named))
            raise ConfigError(
                f"config key {key!r}: the two axes, the fixed coordinates and the solved coordinate must name "
                f"each of {list(phase)} exactly once (missing {missing}, given {named})"
            )
        if self.sign not in (1, -1):
            raise ConfigError(f"config key '{key}.sign': expected +1 or -1, got {self.sign!r}")
        for (lo, hi), axis in zip(self.ranges, self.axes):
            if not lo < hi:
                raise ConfigError(f"config key '{key}.axes.{axis}': expected [low, high] with low < high, got {[lo, hi]}")


    def _check_flow(self, system, key: str) -> None:
        """A vector field's section: the axes and fixed variables name each state variable once."""
        named = [*self.axes, *self.fixed]
        state = system.coordinates
        unknown = [name for name in named if name not in state]
        if unknown:
            raise ConfigError(f"config key {key!r}: {unknown} are not state variables of {system.name}; expected {list(state)}")
        if self.solve is not None:
            raise ConfigError(f"config key '{key}.solve': system {system.name!r} is a vector field with no energy; nothing is solved")
        if len(named) != len(set(named)) or set(named) != set(state):
            raise ConfigError(
                f"config key {key!r}: the two axes and the fixed variables must name each of {list(state)} exactly "
                f"once (missing {sorted(set(state) - set(named))}, given {named})"
            )
        for (lo, hi), axis in zip(self.ranges, self.axes):
            if not lo < hi:
                raise ConfigError(f"config key '{key}.axes.{axis}': expected [low, high] with low < high, got {[lo, hi]}")


def root_rule(spec, *, key: str = "root") -> tuple[str | None, float | None]:
    """``(root, near)`` of a ``root`` spec: None, 'largest', 'smallest' or {nearest: VALUE}."""
    if spec is None or spec in ("largest", "smallest"):
        return spec, None
    if isinstance(spec, Mapping) and set(spec) == {"nearest"}:
        value = spec["nearest"]
        if isinstance(value, Real) and not isinstance(value, bool):
            return "nearest", float(value)
    if spec == "nearest":
        raise ConfigError(f"config key {key!r}: 'nearest' needs the value to be nearest to, {{nearest: VALUE}}")
    raise ConfigError(f"config key {key!r}: expected largest, smallest or {{nearest: VALUE}}, got {spec!r}")


@lru_cache(maxsize=32)
def _quadratic_coefficients(formula: str, coordinates: tuple, parameters: tuple, name: str):
    import sympy  # here, with the formula's parsing: a section that solves no coordinate never needs it

    from ..systems.formula import parse_potential

    expression = parse_potential(formula, coordinates, dict(parameters), "systems")
    symbols = [sympy.Symbol(c, real=True) for c in coordinates]
    solved = symbols[coordinates.index(name)]
    try:
        polynomial = sympy.Poly(expression, solved)
    except sympy.polys.polyerrors.BasePolynomialError:
        return None
    if polynomial.degree() > 2 or polynomial.degree() < 1:
        return None
    others = [s for s in symbols if s != solved]
    return tuple(
        sympy.lambdify(others, polynomial.coeff_monomial(solved**k), "numpy") for k in (2, 1, 0)
    )


def quadratic_in(system: System, name: str):
    """Functions (a, b, c) of the other coordinates with V = a q^2 + b q + c in the coordinate
    ``name`` = q, or None if V is not such a polynomial (or the system has no formula)."""
    if not system.formula:
        return None
    return _quadratic_coefficients(system.formula, tuple(system.coordinates), tuple(sorted(system.parameters.items())), name)


def fixed_values(
    fixed: Mapping[str, float | str], system: System, saddle: np.ndarray | None = None, *, key: str = "fixed"
) -> dict[str, float]:
    """Fixed coordinates as numbers: each value a number, or ``'saddle'`` for the coordinate's value
    at the saddle at position ``saddle`` (shape (n_dof,); 0 for a momentum). ``key`` (the config
    key of ``fixed``) is named in errors."""
    resolved = {}
    for name, value in fixed.items():
        if isinstance(value, str):
            if value != "saddle":
                raise ConfigError(f"config key '{key}.{name}': expected a number or 'saddle', got {value!r}")
            if name not in system.phase_coordinates:
                raise ConfigError(f"config key '{key}.{name}': not a phase coordinate of {system.name}")
            if saddle is None:
                raise ConfigError(f"config key '{key}.{name}': 'saddle' needs a selected index-1 saddle, and none is given")
            # a Hamiltonian's saddle is a configuration (momenta 0); a vector field's a state
            momenta = np.zeros(len(system.phase_coordinates) - len(np.atleast_1d(saddle)))
            saddle_state = np.concatenate([np.asarray(saddle, dtype=np.float64), momenta])
            value = saddle_state[system.phase_coordinates.index(name)]
        elif not isinstance(value, Real) or isinstance(value, bool):
            raise ConfigError(f"config key '{key}.{name}': expected a number or 'saddle', got {value!r}")
        resolved[name] = float(value)
    return resolved


def section_states(
    system: System, section: Section, energy: float, rows: slice = slice(None)
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Phase-space points of the section's grid at ``energy`` (only the first-axis ``rows``).

    Returns
    -------
    states : ndarray, shape (n_allowed, 2 n_dof)
        The allowed points, in C order of the grid (first axis slowest).
    allowed : ndarray of bool, shape (rows, ``section.shape[1]``)
        Where the solved momentum is real, or the solved position has a root.
    solved : ndarray, shape (rows, ``section.shape[1]``), or None
        The solved coordinate (0 where not allowed); None for a vector field (nothing solved).
    """
    section.check(system)
    if not system.hamiltonian:
        return _flow_states(system, section, rows)
    n = system.n_dof
    phase = system.phase_coordinates
    first, second = section.axis_values()
    first = first[rows]
    grid_first, grid_second = np.meshgrid(first, second, indexing="ij")
    states = np.zeros((grid_first.size, 2 * n))
    states[:, phase.index(section.axes[0])] = grid_first.ravel()
    states[:, phase.index(section.axes[1])] = grid_second.ravel()
    for name, value in section.fixed.items():
        states[:, phase.index(name)] = value
    solve = phase.index(section.solve)
    if solve < n:
        allowed, solved = _solve_position(system, section, states, energy)
    else:
        allowed, solved = solve_momentum(system, states, solve - n, energy, section.sign)
    states[:, solve] = solved
    shape = grid_first.shape
    return states[allowed], allowed.reshape(shape), solved.reshape(shape)


def _flow_states(system, section: Section, rows: slice) -> tuple[np.ndarray, np.ndarray, None]:
    """``section_states`` of a vector field: every grid point, all allowed, nothing solved."""
    state = system.coordinates
    first, second = section.axis_values()
    grid_first, grid_second = np.meshgrid(first[rows], second, indexing="ij")
    states = np.zeros((grid_first.size, len(state)))
    states[:, state.index(section.axes[0])] = grid_first.ravel()
    states[:, state.index(section.axes[1])] = grid_second.ravel()
    for name, value in section.fixed.items():
        states[:, state.index(name)] = value
    return states, np.ones(grid_first.shape, dtype=bool), None


def solve_momentum(
    system: System, states: np.ndarray, index: int, energy: float, sign: int | np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """``(allowed, solved)``: the momentum p_index of each row of ``states`` (shape (k, 2 n_dof))
    with H = ``energy``, the other entries given; ``solved`` is 0 where no real value exists.

    Unit masses: p_s = sign sqrt(2 (E - V) - sum of the other p_i^2). With a kinetic matrix,
    W = M^-1, H = E is the quadratic W_ss x^2 / 2 + b x + c = 0 in x = p_s, with
    b = sum_{l != s} W_sl p_l and c = T(other momenta) + V - E, whose roots have the velocity
    dq_s/dt = W_ss x + b = +-sqrt(b^2 - 2 W_ss c): ``sign`` chooses the sign of that velocity (of
    p_s itself for diagonal masses, where b = 0). The root is taken in the form without
    cancellation (x = 2 c / (-b - sign sqrt(D)) where -b and sign sqrt(D) differ in sign).
    ``sign`` is one for all rows or one per row (slices of a family solved together).
    """
    n = system.n_dof
    sign = np.broadcast_to(np.asarray(sign, dtype=np.float64), (len(states),))
    potential = system.potentials(states[:, :n])
    solved = np.zeros(len(states))
    if system.mass_matrix is None:
        other_momenta = np.delete(states[:, n:], index, axis=1)
        radicand = 2.0 * (energy - potential) - np.sum(other_momenta**2, axis=1)
        allowed = radicand >= 0.0
        solved[allowed] = sign[allowed] * np.sqrt(radicand[allowed])
        return allowed, solved
    inverse = system.inverse_mass
    others = np.array(states[:, n:], dtype=np.float64)
    others[:, index] = 0.0
    w = inverse[index, index]
    b = others @ inverse[index]
    c = system.kinetic_energy(others) + potential - energy
    discriminant = b * b - 2.0 * w * c
    allowed = discriminant >= 0.0
    root = sign * np.sqrt(np.where(allowed, discriminant, 0.0))
    same = (-b) * root >= 0.0
    with np.errstate(divide="ignore", invalid="ignore"):
        x = np.where(same, (root - b) / w, 2.0 * c / (-b - root))
    # -b - root is 0 only where b = root = 0 (then c = 0 and p_s = 0), taken by the first form
    solved[allowed] = x[allowed]
    return allowed, solved


def _pick(roots: np.ndarray, valid: np.ndarray, section: Section) -> tuple[np.ndarray, np.ndarray]:
    """The root ``section.root`` takes of each row of ``roots`` (candidates where ``valid``)."""
    if section.root == "largest":
        score = np.where(valid, roots, -np.inf)
        index = np.argmax(score, axis=1)
    elif section.root == "smallest":
        score = np.where(valid, roots, np.inf)
        index = np.argmin(score, axis=1)
    else:
        score = np.where(valid, np.abs(roots - section.near), np.inf)
        index = np.argmin(score, axis=1)
    rows = np.arange(len(roots))
    return valid[rows, index], roots[rows, index]


def _solve_position(system: System, section: Section, states: np.ndarray, energy: float):
    """``(allowed, solved)``: the position ``section.solve`` with V = E - p^T M^-1 p / 2, the others fixed.

    V quadratic in it: the closed form (both roots, the stable formula). Otherwise, on
    ``section.search``: the sign changes of V - target on SCAN_POINTS samples, then bisection
    of the bracket of the root taken (a tangency between two samples is missed). Vectorized
    over all points, in chunks.
    """
    n = system.n_dof
    s = system.coordinates.index(section.solve)
    target = energy - system.kinetic_energy(states[:, n:])
    count = len(states)
    if section.search is None:
        others = [states[:, l] for l in range(n) if l != s]
        # a coordinate far out (1e300) overflows a coefficient to inf: that point has no finite root,
        # and is refused below (np.isfinite), a fact, not a fault to warn of
        with np.errstate(over="ignore", invalid="ignore"):
            a, b, c = (np.broadcast_to(np.asarray(f(*others), dtype=np.float64), (count,))
                       for f in quadratic_in(system, section.solve))
            c = c - target
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            discriminant = b * b - 4.0 * a * c
            root = np.sqrt(np.maximum(discriminant, 0.0))
            half = -0.5 * (b + np.copysign(root, b))
            quadratic = np.column_stack([half / a, np.where(half != 0.0, c / half, half / a)])
            linear = -c / b
        is_quadratic = (a != 0.0)[:, None]
        roots = np.where(is_quadratic, quadratic, linear[:, None])
        valid = np.isfinite(roots) & np.where(is_quadratic, (discriminant >= 0.0)[:, None], True)
        allowed, solved = _pick(roots, valid, section)
        return allowed, np.where(allowed, solved, 0.0)

    samples = np.linspace(*section.search, SCAN_POINTS)
    allowed = np.zeros(count, dtype=bool)
    solved = np.zeros(count)
    columns = np.ascontiguousarray(states[:, :n].T)  # (n, count), the kernels' layout
    chunk = max(1, 2**20 // SCAN_POINTS)
    for start in range(0, count, chunk):
        part = slice(start, min(start + chunk, count))
        size = part.stop - part.start
        positions = np.empty((n, size * SCAN_POINTS))
        for l in range(n):
            positions[l] = np.tile(samples, size) if l == s else np.repeat(columns[l, part], SCAN_POINTS)
        g = potential_of_columns(system, positions).reshape(size, SCAN_POINTS) - target[part, None]
        below, finite = g <= 0.0, np.isfinite(g)
        change = (below[:, :-1] != below[:, 1:]) & finite[:, :-1] & finite[:, 1:]
        middles = np.broadcast_to(0.5 * (samples[:-1] + samples[1:]), change.shape)
        if section.root == "nearest":  # the nearest bracket on each side of the value, both refined
            left = Section(**{**section.__dict__, "root": "largest"})
            right = Section(**{**section.__dict__, "root": "smallest"})
            candidates = [_pick(middles, change & (middles <= section.near), left),
                          _pick(middles, change & (middles >= section.near), right)]
        else:
            candidates = [_pick(middles, change, section)]
        roots = []
        for _, middle in candidates:
            index = np.clip(np.searchsorted(samples, middle) - 1, 0, SCAN_POINTS - 2)
            low, high = samples[index], samples[index + 1]
            low_below = below[np.arange(size), index]
            point = np.array(columns[:, part])
            for _ in range(BISECTIONS):
                mid = 0.5 * (low + high)
                point[s] = mid
                same = (potential_of_columns(system, point) - target[part] <= 0.0) == low_below
                low, high = np.where(same, mid, low), np.where(same, high, mid)
            roots.append(0.5 * (low + high))
        found, root = _pick(np.column_stack(roots), np.column_stack([f for f, _ in candidates]), section)
        allowed[part] = found
        solved[part] = np.where(found, root, 0.0)
    return allowed, solved


def potential_of_columns(system: System, positions: np.ndarray) -> np.ndarray:
    """V at each column of ``positions`` (shape (n_dof, count), C-contiguous)."""
    return system.potentials(positions.T)
