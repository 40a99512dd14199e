"""``python -m ldpipe.engine.codegen --dump``: the modules the engine loads, as text.

What it prints is compared with the code generator's own functions for the same arguments
(``engine_modules``, ``vector_field_modules``: the common modules, then the engine module, which
``engine_source`` gives alone), and must compile; bad arguments are one line on stderr naming the
argument, and exit status 2.
"""

import subprocess
import sys

import pytest

from ldpipe.engine import LDSettings
from ldpipe.engine.codegen import engine_modules, engine_source
from ldpipe.engine.codegen.__main__ import main
from ldpipe.engine.vector_field import vector_field_modules
from ldpipe.systems import make_system

HENON_HEILES = {"formula": "(x**2 + y**2)/2 + lam*(x**2*y - y**3/3)", "coordinates": ["x", "y"],
                "parameters": {"lam": 1.0}}
DUFFING = {"vector_field": {"x": "y", "y": "x - x**3 - delta*y + F*cos(omega*t)"}, "coordinates": ["x", "y"],
           "parameters": {"delta": 0.25, "F": 0.3, "omega": 1.2}}
CONFIG = """\
systems:
  henon_heiles:
    formula: "(x**2 + y**2)/2 + lam*(x**2*y - y**3/3)"
    coordinates: [x, y]
    parameters: {lam: 1.0}
    equilibria: {seeds_per_axis: 7}
  forced_duffing:
    vector_field: {x: "y", y: "x - x**3 - delta*y + F*cos(omega*t)"}
    coordinates: [x, y]
    parameters: {delta: 0.25, F: 0.3, omega: 1.2}
"""


@pytest.fixture
def config_file(tmp_path):
    path = tmp_path / "systems.yaml"
    path.write_text(CONFIG)
    return path


def dump(capsys, *argv):
    assert main(["--dump", *argv]) == 0
    text = capsys.readouterr().out
    compile(text, "<dump>", "exec")
    return text


def test_a_builtin_system(capsys):
    barbanis = make_system("barbanis_2dof", {"builtin": "barbanis_2dof"})
    printed = dump(capsys, "barbanis_2dof", "rk4", "--lanes", "8")
    assert printed == engine_modules(barbanis, "rk4", 8).listing()
    assert printed.endswith(engine_source(barbanis, "rk4", 8) + "\n")  # the engine module last
    flow = dump(capsys, "barbanis_2dof", "dop853", "--lanes", "16", "--entry", "flow_process")
    assert flow == engine_modules(barbanis, "dop853", 16, entry="flow_process").listing()
    assert flow.endswith(engine_source(barbanis, "dop853", 16, entry="flow_process") + "\n")


def test_a_system_of_a_config_file(capsys, config_file):
    # The default block size is compute_ld's (LDSettings.lanes).
    henon_heiles = make_system("henon_heiles", HENON_HEILES)
    lanes = LDSettings(scheme="dop853").lanes
    expected = engine_modules(henon_heiles, "dop853", lanes).listing()
    assert dump(capsys, "--config", str(config_file), "henon_heiles", "dop853") == expected


def test_a_vector_field_of_a_config_file_is_the_flow_engine(capsys, config_file):
    duffing = make_system("forced_duffing", DUFFING)
    printed = dump(capsys, "forced_duffing", "dop853", "--config", str(config_file))
    assert printed == vector_field_modules(duffing).listing()
    assert printed.endswith(vector_field_modules(duffing).engine + "\n")


@pytest.mark.parametrize(
    "argv, named",
    [
        (["no_such_system", "dop853"], "SYSTEM 'no_such_system'"),
        (["barbanis_2dof", "no_such_scheme"], "SCHEME 'no_such_scheme'"),
        (["--config", "no_such_file.yaml", "henon_heiles", "dop853"], "--config 'no_such_file.yaml'"),
        (["henon_heiles", "dop853"], "SYSTEM 'henon_heiles'"),  # declared in a config file, not given
        (["barbanis_2dof", "dop853", "--entry", "no_such_entry"], "--entry 'no_such_entry'"),
    ],
)
def test_bad_arguments_are_named(capsys, argv, named):
    assert main(["--dump", *argv]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert named in captured.err and "expected" in captured.err
    assert captured.err.count("\n") == 1


def test_a_vector_field_with_a_scheme_that_cannot_take_it(capsys, config_file):
    assert main(["--dump", "--config", str(config_file), "forced_duffing", "rk4"]) == 2
    assert "scheme 'rk4' cannot integrate system 'forced_duffing'" in capsys.readouterr().err


@pytest.mark.slow
def test_a_wrong_system_name_exits_2_with_one_line():
    result = subprocess.run(
        [sys.executable, "-m", "ldpipe.engine.codegen", "--dump", "no_such_system", "dop853"],
        capture_output=True, text=True, check=False,
    )
    assert result.returncode == 2
    assert result.stdout == ""
    assert result.stderr.count("\n") == 1 and "no_such_system" in result.stderr
    assert "Traceback" not in result.stderr
