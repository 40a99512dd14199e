"""Lengths on the sphere between points given as longitude and latitude in degrees: the one home of
the great-circle distance, the step along a great circle and the local projection that the
structures measured on the sphere share (the FSLE's separations, the LAVD's vortex shapes, the
FTLE's end points).

Every function works through 3-D unit vectors, so neither the longitude's seam (179.5 and -179.5
are a degree apart) nor a pole (any longitude at latitude 90 is the same point; (0, 89.5) and
(180, 89.5) are a degree apart) is a special case.
"""

from __future__ import annotations

import numpy as np

#: Kilometres per metre: the systems give the sphere's radius in metres, lengths here are in km.
KM = 1e-3


def sphere_radius_km(system) -> float | None:
    """The radius in km of the sphere ``system``'s state lies on (velocity data with ``coordinates:
    sphere``: longitude and latitude in degrees), or None for a state in the plane."""
    source = getattr(system, "source", None)
    return float(source.radius) * KM if getattr(source, "sphere", False) else None


def unit_vectors(lon_lat: np.ndarray) -> np.ndarray:
    """Points (..., 2) of longitude, latitude in degrees as unit vectors (..., 3)."""
    lon, lat = np.radians(lon_lat[..., 0]), np.radians(lon_lat[..., 1])
    return np.stack([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)], axis=-1)


def lon_lat(vectors: np.ndarray) -> np.ndarray:
    """Unit (or any nonzero) vectors (..., 3) as longitude in (-180, 180] and latitude, in degrees (..., 2)."""
    x, y, z = vectors[..., 0], vectors[..., 1], vectors[..., 2]
    return np.stack([np.degrees(np.arctan2(y, x)), np.degrees(np.arctan2(z, np.hypot(x, y)))], axis=-1)


def sphere_positions(lon_lat_points: np.ndarray) -> np.ndarray:
    """Points (..., 2) in degrees as 3-D positions (..., 3) on the sphere of radius 180/pi: a chord
    between near points is their great-circle distance in degrees (the FTLE's end points)."""
    return np.degrees(unit_vectors(lon_lat_points))


def great_circle_distance(a: np.ndarray, b: np.ndarray, radius: float) -> np.ndarray:
    """The great-circle distance between points ``a`` and ``b`` (..., 2; longitude, latitude in
    degrees) on the sphere of ``radius``, in its unit: the angle atan2(|p x q|, p . q) between the
    unit vectors, accurate to rounding for near points and antipodes alike."""
    p, q = unit_vectors(np.asarray(a, dtype=float)), unit_vectors(np.asarray(b, dtype=float))
    return radius * np.arctan2(np.linalg.norm(np.cross(p, q), axis=-1), np.sum(p * q, axis=-1))


def local_basis(lon_lat_points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The unit vectors east and north (..., 3) at points (..., 2) in degrees; at a pole those of the
    point's own meridian (the limit along it), so a start point at a pole has a frame too."""
    lon, lat = np.radians(lon_lat_points[..., 0]), np.radians(lon_lat_points[..., 1])
    east = np.stack([-np.sin(lon), np.cos(lon), np.zeros_like(lon)], axis=-1)
    north = np.stack([-np.sin(lat) * np.cos(lon), -np.sin(lat) * np.sin(lon), np.cos(lat)], axis=-1)
    return east, north


def step_along(lon_lat_points: np.ndarray, east: float, north: float, distance: float, radius: float) -> np.ndarray:
    """The points (..., 2) ``distance`` (in ``radius``'s unit) from ``lon_lat_points`` along the
    great circles leaving them in the direction (``east``, ``north``) of their local basis (a unit
    pair): across the seam and over a pole too. The longitude is kept within 180 degrees of the
    start's, in the start's convention (179.5 stepped a degree east is 180.5)."""
    points = np.asarray(lon_lat_points, dtype=float)
    e, n = local_basis(points)
    angle = distance / radius
    moved = np.cos(angle) * unit_vectors(points) + np.sin(angle) * (east * e + north * n)
    result = lon_lat(moved)
    result[..., 0] = points[..., 0] + np.mod(result[..., 0] - points[..., 0] + 180.0, 360.0) - 180.0
    return result


def tangent_plane(lon_lat_points: np.ndarray, centre: np.ndarray, radius: float) -> np.ndarray:
    """Points (..., 2) in degrees in the Lambert azimuthal equal-area projection about ``centre``
    (lon, lat), x east and y north in ``radius``'s unit: every area is the area on the sphere, and
    a circle on the sphere about the centre at the angle g is a circle of radius 2 R sin(g/2)."""
    p = unit_vectors(np.asarray(lon_lat_points, dtype=float))
    centre = np.asarray(centre, dtype=float)
    c = unit_vectors(centre)
    e, n = local_basis(centre)
    # 2 R sin(g/2) / sin(g) = R sqrt(2 / (1 + cos g)) times the component in the tangent plane
    scale = radius * np.sqrt(2.0 / np.maximum(1.0 + p @ c, 1e-300))
    return np.stack([scale * (p @ e), scale * (p @ n)], axis=-1)
