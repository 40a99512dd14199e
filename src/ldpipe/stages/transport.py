"""Transport stage: the flux over a saddle at several energies, three independent ways (2 DoF).

A study is declared under ``transport:`` in the configuration: a periodic-orbit family of a
2 DoF system (``orbits``) and which of its target energies (``energies``). For each energy
it writes

* ``flux_action``: ∮ p·dq of the family's orbit (:func:`ldpipe.transport.orbit_action`);
* ``flux_island_area``: ∮ p_x dx of the first cut of the inward stable and unstable tubes with
  the section (:func:`ldpipe.transport.closed_curve_area`), from cuts this stage computes with
  ``island.points`` trajectories (the manifold stage's sets have other energies and are not
  needed); ``flux_island_area_half`` is the same from every other point, a measure of the
  quadrature's convergence, and ``flux_island_area_polygon`` the shoelace area for comparison;
* ``flux_monte_carlo`` and ``flux_monte_carlo_stderr``: the reactive flux through the straight
  dividing line at the saddle (:func:`ldpipe.transport.reactive_flux_monte_carlo`), with
  ``flux_dividing_line``, the line's one-way flux that counts recrossings;
* ``flux_harmonic``: the saddle's linear estimate 2π ΔE / ω, ω its centre frequency (from the
  equilibria file);
* ``well_volume``: the energy-shell volume of the well (2π times the area of the allowed well cut off
  by the dividing lines of every index-1 saddle, :func:`ldpipe.transport.well_shell_volume`),
  ``flux_other_saddles`` (± ``flux_other_saddles_stderr``): the Monte Carlo reactive flux over the
  other saddles, and ``rate_tst`` = (``flux_action`` + ``flux_other_saddles``) / ``well_volume``, the
  microcanonical transition-state rate;
* survival of a microcanonical ensemble of the well integrated until it crosses a dividing line:
  ``survival_initial_slope`` (± ``_stderr``; the fraction left by ``survival.t0`` over t0, which
  must equal ``rate_tst``), ``survival_decay_rate`` (the long-time exponential decay, fitted on
  ``survival.decay_window`` in units of 1/rate_tst) and the curve ``survival_probability`` at
  ``survival_time``;
* gap times of a flux-weighted ensemble entering the well through the dividing lines, followed to
  the survival curve's horizon T (:func:`ldpipe.transport.gap_times`): their survival
  ``gap_time_survival`` at ``survival_time``, and the exact identity Φ E[min(τ, T)] = V (1 − P(T))
  as its two sides, ``left_volume_gap_times`` and ``left_volume_survival`` (± ``_stderr``), with
  ``flux_dividing_lines`` = Φ, the lines' one-way flux; a violation beyond 4 standard errors is
  logged as a warning (``gap_identity_deviation`` records it in standard errors).
"""

from __future__ import annotations

import copy
import math
import time
from pathlib import Path

import numpy as np
import xarray as xr

from ..io.contracts import EQUILIBRIA, TRANSPORT, UPO
from ..io.datafile import open_stage_file, stage_parameters, write_stage_file
from ..equilibria import well_and_frequencies
from ..errors import ConfigError, StageFileError
from ..flow import FlowSettings
from ..logs import get_logger
from ..manifolds import MANIFOLDS, ManifoldSettings, manifold_dataset
from ..systems import make_system, require_hamiltonian, system_spec
from ..transport import (
    DividingLine, closed_curve_area, decay_rate, exit_times, gap_times, harmonic_flux, initial_slope, orbit_action,
    reactive_flux_monte_carlo, sample_well, survival, well_shell_volume,
)
from .manifolds import select_orbit

log = get_logger(__name__)


def transport_parameters(config: dict, name: str) -> dict:
    """The keyword arguments of :func:`run_transport` for one study of a validated config (besides paths)."""
    spec = copy.deepcopy(config["transport"][name])
    family = config["periodic_orbits"][spec["orbits"]]
    return {"name": name, "system_name": family["system"], "system_spec": system_spec(config, family["system"]),
            "saddle_near": family.get("saddle_near"), **spec}


def run_transport(*, output: str | Path, upo: str | Path, equilibria: str | Path, threads: int | None = None,
                  **parameters) -> Path:
    """Flux by action, island area and Monte Carlo at each energy of the study; writes ``output``."""
    key = f"transport.{parameters['name']}"
    orbits = open_stage_file(upo, stage=UPO)
    if stage_parameters(orbits)["system_name"] != parameters["system_name"]:
        raise StageFileError(f"{upo}: orbits of system {orbits.attrs['system']!r}, "
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
    values = parameters["energies"][kind]
    indices = [select_orbit(orbits, {kind: value}, key, upo) for value in values]

    island, mc = parameters["island"], parameters["monte_carlo"]
    section = island["section"]
    island_settings = ManifoldSettings(
        points=island["points"], displacement=island["displacement"], time=island["time"], samples=2,
        section=(section["coordinate"], section["value"], section["direction"]), crossings=1,
        orbit_rtol=float(orbits.attrs["rtol"]), orbit_atol=float(orbits.attrs["atol"]),
    )
    island_flow = FlowSettings(**island["integrator"])
    mc_flow = FlowSettings(**mc["integrator"])
    position_axis = 1 - system.phase_coordinates.index(section["coordinate"])  # the other coordinate (2 DoF)
    axes = (position_axis, position_axis + 2)

    count, points = len(indices), island["points"]
    fields = {name: np.empty(count) for name in (
        "flux_action", "flux_monte_carlo", "flux_monte_carlo_stderr", "flux_dividing_line", "monte_carlo_seconds",
        "flux_other_saddles", "flux_other_saddles_stderr", "well_volume", "survival_initial_slope",
        "survival_initial_slope_stderr", "survival_decay_rate", "survival_seconds", "flux_dividing_lines",
        "left_volume_gap_times", "left_volume_gap_times_stderr", "left_volume_survival", "left_volume_survival_stderr",
        "gap_identity_deviation", "gap_times_seconds")}
    gp = parameters["gap_times"]
    sv = parameters["survival"]
    survival_time = np.empty((count, sv["points"]))
    survival_probability = np.empty((count, sv["points"]))
    gap_time_survival = np.empty((count, sv["points"]))
    counts = {name: np.empty(count, dtype=np.int64) for name in (
        "monte_carlo_samples", "monte_carlo_reactive", "monte_carlo_antireactive", "monte_carlo_nonreactive",
        "monte_carlo_undecided")}
    area, area_half, area_polygon = (np.empty((count, 2)) for _ in range(3))
    curves = np.empty((count, 2, points, 2 * system.n_dof))
    for i, index in enumerate(indices):
        energy = float(orbits.energy.values[index])
        excess = float(orbits.excess_energy.values[index])
        initial_state, period = orbits.initial_state.values[index], float(orbits.period.values[index])
        fields["flux_action"][i] = orbit_action(orbits.trajectory.values[index], system.n_dof)

        cut = manifold_dataset(system, initial_state, period, island_settings, island_flow, threads=threads)
        for k, manifold in enumerate(MANIFOLDS):
            valid = cut.section_valid.values[k, 0, 0]
            if not valid.all():
                raise ConfigError(
                    f"config key '{key}.island.time': at dE = {excess:.6g}, {int((~valid).sum())} of {points} "
                    f"{manifold} inward trajectories did not cut the section within {island['time']}; raise it")
            state = cut.section_state.values[k, 0, 0]
            curves[i, k] = state
            x, p = state[:, axes[0]], state[:, axes[1]]
            area[i, k] = abs(closed_curve_area(x, p))
            area_half[i, k] = abs(closed_curve_area(x[::2], p[::2]))
            area_polygon[i, k] = abs(closed_curve_area(x, p, method="shoelace"))

        line = DividingLine.at_saddle(system, saddle, energy, well=well)
        reach = float(np.max(np.abs((orbits.trajectory.values[index][:, :2] - saddle) @ line.normal)))
        if mc["commit"] <= 2 * reach:
            raise ConfigError(f"config key '{key}.monte_carlo.commit': {mc['commit']} is not beyond the orbit, which "
                              f"reaches {reach:.3g} from the dividing line at dE = {excess:.6g}; raise it")
        start = time.perf_counter()
        result = reactive_flux_monte_carlo(
            line, commit=mc["commit"], duration=mc["duration"], target_stderr=mc["target_stderr"],
            batch=mc["batch"], max_samples=mc["max_samples"], sample_step=mc["sample_step"], flow=mc_flow,
            seed=mc["seed"] + i, threads=threads,
        )
        fields["monte_carlo_seconds"][i] = time.perf_counter() - start
        fields["flux_monte_carlo"][i], fields["flux_monte_carlo_stderr"][i] = result.flux, result.stderr
        fields["flux_dividing_line"][i] = result.surface_flux
        for name in ("samples", "reactive", "antireactive", "nonreactive", "undecided"):
            counts[f"monte_carlo_{name}"][i] = getattr(result, name)
        # Saddles below the energy are open; the well is closed at the others (no line needed).
        other_lines = [DividingLine.at_saddle(system, q, energy, well=well) for q, ec in others if ec < energy]
        other = [reactive_flux_monte_carlo(
            other_line, commit=mc["commit"], duration=mc["duration"], target_stderr=mc["target_stderr"],
            batch=mc["batch"], max_samples=mc["max_samples"], sample_step=mc["sample_step"], flow=mc_flow,
            seed=mc["seed"] + 1000 * (k + 1) + i, threads=threads) for k, other_line in enumerate(other_lines)]
        fields["flux_other_saddles"][i] = sum(r.flux for r in other)
        fields["flux_other_saddles_stderr"][i] = math.sqrt(sum(r.stderr**2 for r in other))
        fields["well_volume"][i] = well_shell_volume(system, well, energy, [line, *other_lines])
        log.info("dE = %.6g: well volume %.10g, flux over the other saddles %.8g, TST rate %.6g", excess,
                 fields["well_volume"][i], fields["flux_other_saddles"][i],
                 (fields["flux_action"][i] + fields["flux_other_saddles"][i]) / fields["well_volume"][i])
        rate = (fields["flux_action"][i] + fields["flux_other_saddles"][i]) / fields["well_volume"][i]
        all_lines = [line, *other_lines]
        rng = np.random.default_rng(sv["seed"] + i)
        surv_flow = FlowSettings(**sv["integrator"])
        start = time.perf_counter()
        early = exit_times(system, sample_well(system, well, energy, all_lines, sv["initial_count"], rng), all_lines,
                           sv["t0"], sample_step=sv["sample_step"], flow=surv_flow, threads=threads)
        slope = initial_slope(early, sv["t0"])
        horizon = sv["duration"] / rate
        late = exit_times(system, sample_well(system, well, energy, all_lines, sv["count"], rng), all_lines, horizon,
                          sample_step=sv["sample_step"], segment=max(20.0, horizon / 20), flow=surv_flow,
                          threads=threads)
        window = np.asarray(sv["decay_window"]) / rate
        survival_time[i] = np.linspace(0.0, horizon, survival_time.shape[1])
        survival_probability[i] = survival(late, survival_time[i])
        fields["survival_initial_slope"][i], fields["survival_initial_slope_stderr"][i] = slope.rate, slope.stderr
        fields["survival_decay_rate"][i] = decay_rate(late, window[0], window[1])
        fields["survival_seconds"][i] = time.perf_counter() - start
        start = time.perf_counter()
        gaps = gap_times(system, all_lines, gp["count"], horizon, np.random.default_rng(gp["seed"] + i),
                         sample_step=sv["sample_step"], segment=max(20.0, horizon / 20), flow=surv_flow, threads=threads)
        fields["gap_times_seconds"][i] = time.perf_counter() - start
        gap_time_survival[i] = gaps.survival(survival_time[i])
        fields["flux_dividing_lines"][i] = gaps.flux
        gap_side = gaps.reactive_volume(horizon)
        left = float(np.mean(late <= horizon))
        survival_side = (fields["well_volume"][i] * left,
                         fields["well_volume"][i] * math.sqrt(max(left * (1 - left), 1.0 / len(late)) / len(late)))
        deviation = (gap_side[0] - survival_side[0]) / math.hypot(gap_side[1], survival_side[1])
        (fields["left_volume_gap_times"][i], fields["left_volume_gap_times_stderr"][i]) = gap_side
        (fields["left_volume_survival"][i], fields["left_volume_survival_stderr"][i]) = survival_side
        fields["gap_identity_deviation"][i] = deviation
        log.info("dE = %.6g: volume left by T = %.4g: %.6g +- %.2g from gap times, %.6g +- %.2g from survival "
                 "(%.2f sigma); mean gap time bound %.4g, V/Phi %.4g", excess, horizon, gap_side[0], gap_side[1],
                 survival_side[0], survival_side[1], deviation, gap_side[0] / gaps.flux,
                 fields["well_volume"][i] / gaps.flux)
        if abs(deviation) > 4:
            log.warning("dE = %.6g: gap times and survival disagree by %.1f standard errors on the volume left by "
                        "T (an exact identity): check survival.sample_step and the integrator tolerances",
                        excess, deviation)
        log.info("dE = %.6g: TST rate %.6g, initial slope %.6g +- %.2g, decay rate %.6g (%.1f s)", excess, rate,
                 slope.rate, slope.stderr, fields["survival_decay_rate"][i], fields["survival_seconds"][i])
        log.info("dE = %.6g: action %.12g, island %.12g / %.12g, Monte Carlo %.8g +- %.2g (%d samples, %.1f s), "
                 "line %.8g", excess, fields["flux_action"][i], area[i, 0], area[i, 1], result.flux, result.stderr,
                 result.samples, fields["monte_carlo_seconds"][i], result.surface_flux)

    excess_energy = orbits.excess_energy.values[indices]
    energy_dim, pair = ("energy",), ("energy", "manifold")
    data = xr.Dataset(
        {
            "excess_energy": (energy_dim, excess_energy, {"long_name": "excess energy E - E_c of the orbit"}),
            "total_energy": (energy_dim, orbits.energy.values[indices], {"long_name": "energy E"}),
            "period": (energy_dim, orbits.period.values[indices], {"long_name": "period of the Lyapunov orbit"}),
            "flux_action": (energy_dim, fields["flux_action"],
                            {"long_name": "action of the Lyapunov orbit, closed integral of p.dq (spectral rule)"}),
            "flux_island_area": (pair, area, {"long_name": "area closed integral of p dq of the first cut of the "
                                              "inward tube with the section (spectral rule)"}),
            "flux_island_area_half": (pair, area_half, {"long_name": "the same from every other point"}),
            "flux_island_area_polygon": (pair, area_polygon, {"long_name": "the same by the shoelace (polygon) rule"}),
            "flux_monte_carlo": (energy_dim, fields["flux_monte_carlo"],
                                 {"long_name": "reactive flux through the dividing line, Monte Carlo"}),
            "flux_monte_carlo_stderr": (energy_dim, fields["flux_monte_carlo_stderr"],
                                        {"long_name": "standard error of flux_monte_carlo"}),
            "flux_dividing_line": (energy_dim, fields["flux_dividing_line"],
                                   {"long_name": "one-way flux through the dividing line, recrossings counted "
                                                 "(area of its allowed region)"}),
            "flux_harmonic": (energy_dim, harmonic_flux(excess_energy, frequencies),
                              {"long_name": "harmonic estimate 2 pi dE / omega of the saddle's linearization"}),
            "flux_other_saddles": (energy_dim, fields["flux_other_saddles"],
                                   {"long_name": "reactive flux over the other index-1 saddles, Monte Carlo"}),
            "flux_other_saddles_stderr": (energy_dim, fields["flux_other_saddles_stderr"],
                                          {"long_name": "standard error of flux_other_saddles"}),
            "well_volume": (energy_dim, fields["well_volume"],
                            {"long_name": "energy-shell volume of the well, integral of delta(E - H) over it"}),
            "rate_tst": (energy_dim, (fields["flux_action"] + fields["flux_other_saddles"]) / fields["well_volume"],
                         {"long_name": "microcanonical transition-state rate: total flux out / well_volume"}),
            "survival_initial_slope": (energy_dim, fields["survival_initial_slope"],
                                       {"long_name": "fraction of the well ensemble left by t0, over t0"}),
            "survival_initial_slope_stderr": (energy_dim, fields["survival_initial_slope_stderr"],
                                              {"long_name": "standard error of survival_initial_slope"}),
            "survival_decay_rate": (energy_dim, fields["survival_decay_rate"],
                                    {"long_name": "long-time decay rate of the survival probability"}),
            "survival_time": (("energy", "survival_point"), survival_time, {"long_name": "time"}),
            "survival_probability": (("energy", "survival_point"), survival_probability,
                                     {"long_name": "fraction of the well ensemble not yet left"}),
            "gap_time_survival": (("energy", "survival_point"), gap_time_survival,
                                  {"long_name": "fraction of the flux-weighted entering ensemble still in the well "
                                                "(gap time beyond t)"}),
            "flux_dividing_lines": (energy_dim, fields["flux_dividing_lines"],
                                    {"long_name": "one-way flux through all dividing lines of the well"}),
            "left_volume_gap_times": (energy_dim, fields["left_volume_gap_times"],
                                      {"long_name": "flux_dividing_lines x mean of min(gap time, T), T the last "
                                                    "survival_time"}),
            "left_volume_gap_times_stderr": (energy_dim, fields["left_volume_gap_times_stderr"],
                                             {"long_name": "standard error of left_volume_gap_times"}),
            "left_volume_survival": (energy_dim, fields["left_volume_survival"],
                                     {"long_name": "well_volume x fraction of the well ensemble left by T: equals "
                                                   "left_volume_gap_times exactly in expectation"}),
            "left_volume_survival_stderr": (energy_dim, fields["left_volume_survival_stderr"],
                                            {"long_name": "standard error of left_volume_survival (binomial)"}),
            "gap_identity_deviation": (energy_dim, fields["gap_identity_deviation"],
                                       {"long_name": "(left_volume_gap_times - left_volume_survival) in combined "
                                                     "standard errors"}),
            "gap_times_seconds": (energy_dim, fields["gap_times_seconds"],
                                  {"long_name": "wall time of the gap-time ensemble", "units": "s"}),
            "survival_seconds": (energy_dim, fields["survival_seconds"],
                                 {"long_name": "wall time of the survival ensembles", "units": "s"}),
            "monte_carlo_seconds": (energy_dim, fields["monte_carlo_seconds"],
                                    {"long_name": "wall time of the Monte Carlo estimate", "units": "s"}),
            **{name: (energy_dim, value) for name, value in counts.items()},
            "island": (("energy", "manifold", "point", "phase"), curves,
                       {"long_name": "first cut of the inward tube with the section, ordered by orbit phase"}),
        },
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
