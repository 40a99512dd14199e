"""The saddle-flux stage end to end on small settings, against closed forms.

Independent values: on the rotated quadratic 3 DoF saddle (support.quadratic_saddle) the plane's
flux is (2π)² ΔE² / (2 ω_1 ω_2) exactly, every sample is reactive, and the harmonic estimate is
the same formula with the centre frequencies the equilibria stage finds numerically. On
Barbanis–Contopoulos 3 DoF the centre frequencies are the square roots of the positive Hessian
eigenvalues at the closed-form saddle (numpy, not the equilibria file), and the reactive flux is at
most the one-way flux; at η = 0, where the z oscillator decouples, the reactive flux is the 2 DoF
Lyapunov orbit's action convolved with the oscillator's density of states (support.decoupled_flux).
"""

import math

import numpy as np
import pytest

from ldpipe.config import validate_config
from ldpipe.io.contracts import SADDLE_FLUX
from ldpipe.io.datafile import open_stage_file
from ldpipe.errors import ConfigError
from ldpipe.figures.saddle_flux import draw_saddle_flux
from ldpipe.stages.equilibria import run_equilibria
from ldpipe.config.parameters import parameters_from_config
from ldpipe.stages.saddle_flux import run_saddle_flux
from ldpipe.systems import make_system
from support import quadratic_saddle as quadratic
from support.decoupled_flux import decoupled_reactive_flux
from support.tick_labels import assert_saved_tick_labels_readable, record_saved_figures

BC = {"builtin": "barbanis_contopoulos_3dof",
      "parameters": {"omega_x2": 0.9, "omega_y2": 1.6, "omega_z2": 0.4, "epsilon": 0.08, "eta": 0.01}}
# η = 0, under the name and with the kernels tests/transport/test_flux_3dof.py compiles the flow engine for.
BC_ETA0 = {"builtin": "barbanis_contopoulos_3dof", "parameters": {"eta": 0.0}}


def _config(**studies):
    return validate_config({
        "systems": {"quadratic": {**quadratic.spec(), "equilibria": {"default_interval": [-3.0, 3.0]}},
                    "bc": BC, "bc_eta0": BC_ETA0},
        "saddle_flux": studies,
    })


def _run(folder, config, study, system):
    equilibria = folder / f"{system}_eq.nc"
    if not equilibria.exists():
        run_equilibria(**parameters_from_config(config, "equilibria", system), output=equilibria)
    return run_saddle_flux(**parameters_from_config(config, "saddle_flux", study), equilibria=equilibria,
                           output=folder / f"{study}.nc")


def test_quadratic_saddle_flux_is_the_closed_form(tmp_path):
    excess = [0.05, 0.4]
    config = _config(q={"system": "quadratic", "energies": {"excess": excess},
                        "monte_carlo": {"batch": 300, "max_samples": 300, "commit": 1.0, "duration": 12.0}})
    data = open_stage_file(_run(tmp_path, config, "q", "quadratic"), stage=SADDLE_FLUX)
    exact = quadratic.plane_flux(excess)
    assert data.excess_energy.values == pytest.approx(excess, rel=1e-9)
    assert data.flux_dividing_surface.values == pytest.approx(exact, rel=1e-10)
    assert np.all(data.monte_carlo_reactive.values == 300)
    assert data.flux_monte_carlo.values == pytest.approx(exact, rel=1e-10)
    assert data.flux_harmonic.values == pytest.approx(exact, rel=1e-9)
    assert data.attrs["centre_frequencies"] == pytest.approx([quadratic.OM1, quadratic.OM2], rel=1e-9)


def test_barbanis_contopoulos_flux_and_figure(tmp_path, monkeypatch):
    config = _config(bc={"system": "bc", "saddle_near": [10.29, 5.29, 2.65], "energies": {"total": [23.85, 24.0]},
                         "monte_carlo": {"batch": 300, "max_samples": 300, "duration": 20.0}})
    path = _run(tmp_path, config, "bc", "bc")
    data = open_stage_file(path, stage=SADDLE_FLUX)
    # Closed-form saddle (paper): x² = wx2 wy2 wz2 / (2 (ε² wz2 + η² wy2)), y = ε x²/wy2, z = η x²/wz2.
    x2 = 0.9 * 1.6 * 0.4 / (2 * (0.08**2 * 0.4 + 0.01**2 * 1.6))
    saddle = np.array([math.sqrt(x2), 0.08 * x2 / 1.6, 0.01 * x2 / 0.4])
    assert data.attrs["saddle_position"] == pytest.approx(saddle, rel=1e-9)
    x, y, z = saddle
    hessian = np.array([[0.9 - 2 * 0.08 * y - 2 * 0.01 * z, -2 * 0.08 * x, -2 * 0.01 * x],
                        [-2 * 0.08 * x, 1.6, 0.0], [-2 * 0.01 * x, 0.0, 0.4]])
    w1, w2 = np.sqrt(np.linalg.eigvalsh(hessian)[1:])
    critical = 0.5 * (0.9 * x2 + 1.6 * y**2 + 0.4 * z**2) - 0.08 * x2 * y - 0.01 * x2 * z
    excess = np.array([23.85, 24.0]) - critical
    assert data.flux_harmonic.values == pytest.approx((2 * math.pi * excess) ** 2 / (2 * w1 * w2), rel=1e-9)
    assert np.all(data.monte_carlo_undecided.values == 0)
    assert np.all(data.flux_monte_carlo.values <= data.flux_dividing_surface.values * (1 + 1e-14))
    saved = record_saved_figures(monkeypatch)
    written = draw_saddle_flux(study=path, png=tmp_path / "f.png", pdf=tmp_path / "f.pdf")
    assert all(p.stat().st_size > 10_000 for p in written)
    assert_saved_tick_labels_readable(saved)


def test_decoupled_barbanis_contopoulos_flux_is_the_orbit_convolution(tmp_path):
    """At η = 0 the stage's reactive flux is Φ_3 = ∫_0^ΔE (2π/ω_z) Φ_2(E − E_z) dE_z from the 2 DoF orbits'
    actions (derived in support.decoupled_flux and test_flux_3dof), within 4 of its standard errors
    (measured: 0.8). At ΔE = 80, 0.8 % of the plane's crossings are not reactive and the one-way flux is
    5.4 standard errors above Φ_3: the stage's energies, saddle, settings and classification all count.
    (Time reversal makes the flux from the products to the well the same: the plane's orientation does not.)"""
    excess = 80.0
    config = _config(bc0={"system": "bc_eta0", "saddle_near": [10.6, 5.6, 0.0], "energies": {"excess": [excess]},
                          "monte_carlo": {"batch": 4000, "max_samples": 4000, "commit": 3.0, "duration": 20.0}})
    data = open_stage_file(_run(tmp_path, config, "bc0", "bc_eta0"), stage=SADDLE_FLUX)
    x2 = 0.9 * 1.6 / (2 * 0.08**2)  # the saddle at η = 0: x² = wx2 wy2/(2ε²), y = ε x²/wy2, z = 0
    saddle = np.array([math.sqrt(x2), 0.08 * x2 / 1.6, 0.0])
    assert data.attrs["saddle_position"] == pytest.approx(saddle, rel=1e-9)
    exact, _ = decoupled_reactive_flux(make_system("bc_eta0", BC_ETA0), saddle, excess, math.sqrt(0.4))
    assert (int(data.monte_carlo_samples[0]), int(data.monte_carlo_undecided[0])) == (4000, 0)
    assert abs(float(data.flux_monte_carlo[0]) - exact) < 4 * float(data.flux_monte_carlo_stderr[0])
    assert float(data.flux_dividing_surface[0]) - exact > 3 * float(data.flux_monte_carlo_stderr[0])


def test_unknown_system_and_wrong_saddle_near_are_refused():
    with pytest.raises(ConfigError, match="saddle_flux.s.system"):
        _config(s={"system": "nope", "energies": {"total": [1.0]}})
    with pytest.raises(ConfigError, match="saddle_flux.s.saddle_near"):
        _config(s={"system": "bc", "saddle_near": [1.0, 2.0], "energies": {"total": [24.0]}})


def test_energy_below_the_saddle_is_refused(tmp_path):
    config = _config(bc={"system": "bc", "saddle_near": [10.29, 5.29, 2.65], "energies": {"total": [23.0]}})
    with pytest.raises(ConfigError, match="saddle_flux.bc.energies"):
        _run(tmp_path, config, "bc", "bc")
