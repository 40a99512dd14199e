"""Poincaré surfaces of section: many trajectories on one energy surface, their crossings of a section.

Initial conditions are the allowed points of a grid on an isoenergetic section
(:class:`ldpipe.core.sections.Section`: two axes, fixed coordinates, one momentum
solved from the energy). Each is integrated by :mod:`ldpipe.core.trajectories` (the engine's
DOP853 step) to the final time; its crossings of the surface (a phase coordinate
= value, crossed in the given direction) are located on the step's dense output
to machine precision. A trajectory that reaches the escape radius ends there and
is flagged escaped.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from ..trajectories import ESCAPED, STATUS_MEANINGS, STATUS_VALUES, FlowSettings, integrate
from ..sections import Section, section_states
from ...systems import System


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
