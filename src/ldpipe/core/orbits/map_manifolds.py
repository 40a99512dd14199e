"""Stable and unstable manifolds of a saddle fixed point of a discrete map, by fundamental segments.

Near a saddle fixed point x* with a real multiplier lambda (|lambda| > 1 for the unstable
manifold; the stable one is the unstable manifold of the inverse map, multiplier 1/mu) and its
eigenvector v, the manifold is the line x* + s v to second order in s. A fundamental segment,
the points x* + s v with |s| from d to d |lambda| (on both sides of x*: both branches), is
mapped by f onto the next one; its images under f, f^2, ..., f^k cover the manifold out to k
segments. The points of the first segment are spaced geometrically in s, so their images are
spaced alike along each later segment; the error of the start, O(d^2), is carried along (it
shrinks along the manifold by the other multiplier).

A negative multiplier maps each side of x* onto the other: the k-th image of the segment that
starts at +v lies on the side of sign(lambda)^k. :func:`manifold_branches` gathers each side's
images, so that a branch read image by image, point by point, runs outward from x* along one
curve. :func:`map_manifolds_dataset` is the manifolds stage's file for a map entry (one naming a
``system``): both manifolds, both branches, of the map's saddle fixed points.
"""

from __future__ import annotations

import os

import numpy as np
import xarray as xr

from ...errors import ConfigError, StageFileError
from ...io import contracts
from ...io.datafile import input_name, missing_value_encoding, open_stage_file, stage_dataset, stage_parameters
from ...logs import get_logger
from ...systems import make_system
from ..equilibria.fixed_points import circle_difference

log = get_logger(__name__)

MANIFOLDS = ("stable", "unstable")
#: The side of the fixed point along the eigenvector: x* + s v with s > 0, and with s < 0.
BRANCHES = ("plus", "minus")


def fixed_point_manifold(system, point: np.ndarray, multiplier: float, eigenvector: np.ndarray, *,
                         stable: bool, iterations: int, segment_points: int = 400,
                         first_distance: float = 1e-7, escape_radius: float | None = None) -> np.ndarray:
    """Points of the unstable (``stable`` False) or stable manifold of the saddle fixed point
    ``point`` of the map ``system``, from the fundamental segment of the eigenvector of the real
    ``multiplier`` (that of the manifold's direction: |multiplier| > 1 for the unstable one,
    < 1 for the stable one, which is iterated by the inverse map), mapped ``iterations`` times:
    an array of shape (iterations + 1, 2, segment_points, n), by image, start (+v, -v) and
    point along the segment. An image that leaves the real line (overflow), or passes
    ``escape_radius`` in a coordinate that is not periodic, holds NaN, and so do its images."""
    multiplier = float(multiplier)
    growth = abs(1.0 / multiplier if stable else multiplier)
    if not growth > 1:
        raise ValueError(f"multiplier: {multiplier} is not of the {'stable' if stable else 'unstable'} direction")
    direction = -1 if stable else 1
    vector = np.real(np.asarray(eigenvector, dtype=complex))
    vector = vector / np.linalg.norm(vector)
    s = first_distance * growth ** (np.arange(segment_points) / segment_points)
    n = len(point)
    bounded = np.array([not period for period in getattr(system, "periods", (0.0,) * n)])
    out = np.full((iterations + 1, 2, segment_points, n), np.nan)
    for branch, sign in enumerate((1.0, -1.0)):
        current = np.asarray(point)[None, :] + sign * s[:, None] * vector[None, :]
        if hasattr(system, "wrap"):  # a periodic coordinate in [0, period), as every image has it
            current = system.wrap(current)
        out[0, branch] = current
        for k in range(1, iterations + 1):
            with np.errstate(over="ignore", invalid="ignore"):
                current = np.array([system.step(x, direction) if np.all(np.isfinite(x)) else np.full(n, np.nan)
                                    for x in current])
                if escape_radius is not None:
                    current[np.any(np.abs(current[:, bounded]) > escape_radius, axis=1)] = np.nan
            current[~np.all(np.isfinite(current), axis=1)] = np.nan
            out[k, branch] = current
    return out


def manifold_branches(images: np.ndarray, multiplier: float) -> np.ndarray:
    """:func:`fixed_point_manifold`'s ``images`` (by image and start) rearranged by the side of the
    fixed point each image lies on (:data:`BRANCHES`): with a negative ``multiplier`` (that of
    the manifold's growth, either one of the manifold's direction) the k-th images of the two
    starts trade sides at every odd k."""
    branches = images.copy()
    if multiplier < 0:
        branches[1::2] = images[1::2, ::-1]
    return branches


def _real_vector(vector: np.ndarray) -> np.ndarray:
    """A real unit eigenvector from the file's phased one (its largest component real and positive)."""
    vector = np.real(vector)
    return vector / np.linalg.norm(vector)


def saddle_rows(equilibria: xr.Dataset, near, periods, key: str) -> list[int]:
    """The rows of the map's equilibria file whose fixed points are saddles: every one, or
    (``near`` a point) the one nearest it, a periodic coordinate's distance taken on the circle."""
    rows = [int(i) for i in np.flatnonzero(equilibria.type.values == "saddle")]
    if not rows:
        raise ConfigError(f"config key '{key}.system': the map {equilibria.attrs.get('system')!r} has no saddle "
                          "fixed point in its equilibrium search box (its fixed points are "
                          f"{list(equilibria.type.values)}); widen systems.<name>.equilibria.box")
    if near is None:
        return rows
    distance = np.linalg.norm(circle_difference(equilibria.position.values[rows] - np.asarray(near), periods), axis=1)
    return [rows[int(np.argmin(distance))]]


def map_manifolds_dataset(parameters: dict, equilibria: str | os.PathLike | xr.Dataset) -> xr.Dataset:
    """Both manifolds, both branches, of the saddle fixed points of a map, as the manifolds
    stage's file for an entry naming a ``system`` holds them: ``parameters`` are the stage's
    (:func:`ldpipe.config.parameters.parameters_from_config`), ``equilibria`` the map's
    equilibria file or Dataset (:func:`ldpipe.core.equilibria.study.equilibria_dataset`), whose
    saddles (or the one ``saddle_near``) are taken with their multipliers and eigenvectors."""
    key = f"manifolds.{parameters['name']}"
    data = open_stage_file(equilibria, stage=contracts.FLOW_EQUILIBRIA)
    recorded = stage_parameters(data)
    if recorded["system_spec"] != parameters["system_spec"]:
        raise StageFileError(f"{input_name(equilibria)}: equilibria of system {recorded['system_name']!r} "
                             f"{recorded['system_spec']}, expected {parameters['system_name']!r} "
                             f"{parameters['system_spec']}")
    system = make_system(parameters["system_name"], parameters["system_spec"])
    system.require_inverse(f"{key} (the stable manifolds)")
    rows = saddle_rows(data, parameters.get("saddle_near"), system.periods, key)
    iterations, points = parameters["iterations"], parameters["segment_points"]
    distance, radius = parameters["first_distance"], parameters["escape_radius"]
    n = system.n_state
    curve = np.empty((len(rows), 2, 2, iterations + 1, points, n))
    multipliers = np.empty((len(rows), 2))
    vectors = np.empty((len(rows), 2, n))
    segment = np.empty((len(rows), 2, points))
    for index, row in enumerate(rows):
        position = data.position.values[row]
        for k, (name, mode) in enumerate(zip(MANIFOLDS, (1, 0))):  # modes by decreasing modulus: unstable first
            multiplier = float(data.eigenvalue_real.values[row, mode])
            vector = _real_vector(data.eigenvector_real.values[row, mode] + 1j * data.eigenvector_imag.values[row, mode])
            stable = name == "stable"
            images = fixed_point_manifold(system, position, multiplier, vector, stable=stable, iterations=iterations,
                                          segment_points=points, first_distance=distance, escape_radius=radius)
            # each image point by point, branch by branch: dims (branch, image, point, coordinate)
            curve[index, k] = manifold_branches(images, multiplier).transpose(1, 0, 2, 3)
            multipliers[index, k], vectors[index, k] = multiplier, vector
            growth = abs(1.0 / multiplier if stable else multiplier)
            segment[index, k] = distance * growth ** (np.arange(points) / points)
            log.info("fixed point %d at %s: %s manifold, multiplier %.12g, %d of %d points followed to the end",
                     row, position, name, multiplier, int(np.isfinite(curve[index, k, :, -1, :, 0]).sum()), 2 * points)
    coordinates = list(system.coordinates)
    dataset = xr.Dataset(
        {
            "curve": (("fixed_point", "manifold", "branch", "image", "point", "coordinate"), curve,
                      {"long_name": "points of the manifold: image k of the fundamental segment on one side of the "
                                    "fixed point; read image by image, point by point, a branch runs outward along "
                                    "the manifold; missing after an escape"}),
            "fixed_point_position": (("fixed_point", "coordinate"), data.position.values[rows],
                                     {"long_name": "the saddle fixed point (f(x) = x)"}),
            "equilibrium_index": (("fixed_point",), np.array(rows, dtype=np.int32),
                                  {"long_name": "the fixed point's row in the map's equilibria file"}),
            "multiplier": (("fixed_point", "manifold"), multipliers,
                           {"long_name": "multiplier of the tangent map along the manifold (|m| < 1 stable, "
                                         "> 1 unstable); negative: the branches trade sides at each step"}),
            "eigenvector": (("fixed_point", "manifold", "coordinate"), vectors,
                            {"long_name": "unit eigenvector of the multiplier: the plus branch leaves the fixed "
                                          "point along it"}),
            "segment_distance": (("fixed_point", "manifold", "point"), segment,
                                 {"long_name": "distance s from the fixed point along the eigenvector of each point "
                                               "of the fundamental segment (image 0): d times the growth factor to "
                                               "the power point / segment_points"}),
        },
        coords={"manifold": list(MANIFOLDS), "branch": list(BRANCHES), "image": np.arange(iterations + 1),
                "point": np.arange(points), "coordinate": coordinates},
    )
    dataset["curve"].encoding.update(missing_value_encoding())
    dataset.attrs.update({
        "system": system.name, "discrete_map": system.description, "iterations": iterations,
        "segment_points": points, "first_distance": distance, "escape_radius": radius,
        "periodic": ", ".join(f"{c} mod {p:.17g}" for c, p in zip(coordinates, system.periods) if p) or "none",
        "method": "fundamental segments: the unstable manifold's by the map, the stable one's by its inverse",
        "colors": "stable cyan, unstable magenta",
    })
    title = f"Stable and unstable manifolds of the saddle fixed points of {system.description}"
    return stage_dataset(dataset, stage=contracts.MAP_MANIFOLDS, title=title, parameters=parameters)
