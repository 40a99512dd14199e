"""Model systems: hand-written built-in kernels against finite differences and against the
formula-system code generator (two independent implementations of the same potential)."""

import numpy as np
import pytest

from ldpipe.errors import ConfigError
from ldpipe.systems import BUILTINS, make_system

RNG = np.random.default_rng(20261122)


def finite_difference_gradient(potential, q, step=1e-6):
    # Central differences, O(step^2) truncation: an independent check of the kernels.
    gradient = np.empty_like(q)
    for i in range(len(q)):
        e = np.zeros_like(q)
        e[i] = step
        gradient[i] = (potential(q + e) - potential(q - e)) / (2 * step)
    return gradient


@pytest.mark.parametrize("builtin", sorted(BUILTINS))
def test_builtin_derivatives_match_finite_differences(builtin):
    system = make_system(builtin, {"builtin": builtin})
    for q in RNG.uniform(-8, 8, size=(20, system.n_dof)):
        scale = 1 + np.abs(q).max() ** 2
        np.testing.assert_allclose(
            system.gradient(q), finite_difference_gradient(system.potential, q), atol=1e-6 * scale
        )
        hessian_fd = np.array(
            [finite_difference_gradient(lambda x, i=i: system.gradient(x)[i], q) for i in range(system.n_dof)]
        )
        np.testing.assert_allclose(system.hessian(q), hessian_fd, atol=1e-6 * scale)


@pytest.mark.parametrize("builtin", sorted(BUILTINS))
def test_formula_system_matches_builtin_to_rounding(builtin):
    """The built-in's own formula text, as a formula system, gives the same numbers."""
    entry = BUILTINS[builtin]
    parameters = {k: v * (1 + 0.1 * RNG.standard_normal()) for k, v in entry["defaults"].items()}
    hand = make_system("hand", {"builtin": builtin, "parameters": parameters})
    generated = make_system(
        "generated",
        {"formula": entry["formula"], "coordinates": list(entry["coordinates"]), "parameters": parameters},
    )
    n = hand.n_dof
    points = RNG.uniform(-12, 12, size=(64, n))
    for q in points:
        scale = 1 + np.abs(q).max() ** 3
        # Rounding only: a few ulps of the largest term.
        assert abs(hand.potential(q) - generated.potential(q)) <= 1e-14 * scale
        np.testing.assert_allclose(hand.gradient(q), generated.gradient(q), rtol=0, atol=1e-14 * scale)
        np.testing.assert_allclose(hand.hessian(q), generated.hessian(q), rtol=0, atol=1e-14 * scale)
    # The block (structure-of-arrays) kernels of the hot loop agree too.
    block = np.ascontiguousarray(points.T)
    out_hand, out_generated = np.empty_like(block), np.empty_like(block)
    hand.kernels.acceleration_block(block, out_hand, block.shape[1])
    generated.kernels.acceleration_block(block, out_generated, block.shape[1])
    np.testing.assert_allclose(out_hand, out_generated, rtol=1e-13, atol=1e-12)
    expected = -np.array([hand.gradient(q) for q in points]).T
    np.testing.assert_allclose(out_hand, expected, rtol=1e-13, atol=1e-12)
    v_hand, v_generated = np.empty(len(points)), np.empty(len(points))
    hand.kernels.potential_block(block, v_hand, len(points))
    generated.kernels.potential_block(block, v_generated, len(points))
    np.testing.assert_allclose(v_hand, v_generated, rtol=1e-13, atol=1e-12)


def test_block_kernel_leaves_columns_beyond_count_alone(barbanis):
    block = np.ones((2, 8))
    out = np.full((2, 8), 7.0)
    barbanis.kernels.acceleration_block(block, out, 3)
    assert np.all(out[:, 3:] == 7.0) and np.all(out[:, :3] != 7.0)


def test_formula_with_functions_and_parameters():
    # V = a (1 - cos x) + y^2/2 : gradient (a sin x, y), Hessian diag(a cos x, 1) by hand.
    system = make_system(
        "pendulum", {"formula": "a*(1 - cos(x)) + y**2/2", "coordinates": ["x", "y"], "parameters": {"a": 2.5}}
    )
    q = np.array([0.7, -1.2])
    np.testing.assert_allclose(system.gradient(q), [2.5 * np.sin(0.7), -1.2], rtol=1e-15)
    np.testing.assert_allclose(system.hessian(q), [[2.5 * np.cos(0.7), 0], [0, 1]], rtol=1e-15)


def test_parameter_override_reaches_kernels():
    system = make_system("b", {"builtin": "barbanis_2dof", "parameters": {"delta": -0.2}})
    # dV/dx = wx^2 x + delta y^2 with wx = 1 (default kept), delta = -0.2 (overridden).
    np.testing.assert_allclose(system.gradient(np.array([0.0, 2.0]))[0], -0.8, rtol=1e-15)


@pytest.mark.parametrize(
    "spec, words",
    [
        ({"formula": "x**2 + k*y", "coordinates": ["x", "y"]}, ["systems.bad.formula", "unknown names", "'k'"]),
        ({"formula": "x**2 + foo(y)", "coordinates": ["x", "y"]}, ["systems.bad.formula", "unknown functions", "foo"]),
        ({"formula": "x**2 +* y", "coordinates": ["x", "y"]}, ["systems.bad.formula", "cannot parse"]),
        ({"formula": "q**2", "coordinates": ["q"]}, ["systems.bad", "reserved"]),
        ({"builtin": "barbanis_2dof", "parameters": {"omega": 1.0}}, ["systems.bad.parameters", "omega_x"]),
        ({"builtin": "henon"}, ["systems.bad.builtin", "barbanis_2dof"]),
        ({"builtin": "barbanis_2dof", "parameters": {"delta": "x"}}, ["systems.bad.parameters.delta", "number"]),
    ],
)
def test_bad_system_specs_name_the_key(spec, words):
    with pytest.raises(ConfigError) as info:
        make_system("bad", spec)
    for word in words:
        assert word in str(info.value)


PROBE = """
import json, numpy as np
from ldpipe.systems import make_system
system = make_system("hh", {"formula": "(x**2 + y**2)/2 + x**2*y - y**3/3", "coordinates": ["x", "y"]})
value = system.potential(np.array([0.3, 0.4]))
block = np.ones((2, 4)); out = np.empty((2, 4))
system.kernels.acceleration_block(block, out, 4)
stats = system.kernels.acceleration_block.stats
print(json.dumps({"value": value, "hits": len(stats.cache_hits), "misses": len(stats.cache_misses)}))
"""


def test_compiled_kernels_are_reused_by_the_next_process(tmp_path):
    """The second process loads the kernels numba compiled in the first (on-disk cache)."""
    import json
    import os
    import subprocess
    import sys

    environment = {**os.environ, "LDPIPE_CACHE_DIR": str(tmp_path)}
    runs = [
        json.loads(subprocess.run([sys.executable, "-c", PROBE], env=environment, capture_output=True,
                                  text=True, check=True).stdout)
        for _ in range(2)
    ]
    assert runs[0]["misses"] == 1 and runs[0]["hits"] == 0
    assert runs[1]["hits"] == 1 and runs[1]["misses"] == 0
    # Henon-Heiles at (0.3, 0.4): (0.09 + 0.16)/2 + 0.09*0.4 - 0.064/3 (closed form).
    assert runs[0]["value"] == runs[1]["value"] == pytest.approx(0.125 + 0.036 - 0.064 / 3, rel=1e-15)


@pytest.mark.parametrize("builtin", sorted(BUILTINS))
def test_potentials_are_the_one_point_potential_bit_for_bit(builtin):
    """System.potentials (the block kernel, one call) gives exactly System.potential row by row: both
    kernels evaluate the same expression in the same order (identity, no tolerance)."""
    system = make_system(builtin, {"builtin": builtin})
    points = RNG.uniform(-12, 12, size=(37, system.n_dof))
    expected = np.array([system.potential(q) for q in points])
    assert np.array_equal(system.potentials(points), expected)
    assert np.array_equal(system.potentials(points[::2]), expected[::2])  # a strided view of the rows
