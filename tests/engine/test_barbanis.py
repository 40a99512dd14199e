"""The engine on the paper's Barbanis 2 DoF system: invariants, symmetries, escapes, variable time.

References are invariants (energy, time reversal, the y -> -y reflection) or an independent
integration with scipy's solve_ivp (events for the region exit and for the zero crossings of
every velocity component, QUADPACK's algebraic-weight rule on each piece).
"""

import math
import warnings

import numpy as np
import pytest
from scipy.integrate import IntegrationWarning, quad, solve_ivp

from ldpipe.engine import LDSettings, compute_ld
from support.barbanis import E_C, TOP_SADDLE as SADDLE


def section_states(system, energy, xs, pxs, y=0.0):
    """States on y = const with p_y > 0 from the energy; forbidden points dropped."""
    rows = []
    for x in xs:
        for px in pxs:
            kinetic = 2.0 * (energy - system.potential(np.array([x, y]))) - px * px
            if kinetic > 0.0:
                rows.append((x, y, px, math.sqrt(kinetic)))
    return np.array(rows)


@pytest.fixture(scope="module")
def bounded(barbanis):
    return section_states(barbanis, E_C - 0.125, np.linspace(-2.0, 4.0, 5), np.linspace(-2.0, 2.0, 4))


def test_energy_conserved_on_bounded_orbits(barbanis, bounded):
    # H is a first integral: the energy error measures the integration error. With rtol = atol
    # = 1e-10 over tau = 50 it stays within a few hundred local tolerances.
    result = compute_ld(barbanis, bounded, +1, LDSettings(rtol=1e-10, atol=1e-10, tau=50.0))
    assert not (result.escaped | result.failed).any()
    assert np.all(result.time == 50.0)
    assert result.energy_error.max() < 1e-7
    energies = np.array([barbanis.energy(s) for s in bounded])
    assert np.allclose(energies, E_C - 0.125)
    # work cap: DOP853 at 1e-10 needs a few hundred steps for tau = 50 here
    assert result.steps.max() < 600


def test_time_reversal(barbanis, bounded):
    # H is even in p: the backward trajectory of (q, p) is the forward one of (q, -p) run
    # backwards, so backward LD at (q, p) = forward LD at (q, -p). The engine integrates
    # backward with negative steps h = -|h|; every operation of a step is odd or even in (p, h),
    # and IEEE negation is exact, so the backward run is the forward one's mirror image bit for
    # bit (measured: equal on all 20 trajectories). Any asymmetry gives another step sequence,
    # whose LD differs at the integration error (1e-11 here), so nothing between is tolerated.
    settings = LDSettings(rtol=1e-11, atol=1e-11, tau=30.0)
    forward = compute_ld(barbanis, bounded, +1, settings)
    flipped = bounded * np.array([1, 1, -1, -1])
    backward = compute_ld(barbanis, flipped, -1, settings)
    np.testing.assert_array_equal(backward.ld, forward.ld)
    assert np.all(backward.time == forward.time)


def test_reflection_symmetry(barbanis):
    # V(x, -y) = V(x, y): y -> -y, p_y -> -p_y maps trajectories to trajectories and the sum
    # of |velocity components|^p is unchanged. The force is odd in y term by term and negation
    # is exact, so the mirrored run repeats the other's arithmetic up to signs: equal bit for bit
    # (measured on all 9), as in test_time_reversal.
    states = section_states(barbanis, E_C - 0.5, np.linspace(-1.0, 3.0, 3), np.linspace(-1.5, 1.5, 3), y=1.0)
    mirrored = states * np.array([1, -1, 1, -1])
    settings = LDSettings(rtol=1e-11, atol=1e-11, tau=25.0)
    a = compute_ld(barbanis, states, +1, settings)
    b = compute_ld(barbanis, mirrored, +1, settings)
    np.testing.assert_array_equal(a.ld, b.ld)


def test_escapes_stop_cleanly(barbanis):
    # Above E_c, start at the bottom saddle heading out of the well: these trajectories reach
    # infinity in finite time. They must stop at the escape radius, flagged, with finite values
    # and no warning of any kind.
    x, y = SADDLE
    energy = E_C + 1.0
    states = []
    for angle in np.linspace(-0.6, 0.6, 7):
        speed = math.sqrt(2.0 * (energy - barbanis.potential(np.array([x, y]))))
        states.append((x, y, speed * math.sin(angle) * 0.3 + 0.4, speed * math.cos(angle)))
    states = np.array(states)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with np.errstate(all="raise"):
            result = compute_ld(barbanis, states, +1, LDSettings(rtol=1e-10, atol=1e-10, tau=200.0, escape_radius=100.0))
    assert result.escaped.all() and not result.failed.any()
    assert np.all(result.time < 200.0) and np.all(result.time > 0.0)
    for column in (result.ld, result.time, result.energy_error):
        assert np.isfinite(column).all()
    # stopped at radius 100, well before blow-up: there |V| ~ 0.11 * 100^3 ~ 1e5, so an energy
    # error below 1e-4 is ~1e-9 relative to the energies involved (rtol 1e-10)
    assert result.energy_error.max() < 1e-4


def test_escape_with_fixed_step(barbanis):
    # The same with RK4 at a coarse step: still stopped at the radius, no overflow.
    x, y = SADDLE
    speed = math.sqrt(2.0 * (E_C + 2.0 - barbanis.potential(np.array([x, y]))))
    states = np.array([[x, y, 0.5, speed]])
    with np.errstate(all="raise"):
        result = compute_ld(barbanis, states, +1, LDSettings(scheme="rk4", dt=0.1, tau=500.0))
    assert result.escaped[0] and not result.failed[0] and np.isfinite(result.ld[0])
    assert result.steps[0] < 5000


def test_max_steps_ends_lane_with_flag(barbanis, bounded):
    result = compute_ld(barbanis, bounded[:3], +1, LDSettings(rtol=1e-12, atol=1e-12, tau=50.0, max_steps=10))
    assert result.failed.all() and np.all(result.steps == 10) and np.all(result.time < 50.0)


def test_zero_velocity_starts(barbanis):
    # The potential minimum (an equilibrium) and a point on the zero-velocity curve (p = 0).
    states = np.array([[0.0, 0.0, 0.0, 0.0], [2.0, 1.0, 0.0, 0.0]])
    result = compute_ld(barbanis, states, +1, LDSettings(rtol=1e-10, atol=1e-10, tau=10.0))
    assert result.ld[0] == 0.0 and result.time[0] == 10.0
    assert np.isfinite(result.ld).all() and not result.failed.any()
    assert result.energy_error[1] < 1e-8


# --- independent reference: scipy solve_ivp with events ------------------------------------
def vector_field(t, s, wx2=1.0, wy2=1.21, delta=-0.11):
    x, y, px, py = s
    return np.array([px, py, -(wx2 * x + delta * y * y), -(wy2 * y + 2.0 * delta * x * y)])


def reference_variable_time_ld(state, tau, p, lower, upper):
    """Exit time and M_p up to it, by solve_ivp (DOP853, rtol 1e-13) with a terminal exit event.

    The velocity components' zero crossings are events too (not terminal); between crossings
    each |v_c|^p is integrated with QUADPACK's QAWS rule (weight='alg'), which takes the
    (t - a)^p end behaviour at a crossing out analytically.
    """
    exits = []
    for i in range(2):
        for bound, sign in ((lower[i], -1.0), (upper[i], 1.0)):
            event = lambda t, s, i=i, b=bound: s[i] - b  # noqa: E731
            event.terminal = True
            event.direction = sign
            exits.append(event)
    crossings = []
    for c in range(4):
        event = lambda t, s, c=c: vector_field(t, s)[c]  # noqa: E731
        crossings.append(event)
    sol = solve_ivp(
        vector_field, (0.0, tau), state, method="DOP853", rtol=1e-13, atol=1e-13,
        events=exits + crossings, dense_output=True,
    )  # fmt: skip
    t_end = sol.t[-1]
    total = 0.0
    for c in range(4):
        roots = np.sort(sol.t_events[4 + c])
        # a root on a step boundary can be reported by both steps: keep one
        roots = roots[np.concatenate([[True], np.diff(roots) > 1e-12])] if len(roots) else roots
        edges = np.concatenate([[0.0], roots[(roots > 0) & (roots < t_end)], [t_end]])
        for k in range(len(edges) - 1):
            a, b = edges[k], edges[k + 1]
            start_zero = k == 0 and vector_field(0.0, state)[c] == 0.0  # e.g. p_x = 0 at t = 0
            alpha = p if (k > 0 or start_zero) else 0.0  # a crossing at a
            beta_ = p if k < len(edges) - 2 else 0.0  # a crossing at b
            def g(t, c=c, a=a, b=b, alpha=alpha, beta_=beta_):
                # |v_c|^p with the end factors divided out: smooth on [a, b]; QAWS also samples
                # the ends, where 0/0 is replaced by the value a hair inside
                t = min(max(t, a + 1e-12 * (b - a)), b - 1e-12 * (b - a))
                return abs(vector_field(t, sol.sol(t))[c]) ** p / ((t - a) ** alpha * (b - t) ** beta_)

            with warnings.catch_warnings():
                # QUADPACK flags "roundoff" near 1e-10 on the piecewise-polynomial dense output;
                # its result is still far more accurate than the 1e-9 compared against.
                warnings.simplefilter("ignore", IntegrationWarning)
                value, _ = quad(g, a, b, weight="alg", wvar=(alpha, beta_), epsabs=1e-12, epsrel=1e-10, limit=200)
            total += value
    return t_end, total


def test_variable_time_against_solve_ivp(barbanis):
    # A box around the bottom saddle; starts inside it slightly above E_c, so some trajectories
    # cross the bottleneck and leave through the far side, others go back into the well.
    lower, upper = (4.0, 5.5), (7.0, 8.5)
    energy = E_C + 0.2
    states = []
    for x in (5.0, 5.5, 5.9):
        for px in (-0.4, 0.0, 0.3):
            kinetic = 2.0 * (energy - barbanis.potential(np.array([x, 7.0]))) - px * px
            if kinetic <= 0.0:
                continue
            states.append((x, 7.0, px, math.sqrt(kinetic)))
            states.append((x, 7.0, px, -math.sqrt(kinetic)))
    states = np.array(states)
    settings = LDSettings(rtol=1e-12, atol=1e-12, tau=20.0, p=0.5, region_lower=lower, region_upper=upper)
    result = compute_ld(barbanis, states, +1, settings)
    assert result.left_region.all() and not (result.escaped | result.failed).any()
    for k, state in enumerate(states):
        t_exit, ld = reference_variable_time_ld(state, 20.0, 0.5, lower, upper)
        assert result.time[k] == pytest.approx(t_exit, rel=1e-10, abs=1e-11)
        assert result.ld[k] == pytest.approx(ld, rel=1e-9)


def test_variable_time_start_outside(barbanis):
    settings = LDSettings(region_lower=(4.0, 5.5), region_upper=(7.0, 8.5), tau=10.0)
    result = compute_ld(barbanis, np.array([[0.0, 0.0, 1.0, 1.0]]), +1, settings)
    assert result.left_region[0] and result.time[0] == 0.0 and result.ld[0] == 0.0
