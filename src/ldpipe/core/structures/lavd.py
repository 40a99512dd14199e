"""The Lagrangian-averaged vorticity deviation (LAVD, Haller et al. 2016) and rotationally coherent
vortices: their centres and boundaries.

    LAVD(x0) = ∫_{t0}^{t0+T} |ω(x(s), s) − ω̄(s)| ds,

ω the vorticity ∂v/∂x − ∂u/∂y along the trajectory from x0 (from a vector field's formulas, or
from the derivatives of gridded velocity data's interpolant, :func:`data_vorticity`) and ω̄(s) its
mean over the region the grid's particles fill at time s: the mean over the particles, each weighted
by the area of its start cell, which an incompressible flow carries along unchanged. On the plane the
cells are equal; on the sphere (longitude, latitude in degrees) a cell of the start grid has the area
R² Δλ (sin(φ + Δφ/2) − sin(φ − Δφ/2)) = 2 R² Δλ sin(Δφ/2) cos φ, so the weight is cos φ of the start
point. On the sphere ω is the vertical component of the curl, (1 / (R cos φ)) (∂v/∂λ − ∂(u cos φ)/∂φ)
(λ, φ in radians, u, v east and north); both ω and the LAVD are in the integration's time unit, as on
the plane. The particles are advanced by the flow map
(:func:`ldpipe.core.trajectories.flow_map`) over ``interval`` steps, the vorticity taken at every
step from the system's Jacobian, and the integral by the trapezoidal rule (error O(interval²) for
a smooth integrand).

A rotationally coherent vortex is centred on a maximum of the LAVD; its boundary is the outermost
LAVD level whose superlevel set around the maximum is bounded by one closed curve, convex enough:
its convexity deficiency, (area of its convex hull − its area) / its area, at most
``convexity_deficiency``: in the plane in the section's coordinates, on the sphere in the Lambert
azimuthal equal-area projection about the vortex's centre (:func:`ldpipe.core.sphere.tangent_plane`,
km), where a shape convex on the sphere stays convex to second order in its size over the Earth's
radius while the longitude–latitude chart bends it (a great circle heading east bows poleward there). Levels are tried from the maximum down in ``levels`` equal steps to the
field's minimum; at each, of the closed contours around the maximum the innermost (the boundary
of the superlevel component that holds the maximum) is taken.
"""

from __future__ import annotations

import math

import numpy as np
import xarray as xr

from ...errors import ConfigError
from ...io.contracts import LAVD
from ...io.datafile import stage_dataset
from ..sphere import sphere_radius_km, tangent_plane
from .grid import section_grid
from ..trajectories import COMPLETED, FlowSettings, checked_flow_settings, flow_map

DEFAULTS = {"duration": None, "interval": None, "t0": 0.0, "levels": 100, "convexity_deficiency": 0.01,
            "min_points": 8, "integrator": {}}


def check_lavd_parameters(parameters: dict, where: str = "lavd", key: str = "key") -> dict:
    """``parameters`` with the defaults filled and checked; a ConfigError naming the bad one."""
    unknown = sorted(set(parameters) - set(DEFAULTS))
    if unknown:
        raise ConfigError(f"{where}: unknown {key}s {unknown}; allowed are {sorted(DEFAULTS)}")
    checked = {**DEFAULTS, **parameters}

    def number(name, positive=True):
        value = checked[name]
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
                or (positive and value <= 0):
            raise ConfigError(f"{where}: {key} {name!r}: {value!r}; expected a finite number"
                              + (" > 0" if positive else ""))
        return float(value)

    if checked["duration"] is None:
        raise ConfigError(f"{where}: {key} 'duration' is required (the integration time T, negative: backward)")
    duration = checked["duration"]
    if isinstance(duration, bool) or not isinstance(duration, (int, float)) or not math.isfinite(duration) \
            or duration == 0:
        raise ConfigError(f"{where}: {key} 'duration': {duration!r}; expected a finite nonzero number")
    checked["duration"] = float(duration)
    if checked["interval"] is None:
        checked["interval"] = abs(checked["duration"]) / 100
    checked["interval"] = min(number("interval"), abs(checked["duration"]))
    checked["t0"] = number("t0", positive=False)
    checked["convexity_deficiency"] = number("convexity_deficiency")
    for name, low in (("levels", 2), ("min_points", 3)):
        value = checked[name]
        if isinstance(value, bool) or not isinstance(value, int) or value < low:
            raise ConfigError(f"{where}: {key} {name!r}: {value!r}; expected an integer of at least {low}")
    checked["integrator"] = checked_flow_settings(checked["integrator"], f"{where}: {key} 'integrator'")
    return checked


#: The step of the differences that take the velocity data interpolant's derivatives, as a
#: fraction of the grid's smallest cell: the interpolant is piecewise cubic and continuously
#: differentiable, so a central difference at this step is its derivative but for 1e-4 of a cell
#: times the second derivative's jump at a node it straddles, and rounding of 1e-12 of u per cell.
DATA_STEP = 1e-4


def is_lavd_velocity_data(system) -> bool:
    """Whether ``system`` is gridded velocity data whose vorticity :func:`data_vorticity` takes: on a
    regular or rectilinear grid, in the plane (x, y in the data's own units) or on the sphere
    (longitude, latitude in degrees; not a global grid through a pole, integrated as 3-D positions)."""
    from ...systems.velocity_data import CurvilinearVelocitySystem, PolarVelocitySystem, VelocityDataSystem

    return (isinstance(system, VelocityDataSystem)
            and not isinstance(system, (CurvilinearVelocitySystem, PolarVelocitySystem)) and system.n_state == 2)


def is_sphere_velocity_data(system) -> bool:
    """Whether ``system`` is velocity data on the sphere whose vorticity :func:`data_vorticity` takes."""
    return is_lavd_velocity_data(system) and system.source.sphere


def vorticity(system, states: np.ndarray, t: float, index: tuple[int, int]) -> np.ndarray:
    """The vorticity at each of ``states`` (k, n) and time ``t``, the plane's coordinates at
    ``index``: ∂v/∂x − ∂u/∂y from the system's Jacobian, or for velocity data from its
    interpolant (:func:`data_vorticity`)."""
    if is_lavd_velocity_data(system):
        return data_vorticity(system, states, t)
    i, k = index
    return np.array([(lambda jac: jac[k, i] - jac[i, k])(system.jacobian(state, t)) for state in states])


def data_vorticity(system, states: np.ndarray, t: float) -> np.ndarray:
    """The vorticity of a velocity data system's interpolant at ``states`` (k, 2) and time ``t``, by
    central differences at :data:`DATA_STEP` of the smallest cell (the data bound once), per time
    unit of the integration: on the plane ∂v/∂x − ∂u/∂y; on the sphere (states in degrees, the
    interpolant's rates in degrees per time unit) (1 / (R cos φ)) (∂v/∂λ − ∂(u cos φ)/∂φ), u, v
    the eastward and northward speeds in metres per time unit and λ, φ in radians."""
    cell = min(float(np.min(np.diff(system.source.axis_values(axis)))) for axis in ("x", "y"))
    step = DATA_STEP * cell
    sphere = system.source.sphere
    # on the sphere: metres of arc per degree, and the difference step in radians
    metres, h = (system.source.radius * math.pi / 180.0, math.radians(step)) if sphere else (1.0, step)
    states = np.asarray(states, dtype=float).reshape(-1, 2)
    x, y = states[:, 0], states[:, 1]
    # the stencil of every state at once: east, west, north, south of it
    stencil = np.empty((4, len(states), 2))
    stencil[:, :, 0], stencil[:, :, 1] = x, y
    stencil[0, :, 0] += step
    stencil[1, :, 0] -= step
    stencil[2, :, 1] += step
    stencil[3, :, 1] -= step
    rates = stencil_rates(system, stencil.reshape(-1, 2), float(t)).reshape(4, len(states), 2)
    v_east, v_west = rates[0, :, 1] * metres, rates[1, :, 1] * metres
    u_north, u_south = rates[2, :, 0] * metres, rates[3, :, 0] * metres
    if sphere:  # u cos(lat) north and south of the point: u = R cos(lat) d lon/dt on the sphere
        u_north = u_north * np.cos(np.radians(y + step)) ** 2
        u_south = u_south * np.cos(np.radians(y - step)) ** 2
    curl = (v_east - v_west - u_north + u_south) / (2 * h)
    return curl / (system.source.radius * np.cos(np.radians(y))) if sphere else curl


def stencil_rates(system, points: np.ndarray, t: float) -> np.ndarray:
    """The data interpolant's rates (k, 2) at ``points`` (k, 2) and time ``t``: the compiled
    kernel's ``rhs`` once a point, into rows of one array (no array made per call)."""
    points = np.ascontiguousarray(points, dtype=float)
    rates = np.empty_like(points)
    rhs = system.rhs
    with system.time_window(t, t):
        for row in range(len(points)):
            rhs(points[row], t, rates[row])
    return rates


def area_weights(system, states: np.ndarray) -> np.ndarray:
    """Each start point's weight in the region's mean vorticity: the area of its cell of the start
    grid, up to a common factor (module docstring): cos(latitude) on the sphere, 1 on the plane."""
    if is_sphere_velocity_data(system):
        return np.cos(np.radians(states[:, system.coordinates.index(system.source.y)]))
    return np.ones(len(states))


def lavd_field(system, axes, fixed: dict, parameters: dict, *, threads: int | None = None) -> dict[str, np.ndarray]:
    """The LAVD over the grid ``axes`` ((name, values) twice, the other coordinates at ``fixed``):
    ``lavd`` and ``defined`` (no particle of the grid stopped), each (n0, n1), and ``end`` (n0, n1,
    2) where each point is after the duration."""
    coordinates = list(system.coordinates)
    index = tuple(coordinates.index(name) for name, _ in axes)
    grid = np.meshgrid(*(np.asarray(values, float) for _, values in axes), indexing="ij")
    shape = grid[0].shape
    states = np.zeros((grid[0].size, len(coordinates)))
    for name, value in fixed.items():
        states[:, coordinates.index(name)] = float(value)
    states[:, index[0]], states[:, index[1]] = grid[0].ravel(), grid[1].ravel()
    settings = FlowSettings(**parameters["integrator"])
    duration, t0 = parameters["duration"], parameters["t0"]
    sign = 1.0 if duration > 0 else -1.0
    checks = max(1, math.ceil(abs(duration) / parameters["interval"] - 1e-9))
    times = t0 + sign * np.minimum(np.arange(checks + 1) * parameters["interval"], abs(duration))
    defined = np.ones(len(states), dtype=bool)
    previous = None
    total = np.zeros(len(states))
    weights = area_weights(system, states)
    for step in range(checks + 1):
        if step:
            moved = flow_map(system, states, times[step] - times[step - 1], settings, t0=times[step - 1],
                             threads=threads)
            states = moved.end_state
            defined &= moved.status == COMPLETED
        omega = vorticity(system, states, float(times[step]), index)
        mean = np.average(omega[defined], weights=weights[defined]) if defined.any() else 0.0
        deviation = np.abs(omega - mean)
        if previous is not None:
            total += 0.5 * (previous + deviation) * abs(times[step] - times[step - 1])
        previous = deviation
    return {"lavd": np.where(defined, total, 0.0).reshape(shape), "defined": defined.reshape(shape),
            "end": states[:, list(index)].reshape(*shape, 2)}


def _area(ring: np.ndarray) -> float:
    x, y = ring[:, 0], ring[:, 1]
    return 0.5 * abs(float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))


def _hull_area(points: np.ndarray) -> float:
    """The area of the convex hull of ``points`` (Andrew's monotone chain)."""
    pts = sorted(set(map(tuple, np.round(points, 15))))
    if len(pts) < 3:
        return 0.0

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower, upper = [], []
    for p in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    for p in reversed(pts):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    return _area(np.array(lower[:-1] + upper[:-1]))


def _inside(ring: np.ndarray, point) -> bool:
    """Whether ``point`` lies inside the closed polygon ``ring`` (even-odd rule)."""
    x, y = point
    xs, ys = ring[:, 0], ring[:, 1]
    xn, yn = np.roll(xs, -1), np.roll(ys, -1)
    crosses = (ys > y) != (yn > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        at = xs + (y - ys) * (xn - xs) / (yn - ys)
    return bool(np.count_nonzero(crosses & (x < at)) % 2)


def _maxima(field: np.ndarray, defined: np.ndarray) -> list[tuple[int, int]]:
    """Interior pixels above all eight neighbours, every one defined; the highest first."""
    n0, n1 = field.shape
    found = []
    for i in range(1, n0 - 1):
        for j in range(1, n1 - 1):
            block = field[i - 1:i + 2, j - 1:j + 2]
            if defined[i - 1:i + 2, j - 1:j + 2].all() and field[i, j] == block.max() \
                    and np.count_nonzero(block == field[i, j]) == 1:
                found.append((i, j))
    return sorted(found, key=lambda ij: -field[ij])


def _peak(field: np.ndarray, axes, i: int, j: int) -> tuple[float, float]:
    """The maximum to sub-pixel accuracy: the vertex of the quadratic through the 3 × 3 block."""
    f = field
    g = np.array([(f[i + 1, j] - f[i - 1, j]) / 2, (f[i, j + 1] - f[i, j - 1]) / 2])
    h = np.array([[f[i + 1, j] - 2 * f[i, j] + f[i - 1, j],
                   (f[i + 1, j + 1] - f[i + 1, j - 1] - f[i - 1, j + 1] + f[i - 1, j - 1]) / 4],
                  [0.0, f[i, j + 1] - 2 * f[i, j] + f[i, j - 1]]])
    h[1, 0] = h[0, 1]
    try:
        step = -np.linalg.solve(h, g)
    except np.linalg.LinAlgError:
        step = np.zeros(2)
    step = np.clip(step, -0.5, 0.5)
    return tuple(float(np.interp(index + s, np.arange(len(values)), values))
                 for index, s, values in zip((i, j), step, axes))


def vortex_plane(system, dims: tuple[str, str]):
    """Where a vortex's shape is measured (:func:`coherent_vortices`' ``plane``): on the sphere the
    equal-area projection about its centre, in km (the section's axes ``dims``, in either order);
    in the plane None (the section's own coordinates)."""
    radius = sphere_radius_km(system) if is_sphere_velocity_data(system) else None
    if radius is None:
        return None
    order = [dims.index(name) for name in system.coordinates[:2]]  # the (lon, lat) columns

    def plane(ring: np.ndarray, centre) -> np.ndarray:
        return tangent_plane(ring[:, order], np.asarray(centre, dtype=float)[order], radius)
    return plane


def coherent_vortices(field: np.ndarray, defined: np.ndarray, axes, parameters: dict, plane=None) -> list[dict]:
    """The rotationally coherent vortices of an LAVD field: for each maximum (highest first, none
    inside an earlier vortex), its ``centre``, ``boundary`` (m, 2, closed), ``level``, ``area`` and
    ``convexity_deficiency``; maxima with no acceptable contour are left out. ``plane(ring,
    centre)`` (:func:`vortex_plane`) maps a contour to where its area and convexity are measured
    (None: the axes' coordinates)."""
    import contourpy  # here: only the vortex search needs it

    coordinates = [np.asarray(values, float) for values in axes]
    masked = np.ma.masked_array(field, mask=~defined)
    generator = contourpy.contour_generator(coordinates[0], coordinates[1], masked.T,
                                            line_type=contourpy.LineType.Separate)
    low = float(field[defined].min())
    vortices = []
    for i, j in _maxima(field, defined):
        centre = _peak(field, coordinates, i, j)
        if any(_inside(v["boundary"], centre) for v in vortices):
            continue
        best = None
        for level in np.linspace(field[i, j], low, parameters["levels"] + 1)[1:-1]:
            rings = [ring for ring in generator.lines(level)
                     if len(ring) >= parameters["min_points"] and np.allclose(ring[0], ring[-1])
                     and _inside(ring, centre)]
            if not rings:
                if best is None:  # a contour too small to draw yet, next to the maximum
                    continue
                break
            flat = [ring if plane is None else plane(ring, centre) for ring in rings]
            inner = min(range(len(rings)), key=lambda k: _area(flat[k]))
            ring, area = rings[inner], _area(flat[inner])
            deficiency = (_hull_area(flat[inner]) - area) / area if area > 0 else math.inf
            if deficiency > parameters["convexity_deficiency"]:
                break
            best = {"centre": centre, "boundary": ring, "level": float(level), "area": area,
                    "convexity_deficiency": deficiency}
        if best is not None:
            vortices.append(best)
    return vortices


def lavd_dataset(system, section: dict, parameters: dict, *, threads: int | None = None, where: str = "lavd",
                 key: str = "key") -> xr.Dataset:
    """The LAVD file of ``system`` (a vector field with formulas, or velocity data on a regular or
    rectilinear grid, in the plane or on the sphere) over ``section`` (two axes, the other coordinates fixed): the
    field, and its coherent vortices as a CF contiguous ragged array (per vortex its boundary's
    points along ``point``, ``point_count``, centre, area, level and convexity deficiency)."""
    formulas = not system.hamiltonian and hasattr(system, "jacobian") and hasattr(system, "expressions")
    if not formulas and not is_lavd_velocity_data(system):
        raise ConfigError(f"{where}: system {system.name!r}: the LAVD takes the vorticity from a vector field's "
                          "formulas or from velocity data on a regular or rectilinear grid (in the plane, or "
                          "on the sphere short of a pole)")
    axes, fixed = section_grid(section, system.coordinates, where)
    parameters = check_lavd_parameters(dict(parameters), where, key)
    result = lavd_field(system, axes, fixed, parameters, threads=threads)
    values = [v for _, v in axes]
    dims = tuple(name for name, _ in axes)
    vortices = coherent_vortices(result["lavd"], result["defined"], values, parameters, vortex_plane(system, dims))
    boundary = np.concatenate([v["boundary"] for v in vortices]) if vortices else np.zeros((0, 2))
    per_vortex = lambda name: np.array([v[name] for v in vortices], dtype=float)  # noqa: E731
    area = per_vortex("area")  # where the shape is measured (vortex_plane): on the sphere equal-area, km2
    if is_sphere_velocity_data(system):
        area_attributes = {"long_name": "area on the sphere inside the boundary, at t0", "units": "km2"}
    else:
        area_attributes = {"long_name": "area inside the boundary, at t0"}
    centres = np.array([v["centre"] for v in vortices]).reshape(-1, 2)
    if len(centres):
        fixed_columns = {name: np.full(len(centres), float(value)) for name, value in fixed.items()}
        starts = np.zeros((len(centres), len(system.coordinates)))
        for name, column in fixed_columns.items():
            starts[:, system.coordinates.index(name)] = column
        for k, name in enumerate(dims):
            starts[:, system.coordinates.index(name)] = centres[:, k]
        ends = flow_map(system, starts, parameters["duration"], FlowSettings(**parameters["integrator"]),
                        t0=parameters["t0"], threads=threads).end_state
        centre_end = ends[:, [system.coordinates.index(name) for name in dims]]
    else:
        centre_end = np.zeros((0, 2))
    variables = {
        "lavd": (dims, result["lavd"], {"long_name": "Lagrangian-averaged vorticity deviation",
                                        "units": "vorticity * time",
                                        "comment": "integral of |vorticity - its mean over the particles| along the "
                                                   "trajectory; 0 where not defined (see lavd_defined)"}),
        "lavd_defined": (dims, result["defined"], {"long_name": "the trajectory ran the whole duration"}),
        f"boundary_{dims[0]}": (("point",), boundary[:, 0], {"long_name": f"{dims[0]} of the vortex boundary"}),
        f"boundary_{dims[1]}": (("point",), boundary[:, 1], {"long_name": f"{dims[1]} of the vortex boundary"}),
        "point_count": (("vortex",), np.array([len(v["boundary"]) for v in vortices], dtype=np.int64),
                        {"long_name": "points of the vortex boundary (closed: the last repeats the first)",
                         "sample_dimension": "point"}),
        f"centre_{dims[0]}": (("vortex",), centres[:, 0], {"long_name": f"{dims[0]} of the LAVD maximum, at t0"}),
        f"centre_{dims[1]}": (("vortex",), centres[:, 1], {"long_name": f"{dims[1]} of the LAVD maximum, at t0"}),
        f"centre_end_{dims[0]}": (("vortex",), centre_end[:, 0], {"long_name": f"{dims[0]} of the centre advected "
                                                                               "to t0 + duration"}),
        f"centre_end_{dims[1]}": (("vortex",), centre_end[:, 1], {"long_name": f"{dims[1]} of the centre advected "
                                                                               "to t0 + duration"}),
        "area": (("vortex",), area.reshape(-1), area_attributes),
        "level": (("vortex",), per_vortex("level"), {"long_name": "the LAVD on the boundary"}),
        "convexity_deficiency": (("vortex",), per_vortex("convexity_deficiency"), {
            "long_name": "(convex hull area - area) / area of the boundary, "
                         + ("in the Lambert azimuthal equal-area projection about the centre"
                            if is_sphere_velocity_data(system) else "in the section's coordinates")}),
    }
    dataset = xr.Dataset(variables, coords={name: values for name, values in axes})
    dataset.attrs.update({"system": system.name, "axes": " ".join(dims),
                          **{k: v for k, v in parameters.items() if k != "integrator"},
                          **FlowSettings(**parameters["integrator"]).__dict__})
    return stage_dataset(dataset, stage=LAVD, title=f"LAVD of {system.name}", parameters={**parameters,
                                                                                        "section": section})
