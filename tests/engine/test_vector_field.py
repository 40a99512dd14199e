"""LDs of general flows dx/dt = f(x, t) (vector-field systems) against closed forms and scipy.

Every expected value is a closed form (support.closed_forms: the linear saddle's M_p, the
solution of dx/dt = (1 + cos t) x) or scipy's DOP853 at rtol 1e-13 (support.scipy_reference,
M_1 by total variation between velocity zeros, the arc length as an extra state).
"""

import math

import numpy as np
import pytest

from ldpipe.engine import LDSettings, compute_ld
from ldpipe.errors import ConfigError
from ldpipe.systems import make_system, require_hamiltonian
from support.closed_forms import forced_growth_solution, linear_saddle_ld
from support.scipy_reference import flow_m1_and_arclength, flow_state_quadrature_ld

LAM = 0.8
TIGHT = dict(rtol=1e-12, atol=1e-12)
SADDLE_STATES = np.array([[0.3, 0.2], [-0.1, 0.5], [0.05, -0.7]])
# forced Duffing: x' = y, y' = x - x^3 - delta y + F cos(omega t)
DUFFING = {"delta": 0.25, "F": 0.3, "omega": 1.2}


@pytest.fixture(scope="module")
def saddle():
    spec = {"vector_field": {"x": "lam*x", "y": "-lam*y"}, "coordinates": ["x", "y"], "parameters": {"lam": LAM}}
    return make_system("linear_saddle", spec)


@pytest.fixture(scope="module")
def forced_growth():
    # one dimension (odd), time-dependent: dx/dt = (1 + cos t) x
    return make_system("forced_growth", {"vector_field": {"x": "(1 + cos(t))*x"}, "coordinates": ["x"]})


@pytest.fixture(scope="module")
def duffing():
    spec = {"vector_field": {"x": "y", "y": "x - x**3 - delta*y + F*cos(omega*t)"}, "coordinates": ["x", "y"],
            "parameters": DUFFING}
    return make_system("forced_duffing", spec)


def duffing_field(t, s):
    x, y = s
    return np.array([y, x - x**3 - DUFFING["delta"] * y + DUFFING["F"] * math.cos(DUFFING["omega"] * t)])


@pytest.mark.parametrize("p", [0.5, 1.0, 0.3])
@pytest.mark.parametrize("direction", [1, -1])
def test_linear_saddle_fixed_time_closed_form(saddle, p, direction):
    # M_p of the linear saddle is a closed form (support.closed_forms.linear_saddle_ld); the
    # components never vanish on these orbits, so this is the smooth case of the quadrature.
    tau = 3.0
    result = compute_ld(saddle, SADDLE_STATES, direction, LDSettings(tau=tau, p=p, **TIGHT))
    exact = [linear_saddle_ld(x, y, LAM, tau, p, direction) for x, y in SADDLE_STATES]
    np.testing.assert_allclose(result.ld, exact, rtol=1e-10)
    assert np.all(result.time == tau) and not result.failed.any() and not result.escaped.any()
    # the end state: x0 e^(lam t), y0 e^(-lam t) at t = direction tau
    growth = np.exp(direction * LAM * tau)
    np.testing.assert_allclose(result.end_state, SADDLE_STATES * [growth, 1 / growth], rtol=1e-10)


def test_linear_saddle_variable_time_exit(saddle):
    # Region |x|, |y| <= 1: forward, |x| = |x0| e^(lam t) reaches 1 at t = ln(1/|x0|)/lam (closed
    # form) while |y| shrinks; the LD is the closed form at that exit time.
    settings = LDSettings(tau=20.0, p=0.5, region_lower=(-1.0, -1.0), region_upper=(1.0, 1.0), **TIGHT)
    result = compute_ld(saddle, SADDLE_STATES, 1, settings)
    exits = np.log(1.0 / np.abs(SADDLE_STATES[:, 0])) / LAM
    np.testing.assert_allclose(result.time, exits, rtol=1e-11)
    exact = [linear_saddle_ld(x, y, LAM, t, 0.5) for (x, y), t in zip(SADDLE_STATES, exits)]
    np.testing.assert_allclose(result.ld, exact, rtol=1e-10)
    assert result.left_region.all() and not result.escaped.any()
    # it leaves by the face x = sign(x0): +1 (upper face of coordinate 0) or -1 (lower)
    np.testing.assert_array_equal(result.exit_face, np.where(SADDLE_STATES[:, 0] > 0, 1, -1))


@pytest.mark.parametrize("t0", [0.0, 0.7, -2.1])
@pytest.mark.parametrize("direction", [1, -1])
def test_time_dependent_linear_flow_start_time(forced_growth, t0, direction):
    # dx/dt = (1 + cos t) x: x(t) = x0 exp(t - t0 + sin t - sin t0) (closed form). Since 1 + cos t
    # >= 0, x is monotone and M_1 = arc length = |x(t0 + direction tau) - x0|; both depend on t0.
    tau = 4.0
    x0 = np.array([[0.04], [-0.13]])  # growth at most e^6: inside the escape radius 100
    end = np.array([forced_growth_solution(x, t0, t0 + direction * tau) for x in x0[:, 0]])
    for p in (1.0, "arclength"):
        result = compute_ld(forced_growth, x0, direction, LDSettings(tau=tau, p=p, **TIGHT), t0=t0)
        np.testing.assert_allclose(result.end_state[:, 0], end, rtol=1e-10)
        np.testing.assert_allclose(result.ld, np.abs(end - x0[:, 0]), rtol=1e-10)
        assert not result.escaped.any() and np.all(result.time == tau)


@pytest.mark.parametrize("t0", [0.0, 1.3])
@pytest.mark.parametrize("direction", [1, -1])
def test_forced_duffing_against_scipy(duffing, t0, direction):
    # M_1 and the arc length against scipy's DOP853 at rtol 1e-13 (an independent integrator; M_1
    # by total variation between the velocity zeros, so no quadrature of the cusps).
    tau = 6.0
    states = np.array([[0.1, 0.2], [-0.8, 0.05], [1.2, -0.4]])
    references = [flow_m1_and_arclength(duffing_field, s, t0, t0 + direction * tau) for s in states]
    m1 = compute_ld(duffing, states, direction, LDSettings(tau=tau, p=1.0, **TIGHT), t0=t0)
    arc = compute_ld(duffing, states, direction, LDSettings(tau=tau, p="arclength", **TIGHT), t0=t0)
    np.testing.assert_allclose(m1.ld, [r[0] for r in references], rtol=1e-9)
    np.testing.assert_allclose(arc.ld, [r[1] for r in references], rtol=1e-9)
    np.testing.assert_allclose(m1.end_state, [r[2] for r in references], rtol=1e-8, atol=1e-10)


@pytest.mark.parametrize("direction", [1, -1])
def test_forced_duffing_half_norm_against_scipy_state_quadrature(duffing, direction):
    # M_1/2 against scipy's DOP853 at rtol 1e-12 with the LD as an extra state (ldds' method, an
    # independent integrator and quadrature). Its cusps at the velocity zeros limit that reference
    # (the step control resolves |t - r|^(3/2) only so far): the two agree to ~1e-10, tested at 1e-9.
    tau, t0 = 4.0, 1.3
    states = np.array([[0.1, 0.2], [1.2, -0.4]])
    reference = [flow_state_quadrature_ld(duffing_field, s, t0, t0 + direction * tau, 0.5) for s in states]
    result = compute_ld(duffing, states, direction, LDSettings(tau=tau, p=0.5, **TIGHT), t0=t0)
    np.testing.assert_allclose(result.ld, reference, rtol=1e-9)


def test_forced_duffing_depends_on_start_time(duffing):
    # The forcing makes the flow time-dependent: the same point from another t0 gives another LD
    # (and an autonomous flow would not: the saddle's LD is the same from any t0).
    state = np.array([[0.1, 0.2]])
    settings = LDSettings(tau=6.0, p=0.5, **TIGHT)
    assert duffing.time_dependent
    assert compute_ld(duffing, state, 1, settings, t0=0.0).ld[0] != pytest.approx(
        compute_ld(duffing, state, 1, settings, t0=1.3).ld[0], rel=1e-3)


def test_other_schemes_refuse_a_vector_field(saddle):
    # Only schemes whose record says general_flow integrate a vector field; the error names both.
    for scheme in ("rk4", "sym4", "taylor"):
        with pytest.raises(ValueError, match=rf"scheme '{scheme}' cannot integrate system 'linear_saddle'"):
            compute_ld(saddle, SADDLE_STATES, 1, LDSettings(scheme=scheme, tau=1.0))


def test_hamiltonian_systems_refuse_a_start_time(oscillator):
    with pytest.raises(ValueError, match="t0: system .* is autonomous"):
        compute_ld(oscillator, np.array([[0.1, 0.0, 0.0, 0.1]]), 1, LDSettings(tau=1.0), t0=1.0)


def test_wrong_state_width_is_refused(saddle):
    with pytest.raises(ValueError, match=r"expected shape \(N, 2\)"):
        compute_ld(saddle, np.zeros((3, 4)), 1, LDSettings(tau=1.0))


def test_unknown_symbol_names_the_key():
    spec = {"vector_field": {"x": "y", "y": "-x + k*y"}, "coordinates": ["x", "y"]}
    with pytest.raises(ConfigError, match=r"'systems.bad.vector_field.y': unknown names \['k'\]"):
        make_system("bad", spec)


def test_formulas_must_match_the_coordinates():
    spec = {"vector_field": {"x": "y"}, "coordinates": ["x", "y"]}
    with pytest.raises(ConfigError, match=r"'systems.bad.vector_field': expected one formula for each coordinate"):
        make_system("bad", spec)


def test_time_is_reserved():
    spec = {"vector_field": {"t": "1"}, "coordinates": ["t"]}
    with pytest.raises(ConfigError, match=r"reserved"):
        make_system("bad", spec)


def test_stages_needing_a_hamiltonian_refuse_a_vector_field(saddle, oscillator):
    # The check the orbit, manifold and transport stages make on their system (the config check
    # refuses such entries earlier; this guards the library calls).
    with pytest.raises(ConfigError, match=r"'periodic_orbits.f.system': system 'linear_saddle' is a vector field"):
        require_hamiltonian(saddle, "a periodic-orbit family", key="periodic_orbits.f.system")
    assert require_hamiltonian(oscillator, "a periodic-orbit family") is None
