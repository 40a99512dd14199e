"""What a map will cost in time, measured before it runs: a pilot integrates a few of its
trajectories over a fraction of ``tau``, and the rate it measures, scaled to every trajectory and
the whole ``tau``, is the estimate. A map estimated to run long is warned about before its first
trajectory, naming what shortens it (it can still be interrupted with Ctrl-C: nothing is written
until it finishes).

A trajectory's cost grows with its integration time at most linearly (steps are fixed per unit
time, or fewer once a trajectory escapes or leaves the region), so the rate scaled to the whole
tau bounds it from above. What an engine call costs whatever its size (its inputs; a window of
velocity data, read once per call) is measured apart, by a second, smaller call over the same
time, and counted once a call, not once a trajectory."""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ...logs import get_logger

log = get_logger(__name__)

#: Trajectories a pilot integrates, spread evenly over the map's start points: enough that a
#: call's fixed cost (a window of velocity data read) can be told from its trajectories'.
PILOT_TRAJECTORIES = 512
#: Below this many start points a map is not piloted: the pilot would cost a noticeable share of
#: the map, and tau (at most 10^4 in the configuration) cannot make so few trajectories run long.
PILOT_MIN_POINTS = 10_000
#: A pilot's integration time grows by this factor until it measures at least PILOT_SECONDS.
PILOT_GROWTH = 8
PILOT_FIRST_FRACTION = 1.0 / 4096
PILOT_SECONDS = 0.05
#: ... or at least this much where its estimate is already far below the warning.
PILOT_SECONDS_CHEAP = 0.005
#: Estimated seconds beyond which a map is warned about.
WARN_SECONDS = 600.0

#: Integrates the given start points over the given time (the map's engine call).
Integrate = Callable[[np.ndarray, float], object]


@dataclass(frozen=True)
class TimeEstimate:
    """A pilot's measurement: ``seconds`` for the whole map, from ``pilot_seconds`` of wall time
    spent integrating ``trajectories`` start points over ``pilot_tau``."""

    seconds: float
    trajectories: int
    pilot_tau: float
    pilot_seconds: float

    def describe(self) -> str:
        return (f"about {_duration(self.seconds)} estimated from a pilot of {self.trajectories} trajectories "
                f"over tau = {self.pilot_tau:.3g} ({self.pilot_seconds:.3g} s)")


@dataclass(frozen=True)
class PilotRate:
    """What a pilot measured: ``trajectory`` s a trajectory takes over the whole tau (one
    direction), and ``call`` s an engine call costs besides its trajectories (its inputs, a
    window of velocity data read), from ``pilot_seconds`` of integrating ``trajectories`` start
    points over ``pilot_tau``."""

    trajectory: float
    call: float
    trajectories: int
    pilot_tau: float
    pilot_seconds: float


def estimate_seconds(integrate: Integrate, states: np.ndarray, tau: float, directions: int) -> TimeEstimate | None:
    """The wall time of integrating every row of ``states`` over ``tau`` in each of ``directions``
    (a call for each), from pilots of :data:`PILOT_TRAJECTORIES` of them (:func:`pilot_rate`);
    None for a map of fewer than :data:`PILOT_MIN_POINTS` points (not piloted)."""
    points = len(states)
    if points < PILOT_MIN_POINTS:
        return None
    sample = states[np.linspace(0, points - 1, PILOT_TRAJECTORIES).round().astype(int)]

    def enough(per_trajectory: float, elapsed: float) -> bool:
        # an estimate already far below the warning needs no finer measurement
        return per_trajectory * points * directions < WARN_SECONDS / PILOT_GROWTH and elapsed >= PILOT_SECONDS_CHEAP

    rate = pilot_rate(integrate, sample, tau, enough)
    return TimeEstimate((rate.trajectory * points + rate.call) * directions, rate.trajectories, rate.pilot_tau,
                        rate.pilot_seconds)


def pilot_rate(integrate: Integrate, sample: np.ndarray, tau: float, enough=None) -> PilotRate:
    """``sample`` (start points spread over a map) integrated over a growing share of ``tau``,
    twice at each (the first call reads what its time needs, such as a window of velocity data;
    the second has it), until the second measures :data:`PILOT_SECONDS`, reaches ``tau``, or
    ``enough(seconds a trajectory, pilot seconds)``; then the sample's first
    1/:data:`PILOT_GROWTH` over the same time. The difference of the last two is the
    trajectories' own cost; the rest of the smaller call and what the first call read, a call's
    fixed cost (at the pilot's tau). Where the difference is not positive (timing noise) the
    whole rate is the trajectories' (an upper bound)."""
    def timed(states: np.ndarray, pilot_tau: float) -> float:
        start = time.perf_counter()
        integrate(states, pilot_tau)
        return time.perf_counter() - start

    integrate(sample[:1], tau * PILOT_FIRST_FRACTION)  # compiles or loads the engine: not part of the rate
    fraction = PILOT_FIRST_FRACTION
    while True:
        pilot_tau = tau * min(fraction, 1.0)
        first = timed(sample, pilot_tau)
        elapsed = timed(sample, pilot_tau)
        per_trajectory = elapsed * (tau / pilot_tau) / len(sample)
        if elapsed >= PILOT_SECONDS or fraction >= 1.0 or (enough is not None and enough(per_trajectory, elapsed)):
            break
        fraction *= PILOT_GROWTH
    few = sample[: max(1, len(sample) // PILOT_GROWTH)]
    fewer = timed(few, pilot_tau)
    read = max(0.0, first - elapsed)
    if elapsed <= fewer or len(few) == len(sample):
        return PilotRate(per_trajectory, read, len(sample), pilot_tau, elapsed)
    marginal = (elapsed - fewer) / (len(sample) - len(few))
    return PilotRate(marginal * tau / pilot_tau, read + max(0.0, fewer - marginal * len(few)), len(sample),
                     pilot_tau, elapsed)


def check_map_time(label: str, integrate: Integrate, states: np.ndarray, tau: float,
                   directions: int) -> TimeEstimate | None:
    """Pilot the map ``label`` names (:func:`estimate_seconds`) and warn, naming what shortens it,
    if it is estimated to take longer than :data:`WARN_SECONDS`; the estimate, logged."""
    estimate = estimate_seconds(integrate, states, tau, directions)
    if estimate is None:
        return None
    if estimate.seconds > WARN_SECONDS:
        log.warning("%s will take %s; to shorten it give fewer start points (%d in %d direction(s) of time), "
                    "a shorter tau (%g), a looser rtol, or more tiles (each its own job)",
                    label, estimate.describe(), len(states), directions, tau)
    else:
        log.info("%s: %s", label, estimate.describe())
    return estimate


def _duration(seconds: float) -> str:
    """``seconds`` in the unit a person reads it in."""
    for unit, size in (("days", 86400.0), ("h", 3600.0), ("min", 60.0)):
        if seconds >= size:
            return f"{seconds / size:.3g} {unit}"
    return f"{seconds:.3g} s"
