"""NHIM detection and refinement: the linear saddle (closed form) and the Barbanis slices (the UPO).

The linear saddle H = (p_x^2 + p_y^2)/2 - lam^2 x^2/2 + w^2 y^2/2 has its NHIM at x = p_x = 0 (the
periodic orbit of the y oscillator), stable manifold p_x = -lam x and unstable manifold
p_x = +lam x, whatever the energy: on the section y = k, p_y > 0 with axes (x, p_x) the NHIM point
is (0, 0) and the two manifolds are the lines p_x = -+lam x. A trajectory's x(t) =
A e^{lam t} + B e^{-lam t} with A = (x + p_x/lam)/2, B = (x - p_x/lam)/2, so it leaves forward on
the side of sign(A) and backward on the side of sign(B).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from ldpipe.core import nhim
from ldpipe.io import contracts
from ldpipe.config import validate_config
from ldpipe.io.datafile import open_stage_file
from ldpipe.engine import LDSettings, compute_ld
from ldpipe.errors import ConfigError
from ldpipe.core.sections import Section, section_states
from ldpipe.stages import nhim as nhim_stage
from ldpipe.stages import nhim_validation
from ldpipe.stages.equilibria import run_equilibria
from ldpipe.core.maps.assembly import compute_ld_map
from ldpipe.stages.ld import write_ld_map
from ldpipe.config.parameters import parameters_from_config
from ldpipe.stages.plan import nhim_study_inputs
from ldpipe.stages.upo import run_upo
from ldpipe.systems import make_system

LAM, OMEGA = 1.5, 1.0
ENERGY = 0.5  # above E_c = 0: the y oscillator's amplitude is sqrt(2 E) / w = 1
#: Refinement settings for the tests: the configured tolerance (1e-8), and a shorter max_time
#: (the linear saddle's escapes are fast).
SETTINGS = nhim.RefinementSettings(tolerance=1e-8, bisection_precision=5e-10, max_time=40.0)


@pytest.fixture(scope="module")
def linear_saddle():
    return make_system("linear_saddle", {
        "formula": "-lam**2*x**2/2 + w**2*y**2/2", "coordinates": ["x", "y"],
        "parameters": {"lam": LAM, "w": OMEGA},
    })


@pytest.fixture(scope="module")
def linear_problem(linear_saddle):
    section = Section(axes=("x", "px"), ranges=((-0.5, 0.5), (-0.5, 0.5)), shape=(41, 41), fixed={"y": 0.3},
                      solve="py", sign=1)
    ld_settings = LDSettings(rtol=1e-10, atol=1e-10, tau=20.0, region_lower=(-1.0, -2.0), region_upper=(1.0, 2.0))
    return nhim.make_slice_problem("linear", linear_saddle, section, ENERGY, 0.0, np.zeros(2), ld_settings)


def test_fates_follow_the_closed_form(linear_problem):
    # Closed form (module docstring): forward side sign(x + p_x/lam), backward side sign(x - p_x/lam),
    # times the sign of the reaction vector (an eigenvector, whose sign is arbitrary).
    rng = np.random.default_rng(1)
    points = rng.uniform(-0.4, 0.4, size=(40, 2))
    orientation = np.sign(linear_problem.reaction[0])
    forward, _ = nhim.exit_fates(linear_problem, points, +1, SETTINGS)
    backward, _ = nhim.exit_fates(linear_problem, points, -1, SETTINGS)
    np.testing.assert_array_equal(forward, orientation * np.sign(points[:, 0] + points[:, 1] / LAM))
    np.testing.assert_array_equal(backward, orientation * np.sign(points[:, 0] - points[:, 1] / LAM))


def test_exit_times_follow_the_closed_form(linear_problem):
    # Closed form: x(t) = A e^{lam t} + B e^{-lam t} leaves the region |x| <= 1 (the y oscillator's
    # amplitude, sqrt(2 E_y) / w < 1.2 here, keeps |y| <= 2) when x = sign(A) forward, x(-t) = sign(B)
    # backward; that root of the closed form, found by brentq, is the exit time the engine
    # locates on its step's interpolant (no sampling: to about the integration tolerance).
    from scipy.optimize import brentq

    rng = np.random.default_rng(2)
    points = rng.uniform(-0.4, 0.4, size=(20, 2))
    for direction in (+1, -1):
        _, times = nhim.exit_fates(linear_problem, points, direction, SETTINGS)
        for (x, px), t_engine in zip(points, times):
            a, b = (x + px / LAM) / 2, (x - px / LAM) / 2
            grow, decay = (a, b) if direction > 0 else (b, a)
            exact = brentq(lambda t: grow * np.exp(LAM * t) + decay * np.exp(-LAM * t) - np.sign(grow), 0.0, 40.0,
                           xtol=1e-15, rtol=1e-15)
            assert abs(t_engine - exact) < 1e-9


def test_bisection_lands_on_the_stable_line(linear_problem):
    # Closed form: the stable manifold crosses the segment p_x = c, x in [-0.4, 0.4] at x = -c / lam.
    c = np.array([0.1, -0.2])
    starts = np.column_stack([np.full(2, -0.4), c])
    ends = np.column_stack([np.full(2, 0.4), c])
    points, widths = nhim.bisect_fate_switch(linear_problem, starts, ends, +1, SETTINGS)
    assert np.all(widths <= SETTINGS.bisection_precision)
    np.testing.assert_allclose(points[:, 0], -c / LAM, atol=SETTINGS.bisection_precision)
    with pytest.raises(nhim.RefinementFailed, match="do not bracket"):
        nhim.bisect_fate_switch(linear_problem, starts[:1] + [0.5, 0], ends[:1], +1, SETTINGS)


def test_fate_refinement_finds_the_linear_nhim(linear_problem):
    # Closed form: the NHIM point is (0, 0); the manifolds' angle is that between (1, -lam) and (1, lam).
    refined = nhim.refine_by_fates(linear_problem, np.array([0.03, -0.04]), SETTINGS)
    assert np.linalg.norm(refined.point) <= SETTINGS.tolerance
    assert refined.uncertainty <= SETTINGS.tolerance
    angle = np.arccos(abs(1 - LAM**2) / (1 + LAM**2))
    assert refined.angle == pytest.approx(angle, abs=1e-6)
    assert refined.cost.trajectories > 0 and refined.cost.time_units > 0


def test_detection_and_zoom_on_the_linear_ld_map(linear_problem):
    # The LD map of the linear saddle on a 41 x 41 grid: the detected cell is within one cell of the
    # closed-form NHIM point (0, 0), and zoomed re-gridding converges to it.
    problem = linear_problem
    states, allowed, _ = section_states(problem.system, problem.section, problem.energy)
    fields = []
    for direction in (1, -1):
        values = np.zeros(allowed.size)
        values[allowed.ravel()] = compute_ld(problem.system, states, direction, problem.ld_settings).ld
        fields.append(values.reshape(allowed.shape))
    axes = problem.section.axis_values()
    detected = nhim.detect_nhim_cell(*fields, allowed, axes)
    assert np.all(np.abs(detected.point) <= problem.spacing + 1e-12)
    settings = dataclasses.replace(SETTINGS, tolerance=1e-6, bisection_precision=1e-8)
    zoom = nhim.refine_by_ld_zoom(problem, detected.point, settings)
    assert np.linalg.norm(zoom.point) <= 1e-6


def test_criterion_ignores_a_spike_on_one_ridge():
    # A constructed map (no dynamics): log-singular ridges along the lines b = -a (forward) and b = a
    # (backward), crossing at (0, 0), plus one grid point of the forward ridge far from the crossing
    # that is much closer to its ridge than the others (a spike). The plain argmax of F + B takes the
    # spike; the detection criterion takes the crossing, as built.
    axis = np.linspace(-1, 1, 101)
    a, b = np.meshgrid(axis, axis, indexing="ij")
    forward = -np.log(np.abs(a + b) + 1e-2)
    backward = -np.log(np.abs(a - b) + 1e-2)
    forward[80, 20] = -np.log(1e-9)  # on b = -a, far from the crossing
    allowed = np.ones_like(a, dtype=bool)
    naive = nhim.detect_global_argmax(forward, backward, allowed, (axis, axis))
    detected = nhim.detect_nhim_cell(forward, backward, allowed, (axis, axis))
    assert naive.index == (80, 20)
    assert detected.index == (50, 50)
    with pytest.raises(ValueError, match="no allowed point"):
        nhim.nhim_score(forward, backward, np.zeros_like(allowed))


# ----------------------------------------------------------------------------------------------
# The Barbanis 2 DoF slices of the paper's Fig. 4 (on small grids) against the periodic orbit


def barbanis_config(points: int = 48, **nhim_section):
    fig4 = {
        "system": "barbanis_2dof", "saddle_near": [5.5, -7.0],
        "section": {"axes": [{"name": "x", "range": [4.8, 6.0], "points": points},
                             {"name": "px", "range": [-0.6, 0.6], "points": points}],
                    "fixed": {"y": -7.0}, "solve": "py"},
        "energy": {"excess": 0.125}, "tau": 50, "time": "variable",
        "region": {"x": [4.5, 6.5], "y": [-8.5, -5.5]},
    }
    maps = {"k-7.0": fig4, "k-7.2": {**fig4, "section": {**fig4["section"], "fixed": {"y": -7.2}}},
            "fixed_time": {**fig4, "time": "fixed"}}
    return validate_config({
        "systems": {"barbanis_2dof": {"builtin": "barbanis_2dof"}},
        "ld_maps": maps,
        "periodic_orbits": {"bottom": {"system": "barbanis_2dof", "saddle_near": [5.5, -7.07],
                                       "energies": {"excess": [0.125]}, "samples": 50}},
        "nhim": nhim_section,
    })


@pytest.fixture(scope="module")
def barbanis_files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("nhim")
    config = barbanis_config()
    equilibria = run_equilibria(**parameters_from_config(config, "equilibria", "barbanis_2dof"),
                                output=folder / "equilibria.nc")
    upo = run_upo(**parameters_from_config(config, "upo", "bottom"), equilibria=equilibria, output=folder / "bottom.nc")
    equilibria_data = open_stage_file(equilibria, stage="equilibria")
    maps = {}
    for name in ("k-7.0", "k-7.2", "fixed_time"):
        parameters = parameters_from_config(config, "ld", name)
        if name == "fixed_time":
            parameters["section"]["axes"][0]["points"] = parameters["section"]["axes"][1]["points"] = 6
            parameters["tau"] = 1.0
        dataset = compute_ld_map(parameters, equilibria_data, show_progress=False)
        maps[name] = write_ld_map(dataset, parameters, folder / f"{name}.nc", tile_file=False)
    return {"folder": folder, "equilibria": equilibria, "upo": upo, "maps": maps, "config": config}


@pytest.fixture(scope="module")
def study_file(barbanis_files):
    config = barbanis_files["config"]
    return nhim_stage.run_nhim_study(
        study="fig4_small", refinement={**config["nhim"]["refinement"], "zoom": False},
        maps=[barbanis_files["maps"]["k-7.0"], barbanis_files["maps"]["k-7.2"]],
        references=["bottom"], reference_files=[barbanis_files["upo"]],
        output=barbanis_files["folder"] / "fig4_small.nc",
    )


def test_refined_points_agree_with_the_periodic_orbit(study_file):
    # Independent method: the UPO from differential correction, its crossing of y = k with p_y > 0
    # (the engine's exit from y <= k, located on the step's interpolant). The fate refinement (from a 48 x 48 grid, spacing
    # 0.026) must meet it to the configured tolerance 1e-8 (1e-7 validation tolerance, with margin).
    data = open_stage_file(study_file, stage=contracts.NHIM)
    assert list(data.slice.values) == ["k-7.0", "k-7.2"]
    assert list(data.reference_kind.values) == ["orbit_crossing"] * 2
    assert np.all(data.distance_refined.values < 1e-8)
    assert np.all(data.refined_uncertainty.values <= 1e-8)
    # The detection is within a few grid cells; the refined point stays far longer in the saddle
    # region than its grid neighbours (log(1/distance)/lambda: ~20 against ~5).
    spacing = np.hypot(*data.grid_spacing.values[0])
    assert np.all(data.distance_detected.values < 3 * spacing)
    assert np.all(np.minimum(data.residence_forward, data.residence_backward) > 2 * data.neighbour_residence_max)
    assert np.all(data.refined_trajectories.values > 0) and np.all(data.refined_wall_time.values > 0)
    # The refined point's LD values are near the top of the map's (it is on both ridges).
    assert np.all(data.refined_ld_forward.values > data.detected_grid_ld_forward.values * 0.9)
    assert data.attrs["refinement_tolerance"] == 1e-8


def test_validation_writes_tables_and_fails_loudly(study_file, tmp_path):
    csv_path, markdown = tmp_path / "v.csv", tmp_path / "v.md"
    rows = nhim_validation.run_nhim_validation(studies=[study_file], csv_output=csv_path, markdown_output=markdown,
                                          tolerance=1e-7, residence_ratio=2.0)
    assert [row["status"] for row in rows] == ["ok", "ok"]
    assert csv_path.read_text().count("\n") == 3 and "| fig4_small | k-7.2 |" in markdown.read_text()
    # A tolerance below the achieved distance must fail, naming the slice and the distance.
    with pytest.raises(nhim_validation.NHIMValidationError, match=r"fig4_small/k-7.0: distance .* > tolerance 1e-13"):
        nhim_validation.run_nhim_validation(studies=[study_file], csv_output=csv_path, markdown_output=markdown,
                                       tolerance=1e-13, residence_ratio=2.0)
    assert "FAIL" in csv_path.read_text()  # the tables are written before the failure


def test_fixed_time_maps_are_refused(barbanis_files, tmp_path):
    with pytest.raises(ConfigError, match="variable-time map"):
        nhim_stage.run_nhim_study(study="s", refinement=barbanis_files["config"]["nhim"]["refinement"],
                                  maps=[barbanis_files["maps"]["fixed_time"]], output=tmp_path / "s.nc")


def test_config_errors_name_the_key():
    with pytest.raises(ConfigError, match=r"nhim.studies.s.maps.*no LD map 'nope'"):
        barbanis_config(studies={"s": {"maps": ["nope"]}})
    with pytest.raises(ConfigError, match=r"nhim.studies.s.maps.*fixed time"):
        barbanis_config(studies={"s": {"maps": ["fixed_time"]}})
    with pytest.raises(ConfigError, match=r"nhim.studies.s.reference.*no family 'top'"):
        barbanis_config(studies={"s": {"maps": ["k-7.0"], "reference": ["top"]}})
    with pytest.raises(ConfigError, match=r"nhim.studies.s.derived.fixed.x.*not a fixed coordinate"):
        barbanis_config(studies={"s": {"derived": {"base_map": "k-7.0", "fixed": {"x": [5.0]},
                                                   "excess_energies": [0.125]}}})
    with pytest.raises(ConfigError, match=r"nhim.refinement.bisection_precision"):
        barbanis_config(refinement={"tolerance": 1e-8, "bisection_precision": 1e-8})


def test_derived_slices_take_the_cap_and_names():
    config = barbanis_config(studies={"s": {"derived": {
        "base_map": "k-7.0", "fixed": {"y": [-7.05, -7.15]}, "excess_energies": [0.125, 0.375], "points": 300,
        "ranges": {"px": [-1.2, 1.2]}}, "reference": ["bottom"]}})
    config["max_grid_points"] = 48
    parameters = parameters_from_config(config, "nhim", "s")
    names = [entry["map_name"] for entry in parameters["derived"]]
    assert names == ["y-7.05_dE0.125", "y-7.05_dE0.375", "y-7.15_dE0.125", "y-7.15_dE0.375"]
    entry = parameters["derived"][1]
    assert entry["section"]["fixed"] == {"y": -7.05} and entry["energy"] == {"excess": 0.375}
    assert [axis["points"] for axis in entry["section"]["axes"]] == [48, 48]
    assert entry["section"]["axes"][1]["range"] == [-1.2, 1.2]
    assert nhim_study_inputs(config, "s") == {"maps": [], "references": ["bottom"],
                                                         "systems": ["barbanis_2dof"]}


def test_cli_runs_detection_refinement_and_validation(barbanis_files, tmp_path, capsys):
    from ldpipe.cli import main

    output = tmp_path / "cli.nc"
    arguments = ["nhim", str(barbanis_files["maps"]["k-7.2"]), "-o", str(output), "--upo", str(barbanis_files["upo"]),
                 "--no-zoom", "--csv", str(tmp_path / "cli.csv")]
    assert main([*arguments, "--validate", "1e-7"]) == 0
    data = open_stage_file(output, stage=contracts.NHIM)
    # Independent method: the UPO's crossing of y = -7.2 (as in test_refined_points_agree_with_the_periodic_orbit).
    assert data.distance_refined.values[0] < 1e-8
    # The refined state lies on the section's energy surface (the solved momentum from the energy).
    system = make_system("barbanis_2dof", {"builtin": "barbanis_2dof"})
    assert system.energy(data.refined_state.values[0]) == pytest.approx(float(data.energy.values[0]), abs=1e-12)
    assert (tmp_path / "cli.md").is_file()
    # Beyond the tolerance: exit status 2 and a message naming the slice and the distance.
    assert main([*arguments, "--validate", "1e-13"]) == 2
    assert "cli/k-7.2: distance to the periodic orbit's crossing" in capsys.readouterr().err


def test_linear_saddle_with_masses():
    # H = p_x^2 / (2 m_x) + p_y^2 / (2 m_y) - kap x^2 / 2 + w^2 y^2 / 2: x(t) = A e^{lam t} + B e^{-lam t}
    # with lam = sqrt(kap / m_x) and p_x = m_x dx/dt, so A = (x + p_x / (m_x lam)) / 2: the stable
    # manifold is p_x = -m_x lam x, the unstable p_x = +m_x lam x, the NHIM point (0, 0) (closed form,
    # the module docstring's with p_x / lam replaced by p_x / (m_x lam)).
    mx, my, kap = 4.0, 2.0, 9.0
    lam = np.sqrt(kap / mx)  # 1.5
    system = make_system("linear_saddle_masses", {
        "formula": "-kap*x**2/2 + w**2*y**2/2", "coordinates": ["x", "y"], "parameters": {"kap": kap, "w": OMEGA},
        "masses": {"x": mx, "y": my},
    })
    section = Section(axes=("x", "px"), ranges=((-0.5, 0.5), (-2.0, 2.0)), shape=(41, 41), fixed={"y": 0.3},
                      solve="py", sign=1)
    ld_settings = LDSettings(rtol=1e-10, atol=1e-10, tau=20.0, region_lower=(-1.0, -2.0), region_upper=(1.0, 2.0))
    problem = nhim.make_slice_problem("linear_masses", system, section, ENERGY, 0.0, np.zeros(2), ld_settings)
    rng = np.random.default_rng(5)
    points = rng.uniform(-0.4, 0.4, size=(30, 2)) * [1.0, 4.0]
    orientation = np.sign(problem.reaction[0])
    forward, _ = nhim.exit_fates(problem, points, +1, SETTINGS)
    backward, _ = nhim.exit_fates(problem, points, -1, SETTINGS)
    np.testing.assert_array_equal(forward, orientation * np.sign(points[:, 0] + points[:, 1] / (mx * lam)))
    np.testing.assert_array_equal(backward, orientation * np.sign(points[:, 0] - points[:, 1] / (mx * lam)))
    c = np.array([0.4, -0.8])
    starts = np.column_stack([np.full(2, -0.4), c])
    ends = np.column_stack([np.full(2, 0.4), c])
    found, widths = nhim.bisect_fate_switch(problem, starts, ends, +1, SETTINGS)
    np.testing.assert_allclose(found[:, 0], -c / (mx * lam), atol=SETTINGS.bisection_precision)
    refined = nhim.refine_by_fates(problem, np.array([0.03, -0.1]), SETTINGS)
    assert np.linalg.norm(refined.point) <= SETTINGS.tolerance
    slope = mx * lam
    assert refined.angle == pytest.approx(np.arccos(abs(1 - slope**2) / (1 + slope**2)), abs=1e-6)


def test_validation_figure_tick_labels_are_readable(study_file, barbanis_files, tmp_path, monkeypatch):
    from ldpipe.figures.nhim import draw_nhim_validation
    from support.tick_labels import assert_saved_tick_labels_readable, record_saved_figures

    saved = record_saved_figures(monkeypatch)
    draw_nhim_validation(studies=[study_file], maps=[barbanis_files["maps"]["k-7.0"]], tolerance=1e-7,
                         png=tmp_path / "v.png")
    assert_saved_tick_labels_readable(saved)
