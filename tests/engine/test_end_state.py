"""Each trajectory's end state and the region face it left by (``LDResult.end_state``, ``exit_face``).

* Closed form: for uncoupled harmonic oscillators, V = (wx^2 x^2 + wy^2 y^2)/2, each coordinate
  is q(t) = q0 cos(w t) + (p0/w) sin(w t), p(t) = -q0 w sin(w t) + p0 cos(w t). The end state at
  tau, and the first time and state where |q_i| reaches a bound b_i, follow in closed form.
* Invariant: ``energy_error`` is |H(end) - H(start)| of the returned end state.
* Geometry: a trajectory that left the region ends on the face ``exit_face`` names, inside the
  box in every other coordinate.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from ldpipe.engine import LDSettings, compute_ld
from support.barbanis import E_C
from support.closed_forms import STATES, WX, WY

W = np.array([WX, WY])
# taylor compiles engines (order 14 for the oscillators, 9 for Barbanis) few other tests load.
SCHEMES = ["dop853", pytest.param("taylor", marks=pytest.mark.compiles), "rk4", "sym4", "sym6"]
# Tight settings per scheme: tolerance 1e-12 for the adaptive ones, dt 0.01 for the fixed-step
# ones; and the relative end-state error each reaches over tau ~ 20 on these oscillators (dop853
# and taylor: tolerance-bound; 4th order: ~dt^4 * tau; 6th order: ~dt^6 * tau, with margin).
TIGHT = {
    "dop853": (dict(rtol=1e-12, atol=1e-12), 1e-9),
    # order 14 (the default at 1e-12 is 13): test_taylor.py's order for these oscillators, one engine for both files
    "taylor": (dict(rtol=1e-12, atol=1e-12, taylor_order=14), 1e-9),
    "rk4": (dict(dt=0.01), 1e-7),
    "sym4": (dict(dt=0.01), 1e-7),
    "sym6": (dict(dt=0.01), 1e-9),
}


def flow(states: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The oscillators' exact flow: each row of ``states`` moved by its own time t (closed form)."""
    t = np.asarray(t, dtype=np.float64)[:, None]
    q0, p0 = states[:, :2], states[:, 2:]
    c, s = np.cos(W * t), np.sin(W * t)
    return np.hstack([q0 * c + p0 / W * s, -q0 * W * s + p0 * c])


def first_crossing(state: np.ndarray, bound: np.ndarray) -> tuple[float, int]:
    """Closed-form first time t > 0 at which |q_i| = bound_i for some i, and its face +-(i+1).

    q_i = A cos(w t + phi) with A = hypot(q0, p0/w), phi = atan2(-p0/w, q0); it equals +b at
    w t + phi = +-acos(b/A) (mod 2 pi) and -b at pi +- acos(b/A) (mod 2 pi).
    """
    best, face = math.inf, 0
    for i in range(2):
        q0, p0, w, b = state[i], state[2 + i], W[i], bound[i]
        amplitude = math.hypot(q0, p0 / w)
        if amplitude <= b:
            continue
        phi = math.atan2(-p0 / w, q0)
        a = math.acos(b / amplitude)
        for sign, targets in ((+1, (a, -a)), (-1, (math.pi + a, math.pi - a))):
            for theta in targets:
                t = ((theta - phi) % (2 * math.pi)) / w
                if 0 < t < best:
                    best, face = t, sign * (i + 1)
    return best, face


def scaled(error: np.ndarray, scale: np.ndarray) -> np.ndarray:
    return np.abs(error) / np.maximum(1.0, np.abs(scale))


@pytest.mark.parametrize("scheme", SCHEMES)
def test_end_state_at_tau_matches_the_exact_flow(oscillator, scheme):
    # Closed form: the oscillators' flow over tau, forward and backward in time.
    extra, tolerance = TIGHT[scheme]
    tau = 19.7
    for direction in (+1, -1):
        result = compute_ld(oscillator, STATES, direction, LDSettings(scheme=scheme, tau=tau, **extra))
        assert (result.time == tau).all() and (result.exit_face == 0).all()
        exact = flow(STATES, np.full(len(STATES), direction * tau))
        assert result.end_state.shape == STATES.shape
        assert scaled(result.end_state - exact, exact).max() < tolerance


@pytest.mark.parametrize("scheme", SCHEMES)
def test_region_exit_time_state_and_face_match_the_closed_form(oscillator, scheme):
    # Closed form: the first time |q_i| reaches b_i, the face, and the flow at that time. The
    # start states are inside the box and every one leaves it before tau.
    extra, tolerance = TIGHT[scheme]
    rng = np.random.default_rng(7)
    states = rng.uniform(-0.6, 0.6, size=(60, 4))
    states[:, 2:] *= 3.0
    bound = np.array([0.7, 0.8])
    expected = [first_crossing(s, bound) for s in states]
    leaves = np.array([math.isfinite(t) for t, _ in expected])  # amplitude above the bound somewhere
    states, expected = states[leaves], [e for e, keep in zip(expected, leaves) if keep]
    assert len(states) >= 30
    settings = LDSettings(scheme=scheme, tau=30.0, region_lower=tuple(-bound), region_upper=tuple(bound), **extra)
    result = compute_ld(oscillator, states, +1, settings)
    t_exit = np.array([t for t, _ in expected])
    assert result.left_region.all()
    assert np.array_equal(result.exit_face, [face for _, face in expected])
    assert scaled(result.time - t_exit, t_exit).max() < tolerance
    assert scaled(result.end_state - flow(states, t_exit), 1.0).max() < tolerance
    # the end lies on the face: the located crossing of the step's interpolant, to rounding
    i = np.abs(result.exit_face) - 1
    on_face = np.where(result.exit_face > 0, bound[i], -bound[i])
    assert np.abs(result.end_state[np.arange(len(states)), i] - on_face).max() < 1e-13


@pytest.mark.parametrize("scheme", SCHEMES)
def test_end_state_energy_is_the_reported_energy_error_and_faces_are_consistent(barbanis, scheme):
    # Invariant: energy_error = |H(end_state) - H(start)|, whatever the outcome (tau, region
    # exit, escape). Geometry: a trajectory that left the region is on the face exit_face names
    # and inside the box in the other coordinates; the others have exit_face 0.
    rng = np.random.default_rng(11)
    states = np.hstack([rng.uniform(-1.5, 1.5, size=(200, 2)), rng.uniform(-2.5, 2.5, size=(200, 2))])
    lo, hi = np.array([-2.0, -2.5]), np.array([2.5, 2.0])
    extra = {} if scheme in ("dop853", "taylor") else {"dt": 0.05}
    settings = LDSettings(
        scheme=scheme, tau=20.0, region_lower=tuple(lo), region_upper=tuple(hi), **extra
    )
    result = compute_ld(barbanis, states, +1, settings)
    assert result.left_region.sum() >= 20 and (~result.left_region).sum() >= 20
    energy_end = np.array([barbanis.energy(s) for s in result.end_state])
    energy_start = np.array([barbanis.energy(s) for s in states])
    reported = np.abs(energy_end - energy_start)
    assert np.allclose(result.energy_error, reported, rtol=1e-12, atol=1e-13 * np.abs(energy_start).max())
    assert np.array_equal(result.exit_face != 0, result.left_region)
    left = np.nonzero(result.left_region)[0]
    i = np.abs(result.exit_face[left]) - 1
    face_value = np.where(result.exit_face[left] > 0, hi[i], lo[i])
    q_end = result.end_state[left, :2]
    assert np.abs(q_end[np.arange(len(left)), i] - face_value).max() < 1e-12
    inside = (q_end >= lo - 1e-12) & (q_end <= hi + 1e-12)
    assert inside.all()


def test_start_outside_region_and_not_started(oscillator):
    # A start outside the region stops at once: its end state is the start, its face the one
    # it is beyond; a non-finite start fails with face 0.
    states = np.array([[0.1, 0.9, 0.0, 0.0], [-0.9, 0.0, 0.0, 0.0], [np.nan, 0.0, 0.0, 0.0]])
    settings = LDSettings(tau=5.0, region_lower=(-0.5, -0.5), region_upper=(0.5, 0.5))
    result = compute_ld(oscillator, states, +1, settings)
    assert list(result.exit_face) == [2, -1, 0]
    assert np.array_equal(result.end_state[:2], states[:2]) and result.failed[2]


def above_the_saddles(system, count: int, excess: float) -> np.ndarray:
    """``count`` states in the square |x|, |y| <= 3 of the well, at energy E_C + ``excess``, heading
    in random directions: the square lies well inside the saddles (at distance 9 from the origin)."""
    rng = np.random.default_rng(3)
    positions = rng.uniform(-3.0, 3.0, size=(count, 2))
    angles = rng.uniform(0.0, 2.0 * math.pi, size=count)
    speeds = np.sqrt(2.0 * (E_C + excess - np.array([system.potential(q) for q in positions])))
    return np.column_stack([positions, speeds * np.cos(angles), speeds * np.sin(angles)])


@pytest.mark.parametrize("scheme", ["dop853", "rk4"])
def test_escape_end_state(barbanis, scheme):
    # Escapes: dop853 ends on the escape radius (the crossing located on the step); a fixed-step
    # scheme at the start of the step that left it, inside the radius. Face 0 (no region).
    # Barbanis above its saddles' energy E_C, from inside the well: some of these states escape
    # through a saddle within tau. (Any system with escapes shows this; Barbanis' engines are the
    # ones the other tests compile.)
    states = above_the_saddles(barbanis, 300, 3.0)
    extra = {} if scheme == "dop853" else {"dt": 0.05}
    settings = LDSettings(scheme=scheme, tau=10.0, escape_radius=10.0, **extra)
    result = compute_ld(barbanis, states, +1, settings)
    escaped = result.escaped
    assert escaped.sum() >= 5 and (result.exit_face == 0).all()
    reach = np.abs(result.end_state[escaped, :2]).max(axis=1)
    if scheme == "dop853":
        assert np.abs(reach - 10.0).max() < 1e-11
    else:
        assert (reach <= 10.0).all() and (reach > 5.0).all()
