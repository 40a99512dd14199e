"""Stochastic LD maps: an ensemble of noisy paths from every grid point, forward and backward.

A map with a ``noise:`` block (vector fields and velocity data on the plane; see the schema)
integrates ``members`` paths of dx = f(x, t) dt + G(x, t) dW from each point of its section
(:mod:`ldpipe.engine.stochastic`) and holds, as a fixed-time LD map does, ``ld_forward``,
``ld_backward``, ``exit_time_*``, ``escaped_*`` and ``allowed``, the per-path variables with a
``member`` dimension first, and the ensemble's ``ld_forward_mean``, ``ld_forward_spread`` (and
backward): the mean and the standard deviation (n - 1 in the denominator) over the members.

Backward time: the paths of dx = -f(x, t0 - s) ds + G(x, t0 - s) dW_s for s in [0, tau], the
reversed drift with the same noise law and increments of their own (a diffusion has no
pathwise inverse; this is the backward LD of Balibrea-Iniesta et al. 2016's stochastic LD).

Every path's noise is keyed by the map's seed and start time and counted by the point's index
in the whole grid (row * columns + column), its member and its direction: a tile computes the
same bits as the whole map.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from ...engine import LDSettings
from ...engine.settings import engine_escape_radius
from ...engine.stochastic import DIAGONAL_SCHEMES, SDE_SCHEMES, StochasticSettings, compute_stochastic_ld
from ...errors import ConfigError
from ...systems.noise import Noise, parse_noise
from ..sections import Section, section_states
from .grid import BOTH, map_directions

#: Paths per engine call (the points of a call times its members): the engine's scratch stays
#: bounded whatever the map's size; the paths' bits do not depend on it.
PATHS_PER_CALL = 1 << 18
#: The map variables that take a ``member`` dimension, and their long names.
MEMBER_FIELDS = {
    "ld": "Lagrangian descriptor of the drift along the noisy path, {label} time",
    "exit_time": "{label} integration time reached (|t - t0|): tau, or the escape time (0: not started)",
    "escaped": "path escaped, or started outside the reflecting box or on land ({label})",
}
BACKWARD_TIME = ("the reversed drift with the same noise: dx = -f(x, t0 - s) ds + G(x, t0 - s) dW_s, "
                 "s in [0, tau], with increments of its own")


def resolve_noise(parameters: dict, system) -> tuple[Noise, StochasticSettings]:
    """The noise and the stochastic settings of a map's ``noise:`` block, as ConfigErrors naming its keys."""
    key = f"ld_maps.{parameters['map_name']}.noise"
    block = parameters["noise"]
    noise = parse_noise(block, system, key)
    try:
        settings = StochasticSettings.from_config(block)
    except ValueError as error:
        raise ConfigError(f"config key '{key}': {error}") from None
    if settings.scheme in DIAGONAL_SCHEMES and not noise.diagonal:
        raise ConfigError(f"config key '{key}.scheme': {settings.scheme} needs diagonal noise (g_i a function of x_i "
                          f"and t alone), got {noise.description}; use euler_maruyama")
    return noise, settings


def stochastic_grid_dataset(system, section: Section, settings: LDSettings, noise: Noise,
                            stochastic: StochasticSettings, rows: slice | None = None, t0: float = 0.0,
                            directions: str = BOTH) -> xr.Dataset:
    """The stochastic map's Dataset on the section's grid (or the band ``rows``), see the module
    docstring; ``directions`` (:data:`ldpipe.core.maps.grid.DIRECTIONS`): the directions of time
    integrated, the file holding that direction's variables alone for one."""
    rows = rows if rows is not None else slice(0, section.shape[0])
    states, allowed, _ = section_states(system, section, None, rows)
    columns = section.shape[1]
    index = np.flatnonzero(allowed.ravel()) + rows.start * columns
    shape = allowed.shape
    members = stochastic.members
    radius = engine_escape_radius(system, settings.escape_radius)
    dims = ("member", *section.axes)
    variables = {}
    chunk = max(1, PATHS_PER_CALL // members)
    for direction, label in map_directions(directions):
        parts = [compute_stochastic_ld(system, noise, states[start:start + chunk], direction, settings.tau, settings.p,
                                       stochastic, radius, t0=t0, index=index[start:start + chunk])
                 for start in range(0, max(len(states), 1), chunk)]
        ld, time, escaped, started = (np.concatenate([getattr(part, name) for part in parts])
                                      for name in ("ld", "time", "escaped", "started"))
        values = {"ld": ld, "exit_time": time, "escaped": escaped | ~started}
        for name, per_path in values.items():
            full = np.zeros((members, *shape), dtype=per_path.dtype)
            full[:, allowed] = per_path.T
            variables[f"{name}_{label}"] = (dims, full, {"long_name": MEMBER_FIELDS[name].format(label=label)})
        ld = variables[f"ld_{label}"][1]
        spread = ld.std(axis=0, ddof=1) if members > 1 else np.zeros(shape)
        variables[f"ld_{label}_mean"] = (section.axes, ld.mean(axis=0), {
            "long_name": f"ensemble mean of the {label} Lagrangian descriptor over the members"})
        variables[f"ld_{label}_spread"] = (section.axes, spread, {
            "long_name": f"ensemble standard deviation of the {label} Lagrangian descriptor over the members "
                         "(n - 1 in the denominator; 0 for one member)"})
    variables["allowed"] = (section.axes, allowed, {"long_name": "point integrated (a vector field: every point)"})
    first, second = section.axis_values()
    coords = {
        "member": ("member", np.arange(members), {"long_name": "ensemble member (its noise's counter word)"}),
        section.axes[0]: (section.axes[0], first[rows], {"long_name": f"state variable {section.axes[0]}"}),
        section.axes[1]: (section.axes[1], second, {"long_name": f"state variable {section.axes[1]}"}),
    }
    return xr.Dataset(variables, coords=coords)


def noise_attributes(noise: Noise, stochastic: StochasticSettings, tau: float) -> dict:
    """What a stochastic map's file records of its noise and scheme (replacing the integrator's)."""
    steps, h = stochastic.steps(tau)
    _, strong, strong_additive, weak = SDE_SCHEMES[stochastic.scheme]
    return {
        "noise": noise.description,
        "noise_additive": int(noise.additive),
        "scheme": stochastic.scheme,
        "scheme_strong_order": strong_additive if noise.additive else strong,
        "scheme_weak_order": weak,
        "dt": h,
        "steps": steps,
        "seed": str(stochastic.seed),
        "members": stochastic.members,
        "random_stream": "Philox4x64-10, key (seed, bits of t0), counter (step block, grid index, member, direction)",
        "reflect": "; ".join(f"{c} in [{lo:.17g}, {hi:.17g}]" for c, lo, hi, walls in
                             zip(noise.coordinates, noise.lower, noise.upper, noise.reflecting) if walls) or "none",
        "backward_time": BACKWARD_TIME,
        "descriptor_integrand": "the drift f(x, t) along the path, trapezoidal rule on the steps",
    }
