"""Lyapunov periodic orbits: closure, energy, period limit, Floquet multipliers, symmetry, the stage file."""

import numpy as np
import pytest

from ldpipe.io import contracts
from ldpipe.config import validate_config
from ldpipe.io.datafile import open_stage_file
from ldpipe.errors import ConfigError
from ldpipe.core.orbits.periodic import CorrectorSettings, LyapunovFamily, floquet_multipliers, linearize_saddle
from ldpipe.stages import upo as upo_stage
from ldpipe.stages.equilibria import run_equilibria
from ldpipe.config.parameters import parameters_from_config
from support.lindstedt import REMAINDER, barbanis_contopoulos_saddle, barbanis_saddle, period_energy_slope

SETTINGS = CorrectorSettings(tolerance=1e-10, rtol=1e-13, atol=1e-13)
ENERGY_TOLERANCE = 1e-12
# The appendix figure's excess energies (0.125 to 2.125 in steps of 0.25), 2.25, and well beyond.
TARGETS = [*np.arange(0.125, 2.2, 0.25), 2.25, 5.0, 10.0]
SADDLE_Y = np.sqrt(50.0)  # closed form: y_e = -omega_x omega_y / (sqrt(2) delta) = 7.0711
E_C = 15.125  # paper: the critical energy of both saddles
# Closed form: the centre frequency (the Hessian's positive eigenvalue is omega^2) and the
# Lindstedt-Poincare slope kappa of T = (2 pi / omega) (1 + kappa dE + O(dE^2)) (support.lindstedt):
# kappa = -5.733e-5.
OMEGA = np.sqrt(np.linalg.eigvalsh(barbanis_saddle()[0])[1])
KAPPA = period_energy_slope(*barbanis_saddle())
# The O(dE^2) remainder is bounded by support.lindstedt.REMAINDER |kappa| dE^2; the periods themselves
# are good to the corrector's tolerance (measured 2e-11 relative on the smallest members).


def assert_lindstedt_period(period, omega, kappa, excess):
    """T / (2 pi / omega) - 1 = kappa dE, to the O(dE^2) remainder and the corrector's tolerance."""
    deviation = np.asarray(period) * omega / (2 * np.pi) - 1
    excess = np.asarray(excess)
    bound = REMAINDER * abs(kappa) * excess**2 + SETTINGS.tolerance
    np.testing.assert_array_less(np.abs(deviation - kappa * excess), bound)


def make_family(system, y_sign, mode=0, position=None):
    position = np.array([5.5, y_sign * SADDLE_Y]) if position is None else position
    family = LyapunovFamily(system, linearize_saddle(system, position), mode, SETTINGS)
    return family


@pytest.fixture(scope="module")
def bottom(barbanis):
    family = make_family(barbanis, -1)
    ec = family.saddle.critical_energy
    family.continue_to(ec + max(TARGETS), initial_amplitude=1e-4, max_step=0.1, max_members=2000)
    orbits = {de: family.at_energy(ec + de, energy_tolerance=ENERGY_TOLERANCE) for de in TARGETS}
    return family, orbits


@pytest.fixture(scope="module")
def top(barbanis):
    family = make_family(barbanis, +1)
    ec = family.saddle.critical_energy
    family.continue_to(ec + max(TARGETS), initial_amplitude=1e-4, max_step=0.1, max_members=2000)
    orbits = {de: family.at_energy(ec + de, energy_tolerance=ENERGY_TOLERANCE) for de in TARGETS}
    return family, orbits


def test_saddle_linearization_matches_closed_form(barbanis):
    # Closed form (paper's appendix, with the corrected sqrt(wx^4 + 8 wx^2 wy^2)): the Hessian at the
    # saddle is [[wx^2, 2 delta y_e], [2 delta y_e, 0]], eigenvalues (wx^2 +- sqrt(wx^4 + 8 wx^2 wy^2))/2.
    saddle = linearize_saddle(barbanis, np.array([5.5, -SADDLE_Y]))
    root = np.sqrt(1.0 + 8.0 * 1.21)
    assert saddle.critical_energy == pytest.approx(15.125, abs=1e-12)  # paper: E_c = 15.125
    assert saddle.saddle_rate == pytest.approx(np.sqrt((root - 1.0) / 2.0), rel=1e-12)
    assert saddle.omegas[0] == pytest.approx(np.sqrt((root + 1.0) / 2.0), rel=1e-12)


def test_closure_within_the_asked_tolerance(bottom, barbanis):
    # The definition of a periodic orbit: ||x(T) - x(0)|| below the corrector's tolerance, re-measured here.
    from ldpipe.core.variational import propagate

    _, orbits = bottom
    for de, orbit in orbits.items():
        assert orbit.closure_error < SETTINGS.tolerance, de
        end = propagate(barbanis, orbit.initial_state, orbit.period, rtol=1e-13, atol=1e-13, stm=False)
        assert np.linalg.norm(end.state - orbit.initial_state) < SETTINGS.tolerance, de
        # A brake orbit: it starts at rest (all momenta zero at the turning point).
        assert np.all(orbit.initial_state[2:] == 0.0)


def test_energy_equals_the_target(bottom, barbanis):
    # Energy conservation: H at the initial state is the orbit's energy; it equals E_c + dE.
    family, orbits = bottom
    for de, orbit in orbits.items():
        assert barbanis.energy(orbit.initial_state) - family.saddle.critical_energy == pytest.approx(
            de, abs=ENERGY_TOLERANCE * 2
        )


def test_period_tends_to_the_linear_period(barbanis):
    # Lyapunov's theorem: T -> 2 pi / omega as dE -> 0 (omega from the linearization), and the
    # deviation is linear in dE for a smooth family: doubling dE doubles T - 2 pi / omega. Its
    # rate is Lindstedt-Poincare's kappa (closed form): (T omega / 2 pi - 1) / dE -> kappa
    # (measured 4e-6 relative off at dE = 1e-3).
    family = make_family(barbanis, -1)
    ec = family.saddle.critical_energy
    family.continue_to(ec + 1e-2, initial_amplitude=1e-4, max_step=0.1, max_members=500)
    linear = 2 * np.pi / family.omega
    orbits = [family.at_energy(ec + de, energy_tolerance=1e-14) for de in (1e-3, 2e-3)]
    small, double = (orbit.period - linear for orbit in orbits)
    assert abs(small) < 1e-5 * linear
    assert double / small == pytest.approx(2.0, rel=0.02)
    assert_lindstedt_period([orbit.period for orbit in orbits], OMEGA, KAPPA, [1e-3, 2e-3])


def test_zero_and_tiny_excess_energy_degrade_gracefully(barbanis):
    # dE = 0 is the saddle itself (closure 0, linear period); a tiny dE gives a tiny orbit at the saddle.
    family = make_family(barbanis, -1)
    ec = family.saddle.critical_energy
    family.continue_to(ec + 1e-3, initial_amplitude=1e-4, max_step=0.1, max_members=500)
    at_saddle = family.at_energy(ec, energy_tolerance=1e-14)
    assert at_saddle.period == pytest.approx(2 * np.pi / family.omega, rel=1e-15)
    np.testing.assert_array_equal(at_saddle.initial_state[:2], family.saddle.position)
    tiny = family.at_energy(ec + 1e-10, energy_tolerance=1e-14)
    assert np.linalg.norm(tiny.initial_state[:2] - family.saddle.position) < 1e-4
    assert tiny.closure_error < SETTINGS.tolerance
    with pytest.raises(ValueError, match="below the saddle"):
        family.at_energy(ec - 0.1, energy_tolerance=1e-14)


def test_floquet_multipliers(bottom):
    # Symplectic monodromy (Meyer et al.): multipliers lambda, 1/lambda, 1, 1.
    _, orbits = bottom
    for de, orbit in orbits.items():
        mu, _ = floquet_multipliers(orbit.monodromy)
        assert mu[0].real > 1 and abs(mu[0].imag) == 0 and abs(mu[1].imag) == 0
        assert mu[0].real * mu[1].real == pytest.approx(1.0, rel=1e-8), de
        # The unit pair is a Jordan block: numerically split by ~sqrt(error of M) ~ 1e-6 at most.
        np.testing.assert_allclose(mu[2:], 1.0, atol=1e-5)
        assert np.linalg.det(orbit.monodromy) == pytest.approx(1.0, rel=1e-7)


def test_multiplier_tends_to_the_linear_one(bottom):
    # Near the saddle the orbit's multiplier is the linear flow's over one period: exp(lambda 2 pi / omega).
    family, _ = bottom
    ec = family.saddle.critical_energy
    orbit = family.at_energy(ec + 1e-4, energy_tolerance=1e-14)
    orbit = family.finish(orbit)
    mu, _ = floquet_multipliers(orbit.monodromy)
    assert mu[0].real == pytest.approx(np.exp(family.saddle.saddle_rate * 2 * np.pi / family.omega), rel=1e-3)


def test_family_does_not_jump(bottom):
    # One family: amplitude, energy and the corrected coordinate change monotonically and smoothly
    # along the continuation, up to dE = 10, and every member's period is Lindstedt-Poincare's
    # (2 pi / omega) (1 + kappa dE) to the O(dE^2) remainder; so it stays within 0.1 % of the
    # linear one (|kappa| 10 (1 + 0.01 10) = 6.3e-4).
    family, orbits = bottom
    amplitudes = np.array([m.amplitude for m in family.members])
    energies = np.array([m.energy for m in family.members])
    free = np.array([m.initial_state[1] for m in family.members])
    periods = np.array([m.period for m in family.members])
    assert np.all(np.diff(amplitudes) > 0) and np.all(np.diff(energies) > 0) and np.all(np.diff(free) > 0)
    assert np.all(np.abs(np.diff(periods)) < 1e-3)
    assert energies[-1] - E_C >= 10.0
    assert_lindstedt_period(periods, OMEGA, KAPPA, energies - E_C)
    assert np.all(np.abs(periods * OMEGA / (2 * np.pi) - 1) < 1e-3)
    target_amplitudes = [orbits[de].amplitude for de in TARGETS]
    assert np.all(np.diff(target_amplitudes) > 0)


def test_saddles_orbits_mirror_under_y_reflection(bottom, top):
    # Symmetry of V(x, y) = V(x, -y): the top saddle's orbits are the bottom's with y, p_y -> -y, -p_y.
    (_, lower), (_, upper) = bottom, top
    mirror = np.array([1.0, -1.0, 1.0, -1.0])
    for de in TARGETS:
        np.testing.assert_allclose(upper[de].initial_state, mirror * lower[de].initial_state, atol=1e-9)
        assert upper[de].period == pytest.approx(lower[de].period, rel=1e-10)


@pytest.mark.parametrize("mode", [0, 1])
def test_three_dof_lyapunov_orbits_at_paper_energy(barbanis_contopoulos, mode):
    # Paper: E = 24 (dE = 0.176). Checks: closure, energy, multipliers lambda, 1/lambda, a conjugate pair
    # on the unit circle (the other centre), and the unit pair; the period is Lindstedt-Poincare's
    # (2 pi / omega) (1 + kappa dE) of the mode (closed form: kappa = 1.34e-6 and -1.79e-4).
    position = np.array([10.289915108550531, 5.294117647058823, 2.6470588235294117])  # closed form, paper eq.
    saddle, critical, hessian, third = barbanis_contopoulos_saddle(0.9, 1.6, 0.4, 0.08, 0.01)  # the built-in's defaults
    np.testing.assert_allclose(saddle, position, rtol=1e-15)
    family = make_family(barbanis_contopoulos, +1, mode=mode, position=position)
    assert np.linalg.norm(barbanis_contopoulos.gradient(position)) < 1e-12
    family.continue_to(24.0, initial_amplitude=1e-4, max_step=0.1, max_members=500)
    orbit = family.at_energy(24.0, energy_tolerance=ENERGY_TOLERANCE)
    assert orbit.closure_error < SETTINGS.tolerance
    assert barbanis_contopoulos.energy(orbit.initial_state) == pytest.approx(24.0, abs=2 * ENERGY_TOLERANCE)
    mu, _ = floquet_multipliers(orbit.monodromy)
    assert mu[0].real * mu[1].real == pytest.approx(1.0, rel=1e-7)
    assert abs(mu[2]) == pytest.approx(1.0, abs=1e-7) and mu[3] == pytest.approx(np.conj(mu[2]), abs=1e-7)
    np.testing.assert_allclose(mu[4:], 1.0, atol=1e-5)
    omega = np.sqrt(np.linalg.eigvalsh(hessian)[1 + mode])
    assert_lindstedt_period(orbit.period, omega, period_energy_slope(hessian, third, mode), 24.0 - critical)
    assert orbit.period == pytest.approx(2 * np.pi / family.omega, rel=1e-3)


@pytest.fixture(scope="module")
def equilibria_files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("equilibria")
    config = validate_config({"systems": {
        "barbanis_2dof": {"builtin": "barbanis_2dof"},
        "barbanis_contopoulos_3dof": {"builtin": "barbanis_contopoulos_3dof"},
    }})
    return {name: run_equilibria(**parameters_from_config(config, "equilibria", name), output=folder / f"{name}.nc")
            for name in config["systems"]}


def config_with(**sections):
    return validate_config({"systems": {"barbanis_2dof": {"builtin": "barbanis_2dof"},
                                        "barbanis_contopoulos_3dof": {"builtin": "barbanis_contopoulos_3dof"}},
                            **sections})


def test_stage_writes_the_family_file(tmp_path, equilibria_files):
    config = config_with(periodic_orbits={"bottom": {
        "system": "barbanis_2dof", "saddle_near": [5.5, -7.0], "energies": {"excess": [0.0, 0.125, 2.25]},
        "samples": 50,
    }})
    path = upo_stage.run_upo(**parameters_from_config(config, "upo", "bottom"),
                             equilibria=equilibria_files["barbanis_2dof"],
                             output=tmp_path / "bottom.nc")
    data = open_stage_file(path, stage=contracts.UPO)
    assert data.sizes["orbit"] == 3 and data.sizes["sample"] == 50 and data.sizes["mode"] == 4
    np.testing.assert_allclose(data.excess_energy.values, [0.0, 0.125, 2.25], atol=2e-12)
    assert np.all(data.closure_error.values < 1e-10)
    # The stored samples close the orbit and lie on its energy surface.
    trajectory = data.trajectory.values
    np.testing.assert_allclose(trajectory[:, -1], trajectory[:, 0], atol=1e-9)
    assert data.attrs["held_coordinate"] == "x"


def test_config_errors_name_the_key(equilibria_files, tmp_path):
    with pytest.raises(ConfigError, match="periodic_orbits.f.center_mode"):
        config_with(periodic_orbits={"f": {"system": "barbanis_2dof", "center_mode": 1, "energies": {"excess": [1.0]}}})
    with pytest.raises(ConfigError, match="periodic_orbits.f.energies.excess.0"):
        config_with(periodic_orbits={"f": {"system": "barbanis_2dof", "energies": {"excess": [-1.0]}}})
    with pytest.raises(ConfigError, match="manifolds.m.energy"):
        config_with(periodic_orbits={"f": {"system": "barbanis_2dof", "energies": {"excess": [1.0]}}},
                    manifolds={"m": {"orbits": "f", "energy": {"excess": 2.0}}})
    with pytest.raises(ConfigError, match="periodic_orbits.f.system"):
        config_with(periodic_orbits={"f": {"system": "nope", "energies": {"excess": [1.0]}}})
    config = config_with(periodic_orbits={"f": {"system": "barbanis_2dof", "energies": {"total": [15.0]}}})
    with pytest.raises(ConfigError, match="periodic_orbits.f.energies"):
        upo_stage.run_upo(**parameters_from_config(config, "upo", "f"), equilibria=equilibria_files["barbanis_2dof"],
                          output=tmp_path / "f.nc")


def test_cli_subcommands_write_stage_files(tmp_path):
    # The orbit subcommands through the `ldpipe` parser, which registers them (ldpipe.cli.orbits).
    from ldpipe.cli.main import build_parser
    from support.workflow import ROOT

    parser = build_parser()
    config = ROOT / "config.yaml"
    args = parser.parse_args(["upo", "--config", str(config), "--family", "barbanis_contopoulos_3dof_mode1",
                              "-o", str(tmp_path / "upo.nc")])
    args.handler(args)
    data = open_stage_file(tmp_path / "upo.nc", stage=contracts.UPO)
    assert data.energy.values == pytest.approx([24.0], abs=1e-11)  # the paper's E = 24
    args = parser.parse_args(["upo", "--config", str(config), "--family", "nope", "-o", str(tmp_path / "x.nc")])
    with pytest.raises(ConfigError, match="no entry 'nope' under 'periodic_orbits'"):
        args.handler(args)


def test_stage_with_equal_masses_scales_the_periods(tmp_path, bottom):
    # m_x = m_y = 8: the unit-mass orbit at the same energy, sqrt(8) times slower (q(t) = q_unit(t / sqrt 8),
    # p = sqrt(8) p_unit): periods times sqrt(8), the same Floquet multipliers, the same initial
    # positions (brake orbits start at rest). The file records the matrix and the stored samples lie on
    # H = |p|^2 / 16 + V.
    spec = {"builtin": "barbanis_2dof", "masses": {"x": 8.0, "y": 8.0}}
    config = validate_config({"systems": {"barbanis_m8": spec}, "periodic_orbits": {"heavy": {
        "system": "barbanis_m8", "saddle_near": [5.5, -7.0], "energies": {"excess": [0.125]}, "samples": 40}}})
    equilibria = run_equilibria(**parameters_from_config(config, "equilibria", "barbanis_m8"),
                                output=tmp_path / "eq.nc")
    path = upo_stage.run_upo(**parameters_from_config(config, "upo", "heavy"), equilibria=equilibria,
                             output=tmp_path / "heavy.nc")
    data = open_stage_file(path, stage=contracts.UPO)
    assert data.attrs["mass_matrix"] == "[[8.0, 0.0], [0.0, 8.0]]"
    _, orbits = bottom
    unit = orbits[0.125]
    assert float(data.period.values[0]) == pytest.approx(np.sqrt(8.0) * unit.period, rel=1e-11)
    np.testing.assert_allclose(data.initial_state.values[0, :2], unit.initial_state[:2], atol=1e-9)
    trajectory = data.trajectory.values[0]
    x, y = trajectory[:, 0], trajectory[:, 1]
    energy = (trajectory[:, 2] ** 2 + trajectory[:, 3] ** 2) / 16 + x**2 / 2 + 1.21 * y**2 / 2 - 0.11 * x * y**2
    np.testing.assert_allclose(energy, 15.125 + 0.125, atol=1e-10)
