"""Structures in maps in the Python API: an LD map's singular curves and FTLE ridges."""

from __future__ import annotations

from collections.abc import Sequence

import xarray as xr

from ..core.structures.curves import check_structure_parameters, structures_dataset
from ..errors import ConfigError


def structures(ld_map: xr.Dataset, *, threshold: float = 0.1, min_points: int = 10, ld_kind: str = "valley",
               fields: Sequence[str] | None = None) -> xr.Dataset:
    """The structures of an LD map (:func:`ld_map`, or its file opened): the singular curves of its
    LD and the ridges of its FTLE, as polylines to sub-pixel accuracy; forward fields give stable,
    backward fields unstable structures.

    Parameters
    ----------
    ld_map : xarray.Dataset
        A map of two axes, with or without its FTLE (``ftle: true``).
    threshold : float
        The sharpness a point needs, as a fraction of the sharpest pixel's in its field.
    min_points : int
        Curves with fewer points are dropped.
    ld_kind : {"valley", "ridge"}
        Which singular features of the LD: the V-shaped minima of a p-norm LD with p <= 1 on a
        manifold (default), or sharp maxima.
    fields : list of str, optional
        Some of ``ld_forward``, ``ld_backward``, ``ftle_forward``, ``ftle_backward``; default every
        one the map holds.

    Returns
    -------
    xarray.Dataset
        The structures file (contract ``structures``): the curves as a CF contiguous ragged array
        (``point_count`` per curve, the points along ``point``, their ``strength`` and ``value``;
        per curve its ``source`` field and ``manifold``).

    Raises
    ------
    ConfigError
        naming the argument.

    Examples
    --------
    >>> found = ldpipe.structures(m, threshold=0.2)  # doctest: +SKIP
    >>> stable = ldpipe.core.structures.curves_of(found, manifold="stable")  # doctest: +SKIP
    """
    if not isinstance(ld_map, xr.Dataset):
        raise ConfigError(f"ldpipe.structures: argument 'ld_map': expected an LD map (ldpipe.ld_map), "
                          f"got {type(ld_map).__name__}")
    given = {"threshold": threshold, "min_points": min_points, "ld_kind": ld_kind,
             "fields": None if fields is None else list(fields) if not isinstance(fields, str) else fields}
    try:
        parameters = check_structure_parameters(given, where="ldpipe.structures")
    except ConfigError as error:
        raise ConfigError(str(error).replace(": key '", ": argument '")) from None
    return structures_dataset(parameters, ld_map)
