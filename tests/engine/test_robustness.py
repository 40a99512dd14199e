"""Engine defects found by the accuracy–cost stage: fixed-step escapes, idle lanes, root pairs.

* A fixed step that leaves the escape radius is not trusted: the trajectory stops at the
  step's start, flagged escaped, with finite LD and energy error.
* Idle lanes (a unit with fewer trajectories than lanes) are never sent to the LD
  quadrature's special path, and the results of the real lanes do not depend on them.
* Two roots of a velocity component inside one step (between the quadrature's samples) are
  found and cut out.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad

from ldpipe.testing import reference_ld as reference
from ldpipe.engine import LDSettings, compute_ld
from ldpipe.engine.codegen import load_engine
from ldpipe.systems import make_system


@pytest.fixture(scope="module")
def fig3_high_energy_states():
    """A grid on the Fig. 3 section U_xpx (y = 0, p_y > 0) at dE = 0.125, where some trajectories escape."""
    x, px = np.meshgrid(np.linspace(-5.6, 5.6, 24), np.linspace(-5.6, 5.6, 24), indexing="ij")
    states, allowed = reference.section_state(x.ravel(), px.ravel(), reference.E_SADDLE + 0.125)
    return np.ascontiguousarray(states[allowed])


@pytest.mark.parametrize("scheme", ["rk4", "sym4", "sym6"])
def test_fixed_step_escapes_at_large_dt_are_finite_and_flagged(barbanis, fig3_high_energy_states, scheme):
    # dt 0.4 overshoots the escape radius by orders of magnitude (a step taken across it gives LDs
    # of 1e54..1e129 and inf energy errors, so it is refused). Invariant: nothing non-finite,
    # escaped ones stop before tau.
    result = compute_ld(barbanis, fig3_high_energy_states, +1, LDSettings(scheme=scheme, dt=0.4))
    assert np.all(np.isfinite(result.ld)) and np.all(np.isfinite(result.energy_error))
    assert result.escaped.sum() >= 5 and not result.failed.any()
    assert np.all(result.time[result.escaped] < 50.0)
    # the LD of a trajectory integrated for at most tau = 50 at speeds |v| < ~200 (inside the radius)
    assert result.ld.max() < 1e3


@pytest.mark.parametrize(("scheme", "tolerance"), [("rk4", 2e-3), ("sym4", 2e-3), ("sym6", 1e-6)])
def test_fixed_step_escape_ld_agrees_with_dop853_up_to_the_stop(barbanis, fig3_high_energy_states, scheme, tolerance):
    # Independent method: dop853 at rtol 1e-12 over [0, t_stop] of the fixed-step run. The
    # tolerances are the schemes' accuracy at dt 0.05 (4th order: ~1e-4..7e-4 relative measured
    # on these trajectories, 6th order: ~6e-8).
    result = compute_ld(barbanis, fig3_high_energy_states, +1, LDSettings(scheme=scheme, dt=0.05))
    escaped = np.nonzero(result.escaped)[0]
    assert len(escaped) >= 5
    for i in escaped[:5]:
        tight = LDSettings(tau=float(result.time[i]), rtol=1e-12, atol=1e-12)
        expected = compute_ld(barbanis, fig3_high_energy_states[i], +1, tight)
        assert not expected.escaped[0]  # the stop is the last step start inside the radius
        assert abs(result.ld[i] - expected.ld[0]) <= tolerance * expected.ld[0]


@pytest.mark.parametrize("scheme", ["dop853", "sym6"])
def test_idle_lanes_are_never_special(barbanis, scheme):
    # Work, not time: an idle lane (h = 0; a never-loaded lane is all zero, every velocity 0)
    # must not reach the special path, which would run the scalar root search on it every step.
    module = load_engine(barbanis, scheme, 64)
    W = np.zeros(module.SIZE)
    SP = np.ones((module.NCOMP, module.LANES), dtype=np.int8)
    glx = np.array([0.1127016653792583, 0.5, 0.8872983346207417])
    glw = np.array([5.0, 8.0, 5.0]) / 18.0
    module.fast(W, module.KIND_HALF, 0.5, glx, glw, 0.2, SP)
    assert not SP.any()


@pytest.mark.parametrize("settings", [LDSettings(), LDSettings(scheme="sym6", dt=0.05, tau=10.0)])
def test_partial_blocks_give_the_same_bits(barbanis, fig3_high_energy_states, settings):
    # Invariant: trajectories are independent, so 200 of them (a last unit of 8 in a block of 64)
    # give bit for bit the results of the same 200 inside a run of 256.
    full = compute_ld(barbanis, fig3_high_energy_states[:256], +1, settings)
    part = compute_ld(barbanis, fig3_high_energy_states[:200], +1, settings)
    for name in full._fields:
        np.testing.assert_array_equal(getattr(part, name), getattr(full, name)[:200], err_msg=name)


@pytest.mark.parametrize(("rtol", "bound"), [(1e-10, 1.5e-9), (1e-12, 1e-10)])
def test_two_roots_in_one_step_match_the_reference(barbanis, rtol, bound):
    # The accuracy–cost stage's case: Fig. 4 map at dE 0.125, point (x, y, px) on U_xpx+, where
    # p_x' has roots at t ~ 2.6088 and 2.6188, inside one DOP853 step. Independent method:
    # ldpipe.testing.reference_ld (zero crossings located, pieces integrated apart; 6.7793060198).
    # Before the fix the error was 1.3e-5 at rtol 1e-10 and 4.5e-5 at rtol 1e-12. Bounds a few
    # times the measured relative error: 4.0e-10 at rtol 1e-10, 3.3e-11 at 1e-12.
    x, y, px = 5.58452302, -7.0, 0.32221481
    py = np.sqrt(2.0 * (15.25 - reference.barbanis_potential(x, y)) - px**2)
    state = np.array([x, y, px, py])
    box = {0: (4.5, 6.5), 1: (-8.5, -5.5)}
    expected = reference.reference_ld(state, 50.0, 0.5, box=box)
    settings = LDSettings(rtol=rtol, atol=rtol, region_lower=(4.5, -8.5), region_upper=(6.5, -5.5))
    result = compute_ld(barbanis, state, +1, settings)
    assert result.left_region[0]
    assert abs(result.ld[0] - expected.ld) < bound * expected.ld


@pytest.mark.slow  # compiles the engine for a new formula system (~40 s on a cold cache)
@pytest.mark.parametrize("p", [0.5, 1.0])
def test_close_root_pair_of_the_force_in_one_step(p):
    # One degree of freedom, V = c (q^3/3 - d^2 q): the force -c (q^2 - d^2) vanishes at q = +-d.
    # A particle crossing [-L, L] at speed ~1 sees p' change sign twice within ~2d = 0.04 time
    # units, inside one loose DOP853 step. Independent method: with dt = dq / p(q) and
    # p(q) = sqrt(2 (E - V(q))), the variable-time LD until q leaves [-L, L] is
    # int_{q0}^{L} (p^p + |V'(q)|^p) / p dq, a 1-D quadrature with the roots +-d as breakpoints.
    c, d, big = 1.0, 0.02, 0.5
    system = make_system("cubic", {"formula": f"{c}*(x**3/3 - {d * d}*x)", "coordinates": ["x"]})
    q0, p0 = -0.4, 1.0
    energy = 0.5 * p0**2 + c * (q0**3 / 3 - d * d * q0)

    def momentum(q):
        return np.sqrt(2.0 * (energy - c * (q**3 / 3 - d * d * q)))

    def integrand(q):
        return (momentum(q) ** p + abs(c * (q * q - d * d)) ** p) / momentum(q)

    expected = sum(
        quad(integrand, a, b, epsabs=1e-14, epsrel=1e-13, limit=200)[0]
        for a, b in ((q0, -d), (-d, d), (d, big))
    )
    settings = LDSettings(rtol=1e-6, atol=1e-6, p=p, region_lower=(-big,), region_upper=(big,))
    result = compute_ld(system, np.array([q0, p0]), +1, settings)
    assert result.left_region[0]
    # tolerance: the trajectory's accuracy at rtol 1e-6, far below the missed pair's effect
    assert abs(result.ld[0] - expected) < 1e-5 * expected
