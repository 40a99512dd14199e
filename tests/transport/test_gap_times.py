"""Gap times in the Barbanis well, against the exact identity that ties them to survival.

Independent values: for a well of shell volume V whose dividing lines carry one-way flux Φ (their
areas, closed-form quadrature), the flux-weighted entering ensemble's gap times τ and the fraction
F(T) of the well's microcanonical ensemble that has left by T satisfy V F(T) = Φ E[min(τ, T)] for
every T (ldpipe.core.transport.survival derives it from time-reversal symmetry). Both sides come from
separate ensembles (one drawn on the lines, one in the well) with separate random numbers.
"""

import math

import numpy as np
import pytest

from ldpipe.core.trajectories import FlowSettings
from ldpipe.core.transport import DividingLine, entering_states, exit_times, gap_times, sample_well, well_shell_volume

EXCESS = 2.25
FLOW = FlowSettings(rtol=1e-9, atol=1e-9, escape_radius=30.0)


@pytest.fixture(scope="module")
def well(barbanis):
    energy = 15.125 + EXCESS  # E_c = ω_x² ω_y⁴ / (8 δ²) = 15.125 for the default parameters
    lines = [DividingLine.at_saddle(barbanis, [5.5, sign * math.sqrt(50.0)], energy) for sign in (-1, 1)]
    return energy, lines, well_shell_volume(barbanis, [0.0, 0.0], energy, lines)


def test_entering_states_lie_on_the_lines_moving_inwards_at_energy_E(barbanis, well):
    energy, lines, _ = well
    states = entering_states(lines, 3000, np.random.default_rng(1))
    assert np.max(np.abs([barbanis.energy(row) - energy for row in states])) < 1e-12 * energy
    on_line = [np.abs((states[:, :2] - line.saddle) @ line.normal) < 1e-12 for line in lines]
    assert np.all(on_line[0] | on_line[1])
    for line, mask in zip(lines, on_line):
        assert np.all(states[mask, 2:] @ line.normal <= 0)
    # The two lines carry equal flux (y -> -y symmetry): each gets half the states, binomially.
    assert abs(on_line[0].mean() - 0.5) < 4 * math.sqrt(0.25 / len(states))


def test_gap_times_and_survival_satisfy_the_flux_volume_identity(barbanis, well):
    energy, lines, volume = well
    horizon, count = 50.0, 8000
    gaps = gap_times(barbanis, lines, count, horizon, np.random.default_rng(7), sample_step=0.1, flow=FLOW)
    assert gaps.flux == pytest.approx(sum(line.area() for line in lines), rel=1e-14)
    left = exit_times(barbanis, sample_well(barbanis, [0.0, 0.0], energy, lines, count, np.random.default_rng(8)),
                      lines, horizon, sample_step=0.1, flow=FLOW)
    for t in (10.0, 25.0, horizon):
        fraction = np.mean(left <= t)
        lhs, lhs_err = volume * fraction, volume * math.sqrt(fraction * (1 - fraction) / count)
        rhs, rhs_err = gaps.reactive_volume(t)
        assert abs(lhs - rhs) < 4 * math.hypot(lhs_err, rhs_err)
    # Not every entry has left by the horizon (trapping near regular regions), so the check is not
    # only of the small-t regime where both sides are Φ t.
    assert 0.02 < gaps.survival(np.array([horizon]))[0] < 0.5


def test_truncated_mean_refuses_a_horizon_beyond_the_integration():
    from ldpipe.core.transport import GapTimes

    gaps = GapTimes(np.array([1.0, np.inf]), 2.0, 5.0)
    assert gaps.truncated_mean(5.0)[0] == pytest.approx(3.0)  # (1 + 5) / 2
    with pytest.raises(ValueError, match="beyond"):
        gaps.truncated_mean(6.0)
