"""A normal-form study at a list of energies: the flux by order, its truncation error and the NHIM points.

A study is declared under ``normal_form:`` in the configuration: a system, its saddle
(``saddle_near``, default the lowest), energies, the order and the form (``full`` or ``partial``).
:func:`normal_form_dataset` is its stage file: at each energy, the flux over the saddle
(:func:`ldpipe.core.normal_form.flux`: the action of the Lyapunov orbit in 2 DoF, (2π)² times an
area of the centre actions in 3 DoF) at every even order, its truncation error (the change from
the order below), the harmonic estimate and the NHIM points in phase space; the smallest divisor
met at each degree; the normal form's terms in the actions. A ``transport`` study (2 DoF: the
orbit's action and the Monte Carlo flux) or a ``saddle_flux`` study (the Monte Carlo flux) named
in the study is copied in for comparison.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass

import numpy as np
import xarray as xr

from ...io.contracts import EQUILIBRIA, NORMAL_FORM, SADDLE_FLUX, TRANSPORT
from ...io.datafile import open_stage_file, stage_dataset
from ...logs import get_logger
from ...systems import make_system
from ..equilibria.potential import select_saddle, well_and_frequencies
from ..orbits.family import target_energies
from ..transport.flux import harmonic_flux
from .flux import flux, nhim_points
from .saddle import EquilibriumNormalForm, system_normal_form

log = get_logger(__name__)


@dataclass(frozen=True)
class FluxTable:
    """``by_order[i, j]``: the flux at ``excess[i]`` from K truncated at degree ``orders[j]``."""

    excess: np.ndarray
    orders: np.ndarray
    by_order: np.ndarray

    @property
    def flux(self) -> np.ndarray:
        return self.by_order[:, -1]

    @property
    def truncation_error(self) -> np.ndarray:
        """|flux at the order − flux at the even order below| (NaN with a single order)."""
        if self.by_order.shape[1] < 2:
            return np.full(len(self.excess), np.nan)
        return np.abs(self.by_order[:, -1] - self.by_order[:, -2])


def flux_table(nf: EquilibriumNormalForm, excess, *, method: str | None = None) -> FluxTable:
    """The flux at every excess energy and every even order ≤ the normal form's (actions for the full
    form, the centre-volume quadrature for the partial one, unless ``method`` says)."""
    method = method or ("actions" if nf.normalization.form == "full" else "volume")
    excess = np.asarray(excess, dtype=np.float64)
    orders = np.arange(2, nf.order + 1, 2)
    values = np.array([[flux(nf, float(e), method=method, order=int(o)) for o in orders] for e in excess])
    return FluxTable(excess=excess, orders=orders, by_order=values)


def nhim_samples(nf: EquilibriumNormalForm, excess, angles: int) -> np.ndarray:
    """NHIM points at each excess energy, shape (energies, points, 2n)."""
    nodes = 4
    return np.stack([nhim_points(nf, float(e), angles=angles, nodes=nodes) for e in np.atleast_1d(excess)])


def compared_values(transport: str | os.PathLike | xr.Dataset | None,
                    saddle_flux: str | os.PathLike | xr.Dataset | None) -> dict:
    """The compared studies' fluxes (their files or Datasets) as variables of their own energy
    dimensions: the orbits' actions of a transport study; the Monte Carlo flux of the saddle-flux
    study, or else of the transport study."""
    variables = {}
    if transport is not None:
        data = open_stage_file(transport, stage=TRANSPORT)
        variables["orbit_excess_energy"] = (("orbit_energy",), data.excess_energy.values,
                                            {"long_name": "excess energy of the transport study's orbits"})
        variables["flux_orbit_action"] = (("orbit_energy",), data.flux_action.values,
                                          {"long_name": "action of the Lyapunov orbit (transport study)"})
    source = saddle_flux if saddle_flux is not None else transport
    if source is not None:
        data = open_stage_file(source, stage=SADDLE_FLUX if saddle_flux is not None else TRANSPORT)
        origin = "saddle-flux" if saddle_flux is not None else "transport"
        variables["monte_carlo_excess_energy"] = (("monte_carlo_energy",), data.excess_energy.values,
                                                  {"long_name": f"excess energy of the {origin} study's Monte Carlo"})
        variables["flux_monte_carlo"] = (("monte_carlo_energy",), data.flux_monte_carlo.values,
                                         {"long_name": f"reactive flux, Monte Carlo ({origin} study)"})
        variables["flux_monte_carlo_stderr"] = (("monte_carlo_energy",), data.flux_monte_carlo_stderr.values,
                                                {"long_name": "standard error of flux_monte_carlo"})
    return variables


def normal_form_dataset(parameters: dict, equilibria: str | os.PathLike | xr.Dataset, *,
                        transport: str | os.PathLike | xr.Dataset | None = None,
                        saddle_flux: str | os.PathLike | xr.Dataset | None = None) -> xr.Dataset:
    """The normal form of the study's saddle and everything computed from it, as the normal-form
    stage's file holds it: ``parameters`` are the stage's
    (:func:`ldpipe.config.parameters.parameters_from_config`), ``equilibria`` the system's
    equilibria file or Dataset (the saddle and its centre frequencies), ``transport`` and
    ``saddle_flux`` the files or Datasets of the studies the parameters ``transport`` and
    ``saddle_flux`` name, if they do, whose fluxes are copied in."""
    key = f"normal_form.{parameters['name']}"
    system = make_system(parameters["system_name"], parameters["system_spec"])
    eq = open_stage_file(equilibria, stage=EQUILIBRIA)
    saddle, critical = select_saddle(eq, parameters.get("saddle_near"))
    _, frequencies = well_and_frequencies(eq, saddle, require_well=False)
    energies = target_energies(parameters["energies"], critical, key)
    excess = energies - critical
    start = time.perf_counter()
    nf = system_normal_form(system, saddle, parameters["order"], form=parameters["form"], transforms=False)
    seconds = time.perf_counter() - start
    log.info("%s: normal form of degree %d (%s); smallest divisors by degree %s", key, nf.order,
             parameters["form"], {d: round(v, 6) for d, v in nf.normalization.smallest_divisor.items()})
    table = flux_table(nf, excess)
    points = nhim_samples(nf, excess, parameters["nhim_angles"])  # the change to the original coordinates: the cost
    seconds = time.perf_counter() - start
    log.info("%s: normal form, fluxes and NHIM points in %.2f s", key, seconds)
    for e, value, error in zip(excess, table.flux, table.truncation_error):
        log.info("dE = %.6g: flux %.12g, truncation error %.2g", e, value, error)
    degrees = np.array(sorted(nf.normalization.smallest_divisor))
    divisors = {d: v if np.isfinite(v) else 0.0 for d, v in nf.normalization.smallest_divisor.items()}
    exponents, coefficients = nf.action_terms()
    data = xr.Dataset(
        {
            "total_energy": (("energy",), energies, {"long_name": "energy E"}),
            "excess_energy": (("energy",), excess, {"long_name": "excess energy E - E_c above the saddle"}),
            "flux": (("energy",), table.flux, {"long_name": "flux over the saddle from the normal form"}),
            "flux_truncation_error": (("energy",), table.truncation_error,
                                      {"long_name": "|flux - flux at the even order below|"}),
            "flux_by_order": (("energy", "order"), table.by_order,
                              {"long_name": "flux from the normal form truncated at each order"}),
            "flux_harmonic": (("energy",), harmonic_flux(excess, frequencies),
                              {"long_name": "flux over the quadratic saddle with the same centre frequencies"}),
            "smallest_divisor": (("degree",), np.array([divisors[d] for d in degrees]),
                                 {"long_name": "smallest |<eta, a - b>| divided by at each degree (0: none)"}),
            "resonant_terms": (("degree",), np.array([nf.normalization.resonant_terms[d] for d in degrees]),
                               {"long_name": "monomials kept as exactly resonant at each degree"}),
            "action_exponents": (("term", "mode"), exponents,
                                 {"long_name": "exponents of (I, J_2, ..) of the normal form's terms in the actions"}),
            "action_coefficients": (("term",), coefficients, {"long_name": "coefficients of those terms"}),
            "nhim_state": (("energy", "point", "phase"), points,
                           {"long_name": "points of the NHIM at each energy, in phase space"}),
            **compared_values(transport, saddle_flux),
        },
        coords={"order": table.orders, "degree": degrees, "phase": list(system.phase_coordinates)},
        attrs={"system": system.name, "n_dof": system.n_dof, "saddle_position": saddle, "critical_energy": critical,
               "centre_frequencies": nf.modes.frequencies, "saddle_rate": nf.modes.saddle_rate,
               "form": parameters["form"], "normal_form_seconds": seconds,
               "imaginary_residual": nf.imaginary_residual},
    )
    title = f"Normal form of degree {nf.order} of the saddle of {system.name} at {saddle.tolist()}"
    return stage_dataset(data, stage=NORMAL_FORM, title=title, parameters=parameters)
