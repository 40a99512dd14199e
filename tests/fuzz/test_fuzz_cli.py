"""``ldpipe ld`` with one argument mutated, run in-process (benchmarks/fuzz_inputs.py's CLI
family): exit 0 with a file of finite data, or an error on stderr with no traceback, and nothing
written (no file, no temporary) in the output's folder."""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from ldpipe.cli.main import main

from support.fuzz_inputs import fuzz_inputs

CLI_CASES = st.tuples(st.sampled_from(list(fuzz_inputs.CLI_OPTIONS)), st.integers(0, 1),
                      st.sampled_from([*fuzz_inputs.CLI_VALUES, None, "twice"]))


@pytest.fixture(scope="module")
def family(tmp_path_factory):
    return fuzz_inputs.CliFamily(tmp_path_factory.mktemp("cli"))


@settings(max_examples=80, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(case=CLI_CASES)
def test_a_mutated_argument_runs_or_is_refused_without_a_traceback_or_a_file(family, case):
    family.check(case)


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


def test_a_configuration_error_is_one_line_on_stderr(family, tmp_path, capsys):
    # the schema's refusal of --tau=-1 was printed as two lines ("invalid configuration:" and the key's)
    argv = family.argv(("--tau", 0, "-1"), tmp_path / "out.nc")
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("ldpipe ld: error: invalid configuration: config key "
                                                   "'ld_maps.cli.tau': -1.0 is less than or equal to the minimum of 0")
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("threads", ["-1", "-5"])
def test_a_negative_thread_count_is_refused_by_name(family, tmp_path, capsys, threads):
    # --threads=-1 raised numba's ValueError: The number of threads must be between 1 and N
    assert main(family.argv(("--threads", 0, threads), tmp_path / "out.nc")) == 2
    err = capsys.readouterr().err
    assert f"ldpipe ld: error: threads: expected a whole number of threads, 1 or more (0 or None: every core), " \
           f"got {threads}" in err
    assert not list(tmp_path.iterdir())
