"""The transport stage end to end on small settings: the three fluxes agree at each energy.

Independent values: the identity action = reactive-island area = reactive flux (MacKay 1990),
each computed by a different method from different data (the orbit's samples; trajectories
started on the tubes and cut by y = 0; random points of the dividing line integrated both ways);
the harmonic estimate 2πΔE/ω from the equilibria file's centre frequency, which the flux must
approach as ΔE → 0: the action is ∫ T dE, so its first relative correction is κΔE/2 with κ the
Lindstedt–Poincaré slope of the period (support.lindstedt).
"""

import math

import numpy as np
import pytest

from ldpipe.config import validate_config
from ldpipe.io.contracts import TRANSPORT
from ldpipe.io.datafile import open_stage_file
from ldpipe.errors import ConfigError
from ldpipe.figures.transport import draw_transport
from support.tick_labels import assert_saved_tick_labels_readable, record_saved_figures
from ldpipe.stages import transport as transport_stage
from ldpipe.stages import upo as upo_stage
from ldpipe.stages.equilibria import run_equilibria
from ldpipe.config.parameters import parameters_from_config
from support.lindstedt import REMAINDER, barbanis_saddle, period_energy_slope

EXCESS = [0.125, 2.25]


def _config(**transport):
    return validate_config({
        "systems": {"barbanis_2dof": {"builtin": "barbanis_2dof"}},
        "periodic_orbits": {"bottom": {"system": "barbanis_2dof", "saddle_near": [5.5, -7.0],
                                       "energies": {"excess": EXCESS}, "samples": 64}},
        "transport": {"t": {"orbits": "bottom", "energies": {"excess": EXCESS}, "island": {"points": 24},
                            "monte_carlo": {"batch": 1000, "max_samples": 1000},
                            "survival": {"initial_count": 20000, "count": 400, "duration": 1.0,
                                         "decay_window": [0.3, 1.0]},
                            "gap_times": {"count": 600}, **transport}},
    })


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("transport")
    config = _config()
    equilibria = run_equilibria(**parameters_from_config(config, "equilibria", "barbanis_2dof"),
                                output=folder / "eq.nc")
    upo = upo_stage.run_upo(**parameters_from_config(config, "upo", "bottom"), equilibria=equilibria,
                            output=folder / "upo.nc")
    path = transport_stage.run_transport(**parameters_from_config(config, "transport", "t"), upo=upo,
                                         equilibria=equilibria, output=folder / "t.nc")
    return folder, equilibria, upo, path


def test_action_island_area_and_monte_carlo_agree(files):
    _, _, _, path = files
    data = open_stage_file(path, stage=TRANSPORT)
    assert data.excess_energy.values == pytest.approx(EXCESS, abs=1e-10)
    action = data.flux_action.values
    # 24 points along the orbit already give the island area to ~1e-10 (spectral rule).
    assert np.all(np.abs(data.flux_island_area.values / action[:, None] - 1) < 1e-6)
    # The shoelace rule on the same points is far off: the spectral rule is what makes 1e-6 cheap.
    assert np.all(np.abs(data.flux_island_area_polygon.values / action[:, None] - 1) > 1e-4)
    assert np.all(np.abs(data.flux_monte_carlo.values - action) < 3 * data.flux_monte_carlo_stderr.values)
    assert np.all(data.monte_carlo_undecided.values == 0)
    # The one-way flux through the straight line counts recrossings: larger than the reactive flux.
    assert np.all(data.flux_dividing_line.values > action)


def test_harmonic_estimate_is_the_low_energy_limit(files):
    folder, equilibria, _, path = files
    data = open_stage_file(path, stage=TRANSPORT)
    # The 2 DoF saddle's centre frequency by hand: V = x²/2 + 1.21 y²/2 − 0.11 x y² at (5.5, −√50) has
    # Hessian [[1, −0.22 y], [−0.22 y, 1.21 − 0.22 x]] = [[1, 0.22√50], [0.22√50, 0]]; the linearized
    # flow's eigenvalues ±iω satisfy ω² = the positive Hessian eigenvalue.
    b = 0.22 * math.sqrt(50.0)
    omega = math.sqrt((1 + math.sqrt(1 + 4 * b * b)) / 2)
    assert data.flux_harmonic.values == pytest.approx(2 * math.pi * np.asarray(EXCESS) / omega, rel=1e-12)
    # Closed form: the action J = ∫ T dE over the family, T = (2π/ω)(1 + κ ΔE + O(ΔE²)), so
    # J / (2πΔE/ω) − 1 = κ ΔE / 2 (κ = −5.733e-5: −3.58e-6 and −6.45e-5 here), the remainder below
    # a third of the period's (REMAINDER |κ| ΔE² / 3; measured 0.0010 |κ| ΔE²) plus the corrector's
    # tolerance 1e-10. So the deviation is below 1e-4 at ΔE = 0.125 and grows with ΔE.
    kappa = period_energy_slope(*barbanis_saddle())
    excess = np.asarray(EXCESS)
    relative = data.flux_action.values / data.flux_harmonic.values - 1
    np.testing.assert_array_less(np.abs(relative - kappa * excess / 2), REMAINDER * abs(kappa) * excess**2 / 3 + 1e-10)
    assert abs(relative[0]) < 1e-4 and abs(relative[0]) < abs(relative[1])


def test_figure_is_drawn(files, monkeypatch):
    folder, _, _, path = files
    saved = record_saved_figures(monkeypatch)
    written = draw_transport(study=path, png=folder / "t.png", pdf=folder / "t.pdf")
    assert all(p.stat().st_size > 10_000 for p in written)
    assert_saved_tick_labels_readable(saved)


def test_energy_not_in_the_family_is_refused(files):
    folder, equilibria, upo, _ = files
    config = _config(energies={"excess": [0.5]})
    with pytest.raises(ConfigError, match="no orbit at excess energy 0.5"):
        transport_stage.run_transport(**parameters_from_config(config, "transport", "t"), upo=upo,
                                      equilibria=equilibria, output=folder / "bad.nc")


def test_tst_rate_is_total_flux_over_well_volume(files):
    """Barbanis is symmetric under y → −y, so the flux over the top saddle (Monte Carlo through its
    own line) equals the bottom saddle's action; the rate is their sum over the shell volume."""
    _, _, _, path = files
    data = open_stage_file(path, stage=TRANSPORT)
    action = data.flux_action.values
    assert np.all(np.abs(data.flux_other_saddles.values - action) < 3 * data.flux_other_saddles_stderr.values)
    assert data.rate_tst.values == pytest.approx(
        (action + data.flux_other_saddles.values) / data.well_volume.values, rel=1e-14)
    # The volume grows with the energy, less than linearly in relative terms than the flux.
    assert data.well_volume.values[1] > data.well_volume.values[0]


def test_survival_initial_slope_is_the_tst_rate(files):
    """The stage's two survival numbers against its TST rate (flux from the action, volume from the
    polar quadrature): the initial slope must equal it (to the lines' recrossing flux and the entries
    that leave within t0, both far below its error; ldpipe.core.transport.survival); the curve starts at
    1 and falls."""
    _, _, _, path = files
    data = open_stage_file(path, stage=TRANSPORT)
    rate = data.rate_tst.values
    slope, stderr = data.survival_initial_slope.values, data.survival_initial_slope_stderr.values
    assert np.all(np.abs(slope - rate) < 3 * stderr)
    p = data.survival_probability.values
    assert np.all(p[:, 0] == 1.0) and np.all(np.diff(p, axis=1) <= 0) and np.all(p[:, -1] < 1.0)
    assert np.all(data.survival_decay_rate.values > 0)


def test_gap_times_and_survival_satisfy_the_flux_volume_identity(files):
    """Both sides of Φ E[min(τ, T)] = V (1 − P(T)) (exact; derived in ldpipe.core.transport.survival), each
    from its own ensemble, agree within 4 combined standard errors; Φ is the two lines' one-way flux,
    twice one line's by the y → −y symmetry, and above the total reactive flux (recrossings)."""
    _, _, _, path = files
    data = open_stage_file(path, stage=TRANSPORT)
    gap, survival = data.left_volume_gap_times.values, data.left_volume_survival.values
    error = np.hypot(data.left_volume_gap_times_stderr.values, data.left_volume_survival_stderr.values)
    assert np.all(np.abs(gap - survival) < 4 * error)
    assert data.gap_identity_deviation.values == pytest.approx((gap - survival) / error, rel=1e-12)
    assert data.flux_dividing_lines.values == pytest.approx(2 * data.flux_dividing_line.values, rel=1e-12)
    assert np.all(data.flux_dividing_lines.values > data.flux_action.values + data.flux_other_saddles.values)
    g = data.gap_time_survival.values
    assert np.all(g[:, 0] == 1.0) and np.all(np.diff(g, axis=1) <= 0) and np.all(g[:, -1] < 1.0)
    # The volume that has left by T is part of the well.
    assert np.all(survival < data.well_volume.values)
