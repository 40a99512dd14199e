"""Hard cases of the LD engine and the stages.

Each case is checked against a closed form, an invariant, a symmetry or an independent
integration, never only for "no crash":

- finite-time blow-up beyond the saddles: stopped at the escape radius with the LD up to it
  equal to scipy's (terminal event); the escape time follows the closed-form law of a cubic
  potential;
- starts at an equilibrium (every velocity zero, where |v|^p is not smooth): LD exactly 0;
  the rounded saddle departs no sooner than linear theory allows;
- points exactly on the energy boundary (zero momentum): forward = backward LD (the point is
  its own time reverse), and the whole U_xpx section's reversal symmetry;
- excess energy 0 (the saddle on the grid) and very large: energy conserved;
- tau = 500: LD finite and increasing in tau, energy drift linear in tau;
- a grid entirely in the forbidden region, tiled: a valid file, no NaN;
- the Lyapunov family continued far beyond the configured dE = 10;
- the 3 DoF system at eta = 0, where the z mode decouples into a harmonic oscillator.

Throughout, pytest turns every warning into an error (pyproject.toml), and the engine runs
under ``np.errstate(all="raise")`` where overflow could arise.
"""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq
from scipy.special import beta

from ldpipe.io import contracts
from ldpipe.config import validate_config
from ldpipe.io.datafile import open_stage_file
from ldpipe.engine import LDSettings, compute_ld
from ldpipe.errors import LdpipeWarning
from ldpipe.core.equilibria.potential import equilibrium_table
from ldpipe.core.maps.grid import ld_grid_dataset
from ldpipe.core.orbits.periodic import CorrectorSettings, LyapunovFamily, linearize_saddle
from ldpipe.core.sections import Section
from ldpipe.stages import upo as upo_stage
from ldpipe.stages.equilibria import run_equilibria
from ldpipe.core.maps.assembly import compute_ld_map
from ldpipe.stages.ld import run_ld_gather, run_ld_tile
from ldpipe.config.parameters import parameters_from_config
from ldpipe.systems import make_system
from ldpipe.core.variational import sample
from support.barbanis import BOTTOM_REGION, DELTA, E_C, PAPER_Q_S, WY2, escaping_states

EPS = np.finfo(float).eps


def barbanis_field(state):
    """Hamilton's equations of the Barbanis 2 DoF, written out here (independent of ldpipe's kernels)."""
    x, y, px, py = state
    return np.array([px, py, -(x + DELTA * y * y), -(WY2 * y + 2.0 * DELTA * x * y)])


def barbanis_energy(state):
    x, y, px, py = state
    return 0.5 * (px * px + py * py) + 0.5 * x * x + 0.5 * WY2 * y * y + DELTA * x * y * y


@pytest.fixture(scope="module")
def barbanis_equilibria(barbanis):
    return equilibrium_table(barbanis, {"x": [-20.0, 20.0], "y": [-20.0, 20.0]})


# --- finite-time blow-up ----------------------------------------------------------------------
def escape_reference(state, radius, tau):
    """Escape time, M_1 and the arc length up to the first max_i |q_i| = radius, by solve_ivp.

    DOP853 at rtol = atol = 1e-13 with a terminal event on each face of the escape box. M_1
    needs no quadrature: between consecutive zeros of its velocity (located by events) a phase
    coordinate is monotone, so the integral of |velocity| is the coordinate's total variation.
    The arc length is integrated as a fifth state.
    """

    def rhs(_t, s):
        velocity = barbanis_field(s[:4])
        return [*velocity, math.sqrt(velocity @ velocity)]

    exits = []
    for i in range(2):
        for sign in (1.0, -1.0):
            event = lambda _t, s, i=i, sign=sign: sign * s[i] - radius  # noqa: E731
            event.terminal, event.direction = True, 1.0
            exits.append(event)
    zeros = [lambda _t, s, c=c: barbanis_field(s[:4])[c] for c in range(4)]
    solution = solve_ivp(rhs, (0.0, tau), [*state, 0.0], method="DOP853", rtol=1e-13, atol=1e-13, events=exits + zeros)
    assert solution.status == 1, "the reference trajectory did not escape"
    t_end, end = solution.t[-1], solution.y[:, -1]
    m1 = 0.0
    for c in range(4):
        at_zeros = np.reshape(solution.y_events[4 + c], (-1, 5))  # (0, 5) when there is none
        turning = at_zeros[solution.t_events[4 + c] < t_end, c]
        m1 += np.abs(np.diff([state[c], *turning, end[c]])).sum()
    return t_end, m1, end[4]


def test_blow_up_stops_at_the_escape_radius_as_solve_ivp_does(barbanis):
    # The cubic term sends these trajectories to infinity in finite time; the engine must stop
    # each where max|q_i| first reaches the radius, flag it, and hold the LD integrated up to
    # there: the same exit time, M_1 and arc length as the independent integration.
    states = escaping_states(barbanis)
    radius, tau = 100.0, 50.0
    with np.errstate(all="raise"):
        m1 = compute_ld(barbanis, states, +1, LDSettings(p=1.0, rtol=1e-12, atol=1e-12, tau=tau, escape_radius=radius))
        arc = compute_ld(barbanis, states, +1, LDSettings(p="arclength", rtol=1e-12, atol=1e-12, tau=tau,
                                                          escape_radius=radius))
    for result in (m1, arc):
        assert result.escaped.all() and not (result.failed | result.left_region).any()
        assert np.isfinite(result.ld).all() and np.isfinite(result.energy_error).all()
    for k, state in enumerate(states):
        t_end, reference_m1, reference_arc = escape_reference(state, radius, tau)
        assert m1.time[k] == pytest.approx(t_end, rel=1e-10)
        assert arc.time[k] == pytest.approx(t_end, rel=1e-10)
        assert m1.ld[k] == pytest.approx(reference_m1, rel=1e-9)
        assert arc.ld[k] == pytest.approx(reference_arc, rel=1e-9)


def test_blow_up_time_follows_the_cubic_law(barbanis):
    # Far out the cubic term dominates: |q'| ~ sqrt(2|V|) ~ R^(3/2), so the time left before the
    # blow-up from radius R is proportional to R^(-1/2) (closed form). The escape times at
    # R, 4R, 16R, ... are therefore bounded (finite-time blow-up), and successive differences
    # shrink by a factor 2 (up to O(1/R) corrections from the quadratic terms).
    states = escaping_states(barbanis)
    radii = 100.0 * 4.0 ** np.arange(5)
    tolerance = 1e-12
    times = []
    for radius in radii:
        with np.errstate(all="raise"):
            result = compute_ld(barbanis, states, +1, LDSettings(p=0.5, rtol=tolerance, atol=tolerance, tau=50.0,
                                                                  escape_radius=float(radius)))
        assert result.escaped.all() and not result.failed.any() and np.isfinite(result.ld).all()
        # Energy is conserved relative to the energies in play at the radius, |V| ~ |delta| R^3.
        scale = E_C + abs(DELTA) * radius**3 + 0.5 * (1.0 + WY2) * radius**2
        assert result.energy_error.max() < 10 * tolerance * scale
        times.append(result.time)
    steps = np.diff(np.array(times), axis=0)
    ratios = steps[:-1] / steps[1:]
    assert np.all(np.abs(ratios - 2.0) < 0.1)
    assert np.all(np.abs(ratios[-1] - 2.0) < np.abs(ratios[0] - 2.0))  # approaching the asymptotic law


# --- starts at an equilibrium -----------------------------------------------------------------
@pytest.mark.parametrize("name", ["barbanis", "barbanis_contopoulos"])
def test_ld_at_the_potential_minimum_is_exactly_zero(request, name):
    # The origin is an exact equilibrium in floating point (grad V = 0 exactly): every velocity
    # component is 0 for all time, so M_p = 0 and the arc length = 0 (closed form) for any tau,
    # integrand and time mode: the cusp of |v|^p at v = 0 must add nothing.
    system = request.getfixturevalue(name)
    n = system.n_dof
    state = np.zeros((1, 2 * n))
    assert not np.any(system.gradient(state[0, :n]))
    region = ((-1.0,) * n, (1.0,) * n)
    for tau in (0.5, 50.0, 500.0):
        for p in (0.5, 0.3, 1.0, "arclength"):
            for lower, upper in ((None, None), region):
                settings = LDSettings(p=p, rtol=1e-10, atol=1e-10, tau=tau, region_lower=lower, region_upper=upper)
                result = compute_ld(system, state, +1, settings)
                assert result.ld[0] == 0.0 and result.time[0] == tau and result.energy_error[0] == 0.0
                assert not (result.escaped[0] or result.left_region[0] or result.failed[0])
                # Work: with a zero error estimate every step grows h tenfold, from ~1e-6 to tau.
                assert result.steps[0] <= 20
    # The same with a fixed-step scheme: ceil(tau / dt) steps, all exact zeros.
    if n == 2:
        result = compute_ld(system, state, -1, LDSettings(scheme="rk4", dt=0.5, tau=50.0))
        assert result.ld[0] == 0.0 and result.time[0] == 50.0 and result.steps[0] == 100


def departure_time_bound(rate, omega, gradient, speed, distance):
    """Earliest time linear theory allows a start near a saddle to move ``distance`` away.

    From q_s + 0 with initial speed at most ``speed`` and a constant residual force at most
    ``gradient`` (|grad V| at the rounded saddle), the displacement along the unstable
    eigenvector of Hess V is at most (v/lambda) sinh(lambda t) + (g/lambda^2)(cosh(lambda t) - 1),
    and along the (orthogonal) centre eigenvectors at most v/omega + 2 g/omega^2 with omega the
    smallest centre frequency. Half the distance to the region's boundary keeps the trajectory
    where the linearization holds (the cubic terms change the force by a few per cent there).
    """

    def displacement(t):
        return (speed / rate * math.sinh(rate * t) + gradient / rate**2 * (math.cosh(rate * t) - 1.0)
                + speed / omega + 2.0 * gradient / omega**2)

    return brentq(lambda t: displacement(t) - distance / 2.0, 0.0, 200.0)


@pytest.mark.parametrize("name, saddle_index, region", [
    ("barbanis", 2, BOTTOM_REGION), ("barbanis_contopoulos", 1, PAPER_Q_S),
])
def test_rounded_saddle_departs_no_sooner_than_linear_theory(request, name, saddle_index, region):
    # The closed-form saddle rounded to doubles is an equilibrium only to rounding: |grad V| ~
    # 1e-15, which the saddle's instability amplifies as exp(lambda t). In variable time the
    # trajectory must stay in the saddle region (time = tau, LD ~ 0) for every tau below the
    # linear-theory departure time, and, if it leaves for a long tau, not before that time.
    system = request.getfixturevalue(name)
    saddle = system.closed_form_equilibria()[saddle_index]
    residual = 1e-14  # a bound on |grad V| at the rounded saddle, checked here
    assert np.linalg.norm(system.gradient(saddle)) < residual
    linear = linearize_saddle(system, saddle)
    lower, upper = np.array(region[0]), np.array(region[1])
    distance = float(min(np.min(saddle - lower), np.min(upper - saddle)))
    earliest = departure_time_bound(linear.saddle_rate, linear.omegas.min(), residual, 0.0, distance)
    assert earliest > 20.0  # the rounded saddle holds for tens of time units
    state = np.concatenate([saddle, np.zeros(system.n_dof)])[None, :]
    short = 0.8 * earliest
    settings = LDSettings(p=1.0, rtol=1e-10, atol=1e-10, tau=short, region_lower=region[0], region_upper=region[1])
    for direction in (+1, -1):
        result = compute_ld(system, state, direction, settings)
        assert result.time[0] == short and not (result.left_region[0] or result.escaped[0] or result.failed[0])
        # M_1 of the linear drift: the displacement and velocity bounds above, summed over the
        # 2n components (each at most the norm), integrated.
        n, rate = system.n_dof, linear.saddle_rate
        drift = residual / rate**2 * math.cosh(rate * short) + residual / rate * math.sinh(rate * short)
        assert result.ld[0] <= 2 * n * (drift + residual * short * (1.0 + 1.0 / linear.omegas.min()))
    long = LDSettings(p=1.0, rtol=1e-10, atol=1e-10, tau=500.0, region_lower=region[0], region_upper=region[1])
    result = compute_ld(system, state, +1, long)
    assert result.time[0] >= earliest and np.isfinite(result.ld[0]) and not result.failed[0]


# --- zero momentum: the energy boundary ----------------------------------------------------------
@pytest.mark.parametrize("name", ["barbanis", "barbanis_contopoulos"])
def test_turning_points_have_equal_forward_and_backward_ld(request, name):
    # H is even in p, so the backward trajectory of (q, p) is the forward one of (q, -p)
    # reversed; a point with p = 0 (on the zero-velocity surface V(q) = E) is its own reverse,
    # so its forward and backward LDs, times and flags agree. The integrand |v|^p has its
    # t^p cusp right at t = 0 in both directions.
    system = request.getfixturevalue(name)
    n = system.n_dof
    rng = np.random.default_rng(7)
    # Half anywhere (in the well, and beyond the saddles where trajectories escape), half near
    # the saddle, mostly inside the saddle region of the variable-time runs.
    if n == 2:
        saddle, region = np.array([5.5, -math.sqrt(50.0)]), BOTTOM_REGION
        wide = np.column_stack([rng.uniform(-4.0, 8.0, 12), rng.uniform(-9.0, 9.0, 12)])
    else:
        saddle, region = system.closed_form_equilibria()[1], PAPER_Q_S
        wide = rng.uniform(-12.0, 12.0, (12, 3))
    positions = np.vstack([wide, saddle + rng.uniform(-1.2, 1.2, (12, n))])
    states = np.hstack([positions, np.zeros((len(positions), n))])
    for p in (0.5, 0.3):
        for lower, upper in ((None, None), region):
            settings = LDSettings(p=p, tau=20.0, rtol=1e-11, atol=1e-11, region_lower=lower, region_upper=upper)
            forward = compute_ld(system, states, +1, settings)
            backward = compute_ld(system, states, -1, settings)
            assert not forward.failed.any()
            np.testing.assert_allclose(backward.ld, forward.ld, rtol=1e-10, atol=0)
            np.testing.assert_allclose(backward.time, forward.time, rtol=1e-12, atol=0)
            for flag in ("escaped", "left_region"):
                np.testing.assert_array_equal(getattr(backward, flag), getattr(forward, flag))
    assert forward.left_region.any() and (forward.time > 0).any()  # both kinds of start occur


def test_section_points_exactly_on_the_energy_boundary(barbanis):
    # U_xpx (y = 0, p_y solved >= 0) at E = 12.5 on an integer grid: V(x, 0) = x^2/2, so the
    # radicand 2E - x^2 - px^2 = 25 - x^2 - px^2 is exact, and the 12 grid points with
    # x^2 + px^2 = 25 lie exactly on the boundary: allowed, with p_y = 0 exactly.
    section = Section(axes=("x", "px"), ranges=((-5.0, 5.0), (-5.0, 5.0)), shape=(11, 11), fixed={"y": 0.0},
                      solve="py")
    settings = LDSettings(p=0.5, tau=10.0, rtol=1e-11, atol=1e-11)
    data = ld_grid_dataset(barbanis, section, 12.5, settings)
    x, px = np.meshgrid(data.x.values, data.px.values, indexing="ij")
    allowed = data.allowed.values
    np.testing.assert_array_equal(allowed, x**2 + px**2 <= 25.0)
    boundary = x**2 + px**2 == 25.0
    assert boundary.sum() == 12 and np.all(data.py.values[boundary] == 0.0)
    assert np.all(data.steps_forward.values[allowed] > 0)
    # Time reversal and the reflection y -> -y, p_y -> -p_y (V is even in y) together map
    # (x, 0, px, py) backward onto (x, 0, -px, py) forward: ld_backward(x, px) = ld_forward(x, -px)
    # on the whole section, boundary included (the px axis is symmetric).
    mirrored = data.ld_forward.values[:, ::-1]
    np.testing.assert_allclose(data.ld_backward.values[allowed], mirrored[allowed], rtol=1e-10, atol=0)
    np.testing.assert_allclose(data.exit_time_backward.values, data.exit_time_forward.values[:, ::-1])
    # The turning points (x = +-5, px = 0) are their own reverse: forward = backward there.
    turning = boundary & (px == 0.0)
    np.testing.assert_allclose(data.ld_backward.values[turning], data.ld_forward.values[turning], rtol=1e-10)
    # E < E_c and |x| <= 5 < 5.5: the well is closed, nothing escapes (closed form), energy kept.
    assert not (data.escaped_forward.values | data.escaped_backward.values | data.failed_forward.values).any()
    assert data.energy_error.values[allowed].max() < 1e-11 * 10.0 * 12.5
    assert_defined_where_allowed(data)


def assert_defined_where_allowed(data) -> None:
    """Every field finite at an allowed point; at a forbidden one, finite too unless the variable
    declares missing values (CF _FillValue), which it then is, exactly there."""
    allowed = data.allowed.values
    for name, variable in data.data_vars.items():
        values = variable.values.astype(float)
        assert np.isfinite(values[allowed]).all(), name
        if "_FillValue" in variable.encoding:
            assert np.isnan(values[~allowed]).all(), name
        else:
            assert np.isfinite(values).all(), name


# --- excess energy zero and very large ----------------------------------------------------------
def ld_config(**overrides):
    ld_map = {
        "system": "barbanis_2dof",
        "saddle_near": [5.5, -7.0],
        "section": {
            "axes": [{"name": "x", "range": [4.5, 6.5], "points": 5},
                     {"name": "px", "range": [-0.5, 0.5], "points": 5}],
            "fixed": {"y": "saddle"},
            "solve": "py",
        },
        "energy": {"excess": 0.0},
        "tau": 20.0,
        "time": "variable",
        "region": {"x": [4.5, 6.5], "y": [-8.5, -5.5]},
        "integrator": {"scheme": "dop853", "rtol": 1e-10, "atol": 1e-10},
        **overrides,
    }
    return validate_config({"systems": {"barbanis_2dof": {"builtin": "barbanis_2dof"}}, "ld_maps": {"m": ld_map}})


def test_zero_excess_energy_puts_the_saddle_on_the_grid(barbanis, barbanis_equilibria):
    # U_xpx^+(k) at k = y_saddle and dE = 0 contains the saddle itself (x = 5.5, px = 0). On this
    # line V = (x - 5.5)^2 / 2 + E_c (closed form), so the saddle is the only point that may be
    # allowed, and there E = V: p_y is solved from a radicand that is 0 up to the rounding of V
    # (terms ~ 30 summing to 15: a few ulps of 30), which sqrt turns into |p_y| ~ 1e-7. Linear
    # theory bounds how soon the trajectory may leave the saddle region from that speed; energy
    # is conserved to the tolerance.
    data = compute_ld_map(parameters_from_config(ld_config(), "ld", "m"), barbanis_equilibria, show_progress=False)
    allowed = data.allowed.values
    centre = (2, 2)
    assert data.x.values[2] == 5.5 and data.px.values[2] == 0.0
    assert allowed[centre], "V at the saddle rounds above E_c in the section's kernel: the saddle point is masked"
    assert allowed.sum() == 1
    rounding = 8 * EPS * (0.5 * 5.5**2 + 0.5 * WY2 * 50.0 + abs(DELTA) * 5.5 * 50.0)
    speed = math.sqrt(2.0 * rounding)
    assert abs(data.py.values[centre]) <= speed
    linear = linearize_saddle(barbanis, np.array([5.5, -math.sqrt(50.0)]))
    earliest = departure_time_bound(linear.saddle_rate, linear.omegas.min(), 1e-14, speed, 1.0)
    for direction in ("forward", "backward"):
        assert data[f"exit_time_{direction}"].values[centre] >= earliest
        assert not data[f"failed_{direction}"].values.any()
    assert data.energy_error.values[allowed].max() < 1e-10 * 20.0 * E_C
    assert data.attrs["excess_energy"] == 0.0


@pytest.mark.parametrize("excess", [0.0, 10.0, 100.0])
def test_energy_is_conserved_from_zero_to_large_excess_energy(barbanis, barbanis_equilibria, excess):
    # U_xpx (y = 0) at dE = 0, 10, 100: at 100 every point escapes. Energy is a first integral:
    # bounded trajectories keep it within ~tol per unit time relative to E (the error of H is a
    # sum of local errors, so it grows at most linearly); escaping ones relative to the energies
    # at the escape radius, |V| <= |delta| R^3 + (1 + wy2) R^2 / 2 + E.
    tolerance, tau, radius = 1e-10, 20.0, 100.0
    section = {"axes": [{"name": "x", "range": [-8.0, 8.0], "points": 17},
                        {"name": "px", "range": [-8.0, 8.0], "points": 17}], "fixed": {"y": 0.0}, "solve": "py"}
    config = ld_config(section=section, energy={"excess": excess}, time="fixed")
    del config["ld_maps"]["m"]["region"]
    with np.errstate(all="raise"):
        data = compute_ld_map(parameters_from_config(config, "ld", "m"), barbanis_equilibria, show_progress=False)
    allowed = data.allowed.values
    escaped = data.escaped_forward.values | data.escaped_backward.values
    energy = E_C + excess
    assert not (data.failed_forward.values | data.failed_backward.values).any()
    kept = allowed & ~escaped
    if kept.any():
        assert data.energy_error.values[kept].max() < tolerance * tau * energy
    if escaped.any():
        scale = energy + abs(DELTA) * radius**3 + 0.5 * (1.0 + WY2) * radius**2
        assert data.energy_error.values[escaped].max() < 20 * tolerance * scale
        for direction in ("forward", "backward"):
            times = data[f"exit_time_{direction}"].values[data[f"escaped_{direction}"].values]
            assert np.all((times > 0.0) & (times < tau))
    if excess == 100.0:
        assert escaped[allowed].all()
    assert_defined_where_allowed(data)


# --- long tau -----------------------------------------------------------------------------------
def test_long_tau_ld_increases_and_energy_drift_is_linear(barbanis):
    # Inside the closed well below E_c (x < 5.5, where V >= x^2/2 grows in |y|), trajectories
    # are bounded to any tau. The LD integrand is >= 0, so M_p(tau) increases with tau; the
    # energy error, a sum of local errors, grows at most linearly in tau.
    rng = np.random.default_rng(11)
    energy = E_C - 0.125
    rows = []
    while len(rows) < 24:
        x, y = rng.uniform(-5.0, 5.4), rng.uniform(-7.0, 7.0)
        kinetic = 2.0 * (energy - barbanis.potential(np.array([x, y])))
        if kinetic > 0.0:
            angle = rng.uniform(0.0, 2.0 * math.pi)
            rows.append((x, y, math.sqrt(kinetic) * math.cos(angle), math.sqrt(kinetic) * math.sin(angle)))
    states = np.array(rows)
    tolerance = 1e-10
    previous, errors = None, {}
    for tau in (50.0, 100.0, 250.0, 500.0):
        result = compute_ld(barbanis, states, +1, LDSettings(tau=tau, rtol=tolerance, atol=tolerance))
        assert np.all(result.time == tau) and not (result.escaped | result.failed).any()
        assert np.isfinite(result.ld).all()
        if previous is not None:
            assert np.all(result.ld > previous)
        previous = result.ld
        errors[tau] = result.energy_error.max()
        assert errors[tau] < tolerance * tau * energy
    assert errors[500.0] < 15.0 * errors[50.0]  # 10x the time: about 10x the drift, not more


# --- a grid entirely in the forbidden region ----------------------------------------------------
def test_all_forbidden_grid_in_tiles_gives_a_valid_empty_file(tmp_path, barbanis):
    # At y = 0 the potential is x^2/2 >= 0: a negative energy forbids every point (closed form).
    # Each tile and the gathered map are valid files with every point flagged not allowed, every
    # flag and count 0, every field that declares missing values missing, and the energy recorded.
    config = ld_config(energy={"total": -1.0}, time="fixed", tiles=3,
                       section={"axes": [{"name": "x", "range": [-3.0, 3.0], "points": 7},
                                         {"name": "px", "range": [-3.0, 3.0], "points": 4}],
                                "fixed": {"y": 0.0}, "solve": "py"})
    del config["ld_maps"]["m"]["region"]
    equilibria = run_equilibria(**parameters_from_config(config, "equilibria", "barbanis_2dof"),
                                output=tmp_path / "eq.nc")
    parameters = parameters_from_config(config, "ld", "m")
    tiles = [run_ld_tile(**parameters, equilibria=equilibria, tile=k, tiles=3, show_progress=False,
                         output=tmp_path / f"tile-{k}.nc") for k in range(3)]
    with pytest.warns(LdpipeWarning, match="is empty"):  # said once, for the whole map
        data = open_stage_file(run_ld_gather(tiles=tiles, output=tmp_path / "m.nc"), stage="ld_grid")
    assert data.sizes == {"x": 7, "px": 4} and data.attrs["energy"] == -1.0
    assert not data.allowed.values.any()
    for name, variable in data.data_vars.items():
        values = variable.values.astype(float)
        if "_FillValue" in variable.encoding:
            assert np.isnan(values).all(), name
        else:
            assert np.isfinite(values).all() and not values.any(), name


# --- periodic orbits far beyond the configured energies -----------------------------------------
def test_lyapunov_family_continues_far_beyond_de_10(tmp_path):
    # The config continues the bottom family to dE = 10; here to dE = 80. At each target: the
    # orbit closes within the tolerance when re-integrated by solve_ivp with the vector field
    # written out above (independent of ldpipe's kernels and propagator), its energy is the
    # target, it is a brake orbit (at rest at t = 0 and at T/2, time-reversal symmetry), and its
    # monodromy matrix is symplectic (multipliers lambda, 1/lambda: product 1).
    targets = [10.0, 20.0, 40.0, 80.0]
    config = validate_config({
        "systems": {"barbanis_2dof": {"builtin": "barbanis_2dof"}},
        "periodic_orbits": {"far": {"system": "barbanis_2dof", "saddle_near": [5.5, -7.0711],
                                    "energies": {"excess": targets}, "samples": 101}},
    })
    equilibria = run_equilibria(**parameters_from_config(config, "equilibria", "barbanis_2dof"),
                                output=tmp_path / "eq.nc")
    path = upo_stage.run_upo(**parameters_from_config(config, "upo", "far"), equilibria=equilibria,
                             output=tmp_path / "far.nc")
    data = open_stage_file(path, stage=contracts.UPO)
    tolerance = data.attrs["tolerance"]
    np.testing.assert_allclose(data.excess_energy.values, targets, rtol=0, atol=2 * data.attrs["energy_tolerance"])
    for k in range(len(targets)):
        state, period = data.initial_state.values[k], float(data.period.values[k])
        assert np.all(state[2:] == 0.0)
        assert barbanis_energy(state) == pytest.approx(E_C + targets[k], abs=1e-11)
        solution = solve_ivp(lambda _t, s: barbanis_field(s), (0.0, period), state, method="DOP853",
                             rtol=1e-13, atol=1e-13, dense_output=True)
        assert np.linalg.norm(solution.y[:, -1] - state) < tolerance
        assert np.abs(solution.sol(period / 2)[2:]).max() < 1e-7  # at rest again at the half period
        multipliers = data.floquet_real.values[k, :2] + 1j * data.floquet_imag.values[k, :2]
        assert abs(multipliers[0] * multipliers[1] - 1.0) < 1e-8 and multipliers[0].real > 1.0
    assert np.all(np.diff(data.amplitude.values) > 0)  # one family, growing
    for name, variable in data.data_vars.items():
        if variable.dtype.kind == "f":
            assert np.isfinite(variable.values).all(), name


# --- 3 DoF with eta -> 0: the z mode decouples ---------------------------------------------------
# V = (wx2 x^2 + wy2 y^2 + wz2 z^2)/2 - eps x^2 y - eta x^2 z. At eta = 0 the z equation is
# z'' = -wz2 z, a harmonic oscillator of frequency omega_z = sqrt(wz2), whatever x and y do, and
# (x, y) move in V_xy = (wx2 x^2 + wy2 y^2)/2 - eps x^2 y: the Barbanis potential with the roles
# of x and y swapped (omega_x^2 = wy2, omega_y^2 = wx2, delta = -eps).
WX2_3, WY2_3, WZ2_3, EPSILON = 0.9, 1.6, 0.4, 0.08
OMEGA_Z = math.sqrt(WZ2_3)


@pytest.fixture(scope="module")
def decoupled():
    return make_system("bc_eta0", {"builtin": "barbanis_contopoulos_3dof", "parameters": {"eta": 0.0}})


def test_eta_zero_z_mode_is_a_harmonic_oscillator(decoupled):
    system = decoupled
    # Closed-form saddle at eta = 0: x^2 = wx2 wy2 / (2 eps^2), y = eps x^2 / wy2, z = 0.
    x_squared = WX2_3 * WY2_3 / (2 * EPSILON**2)
    saddle = np.array([math.sqrt(x_squared), EPSILON * x_squared / WY2_3, 0.0])
    np.testing.assert_allclose(system.closed_form_equilibria()[1], saddle, rtol=1e-15)
    linear = linearize_saddle(system, saddle)
    assert np.min(np.abs(linear.omegas - OMEGA_Z)) < 1e-12 * OMEGA_Z
    settings = CorrectorSettings(tolerance=1e-10, rtol=1e-13, atol=1e-13)
    z_mode = int(np.argmin(np.abs(linear.omegas - OMEGA_Z)))
    family = LyapunovFamily(system, linear, z_mode, settings)
    ec = linear.critical_energy
    family.continue_to(ec + 2.0, initial_amplitude=1e-4, max_step=0.1, max_members=500)
    for excess in (0.1, 1.0, 2.0):
        orbit = family.at_energy(ec + excess, energy_tolerance=1e-12)
        # Isochronous: the period is 2 pi / omega_z at every amplitude; the amplitude follows from
        # the energy, wz2 A^2 / 2 = dE; x and y stay at the saddle.
        assert orbit.period == pytest.approx(2 * math.pi / OMEGA_Z, rel=1e-10)
        amplitude = math.sqrt(2 * excess) / OMEGA_Z
        np.testing.assert_allclose(orbit.initial_state[:2], saddle[:2], rtol=1e-12)
        assert abs(orbit.initial_state[2]) == pytest.approx(amplitude, rel=1e-9)
    # A generic trajectory: z(t) = z0 cos(w t) + (pz0 / w) sin(w t) while x, y wander (closed form).
    start = np.array([3.0, -1.0, 0.7, 0.4, 1.1, -0.3])
    times = np.linspace(0.0, 15.0, 61)
    states, _ = sample(system, start, times, rtol=1e-12, atol=1e-12)
    z = start[2] * np.cos(OMEGA_Z * times) + start[5] / OMEGA_Z * np.sin(OMEGA_Z * times)
    np.testing.assert_allclose(states[:, 2], z, atol=1e-9)
    pz = -start[2] * OMEGA_Z * np.sin(OMEGA_Z * times) + start[5] * np.cos(OMEGA_Z * times)
    np.testing.assert_allclose(states[:, 5], pz, atol=1e-9)


def test_eta_zero_xy_motion_is_the_swapped_barbanis_system(decoupled):
    # The (x, y) part at eta = 0 must move as the Barbanis 2 DoF built-in (its own, separately
    # written kernels) with X = y, Y = x, omega_x^2 = wy2, omega_y^2 = wx2, delta = -eps: the
    # same trajectory, and the same Lyapunov family of the in-plane centre mode.
    swapped = make_system("barbanis_swapped", {"builtin": "barbanis_2dof", "parameters": {
        "omega_x": math.sqrt(WY2_3), "omega_y": math.sqrt(WX2_3), "delta": -EPSILON}})
    start = np.array([3.0, -1.0, 0.7, 0.4, 1.1, -0.3])
    times = np.linspace(0.0, 15.0, 31)
    three, _ = sample(decoupled, start, times, rtol=1e-12, atol=1e-12)
    two, _ = sample(swapped, start[[1, 0, 4, 3]], times, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(three[:, [1, 0, 4, 3]], two, atol=1e-8)
    settings = CorrectorSettings(tolerance=1e-10, rtol=1e-13, atol=1e-13)
    x_squared = WX2_3 * WY2_3 / (2 * EPSILON**2)
    saddle3 = np.array([math.sqrt(x_squared), EPSILON * x_squared / WY2_3, 0.0])
    linear3 = linearize_saddle(decoupled, saddle3)
    linear2 = linearize_saddle(swapped, saddle3[[1, 0]])
    in_plane = int(np.argmax(linear3.omegas))  # omega_xy > omega_z here
    assert linear3.omegas[in_plane] == pytest.approx(linear2.omegas[0], rel=1e-12)
    assert linear3.saddle_rate == pytest.approx(linear2.saddle_rate, rel=1e-12)
    family3 = LyapunovFamily(decoupled, linear3, in_plane, settings)
    family2 = LyapunovFamily(swapped, linear2, 0, settings)
    for family in (family3, family2):
        family.continue_to(family.saddle.critical_energy + 1.0, initial_amplitude=1e-4, max_step=0.1, max_members=500)
    for excess in (0.1, 1.0):
        orbit3 = family3.at_energy(linear3.critical_energy + excess, energy_tolerance=1e-12)
        orbit2 = family2.at_energy(linear2.critical_energy + excess, energy_tolerance=1e-12)
        assert orbit3.period == pytest.approx(orbit2.period, rel=1e-9)
        assert abs(orbit3.initial_state[2]) < 1e-14 and orbit3.initial_state[5] == 0.0  # z stays 0
        np.testing.assert_allclose(orbit3.initial_state[[1, 0]], orbit2.initial_state[:2], atol=1e-8)


def oscillator_ld_whole_half_periods(z, pz, omega, half_periods, p):
    """M_p of the z oscillator over k half periods: both of its velocity components (z' and pz')
    are sinusoids of amplitudes A w and A w^2, and |cos|^p integrates to B(1/2, (p+1)/2) over
    each half period (closed form, independent of the phase)."""
    amplitude = math.hypot(z, pz / omega)
    return half_periods * ((amplitude * omega) ** p + (amplitude * omega**2) ** p) * beta(0.5, (p + 1) / 2) / omega


@pytest.mark.slow  # compiles the engine once more for the eta = 0 system (~15 s)
def test_eta_zero_ld_is_the_xy_part_plus_the_oscillator(decoupled):
    # The LD is a sum over phase-space velocity components, so at eta = 0 the LD of a state is
    # the LD of the same (x, y, px, py) with z = pz = 0 (where z stays 0) plus the oscillator's
    # closed form, here over tau = 6 half periods of omega_z.
    rng = np.random.default_rng(5)
    planar = np.column_stack([rng.uniform(-3.0, 3.0, 8), rng.uniform(-2.0, 2.0, 8), np.zeros(8),
                              rng.uniform(-1.0, 1.0, 8), rng.uniform(-1.0, 1.0, 8), np.zeros(8)])
    full = planar.copy()
    full[:, 2] = rng.uniform(-1.5, 1.5, 8)
    full[:, 5] = rng.uniform(-1.0, 1.0, 8)
    tau = 6 * math.pi / OMEGA_Z
    for p in (0.5, 1.0):
        settings = LDSettings(p=p, tau=tau, rtol=1e-12, atol=1e-12)
        with_z = compute_ld(decoupled, full, +1, settings)
        without = compute_ld(decoupled, planar, +1, settings)
        assert not (with_z.escaped | with_z.failed | without.escaped).any()
        oscillator = np.array([oscillator_ld_whole_half_periods(s[2], s[5], OMEGA_Z, 6, p) for s in full])
        np.testing.assert_allclose(with_z.ld - without.ld, oscillator, rtol=1e-8)
