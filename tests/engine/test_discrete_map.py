"""The discrete LD of maps x_{n+1} = f(x_n) against closed forms, and the map kind's refusals.

The discrete LD (Lopesino et al. 2015) is M_p = sum_{n=-N}^{N-1} sum_i |x^i_{n+1} - x^i_n|^p;
ld_forward holds n = 0 .. N-1, ld_backward n = -N .. -1. The linear saddle map's halves are
geometric sums (derived in ``support/linear_saddle_map.py``); an orbit that escapes the radius
R holds the k iterations whose iterate stays inside: the half with N replaced by
k = min(N, floor(log(R / |x0|) / log l)).
"""

import math

import numpy as np
import pytest

import ldpipe
from ldpipe.config import validate_config
from ldpipe.engine.discrete_map import fast_lyapunov_indicator, iterate_map_ld
from ldpipe.errors import ConfigError
from support.linear_saddle_map import LAMBDA, SPEC, saddle_halves


@pytest.fixture(scope="module")
def saddle():
    return ldpipe.system(name="linear_saddle", **SPEC)


@pytest.mark.parametrize("p", [0.5, 1.0, 0.3])
def test_linear_saddle_map_ld_is_its_closed_form(saddle, p):
    """Every pixel's halves equal the geometric sums (to rounding: a few ulps of ~N terms); the
    driver's square root (p = 1/2), absolute value (p = 1) and power (any other p) each."""
    n = 12
    ld = ldpipe.ld_map(saddle, section=ldpipe.section(x=(-1.0, 0.75, 8), y=(-0.8, 0.6, 9)), iterations=n, p=p,
                       integrator={"escape_radius": 1e6})
    x, y = np.meshgrid(ld.x.values, ld.y.values, indexing="ij")
    expected = np.vectorize(lambda a, b: saddle_halves(a, b, n, p))(x, y)
    np.testing.assert_allclose(ld.ld_forward.values, expected[0], rtol=1e-13, atol=1e-15)
    np.testing.assert_allclose(ld.ld_backward.values, expected[1], rtol=1e-13, atol=1e-15)
    assert not ld.escaped_forward.values.any() and (ld.iterations_forward.values == n).all()
    assert ld.attrs["iterations"] == n and ld.attrs["p"] == p and ld.attrs["descriptor"] == f"M_p, p = {p}"
    assert "tau" not in ld.attrs


@pytest.mark.parametrize("states", [np.zeros((4, 3)), np.zeros(2)], ids=["three columns", "one row, flat"])
def test_the_iterations_take_one_row_of_the_maps_coordinates_per_orbit(saddle, states):
    # the LD and the FLI alike: the map's state is (x, y), so rows of two, in a 2-D array
    expected = r"states: expected shape \(N, 2\) with rows \('x', 'y'\) for linear_saddle, got "
    with pytest.raises(ValueError, match=expected):
        iterate_map_ld(saddle, states, 3, 0.5, 1, 1e6)
    with pytest.raises(ValueError, match=expected):
        fast_lyapunov_indicator(saddle, states, 3, 1e6)


def test_an_escaping_orbit_holds_the_iterations_inside(saddle):
    """Starts whose orbit passes the radius R (x forward, y backward): flagged, with the closed
    form's partial sum over k = floor(log(R / |x0|) / log l) iterations (R chosen off every
    iterate), no term of the iteration that left."""
    n, p, radius = 30, 0.5, 10.3
    starts = np.array([[0.7, 0.2], [-0.013, 0.4], [4.0, -1.0], [11.0, 0.0]])
    for direction, grows in ((1, 0), (-1, 1)):
        result = iterate_map_ld(saddle, starts[:, ::direction], n, p, direction, radius)
        held = [min(n, math.floor(math.log(radius / abs(x0)) / math.log(LAMBDA))) if abs(x0) <= radius else 0
                for x0, _ in starts]
        assert result.iterations.tolist() == held
        assert result.escaped.tolist() == [k < n for k in held]
        expected = [saddle_halves(*start[::direction], k, p)[grows] for start, k in zip(starts, held)]
        np.testing.assert_allclose(result.ld, expected, rtol=1e-13)


def test_an_overflowing_orbit_is_flagged_not_infinite():
    """x -> 1e200 x overflows on the second iterate of x0 = 0.5: one iteration held, 0.5^p (1e200 - 1)^p."""
    huge = ldpipe.system(name="huge", map={"x": "1e200*x"}, inverse={"x": "x/1e200"}, coordinates=["x"])
    result = iterate_map_ld(huge, np.array([[0.5]]), 5, 0.5, 1, 1e305)
    assert result.escaped.tolist() == [True] and result.iterations.tolist() == [1]
    assert np.isfinite(result.ld).all() and result.ld[0] == pytest.approx(math.sqrt(0.5 * (1e200 - 1)), rel=1e-14)


def test_standard_map_ld_takes_angle_increments_on_the_circle():
    """K = 0 turns the standard map into theta -> theta + p, p fixed: each forward increment is p
    wrapped into [-pi, pi), so the forward half is N |p wrapped|^(exponent) (both halves alike)."""
    rotation = ldpipe.system(name="rotation", map="standard", parameters={"K": 0.0})
    momenta = np.array([0.3, -2.0, 3.5, 7.0, -9.0])
    starts = np.column_stack([np.full(5, 1.0), momenta])
    wrapped = (momenta + np.pi) % (2 * np.pi) - np.pi
    for direction in (1, -1):
        result = iterate_map_ld(rotation, starts, 7, 0.5, direction, 100.0)
        np.testing.assert_allclose(result.ld, 7 * np.sqrt(np.abs(wrapped)), rtol=1e-12)
        assert (result.end_state[:, 0] >= 0).all() and (result.end_state[:, 0] < 2 * np.pi).all()


def test_standard_map_ld_is_periodic_in_the_angle():
    """The standard map lives on the cylinder (theta mod 2 pi): the LD at theta and theta + 2 pi
    is the same. The grid's theta + 2 pi is theta to rounding (1e-15), which orbits passing near
    the saddle (0, 0) amplify, most through the square root of a near-zero increment (3e-6 at
    most measured over 10 iterations); a wrong wrap of the angle differs by O(1)."""
    standard = ldpipe.system(name="standard", map="standard")
    m = 20  # grid points per period
    ld = ldpipe.ld_map(standard, section=ldpipe.section(theta=(-np.pi, 3 * np.pi, 2 * m + 1), p=(-3.0, 3.0, 13)),
                       iterations=10)
    for name in ("ld_forward", "ld_backward"):
        values = ld[name].values
        np.testing.assert_allclose(values[m:], values[:-m], rtol=0, atol=1e-5)
        assert values.std() > 0.1 * values.mean()  # not a constant field
    assert ld.attrs["periodic"] == f"theta mod {2 * np.pi!r}"


def test_a_map_without_its_inverse_refuses_the_backward_half_naming_the_key():
    """... and computes the forward half alone (``directions: forward``) without it."""
    forward_only = ldpipe.system(name="forward_only", map={"x": "2*x", "y": "y/2"}, coordinates=["x", "y"])
    section = ldpipe.section(x=(0.0, 1.0, 3), y=(0.0, 1.0, 3))
    for directions in ("both", "backward"):
        with pytest.raises(ConfigError, match=r"config key 'systems.forward_only.inverse': .*gives no inverse"):
            ldpipe.ld_map(forward_only, section=section, iterations=3, directions=directions)
    with pytest.raises(ConfigError, match="systems.forward_only.inverse"):
        forward_only.step(np.array([1.0, 1.0]), -1)
    forward = ldpipe.ld_map(forward_only, section=section, iterations=3, directions="forward")
    assert "ld_backward" not in forward and forward.attrs["directions"] == "forward"
    # x -> 2x, y -> y/2 from (1, 1): increments 1, 2, 4 and 1/2, 1/4, 1/8, each to the power 1/2
    assert forward.ld_forward.values[2, 2] == pytest.approx(1 + 2**0.5 + 2 + 0.5**0.5 + 0.5 + 0.125**0.5, rel=1e-14)


@pytest.mark.parametrize("keys, message", [
    ({"iterations": 5, "tau": 2.0}, "argument 'tau': .*discrete map.*give iterations instead of tau"),
    ({}, "argument 'iterations': .*give iterations N"),
    ({"iterations": 5, "energy": 0.1}, "argument 'energy': .*no energy"),
    ({"iterations": 5, "time": "variable"}, "argument 'time'"),
    ({"iterations": 5, "integrator": {"scheme": "rk4"}}, "argument 'integrator.scheme': .*escape_radius alone"),
    ({"iterations": 5, "p": "arclength"}, "argument 'p': .*arc length is of a flow"),
    ({"iterations": 5, "ftle": True}, "argument 'ftle'"),
    ({"iterations": 5, "directions": "forward", "chaos_indicators": {}}, "argument 'chaos_indicators': .*two halves"),
])
def test_a_map_refuses_a_flows_keys_naming_them(saddle, keys, message):
    section = ldpipe.section(x=(-1.0, 1.0, 3), y=(-1.0, 1.0, 3))
    with pytest.raises(ConfigError, match=message):
        ldpipe.ld_map(saddle, section=section, **keys)


def test_a_flow_refuses_a_maps_keys():
    flow = ldpipe.system(name="flow_saddle", vector_field={"x": "x", "y": "-y"}, coordinates=["x", "y"])
    with pytest.raises(ConfigError, match="argument 'iterations': .*flow in time"):
        ldpipe.ld_map(flow, section=ldpipe.section(x=(-1.0, 1.0, 3), y=(-1.0, 1.0, 3)), iterations=4)
    with pytest.raises(ConfigError, match="argument 'chaos_indicators': .*flow in time"):
        ldpipe.ld_map(flow, section=ldpipe.section(x=(-1.0, 1.0, 3), y=(-1.0, 1.0, 3)), chaos_indicators={})


@pytest.mark.parametrize("spec, message", [
    ({"map": "henon", "coordinates": ["x", "y"]}, "systems.m.coordinates': the built-in map 'henon'"),
    ({"map": "henon", "parameters": {"c": 1.0}}, r"systems.m.parameters': unknown parameters \['c'\]"),
    ({"map": "henon", "parameters": {"b": 0.0}}, "systems.m.parameters.b': .*not invertible"),
    ({"map": "lozi"}, "systems.m.map': 'lozi' is not valid.*built-in map: henon.*standard"),
    ({"map": {"x": "2*x"}}, "systems.m.coordinates': a map given by formulas needs its coordinates"),
    ({"map": {"x": "2*x"}, "coordinates": ["x", "y"]}, r"systems.m.map': expected one formula for each"),
    ({"map": {"x": "__import__('os')"}, "coordinates": ["x"]}, "systems.m.map.x'"),
    ({"map": {"x": "2*x"}, "inverse": {"x": "x/t"}, "coordinates": ["x"]}, r"systems.m.inverse.x': unknown names \['t'\]"),
    ({"map": "standard", "periodic": {"q": 1.0}}, "systems.m.periodic.q': not a coordinate"),
    ({"map": "standard", "periodic": {"theta": 1.0}}, "systems.m.periodic.theta': .*period 6.28318"),
    ({"map": "standard", "masses": {"p": 2.0}}, "systems.m': a system needs .*a map takes no 'masses'"),
    ({"formula": "x**2", "coordinates": ["x"], "periodic": {"x": 1.0}},
     "systems.m': a system needs .*a formula.* take no 'inverse' or 'periodic'"),
])
def test_bad_map_entries_name_the_key(spec, message):
    with pytest.raises(ConfigError, match=message):
        validate_config({"systems": {"m": spec}})
