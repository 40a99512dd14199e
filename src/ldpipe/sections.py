"""Isoenergetic two-dimensional sections of phase space.

A section fixes all phase-space coordinates but two (the axes) and one momentum,
which is solved from the energy with a chosen sign:

    p_s = sign * sqrt(2 (E - V(q)) - sum of the other p_i^2).

Points where the radicand is negative lie outside the energetically allowed
region and are masked; they are never integrated. The paper's U_xpx (y = 0,
p_y > 0) is ``axes=("x", "px"), fixed={"y": 0}, solve="py", sign=+1``; its 3 DoF
U_xpx^+ is ``axes=("x", "px"), fixed={"y": y_eq, "z": z_eq, "py": 0},
solve="pz"``.

A configuration spec of a section (``ld_maps.<name>.section``,
``poincare_sections.<name>.initial_conditions``) is resolved into a
:class:`Section` once, by :meth:`Section.from_spec`, where fixed values given as
``saddle`` take the selected saddle's value; the object then travels.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from numbers import Real

import numpy as np

from .errors import ConfigError
from .systems import System


@dataclass(frozen=True)
class Section:
    """A two-dimensional isoenergetic section; see the module docstring."""

    axes: tuple[str, str]
    ranges: tuple[tuple[float, float], tuple[float, float]]
    shape: tuple[int, int]
    fixed: dict[str, float]
    solve: str
    sign: int = 1

    @classmethod
    def from_spec(
        cls, spec: Mapping, system: System, saddle: np.ndarray | None = None, *, key: str = "section"
    ) -> Section:
        """The section a configuration spec describes, checked against ``system``.

        Parameters
        ----------
        spec : mapping
            ``axes`` (two ``{name, range: [low, high], points}``), ``fixed`` (optional;
            coordinate -> number, or ``'saddle'``), ``solve`` (a momentum) and ``sign``
            (optional, +1 or -1, default +1), as the config schema's section.
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
        missing = [name for name in ("axes", "solve") if name not in spec]
        if missing:
            raise ConfigError(f"config key {key!r}: lacks {missing}; a section needs 'axes' and 'solve'")
        axes = spec["axes"]
        if len(axes) != 2:
            raise ConfigError(f"config key '{key}.axes': expected two axes, got {len(axes)}")
        for index, axis in enumerate(axes):
            lacking = [name for name in ("name", "range", "points") if name not in axis]
            if lacking:
                raise ConfigError(f"config key '{key}.axes.{index}': lacks {lacking}")
        section = cls(
            axes=(axes[0]["name"], axes[1]["name"]),
            ranges=(tuple(axes[0]["range"]), tuple(axes[1]["range"])),
            shape=(axes[0]["points"], axes[1]["points"]),
            fixed=fixed_values(spec.get("fixed", {}), system, saddle, key=f"{key}.fixed"),
            solve=spec["solve"],
            sign=spec.get("sign", 1),
        )
        section.check(system, key=key)
        return section

    def axis_values(self) -> tuple[np.ndarray, np.ndarray]:
        """Grid coordinates along each axis, end points included."""
        return tuple(np.linspace(lo, hi, n) for (lo, hi), n in zip(self.ranges, self.shape))

    def check(self, system: System, key: str = "section") -> None:
        """Raise ConfigError unless axes, fixed and solved coordinates split the phase space."""
        phase = system.phase_coordinates
        named = [*self.axes, *self.fixed, self.solve]
        unknown = [name for name in named if name not in phase]
        if unknown:
            raise ConfigError(f"config key {key!r}: {unknown} are not phase coordinates of {system.name}; expected {list(phase)}")
        if self.solve not in system.momenta:
            raise ConfigError(f"config key '{key}.solve': {self.solve!r} is not a momentum; expected one of {list(system.momenta)}")
        if len(named) != len(set(named)) or set(named) != set(phase):
            missing = sorted(set(phase) - set(named))
            raise ConfigError(
                f"config key {key!r}: the two axes, the fixed coordinates and the solved momentum must name "
                f"each of {list(phase)} exactly once (missing {missing}, given {named})"
            )
        if self.sign not in (1, -1):
            raise ConfigError(f"config key '{key}.sign': expected +1 or -1, got {self.sign!r}")
        for (lo, hi), axis in zip(self.ranges, self.axes):
            if not lo < hi:
                raise ConfigError(f"config key '{key}.axes.{axis}': expected [low, high] with low < high, got {[lo, hi]}")


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
            saddle_state = np.concatenate([np.asarray(saddle, dtype=np.float64), np.zeros(system.n_dof)])
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
        Where the solved momentum is real.
    solved : ndarray, shape (rows, ``section.shape[1]``)
        The solved momentum (0 where not allowed).
    """
    section.check(system)
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
    potential = np.empty(len(states))
    positions = np.ascontiguousarray(states[:, :n].T)
    system.kernels.potential_block(positions, potential, len(states))
    other_momenta = np.delete(states[:, n:], solve - n, axis=1)
    radicand = 2.0 * (energy - potential) - np.sum(other_momenta**2, axis=1)
    allowed = radicand >= 0.0
    solved = np.zeros(len(states))
    solved[allowed] = section.sign * np.sqrt(radicand[allowed])
    states[:, solve] = solved
    shape = grid_first.shape
    return states[allowed], allowed.reshape(shape), solved.reshape(shape)
