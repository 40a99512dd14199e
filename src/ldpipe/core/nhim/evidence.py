"""References and evidence for a refined NHIM point: a periodic orbit's crossing, residence times."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ...engine import LDSettings, compute_ld
from .fates import Cost, RefinementSettings
from .refinement import ld_at_points
from .slices import SliceProblem


def orbit_section_crossing(
    problem: SliceProblem, orbit_state: np.ndarray, period: float, *, rtol: float = 1e-13, atol: float = 1e-13,
) -> np.ndarray:
    """Where a periodic orbit of a 2 DoF system crosses the section, in section coordinates, shape (2,).

    The section must fix one coordinate q_j and solve its conjugate momentum p_j with a sign s
    (as U_xpx^+(k): y = k, p_y > 0): the crossing is the orbit's passage through q_j = value with
    dq_j/dt (= p_j without masses) of sign s. It is the engine's exit (DOP853 at ``rtol``, ``atol``; the crossing
    located on the step's interpolant to machine precision, :attr:`LDResult.end_state`) from the
    half-space s (q_j - value) <= 0 through its face q_j = value; an orbit starting in the other
    half-space is first run out of that one.
    """
    system, section = problem.system, problem.section
    if len(section.fixed) != 1:
        raise ValueError(
            f"map {problem.name}: a periodic orbit crosses a section with one fixed coordinate (2 DoF); "
            f"this one fixes {sorted(section.fixed)}"
        )
    (name, value), = section.fixed.items()
    if name not in system.coordinates or section.solve != "p" + name:
        raise ValueError(
            f"map {problem.name}: the orbit crossing needs the fixed coordinate to be a position and the solved "
            f"momentum its conjugate (fixed {name}, solved {section.solve})"
        )
    j = system.coordinates.index(name)
    sign = section.sign
    radius = problem.ld_settings.escape_radius
    state = np.array(orbit_state, dtype=np.float64)
    # Half-spaces of q_j bounded by the section, the other coordinates in a box the escape radius
    # ends first; ``before`` (s (q_j - value) <= 0) is left through the section in the direction s.
    for before in ((False, True) if sign * (state[j] - value) > 0 else (True,)):
        lower, upper = [-2.0 * radius] * system.n_dof, [2.0 * radius] * system.n_dof
        if before == (sign > 0):
            upper[j] = value
        else:
            lower[j] = value
        settings = LDSettings(scheme="dop853", rtol=rtol, atol=atol, p="arclength", tau=1.5 * period,
                              region_lower=tuple(lower), region_upper=tuple(upper), escape_radius=radius)
        result = compute_ld(system, state, +1, settings)
        face = (j + 1) * (sign if before else -sign)
        if result.exit_face[0] != face:
            raise ValueError(f"map {problem.name}: the periodic orbit never crosses {name} = {value} with "
                             f"{section.solve} of sign {sign:+d}")
        state = result.end_state[0].copy()
        state[j] = value  # on the section (the located crossing, to rounding)
    phase = system.phase_coordinates
    return np.array([state[phase.index(section.axes[0])], state[phase.index(section.axes[1])]])


def orbit_section_residual(problem: SliceProblem, samples: np.ndarray) -> tuple[float, np.ndarray]:
    """How close a sampled orbit comes to the section's fixed values (for sections it may miss).

    Parameters
    ----------
    samples : ndarray, shape (s, 2 n_dof)

    Returns
    -------
    residual : float
        Smallest over the samples of the largest |coordinate - fixed value| (0 on the section),
        counting only samples whose solved coordinate's velocity has the section's sign.
    point : ndarray, shape (2,)
        The section coordinates of that sample.
    """
    phase = problem.system.phase_coordinates
    columns = [phase.index(name) for name in problem.section.fixed]
    values = np.array(list(problem.section.fixed.values()))
    residual = np.max(np.abs(samples[:, columns] - values), axis=1)
    # the section's sign is that of the velocity dq_s/dt of the solved momentum's coordinate (= p_s without masses)
    n = problem.system.n_dof
    velocities = problem.system.velocity(samples[:, n:])
    sign_ok = problem.section.sign * velocities[:, phase.index(problem.section.solve) - n] > 0
    residual = np.where(sign_ok, residual, np.inf)
    best = int(np.argmin(residual))
    axes = [phase.index(a) for a in problem.section.axes]
    return float(residual[best]), samples[best, axes]


def residence_evidence(
    problem: SliceProblem, point: np.ndarray, settings: RefinementSettings, cost: Cost | None = None,
) -> dict[str, float]:
    """Time spent in the saddle region, forward and backward, by a point and by its grid neighbours.

    The neighbours are the 8 points one grid cell away. Integrated at the refinement's rtol with
    tau = ``max_time`` (so the exit time, not tau, ends each trajectory).

    Returns
    -------
    dict with ``residence_forward``, ``residence_backward`` (the point), and
    ``neighbour_residence_max`` (the largest min(forward, backward) over the neighbours).
    """
    offsets = np.array([(a, b) for a in (-1, 0, 1) for b in (-1, 0, 1) if (a, b) != (0, 0)], dtype=float)
    points = np.vstack([point, point + offsets * problem.spacing])
    ld_settings = replace(problem.ld_settings, scheme="dop853", rtol=settings.rtol, atol=settings.atol,
                          tau=settings.max_time)
    values = ld_at_points(problem, points, ld_settings, cost)
    both = np.minimum(values["exit_time_forward"], values["exit_time_backward"])
    return {
        "residence_forward": float(values["exit_time_forward"][0]),
        "residence_backward": float(values["exit_time_backward"][0]),
        "neighbour_residence_max": float(both[1:].max()),
    }
