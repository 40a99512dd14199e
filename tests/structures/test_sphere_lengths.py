"""Lengths on the sphere (ldpipe.core.sphere) against closed forms: distances along a meridian and
the equator are R times the angle; across the seam and over a pole the chart's degrees are not the
sphere's; a step along a great circle lands where the navigation formula says; the azimuthal
equal-area projection sends a circle about its centre to a circle of radius 2 R sin(g/2)."""

import math

import numpy as np
import pytest

from ldpipe.core.sphere import great_circle_distance, step_along, tangent_plane

R = 6371.0  # km
DEGREE = math.pi * R / 180.0  # km of arc in a degree


@pytest.mark.parametrize(("a", "b", "degrees"), [
    # the seam: a degree of longitude on the parallel 10 N, the chord's angle 2 asin(cos(lat) sin(0.5 degree))
    ((179.5, 10.0), (-179.5, 10.0), math.degrees(2 * math.asin(math.cos(math.radians(10.0)) * math.sin(math.radians(0.5))))),
    ((0.0, 89.5), (180.0, 89.5), 1.0),  # over the pole
    ((37.0, 90.0), (-120.0, 90.0), 0.0),  # the pole, at any longitude
    ((20.0, -30.0), (20.0, -29.999), 0.001),  # a meridian, near points
    ((10.0, 0.0), (-170.0, 0.0), 180.0),  # antipodes
])
def test_great_circle_distances(a, b, degrees):
    # closed forms: R times the angle between the points
    distance = great_circle_distance(np.array(a), np.array(b), R)
    # measured: rounding, 1e-15 of the distance (1e-12 km at the antipodes' pi R)
    assert distance == pytest.approx(degrees * DEGREE, rel=1e-12, abs=1e-9)


def test_steps_along_great_circles():
    # north along a meridian, over the pole: 89.5 N plus one degree is 89.5 N half-way round
    moved = step_along(np.array([[30.0, 89.5]]), 0.0, 1.0, DEGREE, R)[0]
    np.testing.assert_allclose([(moved[0] - 210.0 + 180.0) % 360.0 - 180.0, moved[1]], [0.0, 89.5], atol=1e-9)
    # east along the equator across the seam, in the start's convention
    moved = step_along(np.array([[179.5, 0.0]]), 1.0, 0.0, DEGREE, R)[0]
    np.testing.assert_allclose(moved, [180.5, 0.0], atol=1e-9)
    # east from 60 N, against the navigation formula for a destination at bearing 90 degrees
    lat, d = math.radians(60.0), 500.0 / R
    lat2 = math.asin(math.sin(lat) * math.cos(d))
    lon2 = 10.0 + math.degrees(math.atan2(math.sin(d) * math.cos(lat), math.cos(d) - math.sin(lat) * math.sin(lat2)))
    moved = step_along(np.array([[10.0, 60.0]]), 1.0, 0.0, 500.0, R)[0]
    np.testing.assert_allclose(moved, [lon2, math.degrees(lat2)], atol=1e-10)
    # and 500 km away
    assert great_circle_distance(np.array([10.0, 60.0]), moved, R) == pytest.approx(500.0, rel=1e-12)


@pytest.mark.parametrize("centre", [(0.0, 0.0), (45.0, 60.0), (-179.0, 85.0)])
def test_the_tangent_plane_keeps_circles_and_areas(centre):
    # a circle on the sphere at the angle g about the centre, through the pole's side too
    g = math.radians(4.0)
    bearings = np.linspace(0.0, 2 * math.pi, 721)
    ring = np.array([step_along(np.array([centre]), math.sin(b), math.cos(b), g * R, R)[0] for b in bearings])
    plane = tangent_plane(ring, np.array(centre), R)
    # closed form of the equal-area projection: the cap's area 2 pi R^2 (1 - cos g) = pi (2 R sin(g/2))^2
    radius = 2 * R * math.sin(g / 2)
    # measured: 1e-12 relative (rounding)
    np.testing.assert_allclose(np.hypot(plane[:, 0], plane[:, 1]), radius, rtol=1e-10)
    # the bearing is kept: east is x, north is y (a circle, but also the right circle)
    np.testing.assert_allclose(np.arctan2(plane[1:-1, 0], plane[1:-1, 1]) % (2 * math.pi), bearings[1:-1], atol=1e-9)
