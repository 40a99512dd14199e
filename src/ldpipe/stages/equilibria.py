"""Equilibrium and linear-analysis stage: one netCDF file per system."""

from __future__ import annotations

from pathlib import Path

from ..core.equilibria.study import equilibria_dataset
from ..io.datafile import write_product


def run_equilibria(
    *,
    system_name: str,
    system_spec: dict,
    box: dict[str, list[float]],
    output: str | Path,
    seeds_per_axis: int = 9,
    tolerance: float = 1e-10,
) -> Path:
    """Find every equilibrium of the system in ``box``, analyse it, and write ``output``
    (:func:`ldpipe.core.equilibria.study.equilibria_dataset`)."""
    parameters = {
        "system_name": system_name, "system_spec": system_spec, "box": box,
        "seeds_per_axis": seeds_per_axis, "tolerance": tolerance,
    }
    return write_product(output, lambda: equilibria_dataset(parameters))
