"""Stable and unstable manifolds of a periodic orbit, globalized, and their cuts by a section.

Globalization (the paper's appendix, after Koon et al.): the monodromy matrix's
eigenvectors e_u (multiplier lambda > 1) and e_s (1/lambda) at the orbit's
initial state X0 are carried to ``points`` states x(t_j), t_j = j T / points,
by the state transition matrix, e(t_j) = Phi(t_j) e; each is scaled so its
position part has length ``displacement`` (epsilon), and x(t_j) +- epsilon e(t_j)
is integrated forward (unstable manifold) or backward (stable manifold) for the
configured time. Each trajectory's crossings of a surface of section, taken in
order of the orbit phase t_j / T, are the curves where the tubes cut the section.

Branches: *inward* is the side whose displacement points, in configuration
space, against the saddle's position vector (towards the origin, where the
wells of the built-in systems are), *outward* the other.

A manifold set is declared under ``manifolds:`` in the configuration: the periodic-orbit family
it grows from (``orbits``) and which of that family's target energies (``energy``), the number of
points along the orbit, the displacement epsilon, the integration time and the surface of
section. :func:`manifolds_dataset` is its stage file; :func:`globalized_manifolds` the
trajectories and cuts of any orbit.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np
import xarray as xr

from ..trajectories import ESCAPED, STATUS_MEANINGS, STATUS_VALUES, FlowSettings, integrate
from .family import select_orbit
from .periodic import floquet_multipliers
from ...errors import ConfigError, StageFileError
from ...io import contracts
from ...io.datafile import input_name, open_stage_file, stage_dataset, stage_parameters
from ...logs import get_logger
from ...systems import System, make_system, require_hamiltonian
from ..variational import sample

log = get_logger(__name__)

MANIFOLDS = ("stable", "unstable")
BRANCHES = ("inward", "outward")


@dataclass(frozen=True)
class ManifoldSettings:
    points: int = 100
    displacement: float = 1e-6
    time: float = 20.0
    samples: int = 200
    section: tuple[str, float, int] = ("y", 0.0, 1)
    crossings: int = 2
    orbit_rtol: float = 1e-13
    orbit_atol: float = 1e-13


def _real_eigenvector(vector: np.ndarray) -> np.ndarray:
    """A real eigenvector of a real eigenvalue (removes the arbitrary complex phase), unit length."""
    vector = vector / vector[int(np.argmax(np.abs(vector)))]
    vector = vector.real
    return vector / np.linalg.norm(vector)


def start_states(
    system: System, initial_state: np.ndarray, period: float, settings: ManifoldSettings
) -> dict:
    """The orbit at ``points`` phases and the displaced starting states of both manifolds and branches.

    Returns a dict with ``times`` (points), ``orbit`` (points, 2n), ``multipliers``,
    ``directions`` (manifold, points, 2n: transported, normalized eigenvectors) and
    ``starts`` (manifold, branch, points, 2n).
    """
    n = system.n_dof
    times = np.linspace(0.0, period, settings.points + 1)
    orbit, stms = sample(system, initial_state, times, rtol=settings.orbit_rtol, atol=settings.orbit_atol, stm=True)
    multipliers, vectors = floquet_multipliers(stms[-1])
    if not (abs(multipliers[0].imag) < 1e-9 * abs(multipliers[0]) and multipliers[0].real > 1.0):
        raise ValueError(f"the orbit is not hyperbolic: leading Floquet multiplier {multipliers[0]}")
    outward = np.asarray(initial_state[:n])  # the saddle side, roughly: see the module docstring
    directions = np.empty((2, settings.points, 2 * n))
    for k, column in enumerate((1, 0)):  # stable: 1/lambda, unstable: lambda
        e = _real_eigenvector(vectors[:, column])
        transported = np.einsum("tij,j->ti", stms[:-1], e)
        transported /= np.linalg.norm(transported[:, :n], axis=1)[:, None]
        # Orient at t = 0 so the displacement points outward (the transport keeps the orientation).
        if transported[0, :n] @ outward < 0:
            transported = -transported
        directions[k] = transported
    eps = settings.displacement
    starts = np.empty((2, 2, settings.points, 2 * n))
    for k in range(2):
        starts[k, 0] = orbit[:-1] - eps * directions[k]
        starts[k, 1] = orbit[:-1] + eps * directions[k]
    return {"times": times[:-1], "orbit": orbit[:-1], "multipliers": multipliers, "directions": directions,
            "starts": starts}


def globalized_manifolds(
    system: System,
    initial_state: np.ndarray,
    period: float,
    settings: ManifoldSettings,
    flow: FlowSettings,
    *,
    threads: int | None = None,
) -> xr.Dataset:
    """Both manifolds, both branches, as trajectories, with their section crossings ordered as curves."""
    n = system.n_dof
    start = start_states(system, np.asarray(initial_state, dtype=np.float64), period, settings)
    points, samples, crossings = settings.points, settings.samples, settings.crossings
    shape = (2, 2, points)
    trajectory = np.empty((*shape, samples, 2 * n))
    section_state = np.zeros((2, 2, crossings, points, 2 * n))
    section_time = np.zeros((2, 2, crossings, points))
    section_valid = np.zeros((2, 2, crossings, points), dtype=bool)
    sample_count = np.empty(shape, dtype=np.int64)
    status = np.empty(shape, dtype=np.int8)
    end_time = np.empty(shape)
    times = np.empty((2, samples))
    for k, sign in enumerate((-1.0, 1.0)):  # stable backward, unstable forward
        duration = sign * settings.time
        times[k] = np.linspace(0.0, duration, samples)
        result = integrate(
            system, start["starts"][k].reshape(2 * points, 2 * n), duration, flow,
            sample_times=times[k], section=settings.section, max_crossings=crossings, threads=threads,
        )
        trajectory[k] = result.samples.reshape(2, points, samples, 2 * n)
        sample_count[k] = result.sample_count.reshape(2, points)
        status[k] = result.status.reshape(2, points)
        end_time[k] = result.final_time.reshape(2, points)
        count = result.crossing_count.reshape(2, points)
        cross = result.crossings.reshape(2, points, crossings, 2 * n)
        cross_t = result.crossing_times.reshape(2, points, crossings)
        for c in range(crossings):
            section_state[k, :, c] = cross[:, :, c]
            section_time[k, :, c] = cross_t[:, :, c]
            section_valid[k, :, c] = count > c
    phase = list(system.phase_coordinates)
    mu = start["multipliers"]
    coords = {"manifold": list(MANIFOLDS), "branch": list(BRANCHES), "phase": phase,
              "point": np.arange(points), "sample": np.arange(samples), "crossing": np.arange(crossings)}
    dims4 = ("manifold", "branch", "point")
    data = xr.Dataset(
        {
            "orbit_phase": ("point", start["times"] / period,
                            {"long_name": "phase t/T along the periodic orbit of each manifold point"}),
            "orbit_state": (("point", "phase"), start["orbit"], {"long_name": "periodic orbit state at each point"}),
            "eigenvector": (("manifold", "point", "phase"), start["directions"],
                            {"long_name": "monodromy eigenvector transported by the STM, position part of unit length"}),
            "start_state": ((*dims4, "phase"), start["starts"],
                            {"long_name": "orbit state plus or minus displacement times eigenvector"}),
            "time": (("manifold", "sample"), times,
                     {"long_name": "time of each sample (negative: the stable manifold runs backward)"}),
            "trajectory": ((*dims4, "sample", "phase"), trajectory,
                           {"long_name": "manifold trajectories; after an early end the last state repeats"}),
            "sample_count": (dims4, sample_count, {"long_name": "samples reached before the trajectory ended"}),
            "status": (dims4, status, {"flag_values": STATUS_VALUES, "flag_meanings": STATUS_MEANINGS}),
            "escaped": (dims4, status == ESCAPED, {"long_name": "left the escape radius before the final time"}),
            "end_time": (dims4, end_time, {"long_name": "time the integration ended"}),
            "section_state": (("manifold", "branch", "crossing", "point", "phase"), section_state,
                              {"long_name": "k-th crossing of the section by each trajectory, ordered by orbit phase: "
                                            "a curve per (manifold, branch, crossing); 0 where section_valid is 0"}),
            "section_time": (("manifold", "branch", "crossing", "point"), section_time),
            "section_valid": (("manifold", "branch", "crossing", "point"), section_valid,
                              {"long_name": "the trajectory reached this crossing"}),
            "floquet_real": ("mode", mu.real), "floquet_imag": ("mode", mu.imag),
        },
        coords=coords,
    )
    coordinate, value, direction = settings.section
    data.attrs.update({
        "period": period, "energy": system.energy(initial_state), "displacement": settings.displacement,
        "integration_time": settings.time, "section_coordinate": coordinate, "section_value": float(value),
        "section_direction": int(direction), "unstable_multiplier": float(mu[0].real),
        "colors": "stable cyan, unstable magenta (the paper's Fig. 3(f))",
    })
    return data


def manifolds_dataset(parameters: dict, orbits: str | os.PathLike | xr.Dataset, *,
                      threads: int | None = None) -> xr.Dataset:
    """Both manifolds of one orbit of a family, globalized and cut by the section, as the
    manifolds stage's file holds them: ``parameters`` are the stage's
    (:func:`ldpipe.config.parameters.parameters_from_config`), ``orbits`` the family's file or
    Dataset (:func:`ldpipe.core.orbits.family.periodic_orbits_dataset`), of which the orbit at
    the entry's ``energy`` is taken; ``threads`` of the engine (default every core)."""
    key = f"manifolds.{parameters['name']}"
    data = open_stage_file(orbits, stage=contracts.UPO)
    if stage_parameters(data)["system_name"] != parameters["system_name"]:
        raise StageFileError(f"{input_name(orbits)}: orbits of system {data.attrs['system']!r}, "
                             f"expected {parameters['system_name']!r}")
    index = select_orbit(data, parameters["energy"], key, orbits)
    system = make_system(parameters["system_name"], parameters["system_spec"])
    require_hamiltonian(system, "the manifolds of a periodic orbit", key=f"{key}.orbits")
    section = parameters["section"]
    if section["coordinate"] not in system.phase_coordinates:
        raise ConfigError(f"config key '{key}.section.coordinate': {section['coordinate']!r} is not one of "
                          f"{list(system.phase_coordinates)}")
    integrator = parameters["integrator"]
    settings = ManifoldSettings(
        points=parameters["points"], displacement=parameters["displacement"], time=parameters["time"],
        samples=parameters["samples"], section=(section["coordinate"], section["value"], section["direction"]),
        crossings=parameters["crossings"],
        # the orbit and its transition matrices integrated at the tolerances the family was computed with
        orbit_rtol=float(data.attrs["rtol"]), orbit_atol=float(data.attrs["atol"]),
    )
    flow = FlowSettings(rtol=integrator["rtol"], atol=integrator["atol"], escape_radius=integrator["escape_radius"])
    initial_state = data.initial_state.values[index]
    period = float(data.period.values[index])
    log.info("%s: orbit %d of %s, dE = %.6g, period %.12g", parameters["name"], index, input_name(orbits),
             float(data.excess_energy.values[index]), period)
    dataset = globalized_manifolds(system, initial_state, period, settings, flow, threads=threads)
    dataset.attrs.update({
        "family": data.attrs["family"], "system": system.name, "excess_energy": float(data.excess_energy.values[index]),
        "critical_energy": float(data.attrs["critical_energy"]), "rtol": flow.rtol, "atol": flow.atol,
        "escape_radius": flow.escape_radius, **system.kinetic_attributes(),
    })
    log.info("unstable multiplier %.12g; %d of %d trajectories escaped", dataset.attrs["unstable_multiplier"],
             int(dataset.escaped.sum()), dataset.escaped.size)
    title = f"Stable and unstable manifolds of {data.attrs['family']} at dE = {dataset.attrs['excess_energy']:.6g}"
    return stage_dataset(dataset, stage=contracts.MANIFOLDS, title=title, parameters=parameters)
