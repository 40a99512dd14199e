"""Velocity fields known exactly, written on curvilinear grids (2-D coordinates) as CF netCDF.

The double gyre of Shadden, Lekien & Marsden (2005, Physica D 212, 271, eq. 9; A = 0.1,
eps = 0.25, omega = 2 pi / 10) on [0, 2] x [0, 1], sampled on a plane grid that is ``regular``
(x, y aligned with i, j), ``rotated`` (by :data:`ROTATION` about the domain's centre) or
``curvilinear`` (the rotated grid bent smoothly: x = a + d sin(k b), y = b + d sin(k a) before
the rotation, a and b even in i and j; its cells not right-angled) or ``conformal`` (the rotated
grid bent by the conformal map x + iy = w + d sin(k w), w = a + ib: orthogonal, as the grids of
ROMS, CROCO and NEMO are, and curved). The grid covers the domain with a margin, so the
interpolant's stencil at the domain's edge stays inside the data.

:func:`curvilinear_dataset` writes any field ``field(x, y, t) -> (u, v)`` on given 2-D
coordinates: u and v on (time, eta, xi) with CF's ``coordinates`` attribute naming the 2-D
``x_rho``/``y_rho`` (``lon_rho``/``lat_rho`` on the sphere), their components geographic (x and
y; east and north) or along the grid's i and j (``grid``, ROMS's convention), the rotation
angle optionally written (``angle``, radians from east to i).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import xarray as xr

from ..io.atomic import atomic_path

A, EPS, OMEGA = 0.1, 0.25, 2 * math.pi / 10
ROTATION = math.radians(30.0)
BEND, BEND_WAVENUMBER = 0.08, 2.0  # d and k of the curvilinear grid (d k < 1: no cell folds)
#: d and k of the conformal grid: |d k cos(k w)| <= d k cosh(k b) < 0.2 over the grid, so the map's
#: derivative never vanishes (no cell folds) and the cells stay within a factor 1.2 of square.
CONFORMAL_BEND, CONFORMAL_WAVENUMBER = 0.06, 1.2
#: The grid's half-extents about the domain's centre (1, 0.5), in its own (a, b) frame: the rotated
#: domain [0, 2] x [0, 1] with a margin of 0.1, and the bend's amplitude.
HALF_EXTENT = (1.4, 1.2)
GRIDS = ("regular", "rotated", "curvilinear", "conformal")


def double_gyre_velocity(x, y, t):
    """(u, v) of the double gyre at points x, y (arrays broadcasting together) and time t."""
    a = EPS * np.sin(OMEGA * t)
    f = a * x**2 + (1 - 2 * a) * x
    dfdx = 2 * a * x + 1 - 2 * a
    return -np.pi * A * np.sin(np.pi * f) * np.cos(np.pi * y), np.pi * A * np.cos(np.pi * f) * np.sin(np.pi * y) * dfdx


def plane_grid(kind: str, spacing: float, offset: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """The 2-D coordinates (x, y), each (eta, xi), of a grid of ``kind`` (:data:`GRIDS`) whose
    (a, b) frame has nodes every ``spacing`` (see the module docstring); with ``offset`` 0.5 the
    corners of its cells instead (a C-grid's psi points: one fewer each way, every node shifted
    by half a spacing in a and b)."""
    if kind not in GRIDS:
        raise ValueError(f"kind: expected one of {GRIDS}, got {kind!r}")
    counts = [round(2 * half / spacing) + 1 - math.ceil(offset) for half in HALF_EXTENT]
    a = -HALF_EXTENT[0] + spacing * (offset + np.arange(counts[0]))
    b = -HALF_EXTENT[1] + spacing * (offset + np.arange(counts[1]))
    B, Aa = np.meshgrid(b, a, indexing="ij")
    if kind == "curvilinear":
        Aa, B = Aa + BEND * np.sin(BEND_WAVENUMBER * B), B + BEND * np.sin(BEND_WAVENUMBER * Aa)
    elif kind == "conformal":
        bent = Aa + 1j * B + CONFORMAL_BEND * np.sin(CONFORMAL_WAVENUMBER * (Aa + 1j * B))
        Aa, B = bent.real, bent.imag
    angle = 0.0 if kind == "regular" else ROTATION
    return (1.0 + math.cos(angle) * Aa - math.sin(angle) * B, 0.5 + math.sin(angle) * Aa + math.cos(angle) * B)


def grid_angle(x: np.ndarray, y: np.ndarray, sphere: bool = False) -> np.ndarray:
    """The angle (radians, counter-clockwise from east, from x on the plane) of the grid's i
    direction at each node, by centred differences of the coordinates (one-sided at the edges)."""
    dx, dy = np.gradient(np.asarray(x, dtype=float), axis=1), np.gradient(np.asarray(y, dtype=float), axis=1)
    if sphere:
        dx = dx * np.cos(np.radians(y))
    return np.arctan2(dy, dx)


def curvilinear_dataset(field, x: np.ndarray, y: np.ndarray, times: np.ndarray, *, sphere: bool = False,
                        components: str = "geographic", angle: np.ndarray | None = None,
                        write_angle: bool = False, time_units: str = "s") -> xr.Dataset:
    """``field(x, y, t) -> (u, v)`` (geographic components, m/s) at the nodes (x, y) and ``times``
    as a CF Dataset on a curvilinear grid (module docstring). With ``components="grid"`` u, v are
    turned onto the grid's i, j by ``angle`` (default :func:`grid_angle`), written as ``angle``
    (radians) if ``write_angle``."""
    T = np.asarray(times, dtype=float)[:, None, None]
    u, v = (np.broadcast_to(c, T.shape[:1] + x.shape).astype(float) for c in field(x[None], y[None], T))
    if components == "grid":
        theta = grid_angle(x, y, sphere) if angle is None else angle
        u, v = u * np.cos(theta) + v * np.sin(theta), -u * np.sin(theta) + v * np.cos(theta)
    elif components != "geographic":
        raise ValueError(f"components: expected 'geographic' or 'grid', got {components!r}")
    names = ("lon_rho", "lat_rho") if sphere else ("x_rho", "y_rho")
    if sphere:
        coordinate_attrs = ({"units": "degrees_east", "standard_name": "longitude"},
                            {"units": "degrees_north", "standard_name": "latitude"})
    else:
        coordinate_attrs = ({"standard_name": "projection_x_coordinate"}, {"standard_name": "projection_y_coordinate"})
    dims = ("time", "eta", "xi")
    velocity_attrs = {"units": "m/s", "coordinates": " ".join(names)}
    variables = {"u": (dims, u, dict(velocity_attrs)), "v": (dims, v, dict(velocity_attrs))}
    if components == "geographic" and sphere:
        variables["u"][2]["standard_name"] = "eastward_sea_water_velocity"
        variables["v"][2]["standard_name"] = "northward_sea_water_velocity"
    if write_angle:
        variables["angle"] = (dims[1:], grid_angle(x, y, sphere) if angle is None else angle,
                              {"units": "radians", "long_name": "angle from east to the grid's i direction"})
    coords = {names[0]: (dims[1:], x, coordinate_attrs[0]), names[1]: (dims[1:], y, coordinate_attrs[1]),
              "time": ("time", np.asarray(times, dtype=float), {"units": time_units})}
    return xr.Dataset(variables, coords=coords, attrs={"Conventions": "CF-1.8",
                                                       "source": "ldpipe.data.curvilinear (analytic)"})


def double_gyre_dataset(kind: str, spacing: float, times: np.ndarray, **options) -> xr.Dataset:
    """The double gyre on a plane grid of ``kind`` with ``spacing`` at ``times`` (module docstring)."""
    x, y = plane_grid(kind, spacing)
    return curvilinear_dataset(double_gyre_velocity, x, y, times, **options)


def double_gyre_c_grid_dataset(kind: str, spacing: float, times: np.ndarray, *, land=None) -> xr.Dataset:
    """The double gyre on a plane grid of ``kind`` with ``spacing`` as a ROMS-like C-grid
    (:func:`c_grid_dataset`, the cells' corners written too): on each face the velocity's
    component along the line between the two centres it separates (the face's normal, on an
    orthogonal grid such as ``conformal``), at the line's midpoint; ``land`` as there."""
    x, y = plane_grid(kind, spacing)
    along_i = np.arctan2(np.diff(y, axis=1), np.diff(x, axis=1))
    along_j = np.arctan2(np.diff(y, axis=0), np.diff(x, axis=0))

    def component(angle):
        def face(X, Y, T):
            u, v = double_gyre_velocity(X, Y, T)
            return u * np.cos(angle) + v * np.sin(angle)
        return face

    return c_grid_dataset(component(along_i), component(along_j), x, y, times, land=land,
                          corners=plane_grid(kind, spacing, offset=0.5))


def write_dataset(dataset: xr.Dataset, path: str | Path) -> Path:
    """Write ``dataset`` to ``path`` (netCDF), atomically."""
    path = Path(path)
    with atomic_path(path) as temporary:
        dataset.to_netcdf(temporary)
    return path


def rotated_pole_grid(half_extent: tuple[float, float], spacing: float, tilt: float) -> tuple[np.ndarray, np.ndarray]:
    """Longitudes and latitudes (degrees, each (eta, xi)) of a grid even in a rotated frame: nodes
    every ``spacing`` degrees over [-half, half] of the frame's longitude and latitude, the frame
    turned by ``tilt`` degrees about the axis through (lon 90, lat 0) (its equator's centre then at
    (0, -tilt)); its i direction turns against east from node to node."""
    lam = np.radians(np.arange(-half_extent[0], half_extent[0] + spacing / 2, spacing))
    phi = np.radians(np.arange(-half_extent[1], half_extent[1] + spacing / 2, spacing))
    PHI, LAM = np.meshgrid(phi, lam, indexing="ij")
    r = np.array([np.cos(PHI) * np.cos(LAM), np.cos(PHI) * np.sin(LAM), np.sin(PHI)])
    b = math.radians(tilt)
    x, z = math.cos(b) * r[0] + math.sin(b) * r[2], -math.sin(b) * r[0] + math.cos(b) * r[2]
    return np.degrees(np.arctan2(r[1], x)), np.degrees(np.arcsin(np.clip(z, -1.0, 1.0)))


def c_grid_dataset(u_face, v_face, x: np.ndarray, y: np.ndarray, times: np.ndarray, *, land=None,
                   land_faces: str = "zero", sphere: bool = False,
                   corners: tuple[np.ndarray, np.ndarray] | None = None) -> xr.Dataset:
    """An Arakawa C-grid (ROMS's layout): the cells' centres (x, y), each (eta, xi), ``x_rho``/
    ``y_rho`` on the plane, ``lon_rho``/``lat_rho`` (degrees) on the ``sphere``; u on the faces between centres (j, i) and (j, i + 1), (time, eta, xi_u),
    and v on those between (j, i) and (j + 1, i), (time, eta_v, xi), the velocities normal to the
    faces (along the grid's i and j), ``u_face(xm, ym, t)`` and ``v_face(xm, ym, t)`` at the
    faces' midpoints; ``land(i, j)`` (node indices) True at land centres, ``mask_rho`` 0 there
    and the faces by them 0 (``land_faces="zero"``, as ROMS writes them), or left as the field
    gives them for u and missing for v (``"unmasked"``: only the mask and the missing values say
    where the coast is). ``corners`` (x, y), each (eta - 1, xi - 1), are the cells' corners
    (ROMS's psi points, :func:`plane_grid` with offset 0.5), written as ``x_psi``/``y_psi``
    (``lon_psi``/``lat_psi``) on (eta_psi, xi_psi): trackers that interpolate a C-grid in cells
    bounded by its corners (Parcels) need them."""
    T = np.asarray(times, dtype=float)[:, None, None]
    xu, yu = (x[:, :-1] + x[:, 1:]) / 2, (y[:, :-1] + y[:, 1:]) / 2
    xv, yv = (x[:-1] + x[1:]) / 2, (y[:-1] + y[1:]) / 2
    u = np.broadcast_to(u_face(xu[None], yu[None], T), T.shape[:1] + xu.shape).astype(float)
    v = np.broadcast_to(v_face(xv[None], yv[None], T), T.shape[:1] + xv.shape).astype(float)
    J, I = np.meshgrid(np.arange(x.shape[0]), np.arange(x.shape[1]), indexing="ij")
    water = np.ones(x.shape, dtype=bool) if land is None else ~np.asarray(land(I, J), dtype=bool)
    if land_faces == "zero":
        u = u * (water[:, :-1] & water[:, 1:])
        v = v * (water[:-1] & water[1:])
    elif land_faces == "unmasked":
        v = np.where(water[:-1] & water[1:], v, np.nan)
    else:
        raise ValueError(f"land_faces: expected 'zero' or 'unmasked', got {land_faces!r}")
    attrs = {"units": "m/s"}
    names = ("lon", "lat") if sphere else ("x", "y")
    coordinate_attrs = ({"units": "degrees_east"}, {"units": "degrees_north"}) if sphere else (
        {"standard_name": "projection_x_coordinate"}, {"standard_name": "projection_y_coordinate"})
    coords = {f"{names[0]}_rho": (("eta", "xi"), x, coordinate_attrs[0]),
              f"{names[1]}_rho": (("eta", "xi"), y, coordinate_attrs[1]),
              "time": ("time", np.asarray(times, dtype=float), {"units": "s"})}
    if corners is not None:
        if any(np.shape(c) != (x.shape[0] - 1, x.shape[1] - 1) for c in corners):
            raise ValueError(f"corners: expected two arrays of shape {(x.shape[0] - 1, x.shape[1] - 1)}")
        for name, values, attributes in zip(names, corners, coordinate_attrs):
            coords[f"{name}_psi"] = (("eta_psi", "xi_psi"), np.asarray(values, dtype=float), dict(attributes))
    return xr.Dataset(
        {"u": (("time", "eta", "xi_u"), u, dict(attrs, long_name="velocity along the grid's i, on its faces")),
         "v": (("time", "eta_v", "xi"), v, dict(attrs, long_name="velocity along the grid's j, on its faces")),
         "mask_rho": (("eta", "xi"), water.astype(float), {"long_name": "1 at sea, 0 on land"})},
        coords=coords, attrs={"Conventions": "CF-1.8", "source": "ldpipe.data.curvilinear (analytic, Arakawa C-grid)"})
