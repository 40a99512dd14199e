"""Every transport quantity of a 2 DoF index-1 saddle at one energy, from its Lyapunov orbit, and a
study of several energies as its file holds it.

:func:`transport_at_energy` computes, at the energy of one orbit of the family,

* the flux three independent ways: the orbit's action (:func:`~ldpipe.core.transport.orbit_action`),
  the area of the reactive islands, the first cuts of the inward stable and unstable tubes with a
  section (:func:`~ldpipe.core.transport.closed_curve_area`; every other point and the shoelace rule
  for comparison), and the Monte Carlo reactive flux through the straight dividing line at the
  saddle (:func:`~ldpipe.core.transport.reactive_flux_monte_carlo`);
* the microcanonical transition-state rate: the flux out of the well (the action plus the Monte
  Carlo flux over the other open saddles) over the well's shell volume
  (:func:`~ldpipe.core.transport.well_shell_volume`);
* the survival of a microcanonical ensemble of the well (:mod:`ldpipe.core.transport.survival`): its
  initial slope, which must equal the rate, its long-time decay rate and its curve;
* the gap times of the flux-weighted ensemble entering the well (:mod:`ldpipe.core.transport.gap_times`),
  and both sides of the exact identity Φ E[min(τ, T)] = V (1 − P(T)) that ties them to the survival.

The settings are the blocks of a ``transport:`` study of the configuration (``island``,
``monte_carlo``, ``survival``, ``gap_times``; see the schema).

:func:`transport_dataset` is the transport stage's file: a study names a periodic-orbit family of
a 2 DoF system (``orbits``) and which of its target energies (``energies``), and for each energy
the file holds

* ``flux_action``: ∮ p·dq of the family's orbit (:func:`ldpipe.core.transport.orbit_action`);
* ``flux_island_area``: ∮ p_x dx of the first cut of the inward stable and unstable tubes with
  the section (:func:`ldpipe.core.transport.closed_curve_area`), from cuts computed here with
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
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import xarray as xr

from ...errors import ConfigError, StageFileError
from ...io.contracts import EQUILIBRIA, TRANSPORT, UPO
from ...io.datafile import input_name, open_stage_file, stage_dataset, stage_parameters
from ..equilibria.potential import well_and_frequencies
from ..trajectories import FlowSettings
from ...logs import get_logger
from ..orbits.family import select_orbit
from ..orbits.manifolds import MANIFOLDS, ManifoldSettings, globalized_manifolds
from ...systems import System, make_system, require_hamiltonian
from .flux import DividingLine, MonteCarloFlux, closed_curve_area, harmonic_flux, orbit_action, \
    reactive_flux_monte_carlo
from .gap_times import gap_times
from .survival import decay_rate, exit_times, initial_slope, sample_well, survival
from .well import well_shell_volume

log = get_logger(__name__)


@dataclass(frozen=True)
class LyapunovOrbit:
    """One orbit of a family file: its energy (total and above the saddle), its state at t = 0 and
    period, its samples uniform in time over one period (``samples``, shape (n, 2 n_dof)), and the
    tolerances it was corrected with (its manifolds start at them)."""

    energy: float
    excess_energy: float
    initial_state: np.ndarray
    period: float
    samples: np.ndarray
    rtol: float
    atol: float


@dataclass(frozen=True)
class TransportAtEnergy:
    """What :func:`transport_at_energy` finds, named as the transport stage's file names it.

    ``island`` has shape (2, points, 2 n_dof) (stable, unstable: the section states in orbit-phase
    order) and the ``flux_island_area*`` shape (2,); ``survival_time``, ``survival_probability`` and
    ``gap_time_survival`` share one time grid from 0 to the horizon T. ``flux_monte_carlo`` to
    ``monte_carlo_undecided`` are the :class:`~ldpipe.core.transport.MonteCarloFlux` of the saddle's line.
    """

    flux_action: float
    flux_island_area: np.ndarray
    flux_island_area_half: np.ndarray
    flux_island_area_polygon: np.ndarray
    flux_monte_carlo: float
    flux_monte_carlo_stderr: float
    flux_dividing_line: float
    flux_other_saddles: float
    flux_other_saddles_stderr: float
    well_volume: float
    rate_tst: float
    survival_initial_slope: float
    survival_initial_slope_stderr: float
    survival_decay_rate: float
    survival_time: np.ndarray
    survival_probability: np.ndarray
    gap_time_survival: np.ndarray
    flux_dividing_lines: float
    left_volume_gap_times: float
    left_volume_gap_times_stderr: float
    left_volume_survival: float
    left_volume_survival_stderr: float
    gap_identity_deviation: float
    gap_times_seconds: float
    survival_seconds: float
    monte_carlo_seconds: float
    monte_carlo_samples: int
    monte_carlo_reactive: int
    monte_carlo_antireactive: int
    monte_carlo_nonreactive: int
    monte_carlo_undecided: int
    island: np.ndarray


def reactive_islands(system: System, orbit: LyapunovOrbit, island: dict, *, threads: int | None = None,
                     key: str = "transport") -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The first cut of each inward tube (stable, unstable) with the section ``island['section']``,
    and the areas ∮ p dq of the other position coordinate round each cut: spectral, from every other
    point, and by the shoelace rule. ``island`` is a study's ``island`` block; ``key`` names it in errors."""
    section = island["section"]
    settings = ManifoldSettings(
        points=island["points"], displacement=island["displacement"], time=island["time"], samples=2,
        section=(section["coordinate"], section["value"], section["direction"]), crossings=1,
        orbit_rtol=orbit.rtol, orbit_atol=orbit.atol,
    )
    position_axis = 1 - system.phase_coordinates.index(section["coordinate"])  # the other coordinate (2 DoF)
    axes = (position_axis, position_axis + 2)
    points = island["points"]
    curves = np.empty((2, points, 2 * system.n_dof))
    area, area_half, area_polygon = (np.empty(2) for _ in range(3))
    cut = globalized_manifolds(system, orbit.initial_state, orbit.period, settings,
                               FlowSettings(**island["integrator"]), threads=threads)
    for k, manifold in enumerate(MANIFOLDS):
        valid = cut.section_valid.values[k, 0, 0]
        if not valid.all():
            raise ConfigError(
                f"config key '{key}.island.time': at dE = {orbit.excess_energy:.6g}, {int((~valid).sum())} of {points} "
                f"{manifold} inward trajectories did not cut the section within {island['time']}; raise it")
        state = cut.section_state.values[k, 0, 0]
        curves[k] = state
        x, p = state[:, axes[0]], state[:, axes[1]]
        area[k] = abs(closed_curve_area(x, p))
        area_half[k] = abs(closed_curve_area(x[::2], p[::2]))
        area_polygon[k] = abs(closed_curve_area(x, p, method="shoelace"))
    return curves, area, area_half, area_polygon


def _monte_carlo(line: DividingLine, settings: dict, seed: int, threads: int | None) -> MonteCarloFlux:
    return reactive_flux_monte_carlo(
        line, commit=settings["commit"], duration=settings["duration"], target_stderr=settings["target_stderr"],
        batch=settings["batch"], max_samples=settings["max_samples"], sample_step=settings["sample_step"],
        flow=FlowSettings(**settings["integrator"]), seed=seed, threads=threads,
    )


def transport_at_energy(
    system: System, orbit: LyapunovOrbit, *, saddle: np.ndarray, well: np.ndarray,
    other_saddles: Sequence[tuple[np.ndarray, float]], island: dict, monte_carlo: dict, survival_settings: dict,
    gap_time_settings: dict, seed_offset: int = 0, threads: int | None = None, key: str = "transport",
) -> TransportAtEnergy:
    """Flux by action, island area and Monte Carlo, the TST rate, survival and gap times at the orbit's energy.

    Parameters
    ----------
    system : System
        A 2 DoF Hamiltonian system.
    orbit : LyapunovOrbit
        The Lyapunov orbit of ``saddle`` at the energy studied.
    saddle, well : array_like, shape (2,)
        The saddle's and the well's positions.
    other_saddles : sequence of (position, critical energy)
        The other index-1 saddles round the well; those below the energy are open (their Monte
        Carlo flux counts towards the rate), the well is closed at the others.
    island, monte_carlo, survival_settings, gap_time_settings : dict
        A study's ``island``, ``monte_carlo``, ``survival`` and ``gap_times`` blocks.
    seed_offset : int
        Added to every configured seed, so that each energy of a study draws its own samples.
    key : str
        The study's configuration key, for errors.
    """
    energy, excess = orbit.energy, orbit.excess_energy
    flux_action = orbit_action(orbit.samples, system.n_dof)
    curves, area, area_half, area_polygon = reactive_islands(system, orbit, island, threads=threads, key=key)

    mc = monte_carlo
    line = DividingLine.at_saddle(system, saddle, energy, well=well)
    reach = float(np.max(np.abs((orbit.samples[:, :2] - saddle) @ line.normal)))
    if mc["commit"] <= 2 * reach:
        raise ConfigError(f"config key '{key}.monte_carlo.commit': {mc['commit']} is not beyond the orbit, which "
                          f"reaches {reach:.3g} from the dividing line at dE = {excess:.6g}; raise it")
    start = time.perf_counter()
    result = _monte_carlo(line, mc, mc["seed"] + seed_offset, threads)
    monte_carlo_seconds = time.perf_counter() - start
    # Saddles below the energy are open; the well is closed at the others (no line needed).
    other_lines = [DividingLine.at_saddle(system, q, energy, well=well) for q, ec in other_saddles if ec < energy]
    other = [_monte_carlo(other_line, mc, mc["seed"] + 1000 * (k + 1) + seed_offset, threads)
             for k, other_line in enumerate(other_lines)]
    flux_other_saddles = float(sum(r.flux for r in other))
    flux_other_saddles_stderr = math.sqrt(sum(r.stderr**2 for r in other))
    all_lines = [line, *other_lines]
    well_volume = well_shell_volume(system, well, energy, all_lines)
    rate = (flux_action + flux_other_saddles) / well_volume
    log.info("dE = %.6g: well volume %.10g, flux over the other saddles %.8g, TST rate %.6g", excess,
             well_volume, flux_other_saddles, rate)

    sv, gp = survival_settings, gap_time_settings
    flow = FlowSettings(**sv["integrator"])
    rng = np.random.default_rng(sv["seed"] + seed_offset)
    start = time.perf_counter()
    early = exit_times(system, sample_well(system, well, energy, all_lines, sv["initial_count"], rng), all_lines,
                       sv["t0"], sample_step=sv["sample_step"], flow=flow, threads=threads)
    slope = initial_slope(early, sv["t0"])
    horizon = sv["duration"] / rate
    late = exit_times(system, sample_well(system, well, energy, all_lines, sv["count"], rng), all_lines, horizon,
                      sample_step=sv["sample_step"], segment=max(20.0, horizon / 20), flow=flow, threads=threads)
    window = np.asarray(sv["decay_window"]) / rate
    survival_time = np.linspace(0.0, horizon, sv["points"])
    survival_probability = survival(late, survival_time)
    survival_decay_rate = decay_rate(late, window[0], window[1])
    survival_seconds = time.perf_counter() - start

    start = time.perf_counter()
    gaps = gap_times(system, all_lines, gp["count"], horizon, np.random.default_rng(gp["seed"] + seed_offset),
                     sample_step=sv["sample_step"], segment=max(20.0, horizon / 20), flow=flow, threads=threads)
    gap_times_seconds = time.perf_counter() - start
    gap_side = gaps.reactive_volume(horizon)
    left = float(np.mean(late <= horizon))
    survival_side = (well_volume * left, well_volume * math.sqrt(max(left * (1 - left), 1.0 / len(late)) / len(late)))
    deviation = (gap_side[0] - survival_side[0]) / math.hypot(gap_side[1], survival_side[1])
    log.info("dE = %.6g: volume left by T = %.4g: %.6g +- %.2g from gap times, %.6g +- %.2g from survival "
             "(%.2f sigma); mean gap time bound %.4g, V/Phi %.4g", excess, horizon, gap_side[0], gap_side[1],
             survival_side[0], survival_side[1], deviation, gap_side[0] / gaps.flux, well_volume / gaps.flux)
    if abs(deviation) > 4:
        log.warning("dE = %.6g: gap times and survival disagree by %.1f standard errors on the volume left by "
                    "T (an exact identity): check survival.sample_step and the integrator tolerances",
                    excess, deviation)
    log.info("dE = %.6g: TST rate %.6g, initial slope %.6g +- %.2g, decay rate %.6g (%.1f s)", excess, rate,
             slope.rate, slope.stderr, survival_decay_rate, survival_seconds)
    log.info("dE = %.6g: action %.12g, island %.12g / %.12g, Monte Carlo %.8g +- %.2g (%d samples, %.1f s), "
             "line %.8g", excess, flux_action, area[0], area[1], result.flux, result.stderr, result.samples,
             monte_carlo_seconds, result.surface_flux)
    return TransportAtEnergy(
        flux_action=float(flux_action), flux_island_area=area, flux_island_area_half=area_half,
        flux_island_area_polygon=area_polygon, flux_monte_carlo=float(result.flux),
        flux_monte_carlo_stderr=float(result.stderr), flux_dividing_line=float(result.surface_flux),
        flux_other_saddles=flux_other_saddles, flux_other_saddles_stderr=flux_other_saddles_stderr,
        well_volume=float(well_volume), rate_tst=float(rate), survival_initial_slope=float(slope.rate),
        survival_initial_slope_stderr=float(slope.stderr), survival_decay_rate=float(survival_decay_rate),
        survival_time=survival_time, survival_probability=survival_probability,
        gap_time_survival=gaps.survival(survival_time), flux_dividing_lines=float(gaps.flux),
        left_volume_gap_times=float(gap_side[0]), left_volume_gap_times_stderr=float(gap_side[1]),
        left_volume_survival=float(survival_side[0]), left_volume_survival_stderr=float(survival_side[1]),
        gap_identity_deviation=float(deviation), gap_times_seconds=gap_times_seconds,
        survival_seconds=survival_seconds, monte_carlo_seconds=monte_carlo_seconds,
        **{f"monte_carlo_{name}": int(getattr(result, name))
           for name in ("samples", "reactive", "antireactive", "nonreactive", "undecided")},
        island=curves,
    )


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


def _family_orbit(orbits: xr.Dataset, index: int) -> LyapunovOrbit:
    """Orbit ``index`` of a family file (its Dataset)."""
    return LyapunovOrbit(
        energy=float(orbits.energy.values[index]), excess_energy=float(orbits.excess_energy.values[index]),
        initial_state=orbits.initial_state.values[index], period=float(orbits.period.values[index]),
        samples=orbits.trajectory.values[index], rtol=float(orbits.attrs["rtol"]), atol=float(orbits.attrs["atol"]),
    )


def transport_dataset(parameters: dict, upo: str | os.PathLike | xr.Dataset,
                      equilibria: str | os.PathLike | xr.Dataset, *, threads: int | None = None) -> xr.Dataset:
    """Flux by action, island area and Monte Carlo, the TST rate, survival and gap times at each
    energy of a study (:func:`transport_at_energy`), as the transport stage's file holds them:
    ``parameters`` are the stage's (:func:`ldpipe.config.parameters.parameters_from_config`), ``upo``
    the family's file or Dataset (:func:`ldpipe.core.orbits.family.periodic_orbits_dataset`), whose
    orbits at the study's energies are taken, ``equilibria`` the system's equilibria file or Dataset
    (the well, the saddle's centre frequency and the other saddles); ``threads`` of the engine
    (default every core)."""
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
            system, _family_orbit(orbits, index), saddle=saddle, well=well, other_saddles=others,
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
    return stage_dataset(data, stage=TRANSPORT, title=title, parameters=parameters)
