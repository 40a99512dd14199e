"""A Lyapunov family of periodic orbits as the UPO stage's file holds it, and the orbit of a
family's file at a given energy.

A family is declared under ``periodic_orbits:`` in the configuration (see the schema): the
system, the saddle (nearest ``saddle_near``), the centre mode, and the target energies (excess
over the saddle's E_c, or total). :func:`periodic_orbits_dataset` is the family's file;
:func:`select_orbit` finds one of its orbits for the stages that read it (manifolds, transport).
This module integrates with scipy's variational equations only, never the engine: an engine edit
does not rerun the families.
"""

from __future__ import annotations

import os

import numpy as np
import xarray as xr

from ...errors import ConfigError
from ...io.contracts import EQUILIBRIA, UPO
from ...io.datafile import input_name, open_stage_file, stage_dataset
from ...logs import get_logger
from ...systems import make_system, require_hamiltonian
from ..equilibria.potential import select_saddle
from .periodic import (
    CorrectionFailed, CorrectorSettings, LyapunovFamily, floquet_multipliers, linearize_saddle, sample_orbit,
)

log = get_logger(__name__)


def target_energies(energies: dict, critical_energy: float, key: str) -> np.ndarray:
    """Total energies of the targets ``{excess: [...]}`` or ``{total: [...]}``, increasing order kept."""
    values = np.asarray(energies["excess"] if "excess" in energies else energies["total"], dtype=float)
    totals = values + critical_energy if "excess" in energies else values
    below = totals[totals < critical_energy]
    if len(below):
        raise ConfigError(
            f"config key '{key}.energies': energies {sorted((below - critical_energy).tolist())} below the saddle's "
            f"critical energy {critical_energy:.12g} (as excess energy); Lyapunov orbits need excess energy >= 0"
        )
    return totals


def select_orbit(orbits: xr.Dataset, energy: dict, key: str, path: str | os.PathLike | xr.Dataset) -> int:
    """The index of the family's orbit at the energy ``{excess: x}`` or ``{total: x}`` (``orbits`` read
    from ``path``, which an error names; ``key`` the configuration key of the entry asking)."""
    kind, value = next(iter(energy.items()))
    available = orbits.excess_energy.values if kind == "excess" else orbits.energy.values
    index = int(np.argmin(np.abs(available - value)))
    if abs(available[index] - value) > 1e-8 * max(1.0, abs(value)):
        raise ConfigError(
            f"config key '{key}.energy': no orbit at {kind} energy {value!r} in {input_name(path)} (it has {available.tolist()}); "
            f"add it to the family's energies"
        )
    return index


def periodic_orbits_dataset(parameters: dict, equilibria: str | os.PathLike | xr.Dataset) -> xr.Dataset:
    """A Lyapunov family at its target energies, as the UPO stage's file holds it: ``parameters``
    are the stage's (:func:`ldpipe.config.parameters.parameters_from_config`), ``equilibria`` the
    system's equilibria file or Dataset, where the saddle is selected (``saddle_near``).

    The family is continued from the saddle's linearization up to the highest target, and the
    orbit at each target found by bracketing and correction (:mod:`ldpipe.core.orbits.periodic`);
    each is sampled over one period with its Floquet multipliers. A ConfigError names the entry's
    key: a centre mode the saddle lacks, a target below E_c, a correction that failed."""
    equilibria = open_stage_file(equilibria, stage=EQUILIBRIA)
    key = f"periodic_orbits.{parameters['family']}"
    system = make_system(parameters["system_name"], parameters["system_spec"])
    require_hamiltonian(system, "a periodic-orbit family", key=f"{key}.system")
    position, critical_energy = select_saddle(equilibria, parameters.get("saddle_near"))
    saddle = linearize_saddle(system, position)
    mode = parameters["center_mode"]
    if mode >= len(saddle.omegas):
        raise ConfigError(f"config key '{key}.center_mode': {mode}, but the saddle has {len(saddle.omegas)} centre modes "
                          f"(0 to {len(saddle.omegas) - 1}, in increasing frequency {saddle.omegas.tolist()})")
    integrator = parameters["integrator"]
    settings = CorrectorSettings(
        tolerance=parameters["tolerance"], max_iterations=parameters["max_iterations"],
        rtol=integrator["rtol"], atol=integrator["atol"],
    )
    targets = target_energies(parameters["energies"], saddle.critical_energy, key)
    family = LyapunovFamily(system, saddle, mode, settings)
    continuation = parameters["continuation"]
    log.info(
        "%s: saddle %s, E_c = %.12g, lambda = %.12g, centre mode %d omega = %.12g (linear period %.12g), "
        "held coordinate %s", system.name, position, saddle.critical_energy, saddle.saddle_rate, mode, family.omega,
        2 * np.pi / family.omega, system.coordinates[family.held],
    )
    try:
        family.continue_to(
            float(targets.max()), initial_amplitude=continuation["initial_amplitude"],
            max_step=continuation["max_step"], max_members=continuation["max_members"],
        )
        log.info("continued the family over %d members up to excess energy %.6g", len(family.members),
                 family.members[-1].energy - saddle.critical_energy)
        orbits = []
        for energy in targets:
            orbit = family.at_energy(float(energy), energy_tolerance=parameters["energy_tolerance"])
            if orbit.monodromy is None:
                orbit = family.finish(orbit)
            orbits.append(orbit)
            log.info("dE = %.6g: period %.12g, closure %.3g, energy error %.3g", energy - saddle.critical_energy,
                     orbit.period, orbit.closure_error, orbit.energy - energy)
    except CorrectionFailed as error:
        raise ConfigError(f"config key '{key}': {error}") from None
    title = f"Lyapunov periodic orbits, family {parameters['family']} of {parameters['system_name']}"
    return stage_dataset(_dataset(system, saddle, family, targets, orbits, parameters), stage=UPO, title=title,
                         parameters=parameters)


def _dataset(system, saddle, family, targets, orbits, parameters) -> xr.Dataset:
    n = system.n_dof
    samples = parameters["samples"]
    multipliers = []
    trajectories = []
    times = []
    for orbit in orbits:
        values, _ = floquet_multipliers(orbit.monodromy)
        multipliers.append(values)
        t, states = sample_orbit(system, orbit, samples, family.settings)
        times.append(t)
        trajectories.append(states)
    multipliers = np.array(multipliers)
    ec = saddle.critical_energy
    members = family.members
    phase = list(system.phase_coordinates)
    data = xr.Dataset(
        {
            "target_energy": ("orbit", targets, {"long_name": "target total energy"}),
            "energy": ("orbit", [o.energy for o in orbits], {"long_name": "total energy of the orbit"}),
            "excess_energy": ("orbit", [o.energy - ec for o in orbits], {"long_name": "energy above E_c of the saddle"}),
            "period": ("orbit", [o.period for o in orbits]),
            "amplitude": ("orbit", [o.amplitude for o in orbits],
                          {"long_name": "held coordinate of the initial state minus the saddle's"}),
            "initial_state": (("orbit", "phase"), np.array([o.initial_state for o in orbits]),
                              {"long_name": "state at t = 0, a turning point (all momenta 0)"}),
            "closure_error": ("orbit", [o.closure_error for o in orbits], {"long_name": "||x(T) - x(0)||"}),
            "half_period_residual": ("orbit", [o.residual for o in orbits],
                                     {"long_name": "largest free momentum at the half-period event"}),
            "corrector_iterations": ("orbit", [o.iterations for o in orbits]),
            "floquet_real": (("orbit", "mode"), multipliers.real),
            "floquet_imag": (("orbit", "mode"), multipliers.imag,
                             {"long_name": "Floquet multipliers: lambda, 1/lambda, then by decreasing |mu - 1|"}),
            "monodromy": (("orbit", "row", "column"), np.array([o.monodromy for o in orbits])),
            "time": (("orbit", "sample"), np.array(times)),
            "trajectory": (("orbit", "sample", "phase"), np.array(trajectories),
                           {"long_name": "the orbit over one period, both ends included"}),
            "family_amplitude": ("member", [m.amplitude for m in members]),
            "family_energy": ("member", [m.energy for m in members]),
            "family_excess_energy": ("member", [m.energy - ec for m in members]),
            "family_period": ("member", [m.period for m in members]),
            "family_initial_state": (("member", "phase"), np.array([m.initial_state for m in members])),
        },
        coords={"orbit": np.arange(len(orbits)), "phase": phase, "mode": np.arange(2 * n),
                "row": phase, "column": phase, "sample": np.arange(samples), "member": np.arange(len(members))},
    )
    data.attrs.update({
        "family": parameters["family"], "system": system.name, "saddle_position": saddle.position,
        "critical_energy": ec, "saddle_rate": saddle.saddle_rate, "center_mode": family.mode,
        "omega": family.omega, "linear_period": 2 * np.pi / family.omega,
        "held_coordinate": system.coordinates[family.held],
        "tolerance": family.settings.tolerance, "energy_tolerance": parameters["energy_tolerance"],
        "rtol": family.settings.rtol, "atol": family.settings.atol,
        **system.kinetic_attributes(),
    })
    return data
