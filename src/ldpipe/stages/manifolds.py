"""Manifold stage: the stable and unstable manifolds of one periodic orbit, and their section curves.

A manifold set is declared under ``manifolds:`` in the configuration: the
periodic-orbit family it grows from (``orbits``) and which of that family's
target energies (``energy``), the number of points along the orbit, the
displacement epsilon, the integration time and the surface of section.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..io.contracts import MANIFOLDS, UPO
from ..io.datafile import input_name, open_stage_file, stage_parameters, write_stage_file
from ..errors import ConfigError, StageFileError
from ..core.trajectories import FlowSettings
from ..logs import get_logger
from ..core.orbits.manifolds import ManifoldSettings, globalized_manifolds
from ..systems import make_system, require_hamiltonian

log = get_logger(__name__)


def select_orbit(orbits, energy: dict, key: str, path) -> int:
    """The index of the family's orbit at the energy ``{excess: x}`` or ``{total: x}``."""
    kind, value = next(iter(energy.items()))
    available = orbits.excess_energy.values if kind == "excess" else orbits.energy.values
    index = int(np.argmin(np.abs(available - value)))
    if abs(available[index] - value) > 1e-8 * max(1.0, abs(value)):
        raise ConfigError(
            f"config key '{key}.energy': no orbit at {kind} energy {value!r} in {input_name(path)} (it has {available.tolist()}); "
            f"add it to the family's energies"
        )
    return index


def run_manifolds(*, output: str | Path, upo: str | Path, threads: int | None = None, **parameters) -> Path:
    """Globalize both manifolds of the selected orbit of the UPO file ``upo`` and write ``output``."""
    key = f"manifolds.{parameters['name']}"
    data = open_stage_file(upo, stage=UPO)
    if stage_parameters(data)["system_name"] != parameters["system_name"]:
        raise StageFileError(f"{input_name(upo)}: orbits of system {data.attrs['system']!r}, expected {parameters['system_name']!r}")
    index = select_orbit(data, parameters["energy"], key, upo)
    system = make_system(parameters["system_name"], parameters["system_spec"])
    require_hamiltonian(system, "the manifolds of a periodic orbit", key=f"{key}.orbits")
    section = parameters["section"]
    if section["coordinate"] not in system.phase_coordinates:
        raise ConfigError(f"config key '{key}.section.coordinate': {section['coordinate']!r} is not one of "
                          f"{list(system.phase_coordinates)}")
    integrator = parameters["integrator"]
    settings = ManifoldSettings(
        points=parameters["points"], displacement=parameters["displacement"], time=parameters["time"],
        samples=parameters["samples"], section=(section["coordinate"], section["value"], section["direction"]),
        crossings=parameters["crossings"],
        orbit_rtol=float(data.attrs["rtol"]), orbit_atol=float(data.attrs["atol"]),
    )
    flow = FlowSettings(rtol=integrator["rtol"], atol=integrator["atol"], escape_radius=integrator["escape_radius"])
    initial_state = data.initial_state.values[index]
    period = float(data.period.values[index])
    log.info("%s: orbit %d of %s, dE = %.6g, period %.12g", parameters["name"], index, upo,
             float(data.excess_energy.values[index]), period)
    dataset = globalized_manifolds(system, initial_state, period, settings, flow, threads=threads)
    dataset.attrs.update({
        "family": data.attrs["family"], "system": system.name, "excess_energy": float(data.excess_energy.values[index]),
        "critical_energy": float(data.attrs["critical_energy"]), "rtol": flow.rtol, "atol": flow.atol,
        "escape_radius": flow.escape_radius, **system.kinetic_attributes(),
    })
    log.info("unstable multiplier %.12g; %d of %d trajectories escaped", dataset.attrs["unstable_multiplier"],
             int(dataset.escaped.sum()), dataset.escaped.size)
    title = f"Stable and unstable manifolds of {data.attrs['family']} at dE = {dataset.attrs['excess_energy']:.6g}"
    path = write_stage_file(dataset, output, stage=MANIFOLDS, title=title, parameters=parameters)
    log.info("wrote %s", path)
    return path
