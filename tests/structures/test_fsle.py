"""The finite-size Lyapunov exponent against the linear saddle's closed form.

x' = lam x, y' = -lam y: a neighbour offset by d0 along x separates as d0 e^(lam t) forward (one
along y as d0 e^(-lam t)), so the first to reach df does so at tau = ln(df/d0)/lam and the FSLE is
lam exactly, at every point; backward the roles of x and y exchange. The flow map is
diag(e^(lam t), e^(-lam t)), so the direction stretched most is the x axis forward, the y axis
backward. Checks that do not divide tau test that the time is found between them, not at one.
"""

import math

import numpy as np
import pytest

import ldpipe
from ldpipe.errors import ConfigError

LAM = 0.8  # the linear saddle of tests/data/test_ftle.py
SADDLE = {"vector_field": {"x": "lam*x", "y": "-lam*y"}, "coordinates": ["x", "y"], "parameters": {"lam": LAM}}
SECTION = ldpipe.section(x=(-0.5, 0.5, 7), y=(-0.4, 0.6, 6))
SETTINGS = {"initial_separation": 0.01, "final_separation": 0.1, "integrator": {"rtol": 1e-12, "atol": 1e-12}}

pytestmark = pytest.mark.compiles  # the saddle's flow-map engine (no LD), which no other test loads


@pytest.fixture(scope="module")
def saddle():
    return ldpipe.system(name="linear_saddle", **SADDLE)


def test_linear_saddle_fsle_is_its_eigenvalue_with_its_direction(saddle):
    result = ldpipe.fsle(saddle, section=SECTION, max_time=5.0, interval=0.37, **SETTINGS)
    tau = math.log(10.0) / LAM
    for label, axis in (("forward", 0), ("backward", 1)):
        assert result[f"fsle_reached_{label}"].values.all() and result[f"fsle_defined_{label}"].values.all()
        # measured: relative error 4e-13 (the integrator's rtol 1e-12)
        np.testing.assert_allclose(result[f"fsle_{label}"].values, LAM, rtol=2e-12, err_msg=label)
        np.testing.assert_allclose(result[f"fsle_time_{label}"].values, tau, rtol=2e-12, err_msg=label)
        # a direction (modulo pi): the axis it lies along, measured exactly (1e-14)
        angle = result[f"fsle_angle_{label}"].values
        expected = 0.0 if axis == 0 else math.pi / 2
        np.testing.assert_allclose(np.sin(angle - expected), 0.0, atol=1e-9, err_msg=label)
    assert result.attrs["initial_separation"] == 0.01 and result.attrs["rtol"] == 1e-12


def test_not_reached_within_max_time_is_zero_and_flagged(saddle):
    # tau = ln(10)/0.8 = 2.88 > 2.5: no neighbour reaches df (AVISO's convention: FSLE 0)
    result = ldpipe.fsle(saddle, section=SECTION, max_time=2.5, **SETTINGS)
    for label in ("forward", "backward"):
        assert not result[f"fsle_reached_{label}"].values.any()
        assert not result[f"fsle_{label}"].values.any()
    # the grid's spacing as the initial separation by default: 1/6 and 0.2 here, the smaller taken
    default = ldpipe.fsle(saddle, section=SECTION, max_time=5.0, final_separation=1.0, interval=0.5,
                          integrator=SETTINGS["integrator"])
    assert default.attrs["initial_separation"] == pytest.approx(1 / 6)
    np.testing.assert_allclose(default.fsle_forward.values, LAM, rtol=2e-12)


def test_bad_fsle_arguments_are_named(saddle):
    with pytest.raises(ConfigError, match=r"ldpipe.fsle: argument 'final_separation': 0.005; expected more than"):
        ldpipe.fsle(saddle, section=SECTION, max_time=1.0, initial_separation=0.01, final_separation=0.005)
    with pytest.raises(ConfigError, match=r"ldpipe.fsle: argument 'max_time'.*finite number > 0"):
        ldpipe.fsle(saddle, section=SECTION, max_time=-1.0, final_separation=1.0)
    with pytest.raises(ConfigError, match=r"ldpipe.fsle: section: axes and fixed must name each of"):
        ldpipe.fsle(saddle, section=ldpipe.section(x=(0, 1, 3), z=(0, 1, 3)), max_time=1.0, final_separation=0.1)
    with pytest.raises(ConfigError, match=r"Hamiltonian"):
        ldpipe.fsle(ldpipe.system(builtin="barbanis_2dof"), section=SECTION, max_time=1.0, final_separation=0.1)
    with pytest.raises(ConfigError, match=r"^ldpipe.fsle: argument 'system': expected a system .*got str"):
        ldpipe.fsle("linear_saddle", section=SECTION, max_time=1.0, final_separation=0.1)
    with pytest.raises(ConfigError, match=r"^ldpipe.fsle: argument 'section': expected a section block .*got list"):
        ldpipe.fsle(saddle, section=[SECTION], max_time=1.0, final_separation=0.1)


def test_a_uniform_fsle_has_no_ridge(saddle):
    # the FSLE is lam at every point (closed form, above): its file is taken by ldpipe.structures
    # like a map's, and a ridge found in it would be spurious
    result = ldpipe.fsle(saddle, section=ldpipe.section(x=(-0.5, 0.5, 12), y=(-0.4, 0.6, 12)), max_time=5.0,
                         interval=0.37, **SETTINGS)
    found = ldpipe.structures(result, min_points=2)
    assert found.attrs["fields"] == "fsle_forward fsle_backward"
    assert found.sizes["curve"] == 0
