"""Curves extracted from maps against closed forms: where they must lie, and how close they come.

The references, none of them from ldpipe's extractor:

- The linear saddle x' = lam x, y' = -lam y: its stable manifold is x = 0, its unstable one y = 0.
  Its p-norm LD is M = |lam x|^p G + |lam y|^p S forward (G = (e^(p lam tau) - 1)/(p lam), S =
  (1 - e^(-p lam tau))/(p lam); backward G and S exchange; tests/support/closed_forms.py), so
  the forward LD has its V-shaped minimum on x = 0, the backward one on y = 0; a kink of the
  other axis is e^(-p lam tau) times as sharp (2 % at p lam tau = 4), below the threshold.
- The same closed form in rotated coordinates: a field whose kinks lie on a known oblique line.
- A Gaussian ridge exp(-(n . x - c)^2 / w^2): its ridge is the line n . x = c.
- A sheared saddle x' = lam x + s y, y' = -lam y: eigenvalues +-lam, the unstable direction (1, 0),
  the stable one (s, -2 lam) (closed form), so its manifolds are y = 0 and 2 lam x + s y = 0.
- The steady double gyre u = -pi A sin(pi x) cos(pi y), v = pi A cos(pi x) sin(pi y): the
  lines x = 0, 1, 2 and y = 0, 1 are invariant (u or v vanishes on them) and join its hyperbolic
  points (the separatrix x = 1 and the walls), each both a stable and an unstable manifold.

Distances are measured both ways (the curves' points to the lines, points sampled along the
lines to the curves) in grid cells, and the tolerances are stated fractions of a cell, a few
times what the extractor achieves (measured values in comments).
"""

import copy
import math

import numpy as np
import pytest

from ldpipe.config import validate_config
from ldpipe.config.parameters import parameters_from_config
from ldpipe.core.maps.assembly import ld_map_dataset
from ldpipe.core.structures import curve_distances, curves_of, ridge_curves, structures_dataset
from ldpipe.io.contracts import STRUCTURES
from ldpipe.io.datafile import open_stage_file, write_stage_file

LAM = 0.8  # the linear saddle of tests/data/test_ftle.py and tests/engine/test_vector_field.py (compiled once)
SYSTEMS = {
    "linear_saddle": {"vector_field": {"x": "lam*x", "y": "-lam*y"}, "coordinates": ["x", "y"],
                      "parameters": {"lam": LAM}},
    "sheared_saddle": {"vector_field": {"x": "lam*x + s*y", "y": "-lam*y"}, "coordinates": ["x", "y"],
                       "parameters": {"lam": LAM, "s": 2 * LAM}},
    "steady_gyre": {"vector_field": {"x": "-pi*A*sin(pi*x)*cos(pi*y)", "y": "pi*A*cos(pi*x)*sin(pi*y)"},
                    "coordinates": ["x", "y"], "parameters": {"A": 0.1}},
}


def ld_map(system: str, x_range, y_range, shape, tau: float, rtol: float = 1e-12, ftle: bool = False):
    # an escape radius no trajectory reaches (|x| grows to 0.53 e^(lam tau) = 1.6e3 at tau = 10):
    # an escaped trajectory's LD stops short, which would bend the kink
    spec = {"system": system, "tau": tau, "p": 0.5, "integrator": {"rtol": rtol, "atol": rtol, "escape_radius": 1e4},
            "section": {"axes": [{"name": "x", "range": list(x_range), "points": shape[0]},
                                 {"name": "y", "range": list(y_range), "points": shape[1]}]}}
    if ftle:
        spec["ftle"] = True
    config = validate_config({"systems": copy.deepcopy(SYSTEMS), "ld_maps": {"m": spec}})
    return ld_map_dataset(parameters_from_config(config, "ld", "m"), None, show_progress=False)


def line(a, b) -> np.ndarray:
    return np.array([a, b], dtype=float)


def samples(a, b, count: int = 200) -> np.ndarray:
    """Points along the segment a-b, the reference's side of the distance the other way."""
    t = np.linspace(0.0, 1.0, count)[:, None]
    return np.asarray(a, float) + t * (np.asarray(b, float) - np.asarray(a, float))


def spacing(x, y) -> tuple[float, float]:
    return float(x[1] - x[0]), float(y[1] - y[0])


# ---------------------------------------------------------------- the extractor on closed-form fields


def test_kinks_of_the_rotated_saddle_ld_lie_on_its_line_to_a_hundredth_of_a_cell():
    # the forward closed-form LD of the linear saddle, in coordinates rotated by 0.5 rad: its kink
    # is the line u = x cos + y sin = 0; grids that never put a pixel on it
    tau, p, theta = 10.0, 0.5, 0.5
    grow, shrink = (math.exp(p * LAM * tau) - 1) / (p * LAM), (1 - math.exp(-p * LAM * tau)) / (p * LAM)
    normal = np.array([math.cos(theta), math.sin(theta)])
    along = np.array([-normal[1], normal[0]])
    worst_in_length = []
    for n in (50, 100, 200):
        x, y = np.linspace(-0.5, 0.53, n), np.linspace(-0.47, 0.6, n)
        X, Y = np.meshgrid(x, y, indexing="ij")
        u, s = X * normal[0] + Y * normal[1], X * along[0] + Y * along[1]
        field = abs(LAM * u) ** p * grow + abs(LAM * s) ** p * shrink
        curves = [c.points for c in ridge_curves(field, (x, y), np.ones(field.shape, bool), kind="valley")]
        assert len(curves) == 1  # one line, in one piece; nothing on the weak kink s = 0
        h = spacing(x, y)
        inside = samples(-0.43 * along / abs(along[1]), 0.4 * along / abs(along[1]))
        d = curve_distances(curves, [line(-along, along)], scale=h, reference_samples=[inside])
        # measured at 50, 100, 200: worst 0.022, 0.017, 0.024 cells, median 0.0045
        assert d["to_reference"]["worst"] < 0.07 and d["to_reference"]["median"] < 0.015, d
        assert d["from_reference"]["worst"] < 0.07, d
        worst_in_length.append(d["to_reference"]["worst"] * h[0])
    # a fixed fraction of a shrinking cell: the error in length falls with the grid
    assert worst_in_length[0] > worst_in_length[1] > worst_in_length[2]


def test_gaussian_ridge_is_found_to_second_order():
    # ridge of exp(-(n . x - c)^2 / w^2) is n . x = c exactly; the ridge point interpolates the
    # derivative across it linearly, an error falling with the square of the cell
    theta, c, w = 0.5, 0.1, 0.1
    normal = np.array([math.cos(theta), math.sin(theta)])
    along = np.array([-normal[1], normal[0]])
    errors = []
    for n in (50, 100, 200):
        x, y = np.linspace(-0.5, 0.53, n), np.linspace(-0.47, 0.6, n)
        X, Y = np.meshgrid(x, y, indexing="ij")
        field = np.exp(-((X * normal[0] + Y * normal[1] - c) / w) ** 2)
        curves = [k.points for k in ridge_curves(field, (x, y), np.ones(field.shape, bool))]
        assert len(curves) == 1
        d = curve_distances(curves, [line(c * normal - along, c * normal + along)])
        errors.append(d["to_reference"]["worst"])
    # measured worst distance: 6.0e-5, 7.3e-6, 9.0e-7 (slope -3 in the number of points: second
    # order in cells, times the cell)
    assert errors[0] < 2e-4
    slope = np.polyfit(np.log([50, 100, 200]), np.log(errors), 1)[0]
    assert slope < -1.9, errors
    # the valley of the same field is none: a maximum is not a minimum
    assert ridge_curves(field, (x, y), np.ones(field.shape, bool), kind="valley") == []


def test_a_smooth_field_and_an_edge_make_no_curve():
    # a bowl (Hessian positive definite) has no ridge, however it is sampled; a tilted plane has
    # no curvature at all; and a mask's edge is no ridge: pixels whose differences would reach
    # an undefined point are not read
    x, y = np.linspace(-1, 1, 40), np.linspace(-1, 1, 30)
    X, Y = np.meshgrid(x, y, indexing="ij")
    assert ridge_curves(X**2 + 2 * Y**2 + 0.3 * X, (x, y), np.ones(X.shape, bool)) == []
    assert ridge_curves(0.2 * X - Y, (x, y), np.ones(X.shape, bool)) == []
    step = np.where(X > 0.1, 1.0, 0.0)  # a cliff whose top row is masked: nothing defined reads across it
    assert ridge_curves(step, (x, y), X > 0.1) == []


# ---------------------------------------------------------------- LD maps of flows


@pytest.fixture(scope="module")
def saddle_maps():
    # one grid offset from the axes by a fraction of a cell, at three resolutions
    return {n: ld_map("linear_saddle", (-0.5, 0.53), (-0.47, 0.6), (n, n), tau=10.0) for n in (25, 50, 100)}


def test_linear_saddle_manifolds_from_its_ld_map_converge(saddle_maps, tmp_path):
    worst = {"stable": [], "unstable": []}
    for n, dataset in saddle_maps.items():
        x, y = dataset.x.values, dataset.y.values
        h = spacing(x, y)
        found = structures_dataset({}, dataset)
        # the ragged file round trip: what a reader gets back
        path = write_stage_file(found, tmp_path / f"s{n}.nc")
        stored = open_stage_file(path, stage=STRUCTURES)
        assert stored.point_count.attrs["sample_dimension"] == "point"
        assert int(stored.point_count.sum()) == stored.sizes["point"]
        # the interior the stencils reach: one cell in from each edge
        x_in, y_in = (x[1], x[-2]), (y[1], y[-2])
        for manifold, reference, inside in (
                ("stable", line((0, -1), (0, 1)), samples((0, y_in[0]), (0, y_in[1]))),
                ("unstable", line((-1, 0), (1, 0)), samples((x_in[0], 0), (x_in[1], 0)))):
            curves = curves_of(stored, manifold=manifold)
            assert len(curves) == 1, (n, manifold, len(curves))
            d = curve_distances(curves, [reference], scale=h, reference_samples=[inside])
            # measured at 25, 50, 100: 0.011, 0.016, 0.010 cells (stable), 0.0032, 0.0018, 0.0011
            # (unstable), both ways (one straight curve: every point equally far)
            assert d["to_reference"]["worst"] < 0.05, (n, manifold, d)
            assert d["from_reference"]["worst"] < 0.05, (n, manifold, d)
            worst[manifold].append(d["to_reference"]["worst"] * h[0])
            np.testing.assert_array_equal(np.concatenate(curves), np.concatenate(curves_of(found, manifold=manifold)))
    for manifold, errors in worst.items():
        assert errors[0] > errors[2] and errors[1] > errors[2], (manifold, errors)


def test_linear_saddle_ftle_is_uniform_and_has_no_ridge():
    # FTLE = lam everywhere (closed form): a structure found in it would be spurious
    dataset = ld_map("linear_saddle", (-0.5, 0.53), (-0.47, 0.6), (20, 20), tau=2.5, ftle=True)
    found = structures_dataset({"fields": ["ftle_forward", "ftle_backward"]}, dataset)
    assert found.sizes["curve"] == 0 and found.sizes["point"] == 0


@pytest.mark.compiles
def test_sheared_saddle_manifolds_are_its_eigenlines():
    # s = 2 lam: the stable line is x + y = 0, the unstable y = 0 (closed form, module docstring)
    for n in (31, 61):
        dataset = ld_map("sheared_saddle", (-0.5, 0.53), (-0.47, 0.6), (n, n), tau=10.0, rtol=1e-10)
        x, y = dataset.x.values, dataset.y.values
        h = spacing(x, y)
        found = structures_dataset({"fields": ["ld_forward", "ld_backward"]}, dataset)
        for manifold, reference, inside in (
                ("stable", line((-1, 1), (1, -1)), samples((-min(y[-2], -x[1]), min(y[-2], -x[1])),
                                                            (-max(y[1], -x[-2]), max(y[1], -x[-2])))),
                ("unstable", line((-1, 0), (1, 0)), samples((x[1], 0), (x[-2], 0)))):
            curves = curves_of(found, manifold=manifold)
            d = curve_distances(curves, [reference], scale=h, reference_samples=[inside])
            # measured at 31 and 61: worst 0.029 and 0.028 cells (stable), 0.028 and 0.025 (unstable),
            # median 0.013-0.018; from the lines worst 0.041 and 0.035 (stable), 0.028, 0.025
            assert d["to_reference"]["worst"] < 0.1 and d["to_reference"]["median"] < 0.05, (n, manifold, d)
            assert d["from_reference"]["worst"] < 0.12, (n, manifold, d)


@pytest.mark.compiles
def test_steady_double_gyre_separatrix_and_walls():
    # the map reaches past the walls so that they lie inside it; the gyres' centres (elliptic
    # points, cones of the LD) make curves shorter than min_points
    lines = [line((0, -0.3), (0, 1.3)), line((1, -0.3), (1, 1.3)), line((2, -0.3), (2, 1.3)),
             line((-0.31, 0), (2.3, 0)), line((-0.31, 1), (2.3, 1))]
    worst = []
    for n in (41, 81):
        dataset = ld_map("steady_gyre", (-0.31, 2.3), (-0.29, 1.3), (2 * n, n), tau=15.0, rtol=1e-10)
        x, y = dataset.x.values, dataset.y.values
        h = spacing(x, y)
        inside = [samples((0, y[1]), (0, y[-2])), samples((1, y[1]), (1, y[-2])), samples((2, y[1]), (2, y[-2])),
                  samples((x[1], 0), (x[-2], 0)), samples((x[1], 1), (x[-2], 1))]
        found = structures_dataset({"fields": ["ld_forward", "ld_backward"]}, dataset)
        for manifold in ("stable", "unstable"):
            d = curve_distances(curves_of(found, manifold=manifold), lines, scale=h, reference_samples=inside)
            # measured at 41 and 81: to the lines worst 0.15 and 0.18 cells, median 0.020 and 0.026;
            # from the lines 95 % within 4.5 cells at 41 (pieces near the hyperbolic points missing),
            # 0.06 at 81 (worst 0.8: a line's end at a hyperbolic point)
            assert d["to_reference"]["worst"] < 0.5 and d["to_reference"]["median"] < 0.08, (n, manifold, d)
            assert d["from_reference"]["p95"] < (10 if n == 41 else 0.2), (n, manifold, d)
            worst.append(d["from_reference"]["p95"] * h[1])
    # the lines covered ever more closely as the grid refines
    assert max(worst[2:]) < min(worst[:2]) / 4, worst


def test_structures_api_names_a_bad_argument(saddle_maps):
    import ldpipe
    from ldpipe.errors import ConfigError

    dataset = saddle_maps[25]
    with pytest.raises(ConfigError, match=r"ldpipe.structures: argument 'threshold': 1.5; expected a fraction"):
        ldpipe.structures(dataset, threshold=1.5)
    with pytest.raises(ConfigError, match=r"argument 'fields': \['ftle_forward'\] are not|the map has no"):
        ldpipe.structures(dataset, fields=["ftle_forward"])
    with pytest.raises(ConfigError, match=r"argument 'ld_map': expected an LD map"):
        ldpipe.structures("map.nc")
    # the API's Dataset is the product function's, but for when it was written
    found = ldpipe.structures(dataset, min_points=5)
    assert found.attrs["min_points"] == 5 and found.attrs["ldpipe_stage"] == "structures"


def test_curves_are_drawn_over_their_map_and_alone(saddle_maps):
    # identity of the drawing: the lines on the axes are the file's curves, stable and unstable
    # in their colours; over the map, drawn with its first axis across, as the figures draw it,
    # and alone, each in the file's order of the curves' coordinates
    import matplotlib.pyplot as plt

    from ldpipe.figures import style

    dataset = saddle_maps[25]
    found = structures_dataset({}, dataset)
    figure, (over, alone) = plt.subplots(1, 2)
    try:
        dataset.ldpipe.plot(over, structures=found)
        found.ldpipe.plot(alone)
        for ax, order in ((over, [0, 1]), (alone, [0, 1])):
            drawn = {line.get_color(): np.column_stack([line.get_xdata(), line.get_ydata()]) for line in ax.lines}
            for manifold, colour in (("stable", style.STABLE_COLOR), ("unstable", style.UNSTABLE_COLOR)):
                np.testing.assert_array_equal(drawn[colour], curves_of(found, manifold=manifold)[0][:, order])
        assert over.get_xlabel() == f"${dataset.allowed.dims[0]}$"  # the map's first axis across
        assert over.collections  # the map itself
    finally:
        plt.close(figure)


def test_rounding_noise_is_no_ridge_but_a_small_ridge_on_a_large_field_is():
    # a field flat but for noise at 1e-13 of it: the relative threshold alone would make ridges of
    # the noise; a Gaussian ridge of 1e-6 of the field's magnitude (a curvature of 8e-8 of it per
    # cell squared, above the noise floor of 1e-8) is still found, on its line x = 0.01
    rng = np.random.default_rng(1)
    x, y = np.linspace(-1, 1, 101), np.linspace(-1, 1, 81)
    X, _ = np.meshgrid(x, y, indexing="ij")
    flat = 1000.0 * (1 + 1e-13 * rng.standard_normal(X.shape))
    assert ridge_curves(flat, (x, y), np.ones(X.shape, bool)) == []
    ridge = 1000.0 + 1e-3 * np.exp(-(((X - 0.01) / 0.1) ** 2))
    (curve,) = ridge_curves(ridge, (x, y), np.ones(X.shape, bool))
    assert np.abs(curve.points[:, 0] - 0.01).max() < 0.01 * (x[1] - x[0])
