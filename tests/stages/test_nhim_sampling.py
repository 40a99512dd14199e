"""NHIM sampling over a slice family: the linear 3 DoF saddle (closed form), the Barbanis-Contopoulos
Lyapunov orbit (independent: the periodic-orbit corrector), continuation against a whole-window
detection (independent method), and the stage file.

The linear saddle H = |p|^2/2 - lam^2 x^2/2 + w1^2 y^2/2 + w2^2 z^2/2 has its NHIM at x = p_x = 0
(the two centre oscillators) whatever the energy. A slice fixing (y, z, p_y), solving p_z, meets it
where the centre energy w1^2 y^2/2 + w2^2 z^2/2 + p_y^2/2 is below E, at (x, p_x) = (0, 0) with
p_z = sign sqrt(2E - w1^2 y^2 - w2^2 z^2 - p_y^2); beyond that ellipsoid the slice has no crossing.
On the slice the stable and unstable curves are p_x = -lam x and p_x = lam x, at the angle
arccos((lam^2 - 1) / (lam^2 + 1)) between the lines.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from ldpipe.config import validate_config
from ldpipe.io.datafile import open_stage_file
from ldpipe.engine import LDSettings
from ldpipe.errors import ConfigError
from ldpipe.core import nhim
from ldpipe.core.nhim.batched import run_tasks
from ldpipe.core.nhim.refinement import refine_by_fates_task
from ldpipe.core.nhim.sampling import SamplingSettings, predict, sample_family, sample_slice, slice_problem, walk_order
from ldpipe.core.orbits.periodic import CorrectorSettings, LyapunovFamily, linearize_saddle, sample_orbit
from ldpipe.core.sections import Section
from ldpipe.stages.equilibria import run_equilibria
from ldpipe.stages.nhim_sampling import run_nhim_sampling
from ldpipe.config.parameters import parameters_from_config
from ldpipe.stages.upo import run_upo
from ldpipe.figures.nhim_sample import draw_nhim_sample
from ldpipe.systems import make_system
from support.barbanis import BC_ENERGY, BC_SADDLE, fig5_slice_problem
from support.tick_labels import assert_readable_tick_labels

LAM, W1, W2 = 1.5, 1.0, 1.3
ENERGY = 0.5
#: The configured refinement tolerance (1e-8); the linear saddle's escapes are fast, so a short max_time.
REFINEMENT = nhim.RefinementSettings(tolerance=1e-8, bisection_precision=5e-10, max_time=40.0)
#: Windows in the linear saddle's units (its NHIM point moves by nothing between slices).
SAMPLING = SamplingSettings(window_points=11, window_half_width=(0.05, 0.05), seed_points=21)
#: The configured refinement (nhim.refinement defaults) for the Barbanis-Contopoulos system.
REFINEMENT_BC = nhim.RefinementSettings()


@pytest.fixture(scope="module")
def linear_base():
    system = make_system("linear_saddle_3dof", {
        "formula": "-lam**2*x**2/2 + w1**2*y**2/2 + w2**2*z**2/2", "coordinates": ["x", "y", "z"],
        "parameters": {"lam": LAM, "w1": W1, "w2": W2},
    })
    section = Section(axes=("x", "px"), ranges=((-0.5, 0.5), (-0.5, 0.5)), shape=(41, 41),
                      fixed={"y": 0.0, "z": 0.0, "py": 0.0}, solve="pz", sign=1)
    settings = LDSettings(rtol=1e-10, atol=1e-10, tau=20.0, region_lower=(-1.0, -2.0, -2.0),
                          region_upper=(1.0, 2.0, 2.0))
    return nhim.make_slice_problem("linear", system, section, ENERGY, 0.0, np.zeros(3), settings)


@pytest.fixture(scope="module")
def bc_base(barbanis_contopoulos):
    return fig5_slice_problem(barbanis_contopoulos)


def test_walk_order_visits_every_node_once_after_a_neighbour():
    # Invariant: a permutation of the grid, each node after the first one step from an earlier node.
    shape = (4, 3, 5)
    order = walk_order(shape)
    assert sorted(order) == sorted(np.ndindex(*shape))
    for k, node in enumerate(order[1:], start=1):
        assert any(sum(abs(a - b) for a, b in zip(node, earlier)) == 1 for earlier in order[:k])


def test_prediction_is_exact_for_points_linear_in_the_grid_index():
    # Closed form: linear extrapolation reproduces a linear function of the index exactly.
    def point(index):
        return np.array([0.3 + 0.1 * index[0] - 0.05 * index[1], -0.2 + 0.02 * index[2]])

    known = {(1, 1, 1): point((1, 1, 1)), (1, 1, 2): point((1, 1, 2)), (2, 1, 1): point((2, 1, 1))}
    np.testing.assert_allclose(predict((1, 1, 0), known), point((1, 1, 0)), atol=1e-15)
    assert predict((3, 3, 3), known) is None


def test_linear_saddle_family_matches_the_closed_form(linear_base):
    grid = {"y": np.array([-0.6, 0.0, 0.6, 1.2]), "z": np.array([0.0, 0.5]), "py": np.array([0.0, 0.3])}
    samples = sample_family(linear_base, grid, (1, -1), SAMPLING, REFINEMENT)
    assert len(samples) == 2 * 4 * 2 * 2
    system = linear_base.system
    for sample in samples:
        y, z, py = sample.fixed["y"], sample.fixed["z"], sample.fixed["py"]
        centre = W1**2 * y**2 + W2**2 * z**2 + py**2  # twice the centre energy at p_z = 0
        if centre >= 2 * ENERGY:
            # Outside the NHIM's projection: recorded as degenerate, never as a point.
            assert sample.status == "no_crossing" and sample.point is None and sample.state is None
            assert sample.reason
            continue
        assert sample.status == "ok", sample.reason
        # Closed form: the NHIM point is (0, 0) on every slice that meets it.
        assert np.linalg.norm(sample.point) <= sample.uncertainty + 1e-12
        assert sample.uncertainty <= REFINEMENT.tolerance
        # Identity: the state is on the energy surface, and on its slice (fixed values exactly).
        assert system.energy(sample.state) == pytest.approx(ENERGY, abs=1e-13)
        assert (sample.state[1], sample.state[2], sample.state[4]) == (y, z, py)
        assert sample.state[5] == pytest.approx(sample.sign * math.sqrt(2 * ENERGY - centre), abs=1e-7)
        # Closed form: the curves p_x = -+lam x cross at arccos((lam^2 - 1) / (lam^2 + 1)). The refinement
        # measures the angle between its last secant chords, whose ends are bisected to 5e-10 on chords
        # of length ~1e-4 (the secant spacing shrinks to sqrt(tolerance)): about 1e-5 rad.
        assert sample.angle == pytest.approx(math.acos((LAM**2 - 1) / (LAM**2 + 1)), abs=1e-4)
        # Evidence: the point stays in the region both ways far longer than its neighbours.
        assert min(sample.residence_forward, sample.residence_backward) > 2 * sample.neighbour_residence_max


def test_degenerate_slices_are_recorded_with_their_reason(linear_base):
    # y = 2: w1^2 y^2 = 4 > 2E + lam^2 x^2 on the whole window |x| <= 0.5: no allowed point there.
    forbidden = sample_slice(linear_base, {"y": 2.0, "z": 0.0, "py": 0.0}, 1, None, SAMPLING, REFINEMENT)
    assert forbidden.status == "forbidden" and forbidden.point is None
    # The closed-form angle (1.18 rad) is below a min_angle of 1.3: a tangent slice, not a point.
    strict = SamplingSettings(window_half_width=(0.05, 0.05), seed_points=21, min_angle=1.3)
    tangent = sample_slice(linear_base, {"y": 0.0, "z": 0.0, "py": 0.0}, 1, None, strict, REFINEMENT)
    assert tangent.status == "tangent" and tangent.point is None and "min_angle" in tangent.reason
    # p_z = sqrt(2E - w1^2 y^2) = 0.02 sqrt(2E) at the point: below min_momentum 0.05 sqrt(2E).
    y = math.sqrt(2 * ENERGY * (1 - 0.02**2)) / W1
    thin = SamplingSettings(window_half_width=(0.05, 0.05), seed_points=21, min_momentum=0.05)
    vanishing = sample_slice(linear_base, {"y": y, "z": 0.0, "py": 0.0}, 1, None, thin, REFINEMENT)
    assert vanishing.status == "momentum_vanishes" and vanishing.point is None and "min_momentum" in vanishing.reason
    # Beyond the NHIM's reach (w1^2 y^2 > 2E for y = 1.2, 1.5): y = 1.2 is searched around the point
    # of y = 0 and fails; y = 1.5, whose only neighbour nearer the middle failed, is not searched.
    family = sample_family(linear_base, {"y": [-0.3, 0.0, 1.2, 1.5], "z": [0.0], "py": [0.0]}, (1,), SAMPLING,
                           REFINEMENT)
    assert [s.status for s in family] == ["ok", "ok", "no_crossing", "no_crossing"]
    assert family[2].predicted and "window 0" in family[2].reason and "whole window" not in family[2].reason
    assert family[3].reason == "no neighbour nearer the middle gave a point" and family[3].point is None


@pytest.fixture(scope="module")
def mode0_orbit(barbanis_contopoulos):
    # Independent of the sampling: the Lyapunov orbit of centre mode 0 at E = 24 from the
    # periodic-orbit corrector (closure 1e-10), sampled along one period.
    settings = CorrectorSettings(tolerance=1e-10, rtol=1e-13, atol=1e-13)
    family = LyapunovFamily(barbanis_contopoulos, linearize_saddle(barbanis_contopoulos, BC_SADDLE), 0, settings)
    family.continue_to(BC_ENERGY, initial_amplitude=1e-4, max_step=0.1, max_members=500)
    orbit = family.at_energy(BC_ENERGY, energy_tolerance=1e-12)
    _, states = sample_orbit(barbanis_contopoulos, orbit, 40, settings)
    return states


def test_slices_through_lyapunov_orbit_points_return_those_points(bc_base, mode0_orbit):
    # Both Lyapunov orbits lie on the NHIM, so a slice through an orbit state (its y, z, p_y, the
    # sign of its p_z) meets the NHIM at the orbit's (x, p_x). Two states with |p_z| well above 0.
    pz = np.abs(mode0_orbit[:, 5])
    chosen = np.argsort(pz)[-1], np.argsort(pz)[-8]
    for k in chosen:
        state = mode0_orbit[k]
        grid = {"y": [state[1]], "z": [state[2]], "py": [state[4]]}
        (sample,) = sample_family(bc_base, grid, (int(np.sign(state[5])),), SamplingSettings(), REFINEMENT_BC)
        assert sample.status == "ok", sample.reason
        # The orbit is closed to 1e-10 and sampled at rtol 1e-13; the point is refined to 1e-8.
        assert np.linalg.norm(sample.point - state[[0, 3]]) <= sample.uncertainty + 1e-9
        np.testing.assert_allclose(sample.state, state, atol=sample.uncertainty + 1e-9)


def test_continuation_agrees_with_a_whole_window_detection(bc_base):
    # Independent method: the second slice's point by continuation (a small window around the
    # first slice's point) and by detection on the base map's whole window, no prediction.
    saddle = BC_SADDLE
    grid = {"y": [saddle[1], saddle[1] + 0.03], "z": [saddle[2]], "py": [0.0]}
    first, second = sample_family(bc_base, grid, (1,), SamplingSettings(), REFINEMENT_BC)
    assert first.status == second.status == "ok"
    assert first.whole_window and not second.whole_window and second.predicted
    alone = sample_slice(bc_base, second.fixed, 1, None, SamplingSettings(), REFINEMENT_BC)
    assert alone.status == "ok" and alone.whole_window
    assert np.linalg.norm(second.point - alone.point) <= second.uncertainty + alone.uncertainty
    # Identity: H = E on the state.
    assert bc_base.system.energy(second.state) == pytest.approx(BC_ENERGY, abs=1e-12)


@pytest.fixture(scope="module")
def small_study(tmp_path_factory):
    tmp_path = tmp_path_factory.mktemp("sampling")
    config = validate_config({
        "systems": {"barbanis_contopoulos_3dof": {"builtin": "barbanis_contopoulos_3dof"}},
        "ld_maps": {"fig5_xpx": {
            "system": "barbanis_contopoulos_3dof", "saddle_near": [10.29, 5.29, 2.65],
            "section": {"axes": [{"name": "x", "range": [9.0, 12.0], "points": 100},
                                 {"name": "px", "range": [-0.6, 0.6], "points": 100}],
                        "fixed": {"y": "saddle", "z": "saddle", "py": 0.0}, "solve": "pz"},
            "energy": {"total": 24.0}, "tau": 50, "p": 0.5, "time": "variable",
            "region": {"x": [9.0, 12.0], "y": [2.5, 7.5], "z": [1.0, 4.0]}}},
        # y = 5.3 (by the saddle) meets the NHIM; y = 6.3 is beyond its reach (no crossing).
        "nhim_sampling": {"small": {"base_map": "fig5_xpx", "fixed": {
            "y": {"range": [5.3, 6.3], "points": 2}, "z": {"range": [2.65, 2.65], "points": 1},
            "py": {"range": [0.0, 0.0], "points": 1}}}},
    })
    equilibria = run_equilibria(**parameters_from_config(config, "equilibria", "barbanis_contopoulos_3dof"),
                                output=tmp_path / "eq.nc")
    parameters = parameters_from_config(config, "nhim_sampling", "small")
    path = run_nhim_sampling(**parameters, equilibria=equilibria, output=tmp_path / "small.nc")
    return config, equilibria, path


def test_batched_fates_agree_with_exit_fates_both_ways(bc_base):
    # Independent method: the batched fates run backward trajectories forward from (q, -p) (time
    # reversal), ldpipe.core.nhim.exit_fates runs the engine backward; same sides, same exit times.
    problem = slice_problem(bc_base, {"y": 5.3, "z": 2.65, "py": 0.0}, 1, np.array([10.29, -0.08]),
                            np.array([0.1, 0.1]), 11)
    points = np.random.default_rng(3).uniform([10.19, -0.18], [10.39, 0.02], size=(30, 2))

    def task():
        both = yield problem, "fates", np.vstack([points, points]), np.repeat([1, -1], len(points))
        return both

    (both,) = run_tasks([task()], REFINEMENT_BC)
    for k, direction in enumerate((1, -1)):
        fate, exit_time = nhim.exit_fates(problem, points, direction, REFINEMENT_BC)
        part = slice(k * len(points), (k + 1) * len(points))
        np.testing.assert_array_equal(both["fate"][part], fate)
        np.testing.assert_allclose(both["exit_time"][part], exit_time, rtol=1e-9)


def test_a_point_refined_in_a_batch_is_the_point_refined_alone(bc_base):
    # Invariant of the task runner: a slice's refinement asks only for its own trajectories, and
    # each trajectory is integrated on its own, so batching it with another slice's refinement
    # changes nothing, to the bit (refine_by_fates is the same task run alone).
    first = slice_problem(bc_base, {"y": 5.35, "z": 2.8, "py": 0.1}, -1, np.array([10.25, 0.05]),
                          np.array([0.05, 0.05]), 11)
    second = slice_problem(bc_base, {"y": 5.3, "z": 2.65, "py": 0.0}, 1, np.array([10.29, -0.08]),
                           np.array([0.1, 0.1]), 11)
    guesses = (np.array([10.25, 0.05]), np.array([10.29, -0.08]))
    together = run_tasks([refine_by_fates_task(problem, guess, REFINEMENT_BC)
                          for problem, guess in zip((first, second), guesses)], REFINEMENT_BC)
    for problem, guess, batched in zip((first, second), guesses, together):
        alone = nhim.refine_by_fates(problem, guess, REFINEMENT_BC)
        np.testing.assert_array_equal(batched.point, alone.point)
        assert batched.uncertainty == alone.uncertainty <= REFINEMENT_BC.tolerance


def test_stage_writes_points_only_for_non_degenerate_slices(small_study):
    config, _, path = small_study
    data = open_stage_file(path, stage="nhim_sampling")
    meanings = data.status.attrs["flag_meanings"].split()
    status = [meanings[int(v)] for v in data.status.values]
    assert status[0] == "ok" and status[1] != "ok"
    assert data.sizes["point"] == 1 and int(data.slice_of_point.values[0]) == 0
    assert data.reason.values[1] != "" and data.point_of_slice.values.tolist() == [0, -1]
    # Identity: on the energy surface and on the slice (its fixed values exactly).
    assert abs(float(data.energy_residual.values[0])) < 1e-12
    state = data.state.values[0]
    np.testing.assert_array_equal(state[[1, 2, 4]], data.fixed_values.values[0])
    assert float(data.uncertainty.values[0]) <= config["nhim"]["refinement"]["tolerance"]
    # The tolerances are recorded.
    assert data.attrs["refinement_tolerance"] == config["nhim"]["refinement"]["tolerance"]
    assert data.attrs["sampling_window_points"] == 11 and data.attrs["count_ok"] == 1


def test_figure_draws_the_points_the_orbit_and_the_coverage(small_study, tmp_path):
    config, equilibria, path = small_study
    config = validate_config({**config, "periodic_orbits": {"mode0": {
        "system": "barbanis_contopoulos_3dof", "saddle_near": [10.29, 5.29, 2.65], "center_mode": 0,
        "energies": {"total": [24.0]}}}})
    upo = run_upo(**parameters_from_config(config, "upo", "mode0"), equilibria=equilibria, output=tmp_path / "mode0.nc")
    figure = draw_nhim_sample({"projections": [["x", "y", "z"], ["y", "z", "pz"]]}, sampling=path, upo=[upo])
    top = [ax for ax in figure.axes if ax.name == "3d"]
    assert len(top) == 2 and all(len(ax.lines) == 1 for ax in top)  # the orbit in each projection
    (coverage,) = [ax for ax in figure.axes if ax.name != "3d"]
    labels = [text.get_text() for text in coverage.get_legend().get_texts()]
    assert "ok (1)" in labels and any(label.endswith("(1)") and label != "ok (1)" for label in labels)
    assert_readable_tick_labels(figure, tmp_path)


def test_config_errors_name_the_key():
    base = {
        "systems": {"barbanis_contopoulos_3dof": {"builtin": "barbanis_contopoulos_3dof"}},
        "ld_maps": {"m": {
            "system": "barbanis_contopoulos_3dof",
            "section": {"axes": [{"name": "x", "range": [9.0, 12.0], "points": 10},
                                 {"name": "px", "range": [-0.6, 0.6], "points": 10}],
                        "fixed": {"y": 5.3, "z": 2.65, "py": 0.0}, "solve": "pz"},
            "energy": {"total": 24.0}, "time": "variable",
            "region": {"x": [9.0, 12.0], "y": [2.5, 7.5], "z": [1.0, 4.0]}}},
    }
    fixed = {"y": {"range": [5.2, 5.4], "points": 3}, "z": {"range": [2.6, 2.7], "points": 2},
             "py": {"range": [0.0, 0.0], "points": 1}}
    with pytest.raises(ConfigError, match=r"nhim_sampling\.s\.base_map"):
        validate_config({**base, "nhim_sampling": {"s": {"base_map": "nope", "fixed": fixed}}})
    with pytest.raises(ConfigError, match=r"nhim_sampling\.s\.fixed"):
        validate_config({**base, "nhim_sampling": {"s": {"base_map": "m", "fixed": {"y": fixed["y"]}}}})
    with pytest.raises(ConfigError, match=r"nhim_sampling\.s\.fixed\.y\.range"):
        validate_config({**base, "nhim_sampling": {"s": {"base_map": "m", "fixed": {
            **fixed, "y": {"range": [5.4, 5.2], "points": 3}}}}})
