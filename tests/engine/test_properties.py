"""Property-based tests (hypothesis) over random points on the energy surface.

- energy conservation within the tolerance asked for, in the closed well below E_c;
- time-reversal symmetry of the LD: backward from (q, p) equals forward from (q, -p), for
  bounded, escaping and region-leaving trajectories, in 2 and 3 DoF;
- tiling: a grid computed in tiles and gathered equals the untiled grid bit for bit, and the
  engine's result does not depend on the order (hence lane and thread) of the trajectories.

The examples are few and cheap (``max_examples`` below, short tau); a failure prints the
falsifying example, and hypothesis replays it first on the next run.
"""

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from ldpipe.engine import LDSettings, compute_ld
from ldpipe.core.maps.grid import gather_tiles, ld_grid_dataset, tile_rows
from ldpipe.core.sections import Section
# The paper's Barbanis 2 DoF: V = x^2/2 + y^2 (wy2 + 2 delta x)/2, E_c = 15.125 at x = 5.5.
from support.barbanis import BOTTOM_REGION, DELTA, E_C, PAPER_Q_S, WY2

PROPERTY = settings(max_examples=30, deadline=None)
unit = st.floats(-1.0, 1.0, allow_nan=False)
angle = st.floats(0.0, 2.0 * math.pi, allow_nan=False)


@st.composite
def well_points(draw):
    """(state, energy): a point on the energy surface E < E_c inside the potential well.

    For x < 5.5 the coefficient wy2 + 2 delta x of y^2/2 is positive, so at energy E the well is
    |x| <= sqrt(2E), y^2 <= 2 (E - x^2/2) / (wy2 + 2 delta x): sampled from that closed form, with
    the momentum's direction drawn and its size solved from the energy (0 on the boundary).
    """
    energy = E_C + draw(st.floats(-10.0, -0.05, allow_nan=False))
    x = draw(unit) * math.sqrt(2.0 * energy)
    y = draw(unit) * math.sqrt(max(0.0, 2.0 * (energy - 0.5 * x * x) / (WY2 + 2.0 * DELTA * x)))
    potential = 0.5 * x * x + 0.5 * WY2 * y * y + DELTA * x * y * y
    speed = math.sqrt(max(0.0, 2.0 * (energy - potential)))
    theta = draw(angle)
    return np.array([x, y, speed * math.cos(theta), speed * math.sin(theta)]), energy


@PROPERTY
@given(point=well_points(), tolerance=st.sampled_from([1e-6, 1e-8, 1e-10]), tau=st.floats(0.5, 40.0),
       p=st.sampled_from([0.5, 0.3, 1.0, "arclength"]), direction=st.sampled_from([1, -1]))
def test_energy_conserved_within_the_asked_tolerance(barbanis, point, tolerance, tau, p, direction):
    # Below E_c the line x = 5.5 is forbidden (V = E_c there for every y), so the well is closed
    # and invariant: nothing escapes and every trajectory runs to tau. H is a first integral; its
    # error is a sum of local errors, each held near the tolerance: |dH| <= tol * tau * E
    # (measured: at most 0.24 of that over 400 random points, all three tolerances).
    state, energy = point
    result = compute_ld(barbanis, state, direction, LDSettings(rtol=tolerance, atol=tolerance, tau=tau, p=p))
    assert not (result.escaped[0] or result.failed[0]) and result.time[0] == tau
    assert np.isfinite(result.ld[0]) and result.ld[0] >= 0.0
    assert result.energy_error[0] <= tolerance * max(tau, 1.0) * energy


@st.composite
def surface_points(draw, n_dof):
    """A point (q, p) anywhere in a box around the wells and saddles, with kinetic energy in
    [0, 4]: on energy surfaces below and above E_c, where trajectories stay, escape or cross."""
    if n_dof == 2:
        q = np.array([2.0 + 8.0 * draw(unit), 10.0 * draw(unit)])
    else:
        q = np.array([10.5 + 12.0 * draw(unit), 5.0 + 6.0 * draw(unit), 2.5 + 4.0 * draw(unit)])
    speed = math.sqrt(2.0 * draw(st.floats(0.0, 4.0, allow_nan=False)))
    if n_dof == 2:
        theta = draw(angle)
        direction = np.array([math.cos(theta), math.sin(theta)])
    else:  # a direction on the sphere from its polar angles
        theta, phi = draw(angle), math.acos(draw(unit))
        direction = np.array([math.sin(phi) * math.cos(theta), math.sin(phi) * math.sin(theta), math.cos(phi)])
    return np.concatenate([q, speed * direction])


def assert_time_reversal(system, states, settings_):
    # H(q, p) = H(q, -p): the backward trajectory of (q, p) is the forward one of (q, -p)
    # reversed, with the same |velocity| components, so the LD, the time reached and the
    # flags agree (the engine integrates backward with negative steps: a separate integration).
    flipped = states * np.repeat([1.0, -1.0], system.n_dof)
    forward = compute_ld(system, states, +1, settings_)
    backward = compute_ld(system, flipped, -1, settings_)
    np.testing.assert_allclose(backward.ld, forward.ld, rtol=1e-10, atol=0)
    np.testing.assert_allclose(backward.time, forward.time, rtol=1e-12, atol=0)
    for flag in ("escaped", "left_region", "failed"):
        np.testing.assert_array_equal(getattr(backward, flag), getattr(forward, flag))
    assert np.isfinite(forward.ld).all() and np.isfinite(forward.energy_error).all()


@PROPERTY
@given(states=st.lists(surface_points(2), min_size=1, max_size=6), tau=st.floats(0.5, 30.0),
       p=st.sampled_from([0.5, 1.0, "arclength"]), variable=st.booleans())
def test_time_reversal_symmetry_2dof(barbanis, states, tau, p, variable):
    region = BOTTOM_REGION if variable else (None, None)
    settings_ = LDSettings(rtol=1e-10, atol=1e-10, tau=tau, p=p, region_lower=region[0], region_upper=region[1])
    assert_time_reversal(barbanis, np.array(states), settings_)


@settings(max_examples=15, deadline=None)
@given(states=st.lists(surface_points(3), min_size=1, max_size=6), tau=st.floats(0.5, 20.0), variable=st.booleans())
def test_time_reversal_symmetry_3dof(barbanis_contopoulos, states, tau, variable):
    region = PAPER_Q_S if variable else (None, None)
    settings_ = LDSettings(rtol=1e-10, atol=1e-10, tau=tau, region_lower=region[0], region_upper=region[1])
    assert_time_reversal(barbanis_contopoulos, np.array(states), settings_)


@PROPERTY
@given(rows=st.integers(2, 10), columns=st.integers(2, 7), data=st.data(), excess=st.floats(-2.0, 1.0),
       y=st.floats(-8.0, 8.0), variable=st.booleans())
def test_tiled_grid_equals_the_untiled_one(barbanis, rows, columns, data, excess, y, variable):
    # Every trajectory is integrated on its own, so splitting the rows into tiles (separate jobs)
    # and gathering them reproduces the whole grid exactly, whatever the split.
    tiles = data.draw(st.integers(1, rows), label="tiles")
    section = Section(axes=("x", "px"), ranges=((-6.0, 8.0), (-4.0, 4.0)), shape=(rows, columns), fixed={"y": y},
                      solve="py")
    region = BOTTOM_REGION if variable else (None, None)
    settings_ = LDSettings(rtol=1e-8, atol=1e-8, tau=3.0, region_lower=region[0], region_upper=region[1])
    energy = E_C + excess
    whole = ld_grid_dataset(barbanis, section, energy, settings_)
    parts = [ld_grid_dataset(barbanis, section, energy, settings_, rows=tile_rows(rows, k, tiles))
             for k in range(tiles)]
    gathered = gather_tiles(parts, "x")
    assert list(gathered.data_vars) == list(whole.data_vars)
    for name in whole.data_vars:
        assert gathered[name].dtype == whole[name].dtype, name
        np.testing.assert_array_equal(gathered[name].values, whole[name].values, err_msg=name)
    np.testing.assert_array_equal(gathered.x.values, whole.x.values)


@PROPERTY
@given(states=st.lists(surface_points(2), min_size=2, max_size=150), seed=st.integers(0, 2**32 - 1))
def test_result_does_not_depend_on_trajectory_order(barbanis, states, seed):
    # The engine packs trajectories into blocks of lanes and blocks onto threads by position, and
    # refills a lane as soon as its trajectory ends: a shuffled input must give the shuffled
    # output, bit for bit (the mechanism behind tiles equal to the whole).
    states = np.array(states)
    order = np.random.default_rng(seed).permutation(len(states))
    settings_ = LDSettings(rtol=1e-8, atol=1e-8, tau=5.0)
    straight = compute_ld(barbanis, states, +1, settings_)
    shuffled = compute_ld(barbanis, states[order], +1, settings_)
    for name, values in straight._asdict().items():
        np.testing.assert_array_equal(getattr(shuffled, name), values[order], err_msg=name)
