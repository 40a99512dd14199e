"""The ``taylor`` scheme on potentials that are not polynomials (auxiliary series).

Every expected value is an invariant or an independent integration:

- each system's trajectories: scipy's DOP853 at rtol = atol = 1e-13 on Hamilton's equations
  derived by hand (independent of sympy and of the generated recurrences), compared through
  M_1 (total variation of each coordinate, turning points located by events) and the
  phase-space arc length (a fifth state);
- the energy, conserved along every trajectory (the engine's |H(end) - H(start)|);
- the LD for p = 1/2 from the engine's dop853 at rtol 1e-13 (its other adaptive scheme), and,
  since dop853 shares the LD quadrature with taylor, from the independent reference LD
  (ldpipe.testing.reference_ld: scipy only) on the hand-derived field at a few points.

The systems cover each recurrence: exp (a Morse oscillator, and a De Leon–Berne-like
coupling of a Morse coordinate to a double well), sin and cos (a pendulum term), real and
negative powers (sqrt, (2 + x)^1.5 from (2 + x)^2.5, quotients) and log. They run at rtol
1e-12 with the default orders (13 for M_1 and p = 1/2, 20 for the arc length); each engine
compiles once per (system, integrand), 20-50 s.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from ldpipe.engine import LDSettings, compute_ld
from ldpipe.engine.schemes.taylor import Acceleration, ExpressionSeries, acceleration_of
from ldpipe.errors import ConfigError
from ldpipe.systems import make_system
from ldpipe.testing.reference_ld import reference_ld
from support.scipy_reference import m1_and_arclength

# Nine engines no other test loads (a Taylor module per system and integrand, and dop853 per system).
pytestmark = pytest.mark.compiles

TOLERANCE = 1e-12
TAU = 10.0


def morse_field(q):
    # V = D (1 - exp(-a x))^2 + y^2 / 2
    D, a = 2.0, 0.8
    x, y = q
    e = np.exp(-a * x)
    return np.array([-2.0 * D * a * (1.0 - e) * e, -y]), D * (1.0 - e) ** 2 + 0.5 * y * y


def deleon_berne_field(q):
    # V = 4 y^2 (y^2 - 1) exp(-z lam x) + eps + D (1 - exp(-lam x))^2
    D, lam, z, eps = 10.0, 1.5, 1.0, 1.0
    x, y = q
    coupling, morse = np.exp(-z * lam * x), np.exp(-lam * x)
    force_x = 4.0 * y * y * (y * y - 1.0) * z * lam * coupling - 2.0 * D * lam * (1.0 - morse) * morse
    force_y = -(16.0 * y**3 - 8.0 * y) * coupling
    return np.array([force_x, force_y]), 4.0 * y * y * (y * y - 1.0) * coupling + eps + D * (1.0 - morse) ** 2


def mixed_field(q):
    # V = 1 - cos x + sqrt(1 + y^2) + x log(3 + y) / 10 + x y / (10 (2 + y)) + (2 + x)^2.5 / 50
    x, y = q
    force_x = -(np.sin(x) + 0.1 * np.log(3.0 + y) + 0.1 * y / (2.0 + y) + 0.05 * (2.0 + x) ** 1.5)
    force_y = -(y / np.sqrt(1.0 + y * y) + 0.1 * x / (3.0 + y) + 0.2 * x / (2.0 + y) ** 2)
    potential = (1.0 - np.cos(x) + np.sqrt(1.0 + y * y) + 0.1 * x * np.log(3.0 + y)
                 + 0.1 * x * y / (2.0 + y) + 0.02 * (2.0 + x) ** 2.5)
    return np.array([force_x, force_y]), potential


SYSTEMS = {
    "morse": ({"formula": "2*(1 - exp(-0.8*x))**2 + y**2/2", "coordinates": ["x", "y"]}, morse_field),
    "deleon_berne": (
        {
            "formula": "4*y**2*(y**2 - 1)*exp(-z*lam*x) + eps + D*(1 - exp(-lam*x))**2",
            "coordinates": ["x", "y"],
            "parameters": {"D": 10.0, "lam": 1.5, "z": 1.0, "eps": 1.0},
        },
        deleon_berne_field,
    ),
    "mixed": (
        {
            "formula": "1 - cos(x) + sqrt(1 + y**2) + x*log(3 + y)/10 + x*y/(10*(2 + y)) + (2 + x)**2.5/50",
            "coordinates": ["x", "y"],
        },
        mixed_field,
    ),
}


@pytest.fixture(scope="module", params=sorted(SYSTEMS))
def case(request):
    spec, field = SYSTEMS[request.param]
    return make_system(f"taylor_{request.param}", spec), field


def start_states(field, count: int = 8) -> np.ndarray:
    """Bounded starts near the potential's well, a spread of directions and energies."""
    rng = np.random.default_rng(21)
    q = rng.uniform(-0.3, 0.3, (count, 2))
    p = rng.uniform(-0.6, 0.6, (count, 2))
    return np.hstack([q, p])


def hamilton(field):
    """Hamilton's equations of a hand-derived force: the phase-space velocity of (x, y, p_x, p_y),
    shape (4,) or (4, N)."""
    return lambda s: np.concatenate([s[2:4], field(s[:2])[0]])


def reference(field, state, tau: float) -> tuple[float, float]:
    """M_1 and the arc length over [0, tau] by scipy (support.scipy_reference) on the hand-derived field."""
    return m1_and_arclength(hamilton(field), state, tau)


def relative(values, reference_values) -> np.ndarray:
    return np.abs(np.asarray(values) - reference_values) / np.abs(reference_values)


def test_series_share_common_subexpressions():
    # The Morse force -2 D a (1 - e) e, e = exp(-a x): one exp series serves both factors,
    # and the y component (-y) is a scaled coordinate, no series of its own.
    spec, _ = SYSTEMS["morse"]
    series = acceleration_of(make_system("taylor_morse_nodes", spec))
    assert isinstance(series, ExpressionSeries)
    kinds = [kind for kind, _, _ in series.nodes]
    assert kinds.count("exp") == 1 and kinds.count("product") == 1


def test_polynomials_keep_the_monomial_recurrences(barbanis):
    # A polynomial's source is that of its monomials (results and numba caches unchanged).
    assert isinstance(acceleration_of(barbanis), Acceleration)


@pytest.mark.parametrize("formula", ["tan(x) + y**2/2", "cosh(x) + y**2/2", "atan(x) + y**2/2", "x**y + y**2"])
def test_functions_rewritten_in_the_recurrences_are_taken(formula):
    # tan = sin / cos and the hyperbolic functions in exp; atan's derivative is rational.
    system = make_system("taylor_rewritten", {"formula": formula, "coordinates": ["x", "y"]})
    assert isinstance(acceleration_of(system), ExpressionSeries)


def test_term_without_recurrence_is_refused():
    # |x|^3 has the force 3 x^2 sign(x): sign has no recurrence. (make_system itself cannot
    # print Abs's Hessian yet, so the scheme sees a system-like record of the formula.)
    system = SimpleNamespace(name="kinked", formula="Abs(x)**3 + y**2/2", coordinates=("x", "y"), parameters={},
                             mass_matrix=None)
    with pytest.raises(ConfigError, match=r"'kinked'.*sign\(x\)"):
        acceleration_of(system)


@pytest.mark.parametrize("direction", [+1, -1])
def test_agrees_with_solve_ivp_and_conserves_energy(case, direction):
    # Independent method: scipy's DOP853 at rtol 1e-13 on the hand-derived field; backward is
    # the forward reference of (q, -p) (time reversal).
    system, field = case
    states = start_states(field)
    settings = dict(scheme="taylor", rtol=TOLERANCE, atol=TOLERANCE, tau=TAU)
    m1 = compute_ld(system, states, direction, LDSettings(p=1.0, **settings))
    # The arc length with 16 Gauss nodes per step: at the default 8, the De Leon–Berne system's
    # long steps (order 20, ~12 per unit time against the Morse frequency ~6.7) leave a
    # quadrature error of 1.3e-8 (measured; 2.8e-12 with 16 nodes, 1.4e-10 at order 15; the
    # trajectories agree to 5e-12 as M_1 shows). The Morse and mixed systems meet 6e-13 with 8.
    arc = compute_ld(system, states, direction, LDSettings(p="arclength", quad_nodes=16, **settings))
    flip = np.array([1, 1, direction, direction])
    expected = np.array([reference(field, state * flip, TAU) for state in states])
    for result in (m1, arc):
        assert not (result.failed | result.escaped).any() and np.all(result.time == TAU)
        assert result.energy_error.max() < 1e-11
    assert relative(m1.ld, expected[:, 0]).max() < 5e-12
    assert relative(arc.ld, expected[:, 1]).max() < 5e-12


def test_half_power_ld_agrees_with_dop853_and_the_reference(case):
    # The engine's dop853 at rtol 1e-13: |v|^(1/2) with its cusps, forward.
    system, field = case
    states = start_states(field)
    taylor = compute_ld(system, states, +1, LDSettings(scheme="taylor", rtol=TOLERANCE, atol=TOLERANCE, p=0.5, tau=TAU))
    dop853 = compute_ld(system, states, +1, LDSettings(scheme="dop853", rtol=1e-13, atol=1e-13, p=0.5, tau=TAU))
    assert not (taylor.failed | taylor.escaped).any()
    assert relative(taylor.ld, dop853.ld).max() < 1e-10
    # dop853 shares the LD quadrature (cusp and near-touch rules) with taylor: the independent
    # reference LD on the hand-derived field judges both, at four points (0.05-0.3 s each; De
    # Leon–Berne's cross zero ~60 times and touch it 2-4 times). Measured: taylor at most 8.5e-14
    # (Morse), 1.5e-13 (De Leon–Berne), 4.4e-14 (mixed) from it; dop853 at rtol 1e-13 1.2e-11.
    expected = np.array([reference_ld(state, TAU, 0.5, field=hamilton(field)).ld for state in states[:4]])
    assert relative(taylor.ld[:4], expected).max() < 5e-13
