"""The `ldpipe` command: the equilibrium subcommand writes the paper's values; errors exit 2."""

import subprocess

import numpy as np
import pytest

from ldpipe.io import contracts
from ldpipe.cli import main
from ldpipe.io.datafile import open_stage_file
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
