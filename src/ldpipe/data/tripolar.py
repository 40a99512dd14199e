"""A tripolar global grid (ORCA-like) with a velocity field known exactly, as CF netCDF.

South of the fold latitude phi0 the grid is a regular longitude–latitude grid; north of it a
bipolar cap (Murray 1996, J. Comput. Phys. 126, 251) whose two poles lie on the circle phi0 at
longitudes 0 and 180 (where an ocean model puts land), so the geographic North Pole is an
ordinary point of the grid. In the stereographic plane of the North Pole, w = tan((90 - lat) / 2)
e^(i lon), the circle phi0 is |w| = a, and the bipolar coordinates zeta = sigma + i tau of
w = i a cot(zeta / 2) (foci w = +-a) are orthogonal, as the stereographic map is conformal: the
cap's rows are the arcs sigma = pi/2 (the circle phi0) .. pi (the segment between the foci, through
the pole), its columns the arcs tau = const, the column of longitude lon on the circle phi0 at the
tau that puts it there (lon in (0, 180); the other half of the ring the same turned by 180
degrees). The last row is the **north fold**: the node of column i is the node of column
n - 1 - i, the row traversed twice, and along it the grid's i and j directions of the two
columns are opposite (a velocity's grid components change sign across it). Or (``last_row="mirror"``,
NEMO's F-point pivot) the cap's rows stop half a row short of the fold and a last row mirrors the
one below it.

:func:`tripolar_grid` gives the coordinates; :func:`tripolar_dataset` a field on them, written by
:func:`ldpipe.data.curvilinear.curvilinear_dataset` (``nav_lon``/``nav_lat``, NEMO's names).
"""

from __future__ import annotations

import math

import numpy as np
import xarray as xr

from .curvilinear import curvilinear_dataset


def cap_nodes(lon: np.ndarray, fold_latitude: float, cap_rows: int, last_row: str = "fold"
              ) -> tuple[np.ndarray, np.ndarray]:
    """Longitudes and latitudes (degrees, (cap_rows + 1, len(lon))) of the cap's nodes of the
    columns that leave the circle ``fold_latitude`` at longitudes ``lon`` (module docstring); with
    ``last_row="mirror"`` the rows stop half a row short of the fold and the last is the mirror of
    the one below (NEMO's F-point pivot)."""
    a = math.tan(math.radians(90.0 - fold_latitude) / 2.0)
    on_poles = np.isclose(np.sin(np.radians(lon)), 0.0, atol=1e-12)  # a column through a cap pole (T pivot)
    upper = np.where(lon > 0.0, lon, lon + 180.0)  # each column's partner in the half lon in (0, 180)
    upper = np.where(on_poles, 90.0, upper)  # (their nodes are set below)
    # i a cot(zeta / 2) = a e^(i lon) on the circle: tan(zeta / 2) = i e^(-i lon), sigma = pi / 2 there
    tau = (2.0 * np.arctan(1j * np.exp(-1j * np.radians(upper)))).imag
    if last_row not in ("fold", "mirror"):
        raise ValueError(f"last_row: expected 'fold' or 'mirror', got {last_row!r}")
    if last_row == "fold" or on_poles.any():  # the last row on the fold (a T pivot's mirrored row added below)
        sigma = 0.5 * np.pi * (1.0 + np.arange(cap_rows + 1) / cap_rows)
    else:  # half a row short of the fold
        sigma = 0.5 * np.pi * (1.0 + np.arange(cap_rows) / (cap_rows - 0.5))
    w = 1j * a / np.tan((sigma[:, None] + 1j * tau[None, :]) / 2.0)
    w = np.where(lon > 0.0, w, -w)  # the other half: turned by 180 degrees about the pole
    w[:, on_poles] = np.where(np.cos(np.radians(lon[on_poles])) > 0.0, a, -a)  # collapsed onto the cap's pole
    if last_row == "mirror" and on_poles.any():  # T pivot: node i of the last row is node n - i of the row below the fold
        w = np.vstack([w, w[-2, (len(lon) - np.arange(len(lon))) % len(lon)]])
    elif last_row == "mirror":  # F pivot: node i of the last row is node n - 1 - i of the row below
        w = np.vstack([w, w[-1, ::-1]])
    return np.degrees(np.angle(w)), 90.0 - 2.0 * np.degrees(np.arctan(np.abs(w)))


def column_longitudes(columns: int, pivot: str = "F") -> np.ndarray:
    """The columns' longitudes (an even number): -180 + (i + 1/2) 360 / columns, centred between
    the cap's poles (``pivot="F"``: the fold pairs column i with columns - 1 - i), or -180 + i 360 /
    columns, a column through each (``"T"``: the fold pairs i with columns - i)."""
    if columns % 2:
        raise ValueError(f"columns: expected an even number (the fold pairs its columns), got {columns}")
    if pivot not in ("F", "T"):
        raise ValueError(f"pivot: expected 'F' or 'T', got {pivot!r}")
    return -180.0 + (np.arange(columns) + (0.5 if pivot == "F" else 0.0)) * 360.0 / columns


def tripolar_grid(columns: int = 72, spacing: float = 5.0, fold_latitude: float = 60.0, cap_rows: int = 6,
                  south: float = -75.0, last_row: str = "fold", pivot: str = "F") -> tuple[np.ndarray, np.ndarray]:
    """Longitudes and latitudes (degrees, each (rows, columns)) of a tripolar grid (module
    docstring): ``columns`` longitudes -180 + (i + 1/2) 360 / columns (an even number), rows every
    ``spacing`` degrees from ``south`` up to the row below ``fold_latitude``, then ``cap_rows`` + 1
    rows of the cap from the circle ``fold_latitude`` to the fold (``last_row="fold"``), or
    ``cap_rows`` of them to half a row short of it and a last row mirroring the one below
    (``"mirror"``: NEMO's F-point pivot). With ``pivot="T"`` a column runs through each of the
    cap's poles (collapsed onto it in the cap) and the fold pairs column i with columns - i; its
    ``"mirror"`` layout adds after the fold a row mirroring the one below the fold (NEMO's T-point pivot)."""
    lon = column_longitudes(columns, pivot)
    count = round((fold_latitude - south) / spacing)
    rows = fold_latitude - spacing * np.arange(count, 0, -1)
    cap_lon, cap_lat = cap_nodes(lon, fold_latitude, cap_rows, last_row)
    longitudes = np.vstack([np.broadcast_to(lon, (count, columns)), cap_lon])
    latitudes = np.vstack([np.broadcast_to(rows[:, None], (count, columns)), cap_lat])
    return longitudes, latitudes


#: The step (degrees of the columns' longitude on the fold circle) of :func:`tripolar_angle`'s differences.
ANGLE_STEP = 1e-5


def tripolar_angle(columns: int = 72, spacing: float = 5.0, fold_latitude: float = 60.0, cap_rows: int = 6,
                   south: float = -75.0, last_row: str = "fold", pivot: str = "F") -> np.ndarray:
    """The angle (radians, counter-clockwise from east) of the grid's i direction at each node of
    :func:`tripolar_grid`: 0 south of the cap; in the cap the direction of the cap's map as its
    column moves along the circle, by centred differences of :data:`ANGLE_STEP` (rounding-level,
    a reference for the grid's own differences)."""
    if pivot != "F":
        raise ValueError("tripolar_angle: the grid's angle is given for pivot='F' (a T pivot's columns collapse "
                         "onto the cap's poles, where it has none)")
    lon, lat = tripolar_grid(columns, spacing, fold_latitude, cap_rows, south, last_row)
    angle = np.zeros(lon.shape)
    ahead = cap_nodes(lon[0] + ANGLE_STEP, fold_latitude, cap_rows, last_row)
    behind = cap_nodes(lon[0] - ANGLE_STEP, fold_latitude, cap_rows, last_row)
    lam, phi = np.radians(lon[-cap_rows - 1:]), np.radians(lat[-cap_rows - 1:])

    def unit(pair):
        a, b = np.radians(pair[0]), np.radians(pair[1])
        return np.stack([np.cos(b) * np.cos(a), np.cos(b) * np.sin(a), np.sin(b)], axis=-1)
    along = unit(ahead) - unit(behind)
    east = np.stack([-np.sin(lam), np.cos(lam), np.zeros_like(lam)], axis=-1)
    north = np.stack([-np.sin(phi) * np.cos(lam), -np.sin(phi) * np.sin(lam), np.cos(phi)], axis=-1)
    angle[-cap_rows - 1:] = np.arctan2(np.einsum("...k,...k", along, north), np.einsum("...k,...k", along, east))
    if last_row == "mirror":  # the mirrored row's i runs the other way
        angle[-1] = np.mod(angle[-2, ::-1], 2.0 * np.pi) - np.pi
    return angle


def tripolar_dataset(field, times: np.ndarray, *, time_units: str = "days since 2000-01-01",
                     components: str = "geographic", **grid) -> xr.Dataset:
    """``field(lon, lat, t) -> (u, v)`` (eastward, northward, m/s) on a tripolar grid
    (:func:`tripolar_grid`'s options ``grid``) at ``times``, its coordinates ``nav_lon``, ``nav_lat``;
    with ``components="grid"`` u, v along the grid's i and j (:func:`tripolar_angle`)."""
    lon, lat = tripolar_grid(**grid)
    angle = tripolar_angle(**grid) if components == "grid" else None
    dataset = curvilinear_dataset(field, lon, lat, times, sphere=True, time_units=time_units, components=components,
                                  angle=angle)
    dataset = dataset.rename({"lon_rho": "nav_lon", "lat_rho": "nav_lat", "eta": "y", "xi": "x"})
    for name in ("u", "v"):
        dataset[name].attrs["coordinates"] = "nav_lon nav_lat"
    dataset.attrs["source"] = "ldpipe.data.tripolar (analytic, tripolar grid with its north fold)"
    return dataset
