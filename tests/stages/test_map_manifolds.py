"""The manifolds stage on a discrete map: the stable and unstable manifolds of its saddle fixed
points, against closed forms.

A linear saddle map x -> x* + A (x - x*), A = [[-2, 1], [0, 1/2]], x* = (1, 2): its manifolds are
the eigen-lines x* + s v, v_u = (1, 0) for the multiplier -2 and v_s = (1, 5/2)/|(1, 5/2)| for
1/2, and the fundamental segment's k-th image (by A, or by A^-1 for the stable one) is the
segment scaled by 2^k: the point j of image k on the plus branch is x* + d 2^(k + j/M) v, exactly
(M points, first distance d). The negative multiplier sends each side of x* to the other at
every step, which the file's branches undo.

The Hénon map (x, y) -> (1 - a x^2 + y, b x): its fixed points x* = (-(1 - b) +- sqrt((1 - b)^2
+ 4 a)) / (2 a), y* = b x*, the multipliers of Df = [[-2 a x*, 1], [b, 0]] and their
eigenvectors (lambda, b) (Df's second row: b v_1 = lambda v_2). Near x* a manifold is the graph
x* + alpha v + beta v' (v' the other eigenvector) with beta = c alpha^2 + O(alpha^3): the
invariance f(W(s)) = W(m s) of W(s) = x* + s v + s^2 w at second order gives
(m^2 I - Df) w = D^2f[v, v] / 2 = (-a v_1^2, 0), and c is w's component along v'. Away from
x*, the manifold is invariant: the midpoint of two neighbouring points of a branch, mapped by f
(or f^-1 for the stable one), lies on the branch again, within the chord's sagitta of each end
(the second difference of the points, |p_(i-1) - 2 p_i + p_(i+1)| / 8, carried by Df).
"""

import copy
import re
import math

import numpy as np
import pytest
from scipy.spatial import cKDTree

import ldpipe
from ldpipe.config import validate_config
from ldpipe.config.parameters import parameters_from_config
from ldpipe.errors import ConfigError
from ldpipe.io.datafile import open_stage_file
from ldpipe.stages.equilibria import run_equilibria
from ldpipe.stages.manifolds import run_map_manifolds

FIXED = np.array([1.0, 2.0])
#: The linear saddle map's entry: x* + A (x - x*) and its inverse x* + A^-1 (x - x*).
LINEAR = {"map": {"x": "1 - 2*(x - 1) + (y - 2)", "y": "2 + (y - 2)/2"},
          "inverse": {"x": "1 + (2*(y - 2) - (x - 1))/2", "y": "2 + 2*(y - 2)"},
          "coordinates": ["x", "y"], "equilibria": {"box": {"x": [-3.0, 3.0], "y": [-2.0, 6.0]}}}
UNSTABLE = np.array([1.0, 0.0])
STABLE = np.array([1.0, 2.5]) / math.hypot(1.0, 2.5)


def linear_config(**keys) -> dict:
    return validate_config({"systems": {"saddle": copy.deepcopy(LINEAR)},
                            "manifolds": {"lines": {"system": "saddle", **keys}}})


def test_the_linear_saddles_manifolds_are_its_eigen_lines_point_for_point(tmp_path):
    """The stage's file from a configuration: each point where the closed form puts it (to the
    start's round-off, 2e-16 |x*| / d, carried along the line; measured 1e-9 of the distance
    from x*), the points past the escape radius missing values, exactly those the closed form
    puts past it."""
    iterations, points, first, radius = 30, 16, 1e-7, 40.0
    config = linear_config(iterations=iterations, segment_points=points, first_distance=first, escape_radius=radius)
    equilibria = run_equilibria(**parameters_from_config(config, "equilibria", "saddle"), output=tmp_path / "eq.nc")
    path = run_map_manifolds(**parameters_from_config(config, "manifolds", "lines"), equilibria=equilibria,
                             output=tmp_path / "lines.nc")
    found = open_stage_file(path, stage="map_manifolds")
    assert found.sizes["fixed_point"] == 1 and found.attrs["iterations"] == iterations
    np.testing.assert_allclose(found.fixed_point_position.values[0], FIXED, atol=1e-12)
    np.testing.assert_allclose(found.multiplier.values[0], [0.5, -2.0], rtol=1e-12)
    s = first * 2.0 ** (np.arange(iterations + 1)[:, None] + np.arange(points)[None, :] / points)
    np.testing.assert_allclose(found.segment_distance.values[0], s[[0, 0]], rtol=1e-15)
    for k, vector in enumerate((STABLE, UNSTABLE)):
        np.testing.assert_allclose(found.eigenvector.values[0, k], vector, atol=1e-15)
        for branch, sign in enumerate((1.0, -1.0)):
            expected = FIXED + sign * s[..., None] * vector
            curve = found.curve.values[0, k, branch]
            # escaped: past the radius at this image or an earlier one (the distance grows with the image)
            escaped = np.maximum.accumulate(np.any(np.abs(expected) > radius, axis=-1), axis=0)
            assert np.any(escaped.any(axis=1) & ~escaped.all(axis=1))  # an image the radius cuts
            np.testing.assert_array_equal(np.isnan(curve).any(axis=-1), escaped)
            error = np.linalg.norm(curve[~escaped] - expected[~escaped], axis=-1) / s[~escaped]
            assert error.max() < 1e-8, (k, branch, error.max())


def henon_closed_form(a: float, b: float, index: int):
    """The fixed point ``index`` (in increasing x), its unstable and stable multipliers, unit
    eigenvectors (largest component positive) and the manifolds' second-order coefficients c."""
    x = (-(1 - b) + (1 if index else -1) * math.sqrt((1 - b) ** 2 + 4 * a)) / (2 * a)
    jacobian = np.array([[-2 * a * x, 1.0], [b, 0.0]])
    root = math.sqrt(a * a * x * x + b)
    multipliers = sorted([-a * x + root, -a * x - root], key=abs, reverse=True)
    vectors = []
    for m in multipliers:
        v = np.array([m, b]) / math.hypot(m, b)
        vectors.append(v if v[np.argmax(np.abs(v))] > 0 else -v)
    curvature = []
    for this, other in ((0, 1), (1, 0)):
        m, v = multipliers[this], vectors[this]
        w = np.linalg.solve(m * m * np.eye(2) - jacobian, [-a * v[0] ** 2, 0.0])
        curvature.append(np.linalg.solve(np.column_stack([v, vectors[other]]), w)[1])
    return np.array([x, b * x]), multipliers, vectors, curvature, jacobian


@pytest.fixture(scope="module")
def henon():
    return ldpipe.system(name="henon", map="henon")


@pytest.fixture(scope="module")
def henon_manifolds(henon):
    return ldpipe.map_manifolds(henon, name="henon_saddles", iterations=14, segment_points=200)


def test_henons_manifolds_leave_its_fixed_points_along_the_eigenvectors_curving_as_the_closed_form(henon_manifolds):
    found = henon_manifolds
    assert found.sizes["fixed_point"] == 2  # both fixed points are saddles at Hénon's values
    for index in range(2):
        point, multipliers, vectors, curvature, _ = henon_closed_form(1.4, 0.3, index)
        np.testing.assert_allclose(found.fixed_point_position.values[index], point, rtol=1e-12)
        for k, mode in enumerate((1, 0)):  # stable, unstable
            np.testing.assert_allclose(found.multiplier.values[index, k], multipliers[mode], rtol=1e-12)
            np.testing.assert_allclose(found.eigenvector.values[index, k], vectors[mode], atol=1e-12)
            basis = np.column_stack([vectors[mode], vectors[1 - mode]])
            for branch, sign in enumerate((1.0, -1.0)):
                offsets = found.curve.values[index, k, branch].reshape(-1, 2) - point
                alpha, beta = np.linalg.solve(basis, offsets[np.isfinite(offsets[:, 0])].T)
                # alpha from 3e-5 (c alpha^2 above 1e5 times the coordinates' round-off; two images
                # past the start, whose O(s^2) error shrinks by (m' / m^2)^k) to 3e-4 (the next
                # term, O(alpha): measured 2e-4 of c at 3e-4)
                near = (np.abs(alpha) > 3e-5) & (np.abs(alpha) < 3e-4)
                assert near.sum() > 100
                # each branch on its own side, and the graph's second-order coefficient
                outward = np.arange(len(alpha)) < np.argmax(np.abs(alpha) > 1e-2)  # before the branch turns back
                assert np.all(sign * alpha[outward] > 0), (index, k, branch)
                np.testing.assert_allclose(beta[near] / alpha[near] ** 2, curvature[mode], rtol=1e-3)


def distance_to_polyline(points: np.ndarray, line: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The distance of each point to the polyline through ``line``'s points (the two segments
    beside the nearest vertex: a point nearest a vertex is nearest one of them), and that vertex."""
    nearest = np.clip(cKDTree(line).query(points)[1], 1, len(line) - 2)
    best = np.full(len(points), np.inf)
    for start in (nearest - 1, nearest):
        a, b = line[start], line[start + 1]
        t = np.clip(np.einsum("ij,ij->i", points - a, b - a) / np.einsum("ij,ij->i", b - a, b - a), 0, 1)
        best = np.minimum(best, np.linalg.norm(points - (a + t[:, None] * (b - a)), axis=1))
    return best, nearest


def test_henons_manifolds_are_invariant_a_midpoint_maps_onto_its_branch(henon, henon_manifolds):
    """Each midpoint of two neighbouring points of a branch, mapped towards the fixed point (the
    stable manifold by f, the unstable one by f^-1, so that it lands on the part computed), lies
    on the branch to within the sagittas: its own, carried by the map's Jacobian, and that of
    the branch where it lands (a bound twice their sum; measured at most 0.45 of it)."""
    found = henon_manifolds
    a, b = 1.4, 0.3
    for index in range(2):
        for k, direction in enumerate((1, -1)):  # stable, unstable
            # the whole manifold, the minus branch inward, the fixed point, the plus branch outward:
            # a negative multiplier maps each branch onto the other, and the first midpoints'
            # images land between the fixed point and the first segment
            plus, minus = (branch.reshape(-1, 2) for branch in found.curve.values[index, k])
            line = np.vstack([minus[np.isfinite(minus[:, 0])][::-1], found.fixed_point_position.values[index],
                              plus[np.isfinite(plus[:, 0])]])
            sagitta = np.linalg.norm(line[:-2] - 2 * line[1:-1] + line[2:], axis=1) / 8
            sagitta = np.concatenate([[sagitta[0]], sagitta, [sagitta[-1]]])  # by vertex
            middle = (line[:-1] + line[1:]) / 2
            images = np.array([henon.step(x, direction) for x in middle])
            jacobians = np.array([[[-2 * a * x[0], 1.0], [b, 0.0]] for x in middle])
            growth = np.linalg.norm(np.linalg.inv(jacobians) if direction < 0 else jacobians, ord=2, axis=(1, 2))
            distance, landing = distance_to_polyline(images, line)
            bound = 2 * (growth * np.maximum(sagitta[:-1], sagitta[1:]) + sagitta[landing]) + 1e-14
            assert np.all(distance <= bound), (index, k, np.max(distance / bound))


def test_the_api_equals_the_stages_file(tmp_path, henon, henon_manifolds):
    """``ldpipe.map_manifolds`` and the stage from the same entry write the same Dataset (but
    for when it was written)."""
    config = validate_config({"systems": {"henon": {"map": "henon"}},
                              "manifolds": {"henon_saddles": {"system": "henon", "iterations": 14,
                                                              "segment_points": 200}}})
    equilibria = run_equilibria(**parameters_from_config(config, "equilibria", "henon"), output=tmp_path / "eq.nc")
    path = run_map_manifolds(**parameters_from_config(config, "manifolds", "henon_saddles"), equilibria=equilibria,
                             output=tmp_path / "m.nc")
    written = open_stage_file(path, stage="map_manifolds").load()
    for name in henon_manifolds.variables:
        np.testing.assert_array_equal(written[name].values, henon_manifolds[name].values, err_msg=name)
    assert {k: v for k, v in written.attrs.items() if k != "history"} == \
        {k: v for k, v in henon_manifolds.attrs.items() if k != "history"}


def test_saddle_near_picks_one_fixed_point(henon):
    point, *_ = henon_closed_form(1.4, 0.3, 1)
    found = ldpipe.map_manifolds(henon, iterations=2, segment_points=4, saddle_near=[0.6, 0.2])
    np.testing.assert_allclose(found.fixed_point_position.values, [point], rtol=1e-12)
    assert found.equilibrium_index.values.tolist() == [1]


@pytest.mark.parametrize("entry, systems, message", [
    ({"system": "henon", "energy": {"excess": 0.1}}, {}, "config key 'manifolds.m': unknown keys ['energy']"),
    ({"system": "flow"}, {"flow": {"vector_field": {"x": "y", "y": "x"}, "coordinates": ["x", "y"]}},
     "config key 'manifolds.m.system': system 'flow' is not a discrete map"),
    ({"system": "forward"}, {"forward": {"map": {"x": "2*x", "y": "y/2"}, "coordinates": ["x", "y"]}},
     "config key 'systems.forward.inverse'"),
    ({"system": "cube"}, {"cube": {"map": {"x": "2*x", "y": "y/2", "z": "z"}, "coordinates": ["x", "y", "z"],
                                   "inverse": {"x": "x/2", "y": "2*y", "z": "z"}}},
     "config key 'manifolds.m.system': map 'cube' has 3 coordinates"),
    ({"system": "henon", "saddle_near": [0.0]}, {}, "config key 'manifolds.m.saddle_near': expected 2 numbers"),
])
def test_a_bad_map_manifold_entry_is_refused_naming_the_key(entry, systems, message):
    with pytest.raises(ConfigError, match=re.escape(message)):
        validate_config({"systems": {"henon": {"map": "henon"}, **systems}, "manifolds": {"m": entry}})


def test_the_command_line_runs_a_maps_manifold_entry(tmp_path, capsys, henon_manifolds):
    """``ldpipe manifolds --manifold NAME`` on an entry naming a map: the map's equilibria
    computed on the fly, the file the API's; ``--upo`` (a family's file) refused by name."""
    import yaml

    from ldpipe.cli import main

    config = tmp_path / "maps.yaml"
    config.write_text(yaml.safe_dump({"systems": {"henon": {"map": "henon"}}, "manifolds": {
        "henon_saddles": {"system": "henon", "iterations": 14, "segment_points": 200}}}))
    options = ["manifolds", "--config", str(config), "--manifold", "henon_saddles"]
    assert main([*options, "--upo", str(tmp_path / "upo.nc"), "-o", str(tmp_path / "x.nc")]) == 2
    assert "--upo: manifolds.henon_saddles is of the fixed points of the map 'henon'" in capsys.readouterr().err
    assert main([*options, "-o", str(tmp_path / "cli.nc")]) == 0
    written = open_stage_file(tmp_path / "cli.nc", stage="map_manifolds")
    np.testing.assert_array_equal(written.curve.values, henon_manifolds.curve.values)


def test_on_the_torus_every_point_is_wrapped_into_the_period():
    """The standard map's saddle (0, 0): multipliers 1 + K/2 +- sqrt(K + K^2/4) (the tangent map
    [[1 + K, 1], [K, 1]]), and every point of its manifolds, the starts of the minus branch
    included (those just below theta = 0), with theta in [0, 2 pi) as the map's iterates are."""
    standard = ldpipe.system(name="standard", map="standard",
                             equilibria={"box": {"theta": [-0.5, 6.5], "p": [-0.5, 0.5]}})
    found = ldpipe.map_manifolds(standard, iterations=4, segment_points=10)
    k = 0.971635406
    root = math.sqrt(k + k * k / 4)
    np.testing.assert_allclose(found.multiplier.values, [[1 + k / 2 - root, 1 + k / 2 + root]], rtol=1e-12)
    theta = found.curve.sel(coordinate="theta").values
    assert np.all((theta >= 0) & (theta < 2 * math.pi))
    segment = theta[0, :, :, 0]  # image 0: a side of theta = 0 for each manifold, wrapped below 2 pi
    assert np.all((segment < 1e-5) | (segment > 2 * math.pi - 1e-5))
    assert np.all(np.any(segment > 6.0, axis=(1, 2)))


def test_the_guides_map_manifold_block_validates():
    """docs/guide/maps-discrete.md's manifolds block, with the guide's Hénon system."""
    import yaml

    from support.workflow import documented_yaml

    systems = yaml.safe_load(documented_yaml("Hénon's values, the defaults"))["systems"]
    config = validate_config({"systems": systems, **yaml.safe_load(documented_yaml("henon_saddles:"))})
    assert parameters_from_config(config, "manifolds", "henon_saddles")["iterations"] == 20
