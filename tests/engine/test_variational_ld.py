"""The arc-length LD's exact gradient along the variational equations, and the FLI and SALI of
the same run, against closed forms and independent methods.

Closed form: the isotropic oscillator H = (|p|^2 + |q|^2)/2 rotates each (q_i, p_i) plane at
unit rate, so |f(x(t))| = |x(t)| = |x_0| for all t: L = tau |x_0| each way and dL/dx_0 =
tau x_0 / |x_0|. Its tangent map is that rotation, orthogonal: |Phi u| = |u| = 1 (FLI = 0) and
the angle between Phi u_1 and Phi u_2 stays 90 degrees (SALI = sqrt 2).

Independent methods on Hénon–Heiles: the engine's DOP853 LD (``compute_ld``, other code, other
scheme) by central differences at step d, whose truncation error is d^2 L'''/6, so its distance
to the exact gradient falls four-fold when d halves; and scipy's DOP853 state transition matrix
(``ldpipe.core.variational.sample``) at the Runge-Kutta step times, for the FLI and SALI.
"""

import math

import numpy as np
import pytest

import ldpipe
from ldpipe.core.variational import sample
from ldpipe.engine.api import compute_ld
from ldpipe.engine.settings import LDSettings
from ldpipe.engine.variational_ld import deviation_vectors, variational_ld
from support.henon_heiles import HENON_HEILES

STARTS = np.array([[0.0, 0.1, 0.35, 0.2], [0.05, -0.2, 0.3, -0.1], [0.0, 0.3, -0.2, 0.25]])


@pytest.fixture(scope="module")
def henon_heiles():
    return ldpipe.system(name="henon_heiles", **HENON_HEILES)


def test_oscillator_ld_gradient_fli_and_sali_are_their_closed_forms():
    oscillator = ldpipe.system(name="isotropic_oscillator", formula="(x**2 + y**2)/2", coordinates=["x", "y"])
    starts = np.array([[0.3, -0.2, 0.1, 0.5], [1.0, 0.0, 0.0, 0.0], [-0.4, 0.7, 0.2, -0.1]])
    tau = 7.0
    radius = np.linalg.norm(starts, axis=1)
    for direction in (1, -1):
        found = variational_ld(oscillator, starts, tau, 0.01, direction)
        # fourth-order Runge-Kutta drifts |x| by about tau h^4 / 120: 1e-11 here
        np.testing.assert_allclose(found.ld, tau * radius, rtol=1e-9)
        np.testing.assert_allclose(found.gradient, tau * starts / radius[:, None], rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(found.fli, 0.0, atol=1e-9)
        np.testing.assert_allclose(found.sali, math.sqrt(2.0), rtol=1e-9)
        np.testing.assert_allclose(found.time, tau)
        assert not found.escaped.any()


def test_gradient_is_the_central_difference_of_the_engines_ld(henon_heiles):
    tau = 10.0
    settings = LDSettings(tau=tau, p="arclength", scheme="dop853", rtol=1e-13, atol=1e-13)
    for direction in (1, -1):
        exact = variational_ld(henon_heiles, STARTS, tau, 0.005, direction)
        np.testing.assert_allclose(exact.ld, compute_ld(henon_heiles, STARTS, direction, settings).ld, rtol=1e-9)
        centrals = []
        for step in (2e-3, 1e-3):
            central = np.empty_like(STARTS)
            for axis in range(4):
                offset = np.zeros(4)
                offset[axis] = step
                plus = compute_ld(henon_heiles, STARTS + offset, direction, settings).ld
                minus = compute_ld(henon_heiles, STARTS - offset, direction, settings).ld
                central[:, axis] = (plus - minus) / (2 * step)
            centrals.append(central)
        errors = [np.abs(central - exact.gradient).max() for central in centrals]
        scale = np.abs(exact.gradient).max()
        # the difference is the central difference's truncation, d^2 L'''/6 (6e-5 of the gradient at
        # d = 2e-3): second order, so it falls four-fold as d halves, and Richardson's extrapolation
        # (4 c(d/2) - c(d)) / 3 cancels it, leaving d^4 terms and the LDs' rounding over d
        # (2.4e-9 of the gradient)
        assert errors[0] < 2e-4 * scale
        assert 3.6 < errors[0] / errors[1] < 4.4
        extrapolated = (4 * centrals[1] - centrals[0]) / 3
        np.testing.assert_allclose(extrapolated, exact.gradient, rtol=0, atol=1e-8 * scale)


def test_fli_and_sali_are_those_of_scipys_transition_matrix(henon_heiles):
    tau, dt = 20.0, 0.01
    found = variational_ld(henon_heiles, STARTS, tau, dt, 1)
    u1, u2 = deviation_vectors(4)
    times = dt * np.arange(1, round(tau / dt) + 1)
    for row, start in enumerate(STARTS):
        _, stms = sample(henon_heiles, start, times, rtol=1e-12, atol=1e-12, stm=True)
        w1, w2 = stms @ u1, stms @ u2
        fli = np.log10(np.linalg.norm(w1, axis=1)).max()
        w1 /= np.linalg.norm(w1, axis=1)[:, None]
        w2 /= np.linalg.norm(w2, axis=1)[:, None]
        sali = np.minimum(np.linalg.norm(w1 + w2, axis=1), np.linalg.norm(w1 - w2, axis=1)).min()
        assert found.fli[row] == pytest.approx(max(fli, 0.0), rel=1e-7, abs=1e-9)
        assert found.sali[row] == pytest.approx(sali, rel=1e-6)


def test_deviation_vectors_are_orthonormal():
    for dimension in (2, 4, 6):
        u1, u2 = deviation_vectors(dimension)
        np.testing.assert_allclose([u1 @ u1, u2 @ u2, u1 @ u2], [1.0, 1.0, 0.0], atol=1e-15)


def test_bad_arguments_are_named(henon_heiles):
    for keywords, name in (({"tau": 0.0}, "tau"), ({"dt": -1.0}, "dt"), ({"direction": 2}, "direction"),
                           ({"escape_radius": math.inf}, "escape_radius")):
        arguments = {"tau": 1.0, "dt": 0.1, "direction": 1, **keywords}
        with pytest.raises(ValueError, match=f"^{name}:"):
            variational_ld(henon_heiles, STARTS, arguments.pop("tau"), arguments.pop("dt"), **arguments)
    with pytest.raises(ValueError, match="^states:"):
        variational_ld(henon_heiles, STARTS[:, :3], 1.0, 0.1)
