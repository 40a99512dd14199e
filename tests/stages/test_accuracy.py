"""The accuracy–cost measurement: its error measures against closed forms, convergence orders,
the periodic-orbit ladder against the definition of a periodic orbit, the stage file and figure.

No test asserts on time: wall times are the measurement, and a shared machine makes them vary.
"""

import math

import numpy as np
import pytest
import xarray as xr

from ldpipe.io import contracts
from ldpipe.core import accuracy
from ldpipe.core.accuracy import measurement
from ldpipe.core.accuracy import (
    CorrectorStep, IntegratorStep, closure_error, corrector_ladder, finite_quantiles, integrator_ladder,
    ld_ladder_dataset, orbit_ladder_dataset, relative_error, sample_indices,
)
from ldpipe.config import validate_config
from ldpipe.io.datafile import open_stage_file
from ldpipe.engine import LDSettings, compute_ld
from ldpipe.errors import ConfigError
from ldpipe.core.orbits.periodic import BrakeOrbit, linearize_saddle
from ldpipe.stages import accuracy as accuracy_stage
from ldpipe.stages.equilibria import run_equilibria
from ldpipe.config.parameters import parameters_from_config
from ldpipe.stages.plan import ladder_engines

# The closed-form M_p of the uncoupled oscillators (Beta functions) of the `oscillator` fixture,
# frequencies (wx, wy) = (1.0, 1.3): derived in tests/support, checked in tests/engine/test_closed_form.py.
from support.closed_forms import WX, oscillator_ld

TAU = 20.0
CONTINUATION = {"initial_amplitude": 1e-4, "max_step": 0.1, "max_members": 5000}


@pytest.fixture(scope="module")
def oscillator_states():
    # One engine block (64) of generic states: every velocity component crosses zero many times in tau.
    return np.random.default_rng(3).uniform(-1.0, 1.0, (64, 4))


@pytest.fixture(scope="module")
def exact(oscillator_states):
    """Closed-form LD forward and backward, shape (2, 64). Backward from (q, p) is forward from (q, -p):
    the oscillators are reversible under p -> -p."""
    forward = [oscillator_ld(s, TAU, 0.5) for s in oscillator_states]
    backward = [oscillator_ld(np.concatenate([s[:2], -s[2:]]), TAU, 0.5) for s in oscillator_states]
    return np.array([forward, backward])


@pytest.fixture(scope="module")
def oscillator_ladder(oscillator, oscillator_states):
    steps = integrator_ladder({
        "dop853": {"rtol": [1e-4, 1e-6, 1e-8]},
        "rk4": {"dt": [0.2, 0.1, 0.05]},
        "sym4": {"dt": [0.2, 0.1, 0.05]},
    })
    reference = IntegratorStep("sym6", dt=0.005)
    check = IntegratorStep("sym6", dt=0.01)
    return steps, ld_ladder_dataset(oscillator, oscillator_states, LDSettings(tau=TAU), steps, reference, check)


def test_reference_meets_the_closed_form(oscillator_ladder, exact):
    # The reference the stage measures against (sym6, dt 0.005) against the closed form: measured
    # 3.5e-12 median, 6e-12 worst; asserted to 1e-10, far below the ladder's smallest error (1e-9).
    _, data = oscillator_ladder
    np.testing.assert_allclose(data.reference_ld.values, exact, rtol=1e-10)


def test_stored_errors_are_the_errors_against_the_closed_form(oscillator_ladder, oscillator, oscillator_states, exact):
    # Each stored per-point error is |LD - LD_ref| / LD_ref; against the closed form it may differ
    # only by the reference's own error (< 1e-10 above), so the ladder's errors are real errors.
    steps, data = oscillator_ladder
    for k, step in enumerate(steps):
        settings = step.apply(LDSettings(tau=TAU))
        ld = np.array([compute_ld(oscillator, oscillator_states, d, settings).ld for d in (1, -1)])
        true_error = np.abs(ld - exact) / exact
        np.testing.assert_allclose(data.ld_relative_error.values[k], true_error, rtol=0, atol=1e-10, err_msg=step.label)
        np.testing.assert_allclose(data.ld_error_quantile.values[k], np.quantile(data.ld_relative_error.values[k],
                                                                                 accuracy.QUANTILES))
    assert data.ld_error_quantile.values[:, 0].min() > 1e-9  # every step resolvable above the reference's error
    assert np.all(data.stop_mismatches.values == 0) and np.all(data.failed_trajectories.values == 0)


def test_fixed_step_errors_converge_at_fourth_order(oscillator_ladder):
    # RK4 and the Suzuki composition are 4th order: halving dt divides the error by ~16 (measured
    # 19-23 for rk4, 15 for sym4). Asserted: by more than 8 (order > 3), for the LD and the energy drift.
    steps, data = oscillator_ladder
    for scheme in ("rk4", "sym4"):
        chosen = [k for k, s in enumerate(steps) if s.scheme == scheme]  # dt 0.2, 0.1, 0.05
        for name in ("ld_error_quantile", "energy_error_quantile"):
            median = data[name].values[chosen, 0]
            assert np.all(median[:-1] / median[1:] > 8), (scheme, name, median)


def test_adaptive_error_follows_the_tolerance(oscillator_ladder):
    # DOP853's error control keeps the local error near rtol: 100 times tighter rtol, a median LD
    # error at least 10 times smaller (measured 120 and 105), and the median error within 10 x rtol.
    steps, data = oscillator_ladder
    chosen = [k for k, s in enumerate(steps) if s.scheme == "dop853"]
    median = data.ld_error_quantile.values[chosen, 0]
    assert np.all(median[:-1] / median[1:] > 10), median
    assert np.all(median < 10 * data.rtol.values[chosen])


def test_reference_check_and_throughput_are_recorded(oscillator_ladder):
    # The check (sym6 at dt 0.01 against dt 0.005) resolves the reference to its ~1e-10 floor here;
    # trajectory time is 64 points x 2 directions x tau (no exit or escape in fixed time).
    steps, data = oscillator_ladder
    assert data.reference_check_quantile.values[-1] < 1e-9
    np.testing.assert_allclose(data.trajectory_time.values, 2 * 64 * TAU, rtol=1e-12)
    assert np.all(data.wall_time.values > 0) and np.all(data.throughput.values > 0)
    assert list(data.label.values) == [s.label for s in steps]


class FakeClock:
    """Stands in for the time module of ldpipe.core.accuracy.timing: each run lasts the next of ``durations``
    (wall seconds; CPU twice that, two threads), so the repeat rule is tested without a real clock."""

    def __init__(self, durations):
        self.durations, self.wall, self.cpu, self.calls = list(durations), 0.0, 0.0, 0

    def perf_counter(self):
        self.calls += 1
        if self.calls % 2 == 0:  # the call that ends a run: the run has taken its duration
            self.wall += self.durations.pop(0)
        return self.wall

    def process_time(self):
        return 2.0 * self.wall


@pytest.mark.parametrize("durations, budget, runs, smallest", [
    # (durations are sums of powers of two, so the clock's differences are exact)
    ([1.5, 1.5, 1.5], 1.0, 1, 1.5),   # the first run fills the budget: timed once
    ([0.75, 0.5, 0.5], 1.0, 2, 0.5),  # 0.75 + 0.5 >= 1: two runs
    ([0.25, 0.125, 0.375], 1.0, 3, 0.125),  # short: every one of the repeats
    ([1.5, 1.25, 1.75], math.inf, 3, 1.25),  # no budget: every setting `repeats` times, as before the rule
])
def test_repeat_rule_times_a_setting_until_its_runs_fill_the_budget(monkeypatch, durations, budget, runs, smallest):
    # Expected from the rule's definition: runs stop at `repeats` (3) or once their wall times total
    # the budget; the smallest wall and CPU time of the runs is kept, with the result of the last run.
    from ldpipe.core.accuracy import timing

    clock = FakeClock(durations)
    monkeypatch.setattr(timing, "time", clock)
    results = iter(range(10))
    timed = timing.repeat_timed(lambda: next(results), timing.RepeatRule(3, budget))
    assert (timed.runs, timed.wall_time, timed.cpu_time, timed.result) == (runs, smallest, 2 * smallest, runs - 1)
    with pytest.raises(ValueError, match="repeats"):
        timing.RepeatRule(0, 1.0)
    with pytest.raises(ValueError, match="budget"):
        timing.RepeatRule(3, 0.0)


def test_ld_ladder_stores_its_repeat_rule(oscillator, oscillator_states):
    # A budget every run exceeds (1 ns) times each setting once; without one, `repeats` times. The
    # count, the budget and the rule are stored, and the numbers do not depend on the runs.
    steps = integrator_ladder({"dop853": {"rtol": [1e-4]}, "rk4": {"dt": [0.2]}})
    reference, check = IntegratorStep("sym6", dt=0.05), IntegratorStep("sym6", dt=0.1)
    runs = {}
    for budget in (1e-9, math.inf):
        data = ld_ladder_dataset(oscillator, oscillator_states, LDSettings(tau=TAU), steps, reference, check,
                                 rule=accuracy.RepeatRule(3, budget))
        runs[budget] = data
        assert data.attrs["repeats"] == 3 and data.attrs["repeat_budget"] == budget
    assert runs[1e-9].timed_runs.values.tolist() == [1, 1] and runs[math.inf].timed_runs.values.tolist() == [3, 3]
    assert "fewer once the runs total 1e-09 s" in runs[1e-9].wall_time.attrs["long_name"]
    assert "smallest of 3 runs" in runs[math.inf].wall_time.attrs["long_name"]
    xr.testing.assert_identical(runs[1e-9].ld_relative_error, runs[math.inf].ld_relative_error)


def test_relative_error_quantiles_and_sample_indices():
    # Definitions: the relative error falls back to the absolute difference where the reference is 0;
    # non-finite values are counted and left out of the quantiles (which stay finite for the file).
    np.testing.assert_allclose(relative_error([1.1, 0.5, 2.0], [1.0, 0.0, 2.0]), [0.1, 0.5, 0.0])
    values, bad = finite_quantiles(np.array([3.0, np.inf, 1.0, np.nan, 2.0]), (0.5, 1.0))
    np.testing.assert_allclose(values, [2.0, 3.0])
    assert bad == 2 and finite_quantiles(np.array([np.inf]), (0.5,))[1] == 1
    chosen = sample_indices(1000, 200, seed=4, multiple_of=64)
    assert len(chosen) == 192 and len(np.unique(chosen)) == 192 and np.all(np.diff(chosen) > 0)
    np.testing.assert_array_equal(chosen, sample_indices(1000, 200, seed=4, multiple_of=64))  # seeded
    assert len(sample_indices(50, 200, seed=0, multiple_of=64)) == 50  # fewer points than a block: all


def test_integrator_steps_are_validated_and_labelled():
    assert IntegratorStep.from_spec({"scheme": "dop853", "rtol": 1e-8}).label == "dop853 rtol 1e-08"
    assert IntegratorStep.from_spec({"scheme": "sym6", "dt": 0.05}).label == "sym6 dt 0.05"
    # A ladder entry names exactly the numbers its scheme uses (IntegratorSettings.from_spec).
    with pytest.raises(ValueError, match="dop853"):
        IntegratorStep.from_spec({"scheme": "dop853", "dt": 0.1})
    with pytest.raises(ValueError, match="rk4"):
        IntegratorStep.from_spec({"scheme": "rk4", "rtol": 1e-8, "atol": 1e-8})
    with pytest.raises(ValueError, match="unknown scheme"):
        IntegratorStep.from_spec({"scheme": "euler", "dt": 0.1})
    assert IntegratorStep.from_spec({"scheme": "rk4", "dt": 0.1}).numbers() == {"rtol": 0.0, "atol": 0.0, "dt": 0.1}
    step = IntegratorStep("dop853", rtol=1e-8, atol=1e-8)
    assert step.matches(LDSettings(rtol=1e-8, atol=1e-8)) and not step.matches(LDSettings(rtol=1e-9, atol=1e-9))
    pairs = corrector_ladder([1e-6, 1e-10], [1e-10, 1e-13], 0.01)
    assert [(p.tolerance, p.rtol) for p in pairs] == [(1e-6, 1e-10), (1e-10, 1e-10), (1e-6, 1e-13), (1e-10, 1e-13)]
    assert pairs[0].energy_tolerance == pytest.approx(1e-8)


def test_closure_error_against_the_harmonic_closed_form(oscillator):
    # x(t) = cos(wx t), p = -wx sin(wx t): after the period 2 pi / wx plus d the distance from the start
    # is sqrt((1 - cos(wx d))^2 + wx^2 sin(wx d)^2); for d = 0 it is 0 to the integrator's accuracy.
    period = 2 * math.pi / WX
    state = np.array([1.0, 0.0, 0.0, 0.0])
    for offset in (0.0, 1e-3, 0.1):
        orbit = BrakeOrbit(amplitude=1.0, initial_state=state, half_period=(period + offset) / 2,
                           energy=0.5 * WX**2, residual=0.0, iterations=0)
        expected = math.hypot(1 - math.cos(WX * offset), WX * math.sin(WX * offset))
        assert closure_error(oscillator, orbit, 1e-13) == pytest.approx(expected, abs=1e-11)


def test_orbit_ladder_meets_the_definition_of_a_periodic_orbit(barbanis):
    # A converged setting's orbit closes within its tolerance (re-measured by a separate integration)
    # and lies at the target energy within its energy tolerance; a tolerance below what the integrator
    # resolves (1e-12 at rtol 1e-8: closure ~4e-9) does not converge and is recorded so, with zeros.
    saddle = linearize_saddle(barbanis, np.array([5.5, -math.sqrt(50.0)]))  # closed-form saddle
    energy = saddle.critical_energy + 0.125
    steps = [CorrectorStep(1e-6, 1e-8, 1e-13, 1e-13), CorrectorStep(1e-10, 1e-12, 1e-13, 1e-13),
             CorrectorStep(1e-12, 1e-14, 1e-8, 1e-8)]
    reference = CorrectorStep(1e-12, 1e-14, 1e-13, 1e-13)
    data = orbit_ladder_dataset(barbanis, saddle, 0, energy, steps, reference, continuation=CONTINUATION,
                                check_rtol=1e-13)
    np.testing.assert_array_equal(data.orbit_converged.values, [True, True, False])
    converged = data.orbit_converged.values
    assert np.all(data.orbit_closure_error.values[converged] < data.orbit_tolerance.values[converged])
    assert np.all(data.orbit_energy_error.values[converged] <= data.orbit_energy_tolerance.values[converged])
    assert data.orbit_period_error.values[1] < 1e-10  # the default setting against the tight reference
    assert data.orbit_closure_error.values[2] == 0 and data.orbit_wall_time.values[2] > 0
    assert data.attrs["orbit_reference_closure_error"] < 1e-12


# -- the stage ------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def equilibria_file(tmp_path_factory):
    config = validate_config({"systems": {"barbanis_2dof": {"builtin": "barbanis_2dof"}}})
    folder = tmp_path_factory.mktemp("equilibria")
    return run_equilibria(**parameters_from_config(config, "equilibria", "barbanis_2dof"),
                          output=folder / "barbanis_2dof.nc")


FIG4 = {
    "system": "barbanis_2dof", "saddle_near": [5.5, -7.0],
    "section": {"axes": [{"name": "x", "range": [4.8, 6.0], "points": 40},
                         {"name": "px", "range": [-0.6, 0.6], "points": 40}],
                "fixed": {"y": -7.0}, "solve": "py"},
    "energy": {"excess": 0.125}, "time": "variable", "region": {"x": [4.5, 6.5], "y": [-8.5, -5.5]},
}


def small_config(**accuracy_cost):
    return validate_config({
        "systems": {"barbanis_2dof": {"builtin": "barbanis_2dof"}},
        "ld_maps": {"slice": FIG4},
        "periodic_orbits": {"bottom": {"system": "barbanis_2dof", "saddle_near": [5.5, -7.07],
                                       "energies": {"excess": [0.125]}}},
        "accuracy_cost": accuracy_cost,
    })


@pytest.fixture(scope="module")
def stage_output(tmp_path_factory, equilibria_file):
    config = small_config(
        ld={"maps": ["slice"], "points": 64, "repeats": 1,
            "ladder": {"dop853": {"rtol": [1e-6, 1e-8]}, "sym6": {"dt": [0.2]}}},
        upo={"family": "bottom", "tolerance": [1e-6, 1e-10], "rtol": [1e-13], "repeats": 1},
        nhim={"map": "slice", "grid_points": [24, 40], "refinement_grid": 40, "tolerance": [1e-4, 1e-8]},
    )
    folder = tmp_path_factory.mktemp("accuracy")
    parameters = parameters_from_config(config, "accuracy")
    path = accuracy_stage.run_accuracy_cost(**parameters, equilibria=[equilibria_file], output=folder / "a.nc",
                                            table=folder / "a.md", threads=1)
    return path, folder / "a.md"


def test_stage_file_holds_every_ladder_without_nan(stage_output):
    path, table = stage_output
    data = open_stage_file(path, stage=contracts.ACCURACY_COST)
    for name, variable in data.data_vars.items():
        if variable.dtype.kind == "f":
            assert np.all(np.isfinite(variable.values)), name
    assert data.sizes["map"] == 1 and data.sizes["setting"] == 3 and data.sizes["point"] == 64
    assert data.is_default.values[0].tolist() == [False, True, False]  # the map's own dop853 rtol 1e-8
    assert data.orbit_is_default.values.tolist() == [False, True]  # the family's tolerance 1e-10, rtol 1e-13
    for key in ("machine_cpu_model", "machine_cores", "machine_threads_used", "load_average_before",
                "reference_validation", "repeat_budget", "orbit_repeat_budget", "nhim_repeat_budget"):
        assert key in data.attrs
    # The NHIM point is the orbit's crossing of y = -7 (2 DoF): refinement to 1e-8 lands within 1e-7 of it
    # by both methods (the validation stage's tolerance), and the detection within a few grid cells.
    assert np.all(data.nhim_refinement_converged.values)
    assert np.all(data.nhim_refinement_error.values[:, -1] < 1e-7)
    assert np.all(data.nhim_detection_error.values < 4 * data.nhim_grid_diagonal.values)
    text = table.read_text()
    assert "dop853 rtol 1e-08 *" in text and "## slice" in text and "Periodic orbit" in text
    # repeats 1: every setting of every ladder timed once, whatever the budget
    for name in ("timed_runs", "orbit_timed_runs", "nhim_grid_timed_runs"):
        assert np.all(data[name].values == 1), name
    assert "Wall time: the time of one run" in text


def test_nhim_ladders_take_the_orbit_ladders_reference_orbit_only_where_it_is_theirs(equilibria_file, monkeypatch):
    # Independent method: the NHIM stage's own computation of the reference orbit. Taken from the
    # orbit ladder (same system, saddle and energy here), the crossing is the same bits and the orbit
    # is not computed again; an orbit ladder at another energy is not taken.
    config = small_config(upo={"family": "bottom", "tolerance": [1e-10], "rtol": [1e-13], "repeats": 1},
                          nhim={"map": "slice", "grid_points": [24], "refinement_grid": 24, "tolerance": [1e-4]})
    parameters = parameters_from_config(config, "accuracy")
    found = measurement.equilibria_by_system([equilibria_file])
    own = measurement.nhim_accuracy_dataset(parameters["nhim"], parameters["upo"], found)
    orbits = measurement.orbit_accuracy_dataset(parameters["upo"], found)
    computed = []
    monkeypatch.setattr(measurement, "compute_orbit",
                        lambda *a, **k: computed.append(1) or accuracy.compute_orbit(*a, **k))
    taken = measurement.nhim_accuracy_dataset(parameters["nhim"], parameters["upo"], found, orbits)
    assert computed == [] and np.array_equal(taken.attrs["nhim_crossing"], own.attrs["nhim_crossing"])
    elsewhere = orbits.assign_attrs(orbit_target_energy=orbits.attrs["orbit_target_energy"] + 0.01)
    again = measurement.nhim_accuracy_dataset(parameters["nhim"], parameters["upo"], found, elsewhere)
    assert computed == [1] and np.array_equal(again.attrs["nhim_crossing"], own.attrs["nhim_crossing"])


def test_figure_is_drawn(stage_output, tmp_path, monkeypatch):
    from ldpipe.figures.accuracy import draw_accuracy_cost
    from support.tick_labels import assert_saved_tick_labels_readable, record_saved_figures

    saved = record_saved_figures(monkeypatch)
    written = draw_accuracy_cost(stage_output[0], png=tmp_path / "a.png", pdf=tmp_path / "a.pdf")
    assert [p.suffix for p in written] == [".png", ".pdf"] and all(p.stat().st_size > 1000 for p in written)
    assert_saved_tick_labels_readable(saved)


def test_config_errors_name_the_key():
    with pytest.raises(ConfigError, match="accuracy_cost.ld.maps"):
        small_config(ld={"maps": ["nope"]})
    with pytest.raises(ConfigError, match="accuracy_cost.ld.reference"):
        small_config(ld={"reference": {"scheme": "dop853", "dt": 0.01}})
    with pytest.raises(ConfigError, match="accuracy_cost.upo.family"):
        small_config(upo={"family": "nope"})
    with pytest.raises(ConfigError, match="accuracy_cost.nhim.map"):
        small_config(nhim={"map": "slice"})  # no upo.family for the exact crossing
    with pytest.raises(ConfigError, match="accuracy_cost.ld.ladder.dop853.atol"):
        small_config(ld={"ladder": {"dop853": {"rtol": [1e-6, 1e-8], "atol": [1e-6]}}})
    with pytest.raises(ConfigError, match="accuracy_cost.ld.points"):
        small_config(ld={"points": 0})


def test_dataset_joins_maps_of_different_sample_sizes():
    # A map with fewer allowed points than asked is padded with zeros, flagged by point_used.
    one = xr.Dataset({"v": ("point", [1.0, 2.0])}, coords={"point": [0, 1]})
    padded = measurement._pad_points(one, 4)
    assert padded.v.values.tolist() == [1.0, 2.0, 0.0, 0.0]
    assert padded.point_used.values.tolist() == [True, True, False, False]


def test_error_statistics_leave_out_the_reference_escapes(barbanis):
    # Above the saddle energy some trajectories escape. A fixed-step reference stops them at the
    # start of the step that leaves the escape radius (short by up to one step of a fast
    # integrand), so their errors say nothing about the setting measured: the quantiles must be
    # those of the other trajectories, and the escapes counted (an invariant of the bookkeeping:
    # recomputed here from the stored per-point errors and stop reasons).
    rng = np.random.default_rng(7)
    saddle = barbanis.closed_form_equilibria()[1]
    energy = barbanis.potential(saddle) + 1.0
    states = []
    while len(states) < 128:
        q = rng.uniform([-3.0, -6.0], [6.0, 6.0])
        kinetic = energy - barbanis.potential(q)
        if kinetic > 0.0:
            angle = rng.uniform(0.0, 2.0 * math.pi)
            states.append([*q, *(math.sqrt(2.0 * kinetic) * np.array([math.cos(angle), math.sin(angle)]))])
    steps = integrator_ladder({"dop853": {"rtol": [1e-8]}})
    reference = IntegratorStep("sym6", dt=0.02)
    check = IntegratorStep("sym6", dt=0.01)
    data = ld_ladder_dataset(barbanis, np.array(states), LDSettings(tau=20.0), steps, reference, check)
    escaped = data.reference_stop_reason.values == accuracy.STOP_REASONS.index("escaped")
    assert 0 < escaped.sum() < escaped.size  # the case is there
    assert data.attrs["reference_escapes"] == escaped.sum()
    kept = data.ld_relative_error.values[0][~escaped]
    assert np.allclose(data.ld_error_quantile.values[0], np.quantile(kept, accuracy.QUANTILES), rtol=0, atol=0)
    kept_check = data.reference_check_error.values[~escaped]
    assert np.allclose(data.reference_check_quantile.values, np.quantile(kept_check, accuracy.QUANTILES), rtol=0, atol=0)


def test_ladder_engines_name_each_engine_module_of_the_ladder_once():
    # Expected from config.yaml's ladder and the Taylor order rule (Taylor.order_for: Jorba & Zou's
    # order less two for |v|^p, the maps' p = 1/2): every tolerance of dop853 and every step of a
    # fixed-step scheme share one module, sym4 and sym6 share the compositions' module (their
    # weights are run-time coefficients), the Taylor scheme has one per order.
    import yaml

    from ldpipe.engine.codegen import engine_name
    from ldpipe.engine.schemes.taylor import jorba_zou_order
    from ldpipe.core.maps.grid import ld_map_settings
    from support.workflow import ROOT

    config = yaml.safe_load((ROOT / "config.yaml").read_text())
    validate_config(config)
    engines = ladder_engines(parameters_from_config(config, "accuracy")["ld"])
    orders = [jorba_zou_order(tolerance) - 2 for tolerance in (1e-6, 1e-8, 1e-10, 1e-12)]
    assert orders == [6, 9, 11, 13]
    variants = ["dop853", "rk4", "composition", *(f"taylor{order}" for order in orders)]
    assert sorted(engines) == sorted(f"engine_barbanis_2dof_{variant}_64" for variant in variants)
    for name, entry in engines.items():  # each job's setting compiles the module it is named after
        settings = accuracy.IntegratorStep.from_spec(entry["setting"]).apply(ld_map_settings(entry["map"]))
        assert engine_name(entry["map"]["system_name"], settings.scheme, settings.lanes, settings.order) == name
