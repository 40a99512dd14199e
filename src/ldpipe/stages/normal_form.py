"""Normal-form stage: the saddle's normal form, the flux over it by energy and order, the NHIM points.

A study is declared under ``normal_form:`` in the configuration: a system, its saddle
(``saddle_near``, default the lowest), energies, the order and the form (``full`` or ``partial``).
It writes, at each energy, the flux over the saddle (:func:`ldpipe.core.normal_form.flux`: the action of
the Lyapunov orbit in 2 DoF, (2π)² times an area of the centre actions in 3 DoF) at every even
order, its truncation error (the change from the order below), the harmonic estimate and the NHIM
points in phase space; the smallest divisor met at each degree; the normal form's terms in the
actions. A ``transport`` study (2 DoF: the orbit's action and the Monte Carlo flux) or a
``saddle_flux`` study (the Monte Carlo flux) named in the study is copied in for comparison.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import xarray as xr

from ..core.equilibria.potential import select_saddle, well_and_frequencies
from ..io.atomic import check_writable
from ..io.contracts import EQUILIBRIA, NORMAL_FORM, SADDLE_FLUX, TRANSPORT
from ..io.datafile import open_stage_file, write_stage_file
from ..logs import get_logger
from ..core.normal_form import system_normal_form
from ..core.normal_form.study import flux_table, nhim_samples
from ..systems import make_system
from ..core.transport import harmonic_flux
from ..core.orbits.family import target_energies

log = get_logger(__name__)


def compared_values(transport: str | Path | None, saddle_flux: str | Path | None) -> dict:
    """The compared studies' fluxes as variables of their own energy dimensions."""
    variables = {}
    if transport:
        data = open_stage_file(transport, stage=TRANSPORT)
        variables["orbit_excess_energy"] = (("orbit_energy",), data.excess_energy.values,
                                            {"long_name": "excess energy of the transport study's orbits"})
        variables["flux_orbit_action"] = (("orbit_energy",), data.flux_action.values,
                                          {"long_name": "action of the Lyapunov orbit (transport study)"})
    source = saddle_flux or transport
    if source:
        data = open_stage_file(source, stage=SADDLE_FLUX if saddle_flux else TRANSPORT)
        origin = "saddle-flux" if saddle_flux else "transport"
        variables["monte_carlo_excess_energy"] = (("monte_carlo_energy",), data.excess_energy.values,
                                                  {"long_name": f"excess energy of the {origin} study's Monte Carlo"})
        variables["flux_monte_carlo"] = (("monte_carlo_energy",), data.flux_monte_carlo.values,
                                         {"long_name": f"reactive flux, Monte Carlo ({origin} study)"})
        variables["flux_monte_carlo_stderr"] = (("monte_carlo_energy",), data.flux_monte_carlo_stderr.values,
                                                {"long_name": "standard error of flux_monte_carlo"})
    return variables


def run_normal_form(*, output: str | Path, equilibria: str | Path, transport_file: str | Path | None = None,
                    saddle_flux_file: str | Path | None = None, **parameters) -> Path:
    """The normal form of the study's saddle and everything computed from it; writes ``output``.

    ``transport_file`` and ``saddle_flux_file`` are the files of the studies the parameters
    ``transport`` and ``saddle_flux`` name, if they do."""
    check_writable(output)  # before any work: never lose a run to a bad path
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
            **compared_values(transport_file, saddle_flux_file),
        },
        coords={"order": table.orders, "degree": degrees, "phase": list(system.phase_coordinates)},
        attrs={"system": system.name, "n_dof": system.n_dof, "saddle_position": saddle, "critical_energy": critical,
               "centre_frequencies": nf.modes.frequencies, "saddle_rate": nf.modes.saddle_rate,
               "form": parameters["form"], "normal_form_seconds": seconds,
               "imaginary_residual": nf.imaginary_residual},
    )
    title = f"Normal form of degree {nf.order} of the saddle of {system.name} at {saddle.tolist()}"
    path = write_stage_file(data, output, stage=NORMAL_FORM, title=title, parameters=parameters)
    log.info("wrote %s", path)
    return path
