"""A map's time estimate, measured by a pilot before its first trajectory
(:mod:`ldpipe.core.maps.pilot`).

The estimate's arithmetic is checked on an integration of known cost: a clock that the stand-in
integration advances by exactly ``cost`` per trajectory and unit of time, plus a fixed overhead
per call. The whole map then takes cost * points * tau * directions, plus the overhead once a
direction (one call each), the closed form the estimate must reproduce."""

import logging

import numpy as np
import pytest

from ldpipe.config import validate_config
from ldpipe.config.parameters import parameters_from_config
from ldpipe.core.maps import pilot
from ldpipe.core.equilibria.potential import equilibrium_table
from ldpipe.core.maps.assembly import compute_ld_map
from ldpipe.systems import make_system
from support.henon_heiles import HENON_HEILES, hh_slice


class KnownCost:
    """An integration whose wall time is ``cost`` s a trajectory and unit of time, plus ``overhead``
    s a call, on a clock of its own that the pilot reads."""

    def __init__(self, cost: float, overhead: float = 0.0):
        self.cost, self.overhead, self.now, self.calls = cost, overhead, 0.0, []

    def clock(self) -> float:
        return self.now

    def __call__(self, states, tau):
        self.calls.append((len(states), tau))
        self.now += self.cost * len(states) * tau + self.overhead


@pytest.fixture
def known_cost(monkeypatch):
    def make(cost, overhead=0.0):
        integration = KnownCost(cost, overhead)
        monkeypatch.setattr(pilot.time, "perf_counter", integration.clock)
        return integration
    return make


@pytest.mark.parametrize("directions", [1, 2])
def test_the_estimate_is_the_closed_form_cost(known_cost, directions):
    """Without overhead the pilot's rate is exact: cost * points * tau * directions."""
    integration = known_cost(cost=1e-4)
    points, tau = 250_000, 1000.0
    estimate = pilot.estimate_seconds(integration, np.zeros((points, 4)), tau, directions)
    assert estimate.seconds == pytest.approx(1e-4 * points * tau * directions, rel=1e-12)
    assert estimate.pilot_tau < tau
    # the first call only loads the engine (one trajectory); the timed ones are the pilot's 512,
    # then its first eighth over the same time (what a call costs besides its trajectories)
    # (twice at each time: the first call reads what its time needs, the second is timed)
    growing, (few, same) = integration.calls[1:-1], integration.calls[-1]
    assert integration.calls[0][0] == 1 and {n for n, _ in growing} == {pilot.PILOT_TRAJECTORIES}
    assert few == pilot.PILOT_TRAJECTORIES // pilot.PILOT_GROWTH and same == growing[-1][1]
    # the pilot grows (x8 a step, from tau/4096) until it has measured enough, at most to tau itself
    assert [t for _, t in growing] == [tau / 4096 * 8**(k // 2) for k in range(len(growing))]
    assert estimate.pilot_seconds >= pilot.PILOT_SECONDS or (
        estimate.seconds < pilot.WARN_SECONDS / pilot.PILOT_GROWTH and estimate.pilot_seconds >= pilot.PILOT_SECONDS_CHEAP)


def test_a_fixed_overhead_is_counted_once_a_call_not_once_a_trajectory(known_cost):
    """A call's overhead (a window of velocity data read) is told from the trajectories' cost by the
    two calls over the same time: the map costs cost * points * tau * 2 plus the overhead once a
    direction (closed form), where scaling the pilot's whole rate would count it 100 000 / 512 times."""
    integration = known_cost(cost=1e-6, overhead=1e-3)
    points, tau = 100_000, 50.0
    estimate = pilot.estimate_seconds(integration, np.zeros((points, 4)), tau, 2)
    assert estimate.seconds == pytest.approx(1e-6 * points * tau * 2 + 1e-3 * 2, rel=1e-9)


def test_cheap_maps_are_measured_coarsely_and_small_maps_not_at_all(known_cost):
    integration = known_cost(cost=1e-5)  # 4 s for this map: measured to 5 ms, not to 50
    estimate = pilot.estimate_seconds(integration, np.zeros((20_000, 4)), 10.0, 2)
    assert estimate.seconds == pytest.approx(4.0)
    assert pilot.PILOT_SECONDS_CHEAP <= estimate.pilot_seconds < pilot.PILOT_SECONDS
    assert pilot.estimate_seconds(integration, np.zeros((pilot.PILOT_MIN_POINTS - 1, 4)), 10.0, 2) is None


def test_a_long_map_is_warned_about_naming_what_shortens_it(known_cost, caplog):
    integration = known_cost(cost=1e-3)  # 1 ms a trajectory and unit of time: 12 days for this map
    with caplog.at_level(logging.WARNING, logger="ldpipe"):
        estimate = pilot.check_map_time("map big, tile 1 of 1", integration, np.zeros((500_000, 4)), 1000.0, 2)
    assert estimate.seconds == pytest.approx(1e-3 * 500_000 * 1000.0 * 2)
    [record] = [r for r in caplog.records if r.levelno == logging.WARNING]
    message = record.getMessage()
    for words in ("map big, tile 1 of 1", "days", "500000 in 2 direction", "tau (1000)", "rtol", "more tiles"):
        assert words in message


def test_a_map_that_fits_is_not_warned_about(known_cost, caplog):
    integration = known_cost(cost=1e-8)
    with caplog.at_level(logging.INFO, logger="ldpipe"):
        pilot.check_map_time("map small", integration, np.zeros((50_000, 4)), 10.0, 2)
    assert not [r for r in caplog.records if r.levelno >= logging.WARNING]
    assert any("estimated from a pilot of 512 trajectories" in r.getMessage() for r in caplog.records)


def test_a_piloted_map_equals_the_map_without_a_pilot(monkeypatch, caplog):
    """The pilot integrates copies of the map's own start points with its own engine: the map itself
    is untouched, bit for bit, and the estimate is logged before it."""
    entry = hh_slice()
    entry["section"]["axes"][0]["points"], entry["section"]["axes"][1]["points"] = 160, 120
    config = validate_config({"systems": {"henon_heiles": dict(HENON_HEILES)}, "ld_maps": {"m": entry}})
    parameters = parameters_from_config(config, "ld", "m")
    equilibria = equilibrium_table(make_system("henon_heiles", dict(HENON_HEILES)), {"x": [-2.0, 2.0], "y": [-2.0, 2.0]})
    with caplog.at_level(logging.INFO, logger="ldpipe"):
        piloted = compute_ld_map(parameters, equilibria, show_progress=False)
    assert int(piloted.allowed.sum()) >= pilot.PILOT_MIN_POINTS
    assert any("map m, tile 1 of 1: about" in r.getMessage() for r in caplog.records)
    monkeypatch.setattr(pilot, "PILOT_MIN_POINTS", 10**9)
    plain = compute_ld_map(parameters, equilibria, show_progress=False)
    for name in plain.data_vars:
        np.testing.assert_array_equal(piloted[name].values, plain[name].values, err_msg=name)


def test_the_rate_tells_a_trajectory_s_cost_from_a_call_s(known_cost):
    """What sizes a Dask block (chunks="auto"): a trajectory's own cost over tau and a call's fixed
    cost, each exactly (closed forms: cost * tau and the overhead), however large the overhead."""
    integration = known_cost(cost=2e-6, overhead=5e-3)
    rate = pilot.pilot_rate(integration, np.zeros((512, 4)), 4.0)
    assert rate.trajectory == pytest.approx(2e-6 * 4.0, rel=1e-9)
    assert rate.call == pytest.approx(5e-3, rel=1e-9)
