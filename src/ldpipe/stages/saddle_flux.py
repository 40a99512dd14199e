"""Saddle-flux stage: the reactive flux through the dividing surface of a saddle, 2 or 3 DoF.

A study is declared under ``saddle_flux:`` in the configuration: a system, its saddle
(``saddle_near``, default the lowest) and energies. At each energy it writes

* ``flux_monte_carlo`` ± ``flux_monte_carlo_stderr``: the reactive flux through the surface through
  the saddle normal to its unstable direction (a line in 2 DoF, :class:`ldpipe.core.transport.DividingLine`;
  a plane in 3 DoF, :class:`ldpipe.core.transport.DividingPlane`) by
  :func:`ldpipe.core.transport.reactive_flux_monte_carlo`, with the samples classified
  (``monte_carlo_reactive``, ``_antireactive``, ``_nonreactive``, ``_undecided``);
* ``flux_dividing_surface``: the surface's one-way flux (recrossings counted every time; quadrature),
  an upper bound of the reactive flux;
* the surface's normal points away from the minimum nearest the saddle (reactive: from that well to
  the products); a system without a minimum is warned about, and the eigenvector's sign kept;
* ``flux_harmonic``: the quadratic saddle's flux (2π)^{n−1} ΔE^{n−1} / ((n−1)! ∏ ω_i)
  (:func:`ldpipe.core.transport.harmonic_flux`), ω_i the centre frequencies from the equilibria file,
  which the flux approaches as ΔE → 0.

Unlike the ``transport`` stage it needs no periodic orbit, so it runs where a family has none (3 DoF).
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import xarray as xr

from ..io.atomic import check_writable
from ..io.contracts import EQUILIBRIA, SADDLE_FLUX
from ..io.datafile import open_stage_file, write_stage_file
from ..core.equilibria.potential import select_saddle, well_and_frequencies
from ..errors import ConfigError
from ..core.trajectories import FlowSettings
from ..logs import get_logger
from ..systems import make_system
from ..core.transport import DividingLine, DividingPlane, harmonic_flux, reactive_flux_monte_carlo
from ..core.orbits.family import target_energies

log = get_logger(__name__)

SURFACES = {2: DividingLine, 3: DividingPlane}
COUNTS = ("samples", "reactive", "antireactive", "nonreactive", "undecided")


def run_saddle_flux(*, output: str | Path, equilibria: str | Path, threads: int | None = None,
                    **parameters) -> Path:
    """Monte Carlo reactive flux, one-way flux and harmonic estimate at each energy; writes ``output``."""
    check_writable(output)  # before any work: never lose a run to a bad path
    key = f"saddle_flux.{parameters['name']}"
    system = make_system(parameters["system_name"], parameters["system_spec"])
    if system.n_dof not in SURFACES:
        raise ConfigError(f"config key '{key}.system': the saddle-flux stage is for 2 and 3 DoF systems; "
                          f"{system.name} has {system.n_dof}")
    eq = open_stage_file(equilibria, stage=EQUILIBRIA)
    saddle, critical = select_saddle(eq, parameters.get("saddle_near"))
    # Without a minimum (e.g. a bare quadratic saddle) "reactive" keeps the eigenvector's own sign.
    well, frequencies = well_and_frequencies(eq, saddle, require_well=False)
    if well is None:
        log.warning("%s: the equilibria file has no minimum; the surface's normal keeps the unstable "
                    "eigenvector's sign (reactive = crossing along it)", key)
        well = saddle
    energies = target_energies(parameters["energies"], critical, key)
    if np.any(energies <= critical):
        raise ConfigError(f"config key '{key}.energies': the flux needs energies above the saddle's "
                          f"{critical:.12g}; got {energies.tolist()}")
    mc = parameters["monte_carlo"]
    flow = FlowSettings(**mc["integrator"])
    count = len(energies)
    values = {name: np.empty(count) for name in ("flux_monte_carlo", "flux_monte_carlo_stderr",
                                                 "flux_dividing_surface", "monte_carlo_seconds")}
    counts = {name: np.empty(count, dtype=np.int64) for name in COUNTS}
    for i, energy in enumerate(energies):
        surface = SURFACES[system.n_dof].at_saddle(system, saddle, float(energy), well=well)
        start = time.perf_counter()
        result = reactive_flux_monte_carlo(
            surface, commit=mc["commit"], duration=mc["duration"], target_stderr=mc["target_stderr"],
            batch=mc["batch"], max_samples=mc["max_samples"], sample_step=mc["sample_step"], flow=flow,
            seed=mc["seed"] + i, threads=threads)
        values["monte_carlo_seconds"][i] = time.perf_counter() - start
        values["flux_monte_carlo"][i], values["flux_monte_carlo_stderr"][i] = result.flux, result.stderr
        values["flux_dividing_surface"][i] = result.surface_flux
        for name in COUNTS:
            counts[name][i] = getattr(result, name)
        if result.undecided:
            log.warning("E = %.10g: %d of %d samples did not commit within %g (weight 0; raise %s.monte_carlo."
                        "duration)", energy, result.undecided, result.samples, mc["duration"], key)
        log.info("E = %.10g (dE = %.6g): reactive flux %.8g +- %.2g, one-way %.8g, harmonic %.8g; %d samples, "
                 "%d not reactive (%.1f s)", energy, energy - critical, result.flux, result.stderr,
                 result.surface_flux, harmonic_flux(energy - critical, frequencies), result.samples,
                 result.samples - result.reactive, values["monte_carlo_seconds"][i])

    energy_dim = ("energy",)
    excess = energies - critical
    data = xr.Dataset(
        {
            "total_energy": (energy_dim, energies, {"long_name": "energy E"}),
            "excess_energy": (energy_dim, excess, {"long_name": "excess energy E - E_c above the saddle"}),
            "flux_monte_carlo": (energy_dim, values["flux_monte_carlo"],
                                 {"long_name": "reactive flux through the dividing surface, Monte Carlo"}),
            "flux_monte_carlo_stderr": (energy_dim, values["flux_monte_carlo_stderr"],
                                        {"long_name": "standard error of flux_monte_carlo"}),
            "flux_dividing_surface": (energy_dim, values["flux_dividing_surface"],
                                      {"long_name": "one-way flux through the dividing surface, recrossings "
                                                    "counted (volume of its allowed region, quadrature)"}),
            "flux_harmonic": (energy_dim, harmonic_flux(excess, frequencies),
                              {"long_name": "flux over the quadratic saddle with the same centre frequencies"}),
            "monte_carlo_seconds": (energy_dim, values["monte_carlo_seconds"],
                                    {"long_name": "wall time of the Monte Carlo estimate", "units": "s"}),
            **{f"monte_carlo_{name}": (energy_dim, value, {"long_name": f"{name} samples" if name != "samples"
                                                           else "samples drawn"})
               for name, value in counts.items()},
        },
        attrs={"system": system.name, "n_dof": system.n_dof, "saddle_position": saddle, "well_position": well,
               "critical_energy": critical, "centre_frequencies": frequencies},
    )
    title = f"Reactive flux through the dividing surface of the saddle of {system.name} at {saddle.tolist()}"
    path = write_stage_file(data, output, stage=SADDLE_FLUX, title=title, parameters=parameters)
    log.info("wrote %s", path)
    return path
