"""Transport over an index-1 saddle: flux, reactive islands and rates.

In 2 DoF three quantities must agree (MacKay 1990; reactive-island theory): the action
of the Lyapunov orbit, the symplectic area enclosed by a manifold tube's cut with a
surface of section, and the reactive flux through a dividing surface across the saddle.
:mod:`ldpipe.core.transport.flux` computes each of them independently;
:func:`ldpipe.core.transport.transport_at_energy` (:mod:`ldpipe.core.transport.study`) computes them all
at one energy, with the transition-state rate, survival and gap times.
"""

from .flux import (
    DividingLine,
    MonteCarloFlux,
    closed_curve_area,
    harmonic_flux,
    orbit_action,
    reactive_flux_monte_carlo,
)

__all__ = [
    "DividingLine",
    "MonteCarloFlux",
    "closed_curve_area",
    "harmonic_flux",
    "orbit_action",
    "reactive_flux_monte_carlo",
]

from .well import well_area, well_shell_volume  # noqa: E402

__all__ += ["well_area", "well_shell_volume"]

from .survival import decay_rate, exit_times, initial_slope, sample_well, survival  # noqa: E402

__all__ += ["decay_rate", "exit_times", "initial_slope", "sample_well", "survival"]

from .gap_times import GapTimes, entering_states, gap_times  # noqa: E402

__all__ += ["GapTimes", "entering_states", "gap_times"]

from .plane import DividingPlane  # noqa: E402

__all__ += ["DividingPlane"]

from .study import LyapunovOrbit, TransportAtEnergy, reactive_islands, transport_at_energy  # noqa: E402

__all__ += ["LyapunovOrbit", "TransportAtEnergy", "reactive_islands", "transport_at_energy"]
