"""Chaos indicators of a Hamiltonian flow from its LD on a section, beside the SALI and the FLI.

The starts are a section's grid on an energy surface (a Poincaré-section-like slice: two axes,
the other coordinates fixed, a momentum solved from H = E). L(x) = L_forward + L_backward is the
LD over [-tau, tau]; a start's neighbours are the section's points at +-sigma along each axis,
their solved momentum solved again, so they lie on the same energy surface. From the LDs of a
start and its four neighbours, the indicators of Hillebrand et al. (2022) and Daquin et al.
(2022), as on a map (:mod:`ldpipe.core.maps.chaos`): D_L, S_L and the Laplacian |Delta L|.

Beside them, the indicator the recent work recommends (Căliman, Daquin and Libert 2024, where
the derivatives come from automatic differentiation instead of finite differences): the
gradient of the LD along the section, with no neighbours, from the exact derivative of the
arc-length LD carried along the variational equations
(:func:`ldpipe.engine.variational_ld.variational_ld`). With the solved coordinate s a function
of the axes on H = E, its derivative along axis a is -(dH/dx_a) / (dH/dx_s), so

    dL/da = dL/dx_a + dL/dx_s * (-(dH/dx_a) / (dH/dx_s)),   ld_gradient = |(dL/da_1, dL/da_2)|.

The reference is the smaller alignment index of two deviation vectors over ``reference_tau``
(Skokos 2001): chaotic where it falls below ``sali_threshold`` (1e-8, Skokos's and the LD
papers' bound); the FLI of the same run is recorded too. Each LD indicator is classified by a
threshold of its own log10 values (reading nothing of the reference), and its agreement with
the SALI's classification is recorded. The finite-difference indicators take Otsu's threshold,
as on a map. The gradient takes the minimum-error threshold of Kittler and Illingworth
(:func:`~ldpipe.core.maps.chaos.minimum_error_threshold`): finite differences saturate once the
neighbours' orbits have parted, the exact derivative does not, so its chaotic values spread
over many decades (e^{lambda tau}) against the regular ones' few (a polynomial growth), and
Otsu's criterion, which assumes classes of equal spread, cuts into the chaotic class (on
Hénon–Heiles at E = 1/8, 20 x 20 starts, tau = 500: agreement 0.86 by Otsu's, 0.96 by this).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import xarray as xr

from ..engine.api import compute_ld
from ..engine.settings import LDSettings
from ..engine.variational_ld import variational_ld
from ..errors import ConfigError
from .maps.chaos import INDICATORS, classify_against, minimum_error_threshold, neighbour_indicators
from .sections import Section, section_states, solve_momentum

#: The indicators of a flow, by their variable's name: the map's, and the exact gradient.
FLOW_INDICATORS = {
    **INDICATORS,
    "ld_gradient": "|grad L| along the section's axes, from the exact derivative of the LD along the variational "
                   "equations (no neighbours)",
}


def _positive(name: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value) or value <= 0:
        raise ConfigError(f"{name}: expected a finite number > 0, got {value!r}")
    return float(value)


def _section(system, section) -> Section:
    if isinstance(section, Mapping):
        section = Section.from_spec(section, system)
    if not isinstance(section, Section):
        raise ConfigError(f"section: expected a Section or a section's spec, got {type(section).__name__}")
    n = system.n_dof
    if section.solve is None or system.phase_coordinates.index(section.solve) < n:
        raise ConfigError(f"section.solve: the chaos indicators re-solve a momentum at each neighbour; got "
                          f"{section.solve!r}, give one of {system.momenta}")
    return section


def total_flow_ld(system, states: np.ndarray, settings: LDSettings) -> tuple[np.ndarray, np.ndarray]:
    """L = forward + backward LD of each start (``compute_ld``), and where either half did not run
    its whole time (escaped or failed)."""
    forward = compute_ld(system, states, 1, settings)
    backward = compute_ld(system, states, -1, settings)
    broken = forward.escaped | forward.failed | backward.escaped | backward.failed
    return forward.ld + backward.ld, broken


def section_gradient(system, states: np.ndarray, gradient: np.ndarray, section: Section) -> np.ndarray:
    """dL/da along the section's two axes (shape (N, 2)) from the phase-space gradient of L,
    the solved coordinate following the axes on the energy surface (see the module docstring)."""
    n = system.n_dof
    phase = system.phase_coordinates
    energy_gradient = np.empty_like(states)
    for row, state in enumerate(states):
        energy_gradient[row, :n] = system.gradient(state[:n])
        energy_gradient[row, n:] = system.velocity(state[n:])
    solved = phase.index(section.solve)
    columns = []
    for axis in section.axes:
        a = phase.index(axis)
        columns.append(gradient[:, a] - gradient[:, solved] * energy_gradient[:, a] / energy_gradient[:, solved])
    return np.stack(columns, axis=1)


def flow_chaos_indicators(system, section, energy: float, *, tau: float, sigma: float, reference_tau: float,
                          dt: float = 0.01, rtol: float = 1e-10, atol: float = 1e-10,
                          sali_threshold: float = 1e-8, escape_radius: float = 100.0) -> xr.Dataset:
    """The LD indicators on ``section`` (a :class:`~ldpipe.core.sections.Section` or its spec, a
    momentum solved) at ``energy`` beside the SALI and FLI over ``reference_tau``.

    The LDs of the finite-difference indicators are the engine's arc-length LDs (DOP853 at
    ``rtol``, ``atol``) over ``tau`` each way, with neighbours at ``sigma``; the gradient and the
    reference come from the variational equations by fourth-order Runge-Kutta with steps of at
    most ``dt``. Returns a Dataset over the section's two axes (every indicator 0 and
    ``defined`` False where a start, one of its neighbours or a trajectory is not usable), the
    Otsu thresholds and the agreements with the SALI's classification in its attributes.
    """
    if not system.hamiltonian:
        raise ConfigError(f"system: the flow's chaos indicators take a natural Hamiltonian; {system.name!r} is a "
                          "vector field")
    tau, sigma, reference_tau = (_positive(name, value) for name, value in
                                 (("tau", tau), ("sigma", sigma), ("reference_tau", reference_tau)))
    dt, sali_threshold = _positive("dt", dt), _positive("sali_threshold", sali_threshold)
    if isinstance(energy, bool) or not isinstance(energy, (int, float)) or not np.isfinite(energy):
        raise ConfigError(f"energy: expected a finite number, got {energy!r}")
    energy = float(energy)
    section = _section(system, section)
    try:
        settings = LDSettings(tau=tau, p="arclength", scheme="dop853", rtol=rtol, atol=atol,
                              escape_radius=escape_radius)
    except ValueError as error:
        raise ConfigError(str(error)) from None
    n = system.n_dof
    phase = system.phase_coordinates
    solve = phase.index(section.solve) - n
    states, allowed, _ = section_states(system, section, energy)
    centre, broken = total_flow_ld(system, states, settings)
    pairs = []
    for axis in section.axes:
        index = phase.index(axis)
        shifted = []
        for step in (sigma, -sigma):
            neighbour = states.copy()
            neighbour[:, index] += step
            reachable, momentum = solve_momentum(system, neighbour, solve, energy, section.sign)
            neighbour[:, n + solve] = momentum
            ld, failed = total_flow_ld(system, neighbour, settings)
            broken |= failed | ~reachable
            shifted.append(ld)
        pairs.append(tuple(shifted))
    found = neighbour_indicators(centre, pairs, sigma, ~broken)

    forward = variational_ld(system, states, tau, dt, 1, escape_radius)
    backward = variational_ld(system, states, tau, dt, -1, escape_radius)
    along = section_gradient(system, states, forward.gradient + backward.gradient, section)
    found["ld_gradient"] = np.where(found["defined"], np.hypot(along[:, 0], along[:, 1]), 0.0)
    reference_run = variational_ld(system, states, reference_tau, dt, 1, escape_radius)
    defined = found["defined"] & ~(forward.escaped | backward.escaped | reference_run.escaped)
    reference = reference_run.sali < sali_threshold
    chaotic, attributes = classify_against(found, tuple(FLOW_INDICATORS), defined, reference,
                                          {"ld_gradient": minimum_error_threshold})

    shape = section.shape

    def grid(values, fill=0.0):
        full = np.full(shape, fill, dtype=np.asarray(values).dtype)
        full[allowed] = values
        return full

    dims = tuple(section.axes)
    variables = {
        "allowed": (dims, allowed, {"long_name": "the solved momentum is real at this point"}),
        "defined": (dims, grid(defined, False), {"long_name": "allowed, L > 0, the neighbours allowed and every "
                                                               "trajectory run its whole time"}),
        "ld": (dims, grid(centre), {"long_name": "arc-length LD, forward and backward halves summed"}),
        "ld_variational": (dims, grid(forward.ld + backward.ld),
                           {"long_name": "the same LD by the variational run (fourth-order Runge-Kutta)"}),
        "sali": (dims, grid(reference_run.sali, 1.0),
                 {"long_name": f"smaller alignment index, minimum over t <= {reference_tau:g}"}),
        "fli": (dims, grid(reference_run.fli), {"long_name": f"fast Lyapunov indicator over t <= {reference_tau:g}"}),
        "chaotic_sali": (dims, grid(reference & defined, False),
                         {"long_name": f"chaotic by the SALI (below {sali_threshold:g})"}),
    }
    for column, axis in enumerate(dims):
        variables[f"dld_d{axis}"] = (dims, grid(np.where(defined, along[:, column], 0.0)),
                                     {"long_name": f"dL/d{axis} along the section (the solved momentum following), "
                                                   "from the variational equations", "comment": "0 where not defined"})
    for name, text in FLOW_INDICATORS.items():
        variables[name] = (dims, grid(found[name]), {"long_name": text, "comment": "0 where not defined"})
        variables[f"chaotic_{name}"] = (dims, grid(chaotic[name], False),
                                        {"long_name": f"chaotic by {name} (log10 above its Otsu threshold)"})
    first, second = section.axis_values()
    attributes.update({
        "system": system.name, "energy": energy, "tau": tau, "sigma": sigma, "reference_tau": reference_tau,
        "dt": dt, "rtol": rtol, "atol": atol, "sali_threshold": sali_threshold, "escape_radius": escape_radius,
        "descriptor": "arclength", "solve": section.solve, "fixed": str(dict(section.fixed)),
        "defined_starts": int(defined.sum()), "chaotic_fraction_sali": float(np.mean(reference[defined]))
        if defined.any() else 0.0,
    })
    return xr.Dataset(variables, coords={dims[0]: first, dims[1]: second}, attrs=attributes)
