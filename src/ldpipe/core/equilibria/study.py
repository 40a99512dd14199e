"""A system's equilibria as the equilibria stage's file holds them."""

from __future__ import annotations

import xarray as xr

from ...io.contracts import EQUILIBRIA, FLOW_EQUILIBRIA
from ...io.datafile import stage_dataset
from ...logs import get_logger
from ...systems import make_system
from .fixed_points import map_fixed_point_table
from .flow import flow_equilibrium_table
from .potential import equilibrium_table

log = get_logger(__name__)


def equilibria_dataset(parameters: dict) -> xr.Dataset:
    """Every equilibrium of a system in a box, analysed: ``parameters`` are the equilibria stage's
    (``system_name``, ``system_spec``, ``box``, ``seeds_per_axis``, ``tolerance``).

    A Hamiltonian system: critical points of V with energies and types (contract EQUILIBRIA); a
    vector field: the roots of f and the Jacobian's spectrum (no energies; contract
    FLOW_EQUILIBRIA); a time-dependent one is refused; a discrete map: its fixed points and
    the tangent map's multipliers (the same contract)."""
    system = make_system(parameters["system_name"], parameters["system_spec"])
    log.info("system %s: %s", system.name, system.description)
    if system.hamiltonian:
        table, stage = equilibrium_table, EQUILIBRIA
    else:  # a flow's roots of f, or a map's fixed points: the same file
        table, stage = (map_fixed_point_table if system.discrete else flow_equilibrium_table), FLOW_EQUILIBRIA
    dataset = table(system, parameters["box"], seeds_per_axis=parameters["seeds_per_axis"],
                    tolerance=parameters["tolerance"])
    for index in range(dataset.sizes["equilibrium"]):
        energy = f", energy {dataset.energy.values[index]:.12g}" if "energy" in dataset else ""
        log.info("equilibrium %d at %s: %s%s", index, dataset.position.values[index], dataset.type.values[index], energy)
    return stage_dataset(dataset, stage=stage, title=f"Equilibria and linear analysis of {parameters['system_name']}",
                         parameters=parameters)
