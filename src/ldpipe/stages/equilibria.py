"""Equilibrium and linear-analysis stage: one netCDF file per system."""

from __future__ import annotations

from pathlib import Path

from ..io.contracts import EQUILIBRIA, FLOW_EQUILIBRIA
from ..io.datafile import write_stage_file
from ..core.equilibria.potential import equilibria_dataset
from ..core.equilibria.flow import vector_field_equilibria_dataset
from ..logs import get_logger
from ..systems import make_system
from .parameters import parameters_from_config

log = get_logger(__name__)


def equilibria_file(config: dict, system_name: str, given: str | Path | None, scratch: Path) -> Path:
    """The equilibria file ``given``, or one computed now into the folder ``scratch`` (for the CLI,
    whose later stages read the equilibria from a file as their Snakemake rules do)."""
    if given is not None:
        return Path(given)
    parameters = parameters_from_config(config, "equilibria", system_name)
    return run_equilibria(**parameters, output=Path(scratch) / f"{system_name}_equilibria.nc")


def run_equilibria(
    *,
    system_name: str,
    system_spec: dict,
    box: dict[str, list[float]],
    output: str | Path,
    seeds_per_axis: int = 9,
    tolerance: float = 1e-10,
) -> Path:
    """Find every equilibrium of the system in ``box``, analyse it, and write ``output``.

    A vector-field system: the roots of f and the Jacobian's spectrum (no energies; contract
    FLOW_EQUILIBRIA); a time-dependent one is refused."""
    system = make_system(system_name, system_spec)
    log.info("system %s: %s", system_name, system.description)
    if not system.hamiltonian:
        dataset = vector_field_equilibria_dataset(system, box, seeds_per_axis=seeds_per_axis, tolerance=tolerance)
        stage = FLOW_EQUILIBRIA
    else:
        dataset = equilibria_dataset(system, box, seeds_per_axis=seeds_per_axis, tolerance=tolerance)
        stage = EQUILIBRIA
    for index in range(dataset.sizes["equilibrium"]):
        energy = f", energy {dataset.energy.values[index]:.12g}" if "energy" in dataset else ""
        log.info("equilibrium %d at %s: %s%s", index, dataset.position.values[index], dataset.type.values[index], energy)
    parameters = {
        "system_name": system_name, "system_spec": system_spec, "box": box,
        "seeds_per_axis": seeds_per_axis, "tolerance": tolerance,
    }
    title = f"Equilibria and linear analysis of {system_name}"
    path = write_stage_file(dataset, output, stage=stage, title=title, parameters=parameters)
    log.info("wrote %s", path)
    return path

