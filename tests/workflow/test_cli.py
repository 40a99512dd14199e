"""The `ldpipe` command: the equilibrium subcommand writes the paper's values, the LD subcommand the
independent reference's; errors exit 2."""

import subprocess

import numpy as np
import pytest

from ldpipe.io import contracts
from ldpipe.cli import main
from ldpipe.io.datafile import open_stage_file
from ldpipe.testing import reference_ld as reference
from support.workflow import LDPIPE, ROOT


def test_equilibria_builtin_writes_paper_values(tmp_path):
    out = tmp_path / "b2.nc"
    assert main(["equilibria", "--system", "barbanis_2dof", "-o", str(out)]) == 0
    dataset = open_stage_file(out, stage=contracts.EQUILIBRIA)
    saddles = dataset.position.values[dataset.saddle_equilibrium.values]
    # Paper: saddles (5.5, +-7.071), E_c = 15.125.
    np.testing.assert_allclose(np.sort(saddles[:, 1]), [-7.0710678118654755, 7.0710678118654755], atol=1e-12)
    np.testing.assert_allclose(saddles[:, 0], [5.5, 5.5], atol=1e-12)
    np.testing.assert_allclose(dataset.critical_energy.values, [15.125, 15.125], atol=1e-12)


def test_equilibria_from_config_with_override(tmp_path):
    out = tmp_path / "bc.nc"
    code = main(["equilibria", "--config", str(ROOT / "config.yaml"), "--system", "barbanis_contopoulos_3dof",
                 "--parameter", "eta=0.02", "-o", str(out)])
    assert code == 0
    dataset = open_stage_file(out, stage="equilibria")
    # z_e = eta x_e^2 / wz2 with x_e^2 = wx2 wy2 wz2 / (2 (eps^2 wz2 + eta^2 wy2)) (paper closed form).
    x2 = 0.9 * 1.6 * 0.4 / (2 * (0.08**2 * 0.4 + 0.02**2 * 1.6))
    saddles = dataset.position.values[dataset.saddle_equilibrium.values]
    np.testing.assert_allclose(saddles[:, 2], [0.02 * x2 / 0.4] * 2, rtol=1e-12)
    assert '"eta": 0.02' in dataset.attrs["parameters"]


def test_ld_fig4a_map_is_the_independent_reference_ld(tmp_path):
    # The README's Fig. 4a command, `ldpipe ld --config config.yaml --map fig4_k-7.0`, on a 5 x 5 grid
    # (max_grid_points caps it, as in a quick run). Closed forms: E = E_c + 0.125 = 15.25, and a
    # point is allowed where p_y^2 = 2 (E - V(x, -7)) - p_x^2 >= 0. Independent method: at four allowed
    # points (two of them mirror images under a swap of the axes' indices) the forward and backward
    # M_1/2 and exit times of ldpipe.testing.reference_ld (scipy DOP853 at 1e-13, stopped where the
    # trajectory leaves the map's saddle region x in [4.5, 6.5], y in [-8.5, -5.5]). The map's
    # integration is at rtol 1e-8: measured 3.4e-8 relative on the LDs and 4e-8 on the exit times,
    # bounds 2e-7.
    config = tmp_path / "config.yaml"
    config.write_text((ROOT / "config.yaml").read_text() + "\nmax_grid_points: 5\n")
    out = tmp_path / "fig4a.nc"
    assert main(["ld", "--config", str(config), "--map", "fig4_k-7.0", "--quiet", "-o", str(out)]) == 0
    data = open_stage_file(out, stage=contracts.LD_GRID)
    x, px = data.x.values, data.px.values
    np.testing.assert_allclose(x, np.linspace(4.8, 6.0, 5), rtol=0, atol=1e-15)
    np.testing.assert_allclose(px, np.linspace(-0.6, 0.6, 5), rtol=0, atol=1e-15)
    energy = 15.125 + 0.125
    py_squared = 2 * (energy - reference.barbanis_potential(x[:, None], -7.0)) - px[None, :] ** 2
    np.testing.assert_array_equal(data.allowed.values, py_squared >= 0)
    box = {0: (4.5, 6.5), 1: (-8.5, -5.5)}
    for i, j in ((1, 2), (2, 1), (2, 2), (3, 3)):
        state = np.array([x[i], -7.0, px[j], np.sqrt(py_squared[i, j])])
        for direction, name in ((1, "forward"), (-1, "backward")):
            expected = reference.reference_ld(state, 50.0, 0.5, box=box, direction=direction)
            assert expected.exited
            assert data[f"ld_{name}"].values[i, j] == pytest.approx(expected.ld, rel=2e-7), (i, j, name)
            assert data[f"exit_time_{name}"].values[i, j] == pytest.approx(expected.t_end, rel=0, abs=2e-7)


@pytest.mark.parametrize(
    "arguments, message",
    [
        (["--system", "nonesuch"], "not a built-in system"),
        (["--system", "barbanis_2dof", "--parameter", "delta=abc"], "--parameter delta: expected a number"),
        (["--system", "barbanis_2dof", "--box", "x=5"], "--box x: expected LOW:HIGH"),
        (["--system", "barbanis_2dof", "--config", "missing.yaml"], "missing.yaml: cannot read"),
    ],
)
def test_bad_arguments_exit_2_with_message(tmp_path, capsys, arguments, message):
    out = tmp_path / "never.nc"
    assert main(["equilibria", *arguments, "-o", str(out)]) == 2
    assert message in capsys.readouterr().err
    assert not out.exists()


def test_console_script_help_is_useful():
    result = subprocess.run([LDPIPE, "--help"], capture_output=True, text=True)
    assert result.returncode == 0
    assert "equilibria" in result.stdout and "Lagrangian descriptors" in result.stdout
    result = subprocess.run([LDPIPE, "equilibria", "--help"], capture_output=True, text=True)
    assert result.returncode == 0
    for option in ("--system", "--config", "--parameter", "--box", "--output"):
        assert option in result.stdout
