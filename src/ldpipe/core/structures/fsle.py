"""The finite-size Lyapunov exponent (FSLE) of a flow over a grid, forward and backward, as AVISO
computes it (d'Ovidio et al. 2004).

Each grid point is advected with its four neighbours at the initial separation δ0 along the two
axes (±δ0 on each). The FSLE is λ = ln(δf / δ0) / τ, where τ is the first time any neighbour's
distance from the point reaches the final separation δf; where none does within the maximum time,
λ = 0 (AVISO's convention) and the point is flagged as not reached. In the plane distances are
Euclidean in the axes' own units. On the sphere (velocity data with longitude and latitude in
degrees) they are great-circle distances in km (:mod:`ldpipe.core.sphere`), and so are δ0 and δf:
the four neighbours start δ0 east, west, north and south of their point along great circles, and a
separation is measured as the sphere has it across the longitude's seam and over a pole, where the
chart's degrees would stretch an east-west pair by 1 / cos(latitude).

The particles are advanced by the flow map (:func:`ldpipe.core.trajectories.flow_map`) over
checking intervals; between two checks the distance is taken as growing exponentially (linear in
its logarithm), so a pair whose separation grows as e^(λt) reaches δf at exactly ln(δf/δ0)/λ.

The direction of stretching: at the check where δf is reached, the deformation gradient by
central differences of the four neighbours, F = [(x₊₀ − x₋₀), (x₊₁ − x₋₁)] / (2 δ0) (on the sphere
x the 3-D position in km), and the eigenvector of the Cauchy–Green tensor FᵀF with the largest
eigenvalue: the direction at the start that the flow stretches most, as an angle from the first
axis (on the sphere from the start point's own east or north, as that axis is longitude or
latitude) in (−π/2, π/2].
"""

from __future__ import annotations

import math

import numpy as np
import xarray as xr

from ...errors import ConfigError
from ...io.contracts import FSLE
from ...io.datafile import stage_dataset
from ..sphere import great_circle_distance, sphere_radius_km, step_along, unit_vectors
from .grid import section_grid
from ..trajectories import COMPLETED, FlowSettings, checked_flow_settings, flow_map

#: The defaults of the FSLE's parameters (``initial_separation`` None: the grid's smaller spacing,
#: on the sphere as km of arc).
DEFAULTS = {"initial_separation": None, "final_separation": None, "max_time": None, "interval": None,
            "t0": 0.0, "integrator": {}}
# the direction of a neighbour's offset from its point: (axis, sign) for the 4 neighbours
NEIGHBOURS = ((0, 1.0), (0, -1.0), (1, 1.0), (1, -1.0))


def _positive(value, key: str, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
        raise ConfigError(f"{where}: {key}: {value!r}; expected a finite number > 0")
    return float(value)


def check_fsle_parameters(parameters: dict, spacing: tuple[float, float], where: str = "fsle",
                          key: str = "key", radius: float | None = None) -> dict:
    """``parameters`` with the defaults filled and checked; a ConfigError naming the key
    (``key`` says what a key is called where the parameters come from: 'key', 'argument').
    ``radius``: the sphere's in km, where separations are great-circle km (``spacing`` still in
    degrees: the default δ0 is the smaller spacing as km of arc), None in the plane."""
    unknown = sorted(set(parameters) - set(DEFAULTS))
    if unknown:
        raise ConfigError(f"{where}: unknown {key}s {unknown}; allowed are {sorted(DEFAULTS)}")
    checked = {**DEFAULTS, **parameters}
    name = lambda k: f"{key} {k!r}"  # noqa: E731
    for required in ("final_separation", "max_time"):
        if checked[required] is None:
            raise ConfigError(f"{where}: {name(required)} is required")
    default = min(spacing) * (math.pi * radius / 180.0 if radius is not None else 1.0)
    delta0 = default if checked["initial_separation"] is None else checked["initial_separation"]
    checked["initial_separation"] = _positive(delta0, name("initial_separation"), where)
    checked["final_separation"] = _positive(checked["final_separation"], name("final_separation"), where)
    if radius is not None and checked["final_separation"] >= math.pi * radius:
        raise ConfigError(f"{where}: {name('final_separation')}: {checked['final_separation']}; on the sphere a "
                          f"great-circle distance in km, expected less than half its circumference {math.pi * radius:.6g}")
    if checked["final_separation"] <= checked["initial_separation"]:
        raise ConfigError(f"{where}: {name('final_separation')}: {checked['final_separation']}; expected more "
                          f"than the initial separation {checked['initial_separation']}")
    checked["max_time"] = _positive(checked["max_time"], name("max_time"), where)
    interval = checked["max_time"] / 100 if checked["interval"] is None else checked["interval"]
    checked["interval"] = min(_positive(interval, name("interval"), where), checked["max_time"])
    t0 = checked["t0"]
    if isinstance(t0, bool) or not isinstance(t0, (int, float)) or not math.isfinite(t0):
        raise ConfigError(f"{where}: {name('t0')}: {t0!r}; expected a finite number")
    checked["t0"] = float(t0)
    checked["integrator"] = checked_flow_settings(checked["integrator"], f"{where}: {name('integrator')}")
    return checked


def fsle_field(system, axes: tuple[tuple[str, np.ndarray], tuple[str, np.ndarray]], fixed: dict, direction: int,
               parameters: dict, *, threads: int | None = None) -> dict[str, np.ndarray]:
    """The FSLE of ``system`` (a vector field) over the grid ``axes`` ((name, values) twice; the
    other coordinates at ``fixed``) in ``direction`` (+1 forward, -1 backward), with checked
    ``parameters`` (:func:`check_fsle_parameters`): ``fsle``, ``reached``, ``time`` (τ, 0 where not
    reached), ``angle`` (of stretching, 0 where not reached) and ``defined`` (False where a
    particle stopped, escaped or failed, before its point reached δf), each (n0, n1)."""
    names = [name for name, _ in axes]
    coordinates = list(system.coordinates)
    index = [coordinates.index(name) for name in names]
    grid = np.meshgrid(*(np.asarray(values, float) for _, values in axes), indexing="ij")
    shape = grid[0].shape
    count = grid[0].size
    base = np.zeros((count, len(coordinates)))
    for name, value in fixed.items():
        base[:, coordinates.index(name)] = float(value)
    base[:, index[0]], base[:, index[1]] = grid[0].ravel(), grid[1].ravel()
    delta0, delta_f = parameters["initial_separation"], parameters["final_separation"]
    particles = np.repeat(base[:, None, :], 5, axis=1)  # the point, then its neighbours
    radius = sphere_radius_km(system)
    if radius is None:
        for k, (axis, sign) in enumerate(NEIGHBOURS, start=1):
            particles[:, k, index[axis]] += sign * delta0
        plane_columns = index

        def separations(plane):
            return np.linalg.norm(plane[:, 1:] - plane[:, :1], axis=-1)

        def positions(plane):
            return plane
    else:
        plane_columns = sphere_columns(system, names)
        # east (1, 0) along longitude, north (0, 1) along latitude, in the axes' order
        directions = [(1.0, 0.0) if plane_columns[0] == index[axis] else (0.0, 1.0) for axis in (0, 1)]
        for k, (axis, sign) in enumerate(NEIGHBOURS, start=1):
            east, north = directions[axis]
            particles[:, k, plane_columns] = step_along(base[:, plane_columns], sign * east, sign * north, delta0,
                                                        radius)

        def separations(plane):
            return great_circle_distance(plane[:, 1:], plane[:, :1], radius)

        def positions(plane):
            return radius * unit_vectors(plane)
    settings = FlowSettings(**parameters["integrator"])
    reached = np.zeros(count, dtype=bool)
    stopped = np.zeros(count, dtype=bool)
    time = np.zeros(count)
    angle = np.zeros(count)
    log_previous = np.full((count, 4), math.log(delta0))
    interval, max_time = parameters["interval"], parameters["max_time"]
    checks = max(1, math.ceil(max_time / interval - 1e-9))
    for check in range(checks):
        # from the check's index, not summed: a sum of steps overshoots max_time by rounding, and
        # a backward run's last window would start before the data's first time
        elapsed = min(check * interval, max_time)
        active = np.flatnonzero(~reached & ~stopped)
        if not len(active):
            break
        step = min((check + 1) * interval, max_time) - elapsed
        moved = flow_map(system, particles[active].reshape(-1, len(coordinates)), direction * step, settings,
                         t0=parameters["t0"] + direction * elapsed, threads=threads)
        particles[active] = moved.end_state.reshape(len(active), 5, -1)
        ok = (moved.status == COMPLETED).reshape(len(active), 5).all(axis=1)
        plane = particles[active][:, :, plane_columns]
        log_now = np.log(np.maximum(separations(plane), 1e-300))
        log_target = math.log(delta_f)
        crossed = (log_now >= log_target) & ok[:, None]
        hit = crossed.any(axis=1)
        if hit.any():
            before, after = log_previous[active][hit], log_now[hit]
            with np.errstate(divide="ignore", invalid="ignore"):
                fraction = np.where(after > before, (log_target - before) / (after - before), 1.0)
            fraction = np.where(crossed[hit], np.clip(fraction, 0.0, 1.0), np.inf)
            time[active[hit]] = elapsed + step * fraction.min(axis=1)
            reached[active[hit]] = True
            angle[active[hit]] = _stretching_angle(positions(plane[hit]), delta0)
        stopped[active[~ok]] = True
        log_previous[active] = log_now
    stopped &= ~reached
    with np.errstate(divide="ignore"):
        fsle = np.where(reached, math.log(delta_f / delta0) / np.where(reached, time, 1.0), 0.0)
    return {"fsle": fsle.reshape(shape), "reached": reached.reshape(shape), "time": time.reshape(shape),
            "angle": angle.reshape(shape), "defined": (~stopped).reshape(shape)}


def sphere_columns(system, names: list[str]) -> list[int]:
    """The state's columns of longitude and latitude, of a system on the sphere whose section's
    axes ``names`` must be these two; a ConfigError otherwise."""
    lon, lat = system.coordinates[:2]  # a sphere's state: longitude, latitude (then a depth)
    if sorted(names) != sorted((lon, lat)):
        raise ConfigError(f"system {system.name!r} is on the sphere: the FSLE's section axes must be its longitude "
                          f"{lon!r} and latitude {lat!r}, got {names}")
    return [list(system.coordinates).index(lon), list(system.coordinates).index(lat)]


def _stretching_angle(plane: np.ndarray, delta0: float) -> np.ndarray:
    """The angle from the first axis of the initial direction stretched most: the largest
    eigenvector of FᵀF, F from the neighbours' central differences (``plane`` (k, 5, d): the
    positions, in the plane the axes' values, on the sphere 3-D in km)."""
    columns = np.stack([(plane[:, 1] - plane[:, 2]), (plane[:, 3] - plane[:, 4])], axis=-1) / (2 * delta0)
    cauchy_green = np.einsum("kij,kil->kjl", columns, columns)
    vectors = np.linalg.eigh(cauchy_green)[1][:, :, -1]
    angle = np.arctan2(vectors[:, 1], vectors[:, 0])
    # a direction, not a vector: folded into (-pi/2, pi/2]
    angle = np.where(angle > math.pi / 2, angle - math.pi, angle)
    return np.where(angle <= -math.pi / 2, angle + math.pi, angle)


def fsle_dataset(system, section: dict, parameters: dict, *, threads: int | None = None, where: str = "fsle",
                 key: str = "key") -> xr.Dataset:
    """The FSLE file of ``system`` over ``section`` (``{"axes": [{name, range, points}] × 2,
    "fixed": {...}}``, as an LD map's section block): forward and backward fields, with the checked
    ``parameters`` recorded as attributes. A ConfigError begins with ``where`` and names a bad
    parameter as a ``key`` (or, from the API, an 'argument')."""
    if system.hamiltonian:
        raise ConfigError(f"{where}: system {system.name!r} is a Hamiltonian; the FSLE is computed for vector "
                          "fields and velocity data")
    axes, fixed = section_grid(section, system.coordinates, where)
    spacing = tuple(abs(float(values[1] - values[0])) if len(values) > 1 else math.inf for _, values in axes)
    radius = sphere_radius_km(system)
    if radius is not None:
        try:
            sphere_columns(system, [name for name, _ in axes])
        except ConfigError as error:
            raise ConfigError(f"{where}: section: {error}") from None
    parameters = check_fsle_parameters(dict(parameters), spacing, where, key, radius)
    dims = tuple(name for name, _ in axes)
    variables = {}
    for label, direction in (("forward", 1), ("backward", -1)):
        result = fsle_field(system, axes, fixed, direction, parameters, threads=threads)
        variables[f"fsle_{label}"] = (dims, result["fsle"], {
            "long_name": f"finite-size Lyapunov exponent, {label} time", "units": "1/time",
            "comment": "ln(final_separation / initial_separation) / the first time a neighbour reaches the final "
                       "separation; 0 where none does within max_time (see fsle_reached)"})
        variables[f"fsle_reached_{label}"] = (dims, result["reached"], {
            "long_name": f"a neighbour reached the final separation within max_time ({label})"})
        variables[f"fsle_time_{label}"] = (dims, result["time"], {
            "long_name": f"time to reach the final separation ({label}); 0 where not reached", "units": "time"})
        variables[f"fsle_angle_{label}"] = (dims, result["angle"], {
            "long_name": f"initial direction stretched most ({label}), from the first axis"
                         + (" (its local east or north)" if radius is not None else ""), "units": "radian",
            "comment": "largest eigenvector of the Cauchy-Green tensor of the neighbours' deformation when the "
                       "final separation is reached; 0 where not reached"})
        variables[f"fsle_defined_{label}"] = (dims, result["defined"], {
            "long_name": f"no particle of the point stopped before it reached the final separation ({label})"})
    dataset = xr.Dataset(variables, coords={name: values for name, values in axes})
    dataset.attrs.update({
        "system": system.name, "t0": parameters["t0"], "initial_separation": parameters["initial_separation"],
        "final_separation": parameters["final_separation"], "max_time": parameters["max_time"],
        "interval": parameters["interval"],
        **({"separation_units": "km", "neighbours": "the four at initial_separation east, west, north and south "
            "along great circles; separations are great-circle distances"} if radius is not None else
           {"neighbours": "the four at +-initial_separation along the two axes; separations are Euclidean in "
            "the axes' units"}),
        **{key: value for key, value in FlowSettings(**parameters["integrator"]).__dict__.items()},
    })
    return stage_dataset(dataset, stage=FSLE, title=f"FSLE of {system.name}",
                         parameters={**parameters, "section": section})
