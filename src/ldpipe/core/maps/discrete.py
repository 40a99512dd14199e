"""The LD map of a discrete map x_{n+1} = f(x_n): the discrete LD over a grid of starts.

The discrete LD of Lopesino et al. (2015) of a start x_0 is

    M_p(x_0) = sum_{n=-N}^{N-1} sum_i |x^i_{n+1} - x^i_n|^p,

its forward half (n = 0 ... N-1, the iterates of f) and its backward half (n = -N ... -1, the
iterates of f^-1) stored apart as a flow's map stores them (``ld_forward``, ``ld_backward``;
their sum is M_p). N is the map's ``iterations``, p its ``p``. An orbit that escapes (an iterate
beyond the escape radius, or not finite) is flagged (``escaped_*``): its half holds the
iterations before it left (``iterations_*``), never an infinity. The grid is the section's (two
axes, every other coordinate fixed), split in tiles of rows as a flow's map is; the file has
the variables and attributes of a flow's map where they apply (:mod:`ldpipe.core.maps.assembly`
gathers and records it), with ``iterations`` and ``p`` recorded. A ``chaos_indicators`` block
adds each point's LD chaos indicators and, if asked, its FLI (:mod:`ldpipe.core.maps.chaos`);
the whole map's classifications and their agreement are added when it is finished.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from ...engine.discrete_map import fast_lyapunov_indicator, iterate_map_ld
from ...engine.integrands import descriptor_attribute
from ...logs import get_logger
from ...systems import make_system
from ..sections import Section, section_states
from .chaos import INDICATORS, ld_indicators, regular_fli_bound
from .grid import directions_setting, map_directions, tile_rows

log = get_logger(__name__)

#: What the ``ld_definition`` attribute of a map's LD file says.
DEFINITION = ("M_p = sum over n from -N to N-1 of sum_i |x^i_{n+1} - x^i_n|^p (Lopesino et al. 2015); "
              "ld_forward holds n = 0 .. N-1, ld_backward n = -N .. -1; periodic coordinates' increments "
              "on the circle")


def resolve_discrete_map(parameters: dict) -> tuple:
    """``(system, section)`` of a discrete map's LD-map parameters (its ``ld_maps`` entry as the
    stage takes it)."""
    system = make_system(parameters["system_name"], parameters["system_spec"])
    key = f"ld_maps.{parameters['map_name']}"
    section = Section.from_spec(parameters["section"], system, None, key=f"{key}.section")
    return system, section


def discrete_ld_dataset(parameters: dict, *, tile: int = 0, tiles: int = 1) -> xr.Dataset:
    """One tile (or, with ``tiles`` 1, the whole) of a discrete map's LD map, with its attributes
    (see the module docstring): both halves, or the one its ``directions`` names; the backward
    half is refused, naming the system's ``inverse`` key, for a map without its inverse."""
    system, section = resolve_discrete_map(parameters)
    directions = map_directions(directions_setting(parameters))
    if any(sign < 0 for sign, _ in directions):
        system.require_inverse(f"the backward half of the LD map {parameters['map_name']!r} (directions: "
                               f"{directions_setting(parameters)}; forward alone needs none)")
    rows = tile_rows(section.shape[0], tile, tiles)
    states, allowed, _ = section_states(system, section, None, rows)
    iterations, p = int(parameters["iterations"]), float(parameters["p"])
    radius = float(parameters["integrator"]["escape_radius"])
    log.info("map %s, tile %d of %d (rows %d:%d of %d): %s, N = %d, p = %g", parameters["map_name"], tile + 1,
             tiles, rows.start, rows.stop, section.shape[0], system.name, iterations, p)
    dims = section.axes
    shape = allowed.shape
    variables = {}
    sums = {"forward": "n = 0 .. N-1", "backward": "n = -N .. -1"}
    for direction, label in directions:
        result = iterate_map_ld(system, states, iterations, p, direction, radius)
        variables[f"ld_{label}"] = (dims, result.ld.reshape(shape), {
            "long_name": f"discrete Lagrangian descriptor, {label} iterations ({sums[label]})",
            "comment": "the iterations before the orbit escaped where it did (see escaped and iterations)"})
        variables[f"iterations_{label}"] = (dims, result.iterations.reshape(shape), {
            "long_name": f"{label} iterations the LD holds: N, or those before the orbit escaped"})
        variables[f"escaped_{label}"] = (dims, result.escaped.reshape(shape), {
            "long_name": f"orbit escaped ({label}): an iterate beyond the escape radius, or not finite"})
    variables["allowed"] = (dims, allowed, {"long_name": "point iterated (a map: every point)"})
    chaos = parameters.get("chaos_indicators")
    if chaos is not None:
        variables.update(indicator_variables(system, states, shape, dims, iterations, p, radius, chaos))
    coords = {name: (name, values, {"long_name": f"coordinate {name}"})
              for name, values in zip(section.axes, (section.axis_values()[0][rows], section.axis_values()[1]))}
    dataset = xr.Dataset(variables, coords=coords)
    periodic = [f"{c} mod {period!r}" for c, period in zip(system.coordinates, system.periods) if period]
    if chaos is not None:
        dataset.attrs.update({"sigma": chaos["sigma"], "fli_iterations": chaos["fli_iterations"] or 0,
                              "fli_regular_bound": regular_fli_bound(chaos["fli_iterations"])
                              if chaos["fli_iterations"] else 0.0})
    dataset.attrs.update({
        "map": parameters["map_name"],
        "system": parameters["system_name"],
        "discrete_map": system.description,
        "iterations": iterations,
        "p": p,
        # the halves computed (a map of one has only that half's variables)
        "directions": directions_setting(parameters),
        "descriptor": descriptor_attribute(p),
        "ld_definition": DEFINITION,
        "escape_radius": radius,
        "periodic": ", ".join(periodic) if periodic else "none",
        "tile": tile,
        "tiles": tiles,
    })
    return dataset


def indicator_variables(system, states: np.ndarray, shape: tuple, dims: tuple, iterations: int, p: float,
                        radius: float, chaos: dict) -> dict:
    """The map's ``chaos_indicators`` block made variables: each point's LD indicators from its
    neighbours at ``sigma`` (:func:`ldpipe.core.maps.chaos.ld_indicators`, a point at a time, so
    tiles change nothing), and its FLI over ``fli_iterations`` where asked for."""
    found = ld_indicators(system, states, iterations, p, chaos["sigma"], radius)
    variables = {name: (dims, found[name].reshape(shape), {"long_name": text, "comment": "0 where not defined"})
                 for name, text in INDICATORS.items()}
    variables["indicator_defined"] = (dims, found["defined"].reshape(shape), {
        "long_name": "the LD indicators are defined: L > 0 and no orbit of the point or its neighbours escaped"})
    if chaos["fli_iterations"]:
        fli, escaped = fast_lyapunov_indicator(system, states, chaos["fli_iterations"], radius)
        variables["fli"] = (dims, fli.reshape(shape), {
            "long_name": f"fast Lyapunov indicator over {chaos['fli_iterations']} iterations of the tangent map",
            "comment": "max over n of log10 |w_n|; chaotic above fli_regular_bound"})
        variables["fli_escaped"] = (dims, escaped.reshape(shape), {
            "long_name": "the orbit escaped before the FLI's iterations ended"})
    return variables
