"""Unstable periodic orbit stage: one Lyapunov family of an index-1 saddle per file.

A family is declared under ``periodic_orbits:`` in the configuration (see the
schema): the system, the saddle (nearest ``saddle_near``), the centre mode, and
the target energies (excess over the saddle's E_c, or total). The family is
continued from the linearization up to the highest target, and the orbit at
each target is found by bracketing and correction (:mod:`ldpipe.core.orbits.periodic`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from ..io.contracts import EQUILIBRIA, UPO
from ..io.datafile import open_stage_file, write_stage_file
from ..core.equilibria.potential import select_saddle
from ..errors import ConfigError
from ..logs import get_logger
from ..core.orbits.periodic import (
    CorrectionFailed, CorrectorSettings, LyapunovFamily, floquet_multipliers, linearize_saddle, sample_orbit,
)
from ..systems import make_system, require_hamiltonian

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


def upo_family_dataset(parameters: dict, equilibria: xr.Dataset) -> xr.Dataset:
    """Continue the family and compute the orbit at every target energy."""
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
    return _dataset(system, saddle, family, targets, orbits, parameters)


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


def run_upo(*, output: str | Path, equilibria: str | Path, **parameters) -> Path:
    """Compute one Lyapunov family from the system's equilibria file and write ``output``."""
    equilibria_data = open_stage_file(equilibria, stage=EQUILIBRIA)
    dataset = upo_family_dataset(parameters, equilibria_data)
    title = f"Lyapunov periodic orbits, family {parameters['family']} of {parameters['system_name']}"
    path = write_stage_file(dataset, output, stage=UPO, title=title, parameters=parameters)
    log.info("wrote %s", path)
    return path
