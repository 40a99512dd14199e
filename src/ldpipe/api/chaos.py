"""Chaos indicators of a Hamiltonian flow from its LD, in memory (no stage writes them)."""

from __future__ import annotations

import xarray as xr

from ..errors import ConfigError
from .arguments import api_function


@api_function()
def chaos_indicators(system, *, section: dict, energy: float, tau: float, sigma: float, reference_tau: float,
                     dt: float = 0.01, rtol: float = 1e-10, atol: float = 1e-10,
                     sali_threshold: float = 1e-8) -> xr.Dataset:
    """Ordered and chaotic starts of a section on an energy surface, told by the LD, beside the SALI.

    At each point x of the section's grid, L = the arc-length LD over [-tau, tau]; from L at x
    and at its neighbours x +- sigma along each axis (the solved momentum solved again), the
    indicators D_L and S_L (Hillebrand et al. 2022) and the Laplacian ``|Delta L|`` (Daquin et al.
    2022); and with no neighbours the exact gradient of L along the section, carried along the
    variational equations. The reference is the SALI over ``reference_tau``. Each indicator is
    classified by a threshold of its own log10 values and its agreement with the SALI recorded.

    Parameters
    ----------
    system : System
        A natural Hamiltonian (:func:`system`).
    section : dict
        Two axes, the other coordinates fixed and a momentum solved from the energy
        (:func:`section`), as an LD map's.
    energy : float
        The energy surface.
    tau : float
        The LD's time each way.
    sigma : float
        The neighbours' distance along each axis.
    reference_tau : float
        The SALI's (and the FLI's) integration time, longer than ``tau``.
    dt : float
        The longest step of the variational equations' fourth-order Runge-Kutta integration.
    rtol, atol : float
        The DOP853 tolerances of the LDs of the starts and their neighbours.
    sali_threshold : float
        A start is chaotic by the SALI where it falls below this (Skokos's 1e-8).

    Returns
    -------
    xarray.Dataset
        Over the section's two axes: ``ld``, the indicators ``ld_difference``,
        ``ld_second_difference``, ``ld_laplacian`` and ``ld_gradient`` (with ``dld_d<axis>``),
        ``sali``, ``fli``, ``chaotic_<indicator>``, ``chaotic_sali`` and ``defined``; the
        thresholds and the agreements ``agreement_<indicator>`` in its attributes.

    Examples
    --------
    >>> found = ldpipe.chaos_indicators(
    ...     henon_heiles, section=ldpipe.section(y=(-0.45, 0.65, 60), py=(-0.5, 0.5, 60),
    ...     fixed={"x": 0.0}, solve="px"), energy=0.125, tau=200, sigma=1e-5,
    ...     reference_tau=2000)  # doctest: +SKIP
    """
    from ..core.flow_chaos import flow_chaos_indicators

    if not isinstance(section, dict):
        raise ConfigError(f"argument 'section': expected a section block (ldpipe.section), got {type(section).__name__}")
    return flow_chaos_indicators(system, section, energy, tau=tau, sigma=sigma, reference_tau=reference_tau, dt=dt,
                                 rtol=rtol, atol=atol, sali_threshold=sali_threshold)
