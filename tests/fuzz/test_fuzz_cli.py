"""``ldpipe ld`` with one argument mutated, run in-process (benchmarks/fuzz_inputs.py's CLI
family): exit 0 with a file of finite data, or an error on stderr with no traceback, and nothing
written (no file, no temporary) in the output's folder."""

from __future__ import annotations

import pytest

from ldpipe.cli.main import main

from support.fuzz_inputs import fuzz_inputs

@pytest.fixture(scope="module")
def family(tmp_path_factory):
    return fuzz_inputs.CliFamily(tmp_path_factory.mktemp("cli"))


def test_the_unmutated_command_writes_its_map(family):
    assert family.check(("--tau", 0, "2")) == "valid"


@pytest.mark.parametrize("option", ["--root", "--tau", "--axis", "--threads"])
def test_an_option_given_as_a_bare_double_dash_is_refused_by_name(family, tmp_path, capsys, option):
    # argparse read '--root=--' as [] past the option's type: AttributeError: 'list' object has no
    # attribute 'partition' (and --tau=-- a tau of [])
    argv = family.argv((option, 0, "x"), tmp_path / "out.nc")
    at = argv.index(option)
    del argv[at:at + 2]  # the option and its value, given again as '--' below
    with pytest.raises(SystemExit) as exit:
        main([*argv, f"{option}=--"])
    assert exit.value.code == 2
    err = capsys.readouterr().err
    assert f"argument {option}: expected one argument" in err and "Traceback" not in err
    assert not list(tmp_path.iterdir())
