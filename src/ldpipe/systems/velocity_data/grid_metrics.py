"""A C-grid's metrics: the faces' lengths and the cells' areas, from the model's file or the coordinates.

A C-grid's u is the velocity normal to its face (the flux through the face per unit of its
length), and the ocean models' own continuity is written with their metrics: ROMS and CROCO
``pm pn [(u on_u)_e - (u on_u)_w + (v om_v)_n - (v om_v)_s]`` with ``on_u = 2 / (pn_i + pn_i+1)``,
NEMO ``[(e2u u)_e - (e2u u)_w + (e1v v)_n - (e1v v)_s] / (e1t e2t)``, MITgcm the same with
``dyG``, ``dxG`` and ``rA``. So a face carries the flux F = u L (L its length), and a cell the
area A; in the grid's indices the velocity across the cell is dI/dt = F / A. With F linear
across a cell between its two faces (as the kernel interpolates) and one A per cell, a corner
streamfunction psi whose differences are the fluxes (F = -(psi_top - psi_bottom) on a u face,
psi_east - psi_west on a v face) has its bilinear interpolant conserved on every trajectory:
in the cell's local coordinates a, b (0 .. 1), dPsi/dt = (Psi_a F_v(b) + Psi_b F_u(a)) / A, and
Psi_b = -F_u(a), Psi_a = F_v(b) for the bilinear Psi, so dPsi/dt = 0.

Where the file gives no metrics the conversion is the one from the coordinates, per face:
U = u / (L_c sin theta), L_c the distance between the two centres the face separates (great-circle
metres on the sphere) and theta the angle between that line and the face (the face's direction
being the grid's j direction there). That is the contravariant component from the face-normal
one: with e_i, e_j the grid's index vectors, u = U e_i . n + V e_j . n = U |e_i x e_j| / |e_j|,
so U = u |e_j| / |e_i x e_j| = u / (|e_i| sin theta); on an orthogonal grid (sin theta = 1) it
is u / L_c, as before. With the file's metrics the cell's area is dx dy sin theta at its centre
(the models' grids are orthogonal: dx dy), or the file's ``area``.

The file's metrics are found by their model's names (:data:`MODEL_METRICS`) or named in the
entry's ``metrics`` block, read with their units (a length, or ROMS's inverse length ``pm``,
``pn``; an area), and checked against the coordinates' own lengths: one that differs by more than
the entry's ``metric_tolerance`` (relative, default :data:`METRIC_TOLERANCE`) is refused, naming
the variable (a metric in other units than it says, or of another grid), as are missing and
non-positive values.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np
import xarray as xr

from ...errors import ConfigError
from .grid_geometry import GridGeometry

#: What each model calls its metrics (the roles of :data:`METRIC_ROLES`), looked for in this order
#: when the entry names none: the first model whose ``dx`` and ``dy`` the file holds.
MODEL_METRICS = {
    "ROMS/CROCO": {"dx": "pm", "dy": "pn"},
    "NEMO": {"dx": "e1t", "dy": "e2t", "u_face": "e2u", "v_face": "e1v"},
    "MITgcm": {"dx": "dxF", "dy": "dyF", "u_face": "dyG", "v_face": "dxG", "area": "rA"},
}
#: The roles: the cells' lengths along i and j at their centres (or their inverses, ROMS's pm, pn),
#: the u faces' lengths (along j) and the v faces' (along i), the cells' areas.
METRIC_ROLES = ("dx", "dy", "u_face", "v_face", "area")
#: The entry's ``metrics`` value that computes them from the coordinates whatever the file holds.
FROM_COORDINATES = "coordinates"
#: The largest relative difference between a file's metric and the coordinates' length before the
#: metric is refused (a model's own metric differs by a few per cent on a stretched grid; one in
#: other units, or of a grid twice as coarse, by far more).
METRIC_TOLERANCE = 0.1
LENGTH_UNITS = {"m": 1.0, "meter": 1.0, "metre": 1.0, "meters": 1.0, "metres": 1.0, "km": 1000.0,
                "kilometer": 1000.0, "kilometre": 1000.0, "cm": 0.01}


def metric_units(units: str | None) -> tuple[float, int] | None:
    """(metres per unit of length, power) of a metric's ``units``: ``m`` (1), ``1/m``, ``m-1``,
    ``meter-1`` (-1), ``m2``, ``m^2`` (2); None if not understood."""
    text = str(units or "").strip().lower().replace("**", "^").replace(" ", "")
    match = re.fullmatch(r"1/([a-z]+)", text)
    if match:
        unit, power = match.group(1), -1
    else:
        match = re.fullmatch(r"([a-z]+)\^?(-?[12])?", text)
        if not match:
            return None
        unit, power = match.group(1), int(match.group(2) or 1)
    return (LENGTH_UNITS[unit], power) if unit in LENGTH_UNITS else None


def metric_variables(entry: dict, dataset: xr.Dataset, centres: tuple[str, ...], staggered: str,
                     key: str) -> tuple[tuple[str, str, float, int], ...]:
    """The metric variables a C-grid is read with, checked as to presence, shape and units: (role,
    variable, metres per unit, power) for each role given; empty if the entry says ``metrics:
    coordinates`` or neither it nor the file (by :data:`MODEL_METRICS`) gives any. ``centres``:
    the coordinates' dims; ``staggered``: the layout (:func:`.source.c_grid`; "" collocated)."""
    given = entry.get("metrics")
    if given == FROM_COORDINATES:
        return ()
    if given is not None and not staggered:
        raise ConfigError(f"config key '{key}.metrics': a model's metrics are read on a C-grid (u and v on the "
                          "cells' faces); on a collocated grid the index velocities come from the coordinates' own "
                          "metric, the one that maps trajectories back to coordinates: give metrics: coordinates "
                          "or leave the key out")
    if not staggered:
        return ()
    if given is None:
        names = next((model for model in MODEL_METRICS.values()
                      if model["dx"] in dataset.variables and model["dy"] in dataset.variables), {})
        names = {role: name for role, name in names.items() if name in dataset.variables}
    elif isinstance(given, dict) and {"dx", "dy"} <= set(given) and set(given) <= set(METRIC_ROLES):
        names = dict(given)
    else:
        raise ConfigError(f"config key '{key}.metrics': expected {FROM_COORDINATES!r} or a mapping of the roles "
                          f"{list(METRIC_ROLES)} to variables, dx and dy required; got {given!r}")
    ny, nx = (dataset.sizes[d] for d in centres)
    outer = 1 if staggered == "nemo" else 0
    shapes = {"dx": (ny, nx), "dy": (ny, nx), "area": (ny, nx), "u_face": (ny, nx - 1 + outer),
              "v_face": (ny - 1 + outer, nx)}
    found = []
    for role, name in names.items():
        where = f"{key}.metrics.{role}" if given else f"{key}.metrics"
        if name not in dataset.variables:
            raise ConfigError(f"config key '{where}': variable {name!r} not in the file (it has "
                              f"{sorted(map(str, dataset.variables))})")
        variable = dataset[name]
        if variable.shape != shapes[role] or variable.dtype.kind not in "iuf":
            raise ConfigError(f"config key '{where}': metric {name!r} ({role}) is {variable.ndim}-D {variable.dtype} "
                              f"of shape {variable.shape}; expected numbers of shape {shapes[role]} (the "
                              f"{'u faces' if role == 'u_face' else 'v faces' if role == 'v_face' else 'centres'}; "
                              f"metrics: {FROM_COORDINATES} computes them from the coordinates instead)")
        read = metric_units(variable.attrs.get("units"))
        powers = (2,) if role == "area" else (1, -1)
        if read is None or read[1] not in powers:
            wanted = "an area, e.g. 'm2'" if role == "area" else "a length ('m', 'km') or its inverse ('1/m', 'm-1')"
            raise ConfigError(f"config key '{where}': metric {name!r} ({role}) has units "
                              f"{variable.attrs.get('units')!r}; expected {wanted} (if the file leaves them out, "
                              f"set them with xarray, e.g. ds[{name!r}].attrs['units'] = "
                              f"{'m2' if role == 'area' else '1/m' if name in ('pm', 'pn') else 'm'!r})")
        found.append((role, name, read[0], read[1]))
    return tuple(found)


@dataclass(frozen=True)
class FaceConversion:
    """How a C-grid's face velocities become index velocities: U = u * velocity_scale / u_divisor
    on the u faces (V likewise), times the cell's ``cell_scale`` where it is read (the kernel)."""

    u_divisor: np.ndarray  # (ny, nx - 1)
    v_divisor: np.ndarray  # (ny - 1, nx)
    cell_scale: np.ndarray  # (ny, nx): 1 / the cell's area with the file's metrics, else 1
    metrics: str  # the variables read, "" from the coordinates


def physical_vectors(geometry: GridGeometry, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """The grid's index vectors e_i, e_j at the nodes, (ny, nx, 2) each: in the coordinates' units on
    the plane, in metres east and north on the sphere."""
    jacobian = geometry.jacobian.copy()
    if geometry.sphere:
        metres = radius * math.pi / 180.0
        jacobian[..., 0, :] *= (metres * np.cos(np.radians(geometry.y)))[..., None]
        jacobian[..., 1, :] *= metres
    return jacobian[..., 0], jacobian[..., 1]


def centre_steps(geometry: GridGeometry, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """The vectors from each centre to its neighbour along i, (ny, nx - 1, 2), and along j,
    (ny - 1, nx, 2), in the units of :func:`physical_vectors` (on the sphere east and north at the
    midpoint: only their directions are used)."""
    x, y = geometry.x, geometry.y

    def step(x0, y0, x1, y1):
        if not geometry.sphere:
            return np.stack([x1 - x0, y1 - y0], axis=-1)
        metres = radius * math.pi / 180.0
        return np.stack([(x1 - x0) * np.cos(np.radians((y0 + y1) / 2)) * metres, (y1 - y0) * metres], axis=-1)

    return step(x[:, :-1], y[:, :-1], x[:, 1:], y[:, 1:]), step(x[:-1], y[:-1], x[1:], y[1:])


def sine_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The sine of the angle between vectors a and b (last axis 2), as sqrt(1 - cos^2): exactly 1
    where they are at right angles to rounding (cos^2 below half an ulp of 1)."""
    cosine = (a * b).sum(-1) / (np.linalg.norm(a, axis=-1) * np.linalg.norm(b, axis=-1))
    return np.sqrt(np.maximum(1.0 - cosine * cosine, 0.0))


def face_conversion(source, geometry: GridGeometry, along_i: np.ndarray, along_j: np.ndarray) -> FaceConversion:
    """The face conversion (module docstring) of a checked C-grid ``source``, a
    :class:`.source.DataSource` (not annotated: that module imports this one): from the file's
    metrics, read and checked here, if it gives them, else from the coordinates (``along_i``,
    ``along_j``: the distances between neighbouring centres, :func:`.staggered.face_lengths`)."""
    e_i, e_j = physical_vectors(geometry, source.radius)
    step_i, step_j = centre_steps(geometry, source.radius)
    face_j = (e_j[:, :-1] + e_j[:, 1:]) / 2  # the u faces' direction: the grid's j direction there
    face_i = (e_i[:-1] + e_i[1:]) / 2
    if not source.metrics:
        return FaceConversion(along_i * sine_between(step_i, face_j), along_j * sine_between(step_j, face_i),
                              np.ones(geometry.shape), "")
    values = read_metrics(source, geometry)
    length = {"dx": np.linalg.norm(e_i, axis=-1), "dy": np.linalg.norm(e_j, axis=-1),
              "u_face": np.linalg.norm(face_j, axis=-1), "v_face": np.linalg.norm(face_i, axis=-1),
              "area": np.abs(e_i[..., 0] * e_j[..., 1] - e_i[..., 1] * e_j[..., 0])}
    names = {role: name for role, name, _, _ in source.metrics}
    for role, value in values.items():
        check_metric(source, names[role], role, value, length[role], geometry.offset)
    dx, dy = values["dx"], values["dy"]
    # ROMS's face lengths from pn, pm: on_u = 2 / (pn_i + pn_i+1), om_v = 2 / (pm_j + pm_j+1)
    u_face = values.get("u_face", 2.0 / (1.0 / dy[:, :-1] + 1.0 / dy[:, 1:]))
    v_face = values.get("v_face", 2.0 / (1.0 / dx[:-1] + 1.0 / dx[1:]))
    area = values.get("area", dx * dy * sine_between(e_i, e_j))
    return FaceConversion(1.0 / u_face, 1.0 / v_face, 1.0 / area, ", ".join(f"{role}: {name}"
                                                                           for role, name in names.items()))


def read_metrics(source, geometry: GridGeometry) -> dict[str, np.ndarray]:
    """The file's metrics by role over the geometry's nodes (the whole grid, or a window's box and
    margin: the centres there, the faces between them), in the coordinates' length units (metres
    on the sphere): a ConfigError names a variable with missing or non-positive values."""
    (i0, j0), (ny, nx) = geometry.offset, geometry.shape
    # NEMO's outer faces (east of the last column, north of the last row) are never among them
    extent = {"u_face": (ny, nx - 1), "v_face": (ny - 1, nx)}
    out = {}
    with source.open() as dataset:
        for role, name, metres, power in source.metrics:
            rows, columns = extent.get(role, (ny, nx))
            y, x = dataset.dataset(0)[name].dims
            values = np.asarray(dataset.read(name, {y: slice(j0, j0 + rows), x: slice(i0, i0 + columns)}), dtype=float)
            bad = ~(np.isfinite(values) & (values > 0.0))
            if bad.any():
                j, i = (int(k) for k in np.argwhere(bad)[0])
                raise ConfigError(f"velocity data {source.label}: metric {name!r} ({role}) has {int(bad.sum())} "
                                  f"missing or non-positive values (the first {float(values[j, i]):g} at index "
                                  f"{(j + j0, i + i0)}); every cell needs its metrics, land too")
            values = values * (metres / source.coordinate_metres) ** power  # the coordinates' length units
            out[role] = 1.0 / values if power < 0 else values
    return out


def check_metric(source, name: str, role: str, value: np.ndarray, coordinates: np.ndarray,
                 offset: tuple[int, int]) -> None:
    """A ConfigError naming ``name`` if it differs from the coordinates' length (or area) by more than
    the source's ``metric_tolerance``, relative (``offset``: the whole grid's (i, j) of the values' first)."""
    ratio = value / coordinates
    worst = np.abs(ratio - 1.0)
    if not worst.max() > source.metric_tolerance:
        return
    j, i = np.unravel_index(int(np.argmax(worst)), worst.shape)
    what = "area" if role == "area" else "length"
    raise ConfigError(f"velocity data {source.label}: metric {name!r} ({role}) gives a {what} of {value[j, i]:.6g} at "
                      f"(j, i) = ({j + offset[1]}, {i + offset[0]}), where the grid's coordinates give {coordinates[j, i]:.6g} (ratio "
                      f"{ratio[j, i]:.4g}, beyond metric_tolerance {source.metric_tolerance:g}): is it in other units "
                      f"than its units attribute says, or of another grid? (metrics: {FROM_COORDINATES} ignores the "
                      "file's)")
