"""Velocity-data files corrupted one way at a time (``ldpipe.testing.fuzz.FILE_CASES``: units
missing or not understood, NaN, decreasing, repeated or non-numeric coordinates, wrong
dimensions, variables missing, truncated or damaged bytes): read as a ``velocity_data`` system,
each gives a valid system or a ConfigError naming the file and the variable at fault."""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from ldpipe.testing import fuzz

from support.fuzz_inputs import fuzz_inputs

#: Corruptions that leave a valid system: integer velocities are numbers; an infinite or missing
#: velocity is land (a trajectory stops at it), every node land included.
VALID = {"none", "u_integer", "u_infinite", "all_land"}
#: The cases checked here, each refused naming the file (and its variable) unless in VALID (then
#: its map is computed and checked finite).
CHECKED = ["none", "v_missing", "u_missing", "time_missing", "u_integer", "u_infinite", "all_land",
           "u_without_units", "v_without_units", "u_units_unknown", "u_units_empty", "x_units_unknown", "nan_x",
           "nan_y", "nan_time", "decreasing_x", "decreasing_y", "decreasing_time", "duplicated_time", "constant_x",
           "two_y_points", "u_transposed", "u_without_time", "v_units_differ", "u_strings", "u_units_a_number",
           "time_units_a_number", "x_units_a_number", "string_x", "time_units_unknown", "u_faster_than_light",
           "truncated", "empty_file", "garbage"]


@pytest.fixture(scope="module")
def family(tmp_path_factory):
    return fuzz_inputs.FilesFamily(tmp_path_factory.mktemp("files"))


def outcome(family, corruption: str, fraction: float = 0.5) -> str:
    """The fuzz command's check: refused naming the file and variable, or a map of finite data."""
    return family.check((corruption, fraction))


@pytest.mark.parametrize("corruption", CHECKED)
def test_a_corrupted_file_is_refused_naming_the_file_and_variable(family, corruption):
    assert outcome(family, corruption) == ("valid" if corruption in VALID else "refused")


@settings(max_examples=25, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(fraction=st.floats(0.0, 0.999))
def test_a_truncated_file_is_refused_naming_it(family, fraction):
    assert outcome(family, "truncated", fraction) == "refused"


def test_every_corruption_is_checked():
    assert sorted(CHECKED) == sorted(c for c in fuzz.FILE_CASES if c != "bytes_flipped")


@settings(max_examples=15, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(fraction=st.floats(0.0, 0.999))
def test_a_file_with_damaged_bytes_is_refused_naming_it_or_gives_a_finite_map(family, fraction):
    # where the damage falls decides: headers and coordinates are checked, velocities may read as numbers
    assert outcome(family, "bytes_flipped", fraction) in ("valid", "refused")
