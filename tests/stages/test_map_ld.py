"""Maps through the stages: the Hénon map's fixed points against their closed form, its LD's
sharp features against its manifolds, and a map's LD file from a configuration alone.

The Hénon map (x, y) -> (1 - a x^2 + y, b x) has fixed points x* = (-(1 - b) +- sqrt((1 - b)^2
+ 4 a)) / (2 a), y* = b x*, and its tangent map [[-2 a x, 1], [b, 0]] has the multipliers
lambda = -a x* +- sqrt(a^2 x*^2 + b) there (the roots of lambda^2 + 2 a x* lambda - b).

The manifolds come from an independent method: a fundamental segment of the saddle's eigenvector
iterated by the map (unstable) or its inverse (stable), :mod:`ldpipe.core.orbits.map_manifolds`,
no LD. Lopesino et al. (2015): the forward LD is singular (a cusp, |distance|^p times a factor
growing like lambda_u^(N p)) along the stable manifold, the backward LD along the unstable one.
A feature of the grid's LD is a pixel below both its neighbours along a row or a column; the
manifold's points in the window lie within 1.5 grid spacings of one (a feature pixel is within
h / sqrt(2) of where the curve crosses its line: 0.72 to 0.80 h measured, at every resolution),
and the same points shifted by 5 spacings across the manifold do not (a control that fails where
features are everywhere).
"""

import cmath
import copy
import math

import numpy as np
import pytest
from scipy.spatial import cKDTree

import ldpipe
from ldpipe.config import validate_config
from ldpipe.config.parameters import parameters_from_config
from ldpipe.core.orbits.map_manifolds import fixed_point_manifold
from ldpipe.io.datafile import open_stage_file, stage_parameters
from ldpipe.io.filediff import compare_files
from ldpipe.stages.equilibria import run_equilibria
from ldpipe.stages.ld import run_ld_gather, run_ld_map, run_ld_tile

#: Tolerance and control shift, in grid spacings (see the module docstring).
FEATURE_TOLERANCE = 1.5
CONTROL_SHIFT = 5.0


def henon_fixed_points(a: float, b: float) -> list[tuple[np.ndarray, np.ndarray]]:
    """(x*, y*) and the two multipliers (decreasing modulus) of each fixed point, in closed form."""
    points = []
    for sign in (1, -1):
        x = (-(1 - b) + sign * math.sqrt((1 - b) ** 2 + 4 * a)) / (2 * a)
        root = cmath.sqrt(a * a * x * x + b)  # imaginary at an elliptic point
        multipliers = sorted([-a * x + root, -a * x - root], key=abs, reverse=True)
        points.append((np.array([x, b * x]), np.array(multipliers)))
    return sorted(points, key=lambda point: tuple(point[0]))


@pytest.mark.parametrize("a, b, types", [(1.4, 0.3, ["saddle", "saddle"]), (1.0, -1.0, ["saddle", "non-hyperbolic"])])
def test_henon_fixed_points_and_multipliers_are_their_closed_form(a, b, types):
    henon = ldpipe.system(name="henon", map="henon", parameters={"a": a, "b": b})
    found = ldpipe.equilibria(henon)
    expected = henon_fixed_points(a, b)
    np.testing.assert_allclose(found.position.values, [point for point, _ in expected], rtol=1e-12, atol=1e-14)
    multipliers = found.eigenvalue_real.values + 1j * found.eigenvalue_imag.values
    np.testing.assert_allclose(multipliers, [m for _, m in expected], rtol=1e-12, atol=1e-14)
    assert found.type.values.tolist() == types
    # the eigenvector of each multiplier: Df v = lambda v
    for index, (point, _) in enumerate(expected):
        jacobian = np.array([[-2 * a * point[0], 1.0], [b, 0.0]])
        for mode in range(2):
            vector = found.eigenvector_real.values[index, mode] + 1j * found.eigenvector_imag.values[index, mode]
            np.testing.assert_allclose(jacobian @ vector, multipliers[index, mode] * vector, atol=1e-12)


def features(ld: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The points of the pixels below both neighbours along a row or a column."""
    found = np.zeros(ld.shape, dtype=bool)
    found[1:-1, :] |= (ld[1:-1, :] < ld[:-2, :]) & (ld[1:-1, :] < ld[2:, :])
    found[:, 1:-1] |= (ld[:, 1:-1] < ld[:, :-2]) & (ld[:, 1:-1] < ld[:, 2:])
    grid_x, grid_y = np.meshgrid(x, y, indexing="ij")
    return np.column_stack([grid_x[found], grid_y[found]])


def manifold_distances(ld_map, half: str, manifold: np.ndarray, centre: np.ndarray, half_width: float,
                       normal: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Distances, in grid spacings, from the manifold's points inside the window (less a border
    of two pixels) to the nearest feature of the LD half, and from the same points shifted
    across the manifold by :data:`CONTROL_SHIFT` spacings."""
    spacing = float(ld_map.x.values[1] - ld_map.x.values[0])
    points = manifold.reshape(-1, 2)
    points = points[np.all(np.isfinite(points), axis=1)]
    points = points[np.all(np.abs(points - centre) < half_width - 2 * spacing, axis=1)]
    tree = cKDTree(features(ld_map[half].values, ld_map.x.values, ld_map.y.values))
    distance = tree.query(points)[0] / spacing
    shifted = tree.query(points + CONTROL_SHIFT * spacing * normal)[0] / spacing
    return distance, shifted, spacing


@pytest.mark.parametrize("a, b, iterations, halves", [
    (1.0, -1.0, 4, ("ld_forward", "ld_backward")),  # area preserving: both manifolds, no orbit escapes in N
    (1.4, 0.3, 6, ("ld_forward",)),  # Hénon's attractor: the backward orbits escape; the stable manifold
])
def test_henon_ld_features_lie_on_the_saddles_manifolds(a, b, iterations, halves):
    henon = ldpipe.system(name="henon", map="henon", parameters={"a": a, "b": b})
    fixed = ldpipe.equilibria(henon)
    saddle = int(np.flatnonzero(fixed.type.values == "saddle")[-1])
    centre = fixed.position.values[saddle]
    multipliers = fixed.eigenvalue_real.values[saddle]
    vectors = fixed.eigenvector_real.values[saddle]
    manifolds = {
        "ld_forward": (fixed_point_manifold(henon, centre, multipliers[1], vectors[1], stable=True, iterations=40,
                                            first_distance=1e-6), vectors[1]),
        "ld_backward": (fixed_point_manifold(henon, centre, multipliers[0], vectors[0], stable=False, iterations=40,
                                             first_distance=1e-6), vectors[0]),
    }
    half_width = 0.05
    for points in (101, 201):  # the tolerance, in spacings, shrinks with the grid
        section = ldpipe.section(x=(centre[0] - half_width, centre[0] + half_width, points),
                                 y=(centre[1] - half_width, centre[1] + half_width, points))
        ld_map = ldpipe.ld_map(henon, section=section, iterations=iterations)
        for half in halves:
            manifold, tangent = manifolds[half]
            normal = np.array([-tangent[1], tangent[0]])
            distance, shifted, _ = manifold_distances(ld_map, half, manifold, centre, half_width, normal)
            assert len(distance) > 1000, (half, points)  # the manifold crosses the window
            assert distance.max() < FEATURE_TOLERANCE, (half, points, distance.max())
            assert np.mean(shifted < FEATURE_TOLERANCE) < 0.05, (half, points)


def map_config(tiles: int = 1) -> dict:
    return validate_config({
        "systems": {"henon": {"map": "henon", "equilibria": {"box": {"x": [-2.0, 2.0], "y": [-1.0, 1.0]}}}},
        "ld_maps": {"h": {"system": "henon", "iterations": 8, "p": 0.5, "tiles": tiles,
                          "section": {"axes": [{"name": "x", "range": [-1.5, 1.5], "points": 31},
                                               {"name": "y", "range": [-0.6, 0.6], "points": 17}]},
                          "integrator": {"escape_radius": 50.0}}},
    })


def test_a_map_file_from_a_configuration_alone(tmp_path):
    """The LD stage's jobs on a map entry: two tiles gathered equal the one-job map bit for bit,
    escapes flagged with finite sums (no inf or NaN in the file), N and p recorded; the
    equilibria stage writes the fixed points."""
    config = map_config(tiles=2)
    # the flow's defaults (tau, time, the integrator's) taken out: validating again changes nothing
    assert validate_config(copy.deepcopy(config)) == config
    parameters = parameters_from_config(config, "ld", "h")
    assert "tau" not in parameters and "time" not in parameters
    assert parameters["integrator"] == {"escape_radius": 50.0}
    tiles = [run_ld_tile(**parameters, output=tmp_path / f"tile-{tile}.nc", equilibria=None, tile=tile, tiles=2,
                         show_progress=False) for tile in range(2)]
    gathered = run_ld_gather(tiles=tiles, output=tmp_path / "gathered.nc")
    alone = run_ld_map(**parameters, output=tmp_path / "alone.nc", equilibria=None, tiles=1, show_progress=False)
    differences = compare_files(gathered, alone)
    # the variables bit for bit; the attributes but for the count of tiles (also in the parameters)
    assert {d.where for d in differences} == {"attribute 'tiles'", "attribute 'parameters'"}, \
        [str(d) for d in differences]
    assert {**stage_parameters(open_stage_file(alone, stage="ld_grid")), "tiles": 2} == \
        stage_parameters(open_stage_file(gathered, stage="ld_grid"))
    ld_map = open_stage_file(gathered, stage="ld_grid")
    assert ld_map.escaped_forward.values.any() and not ld_map.escaped_forward.values.all()
    for name in ("ld_forward", "ld_backward"):
        assert np.isfinite(ld_map[name].values).all()
    escaped = ld_map.escaped_forward.values
    assert (ld_map.iterations_forward.values[escaped] < 8).all() and (ld_map.iterations_forward.values[~escaped] == 8).all()
    assert ld_map.attrs["iterations"] == 8 and ld_map.attrs["p"] == 0.5 and ld_map.attrs["escape_radius"] == 50.0
    assert stage_parameters(ld_map)["iterations"] == 8
    fixed = open_stage_file(run_equilibria(**parameters_from_config(config, "equilibria", "henon"),
                                           output=tmp_path / "equilibria.nc"), stage="flow_equilibria")
    np.testing.assert_allclose(fixed.position.values, [point for point, _ in henon_fixed_points(1.4, 0.3)],
                               rtol=1e-12)


def test_a_maps_chaos_indicators_in_its_file_are_the_cores_tile_by_tile():
    """A standard-map LD map with ``chaos_indicators``: each point's indicators and FLI are those
    of ``chaos_indicators`` on the same starts (bit for bit: the same engine calls per point), two
    tiles gathered equal one, and the whole map's classifications and agreements are recorded."""
    from ldpipe.core.maps.chaos import INDICATORS, chaos_indicators

    standard = ldpipe.system(name="standard", map="standard")
    section = ldpipe.section(theta=(0.0, 6.0, 24), p=(0.0, 6.0, 20))
    keys = {"iterations": 40, "chaos_indicators": {"sigma": 1e-5, "fli_iterations": 300}}
    whole = ldpipe.ld_map(standard, section=section, **keys)
    tiled = ldpipe.ld_map(standard, section=section, tiles=2, **keys)
    for name in whole.data_vars:
        np.testing.assert_array_equal(tiled[name].values, whole[name].values, err_msg=name)
    theta, momentum = np.meshgrid(whole.theta.values, whole.p.values, indexing="ij")
    core = chaos_indicators(standard, np.column_stack([theta.ravel(), momentum.ravel()]), iterations=40,
                            sigma=1e-5, reference_iterations=300)
    for name in (*INDICATORS, "fli"):
        np.testing.assert_array_equal(whole[name].values.ravel(), core[name].values, err_msg=name)
    for name in INDICATORS:
        np.testing.assert_array_equal(whole[f"chaotic_{name}"].values.ravel(), core[f"chaotic_{name}"].values)
        assert whole.attrs[f"agreement_{name}"] == core.attrs[f"agreement_{name}"] > 0.5
    assert whole.attrs["fli_regular_bound"] == pytest.approx(2 * math.log10(300))


def test_the_guides_map_configurations_validate():
    """docs/guide/maps-discrete.md's blocks, as a user would paste them into one configuration."""
    import yaml

    from support.workflow import documented_yaml

    systems = {**yaml.safe_load(documented_yaml("Hénon's values, the defaults"))["systems"],
               **yaml.safe_load(documented_yaml('inverse: {x: "x/l"'))["systems"]}
    maps = {**yaml.safe_load(documented_yaml("henon_ld:"))["ld_maps"],
            **yaml.safe_load(documented_yaml("standard_chaos:"))["ld_maps"]}
    config = validate_config({"systems": systems, "ld_maps": maps})
    assert sorted(config["systems"]) == ["henon", "saddle", "standard"]
    assert parameters_from_config(config, "ld", "standard_chaos")["chaos_indicators"]["fli_iterations"] == 1000


def test_the_command_line_computes_a_maps_ld_from_its_options(tmp_path, capsys):
    """``ldpipe ld --system`` on a map: --iterations instead of --tau (refused, naming it), the
    file the configuration's entry gives."""
    import yaml

    from ldpipe.cli import main

    config = tmp_path / "maps.yaml"
    config.write_text(yaml.safe_dump({"systems": {"henon": {"map": "henon"}}}))
    options = ["ld", "--config", str(config), "--system", "henon", "--axis", "x=-1.5:1.5:31", "--axis", "y=-0.6:0.6:17"]
    assert main([*options, "--tau", "3", "-o", str(tmp_path / "x.nc")]) == 2
    assert "--tau: system 'henon' is a discrete map" in capsys.readouterr().err
    assert main([*options, "-o", str(tmp_path / "x.nc")]) == 2
    assert "--iterations: system 'henon' is a discrete map" in capsys.readouterr().err
    assert not (tmp_path / "x.nc").exists()
    assert main([*options, "--iterations", "8", "--escape-radius", "50", "-o", str(tmp_path / "cli.nc")]) == 0
    expected = run_ld_map(**parameters_from_config(map_config(), "ld", "h"), output=tmp_path / "h.nc",
                          equilibria=None, show_progress=False)
    differences = compare_files(tmp_path / "cli.nc", expected)
    assert {d.where for d in differences} <= {"attribute 'map'", "attribute 'parameters'", "attribute 'title'",
                                              "attribute 'history'"}, [str(d) for d in differences]
