"""An LD or FTLE map's structures: its singular curves and ridges, as the structures file holds them.

From a forward map come stable structures, from a backward map unstable ones: the singular
features of the LD (Mancho et al. 2013; valleys of a p-norm LD with p ≤ 1 by default) and the
ridges of the FTLE (Shadden, Lekien & Marsden 2005) or of the FSLE, each extracted by
:func:`ldpipe.core.structures.ridges.ridge_curves`. The file stores the curves as a CF contiguous
ragged array: the points of every curve one after another along the ``point`` dimension, and per
curve (``curve`` dimension) its number of points (``point_count``, whose ``sample_dimension`` is
``point``), the map field it came from and whether it is stable or unstable.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from ...errors import ConfigError, StageFileError
from ...io.contracts import FSLE, LD_GRID, STRUCTURES
from ...io.datafile import input_name, open_stage_file, stage_dataset
from .ridges import Curve, ridge_curves

#: Each map field structures are taken from: (its flag value in the file, stable or unstable, and
#: the mask of the points where the field is defined, by the map's variables).
SOURCES = {
    "ld_forward": (0, "stable"),
    "ld_backward": (1, "unstable"),
    "ftle_forward": (2, "stable"),
    "ftle_backward": (3, "unstable"),
    "fsle_forward": (4, "stable"),
    "fsle_backward": (5, "unstable"),
}
MANIFOLDS = ("stable", "unstable")
#: The defaults of :func:`structures_dataset`'s parameters.
DEFAULTS = {"threshold": 0.1, "min_points": 10, "ld_kind": "valley", "fields": None}


def check_structure_parameters(parameters: dict, where: str = "structures", key: str = "key") -> dict:
    """``parameters`` with the defaults filled and each checked; a ConfigError beginning with
    ``where`` and naming the bad one as a ``key`` (from the API: an 'argument')."""
    unknown = sorted(set(parameters) - set(DEFAULTS))
    if unknown:
        raise ConfigError(f"{where}: unknown {key}s {unknown}; allowed are {sorted(DEFAULTS)}")
    checked = {**DEFAULTS, **parameters}
    threshold = checked["threshold"]
    if isinstance(threshold, bool) or not isinstance(threshold, (int, float)) or not 0 < threshold < 1:
        raise ConfigError(f"{where}: {key} 'threshold': {threshold!r}; expected a fraction of the sharpest "
                          "point's sharpness, between 0 and 1")
    min_points = checked["min_points"]
    if isinstance(min_points, bool) or not isinstance(min_points, int) or min_points < 2:
        raise ConfigError(f"{where}: {key} 'min_points': {min_points!r}; expected an integer of at least 2")
    if checked["ld_kind"] not in ("valley", "ridge"):
        raise ConfigError(f"{where}: {key} 'ld_kind': {checked['ld_kind']!r}; expected 'valley' (the minima of "
                          "a p-norm LD with p <= 1) or 'ridge'")
    fields = checked["fields"]
    if fields is not None:
        if isinstance(fields, str) or not all(isinstance(f, str) for f in fields) or not fields:
            raise ConfigError(f"{where}: {key} 'fields': {fields!r}; expected a list of {sorted(SOURCES)}")
        bad = sorted(set(fields) - set(SOURCES))
        if bad:
            raise ConfigError(f"{where}: {key} 'fields': {bad} are not map fields structures are taken from; "
                              f"expected some of {sorted(SOURCES)}")
        checked["fields"] = list(fields)
    return {**checked, "threshold": float(threshold)}


def _defined(ld_map: xr.Dataset, field: str) -> np.ndarray:
    """Where the map's ``field`` is defined: the FTLE's own flag; for the LD the points integrated
    whose trajectory no safety limit stopped."""
    direction = field.rsplit("_", 1)[1]
    if field.startswith("fsle"):
        return ld_map[f"fsle_defined_{direction}"].values.astype(bool) & \
            ld_map[f"fsle_reached_{direction}"].values.astype(bool)
    if field.startswith("ftle"):
        return ld_map[f"ftle_defined_{direction}"].values.astype(bool)
    defined = ld_map["allowed"].values.astype(bool)
    failed = f"failed_{direction}"
    if failed in ld_map:
        defined &= ~ld_map[failed].values.astype(bool)
    return defined


def map_curves(ld_map: xr.Dataset, parameters: dict, where: str = "structures",
               key: str = "key") -> dict[str, list[Curve]]:
    """The curves of every field of ``ld_map`` that ``parameters['fields']`` names (default: every
    LD and FTLE field the map holds), by field."""
    fields = parameters["fields"] or [name for name in SOURCES if name in ld_map.data_vars]
    missing = [name for name in fields if name not in ld_map.data_vars]
    if missing:
        raise ConfigError(f"{where}: {key} 'fields': the map has no {missing}")
    axes = tuple(ld_map[field].dims for field in fields)
    if any(len(dims) != 2 for dims in axes):
        raise ConfigError(f"{where}: the map's fields have dimensions {axes[0]}; structures are curves of "
                          "a map of two axes")
    found = {}
    for field in fields:
        dims = ld_map[field].dims
        coordinates = tuple(np.asarray(ld_map[dim].values, dtype=float) for dim in dims)
        kind = parameters["ld_kind"] if field.startswith("ld_") else "ridge"
        found[field] = ridge_curves(ld_map[field].values, coordinates, _defined(ld_map, field), kind=kind,
                                    threshold=parameters["threshold"], min_points=parameters["min_points"])
    return found


def ragged_curves(curves: dict[str, list[Curve]], axes: tuple[str, str]) -> xr.Dataset:
    """``curves`` by field as a CF contiguous ragged array over ``point`` and ``curve``."""
    rows = [(field, curve) for field, listed in curves.items() for curve in listed]
    points = np.concatenate([c.points for _, c in rows]) if rows else np.zeros((0, 2))
    strength = np.concatenate([c.strength for _, c in rows]) if rows else np.zeros(0)
    value = np.concatenate([c.value for _, c in rows]) if rows else np.zeros(0)
    counts = np.array([len(c.points) for _, c in rows], dtype=np.int64)
    source = np.array([SOURCES[field][0] for field, _ in rows], dtype=np.int8)
    manifold = np.array([MANIFOLDS.index(SOURCES[field][1]) for field, _ in rows], dtype=np.int8)
    order = sorted(SOURCES, key=lambda name: SOURCES[name][0])
    variables = {
        axes[0]: ("point", points[:, 0], {"long_name": f"{axes[0]} of the curve's point"}),
        axes[1]: ("point", points[:, 1], {"long_name": f"{axes[1]} of the curve's point"}),
        "strength": ("point", strength, {
            "long_name": "sharpness of the curve at the point",
            "comment": "minus the smallest eigenvalue of the field's Hessian across the curve (of minus the field "
                       "for a valley), per grid cell squared, at the sharper pixel of the grid edge the point "
                       "lies on: for a singular feature, about the jump of the field's slope from cell to cell"}),
        "value": ("point", value, {"long_name": "the map's field interpolated at the point"}),
        "point_count": ("curve", counts, {"long_name": "number of points of the curve",
                                          "sample_dimension": "point"}),
        "source": ("curve", source, {"long_name": "the map field the curve was extracted from",
                                     "flag_values": np.arange(len(order), dtype=np.int8),
                                     "flag_meanings": " ".join(order)}),
        "manifold": ("curve", manifold, {"long_name": "stable (from a forward map) or unstable (backward)",
                                         "flag_values": np.arange(2, dtype=np.int8),
                                         "flag_meanings": " ".join(MANIFOLDS)}),
    }
    return xr.Dataset({name: xr.Variable((dim,), data, attrs) for name, (dim, data, attrs) in variables.items()})


def structures_dataset(parameters: dict, ld_map, *, where: str = "structures", key: str = "key") -> xr.Dataset:
    """The structures file of ``ld_map`` (an LD map's file or Dataset, with or without its FTLE,
    or an FSLE file, whose ridges are taken where the final separation was reached):
    its curves (:func:`map_curves`) as a ragged array, the extraction's parameters as attributes.

    ``parameters``: ``threshold`` (a point's sharpness as a fraction of the sharpest pixel's, per
    field), ``min_points`` (shorter curves dropped), ``ld_kind`` (``valley`` or ``ridge``: which
    singular features of the LD), ``fields`` (default every LD and FTLE field of the map). A
    ConfigError begins with ``where`` and names a bad parameter as a ``key``.
    """
    parameters = check_structure_parameters(dict(parameters), where, key)
    try:
        source = open_stage_file(ld_map, stage=LD_GRID.stage)
    except StageFileError as error:
        if "written by the 'fsle' stage" not in str(error):
            raise
        source = open_stage_file(ld_map, stage=FSLE.stage)
    curves = map_curves(source, parameters, where, key)
    first = next(iter(curves), None)
    axes = tuple(source[first].dims) if first else tuple(source["allowed"].dims)
    dataset = ragged_curves(curves, axes)
    spacing = [float(np.diff(source[dim].values[:2])[0]) if source.sizes[dim] > 1 else 0.0 for dim in axes]
    dataset.attrs.update({
        "map_title": source.attrs.get("title", ""), "system": source.attrs.get("system", ""),
        "axes": " ".join(axes), "grid_spacing": np.array(spacing), "grid_shape": np.array([source.sizes[d] for d in axes]),
        "fields": " ".join(curves), "threshold": parameters["threshold"], "min_points": parameters["min_points"],
        "ld_kind": parameters["ld_kind"], "criterion": "second-derivative ridge: grad g . e_min = 0, "
        "lambda_min(Hessian g) <= -threshold * max(-lambda_min); g the field (ridges) or minus it (valleys)",
    })
    for key in ("tau", "t0", "descriptor"):
        if key in source.attrs:
            dataset.attrs[f"map_{key}"] = source.attrs[key]
    return stage_dataset(dataset, stage=STRUCTURES, title=f"structures of {source.attrs.get('title', 'an LD map')}",
                         parameters={**parameters, "map": input_name(ld_map)})


def curves_of(structures: xr.Dataset, source: str | None = None, manifold: str | None = None) -> list[np.ndarray]:
    """The curves of a structures file as arrays of points (n, 2), in the file's axis order; only
    those of one map field (``source``) or one kind (``manifold``: stable or unstable), if given."""
    axes = structures.attrs["axes"].split()
    points = np.column_stack([structures[axis].values for axis in axes]) if structures.sizes["point"] else np.zeros((0, 2))
    ends = np.concatenate([[0], np.cumsum(structures.point_count.values)])
    chosen = []
    for k in range(structures.sizes["curve"]):
        if source is not None and int(structures.source.values[k]) != SOURCES[source][0]:
            continue
        if manifold is not None and int(structures.manifold.values[k]) != MANIFOLDS.index(manifold):
            continue
        chosen.append(points[ends[k]:ends[k + 1]])
    return chosen
