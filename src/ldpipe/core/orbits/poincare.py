"""Poincaré surfaces of section: many trajectories on one energy surface, their crossings of a section.

Initial conditions are the allowed points of a grid on an isoenergetic section
(:class:`ldpipe.core.sections.Section`: two axes, fixed coordinates, one momentum
solved from the energy). Each is integrated by :mod:`ldpipe.core.trajectories` (the engine's
DOP853 step) to the final time; its crossings of the surface (a phase coordinate
= value, crossed in the given direction) are located on the step's dense output
to machine precision. A trajectory that reaches the escape radius ends there and
is flagged escaped.

A section is declared under ``poincare_sections:`` in the configuration: the system, the energy
(total, or excess over the selected saddle's E_c), the grid of initial conditions (an
isoenergetic section, as for LD maps), the surface crossed (a phase coordinate, its value and the
crossing direction) and the final time. :func:`poincare_dataset` is its stage file;
:func:`section_crossings` the crossings of any grid.
"""

from __future__ import annotations

import os

import numpy as np
import xarray as xr

from ..trajectories import ESCAPED, STATUS_MEANINGS, STATUS_VALUES, FlowSettings, integrate
from ..equilibria.potential import select_saddle
from ..sections import Section, section_states
from ...errors import ConfigError
from ...io.contracts import EQUILIBRIA, POINCARE
from ...io.datafile import open_stage_file, stage_dataset
from ...logs import get_logger
from ...systems import System, make_system

log = get_logger(__name__)


def section_crossings(
    system: System,
    initial_conditions: Section,
    energy: float | None,
    *,
    section: tuple[str, float, int],
    time: float,
    max_crossings: int,
    flow: FlowSettings,
    threads: int | None = None,
    t0: float = 0.0,
) -> xr.Dataset:
    """Crossings of ``section`` by trajectories started on ``initial_conditions`` at ``energy``
    (a vector field: ``energy`` None, every grid point, from the start time ``t0``; its crossing
    times count from t0)."""
    states, allowed, _ = section_states(system, initial_conditions, energy)
    if len(states) == 0:
        raise ValueError(f"no initial condition of the grid is on the energy surface E = {energy!r}")
    result = integrate(system, states, time, flow, section=section, max_crossings=max_crossings, threads=threads, t0=t0)
    phase = list(system.phase_coordinates)
    status = result.status.astype(np.int8)
    valid = np.arange(max_crossings)[None, :] < result.crossing_count[:, None]
    data = xr.Dataset(
        {
            "initial_state": (("trajectory", "phase"), states, {"long_name": "initial condition (on the energy surface)"}),
            "crossing_state": (("trajectory", "crossing", "phase"), result.crossings,
                               {"long_name": "state at each crossing of the section; 0 beyond crossing_count"}),
            "crossing_time": (("trajectory", "crossing"), result.crossing_times),
            "crossing_valid": (("trajectory", "crossing"), valid),
            "crossing_count": ("trajectory", result.crossing_count, {"long_name": "crossings recorded"}),
            "status": ("trajectory", status,
                       {"flag_values": STATUS_VALUES, "flag_meanings": STATUS_MEANINGS}),
            "escaped": ("trajectory", status == ESCAPED, {"long_name": "left the escape radius before the final time"}),
            "end_time": ("trajectory", result.final_time, {"long_name": "time the integration ended"}),
            "steps": ("trajectory", result.steps, {"long_name": "DOP853 steps taken (accepted and rejected)"}),
        },
        coords={"phase": phase, "trajectory": np.arange(len(states)), "crossing": np.arange(max_crossings)},
    )
    coordinate, value, direction = section
    data.attrs.update({"energy": energy} if energy is not None else {"t0": float(t0)})
    data.attrs.update({
        "final_time": time, "section_coordinate": coordinate, "section_value": float(value),
        "section_direction": int(direction), "rtol": flow.rtol, "atol": flow.atol, "escape_radius": flow.escape_radius,
        "initial_condition_axes": list(initial_conditions.axes),
    })
    return data


def poincare_dataset(parameters: dict, equilibria: str | os.PathLike | xr.Dataset | None, *,
                     threads: int | None = None) -> xr.Dataset:
    """A Poincaré section as the Poincaré stage's file holds it: ``parameters`` are the stage's
    (:func:`ldpipe.config.parameters.parameters_from_config`), ``equilibria`` the system's
    equilibria file or Dataset, where an excess energy's saddle is selected (None for a vector
    field: no energy, its trajectories start at ``t0``); ``threads`` of the engine (default every core)."""
    key = f"poincare_sections.{parameters['name']}"
    system = make_system(parameters["system_name"], parameters["system_spec"])
    t0 = float(parameters.get("t0", 0.0))
    if not system.hamiltonian:
        energy = critical_energy = None
    elif equilibria is None:
        raise ConfigError(f"config key '{key}.system': the Hamiltonian system {system.name!r} needs its equilibria file")
    else:
        energy, critical_energy = _energy(parameters, open_stage_file(equilibria, stage=EQUILIBRIA))
    grid = Section.from_spec(parameters["initial_conditions"], system, key=f"{key}.initial_conditions")
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
        time=parameters["time"], max_crossings=parameters["max_crossings"], flow=flow, threads=threads, t0=t0,
    )
    dataset.attrs["system"] = system.name
    dataset.attrs.update(system.kinetic_attributes())
    if critical_energy is not None:
        dataset.attrs.update({"critical_energy": critical_energy, "excess_energy": energy - critical_energy})
    log.info("%d trajectories, %d escaped, %d crossings", dataset.sizes["trajectory"], int(dataset.escaped.sum()),
             int(dataset.crossing_count.sum()))
    title = f"Poincaré section {parameters['name']} of {system.name}"
    return stage_dataset(dataset, stage=POINCARE, title=title, parameters=parameters)


def _energy(parameters: dict, equilibria: xr.Dataset) -> tuple[float, float | None]:
    """The section's total energy and, where the system has an index-1 saddle, its critical energy."""
    energy_spec = parameters["energy"]
    if "total" in energy_spec:
        energy, critical_energy = energy_spec["total"], None
        if equilibria.sizes.get("saddle", 0):
            critical_energy = select_saddle(equilibria, parameters.get("saddle_near"))[1]
    else:
        critical_energy = select_saddle(equilibria, parameters.get("saddle_near"))[1]
        energy = critical_energy + energy_spec["excess"]
    return energy, critical_energy
