"""Poincaré section stage: crossings of a surface of section by many trajectories on one energy surface.

A section is declared under ``poincare_sections:`` in the configuration: the
system, the energy (total, or excess over the selected saddle's E_c), the grid
of initial conditions (an isoenergetic section, as for LD maps), the surface
crossed (a phase coordinate, its value and the crossing direction) and the
final time.
"""

from __future__ import annotations

from pathlib import Path

import numba

from ..io.contracts import EQUILIBRIA, POINCARE
from ..io.datafile import open_stage_file, write_stage_file
from ..core.equilibria.potential import select_saddle
from ..errors import ConfigError
from ..core.trajectories import FlowSettings
from ..logs import get_logger
from ..core.orbits.poincare import section_crossings
from ..core.sections import Section
from ..systems import make_system

log = get_logger(__name__)


def run_poincare(*, output: str | Path, equilibria: str | Path | None, threads: int | None = None,
                 **parameters) -> Path:
    """Integrate the section's initial conditions and write their crossings to ``output``.

    ``equilibria`` None: a vector-field system (no energy; its trajectories start at ``t0``)."""
    key = f"poincare_sections.{parameters['name']}"
    system = make_system(parameters["system_name"], parameters["system_spec"])
    t0 = float(parameters.get("t0", 0.0))
    if not system.hamiltonian:
        energy = critical_energy = None
    elif equilibria is None:
        raise ConfigError(f"config key '{key}.system': the Hamiltonian system {system.name!r} needs its equilibria file")
    else:
        energy, critical_energy = _energy(parameters, open_stage_file(equilibria, stage=EQUILIBRIA))
    return _poincare(key, system, energy, critical_energy, t0, threads, parameters, output)


def _energy(parameters: dict, equilibria_data) -> tuple[float, float | None]:
    """The section's total energy and, where the system has an index-1 saddle, its critical energy."""
    energy_spec = parameters["energy"]
    if "total" in energy_spec:
        energy, critical_energy = energy_spec["total"], None
        if equilibria_data.sizes.get("saddle", 0):
            critical_energy = select_saddle(equilibria_data, parameters.get("saddle_near"))[1]
    else:
        critical_energy = select_saddle(equilibria_data, parameters.get("saddle_near"))[1]
        energy = critical_energy + energy_spec["excess"]
    return energy, critical_energy


def _poincare(key: str, system, energy, critical_energy, t0: float, threads, parameters: dict, output) -> Path:
    start = parameters["initial_conditions"]
    grid = Section.from_spec(start, system, key=f"{key}.initial_conditions")
    section = parameters["section"]
    if section["coordinate"] not in system.phase_coordinates:
        raise ConfigError(f"config key '{key}.section.coordinate': {section['coordinate']!r} is not one of "
                          f"{list(system.phase_coordinates)}")
    integrator = parameters["integrator"]
    flow = FlowSettings(rtol=integrator["rtol"], atol=integrator["atol"], escape_radius=integrator["escape_radius"])
    where = f"E = {energy:.12g}" if energy is not None else f"t0 = {t0:g}"
    log.info("%s: %s at %s, T = %g", parameters["name"], system.name, where, parameters["time"])
    dataset = section_crossings(
        system, grid, energy, section=(section["coordinate"], section["value"], section["direction"]),
        time=parameters["time"], max_crossings=parameters["max_crossings"], flow=flow,
        threads=threads or numba.get_num_threads(), t0=t0,
    )
    dataset.attrs["system"] = system.name
    dataset.attrs.update(system.kinetic_attributes())
    if critical_energy is not None:
        dataset.attrs.update({"critical_energy": critical_energy, "excess_energy": energy - critical_energy})
    log.info("%d trajectories, %d escaped, %d crossings", dataset.sizes["trajectory"], int(dataset.escaped.sum()),
             int(dataset.crossing_count.sum()))
    title = f"Poincaré section {parameters['name']} of {system.name}"
    path = write_stage_file(dataset, output, stage=POINCARE, title=title, parameters=parameters)
    log.info("wrote %s", path)
    return path
