"""The section slice the NHIM detection and refinement work on, and the states of its points."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...engine import LDSettings
from ..orbits.periodic import linearize_saddle
from ..sections import Section, solve_momentum
from ...systems import System


@dataclass(frozen=True)
class SliceProblem:
    """Everything the detection and refinement need about one section of one system.

    Attributes
    ----------
    name : str
        The map's name, for messages.
    system : System
    section : Section
        Axes, ranges and grid shape of the LD map, fixed coordinates (numbers) and solved momentum.
    energy : float
        Total energy of the section.
    excess_energy : float
        Energy above the saddle's critical energy.
    saddle : ndarray, shape (n_dof,)
        Position of the index-1 saddle.
    region_lower, region_upper : ndarray, shape (n_dof,)
        The saddle region (configuration box) of the variable-time LD.
    reaction : ndarray, shape (n_dof,)
        Unit vector of the saddle's unstable direction (the Hessian's negative eigenvector); the
        sign of ``reaction . (q - saddle)`` at exit from the region is the trajectory's fate.
    ld_settings : LDSettings
        The map's LD settings (tau, p, region, integrator).
    """

    name: str
    system: System
    section: Section
    energy: float
    excess_energy: float
    saddle: np.ndarray
    region_lower: np.ndarray
    region_upper: np.ndarray
    reaction: np.ndarray
    ld_settings: LDSettings

    @property
    def spacing(self) -> np.ndarray:
        """Grid spacing along the two axes, shape (2,)."""
        return np.array([(hi - lo) / max(n - 1, 1) for (lo, hi), n in zip(self.section.ranges, self.section.shape)])


def make_slice_problem(
    name: str, system: System, section: Section, energy: float, critical_energy: float,
    saddle: np.ndarray, ld_settings: LDSettings,
) -> SliceProblem:
    """A :class:`SliceProblem` from a map's resolved pieces; the region must be set (variable time)."""
    if not ld_settings.variable_time:
        raise ValueError(f"map {name}: NHIM detection needs a variable-time LD map (a saddle region); this one is fixed time")
    saddle = np.asarray(saddle, dtype=np.float64)
    reaction = linearize_saddle(system, saddle).saddle_vector
    return SliceProblem(
        name=name, system=system, section=section, energy=float(energy),
        excess_energy=float(energy - critical_energy), saddle=saddle,
        region_lower=np.array(ld_settings.region_lower), region_upper=np.array(ld_settings.region_upper),
        reaction=reaction / np.linalg.norm(reaction), ld_settings=ld_settings,
    )


def section_point_states(problem: SliceProblem, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Phase-space states of arbitrary section points (not only grid points).

    Parameters
    ----------
    points : array_like, shape (k, 2)
        Values of the section's two axes.

    Returns
    -------
    states : ndarray, shape (k, 2 n_dof)
        The states, with the solved momentum from the energy (0 where not allowed).
    allowed : ndarray of bool, shape (k,)
        Where the solved momentum is real.
    """
    system, section = problem.system, problem.section
    points = np.atleast_2d(np.asarray(points, dtype=np.float64))
    phase = system.phase_coordinates
    n = system.n_dof
    states = np.zeros((len(points), 2 * n))
    states[:, phase.index(section.axes[0])] = points[:, 0]
    states[:, phase.index(section.axes[1])] = points[:, 1]
    for name, value in section.fixed.items():
        states[:, phase.index(name)] = value
    solve = phase.index(section.solve)
    allowed, solved = solve_momentum(system, states, solve - n, problem.energy, section.sign)
    states[allowed, solve] = solved[allowed]
    return states, allowed


def point_slice(
    system: System, state: np.ndarray, axes: tuple[str, str], half_width: float | tuple[float, float], points: int,
    solve: str | None = None,
) -> Section:
    """The slice through one phase-space point: a window around it on the axes, every other coordinate fixed.

    For n DoF the slice fixes 2 n - 3 phase coordinates at the state's values and solves the remaining
    momentum from the energy with the state's sign, so the state itself is the window's centre.

    Parameters
    ----------
    state : array_like, shape (2 n_dof,)
    axes : (str, str)
        The two phase coordinates of the window (e.g. ``("z", "pz")``).
    half_width : float or (float, float)
        Half-width of the window along each axis.
    points : int
        Grid points per axis (odd, so the state is a grid point).
    solve : str, optional
        The solved momentum; by default the momentum off the axes with the largest |value| at the
        state, where solving for it is best conditioned (dp = -dV / p: the smaller |p|, the more a
        step in the window moves it, and at p = 0 the window meets the energy boundary).
    """
    state = np.asarray(state, dtype=np.float64)
    phase = system.phase_coordinates
    n = system.n_dof
    unknown = [a for a in axes if a not in phase]
    if unknown or len(set(axes)) != 2:
        raise ValueError(f"slice axes {list(axes)}: expected two distinct phase coordinates of {list(phase)}")
    if solve is None:
        momenta = [name for name in phase[n:] if name not in axes]
        if not momenta:
            raise ValueError(f"slice axes {list(axes)}: both are momenta of a 2-coordinate system; no momentum to solve")
        solve = max(momenta, key=lambda name: abs(state[phase.index(name)]))
    if solve not in phase[n:] or solve in axes:
        raise ValueError(f"slice solve {solve!r}: expected a momentum off the axes {list(axes)}")
    widths = np.broadcast_to(np.asarray(half_width, dtype=np.float64), (2,))
    centre = [state[phase.index(a)] for a in axes]
    fixed = {name: float(state[k]) for k, name in enumerate(phase) if name not in axes and name != solve}
    value = state[phase.index(solve)]
    return Section(
        axes=tuple(axes), ranges=tuple((c - w, c + w) for c, w in zip(centre, widths)), shape=(points, points),
        fixed=fixed, solve=solve, sign=1 if value >= 0 else -1,
    )


def boundary_distance(system: System, section: Section, state: np.ndarray) -> float:
    """Distance, in the slice's axes, from ``state`` to where the slice's solved momentum vanishes
    (the energy boundary of the slice), to first order.

    On the slice p_s^2 = 2 (E - H_rest), so moving by d along the axes changes p_s^2 by
    -2 (dH/da, dH/db) . d: p_s reaches 0 at distance p_s^2 / (2 |(dH/da, dH/db)|) (dH/dq = dV/dq,
    dH/dp = p). At a turning point of the solved momentum it is 0; a window or refinement stencil
    larger than it meets the boundary, where the fates of the trajectories are undefined.
    """
    state = np.asarray(state, dtype=np.float64)
    phase = system.phase_coordinates
    n = system.n_dof
    dH = np.concatenate([system.gradient(state[:n]), state[n:]])
    slope = float(np.hypot(*(dH[phase.index(a)] for a in section.axes)))
    momentum = float(state[phase.index(section.solve)])
    return float("inf") if slope == 0.0 else momentum**2 / (2.0 * slope)


def slice_transversality(system: System, section: Section, state: np.ndarray, monodromy: np.ndarray) -> float:
    """How transversally a slice through a point of a periodic orbit meets the NHIM there, in [0, 1].

    The NHIM's tangent space at the orbit point, with the energy direction, is the monodromy
    matrix's centre subspace C (4-dimensional in 3 DoF): the symplectic complement of its two
    hyperbolic eigenvectors u (multiplier lambda) and s (1 / lambda), C = {v : w(u, v) = w(s, v) = 0}
    with w(a, b) = a^T J b. The slice's tangent plane S is spanned by the unit steps v_a, v_b along
    its axes with the solved momentum p following the energy (dp = -dH . e_a / p). S lies in the
    energy surface, so it meets the NHIM only at the point (transversally) iff S and C share only 0,
    iff the 2 x 2 matrix [w(u, v_a), w(u, v_b); w(s, v_a), w(s, v_b)] is invertible. Its
    determinant over |w(u, s)| (unit u, s, v_a, v_b) is the measure: 0 for a slice tangent to the
    NHIM, of order 1 for a slice across it. Independent of the LD and of the fates.

    Parameters
    ----------
    state : array_like, shape (2 n_dof,)
        The orbit point, the slice's centre.
    monodromy : ndarray, shape (2 n_dof, 2 n_dof)
        The orbit's monodromy matrix started at ``state`` (one period of the state transition matrix).
    """
    state = np.asarray(state, dtype=np.float64)
    phase = system.phase_coordinates
    n = system.n_dof
    values, vectors = np.linalg.eig(monodromy)
    order = np.argsort(-np.abs(np.log(np.abs(values))))
    u, s = (np.real(vectors[:, k]) / np.linalg.norm(np.real(vectors[:, k])) for k in order[:2])
    J = np.block([[np.zeros((n, n)), np.eye(n)], [-np.eye(n), np.zeros((n, n))]])
    dH = np.concatenate([system.gradient(state[:n]), state[n:]])
    solve = phase.index(section.solve)
    steps = []
    for axis in section.axes:
        v = np.zeros(2 * n)
        v[phase.index(axis)] = 1.0
        v[solve] = -dH @ v / state[solve]
        steps.append(v / np.linalg.norm(v))
    pairing = np.array([[u @ J @ v for v in steps], [s @ J @ v for v in steps]])
    return float(abs(np.linalg.det(pairing)) / abs(u @ J @ s))
