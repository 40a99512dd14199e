"""The Python API's keywords fuzzed (benchmarks/fuzz_inputs.py's API family): ``ldpipe.system``,
``ldpipe.section`` and ``ldpipe.ld_map`` (a 3 x 3 map of the Hénon–Heiles formula system) with one
keyword mutated end with a Dataset of finite data or a ConfigError naming the function and the
argument. Warnings are errors here, so a numpy warning on bad input fails too."""

from __future__ import annotations

import numpy as np
import pytest

import ldpipe

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
    assert np.isfinite(result.ld_forward.values).all()
