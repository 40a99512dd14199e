"""NHIM crossings of slices through periodic-orbit points: every crossing, degenerate slices, 3 DoF and 2 DoF.

The references are independent of the LDs and of the fates: closed forms (the linear saddle, whose
NHIM is x = p_x = 0; two fate-switch curves of known shape), and the Lyapunov orbits of the
periodic-orbit corrector (differential correction, scipy), which lie on the NHIM, so the slice
through an orbit point has a NHIM point exactly at that point.
"""

from __future__ import annotations

import numpy as np
import pytest

from ldpipe.core import nhim
from ldpipe.io import contracts
from ldpipe.config import validate_config
from ldpipe.io.datafile import open_stage_file
from ldpipe.engine import LDSettings
from ldpipe.errors import ConfigError
from ldpipe.core.maps.grid import resolve_ld_map
from ldpipe.stages import nhim_validation
from ldpipe.stages.equilibria import run_equilibria
from ldpipe.stages.nhim_orbits import run_nhim_orbit_validation
from ldpipe.stages.plan import nhim_orbit_inputs
from ldpipe.config.parameters import parameters_from_config
from ldpipe.stages.upo import run_upo
from ldpipe.systems import make_system
from ldpipe.core.variational import propagate
from support.lindstedt import barbanis_contopoulos_saddle

LAM, OMEGA = 1.5, 1.0
SETTINGS = nhim.RefinementSettings(tolerance=1e-8, bisection_precision=5e-10, max_time=40.0)


# ----------------------------------------------------------------------------------------------
# Closed forms


def test_candidates_are_every_separated_crossing_of_the_two_switch_curves():
    # Closed form: the forward fate switches on the parabola b = a^2 - 0.25, the backward fate on
    # the line b = 0; they cross at a = -0.5 and a = +0.5, b = 0: two candidates, each within a
    # cell of its crossing. A third curve pair that never meets (b = 0.9 alone) adds none.
    a = np.linspace(-1, 1, 81)
    b = np.linspace(-1, 1, 81)
    A, B = np.meshgrid(a, b, indexing="ij")
    forward = np.where(B > A**2 - 0.25, 1, -1)
    backward = np.where(B > 0.0123, 1, -1)  # off the grid lines, so the switch is inside cells
    allowed = np.ones_like(A, dtype=bool)
    candidates = nhim.crossing_candidates(forward, backward, allowed, (a, b))
    assert len(candidates) == 2
    points = sorted((c.point for c in candidates), key=lambda p: p[0])
    cell = a[1] - a[0]
    for point, (x0, y0) in zip(points, [(-np.sqrt(0.25 + 0.0123), 0.0123), (np.sqrt(0.25 + 0.0123), 0.0123)]):
        assert abs(point[0] - x0) <= 1.5 * cell and abs(point[1] - y0) <= cell
    # One curve alone (the backward fate constant): no candidate.
    assert nhim.crossing_candidates(forward, np.ones_like(forward), allowed, (a, b)) == []
    # Cells with a disallowed corner are never candidates.
    assert nhim.crossing_candidates(forward, backward, np.zeros_like(allowed), (a, b)) == []


@pytest.fixture(scope="module")
def linear_saddle():
    return make_system("linear_saddle", {
        "formula": "-lam**2*x**2/2 + w**2*y**2/2", "coordinates": ["x", "y"],
        "parameters": {"lam": LAM, "w": OMEGA},
    })


def _linear_orbit_point(t: float, energy: float = 0.5) -> np.ndarray:
    # The NHIM of the linear saddle is x = p_x = 0: the y oscillator y = A cos(w t), amplitude A = sqrt(2 E) / w.
    amplitude = np.sqrt(2 * energy) / OMEGA
    return np.array([0.0, amplitude * np.cos(OMEGA * t), 0.0, -amplitude * OMEGA * np.sin(OMEGA * t)])


def test_every_crossing_of_the_linear_saddle_is_its_nhim_point(linear_saddle):
    # Closed form: the slice (x, p_x) through the orbit point meets the NHIM x = p_x = 0 only at (0, 0)
    # (the stable and unstable lines p_x = -+lam x cross only there), so exactly one crossing, at the centre.
    state = _linear_orbit_point(0.7)
    section = nhim.point_slice(linear_saddle, state, ("x", "px"), 0.3, 21)
    assert section.fixed == {"y": pytest.approx(state[1])} and section.solve == "py" and section.sign == -1
    ld_settings = LDSettings(rtol=1e-10, atol=1e-10, tau=20.0, region_lower=(-1.0, -2.0), region_upper=(1.0, 2.0))
    problem = nhim.make_slice_problem("linear", linear_saddle, section, 0.5, 0.0, np.zeros(2), ld_settings)
    found = nhim.find_every_crossing(problem, SETTINGS)
    assert [c.status for c in found.crossings] == ["refined"]
    np.testing.assert_allclose(found.points, [[0.0, 0.0]], atol=1e-8)
    assert found.crossings[0].refined.uncertainty <= SETTINGS.tolerance


def test_slices_refined_together_are_the_slices_refined_alone(linear_saddle):
    # Identity: the engine integrates each trajectory on its own lane, so refining the candidates of
    # several slices (through three points of the orbit) in shared rounds must give each slice's
    # crossings, uncertainties and costs exactly as its search alone does.
    ld_settings = LDSettings(rtol=1e-10, atol=1e-10, tau=20.0, region_lower=(-1.0, -2.0), region_upper=(1.0, 2.0))
    problems = [nhim.make_slice_problem(f"linear{t}", linear_saddle,
                                        nhim.point_slice(linear_saddle, _linear_orbit_point(t), ("x", "px"), 0.3, 21),
                                        0.5, 0.0, np.zeros(2), ld_settings) for t in (0.3, 0.7, 1.1)]
    together = nhim.find_crossings_together(problems, SETTINGS)
    for problem, found in zip(problems, together):
        alone = nhim.find_every_crossing(problem, SETTINGS)
        assert [c.status for c in found.crossings] == [c.status for c in alone.crossings] == ["refined"]
        assert np.array_equal(found.points, alone.points)
        assert found.crossings[0].refined.uncertainty == alone.crossings[0].refined.uncertainty
        assert (found.cost.trajectories, found.cost.time_units, found.cost.steps) == (
            alone.cost.trajectories, alone.cost.time_units, alone.cost.steps)


def test_transversality_and_boundary_distance_of_the_linear_saddle(linear_saddle):
    # Closed forms. Monodromy of the linear saddle over the y period T = 2 pi / w: diag-like, the
    # hyperbolic pair u = (1, 0, lam, 0), s = (1, 0, -lam, 0). At x = p_x = 0 the slice (x, p_x)
    # has steps e_x, e_px (dH . e_x = -lam^2 x = 0, dH . e_px = p_x = 0), and
    # det[w(u, e_x), w(u, e_px); w(s, e_x), w(s, e_px)] / |w(u, s)| = (2 lam / n^2) / (2 lam / n^2) = 1.
    state = _linear_orbit_point(0.7)
    monodromy = propagate(linear_saddle, state, 2 * np.pi / OMEGA, rtol=1e-12, atol=1e-12).stm
    across = nhim.point_slice(linear_saddle, state, ("x", "px"), 0.3, 21)
    assert nhim.slice_transversality(linear_saddle, across, state, monodromy) == pytest.approx(1.0, abs=1e-9)
    # Boundary distance p_s^2 / (2 |(dH/da, dH/db)|): on (x, p_x) dH/dx = dH/dpx = 0 there, so the
    # first-order distance is infinite; on (y, p_y), solving p_x = 0, it is 0 (the slice's energy
    # boundary passes through the orbit point: a degenerate slice).
    assert nhim.boundary_distance(linear_saddle, across, state) == np.inf
    along = nhim.point_slice(linear_saddle, state, ("y", "py"), 0.3, 21)
    assert along.solve == "px" and nhim.boundary_distance(linear_saddle, along, state) == 0.0


def test_point_slice_refuses_bad_axes(linear_saddle):
    state = _linear_orbit_point(0.7)
    with pytest.raises(ValueError, match="two distinct phase coordinates"):
        nhim.point_slice(linear_saddle, state, ("x", "pz"), 0.3, 21)
    with pytest.raises(ValueError, match="expected a momentum off the axes"):
        nhim.point_slice(linear_saddle, state, ("x", "px"), 0.3, 21, solve="y")


# ----------------------------------------------------------------------------------------------
# The paper's systems: slices through points of their Lyapunov orbits


def orbit_config(**orbit_validation):
    return validate_config({
        "systems": {"barbanis_2dof": {"builtin": "barbanis_2dof"},
                    "barbanis_contopoulos_3dof": {
                        "builtin": "barbanis_contopoulos_3dof",
                        "parameters": {"omega_x2": 0.9, "omega_y2": 1.6, "omega_z2": 0.4, "epsilon": 0.08, "eta": 0.01}}},
        "ld_maps": {
            "fig4": {"system": "barbanis_2dof", "saddle_near": [5.5, -7.0],
                     "section": {"axes": [{"name": "x", "range": [4.8, 6.0], "points": 20},
                                          {"name": "px", "range": [-0.6, 0.6], "points": 20}],
                                 "fixed": {"y": -7.0}, "solve": "py"},
                     "energy": {"excess": 0.125}, "tau": 50, "time": "variable",
                     "region": {"x": [4.5, 6.5], "y": [-8.5, -5.5]}},
            "fig5": {"system": "barbanis_contopoulos_3dof", "saddle_near": [10.29, 5.29, 2.65],
                     "section": {"axes": [{"name": "x", "range": [9.0, 12.0], "points": 20},
                                          {"name": "px", "range": [-0.6, 0.6], "points": 20}],
                                 "fixed": {"y": "saddle", "z": "saddle", "py": 0.0}, "solve": "pz"},
                     "energy": {"total": 24.0}, "tau": 50, "p": 0.5, "time": "variable",
                     "region": {"x": [9.0, 12.0], "y": [2.5, 7.5], "z": [1.0, 4.0]}},
        },
        # 41 samples: the orbit points at phases 0, 1/4, 1/2, 3/4 are stored samples.
        "periodic_orbits": {
            "bottom": {"system": "barbanis_2dof", "saddle_near": [5.5, -7.07], "energies": {"excess": [0.125]},
                       "samples": 41},
            **{f"mode{m}": {"system": "barbanis_contopoulos_3dof", "saddle_near": [10.29, 5.29, 2.65],
                            "center_mode": m, "energies": {"total": [24.0]}, "samples": 41} for m in (0, 1)},
        },
        "nhim": {"orbit_validation": orbit_validation},
    })


@pytest.fixture(scope="module")
def orbit_files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("nhim_orbits")
    config = orbit_config()
    files = {"folder": folder, "config": config}
    for system in ("barbanis_2dof", "barbanis_contopoulos_3dof"):
        files[system] = run_equilibria(**parameters_from_config(config, "equilibria", system),
              output=folder / f"{system}.nc")
    for family in ("bottom", "mode0", "mode1"):
        system = config["periodic_orbits"][family]["system"]
        files[family] = run_upo(**parameters_from_config(config, "upo", family), equilibria=files[system],
                                output=folder / f"{family}.nc")
    return files


@pytest.fixture(scope="module")
def three_dof_file(orbit_files):
    # Both centre modes at E = 24, four phases (two of them the orbit's turning points), the x-p_x and
    # z-p_z kinds on small windows.
    config = orbit_files["config"]
    return run_nhim_orbit_validation(
        study="bc3", base_map=parameters_from_config(config, "ld", "fig5"), orbits=["mode0", "mode1"],
        orbit_files=[orbit_files["mode0"], orbit_files["mode1"]], equilibria=orbit_files["barbanis_contopoulos_3dof"],
        energies={"total": [24.0]}, phases=4, slices=[["x", "px"], ["z", "pz"]], half_width=0.2, points=33,
        boundary_cells=2.0, min_transversality=1e-3, tolerance=1e-8, refinement={},
        output=orbit_files["folder"] / "bc3.nc",
    )


def _rows(path):
    data = open_stage_file(path, stage=contracts.NHIM_ORBITS)
    return data, {(str(data.family.values[k]), round(float(data.orbit_phase.values[k]), 3),
                   "-".join(data.axis_names.values[k])): k for k in range(data.sizes["slice"])}


def test_3dof_slices_through_the_lyapunov_orbits_find_the_orbit_points(three_dof_file):
    # Independent method: the orbit points come from the periodic-orbit corrector (closure ~1e-11),
    # not from fates or LDs; the refined NHIM crossing nearest each must be within 1e-8 (the issue's
    # tolerance) of it, and its own uncertainty within the refinement tolerance.
    data, rows = _rows(three_dof_file)
    checked = [(family, phase, axes) for family in ("mode0", "mode1") for phase in (0.25, 0.75) for axes in ("x-px",)]
    checked += [("mode1", phase, "z-pz") for phase in (0.25, 0.75)]
    for key in checked:
        k = rows[key]
        assert str(data.status.values[k]) == "ok", (key, str(data.reason.values[k]))
        assert 0 <= float(data.distance.values[k]) <= 1e-8, key
        assert float(data.uncertainty.values[k]) <= 1e-8
    # The crossings table holds each refined crossing with its distance from its slice's orbit point.
    mine = data.crossing_slice.values == rows[("mode1", 0.25, "x-px")]
    assert mine.sum() == 1
    np.testing.assert_allclose(data.crossing_point.values[mine][0], data.orbit_point.values[rows[("mode1", 0.25, "x-px")]],
                               atol=1e-8)


def test_every_crossing_is_found_where_the_slice_meets_the_nhim_twice(three_dof_file):
    # A z-p_z slice through the x-y orbit (centre mode 1) meets the NHIM twice (at E = 24); both are
    # found and refined: the orbit point and the other one the linearization predicts. Near the
    # saddle the NHIM is where the saddle mode's coordinate and momentum, e_s.(q - q_s) and e_s.p,
    # vanish (e_s the Hessian's negative-eigenvalue eigenvector, closed form). The slice holds x, y,
    # p_x at the orbit point's values, so to first order both crossings share its z, and their
    # (p_y, p_z) lie on the line e_s.p = e_s.p0 and on the energy circle |(p_y, p_z)| = |(p0_y, p0_z)|:
    # the orbit point's and the chord's other end p0 - 2 (p0.d) d, d the line's direction. Measured:
    # the refined crossing 1.0e-3 from it in z and 2.6e-5 in p_z (the NHIM's curvature); bound
    # 3e-3, a quarter of a grid cell. Its p_y has the slice's sign, so it is in the slice.
    data, rows = _rows(three_dof_file)
    _, _, hessian, _ = barbanis_contopoulos_saddle(0.9, 1.6, 0.4, 0.08, 0.01)  # orbit_config's parameters
    saddle_mode = np.linalg.eigh(hessian)[1][:, 0]
    direction = np.array([saddle_mode[2], -saddle_mode[1]]) / np.linalg.norm(saddle_mode[1:])
    for phase in (0.25, 0.75):
        k = rows[("mode1", phase, "z-pz")]
        assert int(data.crossings.values[k]) == 2
        mine = data.crossing_slice.values == k
        order = np.argsort(data.crossing_distance.values[mine])
        distances, points = data.crossing_distance.values[mine][order], data.crossing_point.values[mine][order]
        assert distances[0] <= 1e-8
        _, _, z, _, py, pz = data.orbit_state.values[k]
        momenta = np.array([py, pz])
        other = momenta - 2 * (momenta @ direction) * direction
        assert np.sign(other[0]) == np.sign(py)
        np.testing.assert_allclose(points[1], [z, other[1]], rtol=0, atol=3e-3)
        assert distances[1] == pytest.approx(abs(other[1] - pz), abs=3e-3)


def test_degenerate_slices_are_recorded_never_written_as_points(three_dof_file):
    # At the orbit's turning points (phases 0 and 1/2, all momenta 0 by construction of the brake
    # orbit) every solved momentum vanishes; through the z orbit (mode 0) the z-p_z slice solves
    # p_y, which that orbit keeps within about 0.06 of 0, so the slice's energy boundary is within
    # two grid cells. Each is recorded with its reason; none has a crossing in the table.
    data, rows = _rows(three_dof_file)
    degenerate = [rows[(family, phase, axes)] for family in ("mode0", "mode1") for phase in (0.0, 0.5)
                  for axes in ("x-px", "z-pz")] + [rows[("mode0", 0.25, "z-pz")], rows[("mode0", 0.75, "z-pz")]]
    for k in degenerate:
        assert str(data.status.values[k]) == "degenerate:solved_momentum_vanishes"
        assert "vanishes" in str(data.reason.values[k])
        assert int(data.crossings.values[k]) == 0 and float(data.distance.values[k]) == -1.0
        assert k not in data.crossing_slice.values
    assert data.attrs["tolerance"] == 1e-8 and data.attrs["refinement_tolerance"] == 1e-8


def test_the_same_machinery_returns_the_2dof_orbit_crossings(orbit_files):
    # Independent method: the 2 DoF periodic orbit's crossing of the slice y = y(t), p_y of the
    # orbit's sign (ldpipe.core.nhim.orbit_section_crossing, the engine's located section crossing of the
    # corrector's orbit, as the fig4 study's validation uses) is the slice's one crossing: the
    # one-dimensional NHIM meets each slice once in its window.
    config = orbit_files["config"]
    path = run_nhim_orbit_validation(
        study="b2", base_map=parameters_from_config(config, "ld",
                                                    "fig4"), orbits=["bottom"], orbit_files=[orbit_files["bottom"]],
        equilibria=orbit_files["barbanis_2dof"], energies={"excess": [0.125]}, phases=4, slices=[["x", "px"]],
        half_width=0.2, points=41, boundary_cells=2.0, min_transversality=1e-3, tolerance=1e-8, refinement={},
        output=orbit_files["folder"] / "b2.nc",
    )
    data, rows = _rows(path)
    upo = open_stage_file(orbit_files["bottom"], stage=contracts.UPO)
    system = make_system("barbanis_2dof", {"builtin": "barbanis_2dof"})
    base = parameters_from_config(config, "ld", "fig4")
    for phase in (0.25, 0.75):
        k = rows[("bottom", phase, "x-px")]
        assert str(data.status.values[k]) == "ok" and int(data.crossings.values[k]) == 1
        point = data.crossing_point.values[data.crossing_slice.values == k][0]
        state = data.orbit_state.values[k]
        section = nhim.point_slice(system, state, ("x", "px"), 0.2, 41)
        saddle, critical = np.asarray(upo.attrs["saddle_position"]), float(upo.attrs["critical_energy"])
        _, _, settings, _ = resolve_ld_map(base, saddle, critical)
        problem = nhim.make_slice_problem("b2", system, section, float(upo.energy.values[0]), critical, saddle, settings)
        crossing = nhim.orbit_section_crossing(problem, upo.initial_state.values[0], float(upo.period.values[0]))
        np.testing.assert_allclose(point, crossing, atol=1e-8)


def test_slices_below_the_transversality_minimum_are_recorded_as_tangent(orbit_files, tmp_path):
    # The 2 DoF x-p_x slices meet the orbit at transversality 0.25-0.6 (from the monodromy, as in
    # the closed-form test); with a minimum of 0.9 each counts as tangent: searched, its crossings
    # kept in the table, but not checked against the orbit point and not a failure of the run.
    config = orbit_files["config"]
    path = run_nhim_orbit_validation(
        study="tangent", base_map=parameters_from_config(config, "ld", "fig4"), orbits=["bottom"],
        orbit_files=[orbit_files["bottom"]], equilibria=orbit_files["barbanis_2dof"], energies={"excess": [0.125]},
        phases=4, slices=[["x", "px"]], half_width=0.2, points=21, boundary_cells=2.0, min_transversality=0.9,
        tolerance=1e-8, refinement={}, output=tmp_path / "tangent.nc",
    )
    data, rows = _rows(path)
    for phase in (0.25, 0.75):
        k = rows[("bottom", phase, "x-px")]
        assert str(data.status.values[k]) == "degenerate:tangent"
        assert 0 < float(data.transversality.values[k]) < 0.9 and "min_transversality 0.9" in str(data.reason.values[k])
    outputs = {"csv_output": tmp_path / "v.csv", "markdown_output": tmp_path / "v.md", "tolerance": 1e-7,
               "residence_ratio": 2.0, "orbits_csv_output": tmp_path / "o.csv", "orbits_markdown_output": tmp_path / "o.md"}
    nhim_validation.run_nhim_validation(studies=[], orbit_studies=[path], **outputs)
    assert "degenerate:tangent" in (tmp_path / "o.csv").read_text()


def test_validation_table_fails_naming_slice_and_reason(orbit_files, three_dof_file, tmp_path):
    # A passing file gives a table and no error ...
    outputs = {"csv_output": tmp_path / "v.csv", "markdown_output": tmp_path / "v.md", "tolerance": 1e-7,
               "residence_ratio": 2.0, "orbits_csv_output": tmp_path / "o.csv", "orbits_markdown_output": tmp_path / "o.md"}
    nhim_validation.run_nhim_validation(studies=[], orbit_studies=[three_dof_file], **outputs)
    table = (tmp_path / "o.md").read_text()
    assert "degenerate:solved_momentum_vanishes" in table and "| ok |" in table
    # ... a refinement that cannot converge (one secant iteration) fails the run, naming the slice and why.
    config = orbit_files["config"]
    failing = run_nhim_orbit_validation(
        study="bad", base_map=parameters_from_config(config, "ld",
                                                     "fig4"), orbits=["bottom"], orbit_files=[orbit_files["bottom"]],
        equilibria=orbit_files["barbanis_2dof"], energies={"excess": [0.125]}, phases=4, slices=[["x", "px"]],
        half_width=0.2, points=21, boundary_cells=2.0, min_transversality=1e-3, tolerance=1e-8,
        refinement={"max_iterations": 1}, output=tmp_path / "bad.nc",
    )
    with pytest.raises(nhim_validation.NHIMValidationError, match=r"bad/bottom/E.*phase 0.2500/x-px slice: not_converged"):
        nhim_validation.run_nhim_validation(studies=[], orbit_studies=[failing], **outputs)
    assert "fail:not_converged" in (tmp_path / "o.md").read_text()


def test_orbit_validation_config_errors_name_the_key():
    study = {"base_map": "fig5", "orbits": ["mode0"], "energies": {"total": [24.0]}}
    assert orbit_config(s=study)["nhim"]["orbit_validation"]["s"]["points"] == 65  # the schema's defaults
    with pytest.raises(ConfigError, match=r"nhim.orbit_validation.s.orbits.*no family 'nope'"):
        orbit_config(s={**study, "orbits": ["nope"]})
    with pytest.raises(ConfigError, match=r"nhim.orbit_validation.s.orbits.*not of the map's system"):
        orbit_config(s={**study, "orbits": ["bottom"]})
    with pytest.raises(ConfigError, match=r"nhim.orbit_validation.s.points.*odd"):
        orbit_config(s={**study, "points": 64})
    with pytest.raises(ConfigError, match=r"nhim.orbit_validation.s.slices.*position and its momentum"):
        orbit_config(s={**study, "slices": [["x", "py"]]})
    with pytest.raises(ConfigError, match=r"nhim.orbit_validation.s.energies.*no orbit at total energies \[24.5\]"):
        orbit_config(s={**study, "energies": {"total": [24.0, 24.5]}})
    with pytest.raises(ConfigError, match=r"nhim.orbit_validation.s.tolerance.*below nhim.refinement.tolerance"):
        orbit_config(s={**study, "tolerance": 1e-9})
    config = orbit_config(s=study)
    config["max_grid_points"] = 40
    assert parameters_from_config(config, "nhim_orbits", "s")["points"] == 39  # capped, and odd
    assert nhim_orbit_inputs(config, "s") == {"orbits": ["mode0"], "systems": ["barbanis_contopoulos_3dof"]}


def test_the_documented_example_is_the_configured_study():
    # The documented example block is config.yaml's 3 DoF study, and valid against the schema.
    import yaml
    from support.workflow import ROOT, documented_yaml

    example = yaml.safe_load(documented_yaml("orbit_validation"))["nhim"]["orbit_validation"]
    config = yaml.safe_load((ROOT / "config.yaml").read_text())
    assert example["barbanis_contopoulos_3dof"] == config["nhim"]["orbit_validation"]["barbanis_contopoulos_3dof"]
    config["nhim"]["orbit_validation"] = example
    validate_config(config)
