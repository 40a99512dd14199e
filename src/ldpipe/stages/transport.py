"""Transport stage: the flux over a saddle at several energies, three independent ways (2 DoF).

A study is declared under ``transport:`` in the configuration: a periodic-orbit family of a
2 DoF system (``orbits``) and which of its target energies (``energies``). For each energy
it writes

* ``flux_action``: ∮ p·dq of the family's orbit (:func:`ldpipe.core.transport.orbit_action`);
* ``flux_island_area``: ∮ p_x dx of the first cut of the inward stable and unstable tubes with
  the section (:func:`ldpipe.core.transport.closed_curve_area`), from cuts this stage computes with
  ``island.points`` trajectories (the manifold stage's sets have other energies and are not
  needed); ``flux_island_area_half`` is the same from every other point, a measure of the
  quadrature's convergence, and ``flux_island_area_polygon`` the shoelace area for comparison;
* ``flux_monte_carlo`` and ``flux_monte_carlo_stderr``: the reactive flux through the straight
  dividing line at the saddle (:func:`ldpipe.core.transport.reactive_flux_monte_carlo`), with
  ``flux_dividing_line``, the line's one-way flux that counts recrossings;
* ``flux_harmonic``: the saddle's linear estimate 2π ΔE / ω, ω its centre frequency (from the
  equilibria file);
* ``well_volume``: the energy-shell volume of the well (2π times the area of the allowed well cut off
  by the dividing lines of every index-1 saddle, :func:`ldpipe.core.transport.well_shell_volume`),
  ``flux_other_saddles`` (± ``flux_other_saddles_stderr``): the Monte Carlo reactive flux over the
  other saddles, and ``rate_tst`` = (``flux_action`` + ``flux_other_saddles``) / ``well_volume``, the
  microcanonical transition-state rate;
* survival of a microcanonical ensemble of the well integrated until it crosses a dividing line:
  ``survival_initial_slope`` (± ``_stderr``; the fraction left by ``survival.t0`` over t0, which
  must equal ``rate_tst``), ``survival_decay_rate`` (the long-time exponential decay, fitted on
  ``survival.decay_window`` in units of 1/rate_tst) and the curve ``survival_probability`` at
  ``survival_time``;
* gap times of a flux-weighted ensemble entering the well through the dividing lines, followed to
  the survival curve's horizon T (:func:`ldpipe.core.transport.gap_times`): their survival
  ``gap_time_survival`` at ``survival_time``, and the exact identity Φ E[min(τ, T)] = V (1 − P(T))
  as its two sides, ``left_volume_gap_times`` and ``left_volume_survival`` (± ``_stderr``), with
  ``flux_dividing_lines`` = Φ, the lines' one-way flux; a violation beyond 4 standard errors is
  logged as a warning (``gap_identity_deviation`` records it in standard errors).

:func:`ldpipe.core.transport.transport_at_energy` computes them; this module reads the family and
equilibria files and writes the study's file.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from ..io.atomic import check_writable
from ..io.contracts import EQUILIBRIA, TRANSPORT, UPO
from ..io.datafile import input_name, open_stage_file, stage_parameters, write_stage_file
from ..core.equilibria.potential import well_and_frequencies
from ..errors import ConfigError, StageFileError
from ..logs import get_logger
from ..core.orbits.manifolds import MANIFOLDS
from ..systems import make_system, require_hamiltonian
from ..core.transport import LyapunovOrbit, harmonic_flux, transport_at_energy
from ..core.orbits.family import select_orbit

log = get_logger(__name__)


#: The file's variables after the dimension ``energy``: their other dimensions and attributes.
VARIABLES = {
    "excess_energy": ((), {"long_name": "excess energy E - E_c of the orbit"}),
    "total_energy": ((), {"long_name": "energy E"}),
    "period": ((), {"long_name": "period of the Lyapunov orbit"}),
    "flux_action": ((), {"long_name": "action of the Lyapunov orbit, closed integral of p.dq (spectral rule)"}),
    "flux_island_area": (("manifold",), {"long_name": "area closed integral of p dq of the first cut of the inward "
                                                      "tube with the section (spectral rule)"}),
    "flux_island_area_half": (("manifold",), {"long_name": "the same from every other point"}),
    "flux_island_area_polygon": (("manifold",), {"long_name": "the same by the shoelace (polygon) rule"}),
    "flux_monte_carlo": ((), {"long_name": "reactive flux through the dividing line, Monte Carlo"}),
    "flux_monte_carlo_stderr": ((), {"long_name": "standard error of flux_monte_carlo"}),
    "flux_dividing_line": ((), {"long_name": "one-way flux through the dividing line, recrossings counted "
                                             "(area of its allowed region)"}),
    "flux_harmonic": ((), {"long_name": "harmonic estimate 2 pi dE / omega of the saddle's linearization"}),
    "flux_other_saddles": ((), {"long_name": "reactive flux over the other index-1 saddles, Monte Carlo"}),
    "flux_other_saddles_stderr": ((), {"long_name": "standard error of flux_other_saddles"}),
    "well_volume": ((), {"long_name": "energy-shell volume of the well, integral of delta(E - H) over it"}),
    "rate_tst": ((), {"long_name": "microcanonical transition-state rate: total flux out / well_volume"}),
    "survival_initial_slope": ((), {"long_name": "fraction of the well ensemble left by t0, over t0"}),
    "survival_initial_slope_stderr": ((), {"long_name": "standard error of survival_initial_slope"}),
    "survival_decay_rate": ((), {"long_name": "long-time decay rate of the survival probability"}),
    "survival_time": (("survival_point",), {"long_name": "time"}),
    "survival_probability": (("survival_point",), {"long_name": "fraction of the well ensemble not yet left"}),
    "gap_time_survival": (("survival_point",), {"long_name": "fraction of the flux-weighted entering ensemble "
                                                             "still in the well (gap time beyond t)"}),
    "flux_dividing_lines": ((), {"long_name": "one-way flux through all dividing lines of the well"}),
    "left_volume_gap_times": ((), {"long_name": "flux_dividing_lines x mean of min(gap time, T), T the last "
                                                "survival_time"}),
    "left_volume_gap_times_stderr": ((), {"long_name": "standard error of left_volume_gap_times"}),
    "left_volume_survival": ((), {"long_name": "well_volume x fraction of the well ensemble left by T: equals "
                                               "left_volume_gap_times exactly in expectation"}),
    "left_volume_survival_stderr": ((), {"long_name": "standard error of left_volume_survival (binomial)"}),
    "gap_identity_deviation": ((), {"long_name": "(left_volume_gap_times - left_volume_survival) in combined "
                                                 "standard errors"}),
    "gap_times_seconds": ((), {"long_name": "wall time of the gap-time ensemble", "units": "s"}),
    "survival_seconds": ((), {"long_name": "wall time of the survival ensembles", "units": "s"}),
    "monte_carlo_seconds": ((), {"long_name": "wall time of the Monte Carlo estimate", "units": "s"}),
    **{f"monte_carlo_{name}": ((), {}) for name in ("samples", "reactive", "antireactive", "nonreactive", "undecided")},
    "island": (("manifold", "point", "phase"), {"long_name": "first cut of the inward tube with the section, "
                                                             "ordered by orbit phase"}),
}


def _orbit(orbits: xr.Dataset, index: int) -> LyapunovOrbit:
    """Orbit ``index`` of a family file."""
    return LyapunovOrbit(
        energy=float(orbits.energy.values[index]), excess_energy=float(orbits.excess_energy.values[index]),
        initial_state=orbits.initial_state.values[index], period=float(orbits.period.values[index]),
        samples=orbits.trajectory.values[index], rtol=float(orbits.attrs["rtol"]), atol=float(orbits.attrs["atol"]),
    )


def run_transport(*, output: str | Path, upo: str | Path, equilibria: str | Path, threads: int | None = None,
                  **parameters) -> Path:
    """Flux by action, island area and Monte Carlo at each energy of the study; writes ``output``."""
    check_writable(output)  # before any work: never lose a run to a bad path
    key = f"transport.{parameters['name']}"
    orbits = open_stage_file(upo, stage=UPO)
    if stage_parameters(orbits)["system_name"] != parameters["system_name"]:
        raise StageFileError(f"{input_name(upo)}: orbits of system {orbits.attrs['system']!r}, "
                             f"expected {parameters['system_name']!r}")
    eq = open_stage_file(equilibria, stage=EQUILIBRIA)
    system = make_system(parameters["system_name"], parameters["system_spec"])
    require_hamiltonian(system, "the transport study", key=f"{key}.orbits")
    if system.n_dof != 2:
        raise ConfigError(f"config key '{key}.orbits': the transport stage's flux study is for 2 DoF systems; "
                          f"{system.name} has {system.n_dof}")
    saddle = np.asarray(orbits.attrs["saddle_position"], dtype=float)
    well, frequencies = well_and_frequencies(eq, saddle)
    saddles = eq.position.values[eq.saddle_equilibrium.values]
    others = [(q, float(ec)) for q, ec in zip(saddles, eq.critical_energy.values)
              if np.linalg.norm(q - saddle) > 1e-8 * (1 + np.linalg.norm(saddle))]
    kind = "excess" if "excess" in parameters["energies"] else "total"
    indices = [select_orbit(orbits, {kind: value}, key, upo) for value in parameters["energies"][kind]]
    results = [
        transport_at_energy(
            system, _orbit(orbits, index), saddle=saddle, well=well, other_saddles=others,
            island=parameters["island"], monte_carlo=parameters["monte_carlo"],
            survival_settings=parameters["survival"], gap_time_settings=parameters["gap_times"],
            seed_offset=i, threads=threads, key=key,
        )
        for i, index in enumerate(indices)
    ]
    excess_energy = orbits.excess_energy.values[indices]
    of_the_orbits = {
        "excess_energy": excess_energy, "total_energy": orbits.energy.values[indices],
        "period": orbits.period.values[indices], "flux_harmonic": harmonic_flux(excess_energy, frequencies),
    }

    def values(name: str) -> np.ndarray:
        return of_the_orbits[name] if name in of_the_orbits else np.array([getattr(r, name) for r in results])

    section, points = parameters["island"]["section"], parameters["island"]["points"]
    data = xr.Dataset(
        {name: (("energy", *dims), values(name), attrs) for name, (dims, attrs) in VARIABLES.items()},
        coords={"manifold": list(MANIFOLDS), "phase": list(system.phase_coordinates), "point": np.arange(points)},
        attrs={
            "family": orbits.attrs["family"], "system": system.name, "saddle_position": saddle,
            "well_position": well, "centre_frequencies": frequencies,
            "critical_energy": float(orbits.attrs["critical_energy"]),
            "section_coordinate": section["coordinate"], "section_value": float(section["value"]),
            "section_direction": int(section["direction"]), **system.kinetic_attributes(),
        },
    )
    title = f"Flux over the saddle of {orbits.attrs['family']}: action, reactive-island area, Monte Carlo"
    path = write_stage_file(data, output, stage=TRANSPORT, title=title, parameters=parameters)
    log.info("wrote %s", path)
    return path
