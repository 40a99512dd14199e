"""Structures in maps in the Python API: an LD map's singular curves and FTLE ridges."""

from __future__ import annotations

from collections.abc import Sequence

import xarray as xr

from ..core.structures.curves import structures_dataset
from ..errors import ConfigError
from .arguments import api_function


@api_function()
def structures(ld_map: xr.Dataset, *, threshold: float = 0.1, min_points: int = 10, ld_kind: str = "valley",
               fields: Sequence[str] | None = None) -> xr.Dataset:
    """The structures of an LD map (:func:`ld_map`, or its file opened): the singular curves of its
    LD and the ridges of its FTLE, as polylines to sub-pixel accuracy; forward fields give stable,
    backward fields unstable structures.

    Parameters
    ----------
    ld_map : xarray.Dataset
        A map of two axes, with or without its FTLE (``ftle: true``), or an FSLE file
        (:func:`fsle`).
    threshold : float
        The sharpness a point needs, as a fraction of the sharpest pixel's in its field.
    min_points : int
        Curves with fewer points are dropped.
    ld_kind : {"valley", "ridge"}
        Which singular features of the LD: the V-shaped minima of a p-norm LD with p <= 1 on a
        manifold (default), or sharp maxima.
    fields : list of str, optional
        Some of ``ld_forward``, ``ld_backward``, ``ftle_forward``, ``ftle_backward``,
        ``fsle_forward``, ``fsle_backward``; default every one the file holds.

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
    return structures_dataset(given, ld_map, where="ldpipe.structures", key="argument")


def check_flow_grid(function: str, system, section) -> None:
    """The system and the grid of a field over a flow's trajectories (FSLE, LAVD): a system object
    and a section block, or a ConfigError naming the argument (their contents are checked where
    they are read)."""
    if not hasattr(system, "coordinates") or not hasattr(system, "hamiltonian"):
        raise ConfigError(f"ldpipe.{function}: argument 'system': expected a system (ldpipe.system), "
                          f"got {type(system).__name__}")
    if not isinstance(section, dict):
        raise ConfigError(f"ldpipe.{function}: argument 'section': expected a section block (ldpipe.section), "
                          f"got {type(section).__name__}")


@api_function()
def fsle(system, *, section: dict, final_separation: float, max_time: float, initial_separation: float | None = None,
         interval: float | None = None, t0: float = 0.0, integrator: dict | None = None,
         threads: int | None = None) -> xr.Dataset:
    """The finite-size Lyapunov exponent of a flow (a vector field or velocity data) over a grid,
    forward and backward, as AVISO computes it: each grid point with its four neighbours at
    ``initial_separation``, λ = ln(final / initial separation) / the first time a neighbour is
    ``final_separation`` away; 0 where none is within ``max_time``.

    Parameters
    ----------
    system : System
        A vector-field system (:func:`system`).
    section : dict
        Two axes and the other coordinates fixed, as an LD map's (:func:`section`).
    final_separation, max_time : float
        The separation to reach and the longest time to wait for it. Separations are in the axes'
        units in the plane, and great-circle distances in km on the sphere (velocity data with
        longitude and latitude).
    initial_separation : float, optional
        Default: the grid's smaller spacing (the grid's own neighbours, on a square grid; on the
        sphere the smaller spacing in degrees as km of arc).
    interval : float, optional
        How often the separations are checked (default max_time / 100); between checks a
        separation is taken to grow exponentially.
    t0 : float
        Start time.
    integrator : dict, optional
        Some of ``rtol``, ``atol``, ``escape_radius``, ``max_steps``.
    %(threads)s

    Returns
    -------
    xarray.Dataset
        The FSLE file (contract ``fsle``): ``fsle_forward`` and ``fsle_backward``, where the final
        separation was reached, the time, the direction stretched most (``fsle_angle_*``) and where
        no particle stopped early.

    Examples
    --------
    >>> f = ldpipe.fsle(gyre, section=ldpipe.section(x=(0, 2, 101), y=(0, 1, 51)),
    ...                 final_separation=0.2, max_time=20.0)  # doctest: +SKIP
    """
    from ..core.structures.fsle import fsle_dataset

    check_flow_grid("fsle", system, section)
    parameters = {"final_separation": final_separation, "max_time": max_time, "initial_separation": initial_separation,
                  "interval": interval, "t0": t0, "integrator": integrator or {}}
    return fsle_dataset(system, section, parameters, threads=threads, where="ldpipe.fsle", key="argument")


@api_function()
def lavd(system, *, section: dict, duration: float, interval: float | None = None, t0: float = 0.0,
         levels: int = 100, convexity_deficiency: float = 0.01, min_points: int = 8, integrator: dict | None = None,
         threads: int | None = None) -> xr.Dataset:
    """The Lagrangian-averaged vorticity deviation (Haller et al. 2016) of a vector field with
    formulas or of velocity data (in the plane or on the sphere) over a grid, and its rotationally
    coherent vortices: centres (the LAVD's maxima, at t0 and advected to t0 + duration), boundaries
    (the outermost convex-enough LAVD contours around them), areas and convexity deficiencies.

    Parameters
    ----------
    system : System
        A vector-field system (:func:`system`) of formulas, its vorticity taken from their
        derivatives, or of velocity data on a regular or rectilinear grid, in the plane or on the
        sphere (not curvilinear, not a global grid through a pole), its vorticity from the
        derivatives of the data's interpolant; on the sphere the region's mean vorticity weights
        each particle by cos(latitude) of its start point and the areas are in km².
    section : dict
        Two axes and the other coordinates fixed (:func:`section`).
    duration : float
        The integration time T (negative: backward).
    interval : float, optional
        The step of the vorticity's quadrature along the trajectories (default: a hundredth of the
        duration).
    t0 : float
        The start time of every trajectory.
    levels, convexity_deficiency, min_points : int, float, int
        Contour levels tried from each maximum down, the largest convexity deficiency a boundary
        may have, the fewest points a contour may have.
    integrator : dict, optional
        Some of ``rtol``, ``atol``, ``escape_radius``, ``max_steps``.
    %(threads)s

    Returns
    -------
    xarray.Dataset
        The LAVD file (contract ``lavd``): the field on the grid and the vortices as a CF
        contiguous ragged array of boundaries (``point_count`` per vortex).

    Examples
    --------
    >>> v = ldpipe.lavd(eddy, section=ldpipe.section(x=(-1, 1, 101), y=(-1, 1, 101)), duration=4.0)  # doctest: +SKIP
    """
    from ..core.structures.lavd import lavd_dataset

    check_flow_grid("lavd", system, section)
    parameters = {"duration": duration, "interval": interval, "t0": t0, "levels": levels,
                  "convexity_deficiency": convexity_deficiency, "min_points": min_points,
                  "integrator": integrator or {}}
    return lavd_dataset(system, section, parameters, threads=threads, where="ldpipe.lavd", key="argument")
