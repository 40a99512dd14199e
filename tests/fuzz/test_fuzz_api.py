"""The Python API's keywords fuzzed (benchmarks/fuzz_inputs.py's API family): ``ldpipe.system``,
``ldpipe.section`` and ``ldpipe.ld_map`` (a 3 x 3 map of the Hénon–Heiles formula system) with one
keyword mutated end with a Dataset of finite data or a ConfigError naming the function and the
argument. Warnings are errors here, so a numpy warning on bad input fails too."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

import ldpipe
from ldpipe.errors import ConfigError

from support.fuzz_inputs import fuzz_inputs


@pytest.fixture(scope="module")
def family():
    return fuzz_inputs.ApiFamily()


@pytest.mark.parametrize("axes, far", [({"y": (-0.3, 1e300, 3), "py": (-0.3, 0.3, 3)}, np.s_[1:, :]),
                                       ({"y": (-0.3, 0.5, 3), "py": (-0.3, 1e300, 3)}, np.s_[:, 1:])])
def test_a_section_out_to_1e300_is_a_map_with_those_points_not_allowed(family, axes, far):
    # a momentum or a coordinate of 1e300 overflowed the kinetic energy or the solved position's
    # coefficients: 'RuntimeWarning: overflow encountered in square' (in power)
    section = ldpipe.section(**axes, fixed={"px": 0.0}, solve="x", root="largest")
    result = ldpipe.ld_map(family.system, equilibria=family.equilibria, section=section, threads=1,
                           **fuzz_inputs.MAP_KWARGS)
    assert result.allowed.values[0, 0] and not result.allowed.values[far].any()
    allowed = result.allowed.values
    assert np.isfinite(result.ld_forward.values[allowed]).all() and np.isnan(result.ld_forward.values[~allowed]).all()


@pytest.mark.parametrize("name", [[1], {"a": 1}, "not a name", 5])
def test_a_bad_entry_name_is_refused_naming_the_argument(family, name):
    # a list as ldpipe.system's name raised TypeError: unhashable type: 'list'; a bad string an error
    # about 'systems' as a whole
    with pytest.raises(ConfigError, match=r"^ldpipe.system: argument 'name': expected a name"):
        ldpipe.system(name=name, **fuzz_inputs.HH)
    section = ldpipe.section(**{k: tuple(v) if isinstance(v, list) and k in ("y", "py") else v
                                for k, v in fuzz_inputs.SECTION_KWARGS.items()})
    with pytest.raises(ConfigError, match=r"^ldpipe.ld_map: argument 'name': expected a name"):
        ldpipe.ld_map(family.system, name=name, section=section, **fuzz_inputs.MAP_KWARGS)


@settings(max_examples=120, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_a_mutated_keyword_gives_a_finite_map_or_an_error_naming_it(family, data):
    function = data.draw(st.sampled_from(list(family.BASES)))
    case = (function, data.draw(st.sampled_from(family.sites[function])),
            data.draw(st.sampled_from(family.mutations)))
    family.check(case)


@pytest.mark.parametrize("threads", [-1, 1.5, "2", True])
def test_a_thread_count_that_is_no_count_is_refused(family, threads):
    section = ldpipe.section(y=(-0.3, 0.5, 3), py=(-0.3, 0.3, 3), fixed={"px": 0.0}, solve="x", root="largest")
    with pytest.raises(ConfigError, match=r"^ldpipe.ld_map: threads: expected a whole number of threads"):
        ldpipe.ld_map(family.system, equilibria=family.equilibria, section=section, threads=threads,
                      **fuzz_inputs.MAP_KWARGS)
