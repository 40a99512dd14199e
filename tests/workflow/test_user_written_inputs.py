"""Inputs exactly as a user writes them: numbers such as 1e-10 in YAML, the
escape radius on the command line, an energy below the whole section, the SLURM extra, and a
formula with Abs."""

import subprocess
import textwrap
import tomllib

import numpy as np
import pytest

from ldpipe.cli import main
from ldpipe.config import load_config, load_schema, validate_config
from ldpipe.io.datafile import open_stage_file
from ldpipe.engine.settings import DEFAULT_ESCAPE_RADIUS
from ldpipe.errors import ConfigError
from ldpipe.stages.figures import run_figure

from support.workflow import DOCUMENTATION, LDPIPE, ROOT, run_snakemake

# A small fixed-time map on Fig. 3's section U_xpx (y = 0, p_y > 0) of the Barbanis 2 DoF system.
# There V = x^2/2, so the allowed region at total energy E is the disc x^2 + p_x^2 <= 2E (closed form).
SMALL_MAP = ["ld", "--system", "barbanis_2dof", "--axis", "x=-5.5:5.5:9", "--axis", "px=-5.5:5.5:9",
             "--fixed", "y=0", "--solve", "py", "--tau", "20", "--quiet"]

USER_CONFIG = """\
systems:
  barbanis_2dof:
    builtin: barbanis_2dof
ld_maps:
  small:
    system: barbanis_2dof
    section:
      axes:
        - {name: x, range: [-5.5, 5.5], points: 6}
        - {name: px, range: [-5.5, 5.5], points: 6}
      fixed: {y: 0}
      solve: py
    energy: {excess: 0.125}
    tau: 5
    integrator: {rtol: 1e-10, atol: 1e-10, escape_radius: 1e7}
"""


# -------------------------------------------------------------- numbers written 1e-10

def test_numbers_written_1e_minus_10_are_numbers_for_ldpipe(tmp_path):
    path = tmp_path / "user.yaml"
    path.write_text(USER_CONFIG)
    integrator = load_config(path)["ld_maps"]["small"]["integrator"]
    # PyYAML (YAML 1.1) hands these over as the strings '1e-10' and '1e7'; YAML 1.2 reads floats.
    assert integrator["rtol"] == 1e-10 and integrator["atol"] == 1e-10 and integrator["escape_radius"] == 1e7
    assert all(type(integrator[k]) is float for k in ("rtol", "atol", "escape_radius"))
    out = tmp_path / "small.nc"
    assert main(["ld", "--config", str(path), "--map", "small", "--quiet", "-o", str(out)]) == 0
    attrs = open_stage_file(out, stage="ld_grid").attrs
    assert (attrs["rtol"], attrs["atol"], attrs["escape_radius"]) == (1e-10, 1e-10, 1e7)


def test_a_string_that_is_not_a_number_is_still_refused_with_the_key():
    config = load_config(ROOT / "config.yaml")
    config["ld_maps"]["fig4_k-7.0"]["tau"] = "fifty"
    with pytest.raises(ConfigError, match=r"ld_maps\.fig4_k-7\.0\.tau': 'fifty' is not of type 'number'"):
        validate_config(config)
    # inside an anyOf (a fixed coordinate is a number or 'saddle'), '-7e0' is -7.0
    config["ld_maps"]["fig4_k-7.0"]["tau"] = 50
    config["ld_maps"]["fig4_k-7.0"]["section"]["fixed"]["y"] = "-7e0"
    assert validate_config(config)["ld_maps"]["fig4_k-7.0"]["section"]["fixed"]["y"] == -7.0


@pytest.mark.slow
def test_numbers_written_1e_minus_10_are_numbers_for_snakemake(workdir):
    """Snakemake loads the YAML itself (YAML 1.1) and the Snakefile validates it through ldpipe."""
    (workdir / "user.yaml").write_text(textwrap.dedent("""\
        ld_maps:
          fig4_k-7.0:
            integrator: {rtol: 1e-10, escape_radius: 1e7}
        """))
    result = run_snakemake(workdir, "results/ld/fig4_k-7.0.nc", "-n", "--configfile", "config.quick.yaml", "user.yaml")
    assert result.returncode == 0, result.stderr[-3000:]
    assert "ld_map" in result.stdout  # the map (of one tile) is planned


# ---------------------------------------------- the escape radius on the command line

def test_escape_radius_from_the_command_line(tmp_path, capsys):
    help_text = subprocess.run([LDPIPE, "ld", "--help"], capture_output=True, text=True).stdout
    assert "--escape-radius R" in help_text and f"(default {DEFAULT_ESCAPE_RADIUS:g})" in help_text
    default, small = tmp_path / "default.nc", tmp_path / "r20.nc"
    assert main([*SMALL_MAP, "--excess-energy", "0.125", "-o", str(default)]) == 0
    assert main([*SMALL_MAP, "--excess-energy", "0.125", "--escape-radius", "20", "-o", str(small)]) == 0
    a = open_stage_file(default, stage="ld_grid")
    b = open_stage_file(small, stage="ld_grid")
    assert a.attrs["escape_radius"] == DEFAULT_ESCAPE_RADIUS and b.attrs["escape_radius"] == 20.0
    # Invariants of one trajectory stopped at two radii: reaching |q| = 100 passes |q| = 20 first
    # (continuity), so every escape at 100 is an escape at 20, and no later; a trajectory that never
    # reaches 20 is integrated step for step alike, so its LD is the same bit for bit.
    for direction in ("forward", "backward"):
        escaped_a = a[f"escaped_{direction}"].values.astype(bool)
        escaped_b = b[f"escaped_{direction}"].values.astype(bool)
        assert escaped_a.any(), "the test needs escaping trajectories"
        assert np.all(escaped_b[escaped_a])
        allowed = a.allowed.values  # the exit times of the others are missing
        assert np.all(b[f"exit_time_{direction}"].values[allowed] <= a[f"exit_time_{direction}"].values[allowed])
        same = ~escaped_b
        np.testing.assert_array_equal(a[f"ld_{direction}"].values[same], b[f"ld_{direction}"].values[same])


# -------------------------------------------------- an energy below the whole section

def test_an_energy_below_the_whole_section_warns_and_a_figure_of_it_is_refused(tmp_path, capsys):
    out = tmp_path / "empty.nc"
    # V >= 0 on y = 0 (V = x^2/2): at E = -100 no point is allowed (closed form).
    assert main([*SMALL_MAP, "--energy", "-100", "-o", str(out)]) == 0
    err = capsys.readouterr().err
    warning = "WARNING ldpipe.core.maps.assembly: map 'cli' is empty: no point of its section is energetically allowed"
    assert f"{warning} at E = -100" in err and err.count(warning) == 1  # once, though the tile is counted too
    dataset = open_stage_file(out, stage="ld_grid")
    assert dataset.attrs["allowed_points"] == 0 and not dataset.allowed.values.any()
    assert "no point of its section is energetically allowed" in dataset.attrs["warning"]
    with pytest.raises(ConfigError, match="figure 'study': LD map 'cli' .* has no energetically allowed point"):
        run_figure(figure_name="study", kind="ld_slices", settings={}, inputs={"ld_maps": [str(out)]},
                   png=tmp_path / "study.png", pdf=tmp_path / "study.pdf")
    assert not (tmp_path / "study.png").exists()


def test_a_map_with_allowed_points_carries_no_warning(tmp_path):
    out = tmp_path / "disc.nc"
    assert main([*SMALL_MAP, "--energy", "8", "-o", str(out)]) == 0
    dataset = open_stage_file(out, stage="ld_grid")
    x, px = np.meshgrid(dataset.x.values, dataset.px.values, indexing="ij")
    # the disc x^2 + p_x^2 <= 2E = 16 (closed form); no grid point lies on its rim
    assert dataset.attrs["allowed_points"] == np.count_nonzero(x**2 + px**2 < 16) > 0
    assert "warning" not in dataset.attrs


# -------------------------------------------------------------------- the SLURM extra

def test_the_slurm_plugin_is_an_extra_of_its_own():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    extras = project["optional-dependencies"]
    assert any(d.startswith("snakemake-executor-plugin-slurm>=") for d in extras["slurm"])
    assert "ldpipe[slurm]" in extras["test"]
    assert not any(d.startswith("snakemake-executor-plugin-slurm") for d in extras["test"])
    assert any(d.startswith("pygments>=") for d in project["dependencies"])  # snakemake --report needs it
    cluster = DOCUMENTATION["docs/guide/slurm.md"]
    assert "pip install -e '.[slurm]'" in cluster and ".[test]" not in cluster


# ----------------------------------------------------------------- a formula with Abs

def test_a_formula_with_abs_is_a_configuration_error_naming_system_and_term(tmp_path, capsys):
    path = tmp_path / "vee.yaml"
    path.write_text(textwrap.dedent("""\
        systems:
          vee:
            formula: "Abs(x) + y**2/2"
            coordinates: [x, y]
            equilibria:
              box: {x: [-1.0, 1.0], y: [-1.0, 1.0]}
        """))
    assert main(["equilibria", "--config", str(path), "--system", "vee", "-o", str(tmp_path / "vee.nc")]) == 2
    error = capsys.readouterr().err
    assert "config key 'systems.vee.formula': system 'vee': d2V/dxdx" in error
    assert "DiracDelta(x)" in error and "PrintMethodNotImplementedError" not in error
    description = load_schema()["$defs"]["system"]["properties"]["formula"]["description"]
    assert "Abs" in description and "refused" in description
