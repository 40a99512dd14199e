"""The section slice the NHIM detection and refinement work on, and the states of its points."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..engine import LDSettings
from ..periodic_orbits import linearize_saddle
from ..sections import Section, solve_momentum
from ..systems import System


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
