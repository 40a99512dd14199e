"""LDSettings validation, the DOP853 tableau's order conditions, and input checks of compute_ld."""

import math

import numpy as np
import pytest

from ldpipe.engine import LDSettings, compute_ld
from ldpipe.engine.schemes import tableaux
from ldpipe.engine.schemes import SCHEMES
from ldpipe.engine.schemes.composition import Composition


@pytest.mark.parametrize(
    "field,value",
    [
        ("scheme", "euler"),
        ("rtol", -1.0),
        ("atol", 0.0),
        ("dt", float("nan")),
        ("p", 1.5),
        ("p", 0.0),
        ("p", "length"),
        ("tau", 0.0),
        ("escape_radius", -3.0),
        ("block", 0),
        ("max_steps", 2.5),
        ("quad_nodes", 1),
    ],
)
def test_bad_values_name_the_field(field, value):
    with pytest.raises(ValueError, match=field):
        LDSettings(**{field: value})


def test_scheme_error_lists_allowed_values():
    with pytest.raises(ValueError, match="dop853.*rk4"):
        LDSettings(scheme="euler")


def test_region_needs_both_bounds_in_order():
    with pytest.raises(ValueError, match="region_lower"):
        LDSettings(region_lower=(0.0, 0.0))
    with pytest.raises(ValueError, match="lower < upper"):
        LDSettings(region_lower=(0.0, 2.0), region_upper=(1.0, 1.0))
    s = LDSettings(region_lower=[9, 2.5, 1], region_upper=[12, 7.5, 4])
    assert s.variable_time and s.region_lower == (9.0, 2.5, 1.0)


def test_dop853_order_conditions():
    # Quadrature conditions sum_i b_i c_i^k = 1/(k+1) hold up to k = 7 for an 8th-order method,
    # the rows of A sum to c, and the dense output reproduces the step end at x = 1.
    b, c, a = tableaux.B, tableaux.C[:12], tableaux.A
    for k in range(8):
        assert np.dot(b, c**k) == pytest.approx(1.0 / (k + 1), abs=1e-14)
    assert np.allclose(a.sum(axis=1), tableaux.C, atol=1e-14)
    # a second-order tree condition, sum_i b_i sum_j a_ij c_j = 1/6
    assert np.dot(b, a[:12, :12] @ c) == pytest.approx(1.0 / 6.0, abs=1e-14)
    assert np.allclose(tableaux.DOP853_DENSE.sum(axis=0)[:12], b, atol=1e-12)
    assert np.sum(tableaux.E5) == pytest.approx(0.0, abs=1e-14)  # error estimators vanish on constants


def test_compositions_are_consistent():
    compositions = [record for record in SCHEMES.values() if isinstance(record, Composition)]
    assert [record.name for record in compositions] == ["sym4", "sym6"]
    for record in compositions:
        weights = np.array(record.weights)
        assert weights.sum() == pytest.approx(1.0, abs=1e-14)
        assert np.allclose(weights, weights[::-1])  # symmetric composition (time-reversible)
    # 4th order: the triple-power condition sum w^3 = 0 of a symmetric composition of a 2nd-order map
    assert np.sum(tableaux.SUZUKI4**3) == pytest.approx(0.0, abs=1e-14)


def test_compositions_share_one_engine_module(barbanis):
    # By design (Composition.coefficients): the weights reach the step at run time, so every
    # composition of a system compiles the same text, under one name, and differs only in the
    # coefficients the driver is given (the record's own weights).
    from ldpipe.engine.codegen import engine_name, engine_source

    compositions = [record for record in SCHEMES.values() if isinstance(record, Composition)]
    assert len({engine_source(barbanis, record.name, 8) for record in compositions}) == 1
    assert {engine_name(barbanis.name, record.name, 64) for record in compositions} == {
        "engine_barbanis_2dof_composition_64"}
    for record in compositions:
        assert np.array_equal(record.coefficients(), np.array(record.weights))
    assert SCHEMES["dop853"].coefficients().size == SCHEMES["rk4"].coefficients().size == 0
    # the flow driver passes no coefficients: a composition's step there would take no sub-step
    with pytest.raises(ValueError, match="run-time coefficients"):
        engine_source(barbanis, "sym4", 8, entry="flow_process")


def test_input_shape_and_direction(barbanis):
    with pytest.raises(ValueError, match="initial_states"):
        compute_ld(barbanis, np.zeros((3, 3)))
    with pytest.raises(ValueError, match="direction"):
        compute_ld(barbanis, np.zeros((1, 4)), direction=0)
    with pytest.raises(ValueError, match="region_lower"):
        compute_ld(barbanis, np.zeros((1, 4)), settings=LDSettings(region_lower=(0, 0, 0), region_upper=(1, 1, 1)))
    empty = compute_ld(barbanis, np.zeros((0, 4)))
    assert empty.ld.shape == (0,)


def test_results_do_not_depend_on_batching(barbanis):
    # Each lane integrates its own trajectory: the same state gives the same LD whatever its
    # neighbours, block size and position (lanes refill as trajectories finish).
    rng = np.random.default_rng(1)
    states = np.zeros((150, 4))
    states[:, 0] = rng.uniform(-1, 3, 150)
    states[:, 3] = rng.uniform(1, 4, 150)
    whole = compute_ld(barbanis, states, +1, LDSettings(tau=5.0))
    single = compute_ld(barbanis, states[[17]], +1, LDSettings(tau=5.0))
    assert single.ld[0] == whole.ld[17]
    reordered = compute_ld(barbanis, states[::-1], +1, LDSettings(tau=5.0))
    assert np.array_equal(reordered.ld[::-1], whole.ld)
    assert math.isfinite(whole.ld.sum())


# Hang guards: each threshold checked just below and just at it, where a bug would hide.
from ldpipe.core.trajectories import FlowSettings  # noqa: E402
from ldpipe.engine.settings import (  # noqa: E402
    ATOL_FLOOR, MAX_STEPS_CEILING, RTOL_FLOOR, IntegratorSettings, StoppingRules,
)

BELOW_RTOL = math.nextafter(RTOL_FLOOR, 0.0)
BELOW_ATOL = math.nextafter(ATOL_FLOOR, 0.0)


@pytest.mark.parametrize("make", [IntegratorSettings, LDSettings, FlowSettings], ids=lambda c: c.__name__)
def test_tolerances_below_what_doubles_honour_are_refused_naming_the_setting_and_floor(make):
    assert make(rtol=RTOL_FLOOR, atol=ATOL_FLOOR).rtol == RTOL_FLOOR
    with pytest.raises(ValueError, match=r"^rtol: .* below what double precision can honour.*use >= 1e-15$"):
        make(rtol=BELOW_RTOL)
    with pytest.raises(ValueError, match=r"^atol: .* below what double precision can honour.*use >= 2\.2250738585072014e-308$"):
        make(atol=BELOW_ATOL)


def test_flow_settings_refuse_what_spun_through_every_step():
    # rtol 1e-160 was accepted and ran max_steps (1e7) NaN steps per trajectory.
    for name, value in (("rtol", 1e-160), ("rtol", float("nan")), ("atol", float("inf")), ("escape_radius", -1.0)):
        with pytest.raises(ValueError, match=f"^{name}: "):
            FlowSettings(**{name: value})


@pytest.mark.parametrize("make", [StoppingRules, LDSettings, FlowSettings], ids=lambda c: c.__name__)
def test_max_steps_beyond_the_ceiling_is_refused(make):
    assert make(max_steps=MAX_STEPS_CEILING).max_steps == MAX_STEPS_CEILING
    with pytest.raises(ValueError, match=r"^max_steps: expected .*integer"):
        make(max_steps=MAX_STEPS_CEILING + 1)


def test_fixed_step_counts_beyond_the_ceiling_are_refused_naming_tau_and_dt():
    at = LDSettings(scheme="rk4", dt=1.0, tau=float(MAX_STEPS_CEILING), max_steps=MAX_STEPS_CEILING)
    assert at.tau / at.dt == MAX_STEPS_CEILING
    with pytest.raises(ValueError, match=r"^tau, dt: tau/dt = 1e\+09 steps a trajectory, more than 1e\+09"):
        LDSettings(scheme="rk4", dt=1.0, tau=math.nextafter(float(MAX_STEPS_CEILING), math.inf),
                   max_steps=MAX_STEPS_CEILING)
    LDSettings(scheme="dop853", tau=1e12)  # an adaptive scheme's count is not tau/dt


def test_a_fixed_time_map_that_max_steps_would_cut_short_is_refused():
    LDSettings(scheme="sym4", dt=0.01, tau=100.0, max_steps=10_000)  # 1e4 steps: just enough
    with pytest.raises(ValueError, match=r"^tau, dt, max_steps: .* more than max_steps = 9999"):
        LDSettings(scheme="sym4", dt=0.01, tau=100.0, max_steps=9_999)
    # variable time: trajectories that leave the region stop early, so the cap may be lower
    LDSettings(scheme="sym4", dt=0.01, tau=100.0, max_steps=9_999, region_lower=(0, 0), region_upper=(1, 1))


@pytest.mark.parametrize("value", [float("nan"), float("inf")])
@pytest.mark.parametrize("name", ["tau", "dt"])
def test_non_finite_time_settings_are_refused(name, value):
    with pytest.raises(ValueError, match=f"^{name}: expected a finite number"):
        LDSettings(**{name: value})
