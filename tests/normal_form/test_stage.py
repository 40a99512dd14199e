"""The normal-form stage and its figure on the rotated quadratic 3 DoF saddle (support.quadratic_saddle),
whose flux is (2π)² ΔE²/(2 ω₁ ω₂) at every order and whose NHIM is the ellipsoid
{a = 0, ω₁² b²/2 + p_b²/2 + ω₂² c²/2 + p_c²/2 = ΔE, p_a = 0} in the rotated coordinates; and the
configuration checks of a study."""

import numpy as np
import pytest

from ldpipe.config import validate_config
from ldpipe.errors import ConfigError
from ldpipe.figures.normal_form import draw_normal_form, normal_form_figure
from ldpipe.io.datafile import open_stage_file
from ldpipe.stages.equilibria import run_equilibria
from ldpipe.stages.normal_form import run_normal_form
from ldpipe.config.parameters import parameters_from_config
from support import quadratic_saddle as quadratic
from support.tick_labels import assert_readable_tick_labels


def _config(**studies):
    return validate_config({
        "systems": {"quadratic": {**quadratic.spec(), "equilibria": {"default_interval": [-3.0, 3.0]}},
                    "bc": {"builtin": "barbanis_contopoulos_3dof"}},
        "normal_form": studies,
    })


def test_quadratic_saddle_stage_and_figure(tmp_path):
    config = _config(q={"system": "quadratic", "energies": {"excess": [0.1, 1.0]}, "order": 6, "nhim_angles": 6})
    equilibria = tmp_path / "eq.nc"
    run_equilibria(**parameters_from_config(config, "equilibria", "quadratic"), output=equilibria)
    path = run_normal_form(**parameters_from_config(config, "normal_form", "q"), equilibria=equilibria,
                           output=tmp_path / "q.nc")
    data = open_stage_file(path, stage="normal_form")
    exact = quadratic.plane_flux(data.excess_energy.values)
    np.testing.assert_allclose(data.flux_by_order.values, np.repeat(exact[:, None], 3, axis=1), rtol=1e-12)
    np.testing.assert_allclose(data.flux_harmonic.values, exact, rtol=1e-12)
    assert data.flux_truncation_error.values.max() < 1e-12 * exact.max()
    states = data.nhim_state.values  # (energy, point, phase)
    modes = states[..., :3] @ quadratic.rotation().T
    momenta = states[..., 3:] @ quadratic.rotation().T
    assert np.max(np.abs(modes[..., 0])) < 1e-12 and np.max(np.abs(momenta[..., 0])) < 1e-12
    energy = (quadratic.OM1**2 * modes[..., 1] ** 2 + quadratic.OM2**2 * modes[..., 2] ** 2
              + momenta[..., 1] ** 2 + momenta[..., 2] ** 2) / 2
    np.testing.assert_allclose(energy, np.repeat(data.excess_energy.values[:, None], states.shape[1], axis=1),
                               rtol=1e-12)
    assert states.shape[1] == 6 * 6 * 4
    png = tmp_path / "q.png"
    draw_normal_form(study=path, png=png)
    assert png.stat().st_size > 0
    assert_readable_tick_labels(normal_form_figure(data), tmp_path)


def test_study_checks():
    with pytest.raises(ConfigError, match="normal_form.s.system"):
        _config(s={"system": "nope", "energies": {"total": [1.0]}})
    with pytest.raises(ConfigError, match="normal_form.s.saddle_near"):
        _config(s={"system": "bc", "saddle_near": [1.0, 2.0], "energies": {"total": [24.0]}})
    with pytest.raises(ConfigError, match="normal_form.s.saddle_flux"):
        _config(s={"system": "bc", "energies": {"total": [24.0]}, "saddle_flux": "missing"})
    with pytest.raises(ConfigError, match="order"):
        _config(s={"system": "bc", "energies": {"total": [24.0]}, "order": 7})
